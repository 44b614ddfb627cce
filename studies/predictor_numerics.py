"""The predictors' numerics: origin dependence, eq. 27's optimum, the online VAR against lstsq.

Run:  .venv/bin/python studies/predictor_numerics.py

Prints, on the shipped htrack recording (examples/data/htrack-fingerfist.txt, converted
to millimetres and degrees as ``handvar predict --layout htrack`` does):

1. how far each predictor's predictions move when a constant is added to every
   parameter (x + c should give x̂ + c): max |x̂(X + c) − c − x̂(X)| for c = 100, 1e9,
   1e12, beside the predictor's own open-loop RMSE;
2. how many of ``fit_trust_weights``' per-parameter eq. 27 fits (the triangle, as
   RVAR's relative mode uses it) end more than 1% above the exact constrained
   minimum, on RVAR's windows of the recording in its own coordinates and with the
   origin at the latest frame; the exact minimum comes from a separate solve of every
   face of the triangle by pseudo-inverse;
3. the online VAR's largest coefficient deviation from numpy.linalg.lstsq of the same
   window, on real motion followed by a stretch where every parameter is frozen, and
   on a motion whose scale drops from 1e6 to 1e-3.

Only public names are used, so the same script measures any version of the package.
"""

from __future__ import annotations

import numpy as np

from handvar.data import example_path
from handvar.predictors import (
    RVAR,
    VAR,
    Decelerating,
    fit_trust_weights,
    hand_blocks,
    one_step_predictions,
    second_differences,
)
from handvar.synth.motion import htrack_to_handvar

DATA = example_path("htrack")
EPS = np.finfo(float).eps


class LstsqVAR:
    """The full VAR(1) of eq. 14 refitted by numpy.linalg.lstsq every frame (eq. 5, 10° step).

    It shows how much of a shift under an offset the rounding of the input alone
    causes: x + c is stored to ε·|c|, so the second differences carry that noise.
    """

    def __init__(self, memory: int) -> None:
        self.memory = memory
        self.reset()

    def reset(self) -> None:
        self.X: list[np.ndarray] = []

    def update(self, x) -> None:
        self.X = [*self.X[-(self.memory + 2) :], np.asarray(x, dtype=float)]

    def predict(self) -> np.ndarray:
        X = np.array(self.X)
        if len(X) < 2:
            return X[-1].copy()
        y = second_differences(X)
        y_hat = np.zeros(X.shape[1])
        if len(y) - 1 >= X.shape[1]:
            coef, *_ = np.linalg.lstsq(y[:-1], y[1:], rcond=None)
            y_hat = y[-1] @ coef
        return X[-1] + np.clip(y_hat + X[-1] - X[-2], -10.0, 10.0)


def offsets(X: np.ndarray) -> None:
    print("1. prediction shift under a constant offset c (max over frames and parameters)")
    print(f"   {'predictor':<22}{'RMSE':>9}{'c = 100':>12}{'c = 1e9':>12}{'c = 1e12':>12}")
    cases = [
        ("RVAR absolute", lambda: RVAR(mode="absolute")),
        ("RVAR relative", lambda: RVAR(mode="relative")),
        ("VAR full (N = 150)", lambda: VAR()),
        ("VAR structured", lambda: VAR(memory=30, blocks=hand_blocks())),
        ("lstsq refit, full", lambda: LstsqVAR(memory=150)),
    ]
    for name, make in cases:
        base = one_step_predictions(make(), X)
        rmse = np.sqrt(np.nanmean((base[1:] - X[1:]) ** 2))
        shifts = []
        for c in (100.0, 1e9, 1e12):
            moved = one_step_predictions(make(), X + c) - c
            shifts.append(np.nanmax(np.abs(moved - base)))
        print(f"   {name:<22}{rmse:>9.4f}" + "".join(f"{s:>12.3g}" for s in shifts))


def _exact_minimum(x, a, b, w):
    """Min of Σ w (x − α a − β b)² over α, β ≥ 0, α + β ≤ 1, every face solved apart.

    x, a, b : (N, n); w : (n,).  Returns (N,) minima.
    """
    sw = np.sqrt(w)
    X, A, B = x * sw, a * sw, b * sw

    def cost(al, be):
        r = X - al[:, None] * A - be[:, None] * B
        return (r * r).sum(1)

    best = np.full(len(x), np.inf)
    # Interior: the minimum-norm unconstrained minimiser (batched SVD pseudo-inverse).
    M = np.stack([A, B], axis=2)  # (N, n, 2)
    sol = np.einsum("kij,kj->ki", np.linalg.pinv(M), X)
    ok = (sol[:, 0] >= 0) & (sol[:, 1] >= 0) & (sol.sum(1) <= 1)
    best = np.where(ok, cost(sol[:, 0], sol[:, 1]), best)
    zero = np.zeros(len(x))
    # Edges β = 0, α = 0, α + β = 1, each a clipped one-variable least squares.
    for col, rhs, edge in ((A, X, 0), (B, X, 1), (A - B, X - B, 2)):
        nn = (col * col).sum(1)
        t = np.clip(np.divide((col * rhs).sum(1), nn, out=zero.copy(), where=nn > 0), 0, 1)
        al, be = [(t, zero), (zero, t), (t, 1 - t)][edge]
        best = np.minimum(best, cost(al, be))
    return best


def trust_fits(X: np.ndarray, cutoff: int = 8) -> None:
    sv = one_step_predictions(VAR(order=1, memory=30, blocks=hand_blocks()), X)
    dec = one_step_predictions(Decelerating(rho=1.0), X)
    T_all = len(X)
    w = 0.5 ** np.arange(cutoff, -1, -1.0)  # eq. 28, oldest first
    print("2. eq. 27 fits more than 1% above the exact constrained minimum (RVAR windows)")
    for label, ref in (("as printed (origin of the recording)", False), ("origin at x_T", True)):
        above, total, worst = 0, 0, 0.0
        groups = np.zeros(4)
        for T in range(cutoff + 1, T_all):
            ts = np.arange(T - cutoff, T + 1)
            o = X[T] if ref else 0.0
            x, a, b = X[ts] - o, sv[ts] - o, dec[ts] - o  # (n, d)
            alpha, beta = fit_trust_weights(x, a, b, w)
            r = x - alpha * a - beta * b
            ours = (w[:, None] * r * r).sum(0)
            exact = _exact_minimum(x.T, a.T, b.T, w)
            S = (w[:, None] * (np.abs(x) + np.abs(a) + np.abs(b)) ** 2).sum(0)
            slack = 0.01 * exact + 16 * EPS * np.sqrt(exact * S) + (16 * EPS) ** 2 * S
            bad = ours > exact + slack
            above += int(bad.sum())
            total += bad.size
            rel = (ours - exact) / np.maximum(exact, np.finfo(float).tiny)
            worst = max(worst, float(np.max(np.where(bad, rel, 0.0))))
            groups += [bad[:3].sum(), bad[3:6].sum(), bad[6:11].sum(), bad[11:].sum()]
        print(
            f"   {label:<38}{100 * above / total:6.2f}% of {total} fits, worst "
            f"+{100 * worst:.0f}%  (translation {groups[0]:.0f}, rotation {groups[1]:.0f}, "
            f"abduction {groups[2]:.0f}, flexion {groups[3]:.0f})"
        )


def _lstsq_coefs(X, order, memory):
    """A_1 … A_p (statsmodels' layout) by lstsq on the VAR's window, or None."""
    y = second_differences(X)
    n_eq = min(len(y) - order, memory)
    d = X.shape[1]
    if n_eq < d * order:
        return None
    rows = range(len(y) - n_eq, len(y))
    W = np.array([np.concatenate([y[t - lag] for lag in range(1, order + 1)]) for t in rows])
    coef, *_ = np.linalg.lstsq(W, y[len(y) - n_eq :], rcond=None)
    return coef.T.reshape(d, order, d).transpose(1, 0, 2)


def coefficient_drift(name: str, X: np.ndarray, spans: dict[str, slice], memory: int = 150):
    var = VAR(order=1, memory=memory, max_step=None)
    dev = np.zeros(len(X))
    pred = np.zeros(len(X))
    for t, x in enumerate(X):
        var.update(x)
        ref = _lstsq_coefs(X[: t + 1], 1, memory)
        if ref is None:
            continue
        dev[t] = np.max(np.abs(var.coefs - ref))
        y_T = X[t] - 2.0 * X[t - 1] + X[t - 2]
        x_hat = X[t] + (X[t] - X[t - 1]) + ref[0] @ y_T  # eq. 5 with the lstsq fit
        pred[t] = np.max(np.abs(var.predict() - x_hat))
    print(f"   {name}")
    for label, span in spans.items():
        print(
            f"     {label:<44} max |A − A_lstsq| = {dev[span].max():10.3g}   "
            f"max |x̂ − x̂_lstsq| = {pred[span].max():10.3g}"
        )


def main() -> None:
    X = htrack_to_handvar(np.loadtxt(DATA))
    print(f"htrack recording: {X.shape[0]} frames, {X.shape[1]} parameters (mm, degrees)\n")
    offsets(X)
    print()
    trust_fits(X)
    print()
    print("3. the online full VAR (order 1, memory 150) against lstsq of its window")
    motion = X[:400]
    frozen = np.concatenate([motion, np.repeat(motion[-1:], 300, axis=0), X[400:700]])
    coefficient_drift(
        "real motion 400 frames, every parameter frozen 300 frames, motion 300 frames",
        frozen,
        {
            "during the frozen stretch": slice(400, 700),
            "after the frozen stretch": slice(700, 1000),
        },
    )
    rng = np.random.default_rng(0)
    walk = np.cumsum(rng.normal(size=(600, 26)), axis=0)
    drop = np.concatenate([1e6 * walk[:300], 1e-3 * (walk[300:] - walk[300])])
    coefficient_drift(
        "random walk at scale 1e6 for 300 frames, then at scale 1e-3",
        drop,
        {
            "window straddling the drop": slice(300, 455),
            "after the large rows have left the window": slice(455, 600),
        },
    )


if __name__ == "__main__":
    main()
