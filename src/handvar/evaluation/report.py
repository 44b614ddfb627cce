"""The paper's figures and claims, measured from an experiment store (§4–5).

- :func:`r2_boxplot`: R̃² (eq. 21) per joint over the trials, as figures 2, 3 and 5
  (whiskers at 1.5 IQR; outliers between 1.5 and 3 IQR '+', beyond 3 IQR 'o').
- :func:`mean_error_figure`: the mean joint error over frames for every predictor,
  averaged over the trials (figure 4).
- :func:`overlay_figure`: the estimated model over the true silhouettes at the error
  peaks, rows no motion / decelerating / RVAR (figure 6).
- :func:`evaluate_claims`: every claim of §4–5 beside what the store shows, with the
  exact test behind each verdict.
- :func:`write_report`: all of it as PNG files, ``report.md`` and ``report.html``.

Joints are numbered 1–21 on the figures and in the claims as in the paper (joint 1
the palm base = our wrist, index 0; 18–21 the little finger = our 17–20).
"""

from __future__ import annotations

import dataclasses
import html
import json
import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from handvar.evaluation.experiment import ExperimentConfig, open_store

__all__ = [
    "Claim",
    "Results",
    "error_peaks",
    "evaluate_claims",
    "load_results",
    "mean_error_figure",
    "overlay_figure",
    "r2_boxplot",
    "sweep_figure",
    "sweeps",
    "write_report",
]

N_JOINTS = 21
# Colours of figure 4 (no motion green, decelerating blue, structured VAR yellow,
# RVAR red); the others are ours.
_COLOURS = {
    "none": "tab:green",
    "decelerating": "tab:blue",
    "structured_var": "gold",
    "rvar": "tab:red",
    "full_var": "tab:gray",
    "rvar_relative": "tab:purple",
    "kalman": "black",
}


# --- the measurements --------------------------------------------------------------


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


def _joint_medians(r2: np.ndarray) -> np.ndarray:
    """(21,) median over trials of R̃² per joint."""
    if len(r2) == 0:
        return np.full(N_JOINTS, np.nan)
    return np.array([_median(r2[:, j]) for j in range(r2.shape[1])])


def _joint_iqrs(r2: np.ndarray) -> np.ndarray:
    """(21,) interquartile range over trials of R̃² per joint."""
    out = np.full(r2.shape[1] if r2.ndim == 2 else N_JOINTS, np.nan)
    for j in range(len(out)):
        v = r2[:, j][np.isfinite(r2[:, j])] if len(r2) else np.array([])
        if v.size:
            q1, q3 = np.percentile(v, [25, 75])
            out[j] = q3 - q1
    return out


def _median(v) -> float:
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else float("nan")


# --- figures -----------------------------------------------------------------------


def _figure(figsize):
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _outliers(v: np.ndarray):
    """Values beyond 1.5 IQR (mild) and beyond 3 IQR (extreme) of the quartiles."""
    q1, q3 = np.percentile(v, [25, 75])
    iqr = q3 - q1
    far = (v < q1 - 3 * iqr) | (v > q3 + 3 * iqr)
    mild = ((v < q1 - 1.5 * iqr) | (v > q3 + 1.5 * iqr)) & ~far
    return v[mild], v[far]


def r2_boxplot(results: Results, predictor: str, *, ax=None):
    """Figures 2, 3, 5: box plots of R̃² (eq. 21) per joint over the trials.

    Parameters
    ----------
    results : Results
    predictor : str
        Key or label of the predictor.
    ax : matplotlib Axes, optional
        Draw here; a new figure otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    p = results.index(predictor)
    if p is None:
        raise ValueError(
            f"predictor: expected one of {', '.join(results.labels)}; got {predictor!r}"
        )
    fig = None
    if ax is None:
        fig = _figure((9.0, 3.6))
        ax = fig.add_subplot()
    r2 = results.r2(p)
    positions = np.arange(1, N_JOINTS + 1)
    data = [r2[:, j][np.isfinite(r2[:, j])] for j in range(N_JOINTS)]
    shown = [d for d in data if d.size]
    if shown:
        ax.boxplot(
            [d if d.size else np.array([np.nan]) for d in data],
            positions=positions,
            whis=1.5,
            showfliers=False,
            widths=0.6,
            medianprops={"color": "tab:red"},
        )
        for x, d in zip(positions, data, strict=True):
            if d.size:
                mild, far = _outliers(d)
                ax.plot(np.full(mild.size, x), mild, "+", color="tab:red", ms=6)
                ax.plot(np.full(far.size, x), far, "o", mfc="none", color="tab:red", ms=4)
        _limit_to_whiskers(ax, positions, data)
    else:
        ax.text(0.5, 0.5, "no finished trials", transform=ax.transAxes, ha="center")
    ax.axhline(0.0, color="0.5", lw=0.8, ls="--")
    ax.set_xticks(positions, [str(k) for k in positions])
    ax.set_xlim(0.3, N_JOINTS + 0.7)
    ax.set_xlabel("joint / fingertip (paper's numbering)")
    ax.set_ylabel("R̃²(τ)")
    ax.set_title(
        f"R̃² of {results.labels[p]} against no motion, {len(r2)} trials (eq. 21); "
        "↓n: n outliers below the axis"
    )
    return fig if fig is not None else ax.figure


def _limit_to_whiskers(ax, positions, data) -> None:
    """Show the boxes and whiskers (and at least [-1, 1]); count the outliers cut off.

    A few trials with R̃² of −100 would otherwise squash every box into a line.
    """
    lows, highs = [-1.0], [1.0]
    for d in data:
        if d.size:
            q1, q3 = np.percentile(d, [25, 75])
            inside = d[(d >= q1 - 1.5 * (q3 - q1)) & (d <= q3 + 1.5 * (q3 - q1))]
            lows.append(inside.min())
            highs.append(inside.max())
    lo, hi = min(lows), max(highs)
    pad = 0.08 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    ax.set_ylim(lo, hi)
    for x, d in zip(positions, data, strict=True):
        below, above = int(np.sum(d < lo)), int(np.sum(d > hi))
        if below:
            ax.annotate(f"↓{below}", (x, lo), xytext=(0, 2), textcoords="offset points",
                        ha="center", va="bottom", fontsize=7, color="tab:red")  # fmt: skip
        if above:
            ax.annotate(f"↑{above}", (x, hi), xytext=(0, -2), textcoords="offset points",
                        ha="center", va="top", fontsize=7, color="tab:red")  # fmt: skip


def error_peaks(curve, n: int = 3, *, separation: int = 10) -> list[int]:
    """The `n` highest frames of an error curve, at least `separation` frames apart.

    Frame 0 (the true first pose) is never a peak.  Returned in frame order.

    Examples
    --------
    >>> error_peaks([0, 1, 5, 1, 0, 0, 3, 0], n=2, separation=2)
    [2, 6]
    """
    c = np.asarray(curve, dtype=float)
    if c.ndim != 1:
        raise ValueError(f"curve: expected a (F,) series; got shape {c.shape}")
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


def _reference_curve(results: Results) -> np.ndarray:
    ref = results.index("none")
    if ref is not None and results.done[ref].any():
        return results.mean_error_curve(ref)
    curves = [results.mean_error_curve(p) for p in range(len(results.labels))]
    with np.errstate(all="ignore"):
        return np.nanmean(np.where(np.isfinite(curves), curves, 0.0), axis=0)


def mean_error_figure(results: Results, *, peaks: Sequence[int] = (), ax=None):
    """Figure 4: mean joint error over frames, averaged over the trials, per predictor."""
    fig = None
    if ax is None:
        fig = _figure((9.0, 4.0))
        ax = fig.add_subplot()
    frames = np.arange(results.error.shape[2])
    for p, spec in enumerate(results.config.predictors):
        if not results.done[p].any():
            continue
        base = spec.key.split("[", 1)[0]
        swept = "[" in spec.key
        ax.plot(
            frames,
            results.mean_error_curve(p),
            color=_COLOURS.get(base),
            lw=1.0 if swept else 1.6,
            ls=":" if swept else "-",
            label=f"{spec.label} ({int(results.done[p].sum())} trials)",
        )
    for f in peaks:
        ax.axvline(f, color="0.6", lw=0.8, ls="--")
    ax.set_xlabel("frame")
    ax.set_ylabel("mean joint error (mm)")
    ax.set_title("Overall mean error: mean over the 21 joints and the trials (figure 4)")
    ax.legend(fontsize=8, ncols=2)
    ax.set_xlim(frames[0], frames[-1])
    ax.set_ylim(bottom=0)
    return fig if fig is not None else ax.figure


def sweeps(results: Results) -> dict[tuple[str, str], list[tuple[float, int]]]:
    """Swept variants grouped by (base key, argument): [(value, predictor index)].

    The base entry itself is included with its own value of the argument (when it
    sets one), so a sweep ``rvar.gamma=0.5,0.9`` gives the points 0.5, 0.8, 0.9.
    """
    out: dict[tuple[str, str], list[tuple[float, int]]] = {}
    for p, spec in enumerate(results.config.predictors):
        m = re.fullmatch(r"(.+)\[(\w+)=([^\]]+)\]", spec.key)
        if m is None:
            continue
        base, arg = m.group(1), m.group(2)
        value = spec.kwargs.get(arg)
        if isinstance(value, int | float) and not isinstance(value, bool):
            out.setdefault((base, arg), []).append((float(value), p))
    for (base, arg), points in out.items():
        b = results.index(base)
        own = results.config.predictors[b].kwargs.get(arg) if b is not None else None
        if isinstance(own, int | float) and not isinstance(own, bool):
            points.append((float(own), b))
        points.sort()
    return out


def sweep_figure(results: Results, base: str, arg: str):
    """Overall mean error and median R̃² against the swept argument of one predictor."""
    points = sweeps(results).get((base, arg))
    if not points:
        raise ValueError(f"base, arg: expected a swept predictor argument; got {base}.{arg}")
    points = [(v, p) for v, p in points if results.done[p].any()]
    fig = _figure((6.0, 3.6))
    ax = fig.add_subplot()
    x = [v for v, _ in points]
    ax.plot(x, [results.overall_error(p) for _, p in points], "o-", color="tab:red")
    ax.set_xlabel(arg)
    ax.set_ylabel("overall mean error (mm)", color="tab:red")
    right = ax.twinx()
    r2 = [_median(_joint_medians(results.r2(p))) for _, p in points]
    right.plot(x, r2, "s--", color="tab:blue")
    right.set_ylabel("median R̃² over joints", color="tab:blue")
    label = results.config.spec(base).label
    ax.set_title(f"{label}: sweep of {arg}")
    return fig


def _representative_trial(results: Results, p: int, frame: int) -> int | None:
    """The finished trial whose error at `frame` is the median one (lower middle)."""
    trials = np.flatnonzero(results.done[p])
    if not trials.size:
        return None
    e = results.error[p, trials, frame]
    return int(trials[np.argsort(e, kind="stable")[(len(e) - 1) // 2]])


def overlay_figure(
    store: str | os.PathLike,
    results: Results | None = None,
    *,
    frames: Sequence[int] | None = None,
    predictors: Sequence[str] = ("none", "decelerating", "rvar"),
    camera: int = 0,
):
    """Figure 6: the estimated model over the true silhouette at the error peaks.

    One row per predictor (no motion, decelerating, RVAR), one column per frame (the
    three peaks of the no-motion error curve by default).  Each cell shows, in the
    first camera, the true silhouette (grey), the outline of the estimated model's
    silhouette (yellow, re-rendered from the estimated pose) and its joints, for the
    trial whose error at that frame is the median one of the predictor's trials.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from handvar.camera import Rig
    from handvar.hand.kinematics import HandModel
    from handvar.render import draw_overlay, silhouettes

    results = results or load_results(store)
    ds = open_store(store)
    rig = Rig.from_dict(json.loads(ds.attrs["rig"]))
    cam = rig.cameras[camera]
    frames = list(error_peaks(_reference_curve(results)) if frames is None else frames)
    rows = [(k, results.index(k)) for k in predictors]
    rows = [(k, p) for k, p in rows if p is not None and results.done[p].any()]
    fig = _figure((3.0 * max(1, len(frames)), 2.6 * max(1, len(rows)) + 0.3))
    if not rows or not frames:
        ax = fig.add_subplot()
        ax.text(0.5, 0.5, "no finished trials to show", ha="center", transform=ax.transAxes)
        ax.set_axis_off()
        return fig
    hand = HandModel()
    axes = fig.subplots(len(rows), len(frames), squeeze=False)
    for c, f in enumerate(frames):
        truth = ds["masks"][f, camera].values
        cells, boxes = [], [truth]
        for _, p in rows:
            trial = _representative_trial(results, p, f)
            x = ds["poses"][p, trial, f].values
            model = silhouettes(hand, x, rig)[camera]
            boxes.append(model)
            image = draw_overlay(truth, cam, ds["joints"][p, trial, f].values, mask=model)
            cells.append((image, trial, results.error[p, trial, f]))
        y0, y1, x0, x1 = _crop(np.logical_or.reduce(boxes))
        for r, ((_, p), (image, trial, err)) in enumerate(zip(rows, cells, strict=True)):
            ax = axes[r, c]
            ax.imshow(image[y0:y1, x0:x1])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"frame {f}, trial {trial}: {err:.1f} mm", fontsize=8)
            if c == 0:
                ax.set_ylabel(results.labels[p])
    fig.suptitle("Estimated model (yellow outline, joints) over the true silhouette (grey)")
    return fig


def _crop(mask: np.ndarray, margin: int = 20):
    ys, xs = np.nonzero(mask)
    h, w = mask.shape
    if not ys.size:
        return 0, h, 0, w
    return (
        max(0, ys.min() - margin),
        min(h, ys.max() + margin + 1),
        max(0, xs.min() - margin),
        min(w, xs.max() + margin + 1),
    )


# --- the claims --------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Claim:
    """One claim of the paper beside what was measured.

    Attributes
    ----------
    section : str
        Where the paper makes it.
    claim : str
    test : str
        The exact test behind the verdict.
    measured : str
    holds : bool or None
        None when the store cannot decide (a predictor missing or unfinished).
    """

    section: str
    claim: str
    test: str
    measured: str
    holds: bool | None

    @property
    def verdict(self) -> str:
        """``yes``, ``no`` or ``n/a``."""
        return {True: "yes", False: "no", None: "n/a"}[self.holds]


def _fmt(v: float, digits: int = 2) -> str:
    return "nan" if not np.isfinite(v) else f"{v:.{digits}f}"


def _n(results: Results, p: int) -> str:
    return f"{len(results.r2(p))} trials"


def _missing(results: Results, *keys: str) -> str | None:
    """A reason the claim cannot be tested, or None."""
    for key in keys:
        p = results.index(key)
        if p is None:
            return f"{key} is not in this store"
        if key != "none" and not len(results.r2(p)):
            return f"{results.labels[p]} has no trial scored against no motion yet"
        if not results.done[p].any():
            return f"{results.labels[p]} has no finished trial"
    return None


def _claim_decelerating(r: Results) -> tuple[str, bool]:
    p = r.index("decelerating")
    med = _joint_medians(r.r2(p))
    stat = _median(med)
    ref = r.index("none")
    return (
        f"median over joints of the per-joint median R̃² = {_fmt(stat)} "
        f"({int(np.sum(med > 0))}/21 joints > 0; {_n(r, p)}); overall mean error "
        f"{_fmt(r.overall_error(p))} mm vs {_fmt(r.overall_error(ref))} mm without prediction",
        bool(stat > 0),
    )


def _claim_full_var(r: Results) -> tuple[str, bool]:
    p = r.index("full_var")
    med = _joint_medians(r.r2(p))
    stat = _median(med)
    return (
        f"median over joints of the per-joint median R̃² = {_fmt(stat)} "
        f"({int(np.sum(med < 0))}/21 joints < 0; {_n(r, p)})",
        bool(stat < 0),
    )


def _claim_structured_joints(r: Results) -> tuple[str, bool]:
    p = r.index("structured_var")
    r2 = r.r2(p)
    palm = _median(r2[:, 0])
    little = _median(r2[:, 17:21].mean(axis=1)) if len(r2) else float("nan")
    others = _median(_joint_medians(r2)[1:17])
    return (
        f"joint 1: median R̃² = {_fmt(palm)}; joints 18–21: median of the trial means = "
        f"{_fmt(little)}; the other joints: median of medians = {_fmt(others)} ({_n(r, p)})",
        bool(palm > 0 and little > 0),
    )


def _claim_structured_middle_tip(r: Results) -> tuple[str, bool]:
    p = r.index("structured_var")
    tip = _median(r.r2(p)[:, 12])
    return f"joint 13: median R̃² = {_fmt(tip)} ({_n(r, p)})", bool(tip < 0)


def _claim_structured_variance(r: Results) -> tuple[str, bool]:
    sv, d = r.index("structured_var"), r.index("decelerating")
    a, b = _median(_joint_iqrs(r.r2(sv))), _median(_joint_iqrs(r.r2(d)))
    return (
        f"median over joints of the IQR of R̃²: structured VAR {_fmt(a)}, decelerating {_fmt(b)}",
        bool(a > b),
    )


def _claim_rvar_half(r: Results) -> tuple[str, bool]:
    p = r.index("rvar")
    med = _joint_medians(r.r2(p))
    k = int(np.sum((med >= 0.25) & (med <= 0.75)))
    return (
        f"{k}/21 joints with median R̃² in [0.25, 0.75]; median over joints "
        f"{_fmt(_median(med))} ({_n(r, p)})",
        k >= 11,
    )


def _claim_rvar_vs_decelerating(r: Results) -> tuple[str, bool]:
    a = _joint_medians(r.r2(r.index("rvar")))
    b = _joint_medians(r.r2(r.index("decelerating")))
    better = np.flatnonzero(a > b)
    worse = [str(j + 1) for j in range(N_JOINTS) if j not in set(better)]
    return (
        f"RVAR's median R̃² higher at {better.size}/21 joints"
        + (f" (not at joints {', '.join(worse)})" if worse else ""),
        better.size >= 11,
    )


def _claim_rvar_variance(r: Results) -> tuple[str, bool]:
    a = _median(_joint_iqrs(r.r2(r.index("rvar"))))
    b = _median(_joint_iqrs(r.r2(r.index("structured_var"))))
    return (
        f"median over joints of the IQR of R̃²: RVAR {_fmt(a)}, structured VAR {_fmt(b)}",
        bool(a < b),
    )


def _paper_five(r: Results) -> list[int]:
    keys = ("none", "decelerating", "full_var", "structured_var", "rvar")
    return [p for p in (r.index(k) for k in keys) if p is not None and r.done[p].any()]


def _claim_rvar_lowest(r: Results) -> tuple[str, bool]:
    ps = _paper_five(r)
    overall = {r.labels[p]: r.overall_error(p) for p in ps}
    rv = r.index("rvar")
    curves = np.array([r.mean_error_curve(p) for p in ps])[:, 1:]
    lowest = np.argmin(curves, axis=0) == ps.index(rv)
    return (
        "overall mean error (mm): "
        + ", ".join(f"{k} {_fmt(v)}" for k, v in overall.items())
        + f"; RVAR's curve is the lowest at {int(lowest.sum())}/{lowest.size} frames",
        bool(min(overall.values()) == overall[r.labels[rv]]),
    )


def _error_and_r2(r: Results, first: str, second: str, names: tuple[str, str]):
    """Overall mean errors of two predictors and the sentence comparing them."""
    i, j = r.index(first), r.index(second)
    a, b = r.overall_error(i), r.overall_error(j)
    text = (
        f"overall mean error: {names[0]} {_fmt(a)} mm, {names[1]} {_fmt(b)} mm; median "
        f"R̃²: {_fmt(_median(_joint_medians(r.r2(i))))} vs "
        f"{_fmt(_median(_joint_medians(r.r2(j))))}"
    )
    return text, a, b


def _claim_constant_velocity(r: Results) -> tuple[str, bool]:
    text, a, b = _error_and_r2(r, "kalman", "decelerating", ("Kalman CV", "decelerating"))
    return text, bool(a > b)


def _claim_relative(r: Results) -> tuple[str, bool]:
    text, a, b = _error_and_r2(r, "rvar_relative", "rvar", ("relative", "absolute"))
    return text, bool(a <= b)


# (section, claim, test, predictors needed, measurement)
_CLAIMS: tuple[tuple[str, str, str, tuple[str, ...], Callable], ...] = (
    (
        "§4, fig. 2",
        "The decelerating predictor (ρ = 0.4) improves on tracking without prediction.",
        "median over the 21 joints of the per-joint median (over trials) R̃² (eq. 21) > 0",
        ("none", "decelerating"),
        _claim_decelerating,
    ),
    (
        "§4.2",
        "The full VAR (N = 150) tracks worse than no motion prediction.",
        "median over the 21 joints of the per-joint median R̃² < 0",
        ("none", "full_var"),
        _claim_full_var,
    ),
    (
        "§4.3, fig. 3",
        "The structured VAR (N = 30) drastically improves the palm base (joint 1) and "
        "the little finger (joints 18–21).",
        "median over trials of R̃² of joint 1 > 0 and median over trials of the mean R̃² "
        "of joints 18–21 > 0",
        ("none", "structured_var"),
        _claim_structured_joints,
    ),
    (
        "§4.3",
        "The structured VAR worsens the middle fingertip (joint 13).",
        "median over trials of R̃² of joint 13 < 0",
        ("none", "structured_var"),
        _claim_structured_middle_tip,
    ),
    (
        "§4.3",
        "The structured VAR increases the variance of the tracking performance compared "
        "with the decelerating predictor.",
        "median over joints of the interquartile range (over trials) of R̃²: structured "
        "VAR > decelerating",
        ("none", "structured_var", "decelerating"),
        _claim_structured_variance,
    ),
    (
        "§5, fig. 5",
        "RVAR (γ = 0.8, c = 8): R̃² around 0.5 for most joints.",
        "at least 11 of the 21 joints have a median R̃² in [0.25, 0.75]",
        ("none", "rvar"),
        _claim_rvar_half,
    ),
    (
        "§5",
        "RVAR performs better than the decelerating predictor (except the middle PIP, "
        "joint 12, and possibly the thumb, joints 3–5).",
        "RVAR's median R̃² exceeds the decelerating predictor's at at least 11 of 21 joints",
        ("none", "rvar", "decelerating"),
        _claim_rvar_vs_decelerating,
    ),
    (
        "§5",
        "RVAR inherits the low variance of the decelerating predictor: lower than the "
        "structured VAR's.",
        "median over joints of the interquartile range of R̃²: RVAR < structured VAR",
        ("none", "rvar", "structured_var"),
        _claim_rvar_variance,
    ),
    (
        "§5, fig. 4",
        "RVAR has the lowest mean error curve.",
        "RVAR's overall mean error (frames 1.. and finished trials) is the lowest of the "
        "paper's predictors in the store",
        ("none", "rvar"),
        _claim_rvar_lowest,
    ),
    (
        "§4 (ρ = 1)",
        "Tracking with a constant-velocity model is unstable; here: the constant-velocity "
        "Kalman filter (not in the paper) against the decelerating predictor.",
        "overall mean error: Kalman CV > decelerating",
        ("none", "kalman", "decelerating"),
        _claim_constant_velocity,
    ),
    (
        "§5, after eq. 27",
        "Relative interpolation of the changes is an alternative to eq. 26–27 (the "
        "paper gives no result); here: relative RVAR tracks at least as well as absolute.",
        "overall mean error: RVAR relative ≤ RVAR",
        ("none", "rvar_relative", "rvar"),
        _claim_relative,
    ),
)


def evaluate_claims(results: Results) -> list[Claim]:
    """Every claim of §4–5 tested on the store's measurements.

    Returns
    -------
    list of Claim
        In the paper's order; ``holds`` is None where a needed predictor is missing or
        has no finished trial.
    """
    out = []
    for section, claim, test, needs, measure in _CLAIMS:
        reason = _missing(results, *needs)
        if reason is not None:
            out.append(Claim(section, claim, test, reason, None))
            continue
        measured, holds = measure(results)
        out.append(Claim(section, claim, test, measured, bool(holds)))
    return out


# --- the report --------------------------------------------------------------------


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_").lower()


def _temporary(path: Path) -> Path:
    """A hidden name beside `path` (created with the default permissions)."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _save(fig, path: Path) -> None:
    tmp = _temporary(path)
    try:
        fig.savefig(tmp, dpi=110, format="png")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _write_text(path: Path, text: str) -> None:
    tmp = _temporary(path)
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


_FIGURE_NUMBER = {"decelerating": 2, "structured_var": 3, "rvar": 5}


def _summary_rows(results: Results) -> list[list[str]]:
    rows = []
    for p, spec in enumerate(results.config.predictors):
        n = int(results.done[p].sum())
        args = ", ".join(f"{k}={v}" for k, v in spec.params) or "-"
        if n == 0:
            rows.append([spec.label, args, "0", "-", "-", "-", "-", "-"])
            continue
        r2 = results.r2(p)
        it = results.iterations[p][results.done[p]][:, 1:]
        tm = results.timings[p][results.done[p]][:, 1:].sum(axis=-1)
        rows.append(
            [
                spec.label,
                args,
                str(n),
                _fmt(results.overall_error(p)),
                _fmt(_median(_joint_medians(r2))) if len(r2) else "-",
                _fmt(_median(_joint_iqrs(r2))) if len(r2) else "-",
                _fmt(float(it.mean()), 1) if it.size else "-",
                _fmt(1000 * _median(tm), 2) if np.isfinite(tm).any() else "-",
            ]
        )
    return rows


_SUMMARY_HEADER = [
    "predictor",
    "arguments",
    "trials done",
    "overall mean error (mm)",
    "median R̃²",
    "median IQR of R̃²",
    "iterations / frame",
    "median ms / frame",
]


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    def esc(s: str) -> str:
        return s.replace("|", "\\|")

    lines = ["| " + " | ".join(map(esc, header)) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(map(esc, row)) + " |" for row in rows]
    return "\n".join(lines)


def _html_table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def write_report(
    store: str | os.PathLike, out: str | os.PathLike, *, progress: bool = False
) -> Path:
    """Draw every figure and write ``report.md`` and ``report.html`` into `out`.

    Parameters
    ----------
    store : path-like
        An experiment store (complete or not: unfinished trials are left out).
    out : path-like
        Output directory (created).  Files: ``fig2_r2_decelerating.png``,
        ``fig3_r2_structured_var.png``, ``fig5_r2_rvar.png``, ``r2_<predictor>.png``
        for the others, ``fig4_mean_error.png``, ``fig6_overlays.png``,
        ``report.md``, ``report.html``.
    progress : bool, keyword-only
        Print each file as it is written.

    Returns
    -------
    Path
        The Markdown report.
    """
    results = load_results(store)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = results.config
    figures: list[tuple[str, str]] = []  # (file, caption)

    def save(fig, name: str, caption: str) -> None:
        _save(fig, out / name)
        figures.append((name, caption))
        if progress:
            print(out / name)

    ref = results.index("none")
    for p, spec in enumerate(cfg.predictors):
        if p == ref:
            continue
        number = _FIGURE_NUMBER.get(spec.key)
        name = f"fig{number}_r2_{spec.key}.png" if number else f"r2_{_slug(spec.key)}.png"
        caption = f"R̃² (eq. 21) per joint of {spec.label}" + (
            f" (the paper's figure {number})" if number else ""
        )
        save(r2_boxplot(results, spec.key), name, caption)
    for (base, arg), points in sweeps(results).items():
        if any(results.done[p].any() for _, p in points):
            save(
                sweep_figure(results, base, arg),
                f"sweep_{_slug(base)}_{_slug(arg)}.png",
                f"{cfg.spec(base).label}: overall mean error and median R̃² against {arg}",
            )
    peaks = error_peaks(_reference_curve(results))
    save(
        mean_error_figure(results, peaks=peaks),
        "fig4_mean_error.png",
        "Mean joint error over frames, averaged over the trials (the paper's figure 4); "
        f"dashed: the error peaks {', '.join(map(str, peaks))}",
    )
    save(
        overlay_figure(store, results, frames=peaks),
        "fig6_overlays.png",
        "Estimated models at the error peaks (the paper's figure 6); rows: no motion, "
        "decelerating, RVAR; the median trial of each cell",
    )
    claims = evaluate_claims(results)
    claim_rows = [[c.section, c.claim, c.measured, c.verdict, c.test] for c in claims]
    claim_header = ["paper", "claim of the paper", "what we measured", "holds?", "test"]
    summary = _summary_rows(results)
    done, total = int(results.done.sum()), results.done.size
    kind_note = (
        "Trials run the SMD tracker on the rendered silhouettes."
        if cfg.trial_kind == "tracker"
        else "OPEN-LOOP trials: no tracker; each predictor runs one step ahead along the "
        f"truth plus Gaussian noise ({cfg.noise:g} mm / deg), and its predictions stand "
        "in for the estimates. These numbers say nothing about tracking."
    )
    intro = [
        f"Store: `{Path(store)}`; {done}/{total} trials finished.",
        f"Sequence `{cfg.sequence}` (seed {cfg.sequence_seed}), {cfg.frames} frames; "
        f"{cfg.trials} trials per predictor (trial k uses the seed [{cfg.seed}, k]). " + kind_note,
        "R̃² compares each trial with the no-motion trial of the same seed; joints are "
        "numbered 1–21 as in the paper (1 = palm base).",
    ]
    finished = results.done.sum(axis=1)
    if finished.size and finished.min() < 10:
        intro.append(
            f"Some predictors have fewer than 10 finished trials (least: {int(finished.min())}); "
            "their verdicts are indicative only (the paper used 50)."
        )
    if cfg.tracker:
        intro.append(
            "Tracker settings changed: " + ", ".join(f"{k}={v}" for k, v in cfg.tracker) + "."
        )
    md = ["# Tracking experiment: the paper's claims, measured", "", *intro, ""]
    md += ["## Claims", "", _md_table(claim_header, claim_rows), ""]
    md += ["## Predictors", "", _md_table(_SUMMARY_HEADER, summary), ""]
    md += ["## Figures", ""]
    for name, caption in figures:
        md += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    _write_text(out / "report.md", "\n".join(md))

    page = [
        "<!DOCTYPE html>",
        '<html><head><meta charset="utf-8"><title>handvar experiment</title>',
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #aaa;"
        "padding:4px 6px;vertical-align:top;font-size:90%}img{max-width:100%}</style>",
        "</head><body>",
        "<h1>Tracking experiment: the paper's claims, measured</h1>",
        *(f"<p>{html.escape(line).replace('`', '')}</p>" for line in intro),
        "<h2>Claims</h2>",
        _html_table(claim_header, claim_rows),
        "<h2>Predictors</h2>",
        _html_table(_SUMMARY_HEADER, summary),
        "<h2>Figures</h2>",
    ]
    for name, caption in figures:
        page.append(
            f'<figure><img src="{html.escape(name)}" alt="{html.escape(caption)}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
    page.append("</body></html>")
    _write_text(out / "report.html", "\n".join(page))
    return out / "report.md"
