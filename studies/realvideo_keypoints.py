"""The whole example video tracked with keypoints on every K-th frame: how well it holds.

The video ``examples/data/dex-human-hand-video.mp4`` (621 frames, monocular, assumed
camera) and its MediaPipe keypoints ``examples/data/dex-human-hand-video-keypoints.npy``
(every frame).  For keypoints on every 5th frame, every 10th frame and none, the track
(`handvar.track`, as ``handvar track`` makes it: RVAR predictor, seed 0, the first pose
searched in frame 0, recovery) is scored against the detector's keypoints of *every* frame.  The
frames between detections get the detected points carried there by optical flow
(`handvar.vision.carry`, design §14.5), as `handvar track` does; the detector's own keypoints of
those frames are withheld from the tracker.  Printed:

- PCK@0.2: the fraction of the 21 projected points (the fingertips at ``--tips``, as
  the fit compares them) within 0.2 hand sizes of the
  detector's keypoints (hand size: the detected wrist → middle-MCP distance in that
  frame), over the frames whose keypoints were withheld from the tracker, and over all;
- the silhouette IoU of the fit per frame (minimum, mean);
- frames flagged lost, frames re-initialised;
- ms per frame: tracking with its quality checks and re-initialisations (not the
  silhouettes, which are timed apart).

Run: ``PYTHONPATH=src .venv/bin/python studies/realvideo_keypoints.py``
(``--every 5`` for one setting; ``--frames N`` for the first N frames only; ``--seed S``
for the optimiser's seed; ``--carry both`` to carry each detection backwards too,
``--carry none`` to leave the frames between detections without keypoints; ``--probe
555,565`` to print how far the tracked fit's MCPs and fingertips lie from the detector's
in those frames, and to refit them from the track with the keypoint weight lowered and
without keypoints: how far silhouette and keypoints can be matched together, `refit`;
``--breakdown`` to split the misfit of every frame under IoU 0.8 into the heel band, the
fingertips and the rest, `misfit`; ``--tips end`` to compare the detected fingertips
with the ends of the model's fingers instead of the centres of their pads, design
design §14.6).  PCK is that of G(x) either way.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import handvar
from handvar.data import example_path
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.predictors import NoMotion
from handvar.tracking.costs import CostSettings
from handvar.tracking.recovery import RECOVERY_DEFAULTS, RecoverySettings, joint_distances, pck
from handvar.tracking.smd import SMDSettings
from handvar.tracking.tracker import Tracker, TrackerSettings
from handvar.vision.keypoints import read_keypoints

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")


def run(
    every: int,
    frames: int | None,
    scale: float,
    hand_length: float,
    seed: int = 0,
    probe: tuple[int, ...] = (),
    settings: RecoverySettings = RECOVERY_DEFAULTS,
    carry: str = "forward",
    tips: str = "pad",
    breakdown: bool = False,
) -> dict:
    """Track with keypoints on every `every`-th frame (0: none) and score the track.

    With `carry` "forward" or "both" the keypoints are carried by optical flow over the
    frames between (`VideoSource.carried_keypoints`, design §14.5).  For each frame in
    `probe`, the tracked fit is also refitted (`refit`); with `breakdown`, every frame's
    misfit is split by `misfit`.
    """
    detected = read_keypoints(KEYPOINTS)
    tracked = {}  # the silhouettes fitted in the probed frames (cut while tracking)
    fitted = {}  # with `breakdown`: every frame's fitted pose and silhouette of camera 0

    def keep(i, pose, quality, m):
        if i in probe:
            tracked[i] = m
        if breakdown and m[0].any() and np.all(np.isfinite(pose)):
            fitted[i] = (pose, m[0])

    result = handvar.track(
        VIDEO, keypoints=KEYPOINTS if every else None, keypoint_every=max(every, 1),
        carry=carry if every else None, keypoint_tips=tips, scale=scale,
        hand_length=hand_length, seed=seed, frames=frames, recovery=settings, on_frame=keep,
    )  # fmt: skip
    n = result.n_frames
    sil_ms = 1e3 * result.stage_seconds["silhouettes"] / n
    carry_ms = 1e3 * result.stage_seconds["keypoints"] / n if every and carry != "none" else 0.0
    track_ms = 1e3 * result.stage_seconds["tracking"] / n
    hand, rig = result.hand, result.sequence.rig  # the tracked model, the tracked frames' rig
    truth = result.source.scaled_keypoints([detected])[0]
    used = None if result.keypoints is None else result.keypoints[0]
    # frames whose detections the tracker was given
    with_detection = np.zeros(n, dtype=bool) if result.detections is None else result.detections
    carried_error = carried_kept = math.nan
    if every and carry != "none":  # the carried points against the withheld detections
        t = np.flatnonzero(~with_detection & truth.present[:n].any(axis=1))
        size = np.linalg.norm(truth.xy[t, MIDDLE_MCP] - truth.xy[t, WRIST], axis=1)
        d = np.linalg.norm(used.xy[t] - truth.xy[t], axis=2) / size[:, None]
        both = used.present[t] & truth.present[t]
        carried_error = float(np.mean(d[both]))
        carried_kept = float(both.sum() / truth.present[t].sum())
    # frames between detections that the carrying reached with no point left
    bare = np.flatnonzero(~with_detection & ~used.present[:n].any(axis=1)) if every else []
    parts = {i: misfit(pose, m, hand, rig) for i, (pose, m) in fitted.items()}
    q = result.quality
    scores = np.array([pck(result.poses[t], hand, rig, [truth.frame(t)], tips=tips)
                       for t in range(n)])  # fmt: skip
    withheld = ~with_detection
    points = {  # the tracked fit's distance to each detected point, hand sizes
        t: joint_distances(result.poses[t], hand, rig, [truth.frame(t)], tips=tips)[0]
        for t in probe
        if t < n
    }
    probes = {
        t: refit(result.poses[t], tracked[t], hand, rig, truth.frame(t), tips=tips)
        for t in probe
        if t in tracked
    }
    return {
        "parts": parts,
        "points": points,
        "probes": probes,
        "every": every,
        "frames": n,
        "pck_withheld": mean(scores[withheld]),
        "pck_all": float(np.nanmean(scores)),
        "frames_pck_below_0.5": int(np.sum(scores < 0.5)),
        "iou_min": float(q.iou[~q.empty].min()),
        "iou_min_frame": int(np.flatnonzero(~q.empty)[q.iou[~q.empty].argmin()]),
        "iou_mean": float(q.iou[~q.empty].mean()),
        "iou_mean_keypoints": mean(q.iou[~q.empty & q.keypoints]),
        "iou_mean_withheld": mean(q.iou[~q.empty & ~q.keypoints]),
        "frames_iou_below_0.8": int(np.sum(q.iou[~q.empty] < 0.8)),
        "iou_below_0.8_frames": np.flatnonzero(q.iou < 0.8).tolist(),
        "iou": q.iou,
        "lost": int(q.lost.sum()),
        "lost_frames": np.flatnonzero(q.lost).tolist(),
        "reinit": int(q.reinit.sum()),
        "reinit_frames": np.flatnonzero(q.reinit).tolist(),
        "empty": int(q.empty.sum()),
        "iterations": float(result.result.iterations.mean()),
        "track_ms": track_ms,
        "silhouette_ms": sil_ms,
        "carry_ms": carry_ms,
        "carried_error": carried_error,
        "carried_kept": carried_kept,
        "without_keypoints": [int(t) for t in bare],
        "carried": int(np.sum(q.keypoints & ~with_detection)),
    }


def mean(values) -> float:
    """Mean of the finite values; NaN if there are none."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(values.mean()) if values.size else float("nan")


def misfit(pose, mask, hand, rig, band: float = 0.2) -> dict:
    """Where the fitted model and the (cut) silhouette of camera 0 disagree.

    Pixels are split into the *heel band* (closer to the model's wrist than `band` hand
    sizes along its wrist → middle-MCP line, beyond which the silhouette is cut), the
    *tips* (outside the band, nearest to a projected fingertip of G(x) among its 21
    points) and the *rest*.  Returns the IoU, the observed-only and model-only pixels of
    each part, and the IoU with the heel band or the tips left out of both masks.
    """
    from handvar.render import silhouettes

    model = silhouettes(hand, pose, rig)[0]
    G = rig[0].project(hand.joints(pose))
    size = float(np.linalg.norm(G[9] - G[0]))
    ys, xs = np.nonzero(mask | model)
    p = np.column_stack([xs, ys]).astype(float)
    along = (p - G[0]) @ (G[9] - G[0]) / size**2
    nearest = np.argmin(((p[:, None, :] - G[None]) ** 2).sum(axis=2), axis=1)
    heel = along < band
    tips = ~heel & np.isin(nearest, [4, 8, 12, 16, 20])
    obs, mod = mask[ys, xs], model[ys, xs]
    out = {"iou": float((obs & mod).sum() / (obs | mod).sum())}
    for name, part in (("heel", heel), ("tips", tips), ("rest", ~heel & ~tips)):
        out[f"observed_{name}"] = int((obs & ~mod & part).sum())
        out[f"model_{name}"] = int((mod & ~obs & part).sum())
        out[f"iou_without_{name}"] = float((obs & mod & ~part).sum() / ((obs | mod) & ~part).sum())
    out["observed"] = int(obs.sum())
    return out


def refit(
    pose,
    masks,
    hand,
    rig,
    keypoints,
    iterations: int = 200,
    weights=(100.0, 30.0, 10.0, None),
    tips: str = "end",
) -> list[tuple]:
    """How far the silhouette and the keypoints of one frame can be matched together.

    From the tracked `pose`, the frame's silhouettes are fitted again (`iterations`
    iterations, no motion, seed 0) with the detector's keypoints at the keypoint weight
    w_k = 100 (the tracker's), 30 and 10, and without them.  Returns per fit (label,
    silhouette IoU, mean distance of the projected joints to the keypoints in the
    detector's hand sizes, PCK@0.2).
    """
    out = []
    for weight in weights:
        label = "none" if weight is None else f"w_k {weight:g}"
        settings = TrackerSettings(
            cost=CostSettings(
                weight_keypoints=100.0 if weight is None else weight, keypoint_tips=tips
            ),
            smd=SMDSettings(max_iterations=iterations),
        )
        tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0), settings)
        tracker.reset(pose)
        r = tracker.step(masks, keypoints=None if weight is None else [keypoints])
        d = joint_distances(r.pose, hand, rig, [keypoints])
        out.append((label, r.mean_iou, float(np.nanmean(d)), pck(r.pose, hand, rig, [keypoints])))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--every", type=int, action="append",
                        help="keypoints on every K-th frame, 0 for none [5, 10, 0]")  # fmt: skip
    parser.add_argument("--frames", type=int, default=None, help="only the first N frames")
    parser.add_argument("--scale", type=float, default=0.5, help="resize factor of the frames")
    parser.add_argument("--hand-length", type=float, default=185.0, help="model hand, mm")
    parser.add_argument("--seed", type=int, default=0, help="seed of the optimiser")
    parser.add_argument(
        "--probe", default="", help="frames (comma-separated) to refit without the keypoints"
    )
    parser.add_argument("--refine-iterations", type=int,
                        default=RECOVERY_DEFAULTS.refine_iterations,
                        help="iterations of the refinement of a poor fit (0: none)")  # fmt: skip
    parser.add_argument("--carry", choices=("forward", "both", "none"), default="forward",
                        help="carry the keypoints between detections (design §14.5)")  # fmt: skip
    parser.add_argument("--tips", choices=("end", "pad"), default="pad",
                        help="model point of a detected fingertip (design §14.6)")  # fmt: skip
    parser.add_argument("--iou-at", default="", help="frames (comma-separated) to print the IoU of")
    parser.add_argument("--breakdown", action="store_true",
                        help="split each frame's misfit: heel band, fingertips, rest")  # fmt: skip
    args = parser.parse_args()
    settings = RecoverySettings(refine_iterations=args.refine_iterations)
    print(
        f"example video, scale {args.scale:g}, hand {args.hand_length:g} mm, RVAR, "
        f"seed {args.seed}, fingertips at the {args.tips}; PCK@0.2 of those points against the "
        f"detector on every frame; {settings}; keypoints "
        f"carried between detections: {args.carry}"
    )
    for every in args.every or [5, 10, 0]:
        probe = tuple(int(t) for t in args.probe.split(",") if t)
        r = run(
            every, args.frames, args.scale, args.hand_length, args.seed, probe, settings,
            args.carry, args.tips, args.breakdown,
        )  # fmt: skip
        what = f"keypoints every {every:>2}" if every else "no keypoints      "
        print(
            f"  {what}: {r['frames']} frames | PCK@0.2 withheld {r['pck_withheld']:.3f}, "
            f"all {r['pck_all']:.3f} ({r['frames_pck_below_0.5']} frames < 0.5) | IoU min "
            f"{r['iou_min']:.3f} (frame {r['iou_min_frame']}), mean {r['iou_mean']:.3f} "
            f"({r['frames_iou_below_0.8']} frames < 0.8) | lost {r['lost']}, re-initialised "
            f"{r['reinit']} {r['reinit_frames'][:8]}, empty {r['empty']} | "
            f"{r['iterations']:.1f} iterations, tracking {r['track_ms']:.0f} ms/frame, "
            f"silhouettes {r['silhouette_ms']:.0f} ms/frame"
            + (
                f" | carried on {r['carried']} frames ({100 * r['carried_kept']:.0f} % of the "
                f"points, {r['carried_error']:.3f} hand sizes from the detector's), "
                f"{r['carry_ms']:.1f} ms/frame"
                if r["carried"]
                else ""
            )
        )
        print(f"    IoU < 0.8 at {r['iou_below_0.8_frames'][:20]}; lost at {r['lost_frames'][:20]}")
        if r["without_keypoints"] and r["carried"]:
            print(f"    the carrying left no point at {r['without_keypoints'][:20]}")
        if every > 1:
            print(
                f"    IoU mean on the frames with keypoints {r['iou_mean_keypoints']:.3f}, "
                f"without {r['iou_mean_withheld']:.3f}"
            )
        at = [int(t) for t in args.iou_at.split(",") if t]
        if at:
            print(
                "    IoU at " + ", ".join(f"{t} {r['iou'][t]:.3f}" for t in at if t < r["frames"])
            )
        parts = r["parts"]
        if parts:
            heel = np.median([p["observed_heel"] / p["observed"] for p in parts.values()])
            print(
                f"    misfit, all frames: observed-only in the heel band {heel:.3f} of the "
                f"observed (median); IoU mean without the heel band "
                f"{np.mean([p['iou_without_heel'] for p in parts.values()]):.3f}, without the "
                f"tips {np.mean([p['iou_without_tips'] for p in parts.values()]):.3f}"
            )
        for t in r["iou_below_0.8_frames"]:
            if t in parts:
                p = parts[t]
                print(
                    f"    frame {t}: IoU {p['iou']:.3f}; observed-only / model-only px: heel "
                    f"{p['observed_heel']} / {p['model_heel']}, tips {p['observed_tips']} / "
                    f"{p['model_tips']}, rest {p['observed_rest']} / {p['model_rest']}; IoU "
                    f"without the heel band {p['iou_without_heel']:.3f}, without the tips "
                    f"{p['iou_without_tips']:.3f}"
                )
        for t, d in r["points"].items():
            print(
                f"    frame {t} as tracked: MCPs {np.round(d[[5, 9, 13, 17]], 2).tolist()}, "
                f"fingertips {np.round(d[[4, 8, 12, 16, 20]], 2).tolist()} hand sizes from the "
                f"detector's (mean of all 21: {np.nanmean(d):.3f})"
            )
        for t, fits in r["probes"].items():
            text = "; ".join(
                f"{a}: IoU {b:.3f}, joints {c:.3f}, PCK {d:.2f}" for a, b, c, d in fits
            )
            print(f"    frame {t} refitted from the track, 200 iterations: {text}")


if __name__ == "__main__":
    main()
