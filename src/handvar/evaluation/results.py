"""The measurements of an experiment store, in memory, and their statistics (design §7).

:func:`load_results` reads the small arrays of a store (not the poses nor the masks)
into :class:`Results`; the helpers below summarise R̃² over trials and joints and find
the peaks of an error curve, for the figures, the claims and the report alike.

Joints are numbered 1–21 on the figures and in the claims as in the paper (joint 1
the palm base = our wrist, index 0; 18–21 the little finger = our 17–20).
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from handvar.evaluation.config import ExperimentConfig
from handvar.evaluation.store import open_store
from handvar.validate import as_array

__all__ = [
    "N_JOINTS",
    "Results",
    "error_peaks",
    "fmt",
    "joint_iqrs",
    "joint_medians",
    "load_results",
    "median",
    "reference_curve",
]

N_JOINTS = 21


@dataclasses.dataclass(frozen=True, eq=False)
class Results:
    """The small arrays of a store, loaded into memory.

    Attributes
    ----------
    config : ExperimentConfig
    labels : list of str
        Predictor labels, in store order.
    done : (P, N) bool ndarray
        Finished trials.
    error : (P, N, F) ndarray
        Mean joint error per frame, mm (NaN where not done).
    r2_joints : (P, N, 21) ndarray
        R̃² of eq. 21 per trial and joint (NaN where not done).
    r2_params : (P, N, 26) ndarray
        R̃²_y of eq. 18 per trial and parameter.
    iterations : (P, N, F) ndarray
    timings : (P, N, F, 3) ndarray
        Seconds per frame: preprocessing, optimisation, prediction.
    """

    config: ExperimentConfig
    labels: list[str]
    done: np.ndarray
    error: np.ndarray
    r2_joints: np.ndarray
    r2_params: np.ndarray
    iterations: np.ndarray
    timings: np.ndarray

    def index(self, key: str) -> int | None:
        """Position of the predictor with this key or label, None if absent."""
        for p, spec in enumerate(self.config.predictors):
            if key in (spec.key, spec.label):
                return p
        return None

    def r2(self, p: int) -> np.ndarray:
        """(n, 21) R̃² of the trials of predictor p with a finite score."""
        r = self.r2_joints[p]
        return r[np.isfinite(r).any(axis=1)]

    def mean_error_curve(self, p: int) -> np.ndarray:
        """(F,) mean joint error per frame averaged over the finished trials (NaN if none)."""
        e = self.error[p][self.done[p]]
        return e.mean(axis=0) if len(e) else np.full(self.error.shape[2], np.nan)

    def overall_error(self, p: int) -> float:
        """The paper's overall mean error: over frames 1.. and finished trials, mm."""
        e = self.error[p][self.done[p]][:, 1:]
        return float(e.mean()) if e.size else float("nan")


def load_results(store: str | os.PathLike) -> Results:
    """Load the measurements of an experiment store (not the poses nor the masks)."""
    ds = open_store(store)
    config = ExperimentConfig.from_json(ds.attrs["config"])
    return Results(
        config=config,
        labels=[str(v) for v in ds["predictor"].values],
        done=ds["done"].values.astype(bool),
        error=ds["error"].values,
        r2_joints=ds["r2_joints"].values,
        r2_params=ds["r2_params"].values,
        iterations=ds["iterations"].values,
        timings=ds["timings"].values,
    )


def joint_medians(r2: np.ndarray) -> np.ndarray:
    """(21,) median over trials of R̃² per joint."""
    if len(r2) == 0:
        return np.full(N_JOINTS, np.nan)
    return np.array([median(r2[:, j]) for j in range(r2.shape[1])])


def joint_iqrs(r2: np.ndarray) -> np.ndarray:
    """(21,) interquartile range over trials of R̃² per joint."""
    out = np.full(r2.shape[1] if r2.ndim == 2 else N_JOINTS, np.nan)
    for j in range(len(out)):
        v = r2[:, j][np.isfinite(r2[:, j])] if len(r2) else np.array([])
        if v.size:
            q1, q3 = np.percentile(v, [25, 75])
            out[j] = q3 - q1
    return out


def median(v) -> float:
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else float("nan")


def error_peaks(curve, n: int = 3, *, separation: int = 10) -> list[int]:
    """The `n` highest frames of an error curve, at least `separation` frames apart.

    Frame 0 (the true first pose) is never a peak.  Returned in frame order.

    Examples
    --------
    >>> error_peaks([0, 1, 5, 1, 0, 0, 3, 0], n=2, separation=2)
    [2, 6]
    """
    c = as_array(curve, "curve", (None,), finite=False, what="a series")
    order = [int(f) for f in np.argsort(-np.where(np.isfinite(c), c, -np.inf), kind="stable")]
    chosen: list[int] = []
    for f in order:
        if f == 0 or not np.isfinite(c[f]):
            continue
        if all(abs(f - g) >= separation for g in chosen):
            chosen.append(f)
        if len(chosen) == n:
            break
    return sorted(chosen)


def reference_curve(results: Results) -> np.ndarray:
    ref = results.index("none")
    if ref is not None and results.done[ref].any():
        return results.mean_error_curve(ref)
    curves = [results.mean_error_curve(p) for p in range(len(results.labels))]
    with np.errstate(all="ignore"):
        return np.nanmean(np.where(np.isfinite(curves), curves, 0.0), axis=0)


def fmt(v: float, digits: int = 2) -> str:
    return "nan" if not np.isfinite(v) else f"{v:.{digits}f}"
