"""Frame reading: one camera's colour frames from a video file or an image folder (paper §6).

`open_frames` opens a video file (anything ``cv2.VideoCapture`` decodes) or a folder of
numbered images as a `FrameReader`, which reads the frames lazily, in order, and checks
each one (decodable, 8-bit colour, the size of the first); a worker thread decodes the
next frames while the caller works on this one (`READ_AHEAD`). A video whose
decoding stops before the frame count its container states (truncated or damaged) is
refused with the count read and the count claimed, or, opened with ``allow_short``,
read to where it stops with a `ShortVideoWarning`.

Frame indices count the frames of the recording from 0, whatever ``start`` and
``stop`` select.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from handvar.io import IMAGE_SUFFIXES
from handvar.validate import as_int

__all__ = [
    "IMAGE_SUFFIXES",
    "FrameReader",
    "ShortVideoWarning",
    "check_frame_range",
    "open_frames",
]


class ShortVideoWarning(UserWarning):
    """A video ended before the frame count its container states (``allow_short``)."""


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
    allow_short : bool
        A video that stops decoding before `n_frames` warns (`ShortVideoWarning`)
        instead of raising.
    """

    def __init__(
        self,
        path: Path,
        kind: str,
        size: tuple[int, int],
        n_frames: int,
        fps: float | None,
        files: tuple[Path, ...] = (),
        allow_short: bool = False,
    ) -> None:
        self.path = path
        self.kind = kind
        self.size = size
        self.n_frames = n_frames
        self.fps = fps
        self._files = files
        self.allow_short = allow_short

    def __repr__(self) -> str:
        w, h = self.size
        return f"FrameReader({str(self.path)!r}, {self.kind}, {self.n_frames} frames {w}x{h})"

    @property
    def name(self) -> str:
        """The file or folder name, used in messages."""
        return self.path.name

    @property
    def may_end_early(self) -> bool:
        """A video opened with `allow_short`: its frames may end before `n_frames`."""
        return self.allow_short and self.kind == "video"

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
            If a frame cannot be decoded or has another size than the first, or (unless
            `allow_short`) a video stops before the frames its container states; the
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
        files = [str(f) for f in self._files[start:end]]
        images = _read_ahead(lambda i: cv2.imread(files[i], cv2.IMREAD_COLOR), len(files))
        try:
            for index, image in enumerate(images, start):
                yield index, self._check_frame(image, index, self._files[index])
        finally:
            images.close()

    def _video_frames(self, start: int, stop: int | None):
        cap = cv2.VideoCapture(str(self.path))
        reads = None
        try:
            if not cap.isOpened():
                raise ValueError(f"{self.path}: not a readable video (OpenCV cannot open it)")
            index = 0
            while index < start:  # skip without decoding where the backend allows
                if not cap.grab():
                    self._ended(index, stop)
                    return
                index += 1
            reads = _read_ahead(lambda _: cap.read(), None if stop is None else stop - start)
            for ok, image in reads:
                if not ok:
                    self._ended(index, stop)
                    return
                yield index, self._check_frame(image, index, self.path)
                index += 1
        finally:
            if reads is not None:
                reads.close()  # no read left running on the capture it releases
            cap.release()

    def _ended(self, index: int, stop: int | None) -> None:
        """Decoding stopped at frame `index`: refuse (or warn) if the container says more."""
        wanted = self.n_frames if stop is None else min(stop, self.n_frames)
        if index >= wanted:
            return
        msg = (
            f"{self.path}: decoding stopped after {index} of the {self.n_frames} frames the "
            "container claims (a truncated or damaged video)"
        )
        if not self.allow_short:
            raise ValueError(f"{msg}; --allow-short (allow_short=True) uses the {index} read")
        warnings.warn(f"{msg}; using the {index} read", ShortVideoWarning, stacklevel=3)


#: Frames decoded ahead of the one handed out.
READ_AHEAD = 2


def _read_ahead(read, count: int | None) -> Iterator:
    """``read(0), read(1), …`` (`count` of them, or without end), each called in a
    worker thread `READ_AHEAD` calls ahead of the consumer, in order.

    OpenCV releases the interpreter lock while it decodes, so the next frames are
    decoded on another core while the caller fits this one: an image folder or a video
    of large frames costs the slower of the two per frame, not their sum.  Only the
    decoding runs there; the checks, errors and warnings stay in the caller's thread.
    Stopping early waits for the call in progress (none is left running) and cancels
    the rest.
    """
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="handvar-read")
    pending: deque = deque()
    submitted = 0
    try:
        while True:
            while len(pending) <= READ_AHEAD and (count is None or submitted < count):
                pending.append(pool.submit(read, submitted))
                submitted += 1
            if not pending:
                return
            yield pending.popleft().result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _natural_key(path: Path) -> tuple:
    """Sort key that orders ``frame_2`` before ``frame_10``."""
    parts = re.split(r"(\d+)", path.name)
    return tuple(int(p) if p.isdigit() else p.lower() for p in parts)


def open_frames(path: str | os.PathLike, *, allow_short: bool = False) -> FrameReader:
    """Open a video file or an image folder as one camera's frames.

    Parameters
    ----------
    path : path-like
        A video file (any format ``cv2.VideoCapture`` decodes), or a folder of images
        (`IMAGE_SUFFIXES`), taken in natural order of their names (``2`` before
        ``10``).
    allow_short : bool, keyword-only
        Read a video that stops before the frame count of its container to where it
        stops, with a `ShortVideoWarning` (default: raise `ValueError`).

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
    fps = fps if fps > 0 else None
    return FrameReader(p, "video", size, max(n, 1), fps, allow_short=bool(allow_short))


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
