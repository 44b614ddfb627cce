"""The claims of paper §4–6, each beside what an experiment store shows.

:func:`evaluate_claims` tests every claim on the measurements (:class:`Results`) and
states the exact test behind each verdict; a claim whose predictors are missing or
unfinished is undecided (``holds`` None). The paper §6 claims about the palm flip are
tested only on a ``flip`` sequence (at any speed or mismatch, docs/results/mismatch.md);
a trial has lost the hand when its mean joint error exceeds :data:`LOSS_MM` in some
frame.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from handvar.evaluation.results import (
    N_JOINTS,
    Results,
    fmt,
    joint_iqrs,
    joint_medians,
    median,
)

__all__ = ["LOSS_MM", "Claim", "evaluate_claims"]

#: A mean joint error above this (mm) -- more than a finger's breadth -- is a lost hand.
LOSS_MM = 20.0


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
    med = joint_medians(r.r2(p))
    stat = median(med)
    ref = r.index("none")
    return (
        f"median over joints of the per-joint median R̃² = {fmt(stat)} "
        f"({int(np.sum(med > 0))}/21 joints > 0; {_n(r, p)}); overall mean error "
        f"{fmt(r.overall_error(p))} mm vs {fmt(r.overall_error(ref))} mm without prediction",
        bool(stat > 0),
    )


def _claim_full_var(r: Results) -> tuple[str, bool]:
    p = r.index("full_var")
    med = joint_medians(r.r2(p))
    stat = median(med)
    return (
        f"median over joints of the per-joint median R̃² = {fmt(stat)} "
        f"({int(np.sum(med < 0))}/21 joints < 0; {_n(r, p)})",
        bool(stat < 0),
    )


def _claim_structured_joints(r: Results) -> tuple[str, bool]:
    p = r.index("structured_var")
    r2 = r.r2(p)
    palm = median(r2[:, 0])
    little = median(r2[:, 17:21].mean(axis=1)) if len(r2) else float("nan")
    others = median(joint_medians(r2)[1:17])
    return (
        f"joint 1: median R̃² = {fmt(palm)}; joints 18–21: median of the trial means = "
        f"{fmt(little)}; the other joints: median of medians = {fmt(others)} ({_n(r, p)})",
        bool(palm > 0 and little > 0),
    )


def _claim_structured_middle_tip(r: Results) -> tuple[str, bool]:
    p = r.index("structured_var")
    tip = median(r.r2(p)[:, 12])
    return f"joint 13: median R̃² = {fmt(tip)} ({_n(r, p)})", bool(tip < 0)


def _claim_structured_variance(r: Results) -> tuple[str, bool]:
    sv, d = r.index("structured_var"), r.index("decelerating")
    a, b = median(joint_iqrs(r.r2(sv))), median(joint_iqrs(r.r2(d)))
    return (
        f"median over joints of the IQR of R̃²: structured VAR {fmt(a)}, decelerating {fmt(b)}",
        bool(a > b),
    )


def _claim_rvar_half(r: Results) -> tuple[str, bool]:
    p = r.index("rvar")
    med = joint_medians(r.r2(p))
    k = int(np.sum((med >= 0.25) & (med <= 0.75)))
    return (
        f"{k}/21 joints with median R̃² in [0.25, 0.75]; median over joints "
        f"{fmt(median(med))} ({_n(r, p)})",
        k >= 11,
    )


def _claim_rvar_vs_decelerating(r: Results) -> tuple[str, bool]:
    a = joint_medians(r.r2(r.index("rvar")))
    b = joint_medians(r.r2(r.index("decelerating")))
    better = np.flatnonzero(a > b)
    worse = [str(j + 1) for j in range(N_JOINTS) if j not in set(better)]
    return (
        f"RVAR's median R̃² higher at {better.size}/21 joints"
        + (f" (not at joints {', '.join(worse)})" if worse else ""),
        better.size >= 11,
    )


def _claim_rvar_variance(r: Results) -> tuple[str, bool]:
    a = median(joint_iqrs(r.r2(r.index("rvar"))))
    b = median(joint_iqrs(r.r2(r.index("structured_var"))))
    return (
        f"median over joints of the IQR of R̃²: RVAR {fmt(a)}, structured VAR {fmt(b)}",
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
        + ", ".join(f"{k} {fmt(v)}" for k, v in overall.items())
        + f"; RVAR's curve is the lowest at {int(lowest.sum())}/{lowest.size} frames",
        bool(min(overall.values()) == overall[r.labels[rv]]),
    )


def _error_and_r2(r: Results, first: str, second: str, names: tuple[str, str]):
    """Overall mean errors of two predictors and the sentence comparing them."""
    i, j = r.index(first), r.index(second)
    a, b = r.overall_error(i), r.overall_error(j)
    text = (
        f"overall mean error: {names[0]} {fmt(a)} mm, {names[1]} {fmt(b)} mm; median "
        f"R̃²: {fmt(median(joint_medians(r.r2(i))))} vs "
        f"{fmt(median(joint_medians(r.r2(j))))}"
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
        "paper §4, fig. 2",
        "The decelerating predictor (ρ = 0.4) improves on tracking without prediction.",
        "median over the 21 joints of the per-joint median (over trials) R̃² (eq. 21) > 0",
        ("none", "decelerating"),
        _claim_decelerating,
    ),
    (
        "paper §4.2",
        "The full VAR (N = 150) tracks worse than no motion prediction.",
        "median over the 21 joints of the per-joint median R̃² < 0",
        ("none", "full_var"),
        _claim_full_var,
    ),
    (
        "paper §4.3, fig. 3",
        "The structured VAR (N = 30) drastically improves the palm base (joint 1) and "
        "the little finger (joints 18–21).",
        "median over trials of R̃² of joint 1 > 0 and median over trials of the mean R̃² "
        "of joints 18–21 > 0",
        ("none", "structured_var"),
        _claim_structured_joints,
    ),
    (
        "paper §4.3",
        "The structured VAR worsens the middle fingertip (joint 13).",
        "median over trials of R̃² of joint 13 < 0",
        ("none", "structured_var"),
        _claim_structured_middle_tip,
    ),
    (
        "paper §4.3",
        "The structured VAR increases the variance of the tracking performance compared "
        "with the decelerating predictor.",
        "median over joints of the interquartile range (over trials) of R̃²: structured "
        "VAR > decelerating",
        ("none", "structured_var", "decelerating"),
        _claim_structured_variance,
    ),
    (
        "paper §5, fig. 5",
        "RVAR (γ = 0.8, c = 8): R̃² around 0.5 for most joints.",
        "at least 11 of the 21 joints have a median R̃² in [0.25, 0.75]",
        ("none", "rvar"),
        _claim_rvar_half,
    ),
    (
        "paper §5",
        "RVAR performs better than the decelerating predictor (except the middle PIP, "
        "joint 12, and possibly the thumb, joints 3–5).",
        "RVAR's median R̃² exceeds the decelerating predictor's at at least 11 of 21 joints",
        ("none", "rvar", "decelerating"),
        _claim_rvar_vs_decelerating,
    ),
    (
        "paper §5",
        "RVAR inherits the low variance of the decelerating predictor: lower than the "
        "structured VAR's.",
        "median over joints of the interquartile range of R̃²: RVAR < structured VAR",
        ("none", "rvar", "structured_var"),
        _claim_rvar_variance,
    ),
    (
        "paper §5, fig. 4",
        "RVAR has the lowest mean error curve.",
        "RVAR's overall mean error (frames 1.. and finished trials) is the lowest of the "
        "paper's predictors in the store",
        ("none", "rvar"),
        _claim_rvar_lowest,
    ),
    (
        "paper §4 (ρ = 1)",
        "Tracking with a constant-velocity model is unstable; here: the constant-velocity "
        "Kalman filter (not in the paper) against the decelerating predictor.",
        "overall mean error: Kalman CV > decelerating",
        ("none", "kalman", "decelerating"),
        _claim_constant_velocity,
    ),
    (
        "paper §5, after eq. 27",
        "Relative interpolation of the changes is an alternative to eq. 26–27 (the "
        "paper gives no result); here: relative RVAR tracks at least as well as absolute.",
        "overall mean error: RVAR relative ≤ RVAR",
        ("none", "rvar_relative", "rvar"),
        _claim_relative,
    ),
)


def _worst(r: Results, key: str) -> tuple[float, float, int]:
    """(worst frame of the mean error curve, share of trials lost, trials) of `key`."""
    p = r.index(key)
    e = r.error[p][r.done[p]]
    lost = float(np.mean(np.nanmax(e, axis=1) > LOSS_MM)) if len(e) else float("nan")
    return float(np.nanmax(r.mean_error_curve(p))), lost, len(e)


def _flip_text(r: Results) -> tuple[str, float, float]:
    (a, la, n), (b, lb, _) = _worst(r, "rvar"), _worst(r, "decelerating")
    text = (
        f"worst frame of the mean error curve: RVAR {fmt(a)} mm, decelerating {fmt(b)} mm; "
        f"trials that lose the hand (> {LOSS_MM:g} mm in some frame): RVAR {100 * la:.0f}%, "
        f"decelerating {100 * lb:.0f}% ({n} trials)"
    )
    return text, a, b


def _claim_flip_follows(r: Results) -> tuple[str, bool]:
    text, a, b = _flip_text(r)
    return text, bool(a < LOSS_MM <= b)


def _claim_flip_error(r: Results) -> tuple[str, bool]:
    i, j = r.index("rvar"), r.index("decelerating")
    a, b = r.overall_error(i), r.overall_error(j)
    return f"overall mean error: RVAR {fmt(a)} mm, decelerating {fmt(b)} mm", bool(a < b)


_FLIP_CLAIMS: tuple[tuple[str, str, str, tuple[str, ...], Callable], ...] = (
    (
        "paper §6, fig. 8",
        "RVAR follows the palm flip where the decelerating predictor fails.",
        f"worst frame of the mean (over trials) error curve: RVAR < {LOSS_MM:g} mm ≤ decelerating",
        ("rvar", "decelerating"),
        _claim_flip_follows,
    ),
    (
        "paper §6",
        "Weaker form: RVAR tracks the palm flip better than the decelerating predictor.",
        "overall mean error on the flip: RVAR < decelerating",
        ("rvar", "decelerating"),
        _claim_flip_error,
    ),
)


def evaluate_claims(results: Results) -> list[Claim]:
    """Every claim of paper §4–6 tested on the store's measurements.

    Returns
    -------
    list of Claim
        In the paper's order; ``holds`` is None where a needed predictor is missing or
        has no finished trial, and for the paper §6 flip claims on another sequence.
    """
    out = []
    flip = results.config.sequence == "flip"
    for section, claim, test, needs, measure in _CLAIMS + _FLIP_CLAIMS:
        if measure in (_claim_flip_follows, _claim_flip_error) and not flip:
            out.append(Claim(section, claim, test, "not a flip sequence", None))
            continue
        reason = _missing(results, *needs)
        if reason is not None:
            out.append(Claim(section, claim, test, reason, None))
            continue
        measured, holds = measure(results)
        out.append(Claim(section, claim, test, measured, bool(holds)))
    return out
