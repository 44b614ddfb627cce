"""The paper's figures, drawn from an experiment's measurements (paper §4–5).

- :func:`r2_boxplot`: R̃² (eq. 21) per joint over the trials, as figures 2, 3 and 5
  (whiskers at 1.5 IQR; outliers between 1.5 and 3 IQR '+', beyond 3 IQR 'o').
- :func:`mean_error_figure`: the mean joint error over frames for every predictor,
  averaged over the trials (figure 4).
- :func:`overlay_figure`: the estimated model over the true silhouettes at the error
  peaks, rows no motion / decelerating / RVAR (figure 6).
- :func:`sweep_figure`: overall mean error and median R̃² against a swept argument.

Every function returns a ``matplotlib.figure.Figure`` (no pyplot state); writing the
files is the report's business.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Sequence

import numpy as np

from handvar.evaluation.results import (
    N_JOINTS,
    Results,
    error_peaks,
    joint_medians,
    load_results,
    median,
    reference_curve,
)
from handvar.evaluation.store import open_store

__all__ = ["mean_error_figure", "overlay_figure", "r2_boxplot", "sweep_figure", "sweeps"]

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
    "one_euro": "tab:cyan",
    "adaptive": "tab:orange",
    "adaptive_open": "tab:brown",
}


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
    r2 = [median(joint_medians(results.r2(p))) for _, p in points]
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
    frames = list(error_peaks(reference_curve(results)) if frames is None else frames)
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
