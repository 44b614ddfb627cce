"""Track a real hand in a monocular video: silhouettes, initial pose, RVAR tracking, overlays.

The video ``examples/data/dex-human-hand-video.mp4`` (1280×720, 30 fps, a right hand
with the palm towards the camera, forearm visible; MIT licence, see
``examples/data/README.md``) has no calibration, so the camera is the assumed one of
`handvar.vision.sources.assumed_camera` (60° horizontal field of view): the hand's
distance is only as good as that guess and the model's 185 mm hand length.

Steps:

1. skin-colour silhouettes of every frame, the forearm cut at the wrist
   (`VideoSource.silhouettes`), at half resolution (``--scale 0.5``);
2. the first frame's pose by the coarse search of `handvar.tracking.init.initial_pose`;
3. tracking with the paper's RVAR predictor (γ = 0.8, cutoff 8), frame by frame; when
   the fit's silhouette IoU falls below ``--reinit`` (0.5) the track is taken as lost
   and the pose is searched again in that frame (step 2);
4. outputs in ``--out``: ``poses.csv`` (T × 26, mm and degrees), ``joints.csv``
   (T × 63, mm, camera frame), ``iou.csv`` (per-frame silhouette IoU of the fit) and
   ``overlay.mp4`` (the model's outline in yellow, its joints and bones, the observed
   silhouette's outline in light blue, over the real frames); and in ``--images`` a
   PNG strip of evenly spaced frames for the README.

Run from the repository root::

    .venv/bin/python examples/real_video.py            # 150 frames, about a minute
    .venv/bin/python examples/real_video.py --frames 30 --out /tmp/rv
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import cv2
import numpy as np

from handvar.hand import HandModel
from handvar.params import NAMES
from handvar.predictors import RVAR
from handvar.render import silhouettes
from handvar.render.overlay import OverlayWriter, overlay_frame
from handvar.tracking.init import initial_pose, silhouette_iou
from handvar.tracking.tracker import Tracker
from handvar.vision.sources import open_source

ROOT = Path(__file__).resolve().parent.parent
VIDEO = ROOT / "examples" / "data" / "dex-human-hand-video.mp4"


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


def label(image: np.ndarray, text: str) -> np.ndarray:
    """Write `text` in the top-left corner of a BGR image (a copy)."""
    out = image.copy()
    cv2.putText(out, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(out, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def track_frame(tracker: Tracker, masks: np.ndarray) -> tuple[np.ndarray, float]:
    """Track one frame; the pose and its silhouette IoU (0 if the optimiser diverged)."""
    try:
        pose = tracker.step(masks).pose
    except ValueError:  # a lost track can drive the optimiser to non-finite values
        return np.full(26, np.nan), 0.0
    model = silhouettes(tracker.hand, pose, tracker.rig)
    return pose, silhouette_iou(model, masks)


def make_strip(video, hand, poses, picked, *, height: int, ious) -> np.ndarray:
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
        out.append(label(tile, f"frame {t}  IoU {ious[t]:.2f}"))
        out.append(np.full((tile.shape[0], 3, 3), 255, np.uint8))
    return np.concatenate(out[:-1], axis=1)


def write_csv(path: Path, array: np.ndarray, header: str, fmt: str) -> None:
    """Write a CSV to a temporary name and rename it into place."""
    tmp = path.with_name(f".{path.name}.tmp")
    np.savetxt(tmp, array, delimiter=",", header=header, comments="", fmt=fmt)
    os.replace(tmp, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--video", type=Path, default=VIDEO)
    parser.add_argument("--frames", type=int, default=150, help="frames to track")
    parser.add_argument("--scale", type=float, default=0.5, help="resize factor of the frames")
    parser.add_argument("--seed", type=int, default=0, help="seed of the optimiser")
    parser.add_argument("--out", type=Path, default=ROOT / "examples" / "output" / "real_video")
    parser.add_argument("--images", type=Path, default=ROOT / "docs" / "images")
    parser.add_argument(
        "--reinit", type=float, default=0.5,
        help="search the pose again when a frame's silhouette IoU falls below this (0: never)",
    )  # fmt: skip
    parser.add_argument("--strip", type=int, default=6, help="frames in the PNG strip")
    parser.add_argument("--tile-height", type=int, default=240, help="strip height, pixels")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    args.images.mkdir(parents=True, exist_ok=True)

    source = open_source(args.video, scale=args.scale)
    print(source)
    hand = HandModel()
    rng = np.random.default_rng(args.seed)
    tracker = Tracker(source.rig, hand, RVAR(gamma=0.8, cutoff=8), rng)

    # Frames of the strip: evenly spaced over the tracked stretch.
    n = min(args.frames, source.n_frames)
    picks = set(np.linspace(0, n - 1, args.strip).round().astype(int).tolist())
    poses, ious, picked, reinits = [], [], {}, []
    seconds = {"silhouettes": 0.0, "init": 0.0, "tracking": 0.0, "overlay": 0.0}
    clock = time.perf_counter()
    with OverlayWriter(args.out / "overlay.mp4", source.fps) as video:
        for t, images, masks in source.silhouettes(stop=n):
            t1 = time.perf_counter()
            seconds["silhouettes"] += t1 - clock
            if t == 0:
                init = initial_pose(masks, source.rig, hand, rng=rng)
                print(
                    f"initial pose: IoU {init.iou:.3f} (search {init.search_iou:.3f}, "
                    f"shape {init.shape}, {init.n_candidates} candidates)"
                )
                tracker.reset(init.pose)
                t2 = time.perf_counter()
                seconds["init"] += t2 - t1
                t1 = t2
            pose, iou = track_frame(tracker, masks)
            t2 = time.perf_counter()
            seconds["tracking"] += t2 - t1
            if iou < args.reinit:  # lost: search the pose again in this frame
                init = initial_pose(masks, source.rig, hand, rng=rng)
                tracker.reset(init.pose)
                pose, iou = track_frame(tracker, masks)
                if not np.all(np.isfinite(pose)):  # diverged again: keep the search's pose
                    pose, iou = init.pose, init.iou
                    tracker.reset(pose)
                reinits.append(t)
                t1, t2 = t2, time.perf_counter()
                seconds["init"] += t2 - t1
            poses.append(pose)
            ious.append(iou)
            picture = overlay_frame(images, source.rig, hand, pose, masks)
            video.write(label(picture, f"frame {t}  IoU {ious[-1]:.2f}"))
            if t in picks:
                picked[t] = masks[0]
            clock = time.perf_counter()
            seconds["overlay"] += clock - t2
    print(f"overlay video -> {video.path_written} ({video.n_frames} frames)")

    poses_arr = np.array(poses)
    joints = np.stack([hand.joints(x) for x in poses_arr])
    T = len(poses_arr)
    write_csv(args.out / "poses.csv", poses_arr, ",".join(NAMES), "%.6f")
    jheader = ",".join(f"j{j}_{c}" for j in range(21) for c in "xyz")
    write_csv(args.out / "joints.csv", joints.reshape(T, -1), jheader, "%.4f")
    write_csv(args.out / "iou.csv", np.column_stack([np.arange(T), ious]), "frame,iou", "%g")

    # PNG strip: the picked frames at full resolution (the same poses drawn through the
    # camera scaled back up), cropped to one box around the hand, one row.
    strip = make_strip(args.video, hand, poses_arr, picked, height=args.tile_height, ious=ious)
    strip_path = args.images / "real-video-strip.png"
    cv2.imwrite(str(strip_path), strip, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"strip -> {strip_path} ({strip_path.stat().st_size // 1024} KB)")

    ious_arr = np.array(ious)
    print(
        f"{T} frames: silhouette IoU of the fit mean {ious_arr.mean():.3f}, "
        f"median {np.median(ious_arr):.3f}, min {ious_arr.min():.3f} "
        f"(frame {int(ious_arr.argmin())}); frames with IoU < 0.7: "
        f"{int((ious_arr < 0.7).sum())}; re-initialised at frames {reinits or 'none'}"
    )
    total = sum(seconds.values())
    print(
        "seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in seconds.items()) + f", total {total:.1f}"
    )


if __name__ == "__main__":
    main()
