"""The initial pose on the example video with and without its keypoints (design §14.1).

For a few frames of ``examples/data/dex-human-hand-video.mp4`` (open hand, the fist,
edge-on), `handvar.tracking.init.initial_pose` from the silhouette alone and with the
shipped MediaPipe keypoints (``dex-human-hand-video-keypoints.npy``; the forearm then
cut at the detected wrist, else by the forearm heuristic).  Prints the
silhouette IoU, the mean distance of the 21 projected joints to the keypoints (pixels
and hand sizes: the keypoints' wrist → middle-MCP distance) and the seconds taken.

Run: ``PYTHONPATH=src .venv/bin/python studies/keypoint_init.py [--scale 0.5]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from handvar.data import example_path
from handvar.hand import HandModel
from handvar.tracking.init import initial_pose
from handvar.tracking.keypoint_fit import keypoint_error
from handvar.vision.keypoints import read_keypoints
from handvar.vision.sources import open_source
from handvar.vision.wrist import cut_wrist

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")
FRAMES = (0, 100, 262, 510, 560)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", type=float, default=1.0)
    parser.add_argument("--frames", type=lambda s: [int(v) for v in s.split(",")],
                        default=list(FRAMES))  # fmt: skip
    args = parser.parse_args()
    hand = HandModel()
    source = open_source(VIDEO, scale=args.scale)
    kp = read_keypoints(KEYPOINTS).scaled(args.scale, (1280, 720))
    print(f"example video at scale {args.scale}: initial pose without / with keypoints")
    print(f"{'frame':>5} {'method':>10} {'IoU':>6} {'kp err px':>10} {'hand sizes':>10} {'s':>6}")
    for t in args.frames:
        _, _, masks = next(source.silhouettes(t, t + 1, wrist=False))
        k = kp.frame(t)
        size = float(np.linalg.norm(k[9, :2] - k[0, :2]))
        for label, kps in (("silhouette", None), ("keypoints", [k])):
            t0 = time.perf_counter()
            # as `handvar init`: the wrist cut at the detected wrist with keypoints
            cut = np.stack([cut_wrist(m, None if kps is None else kps[0]) for m in masks])
            res = initial_pose(cut, source.rig, hand, keypoints=kps,
                               rng=np.random.default_rng(0))  # fmt: skip
            dt = time.perf_counter() - t0
            err = keypoint_error(res.pose, hand, source.rig, [k])
            print(f"{t:>5} {label:>10} {res.iou:>6.3f} {err:>10.1f} {err / size:>10.2f} {dt:>6.1f}")


if __name__ == "__main__":
    main()
