"""One call from a recording (or a sequence) to a track: `track` and its `Track`.

`track` assembles the whole pipeline of design §1 with every default decided in one
place: the source is opened (`handvar.vision.sources.open_source`, or a sequence read
or synthesised), its skin-colour silhouettes computed, the detected keypoints read,
thinned to every K-th frame and carried by optical flow over the frames between
(design §14.5), the hand model built, the tracker set up with the motion predictor,
and every frame fitted, with the recovery of design §14.3 (refinement, re-seeding,
re-initialisation of lost frames) on recordings and wherever there are keypoints.
`handvar track`, the example and the studies all call it.

The defaults it decides:

- ``carry``: "forward" for a recording with keypoints (online: from the last
  detection), else "none";
- ``keypoint_tips``: "pad" on a recording (a detector marks the pad, design §14.6),
  "end" on a sequence (its keypoints are G(x) projected);
- ``recover``: on for a recording and wherever there are keypoints;
- the wrist: with keypoints and recovery it is cut while tracking (at the detected
  wrist, else at the previous fit's); otherwise with the silhouettes;
- empty silhouettes are allowed (carried by the prediction) only with recovery;
- the first pose: ``init``, else the sequence's true first pose (a synthetic or
  rendered sequence), else searched in the first frame (with recovery).
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from handvar.camera import Rig, check_in_front
from handvar.hand.anthropometry import JOINTS, SIDES, HandShape
from handvar.params import NAMES
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = ["CARRY", "KEYPOINT_TIPS", "MODELS", "Track", "track"]

#: How detected keypoints are carried over the frames without a detection (design §14.5).
CARRY: tuple[str, ...] = ("forward", "both", "none")
#: The model point a detected fingertip is compared with (design §14.6).
KEYPOINT_TIPS: tuple[str, ...] = ("end", "pad")
#: Surfaces of the tracked hand model.
MODELS: tuple[str, ...] = ("spheres", "mesh")

#: The columns of a track's per-frame quality (`handvar.tracking.recovery.TrackQuality`).
_QUALITY_PREFIX = "quality_"
_SHAPE_PREFIX = "shape_"


@dataclass(eq=False)
class Track:
    """A tracked recording or sequence: poses, joints, their projections and fit quality.

    Attributes
    ----------
    poses : (T, 26) ndarray
        Fitted poses, the 26 parameters of `handvar.params` (mm and degrees).
    joints : (T, 21, 3) ndarray
        The 21 joints G(x) of every frame, mm, world frame of the rig (the camera frame
        for one camera).
    projected : (n_cameras, T, 21, 2) ndarray
        The joints projected into every camera, pixels of the full-resolution frames.
    quality : TrackQuality or None
        Per frame: silhouette IoU, keypoint error, cost, lost, re-initialised, empty,
        with keypoints (`handvar.tracking.recovery.TrackQuality`); None without
        recovery.
    rig : Rig
        The cameras, for the full-resolution frames.
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
    """

    poses: np.ndarray
    joints: np.ndarray
    projected: np.ndarray
    quality: Any
    rig: Rig
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
        """The tracked `HandModel` (its shape and surface)."""
        from handvar.hand.kinematics import HandModel

        return HandModel(self.shape, surface=self.options.get("model", "spheres"))

    def save(
        self, directory: str | os.PathLike, *, video: bool = True, overlays: bool = True
    ) -> dict[str, Path | str]:
        """Write the track into `directory`, as ``handvar track --out`` does.

        poses.csv, joints.csv, track.npz (with what `Track.load` needs), quality.csv
        with recovery, overlay.png and, with `video`, overlay.mp4
        (`handvar.tracking.outputs.write_track_outputs`; all-or-nothing).

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
        )  # fmt: skip

    def _extra_arrays(self) -> dict[str, np.ndarray]:
        """What track.npz keeps beyond the tracker's record, for `load`."""
        arrays = {
            "projected": self.projected,
            "search_seconds": np.asarray(self.search_seconds, dtype=float),
            "meta": np.array(json.dumps({
                "name": self.name, "fps": self.fps, "rig": self.rig.to_dict(),
                "options": self.options, "stage_seconds": self.stage_seconds,
            })),
        }  # fmt: skip
        if self.detections is not None:
            arrays["detections"] = np.asarray(self.detections, dtype=bool)
        for f in dataclasses.fields(HandShape):
            if f.init:
                arrays[_SHAPE_PREFIX + f.name] = np.asarray(getattr(self.shape, f.name))
        if self.quality is not None:
            for f in dataclasses.fields(self.quality):
                arrays[_QUALITY_PREFIX + f.name] = np.asarray(getattr(self.quality, f.name))
        return arrays

    @classmethod
    def load(cls, directory: str | os.PathLike) -> Track:
        """Read a track written by `save` (or ``handvar track --out``) from `directory`.

        The frames are not kept with a track: the loaded one has ``sequence`` and
        ``source`` None.

        Raises
        ------
        ValueError
            If track.npz is missing what `save` writes.
        """
        from handvar.tracking.recovery import TrackQuality
        from handvar.tracking.tracker import TrackResult

        path = Path(directory) / "track.npz"
        with np.load(path, allow_pickle=False) as z:
            stored = {name: z[name] for name in z.files}
        missing = [n for n in ("meta", "projected", f"{_SHAPE_PREFIX}length") if n not in stored]
        if missing:
            raise ValueError(
                f"{path}: expected a track saved by handvar.Track.save; missing {missing}"
            )
        meta = json.loads(str(stored["meta"]))
        result = TrackResult(**{f.name: stored[f.name] for f in dataclasses.fields(TrackResult)})
        shape = HandShape(**{
            f.name: _scalar(stored[_SHAPE_PREFIX + f.name])
            for f in dataclasses.fields(HandShape) if f.init
        })  # fmt: skip
        quality = None
        if f"{_QUALITY_PREFIX}iou" in stored:
            quality = TrackQuality(**{
                f.name: stored[_QUALITY_PREFIX + f.name] for f in dataclasses.fields(TrackQuality)
            })  # fmt: skip
        return cls(
            poses=result.poses, joints=result.joints, projected=stored["projected"],
            quality=quality, rig=Rig.from_dict(meta["rig"]), shape=shape, name=meta["name"],
            predictor=str(stored["predictor"]), seed=int(stored["seed"]), fps=meta["fps"],
            result=result, search_seconds=stored["search_seconds"],
            detections=stored.get("detections"), options=meta["options"],
            stage_seconds=meta["stage_seconds"],
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
            pixels of the full-resolution frames).

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
            for cam, uv in zip(self.rig.names, self.projected, strict=True):
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
        return pd.DataFrame(columns, index=pd.RangeIndex(T, name="frame"))


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
    hand: str = "right",
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
    recovery=None,
    on_frame: Callable | None = None,
) -> Track:
    """Track the hand through a recording or a sequence (module notes: the defaults).

    Parameters
    ----------
    source : str, path-like or list of them
        A video file or an image folder, a list of them (one per camera of `calib`;
        or a comma-separated string), a sequence directory (`handvar.io`) or the name
        of a synthetic sequence (`handvar.synth.SEQUENCE_NAMES`).
    keypoints : path-like, (T, 21, 2|3) array_like, Keypoints2D, or a list of them, optional
        2D keypoints of the 21 points (`handvar.vision.keypoints`), pixels of the
        full-resolution frames: a file (.npy or .csv), an array or a `Keypoints2D`; a
        list gives one per camera, in order.
    calib : path-like or Rig, optional
        Recordings only: the calibration (`handvar.camera.Rig.load`); one video
        without it gets an assumed camera.
    fov : float, optional
        One uncalibrated video: the assumed horizontal field of view, degrees.
    scale : float
        Recordings only: resize the frames by this factor first (0.5 is about 4x
        faster).
    hand : {"right", "left"}
        Which hand is tracked.
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
        with keypoints only); default "forward" there, else "none".
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
    recovery : RecoverySettings, optional
        Settings of the recovery (`handvar.tracking.recovery.RECOVERY_DEFAULTS`).
    on_frame : callable, optional
        With recovery: called as ``on_frame(i, pose, quality, masks)`` after every frame
        (`track_with_recovery`), for instance to keep the silhouettes fitted.

    Returns
    -------
    Track

    Raises
    ------
    ValueError
        Naming the argument at fault (``keypoint_every: expected ...``), before any
        frame is read where it can be.
    """
    seed = as_int(seed, "seed", minimum=0)
    keypoint_every = as_int(keypoint_every, "keypoint_every", minimum=1)
    if frames is not None:
        frames = as_int(frames, "frames", minimum=1)
    scale = as_float(scale, "scale", minimum=0.0, exclusive_minimum=True)
    hand_length = as_float(hand_length, "hand_length", minimum=0.0, exclusive_minimum=True)
    one_of(hand, (*SIDES, "auto"), "hand")
    one_of(model, MODELS, "model")
    if carry is not None:
        one_of(carry, CARRY, "carry")
    if keypoint_tips is not None:
        one_of(keypoint_tips, KEYPOINT_TIPS, "keypoint_tips")
    if recover is not None:
        as_instance(recover, bool, "recover")
    if hand == "left" and model == "mesh":
        raise ValueError(
            "model: expected spheres for a left hand (the skinned mesh is a right hand); got mesh"
        )
    from handvar.predictors.catalogue import catalogue_key, make_predictor

    predictor_key = catalogue_key(as_instance(predictor, str, "predictor"), "predictor")
    spec, label = _resolve_source(source)
    detected = _read_keypoints(keypoints, spec, keypoint_every)
    if carry not in (None, "none") and (detected is None or spec.kind != "recording"):
        got = "no keypoints" if spec.kind == "recording" else f"the {spec.kind} sequence {label!r}"
        raise ValueError(
            f"carry: expected a recording (a video file or an image folder) with "
            f"keypoints for {carry}; got {got}"
        )
    recording = spec.kind == "recording"
    if carry is None:
        carry = "forward" if detected is not None and recording else "none"
    if recover is None:
        recover = recording or detected is not None
    if (recovery is not None or on_frame is not None) and not recover:
        raise ValueError("recovery, on_frame: expected only with recover")
    if keypoint_tips is None:  # a detector's keypoints on a recording, else G(x) projected
        keypoint_tips = "pad" if recording else "end"
    bar = _progress_bar if progress else None

    opened, full_rig, used = None, None, detected  # the recording; its rig; the keypoints
    outside = 0  # keypoints dropped as lying outside the frames
    if hand == "auto" and (detected is None or not recording):
        raise ValueError(
            "hand: auto expected a recording with keypoints with handedness; got "
            + ("no keypoints" if detected is None else f"the {spec.kind} sequence {label!r}")
        )
    stage_seconds = {}
    # A recording with keypoints and recovery is tracked online: each frame read once,
    # its keypoints carried forward, its silhouette computed only if the frame needs it.
    online = recording and detected is not None and recover and carry != "both"
    stream = None
    if recording:
        from handvar.vision.sources import open_source

        opened = open_source(list(spec.paths), calib, fov=fov, scale=scale)
        full_rig = opened.rig if scale == 1.0 else open_source(list(spec.paths), calib, fov=fov).rig
        total = opened.n_frames if frames is None else min(frames, opened.n_frames)
        clock = time.perf_counter()
        if detected is not None:
            from handvar.vision.keypoints import check_keypoints

            detected, hand, dropped = check_keypoints(
                detected, opened.n_frames, [r.size for r in opened.readers], hand
            )
            outside = dropped
    if online:
        from handvar.io import Sequence

        if len(detected) != opened.n_cameras:
            raise ValueError(
                f"keypoints: expected one file per camera ({opened.n_cameras}); got {len(detected)}"
            )
        stream = opened.online(detected, stop=frames, carry=carry == "forward")
        sequence = Sequence(
            name=Path(opened.readers[0].path).stem, fps=opened.fps, rig=opened.rig,
            masks=opened.lazy_masks(total),
            provenance={"source": [str(r.path) for r in opened.readers], "scale": scale,
                        "calibrated": opened.calibrated},
        )  # fmt: skip
        used = None
    elif recording:
        # With keypoints and recovery the wrist is cut while tracking (at the detected
        # wrist, else at the tracked model's); otherwise here.
        sequence = opened.to_sequence(
            stop=frames, allow_empty=recover,
            progress=None if bar is None else bar("silhouettes", total),
            **({"wrist": False} if recover and detected is not None else {"keypoints": detected}),
        )  # fmt: skip
        stage_seconds["silhouettes"] = time.perf_counter() - clock
        clock = time.perf_counter()
        if carry != "none":
            used = opened.carried_keypoints(detected, stop=frames, both=carry == "both")
        elif detected is not None:
            used = opened.scaled_keypoints(detected)
        stage_seconds["keypoints"] = time.perf_counter() - clock
    elif calib is not None or fov is not None:
        raise ValueError("calib, fov: expected only with a video or an image folder")
    elif spec.kind == "directory":
        from handvar.io import read_sequence

        sequence = read_sequence(spec.paths[0], lazy=True)
    else:
        from handvar.synth.sequences import make_sequence

        sequence = make_sequence(spec.name, n_frames=frames)
    if full_rig is None:
        full_rig = sequence.rig
    if used is not None and len(used) != len(sequence.rig):
        raise ValueError(
            f"keypoints: expected one file per camera ({len(sequence.rig)}); got {len(used)}"
        )
    x0 = _first_pose(init, sequence, recover, label)

    from handvar.hand.kinematics import HandModel
    from handvar.tracking import CostSettings, Tracker, TrackerSettings

    hand_model = HandModel(HandShape.from_size(hand_length, side=hand), surface=model)
    if x0 is not None:
        check_in_front(hand_model.joints(x0), sequence.rig, "init" if init is not None else label)
    settings = TrackerSettings(cost=CostSettings(keypoint_tips=keypoint_tips))
    tracker = Tracker(
        sequence.rig, hand_model, make_predictor(predictor_key), np.random.default_rng(seed),
        settings,
    )  # fmt: skip
    quality, search_seconds = None, np.zeros(0)
    clock = time.perf_counter()
    if recover:
        from handvar.tracking.recovery import track_with_recovery

        n = sequence.n_frames if frames is None else min(frames, sequence.n_frames)
        if stream is not None:
            given: list = []
            masks = _online_masks(stream, given)
            at = given.__getitem__
        else:
            masks = (np.asarray(sequence.masks[t]) for t in range(n))
            at = None if used is None else _keypoints_at(used)
        if bar is not None:
            masks = bar(f"tracking {sequence.name}", n)(masks)
        extra = {} if recovery is None else {"settings": recovery}
        if on_frame is not None:
            extra["on_frame"] = on_frame
        world = None  # the detector's metric 3D, a weak cue of the fit (first camera)
        if detected is not None and detected[0] is not None and detected[0].world is not None:
            world = detected[0].world.__getitem__
        recovered = track_with_recovery(
            tracker, masks, x0, keypoints=at, world=world,
            cut_wrist=opened is not None and detected is not None, **extra,
        )  # fmt: skip
        result, quality = recovered.track, recovered.quality
        hand_model = tracker.hand  # the shape adapted to the first frames
        if stream is not None:
            used = _as_keypoints(given, len(sequence.rig))
        search_seconds = np.asarray(recovered.init_seconds, dtype=float)
    else:
        result = tracker.track(
            sequence, x0, frames=frames, keypoints=used,
            progress=None if bar is None else bar(f"tracking {sequence.name}", None),
        )  # fmt: skip
    stage_seconds["tracking"] = time.perf_counter() - clock
    T = result.poses.shape[0]
    points = result.joints.reshape(-1, 3)
    finite = np.isfinite(points).all(axis=1)  # no pose before the hand is first seen
    projected = np.full((len(full_rig), len(points), 2), np.nan)
    for j, cam in enumerate(full_rig.cameras):
        projected[j, finite] = cam.project(points[finite])
    projected = projected.reshape(len(full_rig), T, -1, 2)
    seen = None
    if detected is not None:
        seen = np.zeros(T, dtype=bool)
        for k in detected:
            seen[: min(T, k.n_frames)] |= k.present[:T].any(axis=1)
    options = {
        "source": [str(p) for p in spec.paths] or spec.name, "kind": spec.kind,
        "hand_length": hand_length, "model": model, "scale": scale, "init": init is not None,
        "keypoints": detected is not None, "keypoint_every": keypoint_every, "carry": carry,
        "keypoint_tips": keypoint_tips, "recover": recover, "frames": frames,
        "hand": hand, "outside_keypoints": outside,
    }  # fmt: skip
    return Track(
        poses=result.poses, joints=result.joints, projected=projected, quality=quality,
        rig=full_rig, shape=hand_model.shape, name=sequence.name, predictor=predictor,
        seed=seed, fps=None if sequence.fps is None else float(sequence.fps), result=result,
        search_seconds=search_seconds, detections=seen, keypoints=used, options=options,
        stage_seconds=stage_seconds, sequence=sequence, source=opened,
    )  # fmt: skip


def _resolve_source(source):
    """The `SequenceSpec` of `source` and how messages name it."""
    from handvar.io import SequenceSpec, resolve_sequence
    from handvar.synth.sequences import SEQUENCE_NAMES

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


def _read_keypoints(keypoints, spec, every: int):
    """Per camera a `Keypoints2D` (every `every`-th frame), or None without keypoints."""
    if keypoints is None:
        if every != 1:
            raise ValueError("keypoint_every: expected only with keypoints")
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
        out.append(entry.every(every))
    return out


def _first_pose(init, sequence, recover: bool, label: str) -> np.ndarray | None:
    """The pose of the first frame, or None to search it (module notes)."""
    if init is not None:
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
    if sequence.truth is not None:
        return sequence.truth.poses[0]
    if recover:
        return None  # searched in the first frame
    raise ValueError(f"{label}: the sequence has no ground truth; give the first pose with init")


def _online_masks(stream, given: list):
    """The masks callables of `VideoSource.online`'s frames; each frame's keypoints are
    appended to `given` before its masks are yielded (`track_with_recovery` asks for
    frame i's keypoints after taking its masks)."""
    for _, masks, kps in stream:
        given.append(None if all(k is None for k in kps) else kps)
        yield masks


def _as_keypoints(given: list, n_cams: int) -> list:
    """The keypoints given frame by frame, as one `Keypoints2D` per camera."""
    from handvar.vision.keypoints import Keypoints2D

    out = []
    for j in range(n_cams):
        a = np.full((len(given), 21, 3), np.nan)
        a[:, :, 2] = 0.0
        for t, kps in enumerate(given):
            if kps is not None and kps[j] is not None:
                a[t] = kps[j]
        out.append(Keypoints2D.from_array(a, name=f"camera {j}"))
    return out


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
