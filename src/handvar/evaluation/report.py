"""The report of an experiment: its figures and claims as files (paper §4–5, design §7).

:func:`write_report` draws every figure (:mod:`handvar.evaluation.figures`), tests
every claim (:mod:`handvar.evaluation.claims`) and writes them as PNG files,
``report.md`` and ``report.html``.  The store is verified first
(:func:`handvar.evaluation.store.damaged_trials`, design §13.3): a damaged trial stops
the report before any file is written.  The files are all-or-nothing
(:class:`handvar.atomic.OutputSet`, design §13.1): written aside and renamed into place once
every one of them is complete.
"""

from __future__ import annotations

import contextlib
import dataclasses
import html
import os
import re
from pathlib import Path

import numpy as np

from handvar.atomic import OutputSet
from handvar.evaluation.claims import Claim, evaluate_claims
from handvar.evaluation.figures import (
    mean_error_figure,
    overlay_figure,
    r2_boxplot,
    sweep_figure,
    sweeps,
)
from handvar.evaluation.results import (
    Results,
    error_peaks,
    fmt,
    joint_iqrs,
    joint_medians,
    load_results,
    median,
    reference_curve,
)
from handvar.evaluation.store import damaged_trials

__all__ = ["write_report"]

_TITLE = "Tracking experiment: the paper's claims, measured"
_CLAIM_HEADER = ["paper", "claim of the paper", "what we measured", "holds?", "test"]
_STYLE = (
    "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
    "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #aaa;"
    "padding:4px 6px;vertical-align:top;font-size:90%}img{max-width:100%}</style>"
)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_").lower()


def _save_figure(outputs: OutputSet, fig, path: Path) -> None:
    outputs.add(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))


def _save_text(outputs: OutputSet, path: Path, text: str) -> None:
    outputs.add(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def check_store(store: str | os.PathLike) -> None:
    """Raise ValueError naming the first damaged trial of `store`, if any (design §13.3)."""
    damage = damaged_trials(store)
    if damage:
        more = f" and {len(damage) - 1} more" if len(damage) > 1 else ""
        raise ValueError(
            f"{store}: damaged {damage[0]}{more}; no report is drawn from it. "
            f"Run `handvar experiment --out {store}` to recompute"
        )


@dataclasses.dataclass(frozen=True)
class _Figure:
    """One figure of the report: its file name, caption and how to draw it."""

    name: str
    caption: str
    draw: object  # () -> matplotlib Figure


def _figures(store, results: Results) -> list[_Figure]:
    """Every figure of the report, in order: R̃² per predictor, sweeps, figures 4 and 6."""
    cfg = results.config
    out = []
    ref = results.index("none")
    for p, spec in enumerate(cfg.predictors):
        if p == ref:
            continue
        number = _FIGURE_NUMBER.get(spec.key)
        name = f"fig{number}_r2_{spec.key}.png" if number else f"r2_{_slug(spec.key)}.png"
        caption = f"R̃² (eq. 21) per joint of {spec.label}" + (
            f" (the paper's figure {number})" if number else ""
        )
        out.append(_Figure(name, caption, lambda key=spec.key: r2_boxplot(results, key)))
    for (base, arg), points in sweeps(results).items():
        if any(results.done[p].any() for _, p in points):
            out.append(
                _Figure(
                    f"sweep_{_slug(base)}_{_slug(arg)}.png",
                    f"{cfg.spec(base).label}: overall mean error and median R̃² against {arg}",
                    lambda base=base, arg=arg: sweep_figure(results, base, arg),
                )
            )
    peaks = error_peaks(reference_curve(results))
    out.append(
        _Figure(
            "fig4_mean_error.png",
            "Mean joint error over frames, averaged over the trials (the paper's figure 4); "
            f"dashed: the error peaks {', '.join(map(str, peaks))}",
            lambda: mean_error_figure(results, peaks=peaks),
        )
    )
    out.append(
        _Figure(
            "fig6_overlays.png",
            "Estimated models at the error peaks (the paper's figure 6); rows: no motion, "
            "decelerating, RVAR; the median trial of each cell",
            lambda: overlay_figure(store, results, frames=peaks),
        )
    )
    return out


def _intro(store, results: Results) -> list[str]:
    """The report's opening lines: the store, the protocol and the caveats."""
    cfg = results.config
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
    if cfg.mismatch:
        intro.append(_mismatch_text(cfg))
    if cfg.tracker:
        intro.append(
            "Tracker settings changed: " + ", ".join(f"{k}={v}" for k, v in cfg.tracker) + "."
        )
    return intro


def _mismatch_text(cfg) -> str:
    """One sentence: how the sequence departs from the tracker's model.

    The departures are those of docs/results/mismatch.md.
    """
    parts = [
        f"rendered with the {'skinned mesh' if cfg.sequence_model == 'mesh' else 'sphere-mesh'}",
        f"tracked with the {'skinned mesh' if cfg.tracker_model == 'mesh' else 'sphere-mesh'}",
    ]
    if (cfg.sequence_length, cfg.sequence_breadth) != (1.0, 1.0):
        parts.append(
            f"the rendering hand {cfg.sequence_length:g} × the tracker's length and "
            f"{cfg.sequence_breadth:g} × its breadth (errors are against the rendering "
            "hand's joints)"
        )
    if cfg.sequence_speed != 1.0:
        parts.append(f"the motion replayed {cfg.sequence_speed:g}× faster")
    if cfg.sequence_noise:
        parts.append(f"silhouettes corrupted at {cfg.sequence_noise:g} px")
    return "Model mismatch: " + "; ".join(parts) + "."


def _claim_rows(claims: list[Claim]) -> list[list[str]]:
    # the column is headed "paper": its cells drop the section's "paper " prefix
    return [
        [c.section.removeprefix("paper "), c.claim, c.measured, c.verdict, c.test] for c in claims
    ]


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
                fmt(results.overall_error(p)),
                fmt(median(joint_medians(r2))) if len(r2) else "-",
                fmt(median(joint_iqrs(r2))) if len(r2) else "-",
                fmt(float(it.mean()), 1) if it.size else "-",
                fmt(1000 * median(tm), 2) if np.isfinite(tm).any() else "-",
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


def _markdown(intro, claim_rows, summary, figures: list[tuple[str, str]]) -> str:
    """``report.md``: the intro, the claims, the predictors and the figures."""
    md = [f"# {_TITLE}", "", *intro, ""]
    md += ["## Claims", "", _md_table(_CLAIM_HEADER, claim_rows), ""]
    md += ["## Predictors", "", _md_table(_SUMMARY_HEADER, summary), ""]
    md += ["## Figures", ""]
    for name, caption in figures:
        md += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    return "\n".join(md)


def _html(intro, claim_rows, summary, figures: list[tuple[str, str]]) -> str:
    """``report.html``: the same as the Markdown, as one self-contained page."""
    page = [
        "<!DOCTYPE html>",
        '<html><head><meta charset="utf-8"><title>handvar experiment</title>',
        _STYLE,
        "</head><body>",
        f"<h1>{_TITLE}</h1>",
        *(f"<p>{html.escape(line).replace('`', '')}</p>" for line in intro),
        "<h2>Claims</h2>",
        _html_table(_CLAIM_HEADER, claim_rows),
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
    return "\n".join(page)


def write_report(
    store: str | os.PathLike,
    out: str | os.PathLike,
    *,
    progress: bool = False,
    figures: tuple[str, ...] | None = None,
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
    figures : tuple of str, keyword-only, optional
        Draw only the figures of these file names (``("fig4_mean_error.png",)``);
        all by default.

    Returns
    -------
    Path
        The Markdown report.
    """
    check_store(store)
    results = load_results(store)
    out = Path(out)
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    written: list[tuple[str, str]] = []  # (file, caption)
    try:
        with OutputSet() as outputs:
            for figure in _figures(store, results):
                if figures is not None and figure.name not in figures:
                    continue
                _save_figure(outputs, figure.draw(), out / figure.name)
                written.append((figure.name, figure.caption))
            intro = _intro(store, results)
            claim_rows = _claim_rows(evaluate_claims(results))
            summary = _summary_rows(results)
            _save_text(outputs, out / "report.md", _markdown(intro, claim_rows, summary, written))
            _save_text(outputs, out / "report.html", _html(intro, claim_rows, summary, written))
    except BaseException:
        if made:
            with contextlib.suppress(OSError):
                out.rmdir()
        raise
    if progress:
        for name, _ in written:
            print(out / name)
    return out / "report.md"
