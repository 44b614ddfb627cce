"""The format of an experiment store: one Zarr store of every trial (design §7).

An experiment goes to ONE Zarr store (written through xarray, Zarr format 2):

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
and every finished trial is written into its own chunks (:func:`write_trial`), ``done``
last; Zarr's local store writes each chunk atomically, so the store stays readable at
any moment and a finished trial is never lost.

A store is verified where it is read (design §13.3): :func:`damaged_trials` names every
trial marked done whose chunks are missing, unreadable, or hold NaN where a finished
trial has numbers; the experiment clears their ``done`` flags and runs them again, the
report refuses to draw from them.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import time
from pathlib import Path

import numpy as np

from handvar import params
from handvar.atomic import disk_full, remove_stale_temporaries, temporary_name
from handvar.evaluation.config import ExperimentConfig
from handvar.evaluation.metrics import mean_joint_error, r2_tilde_acceleration, r2_tilde_joints
from handvar.evaluation.trials import TIMING_PARTS, TrialResult

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "Damage",
    "clear_done",
    "create_store",
    "damaged_trials",
    "open_store",
    "read_config",
    "store_sequence",
    "write_scores",
    "write_trial",
]

FORMAT = "handvar-experiment"
FORMAT_VERSION = 1


def store_sequence(store: str | os.PathLike):
    """The tracked sequence as kept in a store (masks, rig, truth) -- a Sequence."""
    from handvar.camera import Rig
    from handvar.io import Sequence, Truth

    ds = open_store(store)
    config = ExperimentConfig.from_json(ds.attrs["config"])
    try:
        for name in ("masks", "truth_poses", "truth_joints"):  # a chunk per frame / one
            n_chunks = ds[name].shape[0] if name == "masks" else 1
            for f in range(n_chunks):
                chunk = ".".join([str(f)] + ["0"] * (ds[name].ndim - 1))
                if not (Path(store) / name / chunk).is_file():  # read as zeros, not damage
                    raise ValueError(f"{name}: chunk file {chunk} missing")
        masks = ds["masks"].values
        truth = Truth(ds["truth_poses"].values, ds["truth_joints"].values)
    except Exception as exc:  # a damaged chunk: blosc, zarr and numpy raise many kinds
        raise ValueError(
            f"store: {store} has a damaged sequence (masks or truth: {_why(exc)}); "
            "it cannot be resumed, remove it to start again"
        ) from None
    return Sequence(
        name=config.sequence,
        fps=float(ds.attrs["fps"]),
        rig=Rig.from_dict(json.loads(ds.attrs["rig"])),
        masks=masks,
        truth=truth,
        provenance=json.loads(ds.attrs["provenance"]),
    )


# --- verification (design §13.3) --------------------------------------------------------

# Per-trial variables; the first three hold numbers in every finished trial.
_FINITE_VARS = ("poses", "joints", "error")
_TRIAL_VARS = (*_FINITE_VARS, "cost", "iterations", "timings", "r2_joints", "r2_params")


@dataclasses.dataclass(frozen=True)
class Damage:
    """A trial marked done (or whose flag is unreadable) that cannot be trusted.

    Attributes
    ----------
    predictor : int
        Index of the predictor in the store.
    trial : int
    label : str
        The predictor's label.
    reason : str
        What is wrong (``"poses: chunk file 2.3.0.0 missing"``).
    """

    predictor: int
    trial: int
    label: str
    reason: str

    def __str__(self) -> str:
        return f"trial {self.trial} of predictor {self.label!r} ({self.reason})"


def _why(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 80 else text[:77] + "..."


def _chunk_name(ndim: int, p: int, t: int) -> str:
    return ".".join([str(p), str(t)] + ["0"] * (ndim - 2))


def damaged_trials(store: str | os.PathLike) -> list[Damage]:
    """Every trial whose ``done`` flag cannot be trusted, with the reason.

    A trial is damaged if its ``done`` chunk cannot be read, or it is marked done and
    a chunk it must have is missing, or one of its chunks cannot be decoded, or its
    poses, joints or errors are not all finite. Every finished trial has chunks of
    poses, joints, error and timings, a tracker trial also of cost and iterations, and
    a trial whose no-motion reference is done also of its scores (r2_joints,
    r2_params): a missing one would be read as its fill value, as if it were data.

    Parameters
    ----------
    store : path-like
        An experiment store (:func:`open_store` must accept it).

    Returns
    -------
    list of Damage
        In (trial, predictor) order; empty for a sound store.
    """
    import zarr

    path = Path(store)
    ds = open_store(path)
    labels = [str(v) for v in ds["predictor"].values]
    group = zarr.open_group(str(path), mode="r", zarr_format=2)
    arrays = {k: group[k] for k in ("done", *_TRIAL_VARS)}
    config = ExperimentConfig.from_json(ds.attrs["config"])
    always = {"poses", "joints", "error", "timings"}
    if config.trial_kind == "tracker":
        always |= {"cost", "iterations"}
    reference = None if config.reference is None else config.predictors.index(config.reference)
    P, N = arrays["done"].shape
    damaged = []
    for t in range(N):
        required = set(always)
        if reference is not None and _is_done(arrays, reference, t):
            required |= {"r2_joints", "r2_params"}
        for p in range(P):
            reason = _trial_damage(path, arrays, p, t, required)
            if reason:
                damaged.append(Damage(p, t, labels[p], reason))
    return damaged


def _is_done(arrays: dict, p: int, t: int) -> bool:
    try:
        return bool(arrays["done"][p, t])
    except Exception:  # unreadable: reported as damage of that trial
        return False


def _trial_damage(path: Path, arrays: dict, p: int, t: int, required: set) -> str:
    """Why trial (p, t) is damaged, or "" if it is sound or simply not done.

    `required`: the variables whose chunk of a finished trial must exist.
    """
    try:
        done = bool(arrays["done"][p, t])
    except Exception as exc:
        return f"done: unreadable chunk ({_why(exc)})"
    if not done:
        return ""
    for name in _TRIAL_VARS:
        array = arrays[name]
        chunk = _chunk_name(array.ndim, p, t)
        if name in required and not (path / name / chunk).is_file():
            return f"{name}: chunk file {chunk} missing"
        try:
            values = np.asarray(array[p, t])
        except Exception as exc:
            return f"{name}: unreadable chunk {chunk} ({_why(exc)})"
        if name in _FINITE_VARS and not np.all(np.isfinite(values)):
            return f"{name}: NaN or infinity in a finished trial"
    return ""


def clear_done(path: str | os.PathLike, damage: list[Damage]) -> None:
    """Mark the damaged trials as not done (and their scores missing) to run them again."""
    for d in damage:
        flags = {
            "done": (("predictor", "trial"), np.zeros((1, 1), dtype=bool)),
            "r2_joints": (("predictor", "trial", "joint"), np.full((1, 1, 21), np.nan)),
            "r2_params": (
                ("predictor", "trial", "param"),
                np.full((1, 1, params.N_PARAMS), np.nan),
            ),
        }
        _write_region(Path(path), flags, d.predictor, d.trial)


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


def create_store(path: str | os.PathLike, config: ExperimentConfig, sequence) -> Path:
    """Write the empty store of `config` for `sequence` (every trial missing).

    The store is written under a temporary name beside `path` and renamed into place,
    so `path` is either absent or a complete store.

    Parameters
    ----------
    path : path-like
        The Zarr directory to create; its parent is created if needed.
    config : ExperimentConfig
    sequence : handvar.io.Sequence
        The rendered sequence, with truth, of ``config.frames`` frames.

    Returns
    -------
    Path
    """
    path = Path(path)
    if sequence.n_frames != config.frames:
        raise ValueError(
            f"frames: expected at most {sequence.n_frames} frames of {config.sequence}; "
            f"got {config.frames}"
        )
    ds, encoding = _template(config, sequence)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)  # what a run killed while creating it left
    tmp = Path(temporary_name(path, directory=True))
    try:
        ds.to_zarr(tmp / "store.zarr", mode="w-", encoding=encoding, zarr_format=2)
        os.replace(tmp / "store.zarr", path)
    except BaseException as exc:
        _remove_written(tmp)
        new = disk_full(exc, path) if isinstance(exc, OSError) else exc
        if new is exc:  # not a full disk
            raise
        raise new from None  # a full disk: say so, naming the store
    shutil.rmtree(tmp, ignore_errors=True)
    return path


def _remove_written(tmp: Path, settle: float = 0.5) -> None:
    """Remove the temporary store `tmp`, again while files still appear in it.

    Zarr writes a store's chunks from its own event loop, and an error in one chunk (a
    full disk) reaches us while the others are still being written: they can put files
    back into `tmp` as it is removed.  So it is removed until it has stayed away for
    `settle` seconds (a chunk on a full disk fails at once), for 20 s at most."""
    start = gone_since = time.monotonic()
    while time.monotonic() - start < 20.0:
        shutil.rmtree(tmp, ignore_errors=True)
        now = time.monotonic()
        if tmp.exists():
            gone_since = now
        elif now - gone_since >= settle:
            return
        time.sleep(0.02)


def _write_region(path: Path, variables: dict, p: int | slice, t: int):
    import xarray as xr

    region = {
        "predictor": p if isinstance(p, slice) else slice(p, p + 1),
        "trial": slice(t, t + 1),
    }
    ds = xr.Dataset(variables)
    try:
        ds.to_zarr(path, region=region, consolidated=False)
    except OSError as exc:  # a full disk: say so, naming the store
        new = disk_full(exc, path)
        if new is exc:
            raise
        raise new from None


def write_trial(path: Path, p: int, t: int, result: TrialResult, truth_joints, writes: int):
    """Write one finished trial into its chunks; ``done`` and ``writes`` go last.

    The mean joint error per frame is computed here from the trial's joints and
    `truth_joints` (T, 21, 3), mm.
    """
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


def write_scores(path: Path, config: ExperimentConfig, t: int) -> None:
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
