"""Real video in, overlays out: frame sources, their rig and skin-colour silhouettes (§6).

The paper tracks a real hand filmed by a calibrated stereo pair (section 6). This module
turns such recordings into what the tracker consumes:

- one *frame reader* per camera (`open_frames`): a video file (anything
  ``cv2.VideoCapture`` decodes) or a folder of numbered images, read lazily, one frame
  at a time;
- a *video source* (`open_source`): the readers of all cameras in lockstep with the
  calibrated `Rig` (``Rig.load`` of an OpenCV calibration file), checked against the
  frames (one camera per video, each calibrated for its frames' size);
- per time step, the hand silhouettes of every camera (`VideoSource.silhouettes`):
  Jones–Rehg skin mask, clean-up and, by default, the forearm cut at the wrist
  (`handvar.vision.silhouette`), because the hand model ends at the wrist;
- the model drawn over the real frames (`overlay_frame`) and written as a video
  (`OverlayWriter`: ``cv2.VideoWriter`` with the ``mp4v`` codec, or numbered PNG
  frames when that codec is missing).

Monocular video without a calibration gets an *assumed* camera (`assumed_camera`): a
pinhole at the world origin looking along +z, no distortion, principal point at the
image centre and a horizontal field of view of `SOURCE_DEFAULTS.fov` (60°, typical of
webcams and phone cameras in video mode).  The hand's distance from such a camera is
then only as good as that guess and the assumed hand size: a wider true field of view
puts the hand closer, a larger hand farther away.  Image-plane motion is unaffected.

Frame indices count the frames of the recording from 0, whatever ``start`` and
``step`` select.

Examples
--------
>>> source = open_source(["examples/data/dex-human-hand-video.mp4"], scale=0.5)
... # doctest: +SKIP
>>> for t, images, masks in source.silhouettes(stop=3):  # doctest: +SKIP
...     print(t, masks.shape)
0 (1, 360, 640)
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from handvar.camera import Camera, Rig
from handvar.render.overlay import OverlayWriter, overlay_frame
from handvar.vision.silhouette import silhouettes_from_frames

__all__ = [
    "IMAGE_SUFFIXES",
    "SOURCE_DEFAULTS",
    "FrameReader",
    "OverlayWriter",
    "SourceDefaults",
    "VideoSource",
    "assumed_camera",
    "open_frames",
    "open_source",
    "overlay_frame",
    "scale_camera",
    "scale_rig",
]

#: File name endings of the images an image folder may hold (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm")


@dataclass(frozen=True)
class SourceDefaults:
    """Named defaults of real-video input (paper section 6).

    Attributes
    ----------
    fov : float
        Horizontal field of view, degrees, assumed for a monocular video without a
        calibration file (`assumed_camera`).  60° is typical of laptop webcams and of
        phone cameras filming 16:9 video (about 55–70°); the paper's cameras were
        calibrated, so it gives no value.
    fps : float
        Frame rate assumed for an image folder, or a video that does not state one.
    wrist : bool
        Cut a visible forearm off the silhouettes at the wrist (`cut_wrist`): the hand
        model ends at the wrist, so a forearm left in the silhouette would pull the
        model along it through the filling term C_f.
    codec : str
        FourCC of the overlay video (``mp4v``: MPEG-4 part 2, in OpenCV's own FFmpeg
        build and readable by common players).
    """

    fov: float = 60.0
    fps: float = 30.0
    wrist: bool = True
    codec: str = "mp4v"


SOURCE_DEFAULTS = SourceDefaults()


# --- cameras ---------------------------------------------------------------------------


def _check_size(size, name: str = "size") -> tuple[int, int]:
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (width, height) in pixels; got {size!r}") from None
    if w <= 0 or h <= 0:
        raise ValueError(f"{name}: expected positive (width, height); got {size!r}")
    return w, h


def assumed_camera(size: tuple[int, int], *, fov: float = SOURCE_DEFAULTS.fov) -> Camera:
    """A camera for uncalibrated monocular video, from an assumed field of view.

    The camera sits at the world origin looking along world +z (``R = I``, ``t = 0``),
    image x to the right and y down; square pixels, no distortion, principal point at
    the image centre, and the focal length that gives the horizontal field of view
    `fov`: ``fx = fy = (W / 2) / tan(fov / 2)``.

    Depth is only as good as this guess: the tracker places a hand of the model's size
    at the distance where its image has the observed size, so a focal length off by
    k % puts the hand k % too near or too far (its image position and shape are
    unaffected).

    Parameters
    ----------
    size : (int, int)
        Image (width, height), pixels.
    fov : float, keyword-only
        Horizontal field of view, degrees, in (0, 180).

    Returns
    -------
    Camera

    Examples
    --------
    >>> cam = assumed_camera((1280, 720), fov=60.0)
    >>> round(cam.fx, 1), cam.cx, cam.cy
    (1108.5, 639.5, 359.5)
    """
    w, h = _check_size(size)
    fov = float(fov)
    if not (math.isfinite(fov) and 0.0 < fov < 180.0):
        raise ValueError(f"fov: expected a field of view in (0, 180) degrees; got {fov}")
    f = 0.5 * w / math.tan(math.radians(0.5 * fov))
    return Camera(f, f, (w - 1) / 2.0, (h - 1) / 2.0, size=(w, h))


def scale_camera(camera: Camera, factor: float) -> Camera:
    """The same camera for images resized by `factor` (``cv2.resize``'s pixel grid).

    A pixel centre ``u`` of the original image maps to ``(u + ½)·s − ½`` in the resized
    one, with ``s`` the exact ratio of the integer sizes per axis (``round(W·factor) /
    W``), so ``fx' = s fx`` and ``cx' = (cx + ½) s − ½``.  Distortion acts on
    normalised coordinates and is unchanged, as are R and t.

    Parameters
    ----------
    camera : Camera
    factor : float
        Resize factor, > 0.

    Returns
    -------
    Camera
        With image size ``(round(W·factor), round(H·factor))``.
    """
    factor = float(factor)
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"factor: expected a positive resize factor; got {factor}")
    w, h = camera.size
    w2, h2 = max(1, round(w * factor)), max(1, round(h * factor))
    sx, sy = w2 / w, h2 / h
    return Camera(
        camera.fx * sx,
        camera.fy * sy,
        (camera.cx + 0.5) * sx - 0.5,
        (camera.cy + 0.5) * sy - 0.5,
        dist=camera.dist,
        R=camera.R,
        t=camera.t,
        size=(w2, h2),
    )


def scale_rig(rig: Rig, factor: float) -> Rig:
    """Every camera of `rig` through `scale_camera` (same names)."""
    return Rig(tuple(scale_camera(c, factor) for c in rig), rig.names)


# --- frame readers ---------------------------------------------------------------------


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
    import re

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


# --- several cameras with their rig ----------------------------------------------------


class VideoSource:
    """Synchronised colour frames of one or more cameras with their calibrated rig.

    Created by `open_source`, which checks the calibration against the frames.

    Attributes
    ----------
    readers : tuple of FrameReader
        One per camera, in the rig's order.
    rig : Rig
        The cameras, for the frames as this source delivers them (resized by
        `scale`).
    fps : float
        Frame rate.
    scale : float
        Resize factor applied to every frame before anything else.
    calibrated : bool
        False when the rig is `assumed_camera`'s guess.
    """

    def __init__(
        self,
        readers: tuple[FrameReader, ...],
        rig: Rig,
        fps: float,
        scale: float = 1.0,
        calibrated: bool = True,
    ) -> None:
        self.readers = readers
        self.rig = rig
        self.fps = fps
        self.scale = scale
        self.calibrated = calibrated

    def __repr__(self) -> str:
        w, h = self.image_size
        names = ", ".join(r.name for r in self.readers)
        return (
            f"VideoSource({names}: {self.n_frames} frames at {self.fps:g} fps, "
            f"{len(self.rig)} cameras {w}x{h}{'' if self.calibrated else ', assumed camera'})"
        )

    @property
    def n_frames(self) -> int:
        """Frames of the shortest camera (as far as the containers tell)."""
        return min(r.n_frames for r in self.readers)

    @property
    def n_cameras(self) -> int:
        """Number of cameras."""
        return len(self.readers)

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) of the delivered frames, pixels."""
        return self.rig.cameras[0].size

    @property
    def names(self) -> tuple[str, ...]:
        """The file or folder name of each camera, used in messages."""
        return tuple(r.name for r in self.readers)

    def frames(
        self, start: int = 0, stop: int | None = None, step: int = 1
    ) -> Iterator[tuple[int, list[np.ndarray]]]:
        """Colour frames of every camera, time step by time step.

        Parameters
        ----------
        start, stop, step : int
            Frame range as in ``range(start, stop, step)``; ``stop=None`` reads to the
            end of the shortest recording.

        Yields
        ------
        index : int
            Frame index in the recording.
        images : list of (H, W, 3) uint8 ndarray
            One BGR image per camera, resized by `scale`.
        """
        _check_range(start, stop, step)
        iters = [r.frames(start, stop) for r in self.readers]
        try:
            while True:
                step_frames = []
                for it in iters:
                    item = next(it, None)
                    if item is None:
                        return
                    step_frames.append(item)
                index = step_frames[0][0]
                if (index - start) % step:
                    continue
                images = [self._resize(image) for _, image in step_frames]
                yield index, images
        finally:
            for it in iters:
                it.close()

    def _resize(self, image: np.ndarray) -> np.ndarray:
        if self.scale == 1.0:
            return image
        return cv2.resize(image, self.image_size, interpolation=cv2.INTER_AREA)

    def silhouettes(
        self,
        start: int = 0,
        stop: int | None = None,
        step: int = 1,
        *,
        model=None,
        threshold: float | None = None,
        wrist: bool = SOURCE_DEFAULTS.wrist,
        cleanup: dict | None = None,
    ) -> Iterator[tuple[int, list[np.ndarray], np.ndarray]]:
        """Hand silhouettes of every camera, time step by time step.

        Per camera: skin mask (Jones–Rehg by default), `clean_mask`, and the forearm cut
        at the wrist (`silhouettes_from_frames`).

        Parameters
        ----------
        start, stop, step : int
            Frame range, as in `frames`.
        model : SkinModel or HistogramSkinModel, keyword-only, optional
            Skin classifier; one `SkinModel()` for the whole run by default.
        threshold : float, keyword-only, optional
            Likelihood-ratio threshold Θ (`SkinDefaults.threshold` by default).
        wrist : bool, keyword-only
            Cut a visible forearm off at the wrist (`SourceDefaults.wrist`).
        cleanup : dict, keyword-only, optional
            Keyword arguments of `clean_mask`.

        Yields
        ------
        index : int
            Frame index.
        images : list of (H, W, 3) uint8 ndarray
            The BGR frames.
        masks : (n_cams, H, W) bool ndarray
            The silhouettes.

        Raises
        ------
        EmptySilhouetteError
            (a ValueError) when a camera's silhouette is empty; the message names the
            camera's file and the frame.
        """
        from handvar.vision.skin import SkinModel

        model = SkinModel() if model is None else model
        for index, images in self.frames(start, stop, step):
            masks = silhouettes_from_frames(
                images,
                model,
                threshold=threshold,
                cleanup=cleanup,
                wrist=wrist,
                frame=index,
                cameras=self.names,
            )
            yield index, images, np.stack(masks)

    def to_sequence(
        self,
        start: int = 0,
        stop: int | None = None,
        step: int = 1,
        *,
        rgb: bool = False,
        progress=None,
        **kwargs,
    ):
        """Read a stretch of the recording into a `handvar.io.Sequence` (in memory).

        For `Tracker.track` and ``write_sequence``.  A 1280×720 mask takes 0.9 MB, so
        prefer the streaming `silhouettes` (with `Tracker.step`) for long recordings.

        Parameters
        ----------
        start, stop, step : int
            Frame range, as in `frames`.
        rgb : bool, keyword-only
            Keep the colour frames too (RGB order, as `Sequence` stores them).
        progress : callable, keyword-only, optional
            Wraps the frame iterator (for instance ``tqdm.tqdm``).
        **kwargs
            Passed to `silhouettes` (model, threshold, wrist, cleanup).

        Returns
        -------
        handvar.io.Sequence
            Without ground truth; the provenance names the files, the frame range, the
            scale and whether the camera was assumed.
        """
        from handvar.io import Sequence

        it = self.silhouettes(start, stop, step, **kwargs)
        if progress is not None:
            it = progress(it)
        indices, masks, colour = [], [], []
        for index, images, m in it:
            indices.append(index)
            masks.append(m)
            if rgb:
                colour.append(np.stack([im[:, :, ::-1] for im in images]))
        if not masks:
            raise ValueError(
                f"start: expected a frame range inside the recording "
                f"({self.n_frames} frames); got start={start}, stop={stop}"
            )
        provenance = {
            "source": [str(r.path) for r in self.readers],
            "frames": indices,
            "scale": self.scale,
            "calibrated": self.calibrated,
        }
        return Sequence(
            name=Path(self.readers[0].path).stem,
            fps=self.fps / step,
            rig=self.rig,
            masks=np.stack(masks),
            rgb=np.stack(colour) if rgb else None,
            provenance=provenance,
        )


def _check_range(start: int, stop: int | None, step: int) -> None:
    ints = all(
        isinstance(v, int | np.integer) and not isinstance(v, bool)
        for v in (start, step, 0 if stop is None else stop)
    )
    if not ints or start < 0 or step < 1 or (stop is not None and stop < start):
        raise ValueError(
            f"start, stop, step: expected a forward frame range; got {(start, stop, step)}"
        )


def open_source(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    calibration: str | os.PathLike | Rig | None = None,
    *,
    fov: float | None = None,
    scale: float = 1.0,
    fps: float | None = None,
) -> VideoSource:
    """Open synchronised recordings, one per camera, with their calibration.

    Parameters
    ----------
    paths : path-like or sequence of path-like
        One video file or image folder per camera, in the order of the calibration's
        cameras.
    calibration : path-like or Rig, optional
        An OpenCV calibration file (`Rig.load`: the ``cameras`` layout, the stereo
        ``K1 D1 K2 D2 R T`` layout or a single ``camera_matrix``) or a `Rig`.  Without
        one, a single recording gets `assumed_camera` (see the module notes on depth).
    fov : float, keyword-only, optional
        Horizontal field of view (degrees) of the assumed camera
        (`SourceDefaults.fov`); only without `calibration`.
    scale : float, keyword-only
        Resize every frame by this factor before anything else (0.5 halves the work of
        the skin model and the tracker); the rig is scaled to match.
    fps : float, keyword-only, optional
        Frame rate; by default the first video's, else `SourceDefaults.fps`.

    Returns
    -------
    VideoSource

    Raises
    ------
    ValueError
        One line naming the file at fault: a recording that cannot be read, a
        calibration with another number of cameras than recordings, a camera
        calibrated for another image size than its frames, recordings of different
        sizes without calibration, several recordings without calibration.
    FileNotFoundError
        If the calibration file does not exist.
    """
    if isinstance(paths, str | os.PathLike):
        paths = [paths]
    paths = list(paths)
    if not paths:
        raise ValueError("paths: expected one video file or image folder per camera; got none")
    scale = float(scale)
    if not (math.isfinite(scale) and 0.0 < scale <= 4.0):
        raise ValueError(f"scale: expected a resize factor in (0, 4]; got {scale}")
    readers = tuple(open_frames(p) for p in paths)
    if calibration is None:
        if len(readers) != 1:
            raise ValueError(
                f"calibration: expected a calibration file for {len(readers)} cameras "
                "(only a single video may go without); got none"
            )
        fov = SOURCE_DEFAULTS.fov if fov is None else fov
        rig = Rig((assumed_camera(readers[0].size, fov=fov),), ("cam0",))
        calibrated = False
        where = "assumed camera"
    else:
        if fov is not None:
            raise ValueError("fov: expected no field of view with a calibration; got both")
        if isinstance(calibration, Rig):
            rig, where = calibration, "calibration"
        else:
            rig, where = Rig.load(calibration), str(calibration)
        calibrated = True
        if len(rig) != len(readers):
            raise ValueError(
                f"{where}: calibrates {len(rig)} camera(s) ({', '.join(rig.names)}); "
                f"got {len(readers)} recording(s) ({', '.join(r.name for r in readers)})"
            )
    for reader, name, cam in zip(readers, rig.names, rig.cameras, strict=True):
        if tuple(cam.size) != tuple(reader.size):
            raise ValueError(
                f"{reader.path}: frames are {reader.size[0]}x{reader.size[1]} pixels; camera "
                f"{name!r} of {where} is calibrated for {cam.size[0]}x{cam.size[1]}"
            )
    if scale != 1.0:
        rig = scale_rig(rig, scale)
    if fps is None:
        fps = next((r.fps for r in readers if r.fps), SOURCE_DEFAULTS.fps)
    fps = float(fps)
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate; got {fps}")
    return VideoSource(readers, rig, fps, scale, calibrated)
