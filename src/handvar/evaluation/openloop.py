"""Open-loop evaluation of predictors on recorded motion (no tracker in the loop).

Every predictor is run along a recorded pose series (``one_step_predictions``) and
scored per parameter group: RMSE, mean absolute error and R̃² against no motion,
1 − Σ(x − x̂)² / Σ(x − x_{t−1})², pooled over the group's parameters.  In one-step
open loop the residual x_t − x̂_t equals the acceleration-domain residual
y_t − ŷ_t, so this R̃² is eq. 18 with the recording standing in for the truth.

The league table (design §16) runs every predictor on several recordings and on
noisy copies of them (scored against the clean next frame), ranks the predictors
per recording and divides each RMSE by the best simple baseline's.  One concept —
scoring predictors on recorded motion — hence one module.
"""

from __future__ import annotations

import itertools
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handvar import params
from handvar.predictors import NoMotion, Predictor
from handvar.predictors.base import as_series
from handvar.predictors.catalogue import CATALOGUE

__all__ = [
    "BASELINES",
    "KEYPOINT_TABLE_ROWS",
    "LAYOUTS",
    "TABLE_ROWS",
    "LeagueRow",
    "OpenLoopRow",
    "Recording",
    "default_predictors",
    "evaluate_open_loop",
    "format_league",
    "format_table",
    "keypoint_blocks",
    "layout_structure",
    "league_predictors",
    "league_table",
    "noise_variants",
    "read_pose_series",
    "smooth_variants",
    "synthetic_families",
    "write_csv",
    "write_league_csv",
    "write_league_figure",
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


LAYOUTS = ("handvar", "keypoints", "points", "columns")


def layout_structure(layout: str, width: int) -> tuple[TableRows, list[list[int]] | None]:
    """The groups of the table and the predictors' blocks for a column layout.

    Parameters
    ----------
    layout : {"handvar", "keypoints", "points", "columns"}
        26 hand parameters (groups of the table, blocks of eq. 25); 21 keypoints × 3
        (wrist and digits); any K points × 3 (one group and block per point, plus all
        points); any columns (one group and block per column, plus all columns).
    width : int
        The number of columns of the series.

    Returns
    -------
    groups : tuple of (name, unit, indices)
    blocks : list of lists of int, or None for the hand's eq. 25
    """
    if layout == "handvar":
        if width != params.N_PARAMS:
            raise ValueError(f"X: expected {params.N_PARAMS} columns (layout handvar); got {width}")
        return TABLE_ROWS, None
    if layout == "keypoints":
        if width != 63:
            raise ValueError(f"X: expected 63 columns (layout keypoints); got {width}")
        return KEYPOINT_TABLE_ROWS, keypoint_blocks()
    if layout == "points":
        if width % 3:
            raise ValueError(f"X: expected K x 3 columns (layout points); got {width}")
        blocks = [[3 * k, 3 * k + 1, 3 * k + 2] for k in range(width // 3)]
        groups = tuple((f"point {k}", "", np.array(b)) for k, b in enumerate(blocks))
        return (*groups, ("all points", "", np.arange(width))), blocks
    if layout == "columns":
        groups = tuple((f"column {j}", "", np.array([j])) for j in range(width))
        return (*groups, ("all columns", "", np.arange(width))), [[j] for j in range(width)]
    raise ValueError(f"layout: expected one of {', '.join(LAYOUTS)}; got {layout!r}")


def default_predictors(blocks=None) -> dict[str, Predictor]:
    """The paper's predictors (paper §4–5) with its settings, plus the relative RVAR and Kalman.

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


def read_pose_series(path: str | os.PathLike, *, missing: bool = False) -> np.ndarray:
    """Read a pose series: whitespace text, CSV (header optional) or .npy; rows are frames.

    With `missing`, a row that is NaN throughout is a frame without values (a detector
    that found no hand) and is returned as it is; any other non-finite value is an
    error.

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
    if not missing or X.ndim != 2:
        return as_series(X, str(path))
    gone = np.isnan(X).all(axis=1)
    if gone.all():
        raise ValueError(f"{path}: expected rows with values; every row is NaN")
    X = as_series(np.where(gone[:, None], 0.0, X), str(path))  # any other bad value
    X[gone] = np.nan
    return X


def evaluate_open_loop(
    X,
    predictors: dict[str, Predictor] | None = None,
    *,
    resets=(),
    layout: str = "handvar",
    truth=None,
    groups: TableRows | None = None,
    chunk: int = 4096,
) -> list[OpenLoopRow]:
    """Score every predictor on a recorded series of hand poses, per parameter group.

    The series is streamed: every predictor is advanced `chunk` frames at a time
    (:func:`~handvar.predictors.one_step_chunks`) and only running sums per column are
    kept, so memory does not grow with the series' length beyond `X` itself.

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
    layout : {"handvar", "keypoints", "points", "columns"}
        What the columns are; decides the groups of the table
        (:func:`layout_structure`).
    truth : (T, d) array_like, optional
        What the predictions are scored against (default `X` itself): the clean
        recording when `X` is a noisy copy of it.
    groups : tuple of (name, unit, indices), optional
        The groups of the table; default the layout's.
    chunk : int
        Frames per step of the stream (any value gives the same scores, to rounding).

    Returns
    -------
    rows : list of OpenLoopRow
        A frame is scored when every predictor has a finite prediction of it.
    """
    from handvar.predictors import one_step_chunks

    X = as_series(X)
    layout_groups, blocks = layout_structure(layout, X.shape[1])
    groups = layout_groups if groups is None else groups
    Z = X if truth is None else as_series(truth, "truth")
    if Z.shape != X.shape:
        raise ValueError(f"truth: expected shape {X.shape}; got {Z.shape}")
    predictors = dict(predictors or default_predictors(blocks))
    predictors.setdefault("no motion", NoMotion())
    names = list(predictors)
    streams = [one_step_chunks(predictors[n], X, resets=resets, chunk=chunk) for n in names]
    d = X.shape[1]
    sq = np.zeros((len(names), d))  # Σ err² per predictor and column
    ab = np.zeros((len(names), d))  # Σ |err|
    den = np.zeros(d)  # Σ (z − x̂⁰)², the no-motion reference of R̃²
    n_scored = 0
    ref = names.index("no motion")
    for parts in zip(*streams, strict=True):
        start = parts[0][0]
        P = np.stack([p for _, p in parts])  # (n_predictors, rows, d)
        err = Z[start : start + P.shape[1]][None] - P
        ok = np.isfinite(P).all(axis=(0, 2))
        err = err[:, ok]
        sq += np.einsum("prd,prd->pd", err, err)
        ab += np.abs(err).sum(1)
        den += np.einsum("rd,rd->d", err[ref], err[ref])
        n_scored += int(ok.sum())
    if not n_scored:
        raise ValueError(f"X: expected at least 2 frames to score; got {len(X)}")
    rows = []
    for group, unit, idx in groups:
        g_den = den[idx].sum()
        count = n_scored * len(idx)
        for k, name in enumerate(names):
            g_sq = sq[k, idx].sum()
            r2 = 1.0 - g_sq / g_den if g_den > 0 else float("nan")
            rmse, mae = float(np.sqrt(g_sq / count)), float(ab[k, idx].sum() / count)
            rows.append(OpenLoopRow(group, unit, name, rmse, mae, float(r2), n_scored))
    return rows


def format_table(rows: list[OpenLoopRow]) -> str:
    """The rows as plain-text tables, one per parameter group."""
    lines = []
    for group in dict.fromkeys(r.group for r in rows):
        sub = [r for r in rows if r.group == group]
        unit = f" ({sub[0].unit})" if sub[0].unit else ""
        lines.append(f"{group}{unit}, {sub[0].frames} frames")
        w = max(16, *(len(r.predictor) + 1 for r in sub))
        lines.append(f"  {'predictor':<{w}}{'RMSE':>10}{'MAE':>10}{'R̃² vs none':>12}")
        for r in sub:
            lines.append(f"  {r.predictor:<{w}}{r.rmse:>10.4f}{r.mae:>10.4f}{r.r2_tilde:>12.3f}")
        lines.append("")
    return "\n".join(lines)


def write_csv(rows: list[OpenLoopRow], path: str | os.PathLike) -> None:
    """Write the rows as CSV, atomically (a temporary file renamed into place)."""
    from handvar.atomic import write_atomic

    lines = ["group,unit,predictor,rmse,mae,r2_tilde,frames"]
    lines += [
        f"{r.group},{r.unit},{r.predictor},{r.rmse:.6g},{r.mae:.6g},{r.r2_tilde:.6g},{r.frames}"
        for r in rows
    ]
    write_atomic(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))


# --- the league table: several recordings, noisy variants, ranks and ratios ----------

# The simple baselines every predictor is compared with (labels of the league).
BASELINES = (
    "no motion",
    "decelerating 0.2",
    "decelerating",
    "decelerating 0.6",
    "Kalman CV",
    "One Euro",
)


@dataclass(frozen=True)
class Recording:
    """One series of the league: what the predictors see and what they are scored on.

    Attributes
    ----------
    name : str
    X : (T, d) ndarray
        The series the predictors are fed.
    layout : str
        See :func:`layout_structure`.
    resets : tuple of int
        Rows where a new take starts.
    truth : (T, d) ndarray or None
        The clean series for a noisy variant (None: `X` itself).
    """

    name: str
    X: np.ndarray
    layout: str
    resets: tuple[int, ...] = ()
    truth: np.ndarray | None = None


@dataclass(frozen=True)
class LeagueRow:
    """One predictor on one recording and group of the league table."""

    recording: str
    group: str
    unit: str
    predictor: str
    rmse: float
    r2_tilde: float
    rank: int  # 1 = the lowest RMSE on this recording and group
    ratio: float  # RMSE / the best baseline's RMSE on this recording and group
    frames: int


def noise_variants(
    recording: Recording,
    sigmas=(0.5, 1.0, 2.0),
    *,
    outlier_rate: float = 0.05,
    outlier_sigma: float = 10.0,
    seed: int = 0,
) -> list[Recording]:
    """Noisy copies of a clean recording, each scored against the clean series.

    Gaussian noise of standard deviation σ (in the columns' units: mm, degrees) on
    every value; and outlier frames: a fraction `outlier_rate` of the frames, drawn
    at random, whose every value is displaced by Gaussian noise of standard deviation
    `outlier_sigma` (a gross error of the estimator on that frame, as a tracker that
    slips or a detector that swaps joints makes), the other frames left clean.

    Parameters
    ----------
    recording : Recording
        The clean recording (its `truth` must be None).
    sigmas : sequence of float
    outlier_rate : float
    outlier_sigma : float
    seed : int
        Seed of ``numpy.random.default_rng``; every variant has its own stream.
    """
    if recording.truth is not None:
        raise ValueError(f"recording: expected a clean recording; got {recording.name!r}")
    X = recording.X
    out = []
    for k, sigma in enumerate(sigmas):
        rng = np.random.default_rng([seed, k])
        noisy = X + sigma * rng.standard_normal(X.shape)
        out.append(Recording(f"{recording.name} +N({sigma:g})", noisy, recording.layout,
                             recording.resets, X))  # fmt: skip
    rng = np.random.default_rng([seed, len(sigmas)])
    hit = rng.random(len(X)) < outlier_rate
    noisy = X + outlier_sigma * hit[:, None] * rng.standard_normal(X.shape)
    name = f"{recording.name} +{100 * outlier_rate:g}% outliers"
    out.append(Recording(name, noisy, recording.layout, recording.resets, X))
    return out


def smooth_variants(
    recording: Recording,
    *,
    slow: float = 4.0,
    sigma: float = 2.0,
    walk_sigma: float = 0.005,
    walk_frames: int = 2000,
    seed: int = 0,
) -> list[Recording]:
    """Slow, smooth motion for the league: where constant velocity is hard to beat.

    Two recordings: `recording` played `slow` times slower at the same frame rate
    after a Gaussian smoothing of `sigma` source frames
    (:func:`handvar.synth.motion.retime`, cubic interpolation; takes are slowed one by
    one), and a random walk in velocity of the same width and at most `walk_frames`
    frames, starting at the recording's first frame, v_t = v_{t−1} + `walk_sigma` ε_t,
    x_t = x_{t−1} + v_t (ε standard normal, seeded by `seed`; in the columns' units
    per frame²).  On both the motion between frames is almost linear: the best
    baseline is the constant-velocity Kalman filter, and a predictor that damps the
    last step (decelerating, the steering set without its join rule) loses to it.

    Parameters
    ----------
    recording : Recording
        A clean recording (its `truth` must be None).
    slow, sigma, walk_sigma : float
    walk_frames : int
    seed : int
    """
    from handvar.synth.motion import retime

    if recording.truth is not None:
        raise ValueError(f"recording: expected a clean recording; got {recording.name!r}")
    X = recording.X
    edges = [0, *recording.resets, len(X)]
    takes, resets = [], []
    for a, b in itertools.pairwise(edges):
        if b - a < 2:
            continue
        resets.append(sum(len(t) for t in takes))
        takes.append(retime(X[a:b], 1.0, 1.0, speed=1.0 / slow, smooth_sigma=sigma))
    slowed = Recording(
        f"{recording.name} slowed {slow:g}x", np.concatenate(takes), recording.layout,
        tuple(resets[1:]),
    )  # fmt: skip
    rng = np.random.default_rng([seed, 1])
    n = min(len(X), walk_frames)
    v = np.cumsum(walk_sigma * rng.standard_normal((n, X.shape[1])), axis=0)
    walk = Recording(
        f"{recording.name} velocity random walk", X[0] + np.cumsum(v, axis=0), recording.layout
    )
    return [slowed, walk]


def synthetic_families(T: int = 1500, width: int = 6, seed: int = 7) -> dict[str, np.ndarray]:
    """Four synthetic series (T, width), each with its own best simple baseline.

    A random walk (white-noise velocity: no motion is best), a smooth random walk in
    velocity (second differences of σ = 0.1: a constant-velocity model is best), a
    sinusoid of period 60 frames and amplitude 10 plus noise of σ = 0.2, and white noise
    (a low-pass is best).  Seeded by `seed`.
    """
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.standard_normal((T, width)), 0)
    smooth = np.cumsum(np.cumsum(0.1 * rng.standard_normal((T, width)), 0), 0)
    phase = rng.uniform(0, 6, width)
    sinusoid = 10 * np.sin(2 * np.pi * np.arange(T)[:, None] / 60 + phase)
    sinusoid += 0.2 * rng.standard_normal((T, width))
    return {
        "random walk": walk,
        "smooth velocity": smooth,
        "sinusoid": sinusoid,
        "white noise": rng.standard_normal((T, width)),
    }


def league_predictors(blocks=None, *, rate: float = 30.0, keys=None) -> dict[str, Predictor]:
    """The predictors of the league: the catalogue plus decelerating at ρ = 0.2 and 0.6.

    Parameters
    ----------
    blocks : list of lists of int, optional
        The structured VARs' blocks and the adaptive bank's groups.
    rate : float
        Frames per second (One Euro and the adaptive bank's One Euro expert).
    keys : iterable of str, optional
        Catalogue keys to include besides the baselines (default: all).
    """
    from handvar.predictors import Decelerating

    out: dict[str, Predictor] = {}
    for spec in CATALOGUE.values():
        if keys is not None and spec.key not in keys and spec.label not in BASELINES:
            continue
        if spec.kind in ("one_euro", "adaptive"):
            spec = spec.with_params(rate=rate)
        out[spec.label] = spec.build(blocks)
    out["decelerating 0.2"] = Decelerating(0.2)
    out["decelerating 0.6"] = Decelerating(0.6)
    return out


def league_table(
    recordings: list[Recording],
    *,
    rate: float = 30.0,
    keys=None,
    extra: dict | None = None,
) -> list[LeagueRow]:
    """Score every predictor on every recording: RMSE, R̃², rank and ratio per group.

    Parameters
    ----------
    recordings : list of Recording
    rate : float
        Frames per second of the recordings.
    keys : iterable of str, optional
        Catalogue keys to include besides the baselines.
    extra : dict of name to callable, optional
        More predictors: ``extra[name](recording)`` returns a fresh predictor for a
        recording (the offline-trained VAR), or None to leave it out there.

    Returns
    -------
    list of LeagueRow
        Per recording, its groups and an ``"all"`` group of every column; the rank and
        ratio compare the predictors on the same recording and group.
    """
    rows: list[LeagueRow] = []
    for rec in recordings:
        groups, blocks = layout_structure(rec.layout, rec.X.shape[1])
        width = rec.X.shape[1]
        groups = (*groups, ("all", "", np.arange(width)))
        predictors = league_predictors(blocks, rate=rate, keys=keys)
        for name, make in (extra or {}).items():
            p = make(rec)
            if p is not None:
                predictors[name] = p
        by_group = evaluate_open_loop(
            rec.X, predictors, resets=rec.resets, layout=rec.layout, truth=rec.truth,
            groups=groups,
        )  # fmt: skip
        for group, unit, _idx in groups:
            sub = [r for r in by_group if r.group == group]
            best = min(r.rmse for r in sub if r.predictor in BASELINES)
            order = sorted(sub, key=lambda r: r.rmse)
            rank = {r.predictor: i + 1 for i, r in enumerate(order)}
            for r in sub:
                ratio = r.rmse / best if best > 0 else float("nan")
                rows.append(LeagueRow(rec.name, group, unit, r.predictor, r.rmse, r.r2_tilde,
                                      rank[r.predictor], ratio, r.frames))  # fmt: skip
    return rows


def format_league(rows: list[LeagueRow], *, group: str = "all") -> str:
    """Plain-text league: per recording, every predictor's RMSE, R̃², rank and ratio.

    Only the rows of `group` (default the pooled ``"all"``) are printed; the CSV
    holds every group.  A last table gives each predictor's ratio to the best
    baseline on every recording and its worst ratio.
    """
    lines = []
    sub = [r for r in rows if r.group == group]
    recs = list(dict.fromkeys(r.recording for r in sub))
    w = max(17, *(len(r.predictor) + 1 for r in sub))  # the name column
    for rec in recs:
        rr = sorted((r for r in sub if r.recording == rec), key=lambda r: r.rank)
        lines.append(f"{rec} ({group}, {rr[0].frames} frames)")
        head = f"{'RMSE':>10}{'R̃²':>8}{'/ best baseline':>17}"
        lines.append(f"  {'rank':<6}{'predictor':<{w + 1}}{head}")
        for r in rr:
            mark = "*" if r.predictor in BASELINES else " "
            lines.append(
                f"  {r.rank:<6}{r.predictor:<{w}}{mark}{r.rmse:>10.4f}{r.r2_tilde:>8.3f}"
                f"{r.ratio:>17.3f}"
            )
        lines.append("")
    names = list(dict.fromkeys(r.predictor for r in sub))
    lines.append(f"RMSE / best baseline ({group}); * = a baseline")
    for k, rec in enumerate(recs):
        lines.append(f"  [{k + 1}] {rec}")
    head = "".join(f"{f'[{k + 1}]':>8}" for k in range(len(recs)))
    lines.append(f"  {'predictor':<{w + 1}}{head}{'worst':>8}")
    for name in names:
        vals = [next(r.ratio for r in sub if r.recording == rec and r.predictor == name)
                for rec in recs]  # fmt: skip
        mark = "*" if name in BASELINES else " "
        lines.append(f"  {name:<{w}}{mark}" + "".join(f"{v:>8.3f}" for v in vals)
                     + f"{max(vals):>8.3f}")  # fmt: skip
    return "\n".join(lines) + "\n"


def write_league_csv(rows: list[LeagueRow], path: str | os.PathLike) -> None:
    """Write the league as CSV (every recording, group and predictor), atomically."""
    from handvar.atomic import write_atomic

    def quote(text: str) -> str:
        return f'"{text}"' if "," in text else text

    lines = ["recording,group,unit,predictor,rmse,r2_tilde,rank,ratio_to_best_baseline,frames"]
    lines += [
        f"{quote(r.recording)},{r.group},{r.unit},{r.predictor},{r.rmse:.6g},"
        f"{r.r2_tilde:.6g},{r.rank},{r.ratio:.6g},{r.frames}"
        for r in rows
    ]
    write_atomic(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))


def write_league_figure(rows: list[LeagueRow], path: str | os.PathLike, *, group: str = "all"):
    """A PNG of every predictor's RMSE / best baseline per recording (Agg), atomically."""
    from matplotlib.figure import Figure

    from handvar.atomic import write_atomic

    sub = [r for r in rows if r.group == group]
    recs = list(dict.fromkeys(r.recording for r in sub))
    names = list(dict.fromkeys(r.predictor for r in sub))
    fig = Figure(figsize=(max(6.0, 1.1 * len(recs) + 3), 4.5), layout="constrained")
    ax = fig.add_subplot()
    width = 0.8 / len(names)
    for i, name in enumerate(names):
        vals = [next(r.ratio for r in sub if r.recording == rec and r.predictor == name)
                for rec in recs]  # fmt: skip
        ax.bar(np.arange(len(recs)) + (i - len(names) / 2 + 0.5) * width, vals, width,
               label=name, hatch="//" if name in BASELINES else None)  # fmt: skip
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(np.arange(len(recs)), recs, rotation=30, ha="right", fontsize=7)
    ax.set_ylabel("one-step RMSE / best simple baseline")
    ax.set_ylim(0, min(2.0, 1.05 * max(r.ratio for r in sub)))
    ax.legend(fontsize=6, ncol=2)
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=120))
