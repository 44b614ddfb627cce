"""The wrist cut on the example video, against the detected wrists (design §14.1).

For every frame of ``examples/data/dex-human-hand-video.mp4`` the skin silhouette (no
cut) is cut by the palm-centre heuristic (`handvar.vision.wrist.palm_wrist`), by the
forearm heuristic (`handvar.vision.wrist.forearm_wrist`) and by the keypoint cut
(`handvar.vision.wrist.wrist_from_keypoints`).  The reference is the shipped MediaPipe
wrist (``dex-human-hand-video-keypoints.npy``).  Printed per method and frame group:
the distance from the cut line to the detected wrist in hand sizes (the detected wrist
→ middle-MCP distance): median, 90th percentile, share of frames within 0.25, and how
many frames got no cut.  A cut on the forearm side of the wrist is positive.

Run: ``PYTHONPATH=src .venv/bin/python studies/wrist.py [--scale 0.5] [--step 1]``
"""

from __future__ import annotations

import argparse

import numpy as np

from handvar.data import example_path
from handvar.vision.keypoints import read_keypoints
from handvar.vision.sources import open_source
from handvar.vision.wrist import forearm_wrist, palm_wrist, wrist_from_keypoints

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--step", type=int, default=1)
    args = parser.parse_args()
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
    print(f"{'method':>12} {'frames':>16} {'n':>4} {'no cut':>6} {'median':>7} "
          f"{'|d| p90':>7} {'|d|<0.25':>8}")  # fmt: skip
    for name in methods:
        for group, (a, b) in GROUPS.items():
            v = np.array([x for t, x in d[name].items() if a <= t < b])
            cut = v[~np.isnan(v)]
            med = np.median(cut) if cut.size else np.nan
            p90 = np.percentile(np.abs(cut), 90) if cut.size else np.nan
            within = np.mean(np.abs(v) < 0.25)  # no cut counts as a miss
            print(f"{name:>12} {group:>16} {len(v):>4} {int(np.isnan(v).sum()):>6} "
                  f"{med:>7.2f} {p90:>7.2f} {within:>8.0%}")  # fmt: skip


if __name__ == "__main__":
    main()
