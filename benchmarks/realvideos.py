"""The three real videos tracked by `handvar.track` with their MediaPipe keypoints: lost
frames, the keypoint check, PCK against the detector on withheld frames, and the all-in
time per frame.

Videos (`handvar.data.example_path`): the example video (``video``, 1280×720), the
fingerspelling clip (``fingerspelling``, 620×1080) and the counting clip
(``counting``, 640×480, no hand in its first ~110 and last ~90 frames), each with the
MediaPipe keypoints of every frame.  Each is tracked as `handvar track` does, frame by
frame (frames resized so that the longer side is 640 px; monocular, assumed camera; a
right hand of 185 mm; RVAR predictor, seed 0; the first pose fitted to the first
keypoints), with the detections of every frame (K = 1) or of every 5th, carried by
optical flow between (K = 5; both ways, a recording's default).  Printed per video and K:

- frames, frames with a detection given, no-hand frames, lost, re-initialised;
- the keypoint check (`TrackQuality.check`: on every frame with a detection given the
  joints within 0.2 hand sizes of at least 98 % of the keypoints kept), the frames that
  fail it and the keypoints rejected; with K > 1, the same check's worst frame on the
  frames with carried keypoints;
- PCK@0.2 of the track's points (the fingertips and the thumb's base where a detector
  marks them, as the track reports them) against the detector's keypoints (its own hand
  size; a frame with a detection and no pose, or no point, counts as wrong) over the
  frames whose
  detections were withheld (K > 1), beside it that of the keypoints the fit was given
  there (the detections carried by optical flow) and that of the given detections
  interpolated linearly between the two around (which needs the next one: a user's
  alternative without handvar), and over all frames with a detection;
- ms per frame all-in (reading and resizing the frame, carrying, silhouettes, fit,
  rules, quality: the time between two frames' ends; the frames are timed by an
  ``on_frame`` callback, which has every frame's silhouettes computed, as ``handvar
  track --show`` does, so the times bound those of ``handvar track`` from above): median,
  and the worst one-second window (mean over any fps consecutive frames); the first
  frame's (opening the video, the first fit) and the slowest other frame's.  The first
  call in a process also pays its start-up (imports, the compiled kernels loaded from
  numba's cache, the skin model): it is timed once, on two frames of the example video,
  and printed apart, so that the windows measure tracking, not the process.

With ``--world`` the fingerspelling and counting clips are tracked with MediaPipe's world
landmarks (``-mediapipe.npz``) as the fit's weak 3D cue; with ``--silhouette-term S``
the keypoint fit has its silhouette term at σ S (docs/keypoint-fit.md); the last
column is the tracked hand's length (the shape fit keeps the given 185 mm with one
camera).  The column
before it compares the fit's 3D with the detector's own on those two clips (its world
landmarks, turned from the ray through the fitted palm into the camera's axes,
`handvar.vision.keypoints.world_in_camera`): the mean distance of the joints relative to the
wrist, mm, and the median angle of the rotation between the two hands (least squares
over the 21 points), degrees; the detector's 3D is an estimate too, not the truth.

Last, the counting clip's frames without a hand: their count and ms each, all-in, with
the keypoints carried forward (carried both ways, frames wait for the next detection
and are handed out together, so a single frame's time is not its own).

Run: ``PYTHONPATH=src python benchmarks/realvideos.py [--every 1,5] [--videos NAME,...]
[--world]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from handvar.data import example_path
from handvar.evaluation.metrics import pck_2d, rotation_angle, similarity, thinned
from handvar.pipeline import track
from handvar.tracking.recovery import RECOVERY_DEFAULTS, pck
from handvar.vision.keypoints import Keypoints2D, read_keypoints
from handvar.vision.sources import open_source

VIDEOS = ("video", "fingerspelling", "counting")


def timed_track(path, keypoints, **options):
    """`handvar.track` of the video at `path` at 640 px on its long side, and the
    seconds from the start to each frame's end, one per frame handed out."""
    w, h = open_source(path).image_size
    stamps: list[float] = []
    t0 = time.perf_counter()
    tr = track(path, keypoints=keypoints, scale=640.0 / max(w, h),
               on_frame=lambda *_: stamps.append(time.perf_counter()), **options)  # fmt: skip
    return tr, np.diff([t0, *stamps])


def run(name: str, every: int, seed: int = 0, world: bool = False, silhouette: float = 0.0) -> dict:
    """Track video `name` with the detections of every `every`-th frame; score it.
    `world`: with MediaPipe's world landmarks (``<name>-mediapipe``) as the fit's cue;
    `silhouette`: σ of the keypoint fit's silhouette term (0: off)."""
    path, kp_path = example_path(name), example_path(f"{name}-keypoints")
    given_kp = read_keypoints(kp_path)
    if world:
        with np.load(example_path(f"{name}-mediapipe")) as z:
            given_kp = Keypoints2D(given_kp.xy, given_kp.confidence, given_kp.name,
                                   world=z["world_mm"])  # fmt: skip
    extra = {"recovery": RECOVERY_DEFAULTS.with_silhouette_term(silhouette)} if silhouette else {}
    tr, seconds = timed_track(path, given_kp, keypoint_every=every, seed=seed, **extra)
    q, hand = tr.quality, tr.hand
    detected = read_keypoints(kp_path)
    n = tr.n_frames
    seen = detected.present[:n].any(axis=1)
    scores = np.array(
        [pck(tr.poses[t], hand, tr.rig, [detected.frame(t)], tips=hand.tips) if seen[t]
         else np.nan
         for t in range(n)]
    )  # fmt: skip
    scores[seen & ~np.isfinite(tr.poses).all(axis=1)] = 0.0  # no pose where a hand is seen
    given = seen & (np.arange(n) % every == 0)
    withheld = seen & ~given
    window = max(1, round(tr.fps or 30))
    rolling = np.convolve(seconds, np.ones(window) / window, mode="valid")
    ok, worst, rejected = q.check(frames=given)
    return {
        "frames": n, "given": int(given.sum()), "no_hand": int(q.no_hand.sum()),
        "lost": int(q.lost.sum()), "reinit": int(q.reinit.sum()), "check": ok,
        "worst": worst, "failing": q.failing(frames=given), "rejected": rejected,
        "carried": q.check(frames=q.keypoints & ~given)[:2],
        "pck_withheld": float(np.nanmean(scores[withheld])) if withheld.any() else np.nan,
        "pck_interpolated": _interpolated_pck(detected, n, every, withheld),
        "pck_carried": _carried_pck(detected, tr, withheld, open_source(path).image_size),
        "pck_all": float(np.nanmean(scores[seen])),
        "median_ms": 1e3 * float(np.median(seconds)), "worst_ms": 1e3 * float(rolling.max()),
        "first_ms": 1e3 * float(seconds[0]), "slowest": (1e3 * float(seconds[1:].max()),
                                                          1 + int(seconds[1:].argmax())),
        "size": tr.sequence.masks.shape[:1:-1], "length": tr.shape.length,
        "world": _against_world(name, tr, hand),
    }  # fmt: skip


def _interpolated_pck(detected, n: int, every: int, withheld) -> float:
    """PCK@0.2 on the `withheld` frames of the detections of every `every`-th frame
    interpolated linearly between the two around (`thinned`; it needs the next one),
    against the withheld detections with their own hand size: the user's alternative
    without handvar.  NaN without withheld frames."""
    scored = withheld & detected.present[:n].all(axis=1)
    if not scored.any():
        return np.nan
    between = thinned(detected.xy[:n], every, interpolate=True)
    return pck_2d(detected.xy[:n][scored], between[scored])


def _carried_pck(detected, tr, withheld, size) -> float:
    """PCK@0.2 on the `withheld` frames of the keypoints the fit was given there (the
    detections carried by optical flow, in the tracked frames' pixels), against the
    withheld detections of the frames of `size`: the carry's share of the fit's error.
    NaN without withheld frames."""
    scored = withheld & detected.present[: tr.n_frames].all(axis=1)
    if not scored.any():
        return np.nan
    truth = detected.scaled(640.0 / max(size), size).xy[: tr.n_frames]
    return pck_2d(truth[scored], tr.keypoints[0].xy[scored])


def _against_world(name: str, tr, hand) -> tuple[float, float]:
    """The fit's joints against MediaPipe's world landmarks (module notes): mean
    wrist-relative distance (mm) and median rotation angle (degrees); NaN without them."""
    from handvar.data import EXAMPLES
    from handvar.evaluation.metrics import joint_errors
    from handvar.tracking.keypoint_cost import keypoint_points
    from handvar.vision.keypoints import world_in_camera

    if f"{name}-mediapipe" not in EXAMPLES:
        return np.nan, np.nan
    with np.load(example_path(f"{name}-mediapipe")) as z:
        world = z["world_mm"][: tr.n_frames]
    camera = tr.rig.cameras[0]
    fit = np.full_like(world, np.nan)
    for t, x in enumerate(tr.poses[: len(world)]):
        if np.isfinite(x).all():
            points = keypoint_points(hand, x, "pad")
            fit[t] = points @ camera.R.T
            world[t] = world_in_camera(world[t], camera.project(points), camera)
    both = np.isfinite(fit).all(axis=(1, 2)) & np.isfinite(world).all(axis=(1, 2))
    distance = float(np.mean(joint_errors(world[both], fit[both], alignment="wrist")))
    angles = [_angle(f, w) for f, w in zip(fit[both], world[both], strict=True)]
    return distance, float(np.median(angles))


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle of the rotation of the similarity that best fits `a` to `b`, degrees."""
    return rotation_angle(similarity(a, b)[1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--every", default="1,5")
    ap.add_argument("--videos", default=",".join(VIDEOS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--world",
        action="store_true",
        help="with MediaPipe's world landmarks (fingerspelling, counting)",
    )
    ap.add_argument("--silhouette-term", type=float, default=0.0,
                    help="σ of the keypoint fit's silhouette term, hand sizes; 0: off")  # fmt: skip
    args = ap.parse_args()
    clock = time.perf_counter()
    track(example_path("video"), keypoints=example_path("video-keypoints"), frames=2,
          scale=0.5)  # fmt: skip
    print(f"start-up of the first track in this process: {time.perf_counter() - clock:.2f} s")
    if args.world and args.videos == ",".join(VIDEOS):  # only the clips have world points
        args.videos = "fingerspelling,counting"
    print(
        "video | K | frames (detections given) | no hand | lost | re-init | keypoint check "
        "(worst frame, frames failing, rejected) | carried: worst frame | PCK withheld "
        "(keypoints carried; detections interpolated) | PCK all | "
        "ms/frame median | worst 1 s | first frame ms | slowest other frame: ms (frame) | "
        "3D vs MediaPipe's world: mm, deg | hand length mm"
    )
    for name in args.videos.split(","):
        for every in (int(v) for v in args.every.split(",")):
            r = run(name, every, args.seed, args.world, args.silhouette_term)
            w, h = r["size"]
            print(f"{name} ({w}x{h}) | {every} | {r['frames']} ({r['given']}) | {r['no_hand']} | "
                  f"{r['lost']} | {r['reinit']} | {'holds' if r['check'] else 'fails'} "
                  f"({100 * r['worst']:.1f} %, {r['failing']}, {r['rejected']}) | "
                  f"{100 * r['carried'][1]:.1f} % | "
                  f"{r['pck_withheld']:.3f} ({r['pck_carried']:.3f}; "
                  f"{r['pck_interpolated']:.3f}) | "
                  f"{r['pck_all']:.3f} | "
                  f"{r['median_ms']:.1f} | "
                  f"{r['worst_ms']:.1f} | {r['first_ms']:.0f} | {r['slowest'][0]:.0f} "
                  f"({r['slowest'][1]}) | {_pair(r['world'])} | {r['length']:.0f}",
                  flush=True)  # fmt: skip
    if "counting" in args.videos.split(",") and not args.world:
        n, median, most = no_hand_cost()
        print(f"counting, keypoints carried forward: {n} frames flagged without a hand, "
              f"{median:.1f} ms each (median), at most {most:.1f} ms")  # fmt: skip


def no_hand_cost(name: str = "counting") -> tuple[int, float, float]:
    """Video `name` tracked with its keypoints on every frame, carried forward (so that
    each frame is handed out when it is done and its time is its own): the frames
    flagged without a hand, and their median and largest ms all-in."""
    tr, seconds = timed_track(example_path(name), example_path(f"{name}-keypoints"),
                              carry="forward")  # fmt: skip
    ms = 1e3 * seconds[1:]  # the first frame opens the video
    empty = np.asarray(tr.quality.no_hand[1:], dtype=bool)
    return int(empty.sum()), float(np.median(ms[empty])), float(ms[empty].max())


def _pair(values: tuple[float, float]) -> str:
    return "–" if not np.isfinite(values[0]) else f"{values[0]:.1f}, {values[1]:.1f}"


if __name__ == "__main__":
    main()
