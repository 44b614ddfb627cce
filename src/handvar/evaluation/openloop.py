"""Open-loop evaluation of predictors on recorded motion (no tracker in the loop).

Every predictor is run along a recorded pose series (``one_step_predictions``) and
scored per parameter group: RMSE, mean absolute error and R̃² against no motion,
1 − Σ(x − x̂)² / Σ(x − x_{t−1})², pooled over the group's parameters.  In one-step
open loop the residual x_t − x̂_t equals the acceleration-domain residual
y_t − ŷ_t, so this R̃² is eq. 18 with the recording standing in for the truth.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handvar import params
from handvar.predictors import NoMotion, Predictor, one_step_predictions
from handvar.predictors.base import as_series
from handvar.predictors.catalogue import CATALOGUE

__all__ = [
    "KEYPOINT_TABLE_ROWS",
    "TABLE_ROWS",
    "OpenLoopRow",
    "default_predictors",
    "evaluate_open_loop",
    "format_table",
    "keypoint_blocks",
    "read_pose_series",
    "write_csv",
]

# Rows of the table, parameter groups: (name, unit, indices).
TableRows = tuple[tuple[str, str, np.ndarray], ...]
TABLE_ROWS: TableRows = (
    ("palm translation", "mm", np.arange(0, 3)),
    ("palm rotation", "deg", np.arange(3, 6)),
    ("abduction", "deg", np.arange(6, 11)),
    *(
        (f"{digit} flexion", "deg", np.arange(11 + 3 * k, 14 + 3 * k))
        for k, digit in enumerate(params.DIGITS)
    ),
    ("all fingers", "deg", np.arange(6, 26)),
)


# The 21 keypoints (the order of G(x)) flattened to 63 columns x, y, z: the wrist and
# each digit's four points.
KEYPOINT_TABLE_ROWS: TableRows = (
    ("wrist", "mm", np.arange(0, 3)),
    *((digit, "mm", np.arange(3 + 12 * k, 15 + 12 * k)) for k, digit in enumerate(params.DIGITS)),
    ("all digits", "mm", np.arange(3, 63)),
)


def keypoint_blocks() -> list[list[int]]:
    """Eq. 25's assumption for 3D keypoints: the wrist alone, each digit's 12 coordinates
    together (digits move independently, the joints of one digit together)."""
    return [list(range(0, 3)), *[list(range(3 + 12 * k, 15 + 12 * k)) for k in range(5)]]


def default_predictors(blocks=None) -> dict[str, Predictor]:
    """The paper's predictors (§4–5) with its settings, plus the relative RVAR and Kalman.

    `blocks` are the structured VARs' blocks (default: eq. 25 for hand parameters).
    """
    return {spec.label: spec.build(blocks) for spec in CATALOGUE.values()}


@dataclass(frozen=True)
class OpenLoopRow:
    """One predictor's score on one parameter group."""

    group: str
    unit: str
    predictor: str
    rmse: float
    mae: float
    r2_tilde: float
    frames: int


def read_pose_series(path: str | os.PathLike) -> np.ndarray:
    """Read a pose series: whitespace text, CSV (header optional) or .npy; rows are frames.

    Returns
    -------
    (T, d) ndarray
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: expected a pose file (text, CSV or .npy); no such file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # an empty file: as_series names it
            if path.suffix == ".npy":
                X = np.load(path, allow_pickle=False)
                if X.ndim == 3:  # (T, J, 3) keypoints: one row a frame
                    X = X.reshape(len(X), -1)
            elif path.suffix == ".csv":
                with path.open() as f:
                    first = f.readline()
                header = any(c.isalpha() for c in first.replace("e", "").replace("E", ""))
                X = np.loadtxt(path, delimiter=",", skiprows=int(header), ndmin=2)
            else:
                X = np.loadtxt(path, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: expected a table of numbers; {exc}") from None
    return as_series(X, str(path))


def evaluate_open_loop(
    X,
    predictors: dict[str, Predictor] | None = None,
    *,
    resets=(),
    layout: str = "handvar",
) -> tuple[list[OpenLoopRow], dict[str, np.ndarray]]:
    """Score every predictor on a recorded series of hand poses, per parameter group.

    Parameters
    ----------
    X : (T, 26) or (T, 63) array_like
        One row a frame: poses in handvar's layout (mm, degrees), or with
        ``layout="keypoints"`` the 21 keypoints' x, y, z (mm) in the order of G(x).
    predictors : dict of name to Predictor, optional
        Default :func:`default_predictors` (with :func:`keypoint_blocks` for
        keypoints); ``"no motion"`` is always the reference.
    resets : iterable of int
        Rows where the recording restarts; predictors are reset there and those
        rows are not scored.
    layout : {"handvar", "keypoints"}
        What the columns are; decides the groups of the table.

    Returns
    -------
    rows : list of OpenLoopRow
    predictions : dict of name to (T, d) ndarray
    """
    X = as_series(X)
    layouts = {
        "handvar": (params.N_PARAMS, TABLE_ROWS, None),
        "keypoints": (63, KEYPOINT_TABLE_ROWS, keypoint_blocks()),
    }
    if layout not in layouts:
        raise ValueError(f"layout: expected one of {', '.join(layouts)}; got {layout!r}")
    width, groups, blocks = layouts[layout]
    if X.shape[1] != width:
        raise ValueError(f"X: expected {width} columns (layout {layout}); got {X.shape[1]}")
    predictors = dict(predictors or default_predictors(blocks))
    predictors.setdefault("no motion", NoMotion())
    preds = {name: one_step_predictions(p, X, resets=resets) for name, p in predictors.items()}
    scored = np.all([np.isfinite(P).all(1) for P in preds.values()], axis=0)
    if not scored.any():
        raise ValueError(f"X: expected at least 2 frames to score; got {len(X)}")
    base = (X - preds["no motion"])[scored]
    rows = []
    for group, unit, idx in groups:
        den = np.sum(base[:, idx] ** 2)
        for name, P in preds.items():
            err = (X - P)[scored][:, idx]
            r2 = 1.0 - np.sum(err**2) / den if den > 0 else float("nan")
            rows.append(
                OpenLoopRow(
                    group,
                    unit,
                    name,
                    float(np.sqrt(np.mean(err**2))),
                    float(np.mean(np.abs(err))),
                    float(r2),
                    int(scored.sum()),
                )
            )
    return rows, preds


def format_table(rows: list[OpenLoopRow]) -> str:
    """The rows as plain-text tables, one per parameter group."""
    lines = []
    for group in dict.fromkeys(r.group for r in rows):
        sub = [r for r in rows if r.group == group]
        unit = sub[0].unit
        lines.append(f"{group} ({unit}), {sub[0].frames} frames")
        lines.append(f"  {'predictor':<16}{'RMSE':>10}{'MAE':>10}{'R̃² vs none':>12}")
        for r in sub:
            lines.append(f"  {r.predictor:<16}{r.rmse:>10.4f}{r.mae:>10.4f}{r.r2_tilde:>12.3f}")
        lines.append("")
    return "\n".join(lines)


def write_csv(rows: list[OpenLoopRow], path: str | os.PathLike) -> None:
    """Write the rows as CSV, atomically (a temporary file renamed into place)."""
    from handvar.io import write_atomic

    lines = ["group,unit,predictor,rmse,mae,r2_tilde,frames"]
    lines += [
        f"{r.group},{r.unit},{r.predictor},{r.rmse:.6g},{r.mae:.6g},{r.r2_tilde:.6g},{r.frames}"
        for r in rows
    ]
    write_atomic(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))
