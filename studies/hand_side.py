"""A left hand on real video: the example video mirrored, tracked with the left hand model.

The example video shows a right hand.  Mirrored (every frame flipped left to right, the
detector's keypoints with it) it shows a left hand moving as the right one did, so the
left hand model (`HandShape.mirrored`, design §2) should track the mirrored video as the
right model tracks the original, mirrored: with the assumed camera (principal point at
the image centre) flipping the image maps a camera-frame point (x, y, z) to (−x, y, z).
With one camera the silhouette and the 2D keypoints cannot tell the sides apart (a
right hand seen from the back projects like a left hand seen from the front), so the
check is in 3D: the mean distance of the 21 joints, relative to the wrist, between each
track of the mirrored video (mirrored back) and the track of the original.

Each track is `handvar.track`'s on a recording (as `handvar track`'s): half resolution,
RVAR, seed 0, keypoints on every 5th frame carried between (design §14.5), fingertips at the
pads (design §14.6), recovery.
The mirrored video is written as Motion-JPEG at quality 100 into a temporary folder.

Run: ``PYTHONPATH=src .venv/bin/python studies/hand_side.py`` (``--frames N`` for the
first N frames only).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import cv2
import numpy as np

import handvar
from handvar.data import example_path
from handvar.vision.keypoints import Keypoints2D, read_keypoints

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")


def mirror(folder: Path, frames: int | None) -> tuple[Path, Keypoints2D]:
    """The example video and its keypoints flipped left to right, in `folder`."""
    cap = cv2.VideoCapture(str(VIDEO))
    fps = cap.get(cv2.CAP_PROP_FPS)
    width = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
    height = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    path = folder / "mirrored.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (width, height))
    writer.set(cv2.VIDEOWRITER_PROP_QUALITY, 100)
    n = 0
    while frames is None or n < frames:
        ok, image = cap.read()
        if not ok:
            break
        writer.write(np.ascontiguousarray(image[:, ::-1]))
        n += 1
    cap.release()
    writer.release()
    detected = read_keypoints(KEYPOINTS).to_array()
    detected[..., 0] = (width - 1) - detected[..., 0]  # pixel centres at integers
    return path, Keypoints2D.from_array(detected)


def track_side(video: Path, keypoints: Keypoints2D, side: str, frames: int | None):
    """Joints (T, 21, 3) and `TrackQuality` of `handvar track`'s run on a recording."""
    result = handvar.track(
        video, keypoints=keypoints, keypoint_every=5, hand=side, scale=0.5, frames=frames
    )
    return result.joints, result.quality


def relative_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per frame and joint, ‖(a − a_wrist) − (b − b_wrist)‖, mm."""
    return np.linalg.norm((a - a[:, :1]) - (b - b[:, :1]), axis=2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=None, help="only the first N frames")
    args = parser.parse_args()
    flip = np.array([-1.0, 1.0, 1.0])
    original, q = track_side(VIDEO, read_keypoints(KEYPOINTS), "right", args.frames)
    print(f"original video, right hand model: {q.summary()}")
    with tempfile.TemporaryDirectory() as folder:
        video, keypoints = mirror(Path(folder), args.frames)
        for side in ("left", "right"):
            joints, q = track_side(video, keypoints, side, args.frames)
            d = relative_distance(joints * flip, original)
            print(
                f"mirrored video, {side} hand model: {q.summary()}; joints relative to the "
                f"wrist, mirrored back, from the original's: mean {d.mean():.1f} mm, "
                f"median {np.median(d):.1f} mm"
            )


if __name__ == "__main__":
    main()
