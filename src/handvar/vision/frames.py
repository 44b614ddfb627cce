"""Frame reading: one camera's colour frames from a video file or an image folder (paper §6).

`open_frames` opens a video file (anything ``cv2.VideoCapture`` decodes) or a folder of
numbered images as a `FrameReader`, which reads the frames lazily, one at a time, and
checks each one (decodable, 8-bit colour, the size of the first).

Frame indices count the frames of the recording from 0, whatever ``start`` and
``stop`` select.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from handvar.io import IMAGE_SUFFIXES
from handvar.validate import as_int

__all__ = ["IMAGE_SUFFIXES", "FrameReader", "check_frame_range", "open_frames"]


class FrameReader:
    """The colour frames of one camera: a video file or a folder of images, read lazily.

    Use `open_frames` to create one; it checks that the first frame can be decoded.

    Attributes
    ----------
    path : Path
        The video file or image folder.
    kind : {"video", "folder"}
    size : (int, int)
        Frame (width, height), pixels.
    n_frames : int
        Number of frames: the images of a folder, or the count the video's container
        states (OpenCV's estimate; reading stops at the true end either way).
    fps : float or None
        Frame rate stated by the video; None for a folder or when it states none.
    """

    def __init__(
        self,
        path: Path,
        kind: str,
        size: tuple[int, int],
        n_frames: int,
        fps: float | None,
        files: tuple[Path, ...] = (),
    ) -> None:
        self.path = path
        self.kind = kind
        self.size = size
        self.n_frames = n_frames
        self.fps = fps
        self._files = files

    def __repr__(self) -> str:
        w, h = self.size
        return f"FrameReader({str(self.path)!r}, {self.kind}, {self.n_frames} frames {w}x{h})"

    @property
    def name(self) -> str:
        """The file or folder name, used in messages."""
        return self.path.name

    def frames(self, start: int = 0, stop: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """Frames ``start, start + 1, …`` up to `stop` (exclusive) or the end.

        Yields
        ------
        index : int
            Frame index in the recording.
        image : (H, W, 3) uint8 ndarray
            The frame, BGR (OpenCV's order).

        Raises
        ------
        ValueError
            If a frame cannot be decoded or has another size than the first; the
            message names the file and the frame.
        """
        if self.kind == "folder":
            yield from self._folder_frames(start, stop)
        else:
            yield from self._video_frames(start, stop)

    def _check_frame(self, image: np.ndarray | None, index: int, where: Path) -> np.ndarray:
        if image is None:
            raise ValueError(f"{where}: frame {index} is not a readable image")
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        elif image.shape[2] == 4:
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        if image.dtype != np.uint8:
            raise ValueError(f"{where}: frame {index}: expected 8-bit colour; got {image.dtype}")
        size = (image.shape[1], image.shape[0])
        if size != self.size:
            raise ValueError(
                f"{where}: frame {index} is {size[0]}x{size[1]} pixels; expected "
                f"{self.size[0]}x{self.size[1]} like frame 0"
            )
        return image

    def _folder_frames(self, start: int, stop: int | None):
        end = len(self._files) if stop is None else min(stop, len(self._files))
        for index in range(start, end):
            file = self._files[index]
            yield index, self._check_frame(cv2.imread(str(file), cv2.IMREAD_COLOR), index, file)

    def _video_frames(self, start: int, stop: int | None):
        cap = cv2.VideoCapture(str(self.path))
        try:
            if not cap.isOpened():
                raise ValueError(f"{self.path}: not a readable video (OpenCV cannot open it)")
            index = 0
            while index < start:  # skip without decoding where the backend allows
                if not cap.grab():
                    return
                index += 1
            while stop is None or index < stop:
                ok, image = cap.read()
                if not ok:
                    return
                yield index, self._check_frame(image, index, self.path)
                index += 1
        finally:
            cap.release()


def _natural_key(path: Path) -> tuple:
    """Sort key that orders ``frame_2`` before ``frame_10``."""
    parts = re.split(r"(\d+)", path.name)
    return tuple(int(p) if p.isdigit() else p.lower() for p in parts)


def open_frames(path: str | os.PathLike) -> FrameReader:
    """Open a video file or an image folder as one camera's frames.

    Parameters
    ----------
    path : path-like
        A video file (any format ``cv2.VideoCapture`` decodes), or a folder of images
        (`IMAGE_SUFFIXES`), taken in natural order of their names (``2`` before
        ``10``).

    Returns
    -------
    FrameReader

    Raises
    ------
    ValueError
        If `path` does not exist, the video cannot be opened or its first frame
        decoded, or the folder holds no image; the message names the path.
    """
    p = Path(path)
    if p.is_dir():
        files = tuple(
            sorted(
                (f for f in p.iterdir() if f.is_file() and f.suffix.lower() in IMAGE_SUFFIXES),
                key=_natural_key,
            )
        )
        if not files:
            raise ValueError(
                f"{p}: expected a folder of images ({', '.join(IMAGE_SUFFIXES)}); it holds none"
            )
        first = cv2.imread(str(files[0]), cv2.IMREAD_COLOR)
        if first is None:
            raise ValueError(f"{files[0]}: frame 0 is not a readable image")
        size = (first.shape[1], first.shape[0])
        return FrameReader(p, "folder", size, len(files), None, files)
    if not p.is_file():
        raise ValueError(f"{p}: no such video file or image folder")
    cap = cv2.VideoCapture(str(p))
    try:
        ok, first = cap.read() if cap.isOpened() else (False, None)
        if not ok or first is None:
            raise ValueError(
                f"{p}: not a readable video (OpenCV cannot open it or decode its first frame)"
            )
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        fps = float(cap.get(cv2.CAP_PROP_FPS))
    finally:
        cap.release()
    size = (first.shape[1], first.shape[0])
    return FrameReader(p, "video", size, max(n, 1), fps if fps > 0 else None)


def check_frame_range(start, stop, step) -> tuple[int, int | None, int]:
    """``(start, stop, step)`` of a forward frame range, checked, as Python ints.

    Examples
    --------
    >>> check_frame_range(2, None, 3)
    (2, None, 3)
    """
    start = as_int(start, "start", minimum=0)
    step = as_int(step, "step", minimum=1)
    if stop is not None:
        stop = as_int(stop, "stop", minimum=start)
    return start, stop, step
