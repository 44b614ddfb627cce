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
they are not the truth, and they are not given to the tracker.  Printed per predictor:

- lost: frames the recovery flagged lost (``quality.lost``);
- reinit: frames re-initialised by a pose search (``quality.reinit``);
- PCK@0.2: the fraction of the 21 projected joints within 0.2 hand sizes of the
  keypoints (hand size: the keypoints' wrist → middle-MCP length in that frame;
  `handvar.evaluation.metrics.pck_2d`), over the frames where MediaPipe has all 21;
- off: those frames whose mean joint distance exceeds 0.5 hand sizes (the fit is off
  the hand), and their longest run;
- ms/frame: the tracking stage per frame (fit, quality checks, searches), not the
  silhouettes.

Run: ``PYTHONPATH=src .venv/bin/python studies/paper_real_video.py`` (about 5 minutes;
``--videos`` adds the clips, ``--video NAME`` runs one; ``--predictors rvar,decel`` for
some only; ``--frames N``
for the first N frames; ``--seed S``).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import handvar
from handvar.data import example_path
from handvar.evaluation.metrics import pck_2d
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.vision.keypoints import read_keypoints

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


def first_pose(video: Path, seed: int) -> np.ndarray | None:
    """The first pose as ``handvar init VIDEO --scale 0.5`` finds it in frame 0's silhouette.

    None when the command finds none there (a clip without a hand in its first frame):
    `handvar.track` then searches the pose itself.
    """
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "x0.txt"
        done = subprocess.run(
            [sys.executable, "-m", "handvar", "init", str(video), "--scale", str(SCALE),
             "--seed", str(seed), "--out", str(out)],
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


def longest_run(flags: np.ndarray) -> tuple[int, int]:
    """Length and first index of the longest run of True in `flags` (0, -1 if none)."""
    best, start, run = 0, -1, 0
    for i, f in enumerate(flags):
        run = run + 1 if f else 0
        if run > best:
            best, start = run, i - run + 1
    return best, start


def score(track, keypoints) -> dict:
    """The track's figures against the detector's keypoints (full-resolution pixels)."""
    n = track.n_frames
    kp = keypoints.xy[:n]
    scored = keypoints.present[:n].all(axis=1)  # frames where MediaPipe has all 21
    estimate = track.projected[0][:n]
    d = distances(kp[scored], estimate[scored])
    off = np.zeros(n, dtype=bool)
    off[np.flatnonzero(scored)] = ~(d <= OFF)  # NaN (no pose) counts as off
    run, start = longest_run(off)
    q = track.quality
    return {
        "frames": n,
        "scored": int(scored.sum()),
        "lost": int(q.lost.sum()),
        "reinit": int(q.reinit.sum()),
        "pck": pck_2d(kp[scored], estimate[scored], 0.2),
        "off": int(off.sum()),
        "off_run": run,
        "off_start": start,
        "off_frames": np.flatnonzero(off),
        "median_d": float(np.nanmedian(d)),
        "iou": float(np.mean(q.iou[~q.empty])),
        "ms": 1e3 * track.stage_seconds["tracking"] / n,
    }


def run(name: str, predictors, frames: int | None, seed: int) -> dict:
    """Track video `name` with each predictor from one first pose; their figures."""
    video = example_path(name)
    keypoints = read_keypoints(example_path(f"{name}-keypoints"))
    x0 = first_pose(video, seed)
    rows = {}
    for p in predictors:
        t0 = time.perf_counter()
        track = handvar.track(
            video, scale=SCALE, detector="none", predictor=p, init=x0, seed=seed, frames=frames
        )
        rows[p] = score(track, keypoints)
        rows[p]["wall"] = time.perf_counter() - t0
        r = rows[p]
        print(
            f"  {p:15s} lost {r['lost']:3d}  reinit {r['reinit']:3d}  PCK {r['pck']:.3f}  "
            f"off {r['off']:3d} (longest {r['off_run']} from {r['off_start']})  "
            f"{r['ms']:.1f} ms/frame  ({r['wall']:.0f} s)",
            flush=True,
        )
    return rows


def table(results: dict) -> str:
    """The results as a Markdown table."""
    lines = [
        "| video | predictor | lost | re-initialised | PCK@0.2 | frames > 0.5 hand sizes "
        "(longest run, from) | median distance, hand sizes | mean IoU | ms/frame |",
        "|---|---|---:|---:|---:|---|---:|---:|---:|",
    ]
    for name, rows in results.items():
        for p, r in rows.items():
            lines.append(
                f"| {name} ({r['scored']} of {r['frames']} scored) | {p} | {r['lost']} | "
                f"{r['reinit']} | {r['pck']:.3f} | {r['off']} ({r['off_run']}, "
                f"{r['off_start']}) | {r['median_d']:.3f} | {r['iou']:.3f} | {r['ms']:.1f} |"
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
    args = parser.parse_args()
    predictors = [p.strip() for p in args.predictors.split(",") if p.strip()]
    results = {}
    names = args.video or (VIDEOS if args.videos else VIDEOS[:1])
    for name in names:
        print(f"{name}: {example_path(name).name}", flush=True)
        results[name] = run(name, predictors, args.frames, args.seed)
    print()
    print(table(results))
    for name, rows in results.items():
        for p, r in rows.items():
            if r["off"]:
                print(f"{name} {p}: off-hand frames {r['off_frames'].tolist()}")


if __name__ == "__main__":
    main()
