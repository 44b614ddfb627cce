"""RVAR: the robust adaptive blend of structured VAR and constant velocity (paper §5).

x̂_{T+1}(i) = (1 − γ) x_T(i) + γ (α_i x̂^SV_{T+1}(i) + β_i x̂^D_{T+1}(i))      (eq. 26)

with α_i, β_i ≥ 0, α_i + β_i ≤ 1 minimising, per parameter i,

E_i = Σ_{t=T−c}^{T} 2^{−(T−t)} [x_t(i) − (α x̂^SV_t(i) + β x̂^D_t(i))]²       (eq. 27, 28)

over the predictions each predictor made for the last c + 1 frames.
"""

from __future__ import annotations

import numpy as np

from handvar.params import hand_blocks
from handvar.predictors import _kernels
from handvar.predictors.base import as_vector
from handvar.predictors.simple import Decelerating
from handvar.predictors.var import VAR

__all__ = ["RVAR", "fit_trust_weights"]

_MODES = ("absolute", "relative")


def fit_trust_weights(target, a, b, weights, *, ridge: float = 1e-8):
    """Solve eq. 27 exactly: per column, weighted least squares over the triangle.

    Minimises ``Σ_t w_t (target_t − α a_t − β b_t)² + ε (α² + β²)`` subject to
    α, β ≥ 0 and α + β ≤ 1, independently for every column.  The vanishing ridge
    ε = `ridge` · (Σ w a² + Σ w b²) / 2 only decides between weights that fit
    equally well — in the first frames both predictors make the same prediction
    and eq. 27 alone has a whole segment of minimisers — by taking the smallest.

    The objective is a convex quadratic in two variables, so its minimum over the
    triangle is the unconstrained minimum when that is feasible, and otherwise the
    minimum over the three edges, each a one-variable problem solved by clipping.
    The unconstrained minimum is found by a Gram–Schmidt QR of the weighted design
    (not the normal equations: in the absolute mode a ≈ b ≈ target and the normal
    equations would square an already large condition number).  All four candidates
    are scored from their residuals and the best is kept.

    Parameters
    ----------
    target, a, b : (n, d) array_like
        Observed values and the two predictors' predictions of them.
    weights : (n,) array_like
        Non-negative weights k_t (eq. 28).
    ridge : float, default 1e-8
        Relative size of the tie-breaking ridge ε.

    Returns
    -------
    alpha, beta : (d,) ndarray
    """
    x = np.asarray(target, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    w = np.asarray(weights, dtype=float)[:, None]
    sw = np.sqrt(w)
    S_aa = (w * a * a).sum(0)
    S_bb = (w * b * b).sum(0)
    eps = ridge * 0.5 * (S_aa + S_bb) + np.finfo(float).tiny
    root = np.sqrt(eps)
    zero = np.zeros_like(root)

    # Unconstrained minimum: QR (modified Gram–Schmidt) of the design augmented
    # with the ridge rows, [√w a, √w b; √ε, 0; 0, √ε] against [√w x; 0; 0].
    A = np.concatenate([sw * a, root[None], zero[None]])
    B = np.concatenate([sw * b, zero[None], root[None]])
    Xa = np.concatenate([sw * x, zero[None], zero[None]])
    r11 = np.sqrt((A * A).sum(0))
    q1 = A / r11
    r12 = (q1 * B).sum(0)
    B_perp = B - r12 * q1
    r22 = np.sqrt((B_perp * B_perp).sum(0))
    q2 = B_perp / r22
    beta_in = (q2 * Xa).sum(0) / r22
    alpha_in = ((q1 * Xa).sum(0) - r12 * beta_in) / r11

    # Edges β = 0, α = 0 and α + β = 1 (α = t, β = 1 − t), each clipped to [0, 1].
    d_ab = a - b
    alpha_edge = np.clip((w * a * x).sum(0) / (S_aa + eps), 0.0, 1.0)
    beta_edge = np.clip((w * b * x).sum(0) / (S_bb + eps), 0.0, 1.0)
    t = (w * d_ab * (x - b)).sum(0) + eps
    t = np.clip(t / ((w * d_ab * d_ab).sum(0) + 2.0 * eps), 0.0, 1.0)

    alpha = np.stack([alpha_in, alpha_edge, zero, t])
    beta = np.stack([beta_in, zero, beta_edge, 1.0 - t])
    residual = x[None] - alpha[:, None] * a[None] - beta[:, None] * b[None]  # (4, n, d)
    cost = (w[None] * residual * residual).sum(1) + eps * (alpha * alpha + beta * beta)
    feasible = (alpha_in >= 0) & (beta_in >= 0) & (alpha_in + beta_in <= 1)
    cost[0] = np.where(feasible, cost[0], np.inf)
    best = np.argmin(cost, axis=0)
    cols = np.arange(x.shape[1])
    return alpha[best, cols], beta[best, cols]


class RVAR:
    """The robust VAR predictor of §5 (eq. 26–28).

    Parameters
    ----------
    gamma : float, default 0.8
        γ of eq. 26: the upper bound on how far to trust the motion predictions.
    cutoff : int, default 8
        c of eq. 27: the weights are fitted on the last c + 1 frames.
    mode : {"absolute", "relative"}, default "absolute"
        ``"absolute"`` is eq. 26–27 as printed.  ``"relative"`` is the variant the
        paper mentions after eq. 27: the changes relative to the previous frame are
        blended, x̂ = x_T + γ(α (x̂^SV − x_T) + β (x̂^D − x_T)), and eq. 27 fits
        x_t − x_{t−1} from x̂^SV_t − x_{t−1} and x̂^D_t − x_{t−1}.
    structured : VAR, optional
        The structured VAR; default ``VAR(order=1, memory=30, blocks=hand_blocks(),
        max_step=10.0)``, the paper's (§4.3), for the 26 hand parameters.
    decelerating : Decelerating, optional
        Default ``Decelerating(rho=1.0)``, constant velocity (§5).

    Notes
    -----
    Until a past prediction can be scored (the first two frames), α = β = ½.
    ``alpha`` and ``beta`` hold the weights used by the next ``predict``.
    """

    def __init__(
        self,
        gamma: float = 0.8,
        cutoff: int = 8,
        mode: str = "absolute",
        *,
        structured: VAR | None = None,
        decelerating: Decelerating | None = None,
    ) -> None:
        gamma = float(gamma)
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma: expected a number in [0, 1]; got {gamma}")
        if isinstance(cutoff, bool) or not isinstance(cutoff, int | np.integer) or cutoff < 0:
            raise ValueError(f"cutoff: expected an integer >= 0; got {cutoff!r}")
        if mode not in _MODES:
            raise ValueError(f"mode: expected one of {', '.join(_MODES)}; got {mode!r}")
        self.gamma = gamma
        self.cutoff = int(cutoff)
        self.mode = mode
        self.structured = structured or VAR(order=1, memory=30, blocks=hand_blocks())
        self.decelerating = decelerating or Decelerating(rho=1.0)
        # k_t of eq. 28 for t = T - c, ..., T (oldest first).
        self._weights = 0.5 ** np.arange(self.cutoff, -1, -1, dtype=float)
        self._ridge = 1e-8  # the tie-breaking ridge of fit_trust_weights
        self.reset()

    def reset(self) -> None:
        """Forget every frame, including the sub-predictors' and the past predictions."""
        self.structured.reset()
        self.decelerating.reset()
        self._x: np.ndarray | None = None
        self._pending: tuple[np.ndarray, np.ndarray] | None = None
        self._n = 0  # scored past predictions held (at most c + 1)
        self._head = 0  # ring position of the next scored prediction
        self._hist: np.ndarray | None = None  # (3, c + 1, d): target, SV, D
        self.alpha: np.ndarray | None = None
        self.beta: np.ndarray | None = None

    def update(self, x) -> None:
        """Score the pending predictions against `x`, update both predictors, refit α, β."""
        x = as_vector(x, "x", None if self._x is None else self._x.size)
        if self._hist is None:
            self._hist = np.zeros((3, self.cutoff + 1, x.size))
            self.alpha = np.full(x.size, 0.5)
            self.beta = np.full(x.size, 0.5)
        if self._pending is not None:
            sv, dec = self._pending
            slot = self._hist[:, self._head]
            if self.mode == "relative":
                np.subtract(x, self._x, out=slot[0])
                np.subtract(sv, self._x, out=slot[1])
                np.subtract(dec, self._x, out=slot[2])
            else:
                slot[0], slot[1], slot[2] = x, sv, dec
            self._head = (self._head + 1) % (self.cutoff + 1)
            self._n = min(self._n + 1, self.cutoff + 1)
        self._x = x.copy()
        self.structured.update(x)
        self.decelerating.update(x)
        self._pending = (self.structured.predict(), self.decelerating.predict())
        if self._n:
            # The ring's rows by age: the newest (weight 1) was written last.
            ages = (self._head - 1 - np.arange(self._n)) % (self.cutoff + 1)
            _kernels.trust_weights(
                self._hist[:, ages], self._weights[::-1][: self._n], self._ridge,
                self.alpha, self.beta,
            )  # fmt: skip

    def predict(self) -> np.ndarray:
        """x̂_{T+1} by eq. 26 (or its relative form)."""
        if self._pending is None:
            raise RuntimeError("predict() needs at least one update()")
        sv, dec = self._pending
        g = self.gamma
        if self.mode == "relative":
            return self._x + g * (self.alpha * (sv - self._x) + self.beta * (dec - self._x))
        return (1.0 - g) * self._x + g * (self.alpha * sv + self.beta * dec)  # eq. 26

    def __repr__(self) -> str:
        return f"RVAR(gamma={self.gamma}, cutoff={self.cutoff}, mode={self.mode!r})"
