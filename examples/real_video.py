"""Track a real hand in a monocular video: silhouettes, keypoints, recovery, overlays.

The video ``examples/data/dex-human-hand-video.mp4`` (1280×720, 30 fps, a right hand
with the palm towards the camera, forearm visible; MIT licence, see
``examples/data/README.md``) has no calibration, so the camera is the assumed one of
`handvar.vision.sources.assumed_camera` (60° horizontal field of view): the hand's
distance is only as good as that guess and the model's 185 mm hand length.

Steps:

All of it is one call, `handvar.track` (as ``handvar track`` makes it on a recording):

1. skin-colour silhouettes of every frame at half resolution (``--scale 0.5``), the
   forearm cut at the wrist: at the detected wrist on the frames with keypoints
   (MediaPipe's, shipped as ``dex-human-hand-video-keypoints.npy``; used on every
   ``--keypoint-every``-th frame only, as from a detector at a fraction of the frame
   rate, and carried to the frames between by optical flow, `handvar.vision.carry`,
   design §14.5), else at the wrist of the model fitted to the previous frame (without
   keypoints: where the forearm's width changes);
2. the first frame's pose from its keypoints (`handvar.tracking.init.initial_pose`);
3. tracking with the paper's RVAR predictor and the library's recovery
   (`handvar.tracking.recovery.track_with_recovery`, design §14.3): a poor fit is
   refined, and a frame whose fit is lost (silhouette IoU below 0.75, or joints more
   than 0.3 hand sizes from the keypoints) or drifting from its keypoints is searched
   again and the predictor restarted there;
4. outputs in ``--out`` (`handvar.Track.save`, as ``handvar track --out``):
   ``poses.csv`` (T × 26, mm and degrees), ``joints.csv`` (T × 63, mm, camera frame),
   ``quality.csv`` (per frame: IoU, keypoint error, cost, lost, re-initialised, empty,
   keypoints), ``cameras.yml``, ``track.npz``, ``overlay.png`` and ``overlay.mp4`` (the
   model over the colour frames, the frame's quality in a line, red when lost); and in
   ``--images`` two PNG strips for the README: evenly spaced frames
   (``real-video-strip.png``) and the hard frames ``--hard``
   (``real-video-hard-frames.png``: the fist, the hand edge-on).

Run from the repository root::

    .venv/bin/python examples/real_video.py            # the whole video, a minute or two
    .venv/bin/python examples/real_video.py --frames 30 --out /tmp/rv --images /tmp/rv
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np

import handvar
from handvar.data import example_path
from handvar.render import silhouettes
from handvar.render.overlay import overlay_frame
from handvar.tracking.outputs import quality_captions
from handvar.vision.sources import open_source

ROOT = Path(__file__).resolve().parent.parent
VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")


def crop_box(masks: list[np.ndarray], pad: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1): a box around every silhouette in `masks`, grown by `pad` px."""
    union = np.logical_or.reduce(masks)
    rows = np.flatnonzero(union.any(axis=1))
    cols = np.flatnonzero(union.any(axis=0))
    h, w = union.shape
    return (
        max(int(cols[0]) - pad, 0),
        max(int(rows[0]) - pad, 0),
        min(int(cols[-1]) + pad + 1, w),
        min(int(rows[-1]) + pad + 1, h),
    )


def label(image: np.ndarray, text: str, *, alert: bool = False) -> np.ndarray:
    """Write `text` in the top-left corner of a BGR image (a copy), red when `alert`."""
    out = image.copy()
    colour = (60, 60, 255) if alert else (255, 255, 255)
    cv2.putText(out, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(out, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv2.LINE_AA)
    return out


def make_strip(video, hand, poses, picked, *, height: int, captions, lost) -> np.ndarray:
    """One row of full-resolution overlays of the picked frames, `height` px tall.

    `picked` maps a frame index to its observed silhouette at tracking resolution; the
    fitted pose is drawn through the camera at full resolution (the assumed camera of
    the unscaled video, of which the tracking camera is the scaled copy).
    """
    full = open_source(video)
    w, h = full.image_size
    views, boxes = [], []
    for t, images in full.frames(stop=max(picked) + 1):
        if t not in picked:
            continue
        observed = cv2.resize(picked[t].astype(np.float32), (w, h)) > 0.5
        model = silhouettes(hand, poses[t], full.rig)[0]
        boxes.append(crop_box([observed, model], pad=24))
        picture = overlay_frame(images, full.rig, hand, poses[t], observed[None], thickness=3)
        views.append((t, picture))
    x0, y0 = min(b[0] for b in boxes), min(b[1] for b in boxes)
    x1, y1 = max(b[2] for b in boxes), max(b[3] for b in boxes)
    out = []
    for t, picture in views:
        tile = picture[y0:y1, x0:x1]
        f = height / tile.shape[0]
        tile = cv2.resize(tile, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
        out.append(label(tile, f"{t}: {captions[t]}", alert=bool(lost[t])))
        out.append(np.full((tile.shape[0], 3, 3), 255, np.uint8))
    return np.concatenate(out[:-1], axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--video", type=Path, default=VIDEO)
    parser.add_argument("--keypoints", type=Path, default=KEYPOINTS,
                        help="2D keypoints of the video (.npy or .csv)")  # fmt: skip
    parser.add_argument("--keypoint-every", type=int, default=5,
                        help="use the keypoints of every K-th frame (0: none)")  # fmt: skip
    parser.add_argument("--carry", choices=("forward", "both", "none"), default="forward",
                        help="carry the keypoints between detections (design §14.5)")  # fmt: skip
    parser.add_argument("--tips", choices=("end", "pad"), default="pad",
                        help="model point of a detected fingertip (design §14.6)")  # fmt: skip
    parser.add_argument("--frames", type=int, default=None, help="frames to track [all]")
    parser.add_argument("--scale", type=float, default=0.5, help="resize factor of the frames")
    parser.add_argument("--seed", type=int, default=0, help="seed of the optimiser")
    parser.add_argument("--out", type=Path, default=ROOT / "examples" / "output" / "real_video")
    parser.add_argument("--images", type=Path, default=ROOT / "docs" / "images")
    parser.add_argument("--strip", type=int, default=6, help="frames in the PNG strip")
    parser.add_argument("--hard", default="262,266,270,275,510,560",
                        help="frames of the hard-frames strip (comma-separated)")  # fmt: skip
    parser.add_argument("--tile-height", type=int, default=240, help="strip height, pixels")
    args = parser.parse_args()
    args.images.mkdir(parents=True, exist_ok=True)

    n = open_source(args.video).n_frames
    n = n if args.frames is None else min(args.frames, n)
    picks = set(np.linspace(0, n - 1, args.strip).round().astype(int).tolist())
    hard = {int(t) for t in args.hard.split(",") if t and int(t) < n}
    picked: dict[int, np.ndarray] = {}  # the silhouettes fitted in the strips' frames

    def keep(t, pose, quality, masks):
        if t in picks | hard:
            picked[t] = masks[0]

    clock = time.perf_counter()
    track = handvar.track(
        args.video, keypoints=args.keypoints if args.keypoint_every else None,
        keypoint_every=max(args.keypoint_every, 1),
        carry=args.carry if args.keypoint_every else None, keypoint_tips=args.tips,
        scale=args.scale, seed=args.seed, frames=args.frames, on_frame=keep, progress=True,
    )  # fmt: skip
    written = track.save(args.out)
    seconds = time.perf_counter() - clock
    print(f"track -> {args.out} ({', '.join(sorted(p for p in written if p != 'video_error'))})")

    q, hand = track.quality, track.hand
    with_detection = np.zeros(n, dtype=bool) if track.detections is None else track.detections
    # PNG strips: the picked frames at full resolution (the same poses drawn through the
    # camera scaled back up), cropped to one box around the hand, one row.
    captions = [
        text + ("  detected" if k else "")
        for text, k in zip(quality_captions(q), with_detection, strict=True)
    ]
    for name, chosen in (("real-video-strip.png", picks), ("real-video-hard-frames.png", hard)):
        if not chosen:
            continue
        strip = make_strip(
            args.video, hand, track.poses, {t: picked[t] for t in chosen},
            height=args.tile_height, captions=captions, lost=q.lost,
        )  # fmt: skip
        path = args.images / name
        cv2.imwrite(str(path), strip, [cv2.IMWRITE_PNG_COMPRESSION, 9])
        print(f"strip -> {path} ({path.stat().st_size // 1024} KB)")

    T = track.n_frames
    print(f"{T} frames: {q.summary()}; {seconds:.1f} s (silhouettes, tracking, overlays)")


if __name__ == "__main__":
    main()
