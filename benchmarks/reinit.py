"""The time of a re-initialisation from keypoints (`handvar.tracking.frame_fit.reinitialise`).

A lost keypoint fit is fitted again directly from the frame's keypoints: the
perspective-n-point palm poses of each camera, four per camera, each fitted without a
prior, the best kept (docs/keypoint-fit.md, rule 2).  Timed here on every frame with a
detection of the three real videos (their MediaPipe keypoints, one camera, frames at 640
px on the long side as `handvar track` resizes them, the assumed camera, a right hand of
185 mm): median, 95th percentile and largest ms per call, and the mean keypoint error of
the pose found (hand sizes), whose median says the fits land on the hand.

    python benchmarks/reinit.py
"""

from __future__ import annotations

import time

import numpy as np

from handvar.camera import Rig
from handvar.data import example_path
from handvar.hand import HandModel
from handvar.tracking.frame_fit import reinitialise
from handvar.vision.keypoints import read_keypoints
from handvar.vision.sources import assumed_camera, open_source

VIDEOS = ("video", "fingerspelling", "counting")


def main() -> None:
    hand = HandModel()
    first = read_keypoints(example_path("video-keypoints")).frame(0)
    reinitialise([first], Rig([assumed_camera((1280, 720))]), hand)  # kernels loaded first
    print("video | frames timed | ms per call: median | 95th percentile | largest | "
          "keypoint error of the pose found: median (hand sizes)")  # fmt: skip
    for name in VIDEOS:
        w, h = open_source(example_path(name)).image_size
        scale = 640.0 / max(w, h)
        kp = read_keypoints(example_path(f"{name}-keypoints")).scaled(scale)
        rig = Rig([assumed_camera((round(w * scale), round(h * scale)))])
        seconds, errors = [], []
        for t in np.flatnonzero(kp.present.any(axis=1)):
            start = time.perf_counter()
            fit = reinitialise([kp.frame(t)], rig, hand)
            seconds.append(time.perf_counter() - start)
            errors.append(np.nan if fit is None else fit.error)
        ms = 1e3 * np.array(seconds)
        print(f"{name} | {len(ms)} | {np.median(ms):.1f} | {np.percentile(ms, 95):.1f} | "
              f"{ms.max():.1f} | {np.nanmedian(errors):.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
