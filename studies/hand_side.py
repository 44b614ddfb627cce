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

``--detector``: the one command's way instead (``handvar.track(VIDEO, scale=0.5)``,
MediaPipe inside, keypoints on every frame, the side from its handedness), on the
original and on the mirrored video, and on the mirrored video with the original run's
detections mirrored (its 2D points and world landmarks, labelled left): per run the
keypoint check (frames failing it, keypoints rejected) and the fitted hand's digit
lengths (base joint to tip, mm); and MediaPipe's own points on the mirrored video
against the original's mirrored (hand sizes; frames it labels right).  The fit is the
same on a mirrored hand if the third run matches the first; MediaPipe is if its points
match.  ``--shape-stride S``: every run with `ShapeFitSettings.stride` S.
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
    detected = read_keypoints(KEYPOINTS).to_array()[:frames]
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


def detector_runs(frames: int | None, stride: int) -> None:
    """The `--detector` comparison (module notes)."""
    from dataclasses import replace

    from handvar.tracking.recovery import RECOVERY_DEFAULTS
    from handvar.tracking.shape_fit import SHAPE_FIT_DEFAULTS

    recovery = replace(RECOVERY_DEFAULTS, shape=replace(SHAPE_FIT_DEFAULTS, stride=stride))

    def run(label: str, video, **given):
        track = handvar.track(video, scale=0.5, frames=frames, recovery=recovery, **given)
        q = track.quality
        failing = np.flatnonzero(q.failing_frames(frames=q.keypoints))
        digits = track.shape.segments.sum(axis=1)
        print(f"{label}: {track.shape.side} hand; keypoint check fails on {len(failing)} of "
              f"{int(q.keypoints.sum())} frames {failing.tolist()[:12]}"
              f"{' ...' if len(failing) > 12 else ''}; {int(q.rejected.sum())} keypoints "
              f"rejected; digits (thumb to little, base to tip) "
              f"{', '.join(f'{v:.0f}' for v in digits)} mm", flush=True)  # fmt: skip
        return track

    original = run("original video", VIDEO)
    found = original.detected[0]
    width = original.rig.cameras[0].size[0]
    with tempfile.TemporaryDirectory() as folder:
        video, _ = mirror(Path(folder), frames)
        mirrored = run("mirrored video, MediaPipe on it", video)
        xy = found.xy.copy()
        xy[..., 0] = (width - 1) - xy[..., 0]
        world = None if found.world is None else found.world * np.array([-1.0, 1.0, 1.0])
        flipped = replace(
            found,
            xy=xy,
            world=world,
            handedness=np.where(found.handedness == "right", "left", "right"),
        )
        run("mirrored video, the original's detections mirrored", video, keypoints=flipped)
    own = mirrored.detected[0]
    size = np.linalg.norm(xy[:, 9] - xy[:, 0], axis=-1)
    d = np.linalg.norm(own.xy - xy, axis=-1) / size[:, None]
    print(f"MediaPipe on the mirrored video against the original's points mirrored: median "
          f"{np.nanmedian(d):.3f}, 90th percentile {np.nanpercentile(d, 90):.3f}, largest "
          f"{np.nanmax(d):.2f} hand sizes; labelled right on "
          f"{int((own.handedness == 'right').sum())} frames")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=None, help="only the first N frames")
    parser.add_argument("--detector", action="store_true", help="the one command's way")
    parser.add_argument("--shape-stride", type=int, default=1, metavar="S")
    args = parser.parse_args()
    if args.detector:
        detector_runs(args.frames, args.shape_stride)
        return
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
