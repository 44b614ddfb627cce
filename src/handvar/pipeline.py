"""One call from a recording (or a sequence) to a track: `track` and its `Track`.

`track` assembles the whole pipeline of design §1 with every default decided in one
place: the source is opened (`handvar.vision.sources.open_source`, or a sequence read
or synthesised), its skin-colour silhouettes computed, the detected keypoints read,
thinned to every K-th frame and carried by optical flow over the frames between
(design §14.5), the hand model built, the tracker set up with the motion predictor,
and every frame fitted, with the recovery of design §14.3 (refinement, re-seeding,
re-initialisation of lost frames) on recordings and wherever there are keypoints.
`handvar track`, the example and the studies all call it.

It reads as those stages: the options checked (`TrackOptions`), the source resolved, the
detector chosen (`handvar.vision.detector.make_detectors`: "auto" is MediaPipe Hands when
it is installed; none with keypoints or on a sequence) and the keypoints read, the
defaults decided (`decide_defaults`), the source opened (`_open`), the tracker built,
every frame fitted (`_fit`) and the `Track` assembled.

The defaults it decides, in one function, `decide_defaults`:

- the side (``hand``): "auto" (the detector's handedness, or the keypoint file's) with a
  detector or keypoints with handedness, else "right";
- ``carry``: "both" for a recording with keypoints (from the last detection and back
  from the next, a frame waiting for the next detection: on the realistic benchmark and
  the three real videos this tracks the frames between closer than "forward",
  docs/keypoint-fit.md); played in real time or live (causal), "forward" from a
  detector slower than the frames (``keypoint_every`` > 1, up to its next frame) and
  else "none"; "none" without keypoints;
- ``keypoint_tips``: "pad" on a recording (a detector marks the pad, design §14.6),
  "end" on a sequence (its keypoints are G(x) projected);
- ``recover``: on for a recording and wherever there are keypoints;
- the wrist: with keypoints and recovery it is cut while tracking (at the detected
  wrist, else at the previous fit's); otherwise with the silhouettes;
- empty silhouettes are allowed (carried by the prediction) only with recovery;
- the first pose: ``init``, else the sequence's true first pose (a synthetic or
  rendered sequence), else searched in the first frame (with recovery); a recording
  without recovery and without ``init`` is refused before it is opened;
- the hand: the default proportions at ``hand_length``, adapted to the first frames'
  keypoints where there are some; or ``shape`` (a person's hand fitted before, for
  instance from a track's keypoints), held as given.

The online form.  A recording with recovery is tracked one frame at a time: each frame
read (or, with ``realtime``, the newest frame each time the tracker is free, after
`paced_frames`; or a live camera's), its silhouettes, its keypoints (carried by optical
flow) and its fit follow each other.  Carried both ways, the frames up to the next
detection are read before the first of them is fitted (`_Stream._keyed`); nothing else
is computed ahead.  The frames skipped in real time stay in the track, flagged
``dropped``, holding the last tracked pose.  Only ``recover=False`` reads the whole
recording first (docs/live-and-batch.md).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import inspect
import itertools
import json
import os
import threading
import time
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from handvar.camera import Rig, check_in_front
from handvar.hand.anthropometry import JOINTS, SIDES, HandShape
from handvar.params import NAMES
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = [
    "CARRY",
    "HANDS_INDEX",
    "KEYPOINT_TIPS",
    "MODELS",
    "HandsTrack",
    "Track",
    "load_shape",
    "paced_frames",
    "project_joints",
    "track",
    "track_hands",
]

#: How detected keypoints are carried over the frames without a detection (design §14.5).
CARRY: tuple[str, ...] = ("forward", "both", "none")
#: The model point a detected fingertip is compared with (design §14.6).
KEYPOINT_TIPS: tuple[str, ...] = ("end", "pad")
#: Surfaces of the tracked hand model.
MODELS: tuple[str, ...] = ("spheres", "mesh")

#: The columns of a track's per-frame quality (`handvar.tracking.recovery.TrackQuality`).
_QUALITY_PREFIX = "quality_"
_SHAPE_PREFIX = "shape_"
#: How far (mm) the stored joints of a track saved without its hand shape may be from
#: those of the default hand for it to be taken: a micron, far above the rounding of
#: float64 joints (they are stored as computed).
_SHAPE_TOLERANCE = 1e-3


@dataclass(eq=False)
class Track:
    """A tracked recording or sequence: poses, joints, their projections and fit quality.

    Attributes
    ----------
    poses : (T, 26) ndarray
        Fitted poses, the 26 parameters of `handvar.params` (mm and degrees).
    joints : (T, 21, 3) ndarray
        The 21 points of every frame (`HandModel.landmarks`: on a recording G(x) with
        the fingertips and the thumb's base where a detector marks them, the
        ``keypoint_tips`` option; design §14.6), mm, world frame of the rig (the camera
        frame for one camera).
    projected : (n_cameras, T, 21, 2) ndarray
        The joints projected into every camera, pixels of the full-resolution frames
        (no camera, ``(0, T, 21, 2)``, when `rig` is None).
    quality : TrackQuality or None
        Per frame: silhouette IoU, keypoint error, cost, lost, re-initialised, empty,
        with keypoints (`handvar.tracking.recovery.TrackQuality`); None without
        recovery.
    rig : Rig or None
        The cameras, for the full-resolution frames; None only for a track loaded from
        a directory saved without them (`load`).
    shape : HandShape
        The tracked hand (``shape.side``: which hand).
    name : str
        Name of the recording or sequence.
    predictor : str
        Name of the motion predictor (`handvar.predictors.catalogue`).
    seed : int
        Seed of the optimiser's random samples.
    fps : float or None
        Frame rate of the recording or sequence.
    result : TrackResult or None
        The tracker's own record (starts, costs, iterations, per-camera IoU, per-frame
        seconds; `handvar.tracking.tracker.TrackResult`).
    search_seconds : (S,) ndarray
        Wall time of each pose search of the recovery, seconds (not in ``result``).
    detections : (T,) bool ndarray or None
        Frames with a detected keypoint in some camera, before carrying; None without
        keypoints.
    keypoints : list of Keypoints2D or None
        Per camera, the keypoints the tracker was given (thinned, carried), in the
        pixels of the tracked frames (`sequence`'s, resized by ``scale``); None without
        keypoints or for a loaded track.
    options : dict
        The options the track was made with, defaults resolved (``carry``,
        ``keypoint_tips``, ``recover``, ``model``, ``scale``, ...).
    stage_seconds : dict
        Wall time of the stages, seconds: ``silhouettes`` (reading the frames and their
        silhouettes), ``keypoints`` (carrying them) and ``tracking``.
    sequence : Sequence or None
        The tracked silhouettes (`handvar.io.Sequence`, its rig at the tracking
        resolution, its ground truth if any); None for a loaded track.
    source : VideoSource or None
        The recording, for overlays on its colour frames; None otherwise.
    dropped : (T,) bool ndarray or None
        Tracked in real time (a recording played at its rate, a live camera): the
        frames skipped because the tracker was busy.  A dropped frame holds the last
        tracked frame's pose and joints (what a live display shows then; NaN before the
        first), and NaN, 0 or False in the rest of its row.  None off-line.
    latency : (T,) ndarray or None
        Tracked in real time: seconds from a frame's capture to its pose (NaN on dropped
        frames; `realtime_summary`).  None off-line.
    detected : list of Keypoints2D or None
        With the detector inside the pipeline, per camera what it found, full-resolution
        pixels, world landmarks and handedness (`handvar keypoints`' .npz); None
        otherwise.
    """

    poses: np.ndarray
    joints: np.ndarray
    projected: np.ndarray
    quality: Any
    rig: Rig | None
    shape: HandShape
    name: str
    predictor: str
    seed: int
    fps: float | None
    result: Any = None
    search_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    detections: np.ndarray | None = None
    keypoints: list | None = field(default=None, repr=False)
    options: dict = field(default_factory=dict)
    stage_seconds: dict = field(default_factory=dict)
    sequence: Any = field(default=None, repr=False)
    source: Any = field(default=None, repr=False)
    dropped: np.ndarray | None = None
    latency: np.ndarray | None = None
    detected: list | None = field(default=None, repr=False)

    @property
    def n_frames(self) -> int:
        """Number of tracked frames T."""
        return int(self.poses.shape[0])

    @property
    def fit_seconds(self) -> np.ndarray:
        """(T,) wall time of each frame's fit (preparation, optimisation, prediction), s."""
        if self.result is None:
            return np.full(self.n_frames, np.nan)
        return np.asarray(self.result.seconds).sum(axis=1)

    @property
    def hand(self):
        """The tracked `HandModel` (its shape, surface, and the points it reports:
        ``options["keypoint_tips"]``)."""
        from handvar.hand.kinematics import HandModel

        return HandModel(
            self.shape,
            surface=self.options.get("model", "spheres"),
            tips=self.options.get("keypoint_tips") or "end",
        )

    def save(
        self, directory: str | os.PathLike, *, video: bool = True, overlays: bool = True
    ) -> dict[str, Path | str]:
        """Write the track into `directory`, as ``handvar track --out`` does.

        poses.csv, joints.csv, track.npz (the tracker's record and everything `load`
        rebuilds the track from: the hand shape, the options with the surface model,
        the name, the frame rate, the projections, the quality), cameras.yml (the rig,
        in `handvar.camera.Rig.save`'s format, which ``--calib`` reads), quality.csv
        with recovery, overlay.png and, with `video`, overlay.mp4
        (`handvar.tracking.outputs.write_track_outputs`; all-or-nothing). The layout:
        docs/conventions.md.

        Parameters
        ----------
        directory : path-like
            Output folder, created if missing.
        video : bool, keyword-only
            Also write the overlay video.
        overlays : bool, keyword-only
            Write overlay.png (and the video). A loaded track has no frames to draw
            over: save it with ``video=False, overlays=False``.

        Returns
        -------
        dict
            The files written (`write_track_outputs`); ``"video_error"`` says why no
            video was written.
        """
        from handvar.tracking.outputs import recording_backgrounds, write_track_outputs

        if (video or overlays) and self.sequence is None:
            raise ValueError(
                "overlays: expected a track with its frames (not a loaded one) for the "
                "overlays; got none: save with video=False, overlays=False"
            )
        if self.result is None:
            raise ValueError("result: expected the tracker's record to save; got None")
        backgrounds = None
        if overlays and self.source is not None:
            backgrounds = recording_backgrounds(self.source)
        return write_track_outputs(
            directory, self.result, self.sequence, self.hand, predictor=self.predictor,
            seed=self.seed, video=video and overlays, backgrounds=backgrounds,
            quality=self.quality, overlays=overlays, extra=self._extra_arrays(),
            rig=self.rig,
        )  # fmt: skip

    def _extra_arrays(self) -> dict[str, np.ndarray]:
        """What track.npz keeps beyond the tracker's record, for `load`."""
        arrays = {
            "projected": self.projected,
            "search_seconds": np.asarray(self.search_seconds, dtype=float),
            "meta": np.array(json.dumps({
                "name": self.name, "fps": self.fps, "options": self.options,
                "stage_seconds": self.stage_seconds,
            })),
        }  # fmt: skip
        if self.detections is not None:
            arrays["detections"] = np.asarray(self.detections, dtype=bool)
        if self.dropped is not None:
            arrays["dropped"] = np.asarray(self.dropped, dtype=bool)
        if self.latency is not None:
            arrays["latency"] = np.asarray(self.latency, dtype=float)
        for name in _shape_fields():
            arrays[_SHAPE_PREFIX + name] = np.asarray(getattr(self.shape, name))
        if self.quality is not None:
            for f in dataclasses.fields(self.quality):
                arrays[_QUALITY_PREFIX + f.name] = np.asarray(getattr(self.quality, f.name))
        return arrays

    @classmethod
    def load(cls, directory: str | os.PathLike, *, rig: Rig | None = None) -> Track:
        """Read a track written by `save` (or ``handvar track --out``) from `directory`.

        Everything `save` stores comes back as it was: poses, joints, projections,
        quality, the hand shape (every array of it, its side), the cameras
        (cameras.yml), the name, frame rate, predictor, seed and options (with the
        surface model). The frames are not kept with a track: the loaded one has
        ``sequence``, ``source`` and ``keypoints`` None.

        A directory written before the shape and the cameras were kept (track.npz with
        only the tracker's record, the predictor and the seed) is read too, and nothing
        is guessed for it: its hand is the default of `handvar.track`,
        ``HandShape.from_size()`` (185 mm, right), accepted only when its G(x)
        reproduces the stored joints at every frame, else a ValueError says the shape
        cannot be rebuilt; its ``rig`` is None (no projections) unless `rig` is given;
        ``fps`` and ``quality`` are None, ``options`` empty (so the spheres surface),
        and its name is the directory's.

        Parameters
        ----------
        directory : path-like
            The track directory.
        rig : Rig, keyword-only, optional
            Cameras to use instead of the stored ones (the projections are computed
            for them).

        Raises
        ------
        TypeError
            If `directory` is not a path.
        ValueError
            If `directory` holds no readable track.npz, or it lacks the tracker's
            record, or a pose lies outside the parameter limits, or (older directories)
            the default hand does not give its joints.
        """
        from handvar.params import check_limits
        from handvar.tracking.recovery import TrackQuality
        from handvar.tracking.tracker import TrackResult

        as_instance(directory, (str, os.PathLike), "directory", what="a path (str or path-like)")
        folder = Path(directory)
        path = folder / "track.npz"
        if not path.is_file():
            raise ValueError(
                f"directory: expected a track directory with track.npz; got {directory}"
            )
        try:
            with np.load(path, allow_pickle=False) as z:
                stored = {name: z[name] for name in z.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise ValueError(f"{path}: not a readable track ({exc})") from None
        record = [f.name for f in dataclasses.fields(TrackResult)] + ["predictor", "seed"]
        missing = [name for name in record if name not in stored]
        if missing:
            raise ValueError(
                f"{path}: expected a track saved by handvar.Track.save; missing {missing}"
            )
        result = TrackResult(**{f.name: stored[f.name] for f in dataclasses.fields(TrackResult)})
        T = result.poses.shape[0] if result.poses.ndim == 2 else 0
        if T < 1 or result.poses.shape != (T, len(NAMES)) or result.joints.shape != (T, 21, 3):
            raise ValueError(
                f"{path}: expected (T, 26) poses and (T, 21, 3) joints, T >= 1; got "
                f"{result.poses.shape} and {result.joints.shape}"
            )
        try:  # the poses checked as a pose file's are: within the limits
            check_limits(result.poses, "poses")
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
        try:
            meta = json.loads(str(stored["meta"])) if "meta" in stored else {}
        except ValueError:  # json.JSONDecodeError
            meta = None
        if not isinstance(meta, dict):
            raise ValueError(
                f"{path}: not a readable track (meta: expected a JSON object; got "
                f"{str(stored['meta'])[:40]!r})"
            )
        if _SHAPE_PREFIX + "segments" in stored:
            shape = HandShape(**{
                name: _scalar(stored[_SHAPE_PREFIX + name]) for name in _shape_fields()
            })  # fmt: skip
        else:
            shape = _default_shape(result.poses, result.joints, path)
        if rig is not None:
            rig = as_instance(rig, Rig, "rig", what="a Rig")
            projected = project_joints(rig, result.joints)
        else:
            if (folder / "cameras.yml").is_file():
                rig = Rig.load(folder / "cameras.yml")
            elif "rig" in meta:  # saved when the cameras were kept in track.npz
                rig = Rig.from_dict(meta["rig"])
            if rig is None:
                projected = np.zeros((0, T, len(JOINTS), 2))
            elif "projected" in stored:
                projected = stored["projected"]
            else:
                projected = project_joints(rig, result.joints)
        quality = None
        if f"{_QUALITY_PREFIX}iou" in stored:
            quality = TrackQuality(**{
                f.name: stored[_QUALITY_PREFIX + f.name] for f in dataclasses.fields(TrackQuality)
            })  # fmt: skip
        return cls(
            poses=result.poses, joints=result.joints, projected=projected, quality=quality,
            rig=rig, shape=shape, name=meta.get("name", folder.resolve().name),
            predictor=str(stored["predictor"]), seed=int(stored["seed"]), fps=meta.get("fps"),
            result=result, search_seconds=stored.get("search_seconds", np.zeros(0)),
            detections=stored.get("detections"), options=meta.get("options", {}),
            stage_seconds=meta.get("stage_seconds", {}), dropped=stored.get("dropped"),
            latency=stored.get("latency"),
        )  # fmt: skip

    def to_dataframe(self, kind: str = "wide"):
        """The track as a pandas table.

        pandas is imported here, not by ``import handvar``: it is not a dependency of the
        library (install it, or the ``test`` extra, to use this method).

        Parameters
        ----------
        kind : {"wide", "long"}
            ``"wide"``: one row per frame, indexed by ``frame``: the 26 parameters
            (`handvar.params.NAMES`), the joints ``<joint>_x``, ``_y``, ``_z`` (mm) and
            the quality's columns (``iou``, ``keypoint_error``, ``lost``, ...) when
            there is one.  ``"long"``: one row per frame and joint (``frame``,
            ``joint``, ``x``, ``y``, ``z`` in mm, and ``u_<camera>``, ``v_<camera>``,
            pixels of the full-resolution frames).  Tracked in real time, the wide
            table also has ``dropped`` and ``latency`` (seconds).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        one_of(kind, ("wide", "long"), "kind")
        T = self.n_frames
        if kind == "long":
            columns: dict[str, Any] = {
                "frame": np.repeat(np.arange(T), len(JOINTS)),
                "joint": np.tile(np.array(JOINTS), T),
            }
            for i, c in enumerate("xyz"):
                columns[c] = self.joints[:, :, i].ravel()
            names = () if self.rig is None else self.rig.names
            for cam, uv in zip(names, self.projected, strict=True):
                columns[f"u_{cam}"] = uv[:, :, 0].ravel()
                columns[f"v_{cam}"] = uv[:, :, 1].ravel()
            return pd.DataFrame(columns)
        columns = {name: self.poses[:, i] for i, name in enumerate(NAMES)}
        for j, joint in enumerate(JOINTS):
            for i, c in enumerate("xyz"):
                columns[f"{joint}_{c}"] = self.joints[:, j, i]
        if self.quality is not None:
            for f in dataclasses.fields(self.quality):
                value = np.asarray(getattr(self.quality, f.name))
                if value.ndim == 1:  # per frame (the per-keypoint distances are not)
                    columns[f.name] = value[:T]
        if self.dropped is not None:
            columns["dropped"] = np.asarray(self.dropped, dtype=bool)
        if self.latency is not None:
            columns["latency"] = np.asarray(self.latency, dtype=float)
        return pd.DataFrame(columns, index=pd.RangeIndex(T, name="frame"))

    def realtime_summary(self) -> str:
        """One line: frames, dropped, latency median and 95th percentile (real time only).

        Raises
        ------
        ValueError
            For a track not made in real time (``latency`` None).
        """
        if self.latency is None or self.dropped is None:
            raise ValueError("track: expected a track made in real time; it has no latency")
        ms = 1000.0 * self.latency[~np.isnan(self.latency)]
        return (
            f"realtime: {self.n_frames} frames, {int(np.sum(self.dropped))} dropped, "
            f"latency median {np.median(ms):.0f} ms, 95 % {np.percentile(ms, 95):.0f} ms"
        )


def _shape_fields() -> list[str]:
    """The fields a `HandShape` is built from (its constructor's), as track.npz keeps them."""
    return [f.name for f in dataclasses.fields(HandShape) if f.init]


def _default_shape(poses: np.ndarray, joints: np.ndarray, path: Path) -> HandShape:
    """The hand of a track saved without its shape: `track`'s default, if it fits.

    ``HandShape.from_size()`` is accepted only when its G(x) gives the stored joints
    (within `_SHAPE_TOLERANCE`) at every frame with a pose; otherwise the shape cannot
    be rebuilt and the error says so.
    """
    from handvar.hand.kinematics import HandModel

    shape = HandShape.from_size()
    model = HandModel(shape)
    worst = 0.0
    for x, points in zip(poses, joints, strict=True):
        if np.all(np.isfinite(x)):
            worst = max(worst, float(np.abs(model.joints(x) - points).max()))
    if worst > _SHAPE_TOLERANCE:
        raise ValueError(
            f"{path}: holds no hand shape (saved by an older handvar) and its joints are "
            f"not those of the default {shape.length:g} mm right hand (off by up to "
            f"{worst:.3g} mm): the shape cannot be rebuilt; track the recording again"
        )
    return shape


def project_joints(rig: Rig, joints: np.ndarray) -> np.ndarray:
    """(n_cameras, T, 21, 2) pixels of the (T, 21, 3) `joints` in every camera of `rig`;
    NaN where a frame has no pose (before the hand was first seen)."""
    T = joints.shape[0]
    points = joints.reshape(-1, 3)
    finite = np.isfinite(points).all(axis=1)
    projected = np.full((len(rig), len(points), 2), np.nan)
    for c, cam in enumerate(rig.cameras):
        projected[c, finite] = cam.project(points[finite])
    return projected.reshape(len(rig), T, -1, 2)


def _scalar(value: np.ndarray):
    """A 0-d array read from an npz as its Python value (str, float), else the array."""
    return value.item() if value.ndim == 0 else value


def track(
    source,
    *,
    keypoints=None,
    calib=None,
    fov: float | None = None,
    scale: float = 1.0,
    hand: str | None = None,
    hand_length: float = 185.0,
    model: str = "spheres",
    predictor: str = "rvar",
    init=None,
    keypoint_every: int = 1,
    carry: str | None = None,
    keypoint_tips: str | None = None,
    recover: bool | None = None,
    seed: int = 0,
    frames: int | None = None,
    progress: bool = False,
    allow_short: bool = False,
    recovery=None,
    on_frame: Callable | None = None,
    realtime: bool = False,
    detector="auto",
    hands: int = 1,
    shape=None,
) -> Track:
    """Track the hand through a recording or a sequence (module notes: the defaults).

    Parameters
    ----------
    source : str, path-like, list of them, or CameraSource
        A video file or an image folder, a list of them (one per camera of `calib`;
        or a comma-separated string), a sequence directory (`handvar.io`), the name
        of a synthetic sequence (`handvar.synth.SEQUENCE_NAMES`), or a live camera
        (`handvar.vision.sources.open_camera`, which takes its calibration, field of
        view and scale; tracked as it comes, as with `realtime`, until `frames`
        frames or its ``stop()``).
    keypoints : path-like, (T, 21, 2|3) array_like, Keypoints2D, or a list of them, optional
        2D keypoints of the 21 points (`handvar.vision.keypoints`), pixels of the
        full-resolution frames: a file (.npy or .csv), an array or a `Keypoints2D`; a
        list gives one per camera, in order.  With ``hands=2``, every hand found: one
        ``.json`` detections file per camera (`track_hands`).
    calib : path-like or Rig, optional
        Recordings only: the calibration (`handvar.camera.Rig.load`); one video
        without it gets an assumed camera.
    fov : float, optional
        One uncalibrated video: the assumed horizontal field of view, degrees.
    scale : float
        Recordings only: resize the frames by this factor first (0.5 is about 4x
        faster).
    hand : {"right", "left", "auto"}, optional
        Which hand is tracked; "auto": the side of the detector's handedness (the
        first frames with a hand, `_Stream.decide_side`) or of the keypoint file's.
        Default: "auto" with a detector or keypoints with handedness, else "right".
    hand_length : float
        Hand length of the model (wrist crease to middle fingertip), mm.
    model : {"spheres", "mesh"}
        Surface of the model; the skinned mesh is a right hand.
    predictor : str
        Motion predictor (`handvar.predictors.catalogue.make_predictor`: a key of the
        catalogue or a short name).
    init : str or (26,) array_like, optional
        Pose of the first frame: a named pose (`handvar.hand.kinematics.POSE_NAMES`) or
        the 26 parameters. Default: the sequence's true first pose, else searched in
        the first frame (with recovery).
    keypoint_every : int
        Use the keypoints of every K-th frame only (a slower detector).
    carry : {"forward", "both", "none"}, optional
        Carry the detections by optical flow over the frames without one (recordings
        with keypoints only); default "both" there ("forward" with ``realtime`` or a
        live camera), else "none".
    keypoint_tips : {"end", "pad"}, optional
        Model point a detected fingertip is compared with; default "pad" on a recording,
        "end" on a sequence.
    recover : bool, optional
        Refine poor fits and search lost frames again
        (`handvar.tracking.recovery.track_with_recovery`); default on for recordings and
        with keypoints.
    seed : int
        Seed of the optimiser's random samples.
    frames : int, optional
        Track only the first `frames` frames.
    progress : bool
        Show progress bars (tqdm) on standard error.
    allow_short : bool
        Recordings only: a video that stops decoding before its container's frame count
        is used to where it stops, with a warning, instead of refused.
    recovery : RecoverySettings, optional
        Settings of the recovery (`handvar.tracking.recovery.RECOVERY_DEFAULTS`).
    on_frame : callable, optional
        With recovery: called as ``on_frame(i, pose, quality, masks)`` after every frame
        tracked, i its index in the recording (`track_with_recovery`), for instance to
        keep the silhouettes fitted; a callback with a parameter ``images`` also gets
        the frame's colour images (BGR, one per camera, at `scale`) by that name, one
        with ``hand`` the tracked `HandModel` (its shape as fitted so far: the given
        one until the shape fit over the first frames).
    realtime : bool
        A recording only, with recovery: play it at its own frame rate and track the
        newest frame each time the tracker is free, skipping the others (module notes
        on the online form); the track (each hand's with ``hands=2``) then has
        ``dropped`` and ``latency``.
    detector : {"auto", "mediapipe", "none"} or callable
        The keypoint detector run inside the pipeline on a recording or a camera given
        without `keypoints` (`handvar.vision.detector`): "auto" is MediaPipe Hands when
        it is installed, else none (the silhouette tracker; ``options["notice"]`` says
        so); a callable ``frame -> points`` is the user's own
        (`handvar.vision.detector.user_detector`).  It runs on every `keypoint_every`-th
        frame, in a worker thread ahead of the fit; what it found is the track's
        ``detected``.
    hands : {1, 2}
        2: both hands, each under an identity kept by tracking (`track_hands`, which
        returns a `HandsTrack`): a recording or a camera, the detector inside or
        ``keypoints`` (every hand found, a ``.json`` per camera), ``keypoint_every``,
        ``realtime`` and ``allow_short`` as for one hand; without one hand's own
        options (``init``, ``hand``, ``carry``, ``recover``, ``shape``, ...).
    shape : HandShape or path-like, optional
        The hand's proportions, held for the whole track: a `HandShape`, or a track
        saved by `Track.save` (its directory or its track.npz), whose fitted hand is
        taken (`load_shape`).  Silhouettes do not tell where the knuckles lie along
        the hand, keypoints do: a person's hand fitted from a detector's keypoints
        (the one command's track) given to a silhouette track of the same person
        places its joints where the detector marks them
        (docs/results/paper-real-video.md).  Its side is the hand tracked (``hand``,
        if given, must agree) and its length replaces ``hand_length``; the shape fit
        of the first frames' keypoints is then not run.

    Returns
    -------
    Track
        (A `HandsTrack` with ``hands=2``.)

    Raises
    ------
    ValueError
        Naming the argument at fault (``keypoint_every: expected ...``), before any
        frame is read where it can be.
    """
    _load_compiled_loops()
    if as_int(hands, "hands", minimum=1, maximum=2) == 2:
        alone = {
            "hand": hand,
            "init": init,
            "carry": carry,
            "keypoint_tips": keypoint_tips,
            "recover": recover,
            "on_frame": on_frame,
            "shape": shape,
        }
        given = [k for k, v in alone.items() if v is not None]
        if given:
            raise ValueError(f"{', '.join(given)}: expected none with hands=2 (one hand's "
                             f"options); got {', '.join(given)}")  # fmt: skip
        return track_hands(source, calib=calib, fov=fov, scale=scale, hand_length=hand_length,
                           model=model, predictor=predictor, seed=seed, frames=frames,
                           progress=progress, detector=detector,
                           keypoint_every=keypoint_every, realtime=realtime,
                           keypoints=keypoints, allow_short=allow_short,
                           recovery=recovery)  # fmt: skip
    options = TrackOptions.checked(
        keypoints=keypoints, calib=calib, fov=fov, scale=scale, hand=hand,
        hand_length=hand_length, model=model, predictor=predictor, init=init,
        keypoint_every=keypoint_every, carry=carry, keypoint_tips=keypoint_tips,
        recover=recover, seed=seed, frames=frames, progress=progress,
        allow_short=allow_short, recovery=recovery, on_frame=on_frame, realtime=realtime,
        detector=detector, shape=shape,
    )  # fmt: skip
    spec, label = _source_spec(source, options)
    detectors, notice = _detectors(options.detector, options.keypoints, spec, spec.kind == "camera")
    detected = _read_keypoints(
        options.keypoints, spec, options.keypoint_every, detectors is not None
    )
    decided = decide_defaults(
        options, spec.kind, keypoints=detected is not None, handedness=_handedness(detected),
        detector=detectors is not None, name=label,
    )  # fmt: skip
    opened = _open(source, spec, options, decided, detected, detectors)
    tracker, x0 = _tracker(opened, options, decided, label)
    fitted = _fit(tracker, x0, opened, options, decided)
    return _assemble(
        fitted, opened, options, decided, spec, _detector_name(detector, detectors), notice
    )


@dataclass(frozen=True, eq=False)
class TrackOptions:
    """`track`'s keyword arguments, checked before the source is opened (`checked`).

    The attributes are `track`'s keywords as given (``hand``, ``carry``,
    ``keypoint_tips`` and ``recover`` None where `decide_defaults` decides them; ``hand``
    the side of ``shape`` where only that is given), the numbers as checked, ``shape``
    as a `HandShape` (read by `load_shape`), and two more: ``predictor_key``, the
    catalogue's key of ``predictor``, and ``init_pose``, ``init`` as the 26 parameters
    (None without it).
    """

    keypoints: Any = None
    calib: Any = None
    fov: float | None = None
    scale: float = 1.0
    hand: str | None = None
    hand_length: float = 185.0
    model: str = "spheres"
    predictor: str = "rvar"
    init: Any = None
    keypoint_every: int = 1
    carry: str | None = None
    keypoint_tips: str | None = None
    recover: bool | None = None
    seed: int = 0
    frames: int | None = None
    progress: bool = False
    allow_short: bool = False
    recovery: Any = None
    on_frame: Callable | None = None
    realtime: bool = False
    detector: Any = "auto"
    shape: Any = None
    predictor_key: str = "rvar"
    init_pose: np.ndarray | None = None

    @classmethod
    def checked(cls, **arguments) -> TrackOptions:
        """The options of `track`'s keyword `arguments` (its defaults for the others),
        every one checked that can be without the source.

        Raises
        ------
        TypeError, ValueError
            Naming the keyword at fault, in `track`'s words.

        Examples
        --------
        >>> options = TrackOptions.checked(keypoint_every=5, predictor="decel")
        >>> options.keypoint_every, options.predictor_key, options.carry
        (5, 'decelerating', None)
        """
        from handvar.predictors.catalogue import catalogue_key

        given = cls(**arguments)
        seed = as_int(given.seed, "seed", minimum=0)
        every = as_int(given.keypoint_every, "keypoint_every", minimum=1)
        frames = None if given.frames is None else as_int(given.frames, "frames", minimum=1)
        scale = as_float(given.scale, "scale", minimum=0.0, exclusive_minimum=True)
        hand_length = as_float(given.hand_length, "hand_length", minimum=0.0,
                               exclusive_minimum=True)  # fmt: skip
        if given.hand is not None:
            one_of(given.hand, (*SIDES, "auto"), "hand")
        one_of(given.model, MODELS, "model")
        if given.carry is not None:
            one_of(given.carry, CARRY, "carry")
        if given.keypoint_tips is not None:
            one_of(given.keypoint_tips, KEYPOINT_TIPS, "keypoint_tips")
        if given.recover is not None:
            as_instance(given.recover, bool, "recover")
        as_instance(given.realtime, bool, "realtime")
        if given.hand == "left" and given.model == "mesh":
            raise ValueError(
                "model: expected spheres for a left hand (the skinned mesh is a right hand); "
                "got mesh"
            )
        key = catalogue_key(as_instance(given.predictor, str, "predictor"), "predictor")
        shape, hand = given.shape, given.hand
        if shape is not None:
            shape = load_shape(shape)
            if hand not in (None, shape.side):
                raise ValueError(f"hand: expected {shape.side}, the side of the shape given, "
                                 f"or none; got {hand}")  # fmt: skip
            if hand_length != TrackOptions.hand_length:
                raise ValueError(f"hand_length: expected none with a shape given (the "
                                 f"hand's length is the shape's); got {hand_length:g}")  # fmt: skip
            if given.model == "mesh" and shape.side == "left":
                raise ValueError("shape: expected a right hand with model mesh (the skinned "
                                 "mesh is a right hand); got a left one")  # fmt: skip
            hand = shape.side
        return dataclasses.replace(
            given, seed=seed, keypoint_every=every, frames=frames, scale=scale,
            hand_length=hand_length, predictor_key=key, init_pose=_init_pose(given.init),
            shape=shape, hand=hand,
        )  # fmt: skip


@dataclass(frozen=True)
class TrackDefaults:
    """What `track` decides for a source (`decide_defaults`; module notes).

    Attributes
    ----------
    hand : {"right", "left", "auto"}
        The side; "auto" is then the keypoint file's handedness or the detector's.
    carry : {"forward", "both", "none"}
    keypoint_tips : {"end", "pad"}
    recover : bool
    cut_wrist : bool
        The wrist is cut while tracking (at the detected wrist, else at the previous
        fit's): a recording with keypoints and recovery.  Otherwise a recording's
        silhouettes are cut when computed and a sequence's taken as they are.
    allow_empty : bool
        Empty silhouettes are allowed (carried by the prediction): with recovery.
    first_pose : {"init", "truth", "search"}
        Where the first pose comes from: ``init``; the sequence's true first pose (a
        sequence directory without one: searched, with recovery); searched in the
        first frame.
    """

    hand: str
    carry: str
    keypoint_tips: str
    recover: bool
    cut_wrist: bool
    allow_empty: bool
    first_pose: str


def decide_defaults(
    options: TrackOptions, kind: str, *, keypoints: bool = False, handedness: bool = False,
    detector: bool = False, name: str = "",
) -> TrackDefaults:  # fmt: skip
    """Every default of `track` (module notes), decided for a source of `kind`.

    Parameters
    ----------
    options : TrackOptions
        The options given (`TrackOptions.checked`).
    kind : {"recording", "camera", "directory", "synthetic"}
        The source: recordings, a live camera, a sequence directory or a synthetic
        sequence (`handvar.io.SequenceSpec.kind`).
    keypoints : bool, keyword-only
        Keypoints were given.
    handedness : bool, keyword-only
        Some of them say which hand (a .npz of `handvar keypoints`).
    detector : bool, keyword-only
        A keypoint detector runs inside the pipeline (`handvar.vision.detector`).
    name : str, keyword-only
        How messages name the source.

    Returns
    -------
    TrackDefaults

    Raises
    ------
    ValueError
        An option the source cannot take: ``carry`` without keypoints or on a
        sequence, ``recovery`` or ``on_frame`` without recovery, real time without
        recovery or with ``carry`` both, ``hand`` auto without a side to take it from,
        a recording without recovery and without ``init``.

    Examples
    --------
    >>> d = decide_defaults(TrackOptions.checked(), "recording", keypoints=True)
    >>> d.carry, d.keypoint_tips, d.recover, d.hand, d.cut_wrist, d.first_pose
    ('both', 'pad', True, 'right', True, 'search')
    """
    recording = kind in ("recording", "camera")
    online = options.realtime or kind == "camera"  # one frame at a time, as it comes
    keyed = keypoints or detector  # the track has keypoints
    # the side of the detector's handedness or of a keypoint file's, else the right hand
    hand = options.hand or ("auto" if detector or (keypoints and handedness) else "right")
    carry = options.carry
    if carry not in (None, "none") and (not keypoints or kind != "recording"):
        got = "no keypoints" if kind == "recording" else f"the {kind} sequence {name!r}"
        raise ValueError(
            f"carry: expected a recording (a video file or an image folder) with "
            f"keypoints for {carry}; got {got}"
        )
    if carry is None and not (keyed and recording):
        carry = "none"
    elif carry is None and not online:  # both ways off-line
        carry = "both"
    elif carry is None:  # online only from a detector slower than the frames, up to its
        carry = "forward" if options.keypoint_every > 1 else "none"  # next frame
    recover = (recording or keyed) if options.recover is None else options.recover
    given = [k for k, v in (("recovery", options.recovery), ("on_frame", options.on_frame))
             if v is not None]  # fmt: skip
    if given and not recover:
        raise ValueError(
            f"{', '.join(given)}: expected only with recover (on by default for a recording "
            f"or with keypoints); got it off"
        )
    # a detector's keypoints on a recording, else G(x) projected
    tips = options.keypoint_tips or ("pad" if recording else "end")
    if online and (not recover or carry == "both"):
        raise ValueError(
            "realtime: expected recovery on and carry forward or none (one frame at a "
            f"time); got recover={recover}, carry={carry}"
        )
    if hand == "auto" and (not keyed or not recording):
        raise ValueError(
            "hand: auto expected a recording with a detector or keypoints with handedness; "
            "got " + ("no keypoints" if not keyed else f"the {kind} sequence {name!r}")
        )
    if options.init is not None:
        first = "init"
    elif not recording:
        first = "truth"
    elif recover:
        first = "search"
    else:  # a recording has no true poses
        raise ValueError(f"{name}: the sequence has no ground truth; give the first pose with init")
    return TrackDefaults(
        hand=hand, carry=carry, keypoint_tips=tips, recover=recover,
        cut_wrist=recording and recover and keyed, allow_empty=recover, first_pose=first,
    )  # fmt: skip


def _source_spec(source, options: TrackOptions):
    """The `SequenceSpec` of `source` and how messages name it, checked against the
    options only some sources take."""
    spec, label = _resolve_source(source)
    if spec.kind == "camera" and (
        options.calib is not None or options.fov is not None or options.scale != 1.0
        or options.keypoints is not None
    ):  # fmt: skip
        raise ValueError(
            "calib, fov, scale, keypoints: expected none with a live camera (open_camera "
            "takes the calibration, field of view and scale)"
        )
    if options.realtime and spec.kind != "recording":
        raise ValueError(
            f"realtime: expected a recording (a video file or an image folder); got the "
            f"{spec.kind} sequence {label!r}"
        )
    return spec, label


def _handedness(detected) -> bool:
    """Whether some camera's keypoints say which hand (a .npz of `handvar keypoints`)."""
    return detected is not None and any(k.handedness is not None for k in detected if k is not None)


@dataclass
class _Opened:
    """The source opened (`_open`): the frames to track and what came with them."""

    rig: Rig  # of the tracked frames
    full_rig: Rig  # of the full-resolution frames
    hand: str  # the side, "auto" decided by the keypoints' or the detector's handedness
    source: Any = None  # the recording or the camera; None for a sequence
    stream: _Stream | None = None  # frame by frame (module notes: the online form)
    sequence: Any = None  # the whole sequence, off-line
    detected: list | None = None  # per camera the keypoints read (a recording's checked)
    keypoints: list | None = None  # as the tracker is given them (thinned, carried)
    outside: int = 0  # keypoints dropped as lying outside the frames
    stage_seconds: dict = field(default_factory=dict)


def _open(source, spec, options: TrackOptions, decided: TrackDefaults, detected,
          detectors) -> _Opened:  # fmt: skip
    """The source of `track` opened: a camera or a recording with recovery as a
    `_Stream` (its side decided by the detector, which reads the first frames), a
    recording without recovery read whole, a sequence read or synthesised."""
    if spec.kind == "camera":  # its frames as delivered (open_camera scale)
        stream = _Stream(source, None, carry=decided.carry, frames=options.frames,
                         realtime=True, detectors=detectors,
                         every=options.keypoint_every)  # fmt: skip
        hand = decided.hand if detectors is None else stream.decide_side(decided.hand)
        return _Opened(source.rig, source.rig, hand, source=source, stream=stream)
    if spec.kind == "recording":
        return _open_recording(spec, options, decided, detected, detectors)
    if options.calib is not None or options.fov is not None:
        raise ValueError("calib, fov: expected only with a video or an image folder")
    if spec.kind == "directory":
        from handvar.io import read_sequence

        sequence = read_sequence(spec.paths[0], lazy=True)
    else:
        from handvar.synth.sequences import make_sequence

        sequence = make_sequence(spec.name, n_frames=options.frames)
    detected = _every(detected, options.keypoint_every)
    return _Opened(sequence.rig, sequence.rig, decided.hand, sequence=sequence,
                   detected=detected, keypoints=detected)  # fmt: skip


def _open_recording(spec, options: TrackOptions, decided: TrackDefaults, detected,
                    detectors) -> _Opened:  # fmt: skip
    """A recording opened (its keypoints checked against it): with recovery as a
    `_Stream`, without read whole first, its silhouettes and keypoints (carried)."""
    from handvar.vision.sources import open_source

    paths, calib, fov = list(spec.paths), options.calib, options.fov
    opened = open_source(paths, calib, fov=fov, scale=options.scale,
                         allow_short=options.allow_short)  # fmt: skip
    full_rig = opened.full_rig
    hand, outside = decided.hand, 0
    if detected is not None:
        from handvar.vision.keypoints import check_keypoints

        short = [reader.may_end_early for reader in opened.readers]
        detected, hand, outside = check_keypoints(detected, opened.n_frames,
                                                  [r.size for r in opened.readers], hand,
                                                  short, full_rig.cameras)  # fmt: skip
        if len(detected) != opened.n_cameras:
            raise ValueError(
                f"keypoints: expected one file per camera ({opened.n_cameras}); got {len(detected)}"
            )
        detected = _every(detected, options.keypoint_every)
    if decided.recover:  # frame by frame
        stream = _Stream(opened, detected, carry=decided.carry, frames=options.frames,
                         realtime=options.realtime, detectors=detectors,
                         every=options.keypoint_every)  # fmt: skip
        if detectors is not None:
            hand = stream.decide_side(hand)
        return _Opened(opened.rig, full_rig, hand, source=opened, stream=stream,
                       detected=detected, keypoints=detected, outside=outside)  # fmt: skip
    # the whole recording first (without recovery)
    frames, bar = options.frames, _progress_bar if options.progress else None
    total = opened.n_frames if frames is None else min(frames, opened.n_frames)
    stage_seconds = {}
    clock = time.perf_counter()
    # With keypoints and recovery the wrist is cut while tracking (at the detected
    # wrist, else at the tracked model's); otherwise here.
    sequence = opened.to_sequence(
        stop=frames, allow_empty=decided.allow_empty,
        progress=None if bar is None else bar("silhouettes", total),
        **({"wrist": False} if decided.cut_wrist else {"keypoints": detected}),
    )  # fmt: skip
    stage_seconds["silhouettes"] = time.perf_counter() - clock
    clock = time.perf_counter()
    used = detected
    if decided.carry != "none":
        used = opened.carried_keypoints(detected, stop=frames, both=decided.carry == "both",
                                        every=options.keypoint_every)  # fmt: skip
    elif detected is not None:
        used = opened.scaled_keypoints(detected)
    stage_seconds["keypoints"] = time.perf_counter() - clock
    return _Opened(sequence.rig, full_rig, hand, source=opened, sequence=sequence,
                   detected=detected, keypoints=used, outside=outside,
                   stage_seconds=stage_seconds)  # fmt: skip


def _tracker(opened: _Opened, options: TrackOptions, decided: TrackDefaults, label: str):
    """The tracker of `opened`'s frames and the first pose (None: searched)."""
    from handvar.hand.kinematics import HandModel
    from handvar.predictors.catalogue import make_predictor
    from handvar.tracking import CostSettings, Tracker, TrackerSettings

    rig, used = opened.rig, opened.keypoints
    if used is not None and len(used) != len(rig):
        raise ValueError(f"keypoints: expected one file per camera ({len(rig)}); got {len(used)}")
    truth = None if opened.sequence is None else opened.sequence.truth
    x0 = _first_pose(decided, options.init_pose, truth, label)
    shape = options.shape or HandShape.from_size(options.hand_length, side=opened.hand)
    hand_model = HandModel(shape, surface=options.model)
    if x0 is not None:
        check_in_front(hand_model.joints(x0), rig, "init" if options.init is not None else label)
    settings = TrackerSettings(cost=CostSettings(keypoint_tips=decided.keypoint_tips))
    tracker = Tracker(
        rig, hand_model, make_predictor(options.predictor_key),
        np.random.default_rng(options.seed), settings,
    )  # fmt: skip
    return tracker, x0


@dataclass
class _Fitted:
    """Every frame fitted (`_fit`)."""

    result: Any  # TrackResult
    hand: Any  # HandModel: the shape adapted to the first frames
    sequence: Any  # the tracked silhouettes
    keypoints: list | None  # as the tracker was given them
    quality: Any = None
    search_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    found: list | None = None  # what the detector found
    latency: np.ndarray | None = None
    dropped: np.ndarray | None = None


def _fit(tracker, x0, opened: _Opened, options: TrackOptions, decided: TrackDefaults) -> _Fitted:
    """Every frame of `opened` fitted: one at a time (`_run_stream`), or a sequence with
    recovery (`track_with_recovery`) or without (`Tracker.track`); the time it took in
    ``opened.stage_seconds["tracking"]``."""
    bar = _progress_bar if options.progress else None
    clock = time.perf_counter()
    if options.shape is not None:  # held as given: no shape fit
        from handvar.tracking.recovery import RECOVERY_DEFAULTS

        options = dataclasses.replace(options, recovery=dataclasses.replace(
            options.recovery or RECOVERY_DEFAULTS, shape=None))  # fmt: skip
    if opened.stream is not None:
        fitted = _fit_stream(tracker, x0, opened, options, bar)
        clock += sum(opened.stream.seconds.values())  # the tracking stage is the rest
    elif decided.recover:
        fitted = _fit_with_recovery(tracker, x0, opened, options, decided, bar)
    else:
        sequence = opened.sequence
        result = tracker.track(
            sequence, x0, frames=options.frames, keypoints=opened.keypoints,
            progress=None if bar is None else bar(f"tracking {sequence.name}", None),
        )  # fmt: skip
        fitted = _Fitted(result, tracker.hand, sequence, opened.keypoints)
    opened.stage_seconds["tracking"] = time.perf_counter() - clock
    return fitted


def _fit_stream(tracker, x0, opened: _Opened, options: TrackOptions, bar) -> _Fitted:
    """The frames of `opened.stream` fitted one at a time; the dropped ones filled in."""
    stream = opened.stream
    with contextlib.closing(stream):  # an error in the fit stops what reads ahead
        recovered = _run_stream(tracker, stream, x0, options.recovery, options.on_frame, bar)
    result, quality = _with_dropped(recovered, stream.rows(), stream.n_frames)
    fitted = _Fitted(
        result, tracker.hand, stream.sequence(), stream.keypoints(opened.source.names),
        quality=quality, search_seconds=np.asarray(recovered.init_seconds, dtype=float),
        found=stream.detected(opened.source.names), latency=stream.latency(),
        dropped=stream.dropped_mask() if stream.realtime else None,
    )  # fmt: skip
    opened.stage_seconds.update(stream.seconds)
    return fitted


def _fit_with_recovery(tracker, x0, opened: _Opened, options: TrackOptions,
                       decided: TrackDefaults, bar) -> _Fitted:  # fmt: skip
    """A sequence's frames fitted with recovery (`track_with_recovery`)."""
    from handvar.tracking.recovery import track_with_recovery

    sequence, frames, used = opened.sequence, options.frames, opened.keypoints
    n = sequence.n_frames if frames is None else min(frames, sequence.n_frames)
    masks = (np.asarray(sequence.masks[t]) for t in range(n))
    if bar is not None:
        masks = bar(f"tracking {sequence.name}", n)(masks)
    extra = {} if options.recovery is None else {"settings": options.recovery}
    if options.on_frame is not None:
        extra["on_frame"] = options.on_frame
    recovered = track_with_recovery(
        tracker, masks, x0, keypoints=None if used is None else _keypoints_at(used),
        world=_world_cue(opened.detected), cut_wrist=decided.cut_wrist, **extra,
    )  # fmt: skip
    return _Fitted(recovered.track, tracker.hand, sequence, used, quality=recovered.quality,
                   search_seconds=np.asarray(recovered.init_seconds, dtype=float))  # fmt: skip


def _assemble(fitted: _Fitted, opened: _Opened, options: TrackOptions,
              decided: TrackDefaults, spec, detector: str, notice) -> Track:  # fmt: skip
    """The `Track` of the frames fitted, with the options it was made with."""
    result, sequence = fitted.result, fitted.sequence
    T = result.poses.shape[0]
    seen = None
    for k in fitted.found or opened.detected or ():
        if k is not None:
            seen = np.zeros(T, dtype=bool) if seen is None else seen
            seen[: min(T, k.n_frames)] |= k.present[:T].any(axis=1)
    resolved = {
        "source": [str(p) for p in spec.paths] or spec.name, "kind": spec.kind,
        "hand_length": options.hand_length, "model": options.model, "scale": options.scale,
        "init": options.init is not None, "keypoints": opened.detected is not None,
        "keypoint_every": options.keypoint_every, "carry": decided.carry,
        "keypoint_tips": decided.keypoint_tips, "recover": decided.recover,
        "frames": options.frames, "realtime": options.realtime or spec.kind == "camera",
        "hand": opened.hand, "outside_keypoints": opened.outside, "detector": detector,
        "notice": notice, "shape": options.shape is not None,
    }  # fmt: skip
    return Track(
        poses=result.poses, joints=result.joints,
        projected=project_joints(opened.full_rig, result.joints), quality=fitted.quality,
        rig=opened.full_rig, shape=fitted.hand.shape, name=sequence.name,
        predictor=options.predictor, seed=options.seed,
        fps=None if sequence.fps is None else float(sequence.fps), result=result,
        search_seconds=fitted.search_seconds, detections=seen, keypoints=fitted.keypoints,
        options=resolved, stage_seconds=opened.stage_seconds, sequence=sequence,
        # a camera's frames cannot be read again: overlays over the silhouettes
        source=None if spec.kind == "camera" else opened.source, dropped=fitted.dropped,
        latency=fitted.latency, detected=fitted.found,
    )  # fmt: skip


def _run_stream(tracker, stream: _Stream, x0, settings, on_frame, bar):
    """Fit every frame of `stream`, one at a time: a loop over the per-frame tracker
    (`handvar.tracking.hand_tracker.HandTracker.fit`)."""
    from handvar.tracking.hand_tracker import HandTracker

    step = HandTracker.following(tracker, keyed=stream.keyed, settings=settings)
    if x0 is not None:
        step.recovery.start(x0)
    done = stream.on_frame(on_frame)
    items = stream.frames()
    if bar is not None:
        items = bar("tracking", stream.expected())(items)
    try:
        for i, (masks, kps, world, absent) in enumerate(items):
            r = step.fit(masks, kps, world, absent=absent)
            done(i, r.pose, r.quality, masks, step.hand)
        return step.recovered(keypoints=stream.keyed)
    except ValueError:
        if stream.exhausted and not stream.live and not stream.keyed:  # no hand anywhere:
            stream.source.check_some_hand(stream.masks)  # the recording's own word
        raise


def _detectors(detector, keypoints, spec, live: bool):
    """Per camera the detector of `track` (or None), and the notice when "auto" found
    no MediaPipe."""
    from handvar.vision.detector import make_detectors

    explicit = detector not in ("auto", None)
    if keypoints is not None or not (live or spec.kind == "recording"):
        if explicit and detector != "none":
            what = "keypoints" if keypoints is not None else f"the {spec.kind} sequence"
            raise ValueError(f"detector: expected none with {what}; got {detector!r}")
        return None, None
    detectors = make_detectors(detector, 1 if live else len(spec.paths))
    notice = None
    if detectors is None and detector == "auto":
        notice = (
            "no keypoint detector (MediaPipe is not installed): tracking skin-colour "
            "silhouettes alone, which needs a plain background and controlled light; "
            "pip install 'handvar[mediapipe]' for the detector"
        )
    return detectors, notice


def _detector_name(detector, detectors) -> str:
    if detectors is None:
        return "none"
    return "callable" if callable(detector) else "mediapipe"


def _resolve_source(source):
    """The `SequenceSpec` of `source` and how messages name it."""
    from handvar.io import SequenceSpec, resolve_sequence
    from handvar.synth.sequences import SEQUENCE_NAMES

    if type(source).__name__ == "CameraSource":  # without importing OpenCV for the others
        from handvar.vision.sources import CameraSource

        if isinstance(source, CameraSource):
            return SequenceSpec("camera", (source.readers[0].path,)), source.readers[0].path
    if isinstance(source, list | tuple):
        if not source or not all(isinstance(p, str | os.PathLike) for p in source):
            raise TypeError(
                f"source: expected a list of video files or image folders; got {source!r}"
            )
        paths = tuple(os.fspath(p) for p in source)
        return SequenceSpec("recording", paths), ",".join(paths)
    if isinstance(source, os.PathLike):
        source = os.fspath(source)
    as_instance(source, str, "source", what="a path, a list of paths or a sequence name")
    return resolve_sequence(source, names=SEQUENCE_NAMES, argument="source"), source


def _read_keypoints(keypoints, spec, every: int, detector: bool = False):
    """Per camera a `Keypoints2D` (all its frames: the side is decided on them, as
    `handvar init` decides it; `_every` keeps those fitted), or None without
    keypoints."""
    if keypoints is None:
        if every != 1 and not detector:
            raise ValueError("keypoint_every: expected only with keypoints or a detector")
        return None
    from handvar.vision.keypoints import Keypoints2D, read_keypoints

    entries = list(keypoints) if isinstance(keypoints, list | tuple) else [keypoints]
    if spec.kind == "recording" and len(entries) != len(spec.paths):
        raise ValueError(
            f"keypoints: expected one file per recording ({len(spec.paths)}); got {len(entries)}"
        )
    out = []
    for entry in entries:
        if isinstance(entry, str | os.PathLike):
            entry = read_keypoints(entry)
        elif not isinstance(entry, Keypoints2D):
            entry = Keypoints2D.from_array(entry)
        out.append(entry)
    return out


def _every(detected, every: int):
    """Each camera's keypoints of every `every`-th frame (`Keypoints2D.every`)."""
    if detected is None or every == 1:
        return detected
    return [None if k is None else k.every(every) for k in detected]


def load_shape(source) -> HandShape:
    """The hand of `source`: a `HandShape` as it is, or the fitted hand of a track saved
    by `Track.save` (``handvar track --out``), its directory or its track.npz.

    Raises
    ------
    ValueError
        Naming ``shape``: `source` is neither, or holds no readable track.

    Examples
    --------
    >>> load_shape(HandShape.from_size(170.0)).length
    170.0
    """
    if isinstance(source, HandShape):
        return source
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"shape: expected a HandShape or a track's path; got "
                        f"{type(source).__name__}")  # fmt: skip
    path = Path(source)
    folder = path.parent if path.name == "track.npz" else path
    if not (folder / "track.npz").is_file():
        raise ValueError(f"shape: expected a track saved by handvar (a directory with "
                         f"track.npz, `handvar track --out`); got {source}")  # fmt: skip
    try:
        return Track.load(folder).shape
    except ValueError as exc:
        raise ValueError(f"shape: {exc}") from None


def _init_pose(init) -> np.ndarray | None:
    """`init` as the 26 parameters (a named pose or the parameters, checked); None
    without it."""
    if init is None:
        return None
    from handvar.hand.kinematics import POSE_NAMES, named_pose
    from handvar.params import check_pose

    if isinstance(init, str):
        if init not in POSE_NAMES:
            raise ValueError(
                f"init: expected a named pose ({', '.join(POSE_NAMES)}) or 26 parameters; "
                f"got {init!r}"
            )
        return named_pose(init)
    return check_pose(init, "init")


def _first_pose(decided: TrackDefaults, init_pose, truth, label: str) -> np.ndarray | None:
    """The pose of the first frame (`TrackDefaults.first_pose`), or None to search it."""
    if decided.first_pose == "init":
        return init_pose
    if decided.first_pose == "truth" and truth is not None:
        return truth.poses[0]
    if decided.recover:
        return None  # searched in the first frame
    raise ValueError(f"{label}: the sequence has no ground truth; give the first pose with init")


def _between(last: list, index: int, world, ran: bool, held: list):
    """The detector's 3D given out with frame `index` (its `world`, `ran`: whether the
    detector looked at it) of frames carried both ways: on a frame between two
    detections, their 3D interpolated linearly, between ``last[0]`` ((index, world) of
    the last detection given out, updated here) and the next one's in `held` ((n,
    index, seconds, images, world, ran) of the frames read after); None without both,
    or with a detector's frame without 3D between."""
    if ran:
        last[0] = None if world is None else (index, world)
        return world
    if world is not None or last[0] is None:
        return world
    after = next(((i, w) for _, i, _, _, w, r in held if r), None)
    if after is None or after[1] is None:
        return None
    (i0, w0), (i1, w1) = last[0], after
    return w0 + (index - i0) / (i1 - i0) * (w1 - w0)


def _world_cue(detected):
    """The detector's metric 3D of the first camera, frame by frame (`world[i]`), or None.

    A weak cue of the keypoint fit (docs/keypoint-fit.md), where the keypoint file has it.
    """
    if detected is None or detected[0] is None or detected[0].world is None:
        return None
    return detected[0].world.__getitem__


def _keypoints_at(keypoints):
    """Frame i's keypoints of every camera, for `track_with_recovery`."""

    def at(i):
        return [None if k is None or i >= k.n_frames else k.frame(i) for k in keypoints]

    return at


def _progress_bar(desc: str, total: int | None):
    """A wrapper drawing a tqdm progress bar over an iterable (transient)."""
    from tqdm import tqdm

    def wrap(iterable):
        return tqdm(iterable, total=total, desc=desc, unit="frame", leave=False)

    return wrap


# --- the online form: one frame at a time ------------------------------------------------


def paced_frames(
    frames, fps: float, dropped: list, *, clock=time.perf_counter, sleep=time.sleep,
    origin: list | None = None,
):  # fmt: skip
    """Play `frames` at their own rate, skipping those the consumer had no time for.

    A wall clock starts when the first frame is handed out; frame i's capture time is
    (i − i₀) / fps.  Each time the consumer asks for the next frame, the frames whose
    capture time has passed are skipped except the latest (their indices appended to
    `dropped`); when none is due yet, it waits for the next one.

    Parameters
    ----------
    frames : iterable of (int, images)
        Frame index and images, in order (`VideoSource.frames`).
    fps : float
        Frame rate, frames per second.
    dropped : list
        Receives the indices of the frames skipped.
    clock, sleep : callable, keyword-only
        Seconds, and waiting (for tests: a simulated clock).
    origin : list, keyword-only, optional
        Receives the clock's reading when the first frame was handed out (the zero of
        the capture times).

    Yields
    ------
    index : int
    seconds : float
        Capture time after the first frame's.
    images : list of ndarray
    """
    it = iter(frames)
    item = next(it, None)
    if item is None:
        return
    first, t0 = item[0], clock()
    if origin is not None:
        origin.append(t0)

    def capture(index: int) -> float:
        return (index - first) / fps

    while item is not None:
        wait = capture(item[0]) - (clock() - t0)
        if wait > 0:
            sleep(wait)
        following = next(it, None)
        while following is not None and capture(following[0]) <= clock() - t0:
            dropped.append(item[0])
            item, following = following, next(it, None)
        yield item[0], capture(item[0]), item[1]
        item = following


class _Once:
    """A frame's silhouettes, computed on the first call (a keypoint frame may not ask;
    a silhouette frame gives where the hand is expected, `Recovery.frame`)."""

    def __init__(self, compute: Callable[..., np.ndarray]) -> None:
        self._compute: Callable[..., np.ndarray] | None = compute
        self._value: np.ndarray | None = None

    def __call__(self, near=None) -> np.ndarray:
        if self._value is None:
            if self._compute is None:
                raise RuntimeError("the frame's silhouettes were released before computed")
            self._value = self._compute(near)
        return self._value

    def release(self) -> np.ndarray | None:
        """The silhouettes if they were computed, else None; the frame is let go."""
        self._compute = None
        return self._value


class _Stream:
    """The per-frame steps ahead of the fit, one frame at a time (docs/live-and-batch.md).

    For each frame of the source (a recording, played at its own rate or as fast as
    it goes, or a live camera): its keypoints, detected by the detector stage
    (`handvar.vision.detector.detect_ahead`, ahead of the fit) or
    read from a keypoint file, carried by optical flow inside the gaps between
    detections (`handvar.vision.carry`); and its skin-colour silhouettes, computed only
    when the fit asks.  `frames` hands them to the fit; `on_frame` notes when each fit
    finished.
    """

    def __init__(self, source, detected, *, carry: str, frames: int | None, realtime: bool,
                 detectors: list | None = None, every: int = 1) -> None:  # fmt: skip
        from handvar.vision.carry import (
            CARRY_SETTINGS,
            KeypointCarrier,
            TwoWayCarrier,
            until_next_detection,
        )
        from handvar.vision.skin import SkinModel

        self.source = source
        self.live = not hasattr(source, "frames")
        self.realtime = realtime or self.live
        self.scaled = None if detected is None else source.scaled_keypoints(detected)
        self.world = None if detected is None or detected[0] is None else detected[0].world
        self.detectors = detectors
        self.every = every
        self.keyed = detected is not None or detectors is not None  # the track has keypoints
        self.carry = carry
        self.carriers = None  # per camera, carrying forward, or both ways with a delay
        if self.keyed and carry in ("forward", "both"):
            online = carry == "forward" and every > 1  # up to the next detector frame
            settings = until_next_detection(every) if online else CARRY_SETTINGS
            self.carriers = [
                KeypointCarrier(settings) if carry == "forward"
                else TwoWayCarrier(settings, reach=every - 1)
                for _ in source.names
            ]  # fmt: skip
        self.two_way = carry == "both"
        self.stop = frames
        self.model = SkinModel()
        self.clock = time.perf_counter
        self.t0: float | None = None
        self.hand = "auto"  # the side the detections are chosen for (`decide_side`)
        self.deciding = False  # the detector looks at every frame, for the side
        self.labelled = True  # its labels tell which hand a detection is (`decide_side`)
        self.found: dict[int, list] = {}  # detector: per frame and camera, the chosen hand
        self.indices: list[int] = []  # recording index of each tracked frame
        self.capture: list[float] = []  # its capture time, s after the first frame's
        self.finish: list[float] = []  # when its fit finished, s after the first frame's
        self.masks: list[np.ndarray] = []
        self.kps: list[list | None] = []
        self.dropped: list[int] = []
        self.seconds = {"silhouettes": 0.0, "keypoints": 0.0}
        self.exhausted = False  # every frame read without an error
        self.origin: list[float] = []  # paced playback: when its clock started
        self._ahead: list = []  # frames read ahead by `decide_side`
        self.images: list | None = None  # the colour frames being fitted
        self.shape: tuple | None = None  # of a frame's silhouettes (n_cams, H, W)
        self._items = None

    # -- the frames, their detections ---------------------------------------------------

    def _feed(self):
        """``(index, seconds, images, originals)`` of every frame played."""
        if self.live:
            self.dropped = self.source.dropped
            stream = self.source.stream(self.stop, clock=self.clock)
            return ((i, s, images, images) for i, s, images in stream)
        frames = self.source.frames(0, self.stop, originals=self.detectors is not None)
        frames = ((f[0], (f[1], f[-1])) for f in frames)  # images, full-resolution ones
        if self.realtime:
            frames = paced_frames(
                frames, self.source.fps, self.dropped, clock=self.clock, origin=self.origin
            )
        else:
            frames = ((i, i / self.source.fps, pair) for i, pair in frames)
        return ((i, s, images, full) for i, s, (images, full) in frames)

    def _items_read(self):
        """``(index, seconds, images, found)``: `found` per camera the hands the detector
        found (`handvar.vision.detector.Detection`), or None on a frame it did not run on
        (every K-th frame, ``every``) and without a detector."""
        if self._items is None:
            if self.detectors is None:
                self._items = ((i, s, images, None) for i, s, images, _ in self._feed())
            else:
                from handvar.vision.detector import detect_ahead

                feed = ((i, s, images, full if i % self.every == 0 or self.deciding else None)
                        for i, s, images, full in self._feed())  # fmt: skip
                self._items = detect_ahead(feed, self.detectors, depth=1 if self.realtime else 4)
        return self._items

    def decide_side(self, hand: str) -> str:
        """The side of the hand with a detector: `hand`, or with "auto" the side of the
        first `SIDE_FRAMES` frames with a hand.  With two cameras or more, where the
        first two see one hand (their rays meet, `found_chirality`), by its shape in 3D:
        the sum of its `chirality` over those frames; else by the detector's handedness
        (`handvar.vision.detector.vote_side`; a detector that says no side: right).  The
        frames are read ahead (those before the first hand without their images, but
        for the last `CarrySettings.max_frames`, which its first detection may be
        carried back to: `TwoWayCarrier`), and the detector looks at each of them for the
        vote, whatever ``every``; the fit is given only its detections of every
        ``every``-th frame (`_detections`).

        Raises
        ------
        ValueError
            The detector found no hand in the whole recording.
        """
        from handvar.vision.detector import SIDE_FRAMES
        from handvar.vision.keypoints import decide_side, found_chirality

        self.hand = hand
        if hand != "auto":
            return hand
        votes: list = []  # per frame with a hand and camera, the hands found
        shape: list[float] = []  # per frame two cameras see one hand, its chirality
        seen = 0  # frames with a hand
        # the frames before the first hand keep their images only as far as its first
        # detection may be carried back (`TwoWayCarrier`)
        back = self.carriers[0].settings.max_frames if self.two_way and self.carriers else 0
        self.deciding = True
        for index, seconds, images, found in self._items_read():
            if found is not None and any(found):
                seen += 1
                votes.extend(found)
                shape.append(found_chirality(found, self.source.rig.cameras, self._to_tracked))
            self._ahead.append((index, seconds, images, found))
            if not seen and len(self._ahead) > back:  # beyond reach: its images dropped
                i, s, _, f = self._ahead[-back - 1]
                self._ahead[-back - 1] = (i, s, None, f)
            if seen >= SIDE_FRAMES:
                break
        self.deciding = False
        if not seen:
            self.exhausted = True
            raise ValueError(
                f"{self._name()}: expected a hand; the detector found none in its "
                f"{len(self._ahead)} frames"
            )
        self.hand, self.labelled = decide_side(votes, float(np.nansum(shape)))
        return self.hand

    def _name(self) -> str:
        return self.source.names[0] if self.live else str(self.source.readers[0].path)

    def _detections(self):
        """``(index, seconds, images, detections, world, ran)`` of every frame: per
        camera its detected (21, 3) keypoints in the tracked frames' pixels or None, the
        detector's 3D of the first camera or None, and whether the detector looked at
        this frame."""
        from handvar.vision.detector import choose

        pending, self._ahead = self._ahead, []
        for index, seconds, images, found in itertools.chain(pending, self._items_read()):
            if self.detectors is None:
                yield (index, seconds, images, *self._from_file(index))
                continue
            if found is None or index % self.every:  # (looked at for the side only)
                yield index, seconds, images, [None] * len(self.detectors), None, False
                continue
            chosen = [choose(f, self.hand if self.labelled else "auto") for f in found]
            self.found[index] = chosen
            dets = [None if p is None else self._to_tracked(p, j)
                    for j, (p, _) in enumerate(chosen)]  # fmt: skip
            world = None if chosen[0][1] is None else chosen[0][1].world
            yield index, seconds, images, dets, world, True

    def _from_file(self, index: int):
        """Frame `index`'s detections of a keypoint file, its 3D, whether detected."""
        if self.scaled is None:
            return None, None, False
        dets = []
        for k in self.scaled:
            row = None if k is None or index >= k.n_frames else k.frame(index)
            dets.append(row if row is not None and np.any(row[:, 2] > 0) else None)
        ran = index % self.every == 0 and any(
            k is not None and index < k.n_frames for k in self.scaled
        )
        world = None
        if self.world is not None and index < len(self.world):
            w = self.world[index]
            world = w if np.isfinite(w).all() else None
        return dets, world, ran

    def _to_tracked(self, points: np.ndarray, camera: int) -> np.ndarray:
        """Full-resolution keypoints (21, 3) in the tracked frames' pixels (``scale``)."""
        from handvar.vision.keypoints import scaled_pixels

        scale = getattr(self.source, "scale", 1.0)
        if self.live or scale == 1.0:
            return points
        out = points.copy()
        out[:, :2] = scaled_pixels(points[:, :2], scale, self.source.readers[camera].size)
        return out

    def expected(self) -> int | None:
        """Frames to be tracked, when known (a recording read as fast as it goes)."""
        if self.realtime:
            return None
        n = self.source.n_frames
        return n if self.stop is None else min(self.stop, n)

    def close(self) -> None:
        """Stop what reads ahead: the detector's workers and the frame readers.  An
        error or an interrupt in the fit leaves them suspended otherwise, alive as long
        as its traceback is kept (in a notebook, until the next error)."""
        if self._items is not None:
            self._items.close()

    # -- to the fit ---------------------------------------------------------------------

    def frames(self):
        """``(masks, keypoints, world, absent)`` of every frame tracked, for the fit:
        masks lazily computed where there are keypoints (`_Once`); `absent`: the detector
        found no hand there and none was carried to it."""
        from handvar.vision.sources import frame_silhouettes

        wrist = not self.keyed  # with keypoints the tracker cuts the wrist
        for index, seconds, images, kps, world, ran in self._keyed(self._detections()):
            if self.t0 is None:  # the zero of the capture times
                self.t0 = self.origin[0] if self.origin else self.clock() - seconds

            def silhouettes(near=None, images=images, index=index):
                clock = self.clock()
                masks = frame_silhouettes(
                    images, self.model, index=index, names=self.source.names, wrist=wrist,
                    allow_empty=True, near=near,
                )  # fmt: skip
                self.seconds["silhouettes"] += self.clock() - clock
                return masks

            # computed when the fit asks: with keypoints perhaps never; without them
            # knowing where the hand is expected
            masks = _Once(silhouettes)
            if images is not None and self.shape is None:
                self.shape = (len(images), *images[0].shape[:2])
            present = kps is not None and any(k is not None for k in kps)
            absent = self.keyed and not present and (ran or self.carry != "none")
            self.kps.append(kps)
            self.indices.append(index)
            self.capture.append(seconds)
            self.masks.append(masks)
            self.images = images  # the frame being fitted (`on_frame`'s ``images``)
            yield masks, kps if present else None, world, absent
            if isinstance(masks, _Once):  # keep what was computed, not the frame's images
                self.masks[-1] = masks.release()
        self.exhausted = True

    def _keyed(self, items):
        """``(index, seconds, images, keypoints, world, ran)`` of each frame, in order.

        Carried forward (or not at all) a frame's keypoints are known when it is read.
        Carried both ways (`TwoWayCarrier`), frames are held until every camera's
        keypoints of them are final: the frames up to the next detection are read
        first (at most `CarrySettings.max_frames`), and the silhouettes of the frames
        held are computed only when the fit asks, as for any frame.  A frame read
        ahead without its images (before the first hand) is given no keypoints.  Held
        between two detections with 3D, a frame is given their 3D interpolated
        linearly (`_between`), as its keypoints are blended from both.
        """
        if self.carriers is None or not self.two_way:
            for index, seconds, images, dets, world, ran in items:
                clock = self.clock()
                if self.carriers is not None and images is not None:
                    dets = [c.step(im, d) for c, im, d in zip(self.carriers, images, dets,
                                                              strict=True)]  # fmt: skip
                self.seconds["keypoints"] += self.clock() - clock
                yield index, seconds, images, dets, world, ran
            return
        held: list = []  # (n, index, seconds, images, world, ran) read, keypoints not final
        final: list[dict] = [{} for _ in self.carriers]  # per camera: n → keypoints
        last: list = [None]  # (index, world) of the last detection with 3D given out

        def ready():
            while held and all(held[0][0] in f for f in final):
                n, index, seconds, images, world, ran = held.pop(0)
                world = _between(last, index, world, ran, held)
                yield index, seconds, images, [f.pop(n) for f in final], world, ran

        n = 0
        for index, seconds, images, dets, world, ran in items:
            if images is None:  # before the first hand: nothing held, nothing to carry
                yield index, seconds, images, dets, world, ran
                continue
            clock = self.clock()
            held.append((n, index, seconds, images, world, ran))
            for f, carrier, image, d in zip(final, self.carriers, images, dets, strict=True):
                f.update(carrier.step(image, d))
            n += 1
            self.seconds["keypoints"] += self.clock() - clock
            yield from ready()
        for f, carrier in zip(final, self.carriers, strict=True):
            f.update(carrier.flush())  # the detector's last frames unseen
        yield from ready()

    def on_frame(self, user: Callable | None):
        """`track_with_recovery`'s callback: the finish time, then the user's."""

        takes = set() if user is None else set(inspect.signature(user).parameters)

        def done(i, pose, quality, masks, hand):
            self.finish.append(self.clock() - self.t0)
            if user is None:
                return
            masks = masks() if callable(masks) else masks  # keypoints alone: computed now
            extra = {"images": self.images, "hand": hand}  # for a callback that takes them
            user(self.indices[i], pose, quality, masks,
                 **{k: v for k, v in extra.items() if k in takes})  # fmt: skip

        return done

    @property
    def n_frames(self) -> int:
        """Frames of the source played: tracked and dropped."""
        return len(self.indices) + len(self.dropped)

    def rows(self) -> np.ndarray:
        """(T_tracked,) the row of each tracked frame in the track (index − first)."""
        first = min(self.indices[0], *self.dropped) if self.dropped else self.indices[0]
        return np.asarray(self.indices) - first

    def latency(self) -> np.ndarray | None:
        """(T,) seconds from capture to pose, NaN on dropped frames; None off-line."""
        if not self.realtime:
            return None
        out = np.full(self.n_frames, np.nan)
        out[self.rows()] = np.asarray(self.finish) - np.asarray(self.capture)
        return out

    def dropped_mask(self) -> np.ndarray:
        """(T,) bool: frames skipped."""
        out = np.ones(self.n_frames, dtype=bool)
        out[self.rows()] = False
        return out

    def sequence(self):
        """The tracked silhouettes as a `handvar.io.Sequence`; dropped frames empty.

        Where frames were fitted to keypoints without their silhouettes, a recording's
        are computed when the overlays ask for them (`VideoSource.lazy_masks`).
        """
        if not self.keyed and not self.live:  # no hand in any frame is refused
            self.source.check_some_hand(self.masks)
        if not self.live and any(m is None for m in self.masks):
            from handvar.io import Sequence

            return Sequence(
                name=Path(self.source.readers[0].path).stem, fps=self.source.fps,
                rig=self.source.rig, masks=self.source.lazy_masks(self.n_frames),
                provenance={"source": [str(r.path) for r in self.source.readers],
                            "scale": self.source.scale, "calibrated": self.source.calibrated},
            )  # fmt: skip
        shape = next((m.shape for m in self.masks if m is not None), self.shape)
        rows = self.rows()
        masks = [np.zeros(shape, dtype=bool)] * self.n_frames
        for r, m in zip(rows, self.masks, strict=True):
            if m is not None:
                masks[r] = m
        indices = np.arange(self.n_frames) + (self.indices[0] - rows[0])
        return self.source.sequence_of(indices, masks)

    def keypoints(self, names) -> list | None:
        """Per camera the keypoints given to the tracker, as `Keypoints2D` (T frames)."""
        if not self.keyed:
            return None
        from handvar.vision.keypoints import Keypoints2D

        out = []
        for j, k in enumerate(self.scaled or [None] * len(names)):
            a = np.full((self.n_frames, 21, 3), np.nan)
            for r, kps in zip(self.rows(), self.kps, strict=True):
                if kps is not None and kps[j] is not None:
                    a[r] = kps[j]
            out.append(Keypoints2D.from_array(a, name=names[j] if k is None else k.name))
        return out

    def detected(self, names) -> list | None:
        """With a detector, per camera what it found, as `handvar keypoints` writes it:
        `Keypoints2D` in full-resolution pixels with the world landmarks, handedness
        and presence, one row per frame played (NaN where it found no hand or did not
        run); None without a detector."""
        if self.detectors is None:
            return None
        from handvar.vision.keypoints import Keypoints2D

        first = self.indices[0] - int(self.rows()[0])  # the recording index of row 0
        out = []
        for j, name in enumerate(names):
            points = np.full((self.n_frames, 21, 3), np.nan)
            world = np.full((self.n_frames, 21, 3), np.nan)
            sides = np.full(self.n_frames, "", dtype="<U5")
            for index, chosen in self.found.items():
                r = index - first
                found, d = chosen[j]
                if found is None or not 0 <= r < self.n_frames:
                    continue
                points[r], sides[r] = found, d.side
                if d.world is not None:
                    world[r] = d.world
            k = Keypoints2D.from_array(points, name=name)
            out.append(Keypoints2D(k.xy, k.confidence, name, world=world, handedness=sides,
                                   presence=k.present.any(axis=1).astype(float)))  # fmt: skip
        return out


def _with_dropped(recovered, rows: np.ndarray, n: int):
    """`recovered`'s track and quality over all `n` frames, the dropped ones filled in.

    A dropped frame holds the last tracked pose (and its joints; NaN before the first
    tracked frame); its other entries are NaN, 0 or False.
    """
    from handvar.tracking.recovery import TrackQuality
    from handvar.tracking.tracker import TrackResult

    held = np.maximum.accumulate(np.isin(np.arange(n), rows) * np.arange(n))  # last row
    source_row = np.searchsorted(rows, held)  # the tracked entry at that row
    started = np.arange(n) >= rows[0]

    def expand(a, hold: bool, zero: bool = False):
        a = np.asarray(a)
        if hold:
            out = a[np.minimum(source_row, len(a) - 1)].copy()
            if out.dtype.kind == "f":
                out[~started] = np.nan
            return out
        fill = np.nan if a.dtype.kind == "f" and not zero else 0
        out = np.full((n, *a.shape[1:]), fill, dtype=a.dtype)
        out[rows] = a
        return out

    track = recovered.track
    result = TrackResult(**{
        f.name: expand(
            getattr(track, f.name), f.name in ("poses", "joints", "starts"), f.name == "seconds"
        )
        for f in dataclasses.fields(TrackResult)
    })  # fmt: skip
    quality = TrackQuality(**{
        f.name: expand(getattr(recovered.quality, f.name), False)
        for f in dataclasses.fields(TrackQuality)
    })  # fmt: skip
    return result, quality


# --- both hands ------------------------------------------------------------------------

#: Colours (RGB) the overlay draws each side in.
SIDE_RGB = {"right": (255, 150, 40), "left": (60, 200, 255)}
#: The index of a directory of both hands (`HandsTrack.save`).
HANDS_INDEX = "hands.json"


@dataclass(eq=False)
class HandsTrack:
    """Both hands of a recording, tracked.

    Attributes
    ----------
    tracks : dict
        Hand id → its `Track` (``track.shape.side``: its side); only the hands seen.
    name : str
    fps : float or None
    seconds : (T,) ndarray
        Wall time of each frame (assignment and fits), seconds; 0 on a frame dropped
        (tracked in real time: each hand's ``dropped``).
    source : VideoSource or None
        The recording, for the overlay.
    """

    tracks: dict
    name: str
    fps: float | None
    seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    source: object = field(default=None, repr=False)

    @property
    def n_frames(self) -> int:
        return len(self.seconds)

    def side(self, side: str) -> Track | None:
        """The track of the hand of `side`, or None."""
        return next((t for t in self.tracks.values() if t.shape.side == side), None)

    def save(self, directory: str | os.PathLike, *, video: bool = True) -> dict[str, Path]:
        """Write each hand's track into ``directory/<side>/`` (as one hand's ``--out``,
        without its own overlay), ``hands.json`` (id, side, folder of each) and, with
        `video`, ``overlay.mp4``: both hands over the frames, each side in its colour.
        The files of an earlier track of one hand in `directory` go."""
        from handvar.atomic import OutputSet
        from handvar.tracking.outputs import TRACK_FILES

        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        written: dict[str, Path] = {}
        listing = []
        for k, t in sorted(self.tracks.items()):
            side = t.shape.side
            t.save(out / side, video=False, overlays=False)
            written[side] = out / side
            listing.append({"id": k, "side": side, "directory": side})
        index = out / HANDS_INDEX
        text = json.dumps({"name": self.name, "fps": self.fps, "hands": listing}, indent=2)
        with OutputSet() as outputs:
            outputs.add(index, lambda tmp: Path(tmp).write_text(text + "\n"))
            for name in set(TRACK_FILES) - {HANDS_INDEX}:  # an earlier track of one hand
                outputs.remove(out / name)
        written["hands"] = index
        if video and self.source is not None and self.tracks:
            written["video"] = self._overlay(out / "overlay.mp4")
        return written

    @classmethod
    def load(cls, directory: str | os.PathLike, *, rig: Rig | None = None) -> HandsTrack:
        """Read a directory written by `save` (``handvar track --hands 2 --out``): its
        index (`HANDS_INDEX`: name, fps, each hand's id, side and folder) and each hand's
        track (`Track.load`, with `rig` instead of the stored cameras when given).

        Raises
        ------
        TypeError
            If `directory` is not a path.
        ValueError
            Naming the index: one that is missing or broken, names a folder that is not
            there or a hand of another side, two hands of one side, hands over different
            frames.
        """
        as_instance(directory, (str, os.PathLike), "directory", what="a path (str or path-like)")
        index = Path(directory) / HANDS_INDEX
        if not index.is_file():
            raise ValueError(f"directory: expected a directory of both hands with {HANDS_INDEX} "
                             f"(handvar track --hands 2 --out); got {directory}")  # fmt: skip
        expect = f"{index}: expected {{'name', 'fps', 'hands': [{{'id', 'side', 'directory'}}]}}"
        try:
            doc = json.loads(index.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"{expect}; got JSON it cannot read ({exc})") from None
        entries = doc.get("hands") if isinstance(doc, dict) else None
        if not isinstance(entries, list):
            raise ValueError(f"{expect}; got no list of hands")
        if not entries:
            raise ValueError(f"{index}: expected at least one hand; got none (no hand was tracked)")
        tracks, sides = {}, []
        for i, entry in enumerate(entries):
            ok = isinstance(entry, dict) and isinstance(entry.get("id"), int)
            ok = ok and entry.get("side") in SIDES and isinstance(entry.get("directory"), str)
            if not ok:
                raise ValueError(f"{expect}; got hand {i}: {entry!r:.80}")
            folder = Path(directory) / entry["directory"]
            if not folder.is_dir() or Path(entry["directory"]).is_absolute():
                raise ValueError(f"{index}: expected the folder of each hand inside the "
                                 f"directory; got {entry['directory']!r} for the "
                                 f"{entry['side']} hand, which is not there")  # fmt: skip
            try:
                track = Track.load(folder, rig=rig)
            except ValueError as exc:
                raise ValueError(f"{index}: the {entry['side']} hand's folder {folder}: "
                                 f"{str(exc).removeprefix('directory: ')}") from None  # fmt: skip
            if track.shape.side != entry["side"]:
                raise ValueError(f"{index}: expected a {entry['side']} hand in {folder}; got a "
                                 f"{track.shape.side} hand")  # fmt: skip
            sides.append(entry["side"])
            tracks[entry["id"]] = track
        if len(set(sides)) != len(sides):
            raise ValueError(f"{index}: expected at most one hand of each side; got {sides}")
        if len({t.n_frames for t in tracks.values()}) != 1:
            raise ValueError(
                f"{index}: expected the hands' tracks over the same frames; got "
                + ", ".join(f"{t.shape.side} {t.n_frames}" for t in tracks.values())
            )
        first = next(iter(tracks.values()))
        name = doc.get("name") if isinstance(doc.get("name"), str) else first.name
        fps = doc.get("fps") if isinstance(doc.get("fps"), int | float) else first.fps
        return cls(tracks, name, fps, np.zeros(first.n_frames))

    def _overlay(self, path: Path) -> Path:
        import cv2

        from handvar.render.overlay import OverlayWriter, draw_overlay, side_by_side

        rig = next(iter(self.tracks.values())).rig
        with OverlayWriter(path, self.fps or 30.0) as writer:
            for t, _, originals in self.source.frames(stop=self.n_frames, originals=True):
                views = []
                for j, image in enumerate(originals):
                    rgb = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
                    for track in self.tracks.values():
                        joints, side = track.joints[t], track.shape.side
                        if not np.isfinite(joints).all():
                            continue  # not in this frame
                        rgb = draw_overlay(rgb, rig.cameras[j], joints, colour=SIDE_RGB[side])
                        x, y = track.projected[j, t, 0]
                        cv2.putText(rgb, side, (int(x) + 8, int(y) + 16), cv2.FONT_HERSHEY_SIMPLEX,
                                    0.6, SIDE_RGB[side], 2, cv2.LINE_AA)  # fmt: skip
                    views.append(rgb)
                frame = side_by_side(views, list(rig.names))
                writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
        return writer.path_written


@functools.cache
def _load_compiled_loops() -> threading.Thread:
    """Start loading the fit's compiled loops (numba's cache; the first call of a
    process also loads numba itself) in a thread of their own, once per process.

    Why: a track's first fit would wait for them; in a thread they load while the
    detector's processes start and the first frames are read and detected
    (`benchmarks/two_hands.py` prints the cost of a run besides its frames).  A call
    of a loop still loading waits for it (numba's compiler lock).
    """

    def load() -> None:
        from handvar.hand import HandModel, named_pose
        from handvar.tracking.frame_fit import fit_frame

        hand, camera, x = HandModel(), Rig.default().cameras[0], named_pose("open")
        seen = np.column_stack([camera.project(hand.joints(x)), np.ones(len(JOINTS))])
        fit_frame([seen], Rig([camera]), hand, x + 1.0, world=hand.joints(x))

    thread = threading.Thread(target=load, name="handvar-compiled-loops", daemon=True)
    thread.start()
    return thread


def track_hands(
    source,
    *,
    calib=None,
    fov: float | None = None,
    scale: float = 1.0,
    hands: int = 2,
    hand_length: float = 185.0,
    model: str = "spheres",
    predictor: str = "rvar",
    seed: int = 0,
    frames: int | None = None,
    progress: bool = False,
    detector="auto",
    mirrored: bool = False,
    keypoint_every: int = 1,
    realtime: bool = False,
    keypoints=None,
    allow_short: bool = False,
    recovery=None,
) -> HandsTrack:
    """Track both hands through a recording (module notes).

    Parameters
    ----------
    source : str, path-like, list of them, or CameraSource
        A video file or an image folder, or one per camera of `calib`; or a live camera
        (`handvar.vision.sources.open_camera`, which takes its calibration, field of view
        and scale), its newest frame each time the tracker is free, until `frames` or its
        ``stop()``.
    calib, fov, scale, hand_length, model, predictor, seed, frames, progress
        As `handvar.track`.
    hands : {1, 2}
        Hands tracked at most.
    detector : {"auto", "mediapipe"} or callable
        The keypoint detector (`handvar.vision.detector.make_detectors`); a detector is
        needed (the hands' identities come from its detections).
    mirrored : bool
        MediaPipe: the frames are mirrored (a selfie camera).
    keypoint_every : int
        Run the detector on every K-th frame only; each hand's last detection is carried
        forward by optical flow over the frames between (`HandsTracker`).
    realtime : bool
        A recording played at its own frame rate, the newest frame taken each time the
        tracker is free (`paced_frames`), as from a camera: each hand's track then has
        ``dropped`` (holding its last pose there) and ``latency``, as one hand's has.
    keypoints : path-like or list of them, optional
        Every hand found per frame, instead of the detector: one ``.json`` detections
        file per camera (`handvar.vision.keypoints.read_detections`; ``handvar
        keypoints --hands 2`` writes one), over the recording's frames, in the pixels of
        its full-resolution frames.
    allow_short : bool
        As `handvar.track`: a video that stops decoding early is used to where it stops.
    recovery : RecoverySettings, optional
        Every hand's (`handvar.tracking.recovery.RecoverySettings`; default
        ``RECOVERY_DEFAULTS``); with the silhouette term
        (`RecoverySettings.with_silhouette_term`) the skin is shared between the hands
        (`HandsTracker`, rule 5).

    Returns
    -------
    HandsTrack
    """
    from handvar.tracking.hands import HandsTracker

    hands = as_int(hands, "hands", minimum=1, maximum=2)
    every = as_int(keypoint_every, "keypoint_every", minimum=1)
    realtime = as_instance(realtime, bool, "realtime")
    scale = as_float(scale, "scale", minimum=0.0, exclusive_minimum=True)
    frames = None if frames is None else as_int(frames, "frames", minimum=1)
    if model == "mesh":
        raise ValueError("model: expected spheres with two hands (the skinned mesh is a "
                         "right hand); got mesh")  # fmt: skip
    played = _HandsFeed(source, calib, fov, scale, frames, every, realtime, allow_short)
    opened, live = played.opened, played.live
    reading, detectors, outside = _hands_found(played, keypoints, detector, mirrored, realtime)
    items = reading
    if progress and not realtime:
        from tqdm import tqdm

        items = tqdm(items, total=played.total, desc="tracking", unit="frame", leave=False)
    seconds, rows, latency = [], [], []
    clock0 = None
    with contextlib.closing(reading):  # an error in the fit stops what reads ahead
        # MediaPipe as the detector looks again where it missed a hand (rule 6)
        look = "mediapipe" if _detector_name(detector, detectors) == "mediapipe" else None
        tracker = HandsTracker(opened.rig, hands=hands, detector=None, predictor=predictor,
                               hand_length=hand_length, model=model, seed=seed,
                               keypoint_every=every, back=not (realtime or live), look=look,
                               mirrored=mirrored, recovery=recovery)  # fmt: skip
        with tracker:
            for index, captured, images, found in items:
                given = None if found is None else [
                    [_scaled(d, played.scale, size) for d in ds]
                    for ds, size in zip(found, played.sizes, strict=True)
                ]  # fmt: skip
                t0 = time.perf_counter()
                if clock0 is None:  # the zero of the capture times
                    clock0 = played.origin[0] if played.origin else t0 - captured
                tracker.process(images, detections=given)
                seconds.append(time.perf_counter() - t0)
                rows.append(index)
                latency.append(time.perf_counter() - clock0 - captured)
            tracker.back_fill()  # a recording's hand found late, on the frames before (rule 7)
    name = opened.names[0] if opened.names else "recording"
    if all(h.tracker.recovery is None for h in tracker.hands):
        where = "the detector found" if keypoints is None else "the keypoint file has"
        raise ValueError(f"{name}: expected a hand; {where} none in its {len(seconds)} "
                         f"frames")  # fmt: skip
    dropped = list(source.dropped) if live else played.dropped
    n_played = max([rows[-1], *dropped]) + 1
    timing = {}
    if realtime or live:  # one frame at a time, as it comes
        lag = _with_rows(latency, rows, n_played, fill=np.nan)
        timing = {"dropped": np.isnan(lag), "latency": lag}
    tracks = {}
    for h in tracker.hands:
        if h.tracker.recovery is None:  # never seen
            continue
        r = h.tracker.recovered(keypoints=True)
        result, quality = r.track, r.quality
        if timing:
            result, quality = _with_dropped(r, np.asarray(rows), n_played)
        tracks[h.id] = Track(
            poses=result.poses, joints=result.joints,
            projected=project_joints(played.full, result.joints), quality=quality,
            rig=played.full, shape=r.shape, name=name, predictor=predictor, seed=seed,
            fps=opened.fps, result=result, **timing,
            options={"source": [str(p) for p in played.paths] or name,
                     "kind": "camera" if live else "recording", "hands": hands,
                     "scale": played.scale, "hand_length": hand_length, "model": model,
                     "hand": h.side, "keypoints": True, "recover": True,
                     "keypoint_every": every, "keypoint_tips": h.tracker.tips,
                     "realtime": realtime or live,
                     "detector": _detector_name(detector, detectors),
                     "outside_keypoints": outside},
        )  # fmt: skip
    # a camera's frames cannot be read again: no overlay over them
    return HandsTrack(tracks, name, opened.fps, _with_rows(seconds, rows, n_played),
                      source=None if live else opened)  # fmt: skip


class _HandsFeed:
    """The frames `track_hands` plays: ``(index, capture seconds, images, originals on
    the detector's frames else None)`` of a recording (paced with ``realtime``, its
    skipped frames in `dropped`) or of a live camera (its own scale)."""

    def __init__(self, source, calib, fov, scale, frames, every: int, realtime: bool,
                 allow_short: bool = False) -> None:  # fmt: skip
        from handvar.vision.sources import CameraSource, open_source

        self.dropped: list[int] = []  # realtime: the recording's frames skipped
        self.origin: list[float] = []  # realtime: the clock's reading at the first capture
        self.live = isinstance(source, CameraSource)
        if self.live:  # its frames as delivered
            if realtime:
                raise ValueError("realtime: expected a recording (a video file or an "
                                 "image folder); got a live camera, tracked as it comes "
                                 "anyway")  # fmt: skip
            if calib is not None or fov is not None or scale != 1.0:
                raise ValueError("calib, fov, scale: expected none with a live camera "
                                 "(open_camera takes the calibration, field of view and "
                                 "scale)")  # fmt: skip
            self.opened, self.full, self.paths, self.scale = source, source.rig, [], 1.0
            self.total, self.sizes = frames, [source.image_size]
            self._feed = ((i, t, images, images if i % every == 0 else None)
                          for i, t, images in source.stream(stop=frames))  # fmt: skip
            return
        paths = str(source).split(",") if isinstance(source, str) else source
        self.paths = list(paths) if isinstance(paths, list | tuple) else [paths]
        self.opened = open_source(self.paths, calib, fov=fov, scale=scale,
                                  allow_short=allow_short)  # fmt: skip
        self.full = (self.opened.rig if scale == 1.0
                     else open_source(self.paths, calib, fov=fov,
                                      allow_short=allow_short).rig)  # fmt: skip
        self.scale, self.sizes = scale, [r.size for r in self.opened.readers]
        n = self.opened.n_frames
        self.total = n if frames is None else min(frames, n)
        read = self.opened.frames(stop=frames, originals=True)
        played = ((i, (images, originals)) for i, images, originals in read)
        if realtime:
            played = paced_frames(played, self.opened.fps, self.dropped, origin=self.origin)
        else:
            played = ((i, 0.0, pair) for i, pair in played)
        self._feed = ((i, t, images, originals if i % every == 0 else None)
                      for i, t, (images, originals) in played)  # fmt: skip

    def __iter__(self):
        return self._feed


def _hands_found(played: _HandsFeed, keypoints, detector, mirrored: bool, realtime: bool):
    """``(index, seconds, images, found)`` of every frame played, `found` per camera the
    hands read from `keypoints` or found by the detector (None on a frame it skips);
    the detectors (None with `keypoints`); the points of `keypoints` dropped as outside
    the frames (`check_detections`)."""
    from handvar.vision.detector import detect_ahead, make_detectors

    if keypoints is not None:  # the hands found, read from files
        found, outside = _detection_files(keypoints, played)
        items = ((i, t, images, None if o is None else [f[i] for f in found])
                 for i, t, images, o in played)  # fmt: skip
        return items, None, outside
    detectors = make_detectors("mediapipe" if detector == "auto" else detector,
                               len(played.opened.rig), mirrored=mirrored)  # fmt: skip
    if detectors is None:
        raise ValueError("detector: expected a keypoint detector with hands=2; got none")
    depth = 1 if realtime or played.live else 4  # one frame at a time, as it comes
    return detect_ahead(iter(played), detectors, depth=depth), detectors, 0


def _detection_files(keypoints, played: _HandsFeed) -> tuple[list[list], int]:
    """Per camera of the recording `played`, the hands found per frame, read from
    `keypoints` (one ``.json`` detections file per camera, over the recording's frames),
    and the points dropped as outside the frames (`check_detections`)."""
    from handvar.vision.keypoints import check_detections, read_detections

    opened = played.opened
    if played.live:
        raise ValueError("keypoints: expected none with a live camera (the detector runs "
                         "on its frames); got a file")  # fmt: skip
    files = [keypoints] if isinstance(keypoints, str | os.PathLike) else list(keypoints)
    if len(files) != len(opened.rig):
        raise ValueError(f"keypoints: expected one detections file per camera "
                         f"({len(opened.rig)}); got {len(files)}")  # fmt: skip
    found, outside = [], 0
    for path, camera in zip(files, played.full.cameras, strict=True):
        suffix = Path(path).suffix.lower()
        if suffix != ".json":
            raise ValueError(f"{path}: expected a .json detections file with every hand found "
                             f"(handvar keypoints --hands 2 writes one); got {suffix!r}, "
                             f"one hand's keypoints")  # fmt: skip
        frames = read_detections(path)
        if 0 < len(frames) < opened.n_frames and opened.readers[len(found)].may_end_early:
            warnings.warn(f"{path}: the hands found in {len(frames)} frames, the video's "
                          f"container states {opened.n_frames}; frames after {len(frames)} "
                          f"taken without a hand (--allow-short)", stacklevel=2)  # fmt: skip
            frames = frames + [[] for _ in range(opened.n_frames - len(frames))]
        if len(frames) != opened.n_frames:
            raise ValueError(f"{path}: expected the hands found in each of the recording's "
                             f"{opened.n_frames} frames; got {len(frames)} frames")  # fmt: skip
        frames, dropped = check_detections(frames, camera.size, str(path))
        found.append(frames)
        outside += dropped
    return found, outside


def _with_rows(values: list, rows: list, n: int, fill: float = 0.0) -> np.ndarray:
    """(n,) `values` at their `rows`, `fill` on the frames between (dropped)."""
    out = np.full(n, fill)
    out[rows] = values
    return out


def _scaled(d, scale: float, size):
    """A detection of a full-resolution frame in the frame resized by `scale`."""
    if scale == 1.0:
        return d
    import dataclasses

    from handvar.vision.keypoints import scaled_pixels

    points = d.points.copy()
    points[:, :2] = scaled_pixels(points[:, :2], scale, size)
    return dataclasses.replace(d, points=points)
