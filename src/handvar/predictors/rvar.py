"""RVAR: the robust adaptive blend of structured VAR and constant velocity (paper §5).

x̂_{T+1}(i) = (1 − γ) x_T(i) + γ (α_i x̂^SV_{T+1}(i) + β_i x̂^D_{T+1}(i))      (eq. 26)

with α_i, β_i ≥ 0, α_i + β_i ≤ 1 minimising, per parameter i,

E_i = Σ_{t=T−c}^{T} 2^{−(T−t)} [x_t(i) − (α x̂^SV_t(i) + β x̂^D_t(i))]²       (eq. 27, 28)

over the predictions each predictor made for the last c + 1 frames.  The absolute mode
fits eq. 27 on its edge α + β = 1, the one part of the triangle on which eq. 27 does
not depend on where the parameters' zero is; see ``RVAR``'s Notes.
"""

from __future__ import annotations

import numpy as np

from handvar.params import hand_blocks
from handvar.predictors import _kernels
from handvar.predictors.base import Predictor, as_vector
from handvar.predictors.simple import Decelerating
from handvar.predictors.var import VAR
from handvar.validate import as_array, as_float, as_instance, as_int, one_of

__all__ = ["RVAR", "fit_affine_weights", "fit_trust_weights"]

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
    same constant changes it (eq. 27 is not origin-free), which is why :class:`RVAR`
    hands it changes relative to the frame before (``mode="relative"``) and fits the
    absolute mode with :func:`fit_affine_weights` instead.

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


def fit_affine_weights(target, a, b, weights):
    """Solve eq. 27 exactly on its edge α + β = 1: a weighted least squares in α.

    Minimises ``E(α) = Σ_t w_t (target_t − α a_t − (1 − α) b_t)²
    = Σ_t w_t ((target_t − b_t) − α (a_t − b_t))²`` over α ∈ [0, 1], independently for
    every column.  E is a convex parabola in α, so its minimum over [0, 1] is the
    unconstrained minimiser ``Σ w (a − b)(target − b) / Σ w (a − b)²`` clipped to
    [0, 1] — exact, nothing added to E.  When the minimiser is not unique (a = b, to
    rounding: the cost at α = ½ is within ``1e-12·E* + 16 ε √(E* S) + (16 ε)² S`` of
    the minimum E*, with S = Σ w (|target − b| + |a − b|)²), the weights of smallest
    norm α² + β², α = β = ½, are returned.

    Only the differences target − b and a − b enter, so shifting all three columns by
    the same constant leaves α unchanged (to rounding): on this edge eq. 27 is
    origin-free.

    Parameters
    ----------
    target, a, b : (n, d) array_like
        Observed values and the two predictors' predictions of them.
    weights : (n,) array_like
        Non-negative weights k_t (eq. 28).

    Returns
    -------
    alpha, beta : (d,) ndarray
        β = 1 − α.

    Examples
    --------
    >>> x = np.array([[1.0], [2.0]])
    >>> alpha, beta = fit_affine_weights(x, x + 3, x - 1, [1.0, 1.0])  # x = ¼ a + ¾ b
    >>> float(alpha[0]), float(beta[0])
    (0.25, 0.75)
    >>> alpha, beta = fit_affine_weights(x + 1e6, x + 1e6 + 3, x + 1e6 - 1, [1.0, 1.0])
    >>> float(alpha[0])                                                # the same α
    0.25
    """
    x = as_array(target, "target", (None, None))
    n, d = x.shape
    a = as_array(a, "a", (n, d))
    b = as_array(b, "b", (n, d))
    w = as_array(weights, "weights", (n,))
    if np.any(w < 0):
        raise ValueError(f"weights: expected non-negative values; got {w.min()}")
    D, R = a - b, x - b  # the residual of eq. 27 on the edge is R − α D
    s_dd = (w[:, None] * D * D).sum(0)
    s_dx = (w[:, None] * D * R).sum(0)
    t = np.divide(s_dx, s_dd, out=np.full(d, 0.5), where=s_dd > 0)
    t = np.clip(t, 0.0, 1.0)

    def cost(al):
        r = R - al * D
        return (w[:, None] * r * r).sum(0)

    f_t, f_half = cost(t), cost(np.full(d, 0.5))
    best = np.minimum(f_t, f_half)
    S = (w[:, None] * (np.abs(R) + np.abs(D)) ** 2).sum(0)
    alpha = np.where(f_half <= best + _tie_tolerance(best, S), 0.5, t)
    return alpha, 1.0 - alpha


class RVAR:
    """The robust VAR predictor of paper §5 (eq. 26–28).

    Parameters
    ----------
    gamma : float, default 0.8
        γ of eq. 26: the upper bound on how far to trust the motion predictions.
    cutoff : int, default 8
        c of eq. 27: the weights are fitted on the last c + 1 frames.
    mode : {"absolute", "relative"}, default "absolute"
        ``"absolute"`` is eq. 26–27 with α + β = 1: eq. 27 fits the positions
        x_t from x̂^SV_t and x̂^D_t on the edge of its triangle that does not depend
        on the parameters' origin (see Notes).  ``"relative"`` is the variant the
        paper mentions after eq. 27: each past frame's values are taken relative to
        the frame before it, i.e. eq. 27 fits x_t − x_{t−1} from x̂^SV_t − x_{t−1} and
        x̂^D_t − x_{t−1} over the whole triangle α, β ≥ 0, α + β ≤ 1.
    structured : VAR, optional
        The structured VAR; default ``VAR(order=1, memory=30, blocks=hand_blocks(),
        max_step=10.0)``, the paper's (paper §4.3), for the 26 hand parameters.
    decelerating : Decelerating, optional
        Default ``Decelerating(rho=1.0)``, constant velocity (paper §5).

    Notes
    -----
    Eq. 26–27 as printed depend on where the parameters' origin is: adding c to
    every value adds c (1 − α − β) to each residual of eq. 27, so the fitted α, β —
    and the prediction, unless α + β = 1 — change with c.  The paper does not fix
    the origin (a joint angle's zero and the camera's position are conventions).
    When the parameters are far from their zero compared with how much they move —
    the palm's position, hundreds of millimetres from the camera, is — the
    c (1 − α − β) term dominates eq. 27 and its minimum lies on the edge
    α + β = 1; there, and only there, eq. 27 is origin-free.  The absolute mode
    therefore fits eq. 27 on that edge for every parameter,

        E_i(α) = Σ_t k_t [x_t(i) − (α x̂^SV_t(i) + (1 − α) x̂^D_t(i))]²,  α ∈ [0, 1],

    (:func:`fit_affine_weights`, exact) and predicts by eq. 26 with β = 1 − α:
    an affine combination of the two predictions, pulled towards x̂⁰ = x_T by
    1 − γ.  Each frame t is scored against its own x_t only, never against a later
    frame.  The relative mode fits the whole triangle (:func:`fit_trust_weights`,
    exact) on changes relative to each frame's predecessor, which are origin-free
    by construction.  Both modes predict x̂_{T+1} = x_T + γ (α (x̂^SV_{T+1} − x_T) +
    β (x̂^D_{T+1} − x_T)), eq. 26 rearranged, and every prediction moves with a
    constant offset of the input, x + c ↦ x̂ + c, to rounding.  The relative mode is
    eq. 26 with the no-motion prediction x_{t−1} of each frame taking the weight
    1 − α − β that the printed fit gives to the origin; in the paper's closed-loop
    experiment it tracks better than the absolute mode (figures in design §6).

    Until a past prediction can be scored (the first two frames), α = β = ½.
    ``alpha`` and ``beta`` hold the weights used by the next ``predict``.
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
            if self.mode == "relative":  # relative to x_{t-1}, the frame before
                np.subtract(x, self._x, out=slot[0])
                np.subtract(sv, self._x, out=slot[1])
                np.subtract(dec, self._x, out=slot[2])
            else:  # as observed
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
            fit = _kernels.affine_weights if self.mode == "absolute" else _kernels.trust_weights
            fit(self._hist[:, ages], self._weights[::-1][: self._n], self.alpha, self.beta)

    def predict(self) -> np.ndarray:
        """x̂_{T+1} = x_T + γ (α (x̂^SV − x_T) + β (x̂^D − x_T)): eq. 26 rearranged."""
        if self._pending is None:
            raise RuntimeError("predict() needs at least one update()")
        sv, dec = self._pending
        x = self._x
        return x + self.gamma * (self.alpha * (sv - x) + self.beta * (dec - x))  # eq. 26

    def __repr__(self) -> str:
        return f"RVAR(gamma={self.gamma}, cutoff={self.cutoff}, mode={self.mode!r})"
