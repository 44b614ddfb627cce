"""Real video in: frame sources, their rig and skin-colour silhouettes (design §9).

The paper tracks a real hand filmed by a calibrated stereo pair (section 6). This module
turns such recordings into what the tracker consumes:

- one *frame reader* per camera (`open_frames`, in :mod:`handvar.vision.frames`): a
  video file (anything ``cv2.VideoCapture`` decodes) or a folder of numbered images,
  read lazily, one frame at a time;
- a *video source* (`open_source`): the readers of all cameras in lockstep with the
  calibrated `Rig` (``Rig.load`` of an OpenCV calibration file), checked against the
  frames (one camera per video, each calibrated for its frames' size);
- per time step, the hand silhouettes of every camera (`VideoSource.silhouettes`):
  Jones–Rehg skin mask, clean-up and, by default, the forearm cut at the wrist
  (`handvar.vision.silhouette`), because the hand model ends at the wrist.

The model drawn over the frames and written as a video lives beside the renderer
(:mod:`handvar.render.overlay`).

Monocular video without a calibration gets an *assumed* camera (`assumed_camera`,
`Camera.assumed`): a
pinhole at the world origin looking along +z, no distortion, principal point at the
image centre and a horizontal field of view of `SOURCE_SETTINGS.fov` (60°, typical of
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

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from handvar.camera import Camera, Rig
from handvar.validate import as_float, as_instance
from handvar.vision.frames import IMAGE_SUFFIXES, FrameReader, check_frame_range, open_frames

__all__ = [
    "IMAGE_SUFFIXES",
    "SOURCE_SETTINGS",
    "CameraSource",
    "FrameReader",
    "SourceSettings",
    "VideoSource",
    "assumed_camera",
    "frame_silhouettes",
    "open_camera",
    "open_frames",
    "open_source",
]


@dataclass(frozen=True)
class SourceSettings:
    """Named settings of real-video input (paper section 6).

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
    """

    fov: float = 60.0
    fps: float = 30.0
    wrist: bool = True


SOURCE_SETTINGS = SourceSettings()


def assumed_camera(size: tuple[int, int], *, fov: float = SOURCE_SETTINGS.fov) -> Camera:
    """The camera assumed for an uncalibrated monocular video: `Camera.assumed`.

    Parameters
    ----------
    size : (int, int)
        Image (width, height), pixels.
    fov : float, keyword-only
        Horizontal field of view, degrees, in (0, 180) (`SourceSettings.fov`).

    Returns
    -------
    Camera

    Examples
    --------
    >>> cam = assumed_camera((1280, 720))
    >>> round(cam.fx, 1), cam.cx, cam.cy
    (1108.5, 639.5, 359.5)
    """
    return Camera.assumed(size, fov=fov)


def frame_silhouettes(
    images: Sequence[np.ndarray],
    model,
    *,
    index: int,
    names: Sequence[str],
    threshold: float | None = None,
    cleanup: dict | None = None,
    wrist: bool = SOURCE_SETTINGS.wrist,
    keypoints=None,
    allow_empty: bool = False,
    near=None,
) -> np.ndarray:
    """The hand silhouettes of one time step, one per camera (`VideoSource.silhouettes`).

    Parameters
    ----------
    images : sequence of (H, W, 3) uint8 ndarray
        One BGR frame per camera.
    model : SkinModel or HistogramSkinModel
        Skin classifier.
    index : int, keyword-only
        Frame index, for messages.
    names : sequence of str, keyword-only
        The cameras' file names, for messages.
    threshold, cleanup, wrist : keyword-only
        As in `VideoSource.silhouettes`.
    keypoints : sequence of (21, 3) array_like or None, keyword-only, optional
        Per camera this frame's keypoints in the frames' pixels (or None).
    allow_empty : bool, keyword-only
        An empty silhouette instead of `EmptySilhouetteError`.
    near : (n_cams, H, W) array_like, keyword-only, optional
        Where the hand is expected in each camera (the tracked model's predicted
        silhouettes): the skin components there are kept rather than the largest
        (`handvar.vision.silhouette.clean_mask`).

    Returns
    -------
    (n_cams, H, W) bool ndarray
    """
    from handvar.vision.silhouette import EmptySilhouetteError, silhouettes_from_frames

    masks = []
    for j, image in enumerate(images):
        try:
            masks += silhouettes_from_frames(
                [image], model, threshold=threshold, cleanup=cleanup, wrist=wrist,
                frame=index, cameras=[names[j]],
                keypoints=None if keypoints is None else [keypoints[j]],
                near=None if near is None else [near[j]],
            )  # fmt: skip
        except EmptySilhouetteError:
            if not allow_empty:
                raise
            masks.append(np.zeros(image.shape[:2], dtype=bool))
    return np.stack(masks)


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
    full_rig : Rig
        The cameras, for the frames as read (before `scale`).
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
        full_rig: Rig | None = None,
    ) -> None:
        self.readers = readers
        self.rig = rig
        self.full_rig = rig if full_rig is None else full_rig
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
        self, start: int = 0, stop: int | None = None, step: int = 1, *, originals: bool = False
    ) -> Iterator[tuple]:
        """Colour frames of every camera, time step by time step.

        Parameters
        ----------
        start, stop, step : int
            Frame range as in ``range(start, stop, step)``; ``stop=None`` reads to the
            end of the shortest recording.
        originals : bool, keyword-only
            Also yield the full-resolution images (for a keypoint detector).

        Yields
        ------
        index : int
            Frame index in the recording.
        images : list of (H, W, 3) uint8 ndarray
            One BGR image per camera, resized by `scale`.
        originals : list of (H, W, 3) uint8 ndarray
            With `originals`: the images as read.
        """
        start, stop, step = check_frame_range(start, stop, step)
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
                if originals:
                    yield index, images, [image for _, image in step_frames]
                else:
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
        wrist: bool = SOURCE_SETTINGS.wrist,
        cleanup: dict | None = None,
        keypoints=None,
        allow_empty: bool = False,
    ) -> Iterator[tuple[int, list[np.ndarray], np.ndarray]]:
        """Hand silhouettes of every camera, time step by time step.

        Per camera: skin mask (Jones–Rehg by default), `clean_mask`, and the forearm cut
        at the wrist (`silhouettes_from_frames`): at the detected wrist on a frame with
        keypoints, else where the forearm's width changes.

        Parameters
        ----------
        start, stop, step : int
            Frame range, as in `frames`.
        model : SkinModel or HistogramSkinModel, keyword-only, optional
            Skin classifier; one `SkinModel()` for the whole run by default.
        threshold : float, keyword-only, optional
            Likelihood-ratio threshold Θ (`SkinSettings.threshold` by default).
        wrist : bool, keyword-only
            Cut a visible forearm off at the wrist (`SourceSettings.wrist`).
        cleanup : dict, keyword-only, optional
            Keyword arguments of `clean_mask`.
        keypoints : sequence of Keypoints2D or None, keyword-only, optional
            Per camera, its 2D keypoints in the pixels of the recording (full
            resolution; `handvar.vision.keypoints.read_keypoints`), or None for a camera
            without.  A frame past their end, or without the wrist and middle MCP, is
            cut by the silhouette alone.
        allow_empty : bool, keyword-only
            Yield an empty silhouette instead of raising `EmptySilhouetteError`.

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
        scaled = self.scaled_keypoints(keypoints)
        for index, images in self.frames(start, stop, step):
            kps = None
            if scaled is not None:
                kps = [None if k is None or index >= k.n_frames else k.frame(index) for k in scaled]
            masks = frame_silhouettes(
                images, model, index=index, names=self.names, threshold=threshold,
                cleanup=cleanup, wrist=wrist, keypoints=kps, allow_empty=allow_empty,
            )  # fmt: skip
            yield index, images, masks

    def scaled_keypoints(self, keypoints):
        """Per-camera keypoints mapped to the delivered frames' pixels (or None)."""
        from handvar.vision.keypoints import Keypoints2D

        if keypoints is None:
            return None
        keypoints = list(keypoints)
        if len(keypoints) != self.n_cameras:
            raise ValueError(
                f"keypoints: expected one Keypoints2D (or None) per camera, "
                f"{self.n_cameras} in all; got {len(keypoints)}"
            )
        out = []
        for reader, k in zip(self.readers, keypoints, strict=True):
            if k is not None:
                as_instance(k, Keypoints2D, "keypoints")
                if self.scale != 1.0:
                    k = k.scaled(self.scale, reader.size)
            out.append(k)
        return out

    def carried_keypoints(
        self, keypoints, stop: int | None = None, settings=None, *, both: bool = False,
        every: int = 1,
    ):  # fmt: skip
        """Per-camera keypoints carried by optical flow between detections (design §14.5).

        Parameters
        ----------
        keypoints : sequence of Keypoints2D or None
            Per camera, the detections in the pixels of the recording (full resolution),
            as for `silhouettes`; None for a camera without.
        stop : int, optional
            Carry over frames 0 to ``stop - 1`` only (the frames tracked).
        settings : handvar.vision.carry.CarrySettings, optional
        both : bool, keyword-only
            Carry each detection backwards too, and blend (not causal;
            `handvar.vision.carry.carry_keypoints`).
        every : int, keyword-only
            The detector ran on every `every`-th frame (`carry_keypoints`).

        Returns
        -------
        list of Keypoints2D or None
            Per camera, in the pixels of the delivered (scaled) frames
            (`scaled_keypoints`): the detections, and between them the carried points.
        """
        from handvar.vision.carry import CARRY_SETTINGS, carry_keypoints

        scaled = self.scaled_keypoints(keypoints)
        if scaled is None:
            return None
        settings = CARRY_SETTINGS if settings is None else settings
        return [
            None
            if k is None
            else carry_keypoints(
                (images[j] for _, images in self.frames(0, stop)),
                k,
                settings,
                both=both,
                every=every,
            )
            for j, k in enumerate(scaled)
        ]

    def lazy_masks(self, stop: int | None = None, model=None):
        """The silhouettes of frames 0 to ``stop - 1`` as a `handvar.io.FrameStack` whose
        frames are computed when indexed (skin mask and clean-up, no wrist cut; empty
        where no skin), for a `Sequence` whose masks are needed only for a few frames:
        the overlays of a track whose frames were fitted to keypoints alone."""
        from handvar.io import FrameStack
        from handvar.vision.skin import SkinModel

        model = SkinModel() if model is None else model

        n = self.n_frames if stop is None else min(int(stop), self.n_frames)
        source = self

        class _Silhouettes(FrameStack):
            def frame(self, t: int) -> np.ndarray:
                if not -n <= t < n:
                    raise IndexError(f"t: expected a frame index in [0, {n}); got {t}")
                t = t % n
                index, images = next(source.frames(t, t + 1))
                return frame_silhouettes(
                    images, model, index=index, names=source.names, wrist=False,
                    allow_empty=True,
                )  # fmt: skip

        w, h = self.image_size
        return _Silhouettes(np.full((n, self.n_cameras), "", dtype=object), "mask", (w, h))

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

        Raises
        ------
        EmptySilhouetteError
            A frame's silhouette is empty (unless ``allow_empty``), or no frame read
            shows a hand at all (also with ``allow_empty``).
        """
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
        self.check_some_hand(masks)
        return self.sequence_of(indices, masks, step=step, rgb=colour if rgb else None)

    def check_some_hand(self, masks) -> None:
        """Raise `EmptySilhouetteError` unless some silhouette of `masks` shows a hand.

        `masks` are the silhouettes read with ``allow_empty`` (every frame's, per camera).
        """
        from handvar.vision.silhouette import EmptySilhouetteError

        if not any(np.asarray(m).any() for m in masks):
            raise EmptySilhouetteError(
                f"{', '.join(self.names)}: expected a hand in some frame; none of the "
                f"{len(masks)} frames read shows one (every silhouette is empty, or skin "
                "colour touching all four borders of the image)",
                camera=self.names[0],
                frame=None,
            )

    def sequence_of(self, indices, masks, *, step: int = 1, rgb=None):
        """A `handvar.io.Sequence` of silhouettes computed from this source.

        Parameters
        ----------
        indices : sequence of int
            Frame index of each entry of `masks`.
        masks : sequence of (n_cams, H, W) bool ndarray
            The silhouettes.
        step : int, keyword-only
            Frame step of `indices` (the sequence's rate is ``fps / step``).
        rgb : sequence of (n_cams, H, W, 3) uint8 ndarray, keyword-only, optional
            The colour frames (RGB).

        Returns
        -------
        handvar.io.Sequence
            Without ground truth; the provenance names the files, the frames, the
            scale and whether the camera was assumed.
        """
        from handvar.io import Sequence

        provenance = {
            "source": [str(r.path) for r in self.readers],
            "frames": [int(i) for i in indices],
            "scale": self.scale,
            "calibrated": self.calibrated,
        }
        return Sequence(
            name=Path(self.readers[0].path).stem,
            fps=self.fps / step,
            rig=self.rig,
            masks=np.stack(masks),
            rgb=None if rgb is None else np.stack(rgb),
            provenance=provenance,
        )


def open_source(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    calibration: str | os.PathLike | Rig | None = None,
    *,
    fov: float | None = None,
    scale: float = 1.0,
    fps: float | None = None,
    allow_short: bool = False,
) -> VideoSource:
    """Open synchronised recordings, one per camera, with their calibration.

    Parameters
    ----------
    paths : path-like or sequence of path-like
        One video file or image folder per camera, in the order of the calibration's
        cameras.
    calibration : path-like or Rig, optional
        A calibration file (`Rig.load`: OpenCV's ``cameras`` layout, the stereo
        ``K1 D1 K2 D2 R T`` or rectified ``P1 P2`` layout, a single ``camera_matrix``, or
        an anipose ``.toml``; a file without an image size is taken for the frames') or a
        `Rig`.  Without one, a single recording gets `assumed_camera` (see the module
        notes on depth).
    fov : float, keyword-only, optional
        Horizontal field of view (degrees) of the assumed camera
        (`SourceSettings.fov`); only without `calibration`.
    scale : float, keyword-only
        Resize every frame by this factor before anything else (0.5 halves the work of
        the skin model and the tracker); the rig is scaled to match.
    fps : float, keyword-only, optional
        Frame rate; by default the first video's, else `SourceSettings.fps`.
    allow_short : bool, keyword-only
        Read a video that stops decoding before the frame count its container states
        (truncated or damaged) to where it stops, with a
        `handvar.vision.frames.ShortVideoWarning`; by default reading it raises
        `ValueError` naming the file, the frames read and the frames claimed.

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
    scale = as_float(scale, "scale", minimum=0.0, maximum=4.0, exclusive_minimum=True)
    readers = tuple(open_frames(p, allow_short=allow_short) for p in paths)
    full_rig, calibrated = _source_rig(readers, calibration, fov)
    rig = full_rig if scale == 1.0 else full_rig.scaled(scale)
    if fps is None:
        fps = next((r.fps for r in readers if r.fps), SOURCE_SETTINGS.fps)
    fps = as_float(fps, "fps", minimum=0.0, exclusive_minimum=True)
    return VideoSource(readers, rig, fps, scale, calibrated, full_rig)


def _source_rig(readers, calibration, fov) -> tuple[Rig, bool]:
    """The rig of `readers` (each with ``path``, ``name``, ``size``) and whether calibrated.

    Without `calibration` a single reader gets `assumed_camera`; with one, its cameras
    are checked against the readers (number and image size; `open_source`).
    """
    if calibration is None:
        if len(readers) != 1:
            raise ValueError(
                f"calibration: expected a calibration file for {len(readers)} cameras "
                "(only a single video may go without); got none"
            )
        fov = SOURCE_SETTINGS.fov if fov is None else fov
        rig = Rig((assumed_camera(readers[0].size, fov=fov),), ("cam0",))
        calibrated = False
        where = "assumed camera"
    else:
        if fov is not None:
            raise ValueError("fov: expected no field of view with a calibration; got both")
        as_instance(calibration, (str, os.PathLike, Rig), "calibration", what="a file or a Rig")
        if isinstance(calibration, Rig):
            rig, where = calibration, "calibration"
        else:
            sizes = {tuple(r.size) for r in readers}  # a file without a size: the frames'
            default = sizes.pop() if len(sizes) == 1 else None
            rig, where = Rig.load(calibration, default_size=default), str(calibration)
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
    return rig, calibrated


# --- a live camera -----------------------------------------------------------------------


@dataclass(frozen=True)
class _CameraReader:
    """What messages and the rig need of a live camera (as of a `FrameReader`)."""

    path: str
    name: str
    size: tuple[int, int]


class CameraSource:
    """A live camera read through OpenCV (``cv2.VideoCapture(index)``), latest frame first.

    Created by `open_camera`.  A thread reads the camera continuously; `stream` hands
    out the newest frame each time it is asked, so a consumer slower than the camera
    skips the frames it had no time for (counted in ``dropped``), as a live tracker
    must.  The frame's capture time is when its read returned.

    Attributes
    ----------
    readers : tuple
        One entry (``path``, ``name``, ``size``: the camera as messages name it).
    rig : Rig
        The camera, for the frames as delivered (resized by `scale`).
    fps : float
        Frame rate the camera reports (`SourceSettings.fps` when it reports none).
    scale : float
        Resize factor applied to every frame.
    calibrated : bool
        False when the rig is `assumed_camera`'s guess.
    """

    def __init__(self, capture, reader, rig: Rig, fps: float, scale: float, calibrated: bool):
        self._capture = capture
        self.readers = (reader,)
        self.rig = rig
        self.fps = fps
        self.scale = scale
        self.calibrated = calibrated
        self.dropped: list[int] = []
        self._stopped = False

    def __repr__(self) -> str:
        w, h = self.image_size
        return f"CameraSource({self.readers[0].name}: {w}x{h} at {self.fps:g} fps)"

    n_cameras = 1
    image_size = VideoSource.image_size
    sequence_of = VideoSource.sequence_of  # the silhouettes tracked, as a Sequence

    @property
    def names(self) -> tuple[str, ...]:
        """The camera's name, used in messages."""
        return (self.readers[0].name,)

    def stop(self) -> None:
        """Make `stream` end after the frame it is handing out (safe from a signal handler)."""
        self._stopped = True

    def close(self) -> None:
        """Release the camera."""
        self._stopped = True
        self._capture.release()

    def stream(self, stop: int | None = None, clock=None) -> Iterator[tuple[int, float, list]]:
        """The newest frame each time one is asked for, until `stop` frames were read.

        Parameters
        ----------
        stop : int, optional
            End after the camera's first `stop` frames (those skipped included);
            None: until `stop()` is called or the camera ends.
        clock : callable, optional
            Seconds (``time.perf_counter`` by default).

        Yields
        ------
        index : int
            Frame index, counted from the first frame handed out.
        seconds : float
            Capture time, seconds after the first frame's.
        images : list of one (H, W, 3) uint8 ndarray
            The BGR frame, resized by `scale`.

        The indices of the frames skipped are appended to ``dropped``.
        """
        import threading
        import time

        clock = time.perf_counter if clock is None else clock
        cond = threading.Condition()
        state = {"latest": None, "count": 0, "done": False}

        def grab() -> None:
            while not self._stopped and (stop is None or state["count"] < stop):
                ok, image = self._capture.read()
                with cond:
                    if not ok:
                        break
                    state["latest"] = (state["count"], clock(), image)
                    state["count"] += 1
                    cond.notify()
            with cond:
                state["done"] = True
                cond.notify()

        thread = threading.Thread(target=grab, name="handvar-camera", daemon=True)
        thread.start()
        last, base, t0 = -1, 0, None
        try:
            while not self._stopped:
                with cond:
                    while not state["done"] and (
                        state["latest"] is None or state["latest"][0] <= last
                    ):
                        cond.wait()
                    item = state["latest"]
                    if item is None or item[0] <= last:
                        return  # the camera ended
                count, seconds, image = item
                if t0 is None:  # the first frame handed out is frame 0, at time 0
                    base, t0 = count, seconds
                else:
                    self.dropped.extend(range(last + 1 - base, count - base))
                last = count
                if self.scale != 1.0:
                    image = cv2.resize(image, self.image_size, interpolation=cv2.INTER_AREA)
                yield count - base, seconds - t0, [image]
        finally:
            self._stopped = True
            thread.join(timeout=5.0)


def open_camera(
    index: int,
    calibration: str | os.PathLike | Rig | None = None,
    *,
    fov: float | None = None,
    scale: float = 1.0,
    capture=None,
) -> CameraSource:
    """Open the live camera number `index` (``cv2.VideoCapture(index)``).

    Parameters
    ----------
    index : int
        OpenCV's camera index (0: the first camera).
    calibration : path-like or Rig, optional
        The camera's calibration (one camera, `Rig.load`); without one, `assumed_camera`.
    fov : float, keyword-only, optional
        Horizontal field of view of the assumed camera, degrees.
    scale : float, keyword-only
        Resize every frame by this factor first.
    capture : keyword-only, optional
        An opened ``cv2.VideoCapture`` (or an object with ``read``, ``get`` and
        ``release``) to read instead of camera `index`.

    Returns
    -------
    CameraSource

    Raises
    ------
    ValueError
        ``camera: expected ...`` when no camera `index` can be opened or read.
    """
    from handvar.validate import as_int

    index = as_int(index, "camera", minimum=0)
    scale = as_float(scale, "scale", minimum=0.0, maximum=4.0, exclusive_minimum=True)
    if capture is None:
        capture = cv2.VideoCapture(index)
    ok, image = capture.read() if capture.isOpened() else (False, None)
    if not ok or image is None:
        capture.release()
        raise ValueError(f"camera: expected a camera that can be read at index {index}; none")
    h, w = image.shape[:2]
    reader = _CameraReader(f"camera {index}", f"camera{index}", (w, h))
    try:
        rig, calibrated = _source_rig((reader,), calibration, fov)
    except BaseException:
        capture.release()
        raise
    if scale != 1.0:
        rig = rig.scaled(scale)
    fps = float(capture.get(cv2.CAP_PROP_FPS) or 0.0)
    fps = fps if np.isfinite(fps) and fps > 0 else SOURCE_SETTINGS.fps
    return CameraSource(capture, reader, rig, fps, scale, calibrated)
