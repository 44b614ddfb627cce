"""Overlays: the model's outline and skeleton drawn over frames, and overlay videos.

- `draw_overlay`: the 21 joints and bones (and a silhouette's outline) on one image;
  `side_by_side`: views of one height next to each other under title bars;
- `overlay_views` / `overlay_frame`: the model at a pose drawn over the frames of every
  camera (its rendered outline, joints and bones);
- `OverlayWriter`: frames written as a video (``cv2.VideoWriter`` with the ``mp4v``
  codec) or, when that codec is missing, as numbered PNGs, replacing an existing output
  only by a complete one; `write_overlay_video`: a whole track through it.

Images are RGB unless a name says BGR (`overlay_frame` and `OverlayWriter` speak BGR, as
OpenCV's readers and writers do).
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import cv2
import numpy as np

from handvar.atomic import temporary_name, write_png
from handvar.camera import Camera, Rig
from handvar.hand.anthropometry import JOINT_DIGIT
from handvar.render.silhouettes import silhouettes
from handvar.validate import as_array, as_float, as_instance

__all__ = [
    "SKELETON",
    "VIDEO_CODEC",
    "OverlayWriter",
    "caption",
    "draw_overlay",
    "overlay_frame",
    "overlay_views",
    "side_by_side",
    "write_overlay_video",
]

# Bones of the 21-point layout (design §2): wrist 0; thumb 1-4; index 5-8;
# middle 9-12; ring 13-16; little 17-20 (MCP/CMC, PIP/MCP, DIP/IP, tip).
SKELETON: tuple[tuple[int, int], ...] = (
    (0, 1), (1, 2), (2, 3), (3, 4),
    (0, 5), (5, 6), (6, 7), (7, 8),
    (0, 9), (9, 10), (10, 11), (11, 12),
    (0, 13), (13, 14), (14, 15), (15, 16),
    (0, 17), (17, 18), (18, 19), (19, 20),
    (5, 9), (9, 13), (13, 17),
)  # fmt: skip

# Overlay colours (RGB) per digit: thumb, index, middle, ring, little; palm links grey.
_DIGIT_RGB = ((230, 60, 60), (240, 170, 30), (60, 200, 60), (40, 140, 240), (190, 80, 220))
_PALM_RGB = (200, 200, 200)
_OBSERVED_RGB = (0, 200, 255)  # outline of the observed silhouette: light blue

#: FourCC code of overlay videos.
VIDEO_CODEC = "mp4v"


def draw_overlay(
    image: np.ndarray,
    camera: Camera,
    joints,
    mask: np.ndarray | None = None,
    *,
    thickness: int = 2,
    colour: tuple[int, int, int] | None = None,
) -> np.ndarray:
    """Draw the 21 joints and the bones (and optionally a mask outline) on an image.

    Parameters
    ----------
    image : (H, W, 3) uint8 or (H, W) bool/uint8 ndarray
        RGB image, or a mask / grey image (drawn as grey).
    camera : Camera
        Camera of the image.
    joints : (21, 3) array_like or None
        Joint positions, mm (world); None draws none (a frame without a hand).
    mask : (H, W) bool ndarray, optional
        A silhouette whose outline is drawn in yellow (e.g. the model's).
    thickness : int, optional
        Line thickness, pixels.
    colour : (int, int, int), keyword-only, optional
        RGB of every bone (one hand of two told apart); the joints keep their digits'
        colours.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        A new RGB image; digits are coloured thumb red, index orange, middle green,
        ring blue, little purple.
    """
    img = np.asarray(image)
    if img.ndim == 2:
        grey = (img.astype(np.uint8) * 160) if img.dtype == bool else img.astype(np.uint8)
        img = np.repeat(grey[:, :, None], 3, axis=2)
    elif img.ndim == 3 and img.shape[2] == 3:
        img = img.astype(np.uint8).copy()
    else:
        raise ValueError(f"image: expected (H, W) or (H, W, 3); got shape {img.shape}")
    if (img.shape[1], img.shape[0]) != camera.size:
        raise ValueError(
            f"image: expected size {camera.size} (width, height) of the camera; "
            f"got {(img.shape[1], img.shape[0])}"
        )
    if joints is not None:
        joints = as_array(joints, "joints", (21, 3))
    img = np.ascontiguousarray(img)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.shape != img.shape[:2]:
            raise ValueError(f"mask: expected shape {img.shape[:2]}; got {mask.shape}")
        contours, _ = cv2.findContours(
            mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
        )
        cv2.drawContours(img, contours, -1, (255, 230, 0), 1, cv2.LINE_AA)
    if joints is None:
        return img
    shift = 4
    px = camera.project(joints)
    finite = np.all(np.isfinite(px), axis=1) & (np.abs(px) < 1e5).all(axis=1)
    pts = np.rint(np.where(finite[:, None], px, 0.0) * (1 << shift)).astype(np.int64)
    for i, j in SKELETON:
        if not (finite[i] and finite[j]):
            continue
        bone = _PALM_RGB if (i != 0 and j - i != 1) else _DIGIT_RGB[JOINT_DIGIT[max(i, j)]]
        bone = bone if colour is None else colour
        cv2.line(img, tuple(pts[i]), tuple(pts[j]), bone, thickness, cv2.LINE_AA, shift)
    for i in range(21):
        if finite[i]:
            dot = (255, 255, 255) if i == 0 else _DIGIT_RGB[JOINT_DIGIT[i]]
            cv2.circle(img, tuple(pts[i]), (thickness + 2) << shift, dot, -1, cv2.LINE_AA, shift)
    return img


def side_by_side(images, titles=None, *, gap: int = 4, bar: int = 28) -> np.ndarray:
    """Put RGB images of one height next to each other, each under a title bar.

    Parameters
    ----------
    images : sequence of (H, W, 3) uint8 ndarray
    titles : sequence of str, optional
        One title per image (ASCII), drawn in white on the dark bar above it.
    gap : int, optional
        Dark gap between images, pixels.
    bar : int, optional
        Height of the title bar, pixels (0 for none).

    Returns
    -------
    (H + bar, sum(W) + gap · (n − 1), 3) uint8 ndarray
    """
    images = [np.asarray(im) for im in images]
    if not images or any(im.ndim != 3 or im.shape[2] != 3 for im in images):
        raise ValueError("images: expected one or more (H, W, 3) images")
    h = images[0].shape[0]
    if any(im.shape[0] != h for im in images):
        raise ValueError(f"images: expected one height; got {[im.shape[0] for im in images]}")
    titles = [""] * len(images) if titles is None else list(titles)
    if len(titles) != len(images):
        raise ValueError(f"titles: expected {len(images)} titles; got {len(titles)}")
    panels = []
    for k, (im, title) in enumerate(zip(images, titles, strict=True)):
        panel = np.full((h + bar, im.shape[1], 3), 24, dtype=np.uint8)
        panel[bar:] = im
        if bar and title:
            cv2.putText(panel, title, (8, bar - 9), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
                        (255, 255, 255), 1, cv2.LINE_AA)  # fmt: skip
        panels.append(panel)
        if gap and k < len(images) - 1:
            panels.append(np.full((h + bar, gap, 3), 24, dtype=np.uint8))
    return np.concatenate(panels, axis=1)


def caption(image: np.ndarray, text: str, *, alert: bool = False) -> np.ndarray:
    """A copy of the RGB `image` with one small line of ASCII `text` at its foot.

    White on a dark outline, or red when `alert` (a lost frame).
    """
    out = np.array(image, dtype=np.uint8, copy=True)
    scale = max(0.35, min(0.6, out.shape[0] / 900))
    org = (6, out.shape[0] - 8)
    colour = (255, 60, 60) if alert else (255, 255, 255)
    cv2.putText(out, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(out, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)
    return out


def overlay_views(hand, rig: Rig, backgrounds, pose, *, thickness: int = 2) -> list[np.ndarray]:
    """RGB views of one frame: the model's outline and joints at `pose` over `backgrounds`.

    Parameters
    ----------
    hand : HandModel
    rig : Rig
        The cameras of the frame.
    backgrounds : (n_cams, H, W) bool array_like or sequence of (H, W, 3) uint8 ndarray
        Masks, or one RGB image per camera.
    pose : (26,) array_like
        Pose, mm and degrees.
    thickness : int, keyword-only
        Line thickness of the bones, pixels.

    Returns
    -------
    list of (H, W, 3) uint8 ndarray
        One RGB view per camera (`draw_overlay`); a pose that is not finite (a frame
        without a hand, a dropped frame before the first) draws no model.
    """
    if not np.all(np.isfinite(np.asarray(pose, dtype=float))):
        return [draw_overlay(b, cam, None) for b, cam in zip(backgrounds, rig, strict=True)]
    model = silhouettes(hand, pose, rig)
    joints = hand.landmarks(pose)
    return [
        draw_overlay(b, cam, joints, mask=m, thickness=thickness)
        for b, cam, m in zip(backgrounds, rig, model, strict=True)
    ]


def overlay_frame(
    images: Sequence[np.ndarray] | np.ndarray,
    rig: Rig,
    hand,
    pose,
    masks: np.ndarray | None = None,
    *,
    titles: Sequence[str] | None = None,
    thickness: int = 2,
) -> np.ndarray:
    """The model at `pose` drawn over the frames of every camera, side by side.

    Per camera: the outline of the observed silhouette (light blue, if `masks` is
    given), the outline of the model's rendered silhouette (yellow) and its 21 joints
    and bones (`draw_overlay`).

    Parameters
    ----------
    images : sequence of (H, W, 3) uint8 ndarray
        One BGR frame per camera (a single ndarray of 3 dimensions is one camera).
    rig : Rig
        The cameras of the frames.
    hand : HandModel
    pose : (26,) array_like
        Pose, mm and degrees.
    masks : (n_cams, H, W) bool array_like, optional
        The observed silhouettes.
    titles : sequence of str, keyword-only, optional
        One title per camera, drawn above its view.
    thickness : int, keyword-only
        Line thickness of the bones, pixels.

    Returns
    -------
    (H', W', 3) uint8 ndarray
        BGR image (ready for ``cv2.imwrite`` or a video writer).
    """
    if isinstance(images, np.ndarray) and images.ndim == 3:
        images = [images]
    images = list(images)
    if len(images) != len(rig):
        raise ValueError(f"images: expected {len(rig)} frames (one per camera); got {len(images)}")
    backgrounds = []
    for j, image in enumerate(images):
        rgb = np.ascontiguousarray(np.asarray(image)[:, :, ::-1])
        if masks is not None:
            observed = np.asarray(masks[j]).astype(np.uint8)
            contours, _ = cv2.findContours(observed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            cv2.drawContours(rgb, contours, -1, _OBSERVED_RGB, 1, cv2.LINE_AA)
        backgrounds.append(rgb)
    views = overlay_views(hand, rig, backgrounds, pose, thickness=thickness)
    if len(views) == 1 and titles is None:
        out = views[0]
    else:
        out = side_by_side(views, titles if titles is not None else list(rig.names))
    return np.ascontiguousarray(out[:, :, ::-1])


class OverlayWriter:
    """Write overlay frames as a video, or as numbered PNGs when the codec is missing.

    The video is written with ``cv2.VideoWriter`` and `VIDEO_CODEC` (``mp4v``) to a
    temporary name beside `path` (`handvar.atomic.temporary_name`) and renamed into
    place by `close`, so an existing file is replaced only by a complete one. If OpenCV
    cannot open a writer for that codec, the frames go to the folder
    ``<path without suffix>_frames/`` as ``frame_00000.png``, … instead (renamed into
    place the same way); `path_written` says which. Use as a context manager.

    Parameters
    ----------
    path : path-like
        Output video, e.g. ``overlay.mp4``.
    fps : float
        Frame rate of the video.
    codec : str, keyword-only
        FourCC code, four characters.

    Examples
    --------
    >>> with OverlayWriter("overlay.mp4", 30.0) as out:  # doctest: +SKIP
    ...     out.write(overlay_frame(images, rig, hand, pose, masks))
    """

    def __init__(self, path: str | os.PathLike, fps: float, *, codec: str = VIDEO_CODEC) -> None:
        self.path = Path(path)
        self.fps = as_float(fps, "fps", minimum=0.0, exclusive_minimum=True)
        as_instance(codec, str, "codec", what="a four-character FourCC code")
        if len(codec) != 4:
            raise ValueError(f"codec: expected a four-character FourCC code; got {codec!r}")
        if not self.path.parent.is_dir():
            raise ValueError(f"path: expected a file in an existing folder; got {self.path}")
        self.codec = codec
        self.path_written: Path | None = None
        self.n_frames = 0
        self._writer: cv2.VideoWriter | None = None
        self._tmp: Path | None = None
        self._size: tuple[int, int] | None = None
        self._png_dir: Path | None = None

    def __enter__(self) -> OverlayWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def _open(self, size: tuple[int, int]) -> None:
        tmp = temporary_name(self.path)
        self._tmp = Path(tmp)
        writer = cv2.VideoWriter(tmp, cv2.VideoWriter_fourcc(*self.codec), self.fps, size)
        if writer.isOpened():
            self._writer = writer
            return
        writer.release()
        self._tmp.unlink(missing_ok=True)
        self._tmp = None
        self._png_dir = Path(temporary_name(self._frames_dir(), directory=True))

    def _frames_dir(self) -> Path:
        return self.path.with_name(self.path.stem + "_frames")

    def write(self, image: np.ndarray) -> None:
        """Append one BGR frame (H, W, 3) uint8; every frame must have the first's size."""
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(
                f"image: expected an (H, W, 3) uint8 BGR frame; got {image.dtype} {image.shape}"
            )
        size = (image.shape[1], image.shape[0])
        if self._size is None:
            self._size = size
            self._open(size)
        elif size != self._size:
            raise ValueError(
                f"image: expected {self._size} (width, height) like frame 0; got {size}"
            )
        if self._writer is not None:
            self._writer.write(np.ascontiguousarray(image))
        else:
            file = self._png_dir / f"frame_{self.n_frames:05d}.png"
            write_png(file, image)
        self.n_frames += 1

    def close(self) -> Path | None:
        """Finish and move the output into place; returns it (None if nothing was written)."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None
            os.replace(self._tmp, self.path)
            self._tmp = None
            self.path_written = self.path
        elif self._png_dir is not None:
            target = self._frames_dir()
            if target.exists():
                shutil.rmtree(target)
            os.replace(self._png_dir, target)
            self._png_dir = None
            self.path_written = target
        return self.path_written

    def abort(self) -> None:
        """Drop what was written; an existing output is left as it was."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None
        if self._tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                self._tmp.unlink()
            self._tmp = None
        if self._png_dir is not None:
            shutil.rmtree(self._png_dir, ignore_errors=True)
            self._png_dir = None


def write_overlay_video(
    path: str | os.PathLike,
    hand,
    rig: Rig,
    poses,
    backgrounds: Callable[[list[int]], Iterable[tuple[int, Sequence[np.ndarray] | np.ndarray]]],
    fps: float,
    *,
    captions: Sequence[str] | None = None,
    alerts: Sequence[bool] | None = None,
) -> Path | None:
    """Every pose of a track drawn over its frame, all cameras side by side, as a video.

    Parameters
    ----------
    path : path-like
        Output video (`OverlayWriter`: numbered PNGs in ``<stem>_frames/`` when the
        codec is missing).
    hand : HandModel
    rig : Rig
        The cameras, whose names title the views.
    poses : (T, 26) array_like
        One pose per frame, mm and degrees.
    backgrounds : callable
        ``backgrounds(frames)`` yields ``(t, images)`` for the frame indices
        ``0, …, T − 1``: the masks or RGB images the model is drawn over.
    fps : float
        Frame rate of the video.
    captions : sequence of str, keyword-only, optional
        One line per frame (its fit quality), written at the foot of every view.
    alerts : sequence of bool, keyword-only, optional
        Per frame: draw its caption in red (a lost frame).

    Returns
    -------
    Path or None
        What was written (the video or the folder of PNGs).
    """
    with OverlayWriter(path, fps) as writer:
        for t, images in backgrounds(list(range(len(poses)))):
            views = overlay_views(hand, rig, images, poses[t])
            if captions is not None:
                alert = alerts is not None and bool(alerts[t])
                views = [caption(v, captions[t], alert=alert) for v in views]
            writer.write(cv2.cvtColor(side_by_side(views, list(rig.names)), cv2.COLOR_RGB2BGR))
    return writer.path_written
