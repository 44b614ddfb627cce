"""Tracking an image folder of large frames: the frames decoded ahead, and one at a time.

The first frames of the example video are written as a folder of 1920×1080 images (PNG,
or JPEG with ``--jpeg``; upscaled from its 1280×720), its keypoints scaled to them, and
tracked as ``handvar track FOLDER --scale 1/3 --keypoints …`` tracks them (640×360, one
camera, keypoints on every frame, the first pose from the keypoints; ``--scale 0.5``:
960×540, as ``--scale 0.5`` on a 1920×1080 recording).  Printed: the
time to decode one frame, and the all-in ms per frame of the track (median and mean
over the frames after the first ten, which hold the first fit and the shape fit) with
the frames read ahead in a worker thread (`handvar.vision.frames.READ_AHEAD`, the
default) and read one at a time in the tracker's thread.  Both tracks give the same
poses (checked).

    python benchmarks/frame_reading.py [--frames 120] [--jpeg] [--scale 0.5]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

import handvar.vision.frames as frames_module
from handvar import track
from handvar.data import example_path
from handvar.vision.keypoints import read_keypoints


def _one_at_a_time(read, count):
    i = 0
    while count is None or i < count:
        yield read(i)
        i += 1


def _timed(folder: Path, keypoints, scale: float) -> tuple[np.ndarray, np.ndarray]:
    stamps: list[float] = []
    start = time.perf_counter()
    tr = track(str(folder), keypoints=keypoints, scale=scale, keypoint_every=1,
               on_frame=lambda *_: stamps.append(time.perf_counter()))  # fmt: skip
    return 1e3 * np.diff([start, *stamps]), tr.poses


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--jpeg", action="store_true", help="JPEG frames instead of PNG")
    parser.add_argument("--scale", type=float, default=1 / 3, help="the tracking scale")
    args = parser.parse_args()
    suffix = ".jpg" if args.jpeg else ".png"
    detected = read_keypoints(example_path("video-keypoints"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "frames"
        folder.mkdir()
        cap = cv2.VideoCapture(str(example_path("video")))
        for t in range(args.frames):
            ok, image = cap.read()
            if not ok:
                break
            big = cv2.resize(image, (1920, 1080), interpolation=cv2.INTER_CUBIC)
            cv2.imwrite(str(folder / f"{t:05d}{suffix}"), big)
        cap.release()
        n = len(list(folder.iterdir()))
        keypoints = detected.scaled(1.5)
        keypoints = type(keypoints)(keypoints.xy[:n], keypoints.confidence[:n], "kp.npy")
        file = str(folder / f"00000{suffix}")
        clock = time.perf_counter()
        for _ in range(10):
            cv2.imread(file, cv2.IMREAD_COLOR)
        decode = 1e2 * (time.perf_counter() - clock)
        track(str(folder), keypoints=keypoints, scale=args.scale, frames=2)  # start-up apart
        ahead, poses = _timed(folder, keypoints, args.scale)
        original = frames_module._read_ahead
        frames_module._read_ahead = _one_at_a_time
        try:
            single, poses_single = _timed(folder, keypoints, args.scale)
        finally:
            frames_module._read_ahead = original
    same = np.array_equal(poses, poses_single, equal_nan=True)
    w, h = round(1920 * args.scale), round(1080 * args.scale)
    print(f"{n} frames of 1920x1080 {suffix[1:].upper()}, tracked at {w}x{h}; "
          f"decoding one frame: {decode:.1f} ms; the same poses both ways: {same}")  # fmt: skip
    for label, ms in (("read ahead (default)", ahead), ("read one at a time", single)):
        rest = ms[10:]
        print(f"{label:22s} ms/frame all-in: median {np.median(rest):5.1f}, mean "
              f"{rest.mean():5.1f} ({1e3 / rest.mean():.0f} frames/s)")  # fmt: skip


if __name__ == "__main__":
    main()
