"""On real video, paper §6: does the robust VAR keep the silhouette tracker on the hand?

In paper §6 (fig. 8) the authors claim that with RVAR the silhouette tracker follows fast
out-of-plane motion with severe self-occlusion that simpler predictors lose.  Here the
silhouette tracker alone (no keypoints in the fit: ``detector="none"``), as the README's
silhouette way runs it (``handvar init VIDEO --scale 0.5`` for the first pose, then
``handvar track VIDEO --scale 0.5 --detector none --init x0.txt``, recovery on, seed 0),
tracks the example video ``examples/data/dex-human-hand-video.mp4`` (621 frames) with
each predictor of the paper and ours: no motion, decelerating, full VAR, structured VAR,
RVAR as printed (eq. 26–28), the edge RVAR and the steering adaptive bank.  With
``--videos`` the two clips ``fingerspelling`` and ``counting`` are added.

The reference is MediaPipe's keypoints shipped beside each video (``*-keypoints.npy``);
they are not the truth, and they are not given to the tracker.  With ``--realistic DIR``
the same runs are scored against the truth instead: the 16 cases of the realistic
benchmark (``studies/realistic.py``: the skinned hand over real and generated
backgrounds, the palm flip among its motions; generated into DIR unless there), each
tracked on its frames alone from its true first pose with a model of its true length,
so that the predictor is what differs.  Printed per predictor:

- lost: frames the recovery flagged lost (``quality.lost``);
- reinit: frames re-initialised by a pose search (``quality.reinit``);
- PCK@0.2: the fraction of the 21 projected points the track reports (the fingertips
  and the thumb's base where a detector marks them; ``--skeleton``: G(x)'s joints)
  within 0.2 hand sizes of the keypoints (hand size: the keypoints' wrist → middle-MCP
  length in that frame; `handvar.evaluation.metrics.pck_2d`), over the frames where
  MediaPipe has all 21;
- off: those frames whose mean joint distance exceeds 0.5 hand sizes (the fit is off
  the hand), and their longest run;
- ms/frame: the tracking stage per frame (fit, quality checks, searches), not the
  silhouettes;
- on the realistic cases also the wrist-relative and absolute 3D errors (mm, as
  ``studies/realistic.py`` scores them), the frames whose wrist-relative mean joint
  error exceeds `LOSS_MM` (the paper experiment's lost hand), and paper §6's two tests
  on the flip cases (`handvar.evaluation.claims`), with the wrist-relative error: RVAR's
  worst frame under `LOSS_MM` where the decelerating predictor's is not, and RVAR's mean
  error below the decelerating predictor's; per predictor how well the silhouettes the
  tracker was given match the hand's true one (IoU; it keeps the skin component where
  the hand is expected), and per case what keeping the largest component would give.
  ``--largest`` tracks with the largest component instead
  (`RecoverySettings.skin_where_expected` off), to compare the two rules.

``--shape``: each video tracked with the person's hand instead of the default one: the
hand the one command fits to MediaPipe's keypoints (``handvar track VIDEO --scale 0.5
--out DIR``, the detector inside), given to both commands (``handvar init ... --shape
DIR`` and ``handvar track ... --detector none --shape DIR``); the fit still gets no
keypoint.  Silhouettes do not tell where the knuckles lie along the hand, keypoints do.
Printed beside each row: the median distance (hand sizes) along the hand (the
keypoints' wrist → middle MCP) of the projected MCPs from MediaPipe's, negative towards
the wrist.

``--strip DIR`` draws, per video (and for the realistic case whose predictors are off
the hand most), the hardest stretch: six frames of the window of 12 where the
predictors are off the hand most often, one row per predictor (the model's joints and
bones over the frame about the reference points, those white), to
``DIR/paper-real-video-NAME.jpg``.

Run: ``PYTHONPATH=src .venv/bin/python studies/paper_real_video.py`` (about 5 minutes;
``--videos`` adds the clips, ``--video NAME`` runs one; ``--predictors rvar,decel`` for
some only; ``--frames N``
for the first N frames; ``--seed S``; ``--realistic DIR [--cases S]`` the rendered cases,
about 2 minutes per case and predictor where the searches run on most frames, and with
``--predictors ''`` their silhouette figures alone).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

import handvar
from handvar.data import example_path
from handvar.evaluation.claims import LOSS_MM
from handvar.evaluation.metrics import joint_errors, pck_2d
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST, HandShape
from handvar.render import draw_overlay
from handvar.render.overlay import side_by_side
from handvar.tracking.recovery import RecoverySettings
from handvar.tracking.tracker import silhouette_iou
from handvar.vision.keypoints import read_keypoints
from handvar.vision.silhouette import EmptySilhouetteError
from realistic import generate, scored_points, specs

PREDICTORS = (
    "none",
    "decelerating",
    "full_var",
    "structured_var",
    "rvar",
    "rvar_edge",
    "adaptive",
)
VIDEOS = ("video", "fingerspelling", "counting")
SCALE = 0.5
OFF = 0.5  # hand sizes: a frame whose mean joint distance exceeds this is off the hand
STRETCH = 12  # frames: the window of the overlay strip
STRIP_FRAMES = 6
STRIP_WIDTH = 200  # px: one tile of the strip, a square about the reference points


def first_pose(video: Path, seed: int, shape: Path | None = None) -> np.ndarray | None:
    """The first pose as ``handvar init VIDEO --scale 0.5 [--shape DIR]`` finds it in
    frame 0's silhouette.

    None when the command finds none there (a clip without a hand in its first frame):
    `handvar.track` then searches the pose itself.
    """
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "x0.txt"
        done = subprocess.run(
            [sys.executable, "-m", "handvar", "init", str(video), "--scale", str(SCALE),
             "--seed", str(seed), "--out", str(out),
             *(["--shape", str(shape)] if shape is not None else [])],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        if done.returncode != 0:
            print(f"  handvar init: {done.stderr.strip()} (the track searches instead)")
            return None
        return np.loadtxt(out)


def distances(truth: np.ndarray, estimate: np.ndarray) -> np.ndarray:
    """Mean joint distance per frame, in the frame's wrist → middle-MCP lengths.

    truth, estimate : (T, 21, 2) ndarray, pixels.  Returns (T,).
    """
    size = np.linalg.norm(truth[:, MIDDLE_MCP] - truth[:, WRIST], axis=-1)
    return np.linalg.norm(estimate - truth, axis=-1).mean(axis=1) / size


#: The four fingers' MCPs (MediaPipe's order).
MCPS = (5, 9, 13, 17)


def mcp_along(reference: np.ndarray, estimate: np.ndarray) -> float:
    """Median offset of the estimate's finger MCPs from the reference's along the hand
    (the reference's wrist → middle MCP), in its length; negative towards the wrist."""
    axis = reference[:, MIDDLE_MCP] - reference[:, WRIST]
    length = np.linalg.norm(axis, axis=-1)
    along = np.einsum("tkc,tc->tk", estimate[:, MCPS] - reference[:, MCPS], axis)
    return float(np.nanmedian(along / length[:, None] ** 2))


def longest_run(flags: np.ndarray) -> tuple[int, int]:
    """Length and first index of the longest run of True in `flags` (0, -1 if none)."""
    best, start, run = 0, -1, 0
    for i, f in enumerate(flags):
        run = run + 1 if f else 0
        if run > best:
            best, start = run, i - run + 1
    return best, start


def score(track, keypoints, skeleton: bool = False) -> dict:
    """The track's figures against the detector's keypoints (full-resolution pixels): of
    the points it reports, or with `skeleton` of its skeleton's joints G(x)."""
    n = track.n_frames
    scored = keypoints.present[:n].all(axis=1)  # frames where MediaPipe has all 21
    estimate = track.projected[0][:n]
    if skeleton:
        camera, hand = track.rig.cameras[0], track.hand
        estimate = np.full_like(estimate, np.nan)
        for t in np.flatnonzero(np.isfinite(track.poses[:n]).all(axis=1)):
            estimate[t] = camera.project(hand.joints(track.poses[t]))
    return figures(track, keypoints.xy[:n], estimate, scored)


def figures(track, reference: np.ndarray, estimate: np.ndarray, scored: np.ndarray) -> dict:
    """The track's figures (module notes) from its `estimate` of camera 0's points
    against the `reference` ones, (T, 21, 2) pixels, over the `scored` (T,) frames."""
    n = len(scored)
    d = distances(reference[scored], estimate[scored])
    off = np.zeros(n, dtype=bool)
    off[np.flatnonzero(scored)] = ~(d <= OFF)  # NaN (no pose) counts as off
    run, start = longest_run(off)
    q = track.quality
    return {
        "frames": n,
        "scored": int(scored.sum()),
        "lost": int(q.lost.sum()),
        "reinit": int(q.reinit.sum()),
        "pck": pck_2d(reference[scored], estimate[scored], 0.2),
        "off": int(off.sum()),
        "off_run": run,
        "off_start": start,
        "off_flags": off,
        "median_d": float(np.nanmedian(d)),
        "mcp_along": mcp_along(reference[scored], estimate[scored]),
        "iou": float(np.mean(q.iou[~q.empty])),
        "ms": 1e3 * track.stage_seconds["tracking"] / n,
    }


def person_shape(video: Path, out: Path) -> Path:
    """The person's hand: `video` tracked by the one command (the detector inside,
    ``handvar track VIDEO --scale 0.5 --out OUT``), whose track holds the hand fitted
    to its keypoints; `out`, for ``--shape``."""
    person = handvar.track(video, scale=SCALE)
    person.save(out, video=False, overlays=False)
    shape = person.shape
    default = HandShape.from_size(side=shape.side)
    print(f"  the person's hand (the one command's track): wrist → middle MCP "
          f"{shape.bases[2, 1]:.1f} mm, the middle finger's bones "
          f"{', '.join(f'{b:.1f}' for b in shape.segments[2])} mm; the default hand "
          f"{default.bases[2, 1]:.1f} and {', '.join(f'{b:.1f}' for b in default.segments[2])}",
          flush=True)  # fmt: skip
    return out


def run(name: str, predictors, frames: int | None, seed: int, strip: Path | None,
        recovery=None, shape: Path | None = None, skeleton: bool = False) -> dict:  # fmt: skip
    """Track video `name` with each predictor from one first pose (the default hand, or
    the track `shape`'s); their figures."""
    video = example_path(name)
    keypoints = read_keypoints(example_path(f"{name}-keypoints"))
    x0 = first_pose(video, seed, shape)
    rows, tracks = {}, {}
    for p in predictors:
        t0 = time.perf_counter()
        track = handvar.track(video, scale=SCALE, detector="none", predictor=p, init=x0,
                              seed=seed, frames=frames, recovery=recovery,
                              shape=shape)  # fmt: skip
        rows[p] = score(track, keypoints, skeleton)
        rows[p]["wall"] = time.perf_counter() - t0
        tracks[p] = track
        _print_row(p, rows[p])
    if strip is not None:
        write_strip(strip / f"paper-real-video-{name}.jpg", tracks, rows,
                    _video_frames(video), keypoints.xy)  # fmt: skip
    return rows


def spread(seeds=(0, 1, 2)) -> None:
    """The default silhouette track of the example video with each seed (module notes)."""
    name = VIDEOS[0]
    keypoints = read_keypoints(example_path(f"{name}-keypoints"))
    for seed in seeds:
        track = handvar.track(example_path(name), scale=SCALE, detector="none", seed=seed)
        r = score(track, keypoints)
        print(f"seed {seed}: PCK@0.2 {r['pck']:.3f}, frames > 0.5 hand sizes {r['off']}, "
              f"lost {r['lost']}, re-initialised {r['reinit']}", flush=True)  # fmt: skip


def _print_row(p: str, r: dict) -> None:
    extra = "" if "mpjpe" not in r else (
        f"  3D {r['mpjpe']:.1f} mm (abs {r['abs']:.1f}; worst frame {r['worst']:.1f}; "
        f"> {LOSS_MM:g} mm on {r['over']}; silhouette given: IoU median {r['given']:.2f})"
    )  # fmt: skip
    print(
        f"  {p:15s} lost {r['lost']:3d}  reinit {r['reinit']:3d}  PCK {r['pck']:.3f}  "
        f"off {r['off']:3d} (longest {r['off_run']} from {r['off_start']})  "
        f"MCPs {r['mcp_along']:+.2f}  {r['ms']:.1f} ms/frame  ({r['wall']:.0f} s){extra}",
        flush=True,
    )


def _video_frames(video: Path):
    """frames(indices) -> {index: RGB full-resolution frame} of a video."""

    def frames(indices):
        cap = cv2.VideoCapture(str(video))
        out = {}
        for t in sorted(indices):
            cap.set(cv2.CAP_PROP_POS_FRAMES, t)
            ok, bgr = cap.read()
            if ok:
                out[t] = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        cap.release()
        return out

    return frames


def _folder_frames(folder: Path):
    """frames(indices) -> {index: RGB frame} of an image folder (sorted names)."""
    files = sorted(folder.iterdir())

    def frames(indices):
        return {t: cv2.cvtColor(cv2.imread(str(files[t])), cv2.COLOR_BGR2RGB) for t in indices}

    return frames


def hardest_stretch(rows: dict, n_frames: int) -> list[int]:
    """`STRIP_FRAMES` frames spread over the window of `STRETCH` frames where the
    predictors are off the hand most often (summed over predictors; the first such)."""
    off = np.sum([r["off_flags"][:n_frames] for r in rows.values()], axis=0)
    width = min(STRETCH, n_frames)
    counts = np.convolve(off, np.ones(width), mode="valid")
    start = int(np.argmax(counts))
    picks = np.linspace(start, start + width - 1, min(STRIP_FRAMES, width)).round()
    return np.unique(picks).astype(int).tolist()


def write_strip(path: Path, tracks: dict, rows: dict, frames, reference: np.ndarray) -> None:
    """The overlay strip of the hardest stretch (module notes): one row per predictor,
    the model of its track over camera 0's frame, the `reference` points (T, 21, 2)
    white."""
    n = min(t.n_frames for t in tracks.values())
    picks = hardest_stretch(rows, n)
    images = frames(picks)
    lines = []
    for p, track in tracks.items():
        camera = track.rig.cameras[0]
        tiles = []
        for t in picks:
            image = draw_overlay(images[t], camera, track.joints[t])
            for u, v in reference[t]:
                if np.isfinite(u) and np.isfinite(v):
                    cv2.circle(image, (round(u), round(v)), 3, (255, 255, 255), -1)
            y0, y1, x0, x1 = _crop(reference[t], image.shape)
            tile = image[y0:y1, x0:x1]
            tiles.append(cv2.resize(tile, (STRIP_WIDTH, STRIP_WIDTH), interpolation=cv2.INTER_AREA))
        lines.append(side_by_side(tiles, [f"{p} {t}" for t in picks]))
    path.parent.mkdir(parents=True, exist_ok=True)
    strip = cv2.cvtColor(np.concatenate(lines, axis=0), cv2.COLOR_RGB2BGR)
    cv2.imwrite(str(path), strip, [cv2.IMWRITE_JPEG_QUALITY, 85])
    print(f"  overlay strip of frames {picks[0]}-{picks[-1]}: {path}")


def _crop(points: np.ndarray, shape) -> tuple[int, int, int, int]:
    """A square about the reference `points` (21, 2), twice their extent (at least 120
    px), inside an image of `shape`: rows y0:y1, columns x0:x1 (the image's middle when
    there are no points)."""
    h, w = shape[:2]
    ok = np.isfinite(points).all(axis=1)
    centre = points[ok].mean(axis=0) if ok.any() else np.array([w / 2, h / 2])
    extent = np.ptp(points[ok], axis=0).max() if ok.sum() > 1 else 0.0
    side = int(min(max(2.0 * extent, 120.0), h, w))
    x0 = int(np.clip(round(centre[0] - side / 2), 0, w - side))
    y0 = int(np.clip(round(centre[1] - side / 2), 0, h - side))
    return y0, y0 + side, x0, x0 + side


def run_realistic(directory: Path, predictors, seed: int, cases: str,
                  strip: Path | None, recovery=None) -> dict:  # fmt: skip
    """Track each realistic case (module notes) with each predictor; figures per case."""
    results, hardest = {}, None
    for spec in specs(quick=False):
        if cases not in spec.name:
            continue
        case_dir = directory / spec.name
        case = generate(spec, case_dir)
        cams = [str(case_dir / f"cam{j}") for j in range(spec.cameras)]
        print(f"{spec.name}: {case.n_frames} frames", flush=True)
        rows, tracks = {}, {}
        for p in predictors:
            t0 = time.perf_counter()
            try:
                track = handvar.track(
                    cams, calib=case_dir / "calib.yml", hand=spec.side, detector="none",
                    hand_length=case.hand_length, init=case.poses[0], predictor=p, seed=seed,
                    recovery=recovery,
                )  # fmt: skip
            except EmptySilhouetteError as exc:  # the tracker's own refusal, said as such
                print(f"  not tracked: {exc}", flush=True)
                break
            rows[p] = score_truth(track, case)
            rows[p]["wall"] = time.perf_counter() - t0
            tracks[p] = track
            _print_row(p, rows[p])
        skin = skin_agreement(case_dir / "cam0", case.masks[0])
        largest = skin["largest"]
        print(f"  the skin silhouette against the true one, keeping the largest component: "
              f"IoU median {np.median(largest):.2f}, below 0.5 on {np.sum(largest < 0.5)} of "
              f"{len(largest)} frames; the hand's pixels called skin: median "
              f"{np.median(skin['recall']):.2f}; the component holding most of the hand: "
              f"IoU median {np.median(skin['nearest']):.2f}", flush=True)  # fmt: skip
        if not rows:
            continue
        results[spec.name] = rows
        off = sum(r["off"] for r in rows.values())
        if strip is not None and (hardest is None or off > hardest[0]):  # only its tracks kept
            frames = _folder_frames(case_dir / "cam0")
            hardest = (off, spec.name, (tracks, rows, frames, case.truth_2d[0]))
    if hardest is not None:
        _, name, drawn = hardest
        write_strip(strip / f"paper-real-video-{name}.jpg", *drawn)
    return results


def skin_agreement(folder: Path, truth: np.ndarray) -> dict[str, np.ndarray]:
    """Per frame of an image folder, against the hand's true silhouette `truth` (T, H, W):

    - ``largest``: the IoU of the silhouette at `silhouettes_from_frames`' defaults, as
      the tracker had it before it chose the skin where the hand is expected (the
      published skin model, the clean-up keeping the largest component, the forearm
      cut at the wrist; 0 where none);
    - ``recall``: the share of the hand's pixels the skin model calls skin;
    - ``nearest``: the IoU of the clean-up's component that overlaps the hand most
      (before any wrist cut, so with the forearm): what keeping the right component
      could give at best.
    """
    from handvar.vision.silhouette import clean_mask, silhouettes_from_frames
    from handvar.vision.skin import SkinModel

    model = SkinModel()
    out = {k: np.zeros(len(truth)) for k in ("largest", "recall", "nearest")}
    for t, name in enumerate(sorted(folder.iterdir())[: len(truth)]):
        image, hand = cv2.imread(str(name)), truth[t]
        raw = model.mask(image)
        out["recall"][t] = (raw & hand).sum() / max(hand.sum(), 1)
        n, labels = cv2.connectedComponents(clean_mask(raw, keep=1000).astype(np.uint8))
        inside = np.bincount(labels[hand], minlength=n)[1:]
        if inside.any():
            part = labels == 1 + int(np.argmax(inside))
            out["nearest"][t] = silhouette_iou(part[None], hand[None])[0]
        try:
            mask = silhouettes_from_frames([image], model, wrist=True)[0]
        except EmptySilhouetteError:
            continue
        out["largest"][t] = silhouette_iou(mask[None], hand[None])[0]
    return out


def score_truth(track, case) -> dict:
    """The track's figures against a realistic case's truth: its scored points (the
    detector's, fingertips at the pads: ``studies/realistic.py``) through the tracked
    model, in camera 0 (2D) and in the world (3D)."""
    n = case.n_frames
    points = scored_points(track.hand, track.poses[:n])
    estimate = np.full((n, 21, 2), np.nan)
    ok = np.isfinite(points).all(axis=(1, 2))
    estimate[ok] = track.rig.cameras[0].project(points[ok].reshape(-1, 3)).reshape(-1, 21, 2)
    relative = joint_errors(case.joints, points, alignment="wrist").mean(axis=1)
    absolute = joint_errors(case.joints, points, alignment="none").mean(axis=1)
    row = figures(track, case.truth_2d[0], estimate, np.ones(n, dtype=bool))
    given = np.asarray([np.asarray(track.sequence.masks[t])[0] for t in range(n)])
    row.update(
        given=float(np.nanmedian(silhouette_iou(given, case.masks[0][:n]))),  # frames as cameras
        mpjpe=float(np.nanmean(relative)),
        abs=float(np.nanmean(absolute)),
        worst=float(np.nanmax(relative)),
        over=int(np.sum(~(relative <= LOSS_MM))),
    )
    return row


def realistic_summary(results: dict) -> str:
    """Per predictor over the realistic cases, mono, stereo and all: mean PCK, 3D errors,
    the frames off the hand and over `LOSS_MM`, lost, re-initialised, ms/frame."""
    lines = [
        "| rig | predictor | PCK@0.2 | MPJPE | abs 3D | frames > 0.5 hand sizes | "
        f"frames > {LOSS_MM:g} mm | lost | re-initialised | ms/frame |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    predictors = next(iter(results.values())).keys()
    for rig in ("mono", "stereo", "all"):
        cases = [rows for name, rows in results.items() if rig == "all" or f"-{rig}-" in name]
        if not cases:
            continue
        for p in predictors:
            rs = [rows[p] for rows in cases]
            lines.append(
                f"| {rig} | {p} | {np.mean([r['pck'] for r in rs]):.3f} | "
                f"{np.mean([r['mpjpe'] for r in rs]):.1f} | "
                f"{np.mean([r['abs'] for r in rs]):.1f} | "
                f"{sum(r['off'] for r in rs)} | {sum(r['over'] for r in rs)} | "
                f"{sum(r['lost'] for r in rs)} | {sum(r['reinit'] for r in rs)} | "
                f"{np.mean([r['ms'] for r in rs]):.1f} |"
            )
    return "\n".join(lines)


def flip_verdicts(results: dict) -> list[str]:
    """Paper §6's two tests (`handvar.evaluation.claims`) on each realistic flip case,
    with the wrist-relative error: RVAR as printed against decelerating, then each of
    our variants in RVAR's place."""
    out = []
    for name, rows in results.items():
        if not name.startswith("flip-") or "decelerating" not in rows:
            continue
        d = rows["decelerating"]
        for p in ("rvar", "rvar_edge", "adaptive"):
            if p not in rows:
                continue
            r = rows[p]
            strong = r["worst"] < LOSS_MM <= d["worst"]
            weak = r["mpjpe"] < d["mpjpe"]
            out.append(
                f"{name}: {p} worst frame {r['worst']:.1f} mm, decelerating {d['worst']:.1f} "
                f"mm: fig. 8 form {'holds' if strong else 'does not hold'}; mean "
                f"{r['mpjpe']:.1f} against {d['mpjpe']:.1f} mm: weaker form "
                f"{'holds' if weak else 'does not hold'}"
            )
    return out


def table(results: dict) -> str:
    """The results as a Markdown table."""
    lines = [
        "| video | predictor | lost | re-initialised | PCK@0.2 | frames > 0.5 hand sizes "
        "(longest run, from) | median distance, hand sizes | MCPs along the hand | mean IoU | "
        "ms/frame |",
        "|---|---|---:|---:|---:|---|---:|---:|---:|---:|",
    ]
    for name, rows in results.items():
        for p, r in rows.items():
            lines.append(
                f"| {name} ({r['scored']} of {r['frames']} scored) | {p} | {r['lost']} | "
                f"{r['reinit']} | {r['pck']:.3f} | {r['off']} ({r['off_run']}, "
                f"{r['off_start']}) | {r['median_d']:.3f} | {r['mcp_along']:+.2f} | "
                f"{r['iou']:.3f} | {r['ms']:.1f} |"
            )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--videos", action="store_true", help="add the two clips")
    parser.add_argument(
        "--video", action="append", choices=VIDEOS, help="this video only (repeatable)"
    )
    parser.add_argument("--predictors", default=",".join(PREDICTORS))
    parser.add_argument("--frames", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--realistic", type=Path, default=None, metavar="DIR",
                        help="the realistic cases in DIR instead, against the truth")  # fmt: skip
    parser.add_argument("--cases", default="", help="with --realistic: cases containing this")
    parser.add_argument("--strip", type=Path, default=None, metavar="DIR",
                        help="write the overlay strip of the hardest stretch into DIR")  # fmt: skip
    parser.add_argument("--spread", action="store_true",
                        help="the default example track with seeds 0, 1, 2")  # fmt: skip
    parser.add_argument("--shape", action="store_true",
                        help="the person's hand, as the one command's track fits it")  # fmt: skip
    parser.add_argument("--skeleton", action="store_true",
                        help="score the skeleton's joints G(x), not the points the track "
                             "reports")  # fmt: skip
    parser.add_argument("--largest", action="store_true",
                        help="keep the largest skin component, not the one where the hand "
                             "is expected (RecoverySettings.skin_where_expected)")  # fmt: skip
    args = parser.parse_args()
    predictors = [p.strip() for p in args.predictors.split(",") if p.strip()]
    recovery = RecoverySettings(skin_where_expected=not args.largest)
    if args.spread:
        spread()
        return
    if args.realistic is not None:
        results = run_realistic(args.realistic, predictors, args.seed, args.cases, args.strip,
                                recovery)  # fmt: skip
        print()
        print(table(results))
        print()
        print(realistic_summary(results))
        print()
        print("\n".join(flip_verdicts(results)))
        return
    results = {}
    names = args.video or (VIDEOS if args.videos else VIDEOS[:1])
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            print(f"{name}: {example_path(name).name}", flush=True)
            shape = person_shape(example_path(name), Path(tmp) / name) if args.shape else None
            results[name] = run(name, predictors, args.frames, args.seed, args.strip,
                                recovery, shape, args.skeleton)  # fmt: skip
    print()
    print(table(results))
    for name, rows in results.items():
        for p, r in rows.items():
            if r["off"]:
                print(f"{name} {p}: off-hand frames {np.flatnonzero(r['off_flags']).tolist()}")


if __name__ == "__main__":
    main()
