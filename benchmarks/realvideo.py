"""Speed of the real-video path: reading + silhouettes, the initial pose, tracking.

On the example video (``examples/data/dex-human-hand-video.mp4``, 1280×720, monocular,
assumed camera), at full and half resolution; and the initial-pose search on the
paper's synthetic stereo rig.  Prints medians (the machine is shared: single runs are
noisy).

Run: ``.venv/bin/python benchmarks/realvideo.py``
"""

from __future__ import annotations

import time

import numpy as np

from handvar.camera import Rig
from handvar.data import example_path
from handvar.hand import HandModel, named_pose
from handvar.predictors import RVAR
from handvar.render import silhouettes
from handvar.tracking.init import initial_pose
from handvar.tracking.tracker import Tracker
from handvar.vision.sources import open_source

VIDEO = example_path("video")


def silhouettes_ms(scale: float, n: int = 60) -> tuple[float, list[np.ndarray]]:
    """Median time per frame of decoding + resizing + skin mask + clean-up + wrist cut."""
    source = open_source(VIDEO, scale=scale)
    times, masks = [], []
    it = source.silhouettes(stop=n)
    while True:
        t0 = time.perf_counter()
        item = next(it, None)
        if item is None:
            break
        times.append(time.perf_counter() - t0)
        masks.append(item[2])
    return 1e3 * float(np.median(times[1:])), masks  # the first builds the skin table


def main() -> None:
    hand = HandModel()
    print("real video, monocular 1280x720, assumed 60 deg camera")
    for scale in (1.0, 0.5):
        ms, masks = silhouettes_ms(scale)
        rig = open_source(VIDEO, scale=scale).rig
        init_s = []
        for _ in range(3):
            t0 = time.perf_counter()
            result = initial_pose(masks[0], rig, hand, rng=np.random.default_rng(0))
            init_s.append(time.perf_counter() - t0)
        tracker = Tracker(rig, hand, RVAR(), np.random.default_rng(0))
        tracker.reset(result.pose)
        steps = [tracker.step(m) for m in masks]
        track_ms = 1e3 * np.median([s.seconds.sum() for s in steps[1:]])
        its = np.median([s.iterations for s in steps])
        print(
            f"  scale {scale:g}: silhouettes {ms:6.1f} ms/frame | initial pose "
            f"{np.median(init_s):5.2f} s (IoU {result.iou:.3f}) | tracking {track_ms:5.1f} "
            f"ms/frame ({its:.0f} iterations median)"
        )
    rig = Rig.default()
    truth = named_pose("pinch")
    truth[:6] = [20.0, 90.0, -10.0, 165.0, -20.0, 40.0]
    masks = silhouettes(hand, truth, rig)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        result = initial_pose(masks, rig, hand, rng=np.random.default_rng(0))
        times.append(time.perf_counter() - t0)
    err = np.linalg.norm(hand.joints(result.pose) - hand.joints(truth), axis=1).mean()
    print(
        f"synthetic stereo 2x640x480: initial pose {np.median(times):.2f} s "
        f"({result.n_candidates} candidates, IoU {result.iou:.3f}, joint error {err:.1f} mm)"
    )


if __name__ == "__main__":
    main()
