"""Speed of skin masks, silhouette clean-up and keypoint carrying on 1280×720 frames.

Prints medians (milliseconds) over repeated runs on frames of the example video
(``examples/data/dex-human-hand-video.mp4``); falls back to random frames if it cannot
be read.  The carrying of the 21 keypoints by optical flow (`handvar.vision.carry`,
design §14.5) is timed on 60 consecutive frames, at full and half resolution, from the
detected keypoints of the first.  Target (design §10 and the vision part): skin mask of
a 1280×720 frame ≤ 10 ms; the one-off table build is printed separately.

Run: ``.venv/bin/python benchmarks/vision.py``
"""

from __future__ import annotations

import time

import cv2
import numpy as np

from handvar.data import example_path
from handvar.vision import SkinModel, clean_mask, cut_wrist, silhouettes_from_frames
from handvar.vision.carry import KeypointCarrier
from handvar.vision.keypoints import read_keypoints

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")


def carry_ms(scale: float, n: int = 60) -> float:
    """Median ms of `KeypointCarrier.step` over `n` consecutive frames (frame 0 detected)."""
    frames = load_frames(n, skip=0)
    frames = [cv2.resize(f, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) for f in frames]
    detected = read_keypoints(KEYPOINTS)
    first = detected.scaled(scale, (1280, 720)).frame(0)
    times = []
    for _ in range(5):
        carrier = KeypointCarrier()
        carrier.step(frames[0], first)
        for f in frames[1:]:
            t0 = time.perf_counter()
            carrier.step(f)
            times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def load_frames(n: int = 20, skip: int = 25) -> list[np.ndarray]:
    """`n` frames of the example video, `skip` frames apart."""
    cap = cv2.VideoCapture(str(VIDEO))
    frames = []
    while len(frames) < n:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
        for _ in range(skip):
            cap.grab()
    cap.release()
    if not frames:
        rng = np.random.default_rng(0)
        frames = [rng.integers(0, 256, (720, 1280, 3), dtype=np.uint8) for _ in range(n)]
    return frames


def median_ms(func, frames, repeats: int = 10) -> float:
    times = []
    for _ in range(repeats):
        for f in frames:
            t0 = time.perf_counter()
            func(f)
            times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def main() -> None:
    frames = load_frames()
    print(f"frames: {len(frames)} × {frames[0].shape[1]}×{frames[0].shape[0]}")
    for bins in (32, 64, 128, 256):
        model = SkinModel(bins=bins)
        t0 = time.perf_counter()
        model.table  # noqa: B018 - builds and caches the lookup table
        build = 1e3 * (time.perf_counter() - t0)
        model.mask(frames[0])  # builds the boolean table for the default threshold
        mask = median_ms(model.mask, frames)
        print(f"bins={bins:3d}: table build {build:7.1f} ms   mask (LUT) median {mask:6.2f} ms")
    model = SkinModel()
    model.mask(frames[0])
    clean = median_ms(lambda f: clean_mask(model.mask(f)), frames)
    print(f"mask + clean_mask      median {clean:6.2f} ms")
    print(
        "mask + clean + wrist   median "
        f"{median_ms(lambda f: cut_wrist(clean_mask(model.mask(f))), frames):6.2f} ms"
    )
    print(
        "silhouettes_from_frames, 2 cameras, median "
        f"{median_ms(lambda f: silhouettes_from_frames([f, f], model), frames):6.2f} ms"
    )
    small = [cv2.resize(f, (640, 480)) for f in frames]
    print(
        "640×480 (paper's cameras) mask + clean median "
        f"{median_ms(lambda f: clean_mask(model.mask(f)), small):6.2f} ms"
    )
    print(
        f"keypoints carried by optical flow, per frame: 1280×720 median {carry_ms(1.0):.2f} ms, "
        f"640×360 median {carry_ms(0.5):.2f} ms"
    )


if __name__ == "__main__":
    main()
