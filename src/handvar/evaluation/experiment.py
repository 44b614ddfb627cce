"""The paper's tracking experiments at scale (§4–5, DESIGN.md §7), on Dask distributed.

One experiment is a set of predictors × trials on one synthetic sequence.  A trial
tracks the whole sequence from its true first pose with one predictor; trials differ
only by the seed of the optimiser's random generator, ``default_rng([seed, trial])``,
which is the same for every predictor, so trial k of a predictor is compared with
trial k of no motion (R̃², eq. 18 and 21).

Everything goes to ONE Zarr store (written through xarray, Zarr format 2):

=====================  =====================================  ========================
variable               dims                                   meaning
=====================  =====================================  ========================
``poses``              predictor, trial, frame, param         estimates x_t (mm, deg)
``joints``             predictor, trial, frame, joint, xyz    G(x_t) (mm)
``error``              predictor, trial, frame                mean joint error (mm)
``cost``               predictor, trial, frame                final cost of the frame
``iterations``         predictor, trial, frame                optimiser iterations
``timings``            predictor, trial, frame, part          seconds per frame
``r2_joints``          predictor, trial, joint                R̃² of eq. 21
``r2_params``          predictor, trial, param                R̃²_y of eq. 18
``done``               predictor, trial                       the trial is complete
``writes``             predictor, trial                       times the trial was written
``truth_poses``        frame, param                           x*
``truth_joints``       frame, joint, xyz                      z* = G(x*)
``masks``              frame, camera, y, x                    the silhouettes tracked
=====================  =====================================  ========================

Attributes: ``config`` (the :class:`ExperimentConfig` as JSON), ``rig`` (the cameras,
``Rig.to_dict()``), ``provenance`` (of the sequence) and ``fps``.

The store is created in full before any trial runs (arrays of NaN, ``done`` False),
and every finished trial is written into its own chunks as soon as its result
arrives, ``done`` last; Zarr's local store writes each chunk atomically.  Killing a
worker or the whole run therefore loses no finished trial, the store stays readable
at any moment, and running again with the same store computes only the trials not
yet done.  The same configuration gives the same store (all arrays but ``timings``).

Examples
--------
>>> cfg = ExperimentConfig.quick().with_overrides(["trials=2"])
>>> cfg.trials, cfg.frames, [s.label for s in cfg.predictors][:2]
(2, 40, ['no motion', 'decelerating'])
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from handvar import params
from handvar.evaluation.metrics import mean_joint_error, r2_tilde_acceleration, r2_tilde_joints
from handvar.predictors.catalogue import (
    ARG_ALIASES,
    CATALOGUE,
    EXTRA_PREDICTORS,
    PAPER_PREDICTORS,
    PredictorSpec,
    json_scalar,
)

__all__ = [
    "EXTRA_PREDICTORS",
    "PAPER_PREDICTORS",
    "TIMING_PARTS",
    "TRIAL_KINDS",
    "ExperimentConfig",
    "PredictorSpec",
    "RunSummary",
    "TrialResult",
    "open_store",
    "read_config",
    "run_experiment",
    "run_trial",
    "store_sequence",
    "summary_text",
    "tracker_settings",
]

FORMAT = "handvar-experiment"
FORMAT_VERSION = 1

# --- configuration -----------------------------------------------------------------

TRIAL_KINDS = ("tracker", "openloop")


def _parse_value(text: str) -> Any:
    """``true``/``false``/``none``, an int, a float, else the string itself."""
    low = text.strip().lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("none", "null"):
        return None
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return text.strip()


def _split_assignment(text: str, what: str) -> tuple[str, str]:
    if not isinstance(text, str) or "=" not in text:
        raise ValueError(f"{what}: expected KEY=VALUE; got {text!r}")
    key, value = text.split("=", 1)
    key = key.strip()
    if not key:
        raise ValueError(f"{what}: expected KEY=VALUE; got {text!r}")
    return key, value


def _format_value(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


@dataclasses.dataclass(frozen=True)
class ExperimentConfig:
    """One experiment: the paper's protocol (§4, DESIGN.md §7) by default.

    Attributes
    ----------
    sequence : str
        Synthetic sequence (``benchmark``, ``flexion``, ``flip``), rendered once.
    sequence_seed : int
        Seed of the sequence's motion.
    frames : int
        First frames of the sequence to track (the paper: all 175).
    trials : int
        Trials per predictor (the paper: 50).
    seed : int
        Trial k uses ``numpy.random.default_rng([seed, k])`` for every predictor.
    predictors : tuple of PredictorSpec
        The paper's five (:data:`PAPER_PREDICTORS`); :meth:`with_extras` adds
        the relative RVAR and the Kalman filter.
    trial_kind : {"tracker", "openloop"}
        ``"tracker"``: the SMD tracker on the silhouettes (the experiment of the
        paper).  ``"openloop"``: no tracker; the predictor runs one step ahead along
        the truth plus Gaussian noise of standard deviation `noise` (mm, degrees), and
        its predictions are the poses -- a quick check of predictors and machinery.
    noise : float
        Noise of the ``openloop`` trials.
    tracker : tuple of (str, value) pairs
        Overrides of the tracker's settings (the paper's by default, §4).
    """

    sequence: str = "benchmark"
    sequence_seed: int = 0
    frames: int = 175
    trials: int = 50
    seed: int = 0
    predictors: tuple[PredictorSpec, ...] = PAPER_PREDICTORS
    trial_kind: str = "tracker"
    noise: float = 2.0
    tracker: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        from handvar.synth.sequences import SEQUENCE_NAMES

        if self.sequence not in SEQUENCE_NAMES:
            raise ValueError(
                f"sequence: expected one of {', '.join(SEQUENCE_NAMES)}; got {self.sequence!r}"
            )
        for name, low in (("sequence_seed", 0), ("frames", 3), ("trials", 1), ("seed", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(f"{name}: expected an integer >= {low}; got {value!r}")
            object.__setattr__(self, name, int(value))
        if self.trial_kind not in TRIAL_KINDS:
            raise ValueError(
                f"trial_kind: expected one of {', '.join(TRIAL_KINDS)}; got {self.trial_kind!r}"
            )
        if not (isinstance(self.noise, int | float) and np.isfinite(self.noise)) or self.noise < 0:
            raise ValueError(f"noise: expected a finite number >= 0; got {self.noise!r}")
        object.__setattr__(self, "noise", float(self.noise))
        specs = tuple(self.predictors)
        if not specs or not all(isinstance(s, PredictorSpec) for s in specs):
            raise ValueError("predictors: expected a non-empty tuple of PredictorSpec")
        for attr in ("key", "label"):
            names = [getattr(s, attr) for s in specs]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"predictors: expected distinct {attr}s; got {dup} twice")
        object.__setattr__(self, "predictors", specs)
        tracker = dict(self.tracker.items() if isinstance(self.tracker, Mapping) else self.tracker)
        object.__setattr__(
            self, "tracker", tuple(sorted((k, json_scalar(v)) for k, v in tracker.items()))
        )

    # -- presets and changes ----------------------------------------------------
    @classmethod
    def quick(cls) -> ExperimentConfig:
        """A reduced protocol for a demonstration: 3 trials of the first 40 frames."""
        return cls(trials=3, frames=40)

    @property
    def reference(self) -> PredictorSpec | None:
        """The no-motion entry R̃² is measured against (the first of kind ``none``)."""
        return next((s for s in self.predictors if s.kind == "none"), None)

    @property
    def labels(self) -> list[str]:
        """The predictors' labels, in order."""
        return [s.label for s in self.predictors]

    def spec(self, key_or_label: str) -> PredictorSpec:
        """The predictor entry with this key or label."""
        for s in self.predictors:
            if key_or_label in (s.key, s.label):
                return s
        raise ValueError(
            f"predictor: expected one of {', '.join(s.key for s in self.predictors)}; "
            f"got {key_or_label!r}"
        )

    def with_extras(self) -> ExperimentConfig:
        """Add the relative RVAR and the Kalman filter (those not yet present)."""
        keys = {s.key for s in self.predictors}
        extra = tuple(s for s in EXTRA_PREDICTORS if s.key not in keys)
        return dataclasses.replace(self, predictors=self.predictors + extra)

    def with_overrides(self, assignments: Iterable[str]) -> ExperimentConfig:
        """Apply ``KEY=VALUE`` assignments (the command line's ``--set``).

        Keys: a field (``trials``, ``frames``, ``seed``, ``sequence``,
        ``sequence_seed``, ``trial_kind`` or ``trial``, ``noise``); ``predictors`` with
        a comma-separated list of keys (``none,decelerating,rvar,rvar_relative,kalman``
        ...); ``extras=true``; ``tracker.FIELD`` for a tracker setting;
        ``PREDICTOR.ARG`` for a predictor's argument (``rvar.gamma=0.7``,
        ``decelerating.rho=0.5``, ``structured_var.N=20``).
        """
        cfg = self
        for text in assignments:
            key, raw = _split_assignment(text, "--set")
            value = _parse_value(raw)
            if key == "trial":
                key = "trial_kind"
            if key == "predictors":
                wanted = [k.strip() for k in str(raw).split(",") if k.strip()]
                unknown = [k for k in wanted if k not in CATALOGUE]
                if unknown or not wanted:
                    raise ValueError(
                        f"--set predictors: expected keys among {', '.join(CATALOGUE)}; got {raw!r}"
                    )
                cfg = dataclasses.replace(cfg, predictors=tuple(CATALOGUE[k] for k in wanted))
            elif key == "extras":
                if value is True:
                    cfg = cfg.with_extras()
                elif value is not False:
                    raise ValueError(f"--set extras: expected true or false; got {raw!r}")
            elif key.startswith("tracker."):
                group, field = _tracker_key(key.split(".", 1)[1])
                name = f"{group}.{field}"
                tracker_settings([(name, value)])  # checks the value
                kept = tuple((k, v) for k, v in cfg.tracker if k != name)
                cfg = dataclasses.replace(cfg, tracker=(*kept, (name, value)))
            elif "." in key:
                pkey, arg = key.split(".", 1)
                spec = cfg.spec(pkey)
                new = spec.with_params(**{arg: value})
                new.build()
                cfg = dataclasses.replace(
                    cfg, predictors=tuple(new if s is spec else s for s in cfg.predictors)
                )
            elif key in {f.name for f in dataclasses.fields(self)} - {"predictors", "tracker"}:
                cfg = dataclasses.replace(cfg, **{key: value})
            else:
                raise ValueError(
                    f"--set: expected a field ({', '.join(_SETTABLE)}), tracker.FIELD or "
                    f"PREDICTOR.ARG; got {key!r}"
                )
        return cfg

    def with_sweep(self, text: str) -> ExperimentConfig:
        """Add swept variants of one predictor: ``"rvar.gamma=0.5,0.6,0.7"``.

        Each value becomes an extra predictor entry labelled like ``RVAR (gamma=0.5)``;
        a value equal to the entry's own setting is not repeated.
        """
        key, raw = _split_assignment(text, "--sweep")
        if "." not in key:
            raise ValueError(f"--sweep: expected PREDICTOR.ARG=V1,V2,...; got {text!r}")
        pkey, arg = key.split(".", 1)
        base = self.spec(pkey)
        arg = ARG_ALIASES.get(arg, arg)
        values = [_parse_value(v) for v in raw.split(",") if v.strip()]
        if not values:
            raise ValueError(f"--sweep: expected at least one value; got {text!r}")
        specs = list(self.predictors)
        for v in values:
            variant = base.with_params(**{arg: v})
            if variant.params == base.params:
                continue
            variant = dataclasses.replace(
                variant,
                key=f"{base.key}[{arg}={_format_value(v)}]",
                label=f"{base.label} ({arg}={_format_value(v)})",
            )
            variant.build()
            if all(s.key != variant.key for s in specs):
                specs.append(variant)
        return dataclasses.replace(self, predictors=tuple(specs))

    # -- JSON -----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form (stored in the store's attributes)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["predictors"] = [s.to_dict() for s in self.predictors]
        out["tracker"] = dict(self.tracker)
        return out

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string with sorted keys."""
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ExperimentConfig:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, Mapping):
            raise ValueError(f"config: expected a mapping; got {type(data).__name__}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"config: unknown keys {unknown}")
        kw = dict(data)
        if "predictors" in kw:
            kw["predictors"] = tuple(PredictorSpec.from_dict(d) for d in kw["predictors"])
        if "tracker" in kw:
            kw["tracker"] = tuple(dict(kw["tracker"]).items())
        return cls(**kw)

    @classmethod
    def from_json(cls, text: str) -> ExperimentConfig:
        """Inverse of :meth:`to_json`."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"config: expected JSON; {exc}") from None
        return cls.from_dict(data)


_SETTABLE = ("sequence", "sequence_seed", "frames", "trials", "seed", "trial_kind", "noise")


# --- the tracker ---------------------------------------------------------------------


def tracker_settings(overrides: Iterable[tuple[str, Any]] = ()):
    """The tracker's settings (the paper's, §4) with ``("group.field", value)`` overrides.

    A group is a field of :class:`handvar.tracking.TrackerSettings` (``smd``, ``cost``);
    a bare field name (``max_iterations``) is looked up in every group.

    Examples
    --------
    >>> tracker_settings([("max_iterations", 20)]).smd.max_iterations
    20
    """
    from handvar.tracking import TrackerSettings

    base = TrackerSettings()
    groups: dict[str, dict[str, Any]] = {}
    for key, value in overrides:
        group, name = _tracker_key(key)
        groups.setdefault(group, {})[name] = value
    return dataclasses.replace(
        base,
        **{g: dataclasses.replace(getattr(base, g), **kw) for g, kw in groups.items()},
    )


def _tracker_key(key: str) -> tuple[str, str]:
    """(group, field) of a tracker setting; ValueError naming the choices."""
    from handvar.tracking import TrackerSettings

    base = TrackerSettings()
    fields = {
        g.name: {f.name for f in dataclasses.fields(getattr(base, g.name))}
        for g in dataclasses.fields(base)
    }
    choices = ", ".join(f"{g}.{f}" for g in fields for f in sorted(fields[g]))
    if "." in key:
        group, name = key.split(".", 1)
        if name in fields.get(group, ()):
            return group, name
    else:
        hits = [g for g in fields if key in fields[g]]
        if len(hits) == 1:
            return hits[0], key
    raise ValueError(f"--set tracker.{key}: expected a tracker setting ({choices})")


@functools.lru_cache(maxsize=2)
def _hand():
    from handvar.hand.kinematics import HandModel

    return HandModel()


# --- one trial -----------------------------------------------------------------------


TIMING_PARTS = ("preprocessing", "optimisation", "prediction")


@dataclasses.dataclass(frozen=True, eq=False)
class TrialResult:
    """What one trial produced.

    Attributes
    ----------
    poses : (T, 26) ndarray
        Estimated poses (mm, degrees); ``poses[0]`` is fitted from the true first pose.
    joints : (T, 21, 3) ndarray
        G(poses), mm.
    cost : (T,) ndarray
        Cost at the last iteration of each frame (NaN in open-loop trials).
    iterations : (T,) int ndarray
        Cost evaluations per frame (0 in open-loop trials).
    timings : (T, 3) ndarray
        Seconds per frame spent on preprocessing, optimisation and prediction
        (:data:`TIMING_PARTS`).
    """

    poses: np.ndarray
    joints: np.ndarray
    cost: np.ndarray
    iterations: np.ndarray
    timings: np.ndarray


def _openloop_trial(config, spec, rng, sequence) -> TrialResult:
    """One step ahead along the truth plus noise: the predictions are the 'estimates'."""
    truth = sequence.truth.poses[: config.frames]
    observed = params.clamp(truth + rng.normal(0.0, config.noise, truth.shape))
    observed[0] = truth[0]
    predictor = spec.build()
    n = len(truth)
    poses = np.empty_like(truth)
    timings = np.zeros((n, len(TIMING_PARTS)))
    poses[0] = truth[0]
    predictor.update(observed[0])
    for t in range(1, n):
        start = time.perf_counter()
        poses[t] = params.clamp(predictor.predict())
        predictor.update(observed[t])
        timings[t, 2] = time.perf_counter() - start
    hand = _hand()
    joints = np.stack([hand.joints(x) for x in poses])
    return TrialResult(poses, joints, np.full(n, np.nan), np.zeros(n, dtype=np.int16), timings)


# The frames' preprocessing (distance fields) depends only on the silhouettes and the
# cost settings, so a worker prepares each frame once and shares it between all the
# trials it runs on the same sequence (the scattered sequence is one object per worker).
_PREPARED: dict[tuple[int, str], tuple[object, list]] = {}


def _prepared_frames(tracker, sequence, settings_key: str) -> list:
    key = (id(sequence), settings_key)
    held = _PREPARED.get(key)
    if held is None or held[0] is not sequence:
        _PREPARED.clear()  # one sequence at a time: bounded memory
        frames = [tracker.prepare(np.asarray(sequence.masks[t])) for t in range(sequence.n_frames)]
        held = _PREPARED[key] = (sequence, frames)
    return held[1]


def _tracker_trial(config, spec, rng, sequence) -> TrialResult:
    """The SMD tracker with this predictor on the sequence, from the true first pose.

    The frames are prepared once per worker and sequence (`_prepared_frames`), so the
    timings' preprocessing column is zero for the trials that reuse them.
    """
    from handvar.tracking import Tracker

    settings = tracker_settings(config.tracker)
    tracker = Tracker(sequence.rig, _hand(), spec.build(), rng, settings)
    prepared = _prepared_frames(tracker, sequence, repr(settings.cost))
    result = tracker.track(sequence, sequence.truth.poses[0], prepared=prepared)
    return TrialResult(
        result.poses,
        result.joints,
        result.final_costs,
        result.iterations.astype(np.int16),
        result.seconds,
    )


_TRIALS: dict[str, Callable] = {"tracker": _tracker_trial, "openloop": _openloop_trial}


def run_trial(config: ExperimentConfig, key: str, trial: int, sequence) -> TrialResult:
    """Run one trial: predictor `key` of `config`, trial number `trial`.

    Parameters
    ----------
    config : ExperimentConfig
    key : str
        Key or label of one of ``config.predictors``.
    trial : int
        Trial number; the generator is ``default_rng([config.seed, trial])``.
    sequence : handvar.io.Sequence
        The sequence, with truth, cut to ``config.frames`` frames.

    Returns
    -------
    TrialResult
    """
    spec = config.spec(key)
    if sequence.truth is None:
        raise ValueError("sequence: expected a sequence with ground truth; it has none")
    if sequence.n_frames != config.frames:
        raise ValueError(
            f"sequence: expected {config.frames} frames (config.frames); got {sequence.n_frames}"
        )
    rng = np.random.default_rng([config.seed, int(trial)])
    return _TRIALS[config.trial_kind](config, spec, rng, sequence)


# --- the store ------------------------------------------------------------------------


def store_sequence(store: str | os.PathLike):
    """The tracked sequence as kept in a store (masks, rig, truth) -- a Sequence."""
    from handvar.camera import Rig
    from handvar.io import Sequence, Truth

    ds = open_store(store)
    config = ExperimentConfig.from_json(ds.attrs["config"])
    return Sequence(
        name=config.sequence,
        fps=float(ds.attrs["fps"]),
        rig=Rig.from_dict(json.loads(ds.attrs["rig"])),
        masks=ds["masks"].values,
        truth=Truth(ds["truth_poses"].values, ds["truth_joints"].values),
        provenance=json.loads(ds.attrs["provenance"]),
    )


def open_store(store: str | os.PathLike):
    """Open an experiment store lazily as an ``xarray.Dataset``.

    Variables are read from disk when indexed (``ds["error"].values``), only the
    chunks needed.  Raises ValueError if `store` is not an experiment store.
    """
    import xarray as xr

    path = Path(store)
    if not path.is_dir():
        raise ValueError(f"store: expected an experiment store (a Zarr directory); {path} is not")
    try:
        # chunks=None: lazily indexed numpy arrays, never dask -- reads stay local and
        # cheap even while a distributed client is the default scheduler
        ds = xr.open_zarr(path, consolidated=True, chunks=None)
    except Exception as exc:  # zarr raises many kinds on a foreign directory
        raise ValueError(f"store: {path} is not a readable Zarr store ({exc})") from None
    if ds.attrs.get("format") != FORMAT:
        raise ValueError(f"store: expected a {FORMAT} store; {path} is something else")
    return ds


def read_config(store: str | os.PathLike) -> ExperimentConfig:
    """The configuration an experiment store was made with."""
    return ExperimentConfig.from_json(open_store(store).attrs["config"])


def _template(config: ExperimentConfig, sequence):
    """The whole store, every trial missing (NaN, iterations −1, done False)."""
    import xarray as xr

    from handvar.hand.anthropometry import JOINTS

    P, N, F = len(config.predictors), config.trials, config.frames
    J, D = len(JOINTS), params.N_PARAMS
    w, h = sequence.image_size
    nan = np.nan

    def full(shape, value, dtype=float):
        return np.full(shape, value, dtype=dtype)

    ds = xr.Dataset(
        {
            "poses": (("predictor", "trial", "frame", "param"), full((P, N, F, D), nan)),
            "joints": (("predictor", "trial", "frame", "joint", "xyz"), full((P, N, F, J, 3), nan)),
            "error": (("predictor", "trial", "frame"), full((P, N, F), nan)),
            "cost": (("predictor", "trial", "frame"), full((P, N, F), nan)),
            "iterations": (("predictor", "trial", "frame"), full((P, N, F), -1, np.int16)),
            "timings": (("predictor", "trial", "frame", "part"), full((P, N, F, 3), nan)),
            "r2_joints": (("predictor", "trial", "joint"), full((P, N, J), nan)),
            "r2_params": (("predictor", "trial", "param"), full((P, N, D), nan)),
            "done": (("predictor", "trial"), full((P, N), False, bool)),
            "writes": (("predictor", "trial"), full((P, N), 0, np.int16)),
            "truth_poses": (("frame", "param"), sequence.truth.poses),
            "truth_joints": (("frame", "joint", "xyz"), sequence.truth.joints),
            "masks": (("frame", "camera", "y", "x"), np.asarray(sequence.masks)),
        },
        coords={
            "predictor": np.array(config.labels, dtype=str),
            "trial": np.arange(N),
            "frame": np.arange(F),
            "param": np.array(params.NAMES, dtype=str),
            "joint": np.array(JOINTS, dtype=str),
            "xyz": np.array(["x", "y", "z"]),
            "camera": np.array(sequence.rig.names, dtype=str),
            "part": np.array(TIMING_PARTS, dtype=str),
        },
        attrs={
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "config": config.to_json(),
            "rig": json.dumps(sequence.rig.to_dict()),
            "provenance": json.dumps(sequence.provenance),
            "fps": float(sequence.fps),
        },
    )
    ds["poses"].attrs["units"] = "mm (tx, ty, tz), degrees (the rest)"
    ds["joints"].attrs["units"] = "mm"
    ds["error"].attrs.update(units="mm", long_name="mean joint error over the 21 points")
    ds["timings"].attrs.update(units="s", long_name="wall time per frame and part")
    ds["r2_joints"].attrs["long_name"] = "R̃² of eq. 21 against no motion, same trial"
    ds["r2_params"].attrs["long_name"] = "R̃²_y of eq. 18 against no motion, same trial"
    chunks = {
        "poses": (1, 1, F, D),
        "joints": (1, 1, F, J, 3),
        "error": (1, 1, F),
        "cost": (1, 1, F),
        "iterations": (1, 1, F),
        "timings": (1, 1, F, 3),
        "r2_joints": (1, 1, J),
        "r2_params": (1, 1, D),
        "done": (1, 1),
        "writes": (1, 1),
        "masks": (1, len(sequence.rig), h, w),
    }
    encoding = {k: {"chunks": c} for k, c in chunks.items()}
    for k in ("iterations", "done", "writes", "masks"):
        encoding[k]["_FillValue"] = None
    return ds, encoding


def _render(config: ExperimentConfig, progress: bool):
    from handvar.synth.sequences import make_sequence

    wrap = None
    if progress:
        from tqdm import tqdm

        def wrap(it):
            return tqdm(it, desc=f"rendering {config.sequence}", unit="frame", leave=False)

    return make_sequence(
        config.sequence, seed=config.sequence_seed, n_frames=config.frames, progress=wrap
    )


def _create_store(path: Path, config: ExperimentConfig, progress: bool):
    """Render the sequence and write the empty store under a temporary name, then rename."""
    import shutil
    import tempfile

    sequence = _render(config, progress)
    if sequence.n_frames != config.frames:
        raise ValueError(
            f"frames: expected at most {sequence.n_frames} frames of {config.sequence}; "
            f"got {config.frames}"
        )
    ds, encoding = _template(config, sequence)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    try:
        ds.to_zarr(tmp / "store.zarr", mode="w-", encoding=encoding, zarr_format=2)
        os.replace(tmp / "store.zarr", path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return sequence


def _write_region(path: Path, variables: dict, p: int | slice, t: int):
    import xarray as xr

    region = {
        "predictor": p if isinstance(p, slice) else slice(p, p + 1),
        "trial": slice(t, t + 1),
    }
    ds = xr.Dataset(variables)
    ds.to_zarr(path, region=region, consolidated=False)


def _write_trial(path: Path, p: int, t: int, result: TrialResult, truth_joints, writes: int):
    """Write one finished trial into its chunks; ``done`` and ``writes`` go last."""
    dims = ("predictor", "trial", "frame")
    error = mean_joint_error(truth_joints, result.joints)
    data = {
        "poses": ((*dims, "param"), result.poses[None, None]),
        "joints": ((*dims, "joint", "xyz"), result.joints[None, None]),
        "error": (dims, error[None, None]),
        "cost": (dims, np.asarray(result.cost, dtype=float)[None, None]),
        "iterations": (dims, np.asarray(result.iterations, dtype=np.int16)[None, None]),
        "timings": ((*dims, "part"), np.asarray(result.timings, dtype=float)[None, None]),
    }
    _write_region(path, data, p, t)
    flags = {
        "done": (("predictor", "trial"), np.ones((1, 1), dtype=bool)),
        "writes": (("predictor", "trial"), np.full((1, 1), writes, dtype=np.int16)),
    }
    _write_region(path, flags, p, t)


def _write_scores(path: Path, config: ExperimentConfig, t: int) -> None:
    """R̃² (eq. 18 and 21) of every finished trial t against no motion's trial t."""
    ref = config.reference
    if ref is None:
        return
    ds = open_store(path)
    done = ds["done"][:, t].values
    r = config.predictors.index(ref)
    if not done[r]:
        return
    truth_x, truth_z = ds["truth_poses"].values, ds["truth_joints"].values
    poses, joints = ds["poses"][:, t].values, ds["joints"][:, t].values
    P = len(config.predictors)
    r2z = ds["r2_joints"][:, t].values
    r2x = ds["r2_params"][:, t].values
    for p in range(P):
        if done[p]:
            r2z[p] = r2_tilde_joints(truth_z, joints[p], joints[r])  # eq. 21
            r2x[p] = r2_tilde_acceleration(truth_x, poses[p], poses[r])  # eq. 18
    scores = {
        "r2_joints": (("predictor", "trial", "joint"), r2z[:, None]),
        "r2_params": (("predictor", "trial", "param"), r2x[:, None]),
    }
    _write_region(path, scores, slice(None), t)


# --- running ------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class RunSummary:
    """What one call of :func:`run_experiment` did.

    Attributes
    ----------
    store : Path
    total : int
        Trials in the experiment (predictors × trials).
    already_done : int
        Trials found finished in the store and not run again.
    computed : int
        Trials computed and written by this call.
    missing : tuple of (str, int)
        (predictor label, trial) still not done when the call ended.
    seconds : float
        Wall-clock time of the call.
    """

    store: Path
    total: int
    already_done: int
    computed: int
    missing: tuple[tuple[str, int], ...]
    seconds: float

    @property
    def complete(self) -> bool:
        """Every trial of the experiment is in the store."""
        return not self.missing


def _open_or_create(path: Path, config: ExperimentConfig, progress: bool):
    """(config, sequence, done) of the store, created if it does not exist."""
    if path.exists():
        ds = open_store(path)
        stored = ExperimentConfig.from_json(ds.attrs["config"])
        if stored != config:
            raise ValueError(
                f"store: {path} holds a different experiment (config {stored.to_json()}); "
                "choose another --out or the same settings"
            )
        return stored, store_sequence(path), ds["done"].values.copy(), ds["writes"].values.copy()
    sequence = _create_store(path, config, progress)
    P, N = len(config.predictors), config.trials
    return config, sequence, np.zeros((P, N), bool), np.zeros((P, N), np.int16)


def _local_client(workers: int | None):
    from distributed import Client, LocalCluster

    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=40,
    )
    return Client(cluster), cluster


def run_experiment(
    config: ExperimentConfig,
    store: str | os.PathLike,
    *,
    client=None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    rounds: int = 3,
    on_written: Callable[[str, int], None] | None = None,
) -> RunSummary:
    """Run (or resume) an experiment into one Zarr store.

    Parameters
    ----------
    config : ExperimentConfig
        What to run; must equal the configuration of an existing `store`.
    store : path-like
        The Zarr directory; created (with the rendered sequence) if missing.
    client : distributed.Client, keyword-only, optional
        Run on this client.  Otherwise on `scheduler`, otherwise on an embedded
        ``LocalCluster`` of `workers` processes with one thread each (default: the
        number of cores), closed on return.
    scheduler : str, keyword-only, optional
        Address of an existing Dask scheduler (``tcp://host:8786``).
    workers : int, keyword-only, optional
        Worker processes of the embedded cluster.
    progress : bool, keyword-only
        Show tqdm progress bars.
    rounds : int, keyword-only
        Times the trials still missing are resubmitted after losing workers or
        their data (``client.restart()``, killed processes).
    on_written : callable, keyword-only, optional
        Called with (predictor label, trial) after each trial is written.

    Returns
    -------
    RunSummary
        Trials already done, computed now, and still missing.
    """
    start = time.perf_counter()
    if not isinstance(config, ExperimentConfig):
        raise ValueError(f"config: expected an ExperimentConfig; got {type(config).__name__}")
    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise ValueError(f"workers: expected a positive integer; got {workers!r}")
    if config.trial_kind == "tracker":
        tracker_settings(config.tracker)  # checks the overrides before anything runs
    for spec in config.predictors:
        spec.build()
    path = Path(store)
    config, sequence, done, writes = _open_or_create(path, config, progress)
    labels = config.labels
    P, N = done.shape
    already = int(done.sum())
    todo = [(p, t) for t in range(N) for p in range(P) if not done[p, t]]
    computed = 0
    if todo:
        own = None
        if client is None:
            if scheduler is not None:
                from distributed import Client

                client = Client(scheduler)
                own = (client, None)
            else:
                own = _local_client(workers)
                client = own[0]
        try:
            computed = _run_tasks(
                client, config, sequence, path, todo, done, writes, progress, rounds, on_written
            )
        finally:
            if own is not None:
                own[0].close()
                if own[1] is not None:
                    own[1].close()
    # Scores a run stopped before writing (they are written after each trial).
    ds = open_store(path)
    done = ds["done"].values
    unscored = done & np.isnan(ds["r2_joints"].values).all(axis=2)
    for t in np.flatnonzero(unscored.any(axis=0)):
        _write_scores(path, config, int(t))
    missing = tuple((labels[p], int(t)) for p, t in zip(*np.nonzero(~done), strict=True))
    return RunSummary(path, P * N, already, computed, missing, time.perf_counter() - start)


def _run_tasks(client, config, sequence, path, todo, done, writes, progress, rounds, on_written):
    from concurrent.futures import CancelledError

    from distributed import KilledWorker, as_completed
    from tqdm import tqdm

    labels = config.labels
    truth_joints = sequence.truth.joints
    computed = 0
    bar = tqdm(total=len(todo), desc="trials", unit="trial", disable=not progress)
    try:
        for _ in range(max(1, int(rounds))):
            todo = [(p, t) for p, t in todo if not done[p, t]]
            if not todo:
                break
            shared = client.scatter(sequence, broadcast=True)
            futures = {}
            for p, t in todo:
                fut = client.submit(
                    run_trial,
                    config,
                    config.predictors[p].key,
                    t,
                    shared,
                    pure=False,
                )
                futures[fut] = (p, t)
            lost = False
            for fut in as_completed(futures):
                p, t = futures[fut]
                try:
                    result = fut.result()
                except (CancelledError, KilledWorker):  # lost worker or data: next round
                    lost = True
                    continue
                except ValueError:
                    raise
                except Exception as exc:
                    raise RuntimeError(
                        f"trial {t} of predictor {labels[p]!r} failed: {exc!r}"
                    ) from exc
                writes[p, t] += 1
                _write_trial(path, p, t, result, truth_joints, int(writes[p, t]))
                done[p, t] = True
                computed += 1
                bar.update(1)
                _write_scores(path, config, t)
                if on_written is not None:
                    on_written(labels[p], t)
            del futures
            if not lost:
                break
    finally:
        bar.close()
    return computed


def summary_text(summary: RunSummary) -> str:
    """One line describing a run."""
    state = "complete" if summary.complete else f"{len(summary.missing)} trials missing"
    return (
        f"{summary.store}: {summary.total} trials, {summary.already_done} already done, "
        f"{summary.computed} computed in {summary.seconds:.1f} s ({state})"
    )
