"""The wrist cut on the example video, against the detected wrists (design §14.1).

For every frame of ``examples/data/dex-human-hand-video.mp4`` the skin silhouette (no
cut) is cut by the palm-centre heuristic (`handvar.vision.wrist.palm_wrist`), by the
forearm heuristic (`handvar.vision.wrist.forearm_wrist`) and by the keypoint cut
(`handvar.vision.wrist.wrist_from_keypoints`).  The reference is the shipped MediaPipe
wrist (``dex-human-hand-video-keypoints.npy``).  Printed per method and frame group:
the distance from the cut line to the detected wrist in hand sizes (the detected wrist
→ middle-MCP distance): median, 90th percentile, share of frames within 0.25, how
many frames got no cut, and how many cuts lie more than half a hand size into the hand
("into >0.5").  A cut on the forearm side of the wrist is positive.

Run: ``PYTHONPATH=src .venv/bin/python studies/wrist.py [--scale 0.5] [--step 1]``

``--realistic DIR`` measures the forearm cut against the truth instead: on the realistic
benchmark's 16 cases (``studies/realistic.py``; DIR as made by ``--out DIR``, the cases
generated if missing), every ``--step``-th frame (2 by default) of each camera, the skin
silhouette as the tracker makes it without keypoints (the component kept where the true
silhouette lies, as the tracker keeps the one its prediction overlaps), on the frames
where it holds the hand (IoU with the true silhouette ≥ 0.3) and leaves the image (where
the forearm cut applies): the same figures against the rendered wrist for the three
routes (the keypoint cut on the simulated detector's points, what a detector alone
gives), per motion.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from handvar.data import example_path
from handvar.evaluation.realistic import read_case
from handvar.tracking.tracker import silhouette_iou
from handvar.vision.keypoints import read_keypoints
from handvar.vision.silhouette import EmptySilhouetteError, silhouettes_from_frames
from handvar.vision.sources import open_source
from handvar.vision.wrist import forearm_wrist, palm_wrist, wrist_from_keypoints
from realistic import generate, specs

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")
GROUPS = {
    "all": (0, 621),
    "fist 255-280": (255, 281),
    "edge-on 459-620": (459, 621),
    "edge-on turn 554-567": (554, 568),
}


def signed_distance(cut, wrist: np.ndarray) -> float:
    """Distance of the cut line beyond the wrist, towards the forearm, pixels."""
    return float((cut.wrist - wrist) @ cut.direction)


HEADER = (f"{'method':>12} {'frames':>20} {'n':>4} {'no cut':>6} {'median':>7} "
          f"{'|d| p90':>7} {'|d|<0.25':>8} {'into >0.5':>9}")  # fmt: skip


def print_row(name: str, group: str, v: np.ndarray) -> None:
    """One row of signed distances `v` (hand sizes, NaN: no cut)."""
    cut = v[~np.isnan(v)]
    med = np.median(cut) if cut.size else np.nan
    p90 = np.percentile(np.abs(cut), 90) if cut.size else np.nan
    within = np.mean(np.abs(v) < 0.25)  # no cut counts as a miss
    print(f"{name:>12} {group:>20} {len(v):>4} {int(np.isnan(v).sum()):>6} "
          f"{med:>7.2f} {p90:>7.2f} {within:>8.0%} {int((cut < -0.5).sum()):>9}")  # fmt: skip


def realistic(directory: Path, step: int) -> None:
    """The three routes against the rendered wrists (module notes)."""
    d: dict[str, dict[str, list[float]]] = {}
    for spec in specs(quick=False):
        generate(spec, directory / spec.name)
        case = read_case(directory / spec.name, frames=True)
        for j in range(len(case.rig)):
            for t in range(0, case.n_frames, step):
                true = case.masks[j][t]
                image = cv2.cvtColor(case.frames[j][t], cv2.COLOR_RGB2BGR)
                try:
                    (m,) = silhouettes_from_frames([image], near=[true])
                except EmptySilhouetteError:
                    continue
                leaves = m[0].any() or m[-1].any() or m[:, 0].any() or m[:, -1].any()
                if not leaves or silhouette_iou(m[None], true[None])[0] < 0.3:
                    continue
                k = case.truth_2d[j][t]
                size = float(np.linalg.norm(k[9, :2] - k[0, :2]))
                cuts = {
                    "palm centre": palm_wrist(m),
                    "forearm": forearm_wrist(m),
                    "keypoints": wrist_from_keypoints(case.keypoints[j][t], m.shape),
                }
                for name, cut in cuts.items():
                    x = np.nan if cut is None else signed_distance(cut, k[0, :2]) / size
                    d.setdefault(name, {}).setdefault(spec.name.split("-")[0], []).append(x)
    print(
        f"realistic benchmark, every {step} frame(s) of each camera where the skin "
        "silhouette holds the hand and leaves the image (keypoints: the simulated "
        "detector's, no cut where it missed the hand):"
    )
    print("cut line - true wrist, hand sizes, + towards the forearm")
    print(HEADER)
    for name, groups in d.items():
        for group, v in groups.items():
            print_row(name, group, np.array(v))
        print_row(name, "all", np.concatenate([np.array(v) for v in groups.values()]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument(
        "--step",
        type=int,
        default=None,
        help="every N-th frame (1 on the video, 2 with --realistic)",
    )
    parser.add_argument(
        "--realistic",
        type=Path,
        default=None,
        metavar="DIR",
        help="against the truth on the realistic benchmark in DIR",
    )
    args = parser.parse_args()
    if args.realistic is not None:
        realistic(args.realistic, args.step or 2)
        return
    args.step = args.step or 1
    source = open_source(VIDEO, scale=args.scale)
    kp = read_keypoints(KEYPOINTS).scaled(args.scale, (1280, 720))
    methods = {
        "palm centre": lambda m, k: palm_wrist(m),
        "forearm": lambda m, k: forearm_wrist(m),
        "keypoints": lambda m, k: wrist_from_keypoints(k, m.shape),
    }
    d = {name: {} for name in methods}
    for t, _, masks in source.silhouettes(step=args.step, wrist=False):
        k = kp.frame(t)
        size = float(np.linalg.norm(k[9, :2] - k[0, :2]))
        for name, method in methods.items():
            cut = method(masks[0], k)
            d[name][t] = np.nan if cut is None else signed_distance(cut, k[0, :2]) / size
    print(f"example video at scale {args.scale}, every {args.step} frame(s): cut line - wrist,")
    print("hand sizes (wrist to middle MCP), + towards the forearm")
    print(HEADER)
    for name in methods:
        for group, (a, b) in GROUPS.items():
            print_row(name, group, np.array([x for t, x in d[name].items() if a <= t < b]))


if __name__ == "__main__":
    main()
