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
from handvar.vision.silhouette import silhouettes_from_frames

__all__ = [
    "IMAGE_SUFFIXES",
    "SOURCE_SETTINGS",
    "FrameReader",
    "SourceSettings",
    "VideoSource",
    "assumed_camera",
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
        from handvar.vision.silhouette import EmptySilhouetteError
        from handvar.vision.skin import SkinModel

        model = SkinModel() if model is None else model
        scaled = self.scaled_keypoints(keypoints)
        for index, images in self.frames(start, stop, step):
            kps = None
            if scaled is not None:
                kps = [None if k is None or index >= k.n_frames else k.frame(index) for k in scaled]
            masks = []
            for j, image in enumerate(images):
                try:
                    masks += silhouettes_from_frames(
                        [image],
                        model,
                        threshold=threshold,
                        cleanup=cleanup,
                        wrist=wrist,
                        frame=index,
                        cameras=[self.names[j]],
                        keypoints=None if kps is None else [kps[j]],
                    )
                except EmptySilhouetteError:
                    if not allow_empty:
                        raise
                    masks.append(np.zeros(image.shape[:2], dtype=bool))
            yield index, images, np.stack(masks)

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
        self, keypoints, stop: int | None = None, settings=None, *, both: bool = False
    ):
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
                (images[j] for _, images in self.frames(0, stop)), k, settings, both=both
            )
            for j, k in enumerate(scaled)
        ]

    def online(self, keypoints, stop: int | None = None, *, carry: bool = True,
               settings=None, model=None):  # fmt: skip
        """The recording frame by frame for a track with keypoints, nothing computed ahead.

        Yields, per frame, its index, a callable that computes the frame's silhouettes
        (skin mask and `clean_mask`, no wrist cut; empty where no skin) only when
        called, once, and the keypoints of every camera: the detection, else with
        `carry` the last detection carried forward by optical flow
        (`handvar.vision.carry.KeypointCarrier`, design §14.5), else None.  A frame
        with keypoints then costs no silhouette when the tracker does not ask for it.

        Parameters
        ----------
        keypoints : sequence of Keypoints2D or None
            Per camera, the detections in the pixels of the recording (full resolution).
        stop : int, optional
            Frames 0 to ``stop - 1`` only.
        carry : bool, keyword-only
            Carry the detections forward between them.
        settings : handvar.vision.carry.CarrySettings, keyword-only, optional
        model : SkinModel or HistogramSkinModel, keyword-only, optional
            Skin classifier; one `SkinModel()` for the whole run by default.

        Yields
        ------
        index : int
        masks : callable
            ``masks()`` → (n_cams, H, W) bool.
        keypoints : list of (21, 3) ndarray or None
            Per camera, in the delivered (scaled) frames' pixels.
        """
        from handvar.vision.carry import CARRY_SETTINGS, KeypointCarrier
        from handvar.vision.skin import SkinModel

        scaled = self.scaled_keypoints(keypoints)
        model = SkinModel() if model is None else model
        settings = CARRY_SETTINGS if settings is None else settings
        carriers = [KeypointCarrier(settings) if carry else None for _ in range(self.n_cameras)]
        for index, images in self.frames(0, stop):
            kps = []
            for j, image in enumerate(images):
                k = scaled[j] if scaled is not None else None
                det = k.frame(index) if k is not None and index < k.n_frames else None
                if det is not None and not (det[:, 2] > 0).any():
                    det = None
                if carriers[j] is not None and k is not None:
                    det = carriers[j].step(image, det)
                kps.append(det)
            yield index, _OnceMasks(self, images, index, model), kps

    def lazy_masks(self, stop: int | None = None, model=None):
        """The silhouettes of frames 0 to ``stop - 1`` as a `handvar.io.FrameStack` whose
        frames are computed when indexed (for a `Sequence` whose masks are needed only
        for a few frames, e.g. the overlays of a track made `online`)."""
        from handvar.io import FrameStack

        n = self.n_frames if stop is None else min(int(stop), self.n_frames)
        source = self

        class _Silhouettes(FrameStack):
            def frame(self, t: int) -> np.ndarray:
                if not -n <= t < n:
                    raise IndexError(f"t: expected a frame index in [0, {n}); got {t}")
                t = t % n
                index, images = next(source.frames(t, t + 1))
                return _OnceMasks(source, images, index, model)()

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
        (`SourceSettings.fov`); only without `calibration`.
    scale : float, keyword-only
        Resize every frame by this factor before anything else (0.5 halves the work of
        the skin model and the tracker); the rig is scaled to match.
    fps : float, keyword-only, optional
        Frame rate; by default the first video's, else `SourceSettings.fps`.

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
    readers = tuple(open_frames(p) for p in paths)
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
        rig = rig.scaled(scale)
    if fps is None:
        fps = next((r.fps for r in readers if r.fps), SOURCE_SETTINGS.fps)
    fps = as_float(fps, "fps", minimum=0.0, exclusive_minimum=True)
    return VideoSource(readers, rig, fps, scale, calibrated)


class _OnceMasks:
    """One frame's silhouettes, computed on the first call (`VideoSource.online`)."""

    def __init__(self, source, images, index, model) -> None:
        self.source, self.images, self.index, self.model = source, images, index, model
        self._masks = None

    def __call__(self) -> np.ndarray:
        if self._masks is None:
            from handvar.vision.silhouette import EmptySilhouetteError, silhouettes_from_frames
            from handvar.vision.skin import SkinModel

            model = SkinModel() if self.model is None else self.model
            masks = []
            for j, image in enumerate(self.images):
                try:
                    masks += silhouettes_from_frames(
                        [image], model, wrist=False, frame=self.index,
                        cameras=[self.source.names[j]],
                    )  # fmt: skip
                except EmptySilhouetteError:
                    masks.append(np.zeros(image.shape[:2], dtype=bool))
            self._masks = np.stack(masks)
        return self._masks
