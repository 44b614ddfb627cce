"""RVAR: the robust adaptive blend of structured VAR and constant velocity (paper §5).

x̂_{T+1}(i) = (1 − γ) x_T(i) + γ (α_i x̂^SV_{T+1}(i) + β_i x̂^D_{T+1}(i))      (eq. 26)

with α_i, β_i ≥ 0, α_i + β_i ≤ 1 minimising, per parameter i,

E_i = Σ_{t=T−c}^{T} 2^{−(T−t)} [x_t(i) − (α x̂^SV_t(i) + β x̂^D_t(i))]²       (eq. 27, 28)

over the predictions each predictor made for the last c + 1 frames.  The values are
taken with the origin at the latest observation x_T (so x̂⁰ = x_T = 0 in eq. 26), which
makes the predictor independent of where the parameters' zero is; see ``RVAR``'s Notes.
"""

from __future__ import annotations

import numpy as np

from handvar.params import hand_blocks
from handvar.predictors import _kernels
from handvar.predictors.base import Predictor, as_vector
from handvar.predictors.simple import Decelerating
from handvar.predictors.var import VAR
from handvar.validate import as_array, as_float, as_instance, as_int, one_of

__all__ = ["RVAR", "fit_trust_weights"]

_MODES = ("absolute", "relative")
_RANK_TOL = 1e-13  # relative rank tolerance of the 2-column design of eq. 27
_EPS = float(np.finfo(float).eps)


def _tie_tolerance(best, S):
    """How far above the minimum E* a cost still counts as a minimiser (rounding)."""
    return 1e-12 * best + 16.0 * _EPS * np.sqrt(best * S) + (16.0 * _EPS) ** 2 * S


def fit_trust_weights(target, a, b, weights):
    """Solve eq. 27 exactly: per column, weighted least squares over the triangle.

    Minimises ``E(α, β) = Σ_t w_t (target_t − α a_t − β b_t)²`` subject to α, β ≥ 0
    and α + β ≤ 1, independently for every column, and among the minimisers returns
    the one of smallest norm α² + β².

    E is a convex quadratic in two variables, so its minimum over the triangle lies
    on one of its faces: the unconstrained (interior) stationary point when that is
    feasible, else the minimum of one of the three edges (β = 0, α = 0, α + β = 1),
    each a one-variable least squares clipped to [0, 1], else a vertex.  Every
    candidate is scored by its residuals and the cheapest kept.  When the minimiser
    is not unique — both predictors made the same predictions (a = b: a whole
    segment of α + β minimises E), or one predicted zero — the candidates include
    the smallest-norm point of each such set: the minimum-norm interior solution
    (pseudo-inverse of the 2-column design, by a pivoted Gram–Schmidt QR with a
    relative rank tolerance), the edge midpoint (½, ½) and the origin.  Candidates
    whose cost is within rounding (``1e-12·E* + 16 ε √(E* S) + (16 ε)² S``, with E*
    the minimum, ε the machine epsilon and S = Σ w (|target| + |a| + |b|)²) of the
    minimum count as minimisers, so the tie is decided on the scale of the residual,
    and the one of smallest norm is returned.  Nothing is added to E: the result is
    its exact constrained minimum.

    The fit is a function of the three columns as given: shifting all three by the
    same constant changes it (eq. 27 is not origin-free), which is why
    :class:`RVAR` hands it values relative to the latest observation.

    Parameters
    ----------
    target, a, b : (n, d) array_like
        Observed values and the two predictors' predictions of them.
    weights : (n,) array_like
        Non-negative weights k_t (eq. 28).

    Returns
    -------
    alpha, beta : (d,) ndarray

    Examples
    --------
    >>> x = np.array([[1.0], [2.0]])
    >>> alpha, beta = fit_trust_weights(x, 2 * x, 2 * x, [1.0, 1.0])  # a = b: a tie
    >>> float(alpha[0]), float(beta[0])                                 # α + β = ½
    (0.25, 0.25)
    """
    x = as_array(target, "target", (None, None))
    n, d = x.shape
    a = as_array(a, "a", (n, d))
    b = as_array(b, "b", (n, d))
    w = as_array(weights, "weights", (n,))
    if np.any(w < 0):
        raise ValueError(f"weights: expected non-negative values; got {w.min()}")
    sw = np.sqrt(w)[:, None]
    X, A, B = sw * x, sw * a, sw * b
    zero, half, one = np.zeros(d), np.full(d, 0.5), np.ones(d)

    # Interior: pivoted Gram–Schmidt QR of [A B] (the longer column first), then the
    # full-rank solution and the minimum-norm solution of the rank-one part.
    swap = (B * B).sum(0) > (A * A).sum(0)
    P1 = np.where(swap, B, A)
    P2 = np.where(swap, A, B)
    r11 = np.sqrt((P1 * P1).sum(0))
    q1 = np.divide(P1, r11, out=np.zeros_like(P1), where=r11 > 0)
    r12 = (q1 * P2).sum(0)
    p = P2 - r12 * q1
    c = (q1 * p).sum(0)  # reorthogonalise once
    p -= c * q1
    r12 += c
    r22 = np.sqrt((p * p).sum(0))
    c1 = (q1 * X).sum(0)
    full = r22 > _RANK_TOL * np.hypot(r11, r12)
    u2 = np.divide((p * X).sum(0), r22 * r22, out=zero.copy(), where=full)
    u1 = np.divide(c1 - r12 * u2, r11, out=zero.copy(), where=full)
    norm2 = r11 * r11 + r12 * r12
    v1 = np.divide(r11 * c1, norm2, out=zero.copy(), where=norm2 > 0)  # rank one
    v2 = np.divide(r12 * c1, norm2, out=zero.copy(), where=norm2 > 0)
    in_a = [np.where(swap, u2, u1), np.where(swap, v2, v1)]
    in_b = [np.where(swap, u1, u2), np.where(swap, v1, v2)]

    def edge(col, rhs):
        nn = (col * col).sum(0)
        t = np.divide((col * rhs).sum(0), nn, out=zero.copy(), where=nn > 0)
        return np.clip(t, 0.0, 1.0)

    t_a, t_b = edge(A, X), edge(B, X)
    t_ab = np.where(((A - B) ** 2).sum(0) > 0, edge(A - B, X - B), 0.5)  # α = t, β = 1 − t
    alpha = np.stack([*in_a, t_a, zero, t_ab, half, zero, one, zero])
    beta = np.stack([*in_b, zero, t_b, 1.0 - t_ab, half, zero, zero, one])
    residual = X[None] - alpha[:, None] * A[None] - beta[:, None] * B[None]  # (9, n, d)
    cost = (residual * residual).sum(1)
    feasible = (alpha >= 0) & (beta >= 0) & (alpha + beta <= 1)
    feasible[0] &= full
    cost = np.where(feasible, cost, np.inf)
    best = cost.min(0)
    S = (w[:, None] * (np.abs(x) + np.abs(a) + np.abs(b)) ** 2).sum(0)
    tol = _tie_tolerance(best, S)
    norm = np.where(cost <= best + tol, alpha * alpha + beta * beta, np.inf)
    pick = np.argmin(norm, axis=0)
    cols = np.arange(d)
    return alpha[pick, cols], beta[pick, cols]


class RVAR:
    """The robust VAR predictor of §5 (eq. 26–28).

    Parameters
    ----------
    gamma : float, default 0.8
        γ of eq. 26: the upper bound on how far to trust the motion predictions.
    cutoff : int, default 8
        c of eq. 27: the weights are fitted on the last c + 1 frames.
    mode : {"absolute", "relative"}, default "absolute"
        ``"absolute"`` is eq. 26–27 as printed, with the origin of the parameters
        placed at the latest observation x_T (see Notes).  ``"relative"`` is the
        variant the paper mentions after eq. 27: each past frame's values are taken
        relative to the frame before it, i.e. eq. 27 fits x_t − x_{t−1} from
        x̂^SV_t − x_{t−1} and x̂^D_t − x_{t−1}.
    structured : VAR, optional
        The structured VAR; default ``VAR(order=1, memory=30, blocks=hand_blocks(),
        max_step=10.0)``, the paper's (§4.3), for the 26 hand parameters.
    decelerating : Decelerating, optional
        Default ``Decelerating(rho=1.0)``, constant velocity (§5).

    Notes
    -----
    Eq. 26–27 as printed depend on where the parameters' origin is: adding c to
    every value adds c (1 − α − β) to each residual of eq. 27, so the fitted α, β —
    and the prediction, unless α + β = 1 — change with c.  The paper does not fix
    the origin (a joint angle's zero and the camera's position are conventions), so
    the absolute mode places it at the latest observation x_T, which is also the
    no-motion prediction x̂⁰ of eq. 26.  In those coordinates eq. 27 is fitted on
    x_t − x_T, x̂^SV_t − x_T and x̂^D_t − x_T, and eq. 26 reads

        x̂_{T+1} = x_T + γ (α (x̂^SV_{T+1} − x_T) + β (x̂^D_{T+1} − x_T)),

    which is eq. 26 itself with x̂⁰ = x_T = 0: the paper's estimator, unchanged
    except that its answer no longer depends on an arbitrary origin.  Both modes
    predict by this formula; they differ in the reference of the fit: one common
    reference x_T (absolute) or each frame's predecessor x_{t−1} (relative).  Every
    prediction moves with a constant offset of the input, x + c ↦ x̂ + c, to
    rounding.

    α, β are eq. 27's exact constrained minimum (:func:`fit_trust_weights`); until a
    past prediction can be scored (the first two frames), α = β = ½.  ``alpha`` and
    ``beta`` hold the weights used by the next ``predict``.
    """

    def __init__(
        self,
        gamma: float = 0.8,
        cutoff: int = 8,
        mode: str = "absolute",
        *,
        structured: Predictor | None = None,
        decelerating: Predictor | None = None,
    ) -> None:
        self.gamma = as_float(gamma, "gamma", minimum=0.0, maximum=1.0)
        self.cutoff = as_int(cutoff, "cutoff", minimum=0)
        self.mode = one_of(mode, _MODES, "mode")
        if structured is None:
            structured = VAR(order=1, memory=30, blocks=hand_blocks())
        if decelerating is None:
            decelerating = Decelerating(rho=1.0)
        what = "a predictor (update, predict, reset)"
        self.structured = as_instance(structured, Predictor, "structured", what=what)
        self.decelerating = as_instance(decelerating, Predictor, "decelerating", what=what)
        # k_t of eq. 28 for t = T - c, ..., T (oldest first).
        self._weights = 0.5 ** np.arange(self.cutoff, -1, -1, dtype=float)
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
        self._origin: np.ndarray | None = None  # subtracted from _hist before the fit
        self.alpha: np.ndarray | None = None
        self.beta: np.ndarray | None = None

    def update(self, x) -> None:
        """Score the pending predictions against `x`, update both predictors, refit α, β."""
        x = as_vector(x, "x", None if self._x is None else self._x.size)
        if self._hist is None:
            self._hist = np.zeros((3, self.cutoff + 1, x.size))
            self._origin = np.zeros(x.size)
            self.alpha = np.full(x.size, 0.5)
            self.beta = np.full(x.size, 0.5)
        if self._pending is not None:
            sv, dec = self._pending
            slot = self._hist[:, self._head]
            if self.mode == "relative":  # relative to x_{t-1}, the frame before
                np.subtract(x, self._x, out=slot[0])
                np.subtract(sv, self._x, out=slot[1])
                np.subtract(dec, self._x, out=slot[2])
            else:  # as observed; the origin x_T is subtracted at the fit
                slot[0], slot[1], slot[2] = x, sv, dec
            self._head = (self._head + 1) % (self.cutoff + 1)
            self._n = min(self._n + 1, self.cutoff + 1)
        self._x = x.copy()
        if self.mode == "absolute":
            self._origin[:] = x
        self.structured.update(x)
        self.decelerating.update(x)
        self._pending = (self.structured.predict(), self.decelerating.predict())
        if self._n:
            # The ring's rows by age: the newest (weight 1) was written last.
            ages = (self._head - 1 - np.arange(self._n)) % (self.cutoff + 1)
            _kernels.trust_weights(
                self._hist[:, ages], self._weights[::-1][: self._n], self._origin,
                self.alpha, self.beta,
            )  # fmt: skip

    def predict(self) -> np.ndarray:
        """x̂_{T+1} = x_T + γ (α (x̂^SV − x_T) + β (x̂^D − x_T)): eq. 26 with origin x_T."""
        if self._pending is None:
            raise RuntimeError("predict() needs at least one update()")
        sv, dec = self._pending
        x = self._x
        return x + self.gamma * (self.alpha * (sv - x) + self.beta * (dec - x))  # eq. 26

    def __repr__(self) -> str:
        return f"RVAR(gamma={self.gamma}, cutoff={self.cutoff}, mode={self.mode!r})"
