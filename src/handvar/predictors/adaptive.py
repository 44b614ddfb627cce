"""The adaptive bank: a convex combination of simple predictors fitted online (design §16).

A bank of M cheap one-step predictors (the experts) runs on every coordinate: no
motion (eq. 16), decelerating (eq. 22) at ρ = 0.2, 0.4, 0.6 and constant velocity
(ρ = 1), the constant-velocity Kalman filter at three noise ratios (the default
one of :class:`~handvar.predictors.KalmanCV` and two smoother ones), the One Euro
filter, two autoregressions fitted online per coordinate (the velocity on the
previous velocity, and the second difference of eq. 3 on the previous one; both on a
copy of the series whose isolated gross errors are pulled back, ``ar_gate``), and the
fast blend: RVAR's eq. 26 in the relative mode of eq. 27, per coordinate, between a
block VAR(1) on second differences (eq. 2, 25; discounted least squares) and
constant velocity, with eq. 28's weights 2^−(T−t).  For
every group g of coordinates the prediction is

    x̂_{T+1}(j) = Σ_i w_{g,i} x̂^i_{T+1}(j),   j ∈ g,   w_g ∈ Δ (w ≥ 0, Σ w = 1)

with the weights minimising the discounted squared error the combination would have
made on the frames seen so far,

    w_g = argmin_{w ∈ Δ} wᵀ G_g w,   G_g = Σ_t λ^{T−t} Σ_{j∈g} e_t(j) e_t(j)ᵀ,

e_t(j) ∈ R^M the experts' errors x_t(j) − x̂^i_t(j).  The simplex constraint makes the
bank never much worse than its best expert (every vertex is an expert), and the
discount λ = 1 − 1/memory lets it follow a change in how predictable the motion is.

The minimum over the simplex is found through the cone: v* = argmin_{v ≥ 0}
vᵀGv − 2·1ᵀv gives w* = v* / 1ᵀv* (writing v = s w, the inner minimum over s is
−1 / wᵀGw).  That non-negative quadratic programme is solved by coordinate descent,
warm-started from the previous frame's weights, a few sweeps a frame — O(M²) per
sweep and group, so a frame costs O(d M + n_groups M²) whatever the history.

One compiled call per frame (``_bank_update``) does everything: score the experts'
last predictions, update every expert, refit the weights, combine.  The module is
longer than most because it holds one concept, the bank: its experts are computed
inside that one call, so their updates live here rather than in their own modules.

A bank that steers a tracker weights only :data:`STEERING_EXPERTS` (``experts=
"steering"``): fed back the tracker's estimates, the fit over all twelve puts its
weight on the experts that carry the whole last step forward, the weights swing, and
the tracking does not recover after fast motion (design §16, "In closed loop").  The
fast blend is the steering set's extrapolator: it carries at most γ of the step and
its own weights, refitted per coordinate within two or three frames, fall back to no
motion when the extrapolation fails.  On slow smooth motion carrying the whole step is
what predicts best, so in the steering bank an expert kept out (:data:`JOINING`) joins
a group's weights while its discounted squared error is below ``join`` (¼) times the
best kept expert's: its RMSE under half theirs, which the tracker's estimates never
gave it on the benchmark.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit

from handvar.predictors.base import as_vector
from handvar.predictors.one_euro import one_euro_alpha
from handvar.validate import as_float, as_int

__all__ = ["EXPERTS", "JOINING", "STEERING_EXPERTS", "AdaptiveBank", "hand_groups"]

# The experts, in the order of the weights.
EXPERTS: tuple[str, ...] = (
    "no motion",
    "decelerating 0.2",
    "decelerating 0.4",
    "decelerating 0.6",
    "constant velocity",
    "Kalman CV",
    "One Euro",
    "Kalman CV q/r=1e-2",
    "Kalman CV q/r=1e-4",
    "AR velocity",
    "AR acceleration",
    "fast blend",
)
_M = len(EXPERTS)
# The experts of a bank that steers a tracker (design §16, "In closed loop"): those whose
# prediction carries less than the whole last step forward.  Constant velocity, the
# default Kalman CV (q/r = 1, close to constant velocity) and the two autoregressions
# (gains up to 1 and beyond) are left out: with them, the weights fitted on the
# tracker's estimates (which the bank's own prediction helped produce) swing from frame
# to frame and the tracking does not recover after fast motion.  The fast blend stays:
# it carries at most γ = 0.8 of the (bounded) step, and it drops to no motion by itself.
STEERING_EXPERTS: tuple[str, ...] = (
    "no motion",
    "decelerating 0.2",
    "decelerating 0.4",
    "decelerating 0.6",
    "One Euro",
    "Kalman CV q/r=1e-2",
    "Kalman CV q/r=1e-4",
    "fast blend",
)
# The experts that join a group's weights when kept out of a bank's set, while clearly
# the best (discounted squared error below `join` times the best kept expert's): those
# that carry the whole step, which on slow smooth motion have a tenth of the steering
# set's error.  The autoregressions, which amplify noise most, never join.
JOINING: tuple[str, ...] = ("constant velocity", "Kalman CV")
_RHOS = np.array([0.2, 0.4, 0.6, 1.0])  # experts 1..4
# Kalman experts 5, 7, 8: (q, r), as KalmanCV's arguments.
_KALMAN_Q = np.array([1.0, 1e-2, 1e-4])
_KALMAN_R = np.array([1.0, 1.0, 1.0])
_KALMAN_SLOT = np.array([5, 7, 8])
_P11_0 = 1e4  # KalmanCV's initial velocity variance
_PRIOR = np.zeros(_M)
_FAST = EXPERTS.index("fast blend")
_PRIOR[2] = 1.0  # decelerating ρ = 0.4, the paper's choice (paper §4), until errors are known
_GATE_FRAMES = 10.0  # frames before the autoregressions' gate opens (its RMS needs a history)


def hand_groups() -> list[list[int]]:
    """The groups of the 26 hand parameters that share weights.

    Palm translation, palm rotation, the five abductions, and each digit's three
    flexions: the parameter groups of the open-loop table, whose members move alike
    (coarser than eq. 25's blocks, so each group's weights rest on more errors).
    """
    return [[0, 1, 2], [3, 4, 5], list(range(6, 11)),
            *[list(range(11 + 3 * k, 14 + 3 * k)) for k in range(5)]]  # fmt: skip


# Rows of the state array S (R, d).
_X0 = 0  # x_T, x_{T-1}, x_{T-2}
_KAL0 = 3  # per Kalman expert k: m0, m1, P00, P01, P11 at rows _KAL0 + 5k ...
_OE0 = _KAL0 + 5 * len(_KALMAN_Q)  # One Euro: x̂, dx̂
_AR0 = _OE0 + 2  # Σ v v₋₁, Σ v₋₁², Σ y y₋₁, Σ y₋₁², y_T
_FB0 = _AR0 + 5  # fast blend: Σ a², Σ a b, Σ b², Σ a r, Σ b r, Σ r² (discounted by λ_F)
_Y1 = _FB0 + 6  # y_{T−1}
_SV = _Y1 + 1  # the block VAR's undamped prediction x_T + v_T + ŷ (eq. 5)
_RB0 = _SV + 1  # the autoregressions' robust history: x̃_T, x̃_{T−1}, x̃_{T−2}, ỹ_T, Σ r̃², clipped
_P0 = _RB0 + 6  # the experts' predictions, M rows
_OUT = _P0 + _M  # the combined prediction
_ROWS = _OUT + 1
# cfg (the kernel's parameters): λ, λ_AR, α(f_d) of One Euro, f_cmin, β, rate, ridge,
# pool, n₀, sweeps, γ and λ_F of the fast blend, λ_V, max_step, ar_gate, join and the
# fast blend's first_step.


@njit(cache=True, inline="always")
def _triangle_cost(al, be, saa, sab, sbb, sax, sbx, sxx):  # pragma: no cover
    """Σ (r − α a − β b)² from the sums, +∞ outside the triangle α, β ≥ 0, α + β ≤ 1."""
    if al < 0.0 or be < 0.0 or al + be > 1.0 + 1e-12:
        return np.inf
    return (sxx - 2.0 * (al * sax + be * sbx) + al * al * saa
            + 2.0 * al * be * sab + be * be * sbb)  # fmt: skip


@njit(cache=True)
def _triangle(saa, sab, sbb, sax, sbx, sxx):  # pragma: no cover
    """argmin over α, β ≥ 0, α + β ≤ 1 of Σ (r − α a − β b)², from the sums (eq. 27).

    The cost is a convex quadratic in (α, β), so its minimum over the triangle is the
    interior stationary point when that is feasible, else the minimum of an edge
    (β = 0, α = 0, α + β = 1; one-variable least squares clipped to [0, 1]); when the
    two columns are collinear, the minimum-norm solution joins the candidates.  Among
    candidates whose cost is within rounding of the least, the one of smallest
    α² + β² is kept (as :func:`~handvar.predictors.rvar.fit_trust_weights`).
    """
    a0 = b0 = a4 = b4 = -1.0  # infeasible unless the interior / rank-one point exists
    det = saa * sbb - sab * sab
    if det > 1e-12 * saa * sbb and det > 0.0:
        a0 = (sax * sbb - sbx * sab) / det
        b0 = (sbx * saa - sax * sab) / det
    elif saa + sbb > 0.0:  # rank one: the minimum-norm solution (pseudo-inverse)
        ua = np.sqrt(saa)
        ub = np.sqrt(sbb) if sab >= 0.0 else -np.sqrt(sbb)
        h = (ua * sax + ub * sbx) / (saa + sbb) ** 2
        a4 = h * ua
        b4 = h * ub
    a1 = min(max(sax / saa, 0.0), 1.0) if saa > 0.0 else 0.0  # β = 0
    b2 = min(max(sbx / sbb, 0.0), 1.0) if sbb > 0.0 else 0.0  # α = 0
    sdd = saa - 2.0 * sab + sbb  # α + β = 1: r − b = α (a − b)
    a3 = min(max((sax - sab - sbx + sbb) / sdd, 0.0), 1.0) if sdd > 0.0 else 0.5
    ca = (a0, a1, 0.0, a3, a4)  # tuples: no allocation in the per-coordinate loop
    cb = (b0, 0.0, b2, 1.0 - a3, b4)
    best = np.inf
    for k in range(5):
        best = min(best, _triangle_cost(ca[k], cb[k], saa, sab, sbb, sax, sbx, sxx))
    tol = 1e-12 * (abs(sxx) + saa + sbb)
    alpha = 0.0
    beta = 0.0
    small = np.inf
    for k in range(5):
        al = ca[k]
        be = cb[k]
        f = _triangle_cost(al, be, saa, sab, sbb, sax, sbx, sxx)
        if f <= best + tol and al * al + be * be < small:
            small = al * al + be * be
            alpha = al
            beta = be
    return alpha, beta


@njit(cache=True, inline="always")
def _join(G, w, allowed, joinable, join, kept):  # pragma: no cover
    """The experts a group may weight (`kept`, set in place): the allowed ones, and a
    joinable one while its error G[a, a] is below `join` times the best allowed
    expert's.  An expert that has left gives its weight in `w` back to the others."""
    M = w.shape[0]
    best = np.inf
    m_allowed = 0
    for a in range(M):
        kept[a] = allowed[a]
        if allowed[a]:
            best = min(best, G[a, a])
            m_allowed += 1
    if best > 0.0:
        for a in range(M):
            if joinable[a] and not allowed[a] and G[a, a] < join * best:
                kept[a] = True
    left = 0.0
    for a in range(M):
        if not kept[a]:
            left += w[a]
            w[a] = 0.0
    if left > 0.0:
        for a in range(M):
            w[a] = w[a] / (1.0 - left) if left < 1.0 else allowed[a] / m_allowed


@njit(cache=True)
def _bank_update(
    x, S, G, N, W, index, sizes, cfg, aux, allowed, joinable, prior, vindex, vsizes, Vyy, Vxy
):  # pragma: no cover
    """One frame: score the experts, update them, refit the weights, combine.

    Only the experts with `allowed` true get weight, and in a group those with
    `joinable` true whose discounted squared error is below cfg[15] times the best
    allowed expert's (from frame n₀ on); `prior` (M,) is w₀.

    `aux` holds [frames seen, increment scale c]; G and N are stored multiplied by c
    (c = λ^−t grows instead of G shrinking, and is folded back when large).
    Returns False, changing nothing, if `x` is not finite.
    """
    d = x.shape[0]
    M = _M
    ng = sizes.shape[0]
    for j in range(d):
        if not np.isfinite(x[j]):
            return False
    lam, lam_ar, oe_a_d, oe_min, oe_beta, rate, ridge, pool, n0 = cfg[:9]
    sweeps = int(cfg[9])
    gamma, lam_f, lam_v, max_step = cfg[10], cfg[11], cfg[12], cfg[13]
    gate, join, first_step = cfg[14], cfg[15], cfg[16]
    n = int(aux[0])
    # the discounted count of the gate's innovations, Σ_{k<n} λ_AR^k
    wsum = (1.0 - lam_ar**n) / (1.0 - lam_ar)
    # 1. Score the experts' predictions of this frame: G_g = λ G_g + Σ_j e eᵀ.
    if n >= 1:
        c = aux[1] / lam
        if c > 1e100:  # fold the scale back into G and N
            for g in range(ng):
                N[g] /= c
                for a in range(M):
                    for b in range(M):
                        G[g, a, b] /= c
            c = 1.0
        aux[1] = c
        e = np.empty(M)
        for g in range(ng):
            for jj in range(sizes[g]):
                j = index[g, jj]
                for a in range(M):
                    e[a] = x[j] - S[_P0 + a, j]
                for a in range(M):
                    ea = c * e[a]
                    for b in range(a, M):
                        G[g, a, b] += ea * e[b]
            N[g] += c * sizes[g]
    # 2. Update every expert and make its prediction of the next frame.
    for j in range(d):
        z = x[j]
        # Fast blend: score the last undamped AR-acceleration (a) and constant-velocity
        # (b) predictions relative to x_{t−1}, as the relative mode of eq. 27 does.
        if n >= 1:
            xp = S[_X0, j]
            r = z - xp
            pa = S[_SV, j] - xp
            pb = S[_P0 + 4, j] - xp
            S[_FB0, j] = lam_f * S[_FB0, j] + pa * pa
            S[_FB0 + 1, j] = lam_f * S[_FB0 + 1, j] + pa * pb
            S[_FB0 + 2, j] = lam_f * S[_FB0 + 2, j] + pb * pb
            S[_FB0 + 3, j] = lam_f * S[_FB0 + 3, j] + pa * r
            S[_FB0 + 4, j] = lam_f * S[_FB0 + 4, j] + pb * r
            S[_FB0 + 5, j] = lam_f * S[_FB0 + 5, j] + r * r
        S[_X0 + 2, j] = S[_X0 + 1, j]
        S[_X0 + 1, j] = S[_X0, j]
        S[_X0, j] = z
        # Kalman CV (as KalmanCV): time update, then measurement update.
        for k in range(_KALMAN_Q.shape[0]):
            r0 = _KAL0 + 5 * k
            if n == 0:
                S[r0, j] = z
                S[r0 + 1, j] = 0.0
                S[r0 + 2, j] = _KALMAN_R[k]
                S[r0 + 3, j] = 0.0
                S[r0 + 4, j] = _P11_0
            else:
                q = _KALMAN_Q[k]
                m0 = S[r0, j] + S[r0 + 1, j]  # m = F m
                m1 = S[r0 + 1, j]
                p00 = S[r0 + 2, j]
                p01 = S[r0 + 3, j]
                p11 = S[r0 + 4, j]
                p00, p01, p11 = p00 + 2 * p01 + p11 + q / 3, p01 + p11 + q / 2, p11 + q  # FPF'+Q
                s = p00 + _KALMAN_R[k]
                k0 = p00 / s
                k1 = p01 / s
                inn = z - m0
                S[r0, j] = m0 + k0 * inn
                S[r0 + 1, j] = m1 + k1 * inn
                S[r0 + 2, j] = (1 - k0) * p00
                S[r0 + 3, j] = (1 - k0) * p01
                S[r0 + 4, j] = p11 - k1 * p01
            S[_P0 + _KALMAN_SLOT[k], j] = S[r0, j] + S[r0 + 1, j]  # H F m
        # One Euro: x̂, dx̂.
        if n == 0:
            S[_OE0, j] = z
            S[_OE0 + 1, j] = 0.0
        else:
            dx = (z - S[_OE0, j]) * rate
            S[_OE0 + 1, j] += oe_a_d * (dx - S[_OE0 + 1, j])
            tau = 1.0 / (2.0 * np.pi * (oe_min + oe_beta * abs(S[_OE0 + 1, j])))
            S[_OE0, j] += (z - S[_OE0, j]) / (1.0 + tau * rate)
        S[_P0 + 6, j] = S[_OE0, j]
        # No motion (eq. 16), decelerating (eq. 22) and constant velocity.
        v = z - S[_X0 + 1, j] if n >= 1 else 0.0
        S[_P0, j] = z
        for r in range(_RHOS.shape[0]):
            S[_P0 + 1 + r, j] = z + _RHOS[r] * v
        # The second difference y_T, for the fast blend's VAR.
        if n >= 2:
            S[_Y1, j] = S[_AR0 + 4, j]
            S[_AR0 + 4, j] = z - 2.0 * S[_X0 + 1, j] + S[_X0 + 2, j]
        # The two autoregressions run on a robust copy x̃ of the series: a value whose
        # innovation against the AR(1)-acceleration prediction exceeds `gate` times
        # its discounted RMS is pulled back to that bound (winsorised), so one gross
        # error is not carried forward as a velocity and an acceleration.
        zt = z
        if n >= 1:
            r = z - S[_P0 + 10, j]
            bound = gate * np.sqrt(S[_RB0 + 4, j] / wsum)
            if n <= _GATE_FRAMES or not abs(r) > bound:  # (∞ · 0 = NaN: no gate)
                S[_RB0 + 5, j] = 0.0
            elif S[_RB0 + 5, j] > 0.0:
                # Two frames out of bounds in a row: a real change, not a gross error.
                # Take both as they came.
                S[_RB0, j] = S[_X0 + 1, j]
                S[_RB0 + 5, j] = 0.0
            else:
                r = bound if r > 0.0 else -bound
                zt = S[_P0 + 10, j] + r
                S[_RB0 + 5, j] = 1.0
            S[_RB0 + 4, j] = lam_ar * S[_RB0 + 4, j] + r * r
        S[_RB0 + 2, j] = S[_RB0 + 1, j]
        S[_RB0 + 1, j] = S[_RB0, j]
        S[_RB0, j] = zt
        vt = zt - S[_RB0 + 1, j] if n >= 1 else 0.0
        # AR(1) on velocities: v̂ = b ṽ_T, b by discounted least squares.
        if n >= 2:
            v1 = S[_RB0 + 1, j] - S[_RB0 + 2, j]
            S[_AR0, j] = lam_ar * S[_AR0, j] + vt * v1
            S[_AR0 + 1, j] = lam_ar * S[_AR0 + 1, j] + v1 * v1
        b = S[_AR0, j] / (1.001 * S[_AR0 + 1, j] + 1e-300)
        b = min(max(b, -1.0), 1.0)
        S[_P0 + 9, j] = zt + b * vt
        # AR(1) on second differences (eq. 3): ŷ = a ỹ_T, x̂ = x̃_T + ṽ_T + ŷ (eq. 5).
        y = 0.0
        if n >= 2:
            y = zt - 2.0 * S[_RB0 + 1, j] + S[_RB0 + 2, j]
            if n >= 3:
                S[_AR0 + 2, j] = lam_ar * S[_AR0 + 2, j] + y * S[_RB0 + 3, j]
                S[_AR0 + 3, j] = lam_ar * S[_AR0 + 3, j] + S[_RB0 + 3, j] ** 2
            S[_RB0 + 3, j] = y
        a = S[_AR0 + 2, j] / (1.001 * S[_AR0 + 3, j] + 1e-300)
        a = min(max(a, -1.0), 1.0)
        S[_P0 + 10, j] = zt + vt + a * y
    # 2b. The block VAR(1) on second differences (eq. 2, 25), discounted least squares:
    # Ŷ = Σ y_t y_{t−1}ᵀ (Σ y_{t−1} y_{t−1}ᵀ)⁻¹ y_T per block, each ŷ_j bounded by the
    # block's largest |y_T| (the diagonal AR's |a| ≤ 1, unit-free).
    L = np.empty((Vyy.shape[1], Vyy.shape[1]))
    zz = np.empty(Vyy.shape[1])
    for bb in range(vsizes.shape[0]):
        k = vsizes[bb]
        if n >= 3:
            for p in range(k):
                ip = vindex[bb, p]
                for q in range(k):
                    iq = vindex[bb, q]
                    Vyy[bb, p, q] = lam_v * Vyy[bb, p, q] + S[_Y1, ip] * S[_Y1, iq]
                    Vxy[bb, p, q] = lam_v * Vxy[bb, p, q] + S[_AR0 + 4, ip] * S[_Y1, iq]
        # Cholesky of Vyy + εI, ε = 10⁻⁹ tr / k: z = Vyy⁻¹ y_T, ŷ = Vxy z.
        tr = 0.0
        ymax = 0.0
        for p in range(k):
            tr += Vyy[bb, p, p]
            ymax = max(ymax, abs(S[_AR0 + 4, vindex[bb, p]]))
        ok = n >= 3 + k and tr > 0.0
        if ok:
            eps = 1e-9 * tr / k
            for p in range(k):
                for q in range(p + 1):
                    acc = Vyy[bb, p, q] + (eps if p == q else 0.0)
                    for m in range(q):
                        acc -= L[p, m] * L[q, m]
                    if p == q:
                        if acc <= 0.0:
                            ok = False
                            break
                        L[p, p] = np.sqrt(acc)
                    else:
                        L[p, q] = acc / L[q, q]
                if not ok:
                    break
        if ok:
            for p in range(k):  # L u = y_T
                acc = S[_AR0 + 4, vindex[bb, p]]
                for m in range(p):
                    acc -= L[p, m] * zz[m]
                zz[p] = acc / L[p, p]
            for p in range(k - 1, -1, -1):  # Lᵀ z = u
                acc = zz[p]
                for m in range(p + 1, k):
                    acc -= L[m, p] * zz[m]
                zz[p] = acc / L[p, p]
        for p in range(k):
            j = vindex[bb, p]
            yh = 0.0
            if ok:
                for q in range(k):
                    yh += Vxy[bb, p, q] * zz[q]
                yh = min(max(yh, -ymax), ymax)
            step = S[_P0 + 4, j] - x[j] + yh  # x̂^SV − x_T = v_T + ŷ, bounded (paper §4.2)
            step = min(max(step, -max_step), max_step)
            S[_SV, j] = x[j] + step
    # 2c. The fast blend (eq. 26 in the relative mode of eq. 27, per coordinate):
    # x_T + γ (α (x̂^SV − x_T) + β (x̂^CV − x_T)), α, β on the triangle.
    for j in range(d):
        z = x[j]
        if S[_FB0, j] + S[_FB0 + 2, j] > 0.0:
            al, be = _triangle(S[_FB0, j], S[_FB0 + 1, j], S[_FB0 + 2, j],
                               S[_FB0 + 3, j], S[_FB0 + 4, j], S[_FB0 + 5, j])  # fmt: skip
            step = gamma * (al * (S[_SV, j] - z) + be * (S[_P0 + 4, j] - z))
        else:  # no scored prediction has moved yet: carry `first_step` of the step
            step = first_step * 0.5 * ((S[_SV, j] - z) + (S[_P0 + 4, j] - z))
        S[_P0 + 11, j] = z + step
    # 3. Refit the weights of every group and combine.  Each group's Gram matrix is
    # normalised to mean diagonal 1 over the experts that may get weight (Ĝ_g) and
    # shrunk towards the pooled Ĝ of all groups by `pool` pseudo-observations:
    # A_g = N_g Ĝ_g + pool Ḡ.  The experts without weight enter nothing.
    c = aux[1]
    m_allowed = 0
    for a in range(M):
        if allowed[a]:
            m_allowed += 1
    Gbar = np.zeros((M, M))
    total_n = 0.0
    scale = np.zeros(ng)
    for g in range(ng):
        tr = 0.0
        for a in range(M):
            if allowed[a]:
                tr += G[g, a, a]
        if tr > 0.0 and N[g] > 0.0:
            scale[g] = m_allowed / tr
            f = N[g] * scale[g]
            for a in range(M):
                for b in range(a, M):
                    Gbar[a, b] += f * G[g, a, b]
            total_n += N[g]
    if total_n > 0.0:
        for a in range(M):
            for b in range(a, M):
                Gbar[a, b] *= pool / total_n
                Gbar[b, a] = Gbar[a, b]
    A = np.empty((M, M))
    Gv = np.empty(M)
    v = np.empty(M)
    shrink = max(0.0, 1.0 - n / n0) if n0 > 0.0 else 0.0
    kept = np.empty(M, dtype=np.bool_)
    for g in range(ng):
        _join(G[g], W[g], allowed, joinable, join if n >= n0 else 0.0, kept)
        if scale[g] > 0.0:
            f = N[g] / c * scale[g]
            for a in range(M):
                for b in range(a, M):
                    A[a, b] = f * G[g, a, b] + Gbar[a, b]
                    A[b, a] = A[a, b]
            tr = 0.0
            for a in range(M):
                if allowed[a]:
                    tr += A[a, a]
            delta = ridge * tr / m_allowed + 1e-300
            # Warm start: v = w / (wᵀ A w), the best scaling of last frame's w.
            q = 0.0
            for a in range(M):
                s = delta * W[g, a]
                for b in range(M):
                    s += A[a, b] * W[g, b]
                Gv[a] = s
                q += W[g, a] * s
            if q > 0.0:
                for a in range(M):
                    v[a] = W[g, a] / q
                    Gv[a] /= q
                # Coordinate descent on vᵀ(A + δI)v − 2·1ᵀv over v ≥ 0.
                for _ in range(sweeps):
                    for a in range(M):
                        if not kept[a]:
                            continue
                        new = v[a] + (1.0 - Gv[a]) / (A[a, a] + delta)
                        if new < 0.0:
                            new = 0.0
                        step = new - v[a]
                        if step != 0.0:
                            v[a] = new
                            for b in range(M):
                                Gv[b] += step * A[b, a]
                            Gv[a] += step * delta
                total = 0.0
                for a in range(M):
                    total += v[a]
                if total > 0.0:
                    for a in range(M):
                        W[g, a] = v[a] / total
        # Shrink towards the prior weights while few frames have been seen.
        for jj in range(sizes[g]):
            j = index[g, jj]
            s = 0.0
            for a in range(M):
                s += ((1.0 - shrink) * W[g, a] + shrink * prior[a]) * S[_P0 + a, j]
            S[_OUT, j] = s
    aux[0] = n + 1
    return True


def _partition(blocks, d: int, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Blocks of the indices 0..d-1 (each alone when None) as the kernel takes them: an
    index table (n_blocks, largest block), padded with 0, and the block sizes."""
    blocks = [[i] for i in range(d)] if blocks is None else blocks
    flat = sorted(i for b in blocks for i in b)
    if flat != list(range(d)) or any(len(b) == 0 for b in blocks):
        raise ValueError(
            f"{name}: expected a partition of the indices 0..{d - 1} (each exactly once); "
            f"got {blocks!r}"
        )
    index = np.zeros((len(blocks), max(len(b) for b in blocks)), dtype=np.intp)
    for g, b in enumerate(blocks):
        index[g, : len(b)] = b
    return index, np.array([len(b) for b in blocks], dtype=np.intp)


class AdaptiveBank:
    """Online convex combination of simple predictors, one set of weights per group.

    Parameters
    ----------
    blocks : sequence of sequences of int, optional
        The groups of coordinates that share weights (a partition of 0..d−1); default
        every coordinate alone.  For hand parameters :func:`hand_blocks` (eq. 25),
        for keypoints one block per digit.
    memory : float, default 400
        The weights' horizon in frames: the squared errors are discounted by
        λ = 1 − 1/memory a frame.
    ar_memory : float, default 50
        The horizon of the two autoregressive experts (λ_AR = 1 − 1/ar_memory).
    rate : float, default 30
        Frames per second, for the One Euro expert (its published parameters:
        f_cmin = 1 Hz, β = 0, f_d = 1 Hz).
    sweeps : int, default 3
        Coordinate-descent sweeps of the weights per frame.
    ridge : float, default 1e-6
        δ / (tr G / M): a vanishing ridge that keeps the weights unique.
    prior_frames : float, default 30
        n₀: after n frames the weights used are (1 − s) w_g + s w₀ with
        s = max(0, 1 − n / n₀) and w₀ all on decelerating ρ = 0.4, so that the first
        frames, whose errors say little, follow the paper's choice.
    pool : float, default 1000
        Pseudo-observations (coordinate-frames) of the pooled error matrix of all
        groups added to each group's own: a group's weights lean on the others'
        evidence while its own is short.
    experts : {"all", "steering"} or sequence of str, default "all"
        The experts that may get weight (names of :data:`EXPERTS`); the others still
        run but get none.  ``"steering"`` is :data:`STEERING_EXPERTS`, for a bank whose
        predictions start a tracker's optimiser and which is fed the tracker's
        estimates (design §16, "In closed loop").  w₀ is the fast blend when it is
        kept, else decelerating ρ = 0.4 when that is kept, else uniform on the kept
        experts.
    gamma : float, default 0.8
        γ of eq. 26 in the fast blend: the most of the extrapolated step it carries.
    var_blocks : sequence of sequences of int, optional
        The blocks of the fast blend's VAR (eq. 25); default every coordinate alone.
        For hand parameters :func:`~handvar.params.hand_blocks`.
    var_memory : float, default 30
        The horizon of the fast blend's VAR: its sums are discounted by
        1 − 1/var_memory a frame (the structured VAR's N = 30, paper §4.3).
    max_step : float or None, default 10
        Bound on |x̂^SV − x_T| of the fast blend's VAR prediction, in the coordinates'
        units (the paper's 10° threshold, paper §4.2); ``None`` disables it.
    ar_gate : float or None, default 4
        The two autoregressive experts run on a robust copy of the series: from the
        11th frame on, a value whose innovation against the AR-acceleration expert's
        prediction exceeds ar_gate times that innovation's discounted RMS (horizon
        ar_memory) is pulled back to the bound, unless the frame before was pulled
        back too (two in a row are a real change, and both are taken as they came).
        One gross error is then not carried into the next prediction as a velocity
        and an acceleration.  ``None`` disables it.  Chosen on the league's rows with
        outlier frames (docs/predictors-notes.md); 3 to 5 give the same league.
    join : float, optional
        From frame n₀ on, an expert of :data:`JOINING` that `experts` leaves out gets
        weight in a group while its discounted squared error there is below join times
        the best kept expert's (and gives its weight back once it is not); 0 disables
        it.  Default 0.25 for ``experts="steering"``, else 0 (a list gets exactly its
        experts).  Chosen between the league's slow smooth rows, where that ratio's
        median is 0.04–0.15, and the benchmark tracked in closed loop, where its least
        is 0.53 (docs/predictors-notes.md).
    first_step : float, optional
        The share of the step x̂ − x_T of ½ (x̂^SV + x̂^CV) that the fast blend carries
        until one of its scored predictions has moved (the first, made from one
        frame, has not): at the series' second prediction.  Default `gamma`: the
        fast blend with α = β = ½ before it has errors to fit them on.  0 predicts
        no motion there, which loses open loop on clips that start fast and gains
        nothing steering the benchmark (docs/predictors-notes.md).

    Notes
    -----
    The fast blend predicts x_T + γ (α (x̂^SV − x_T) + β (x̂^CV − x_T)) (eq. 26) per
    coordinate, with α, β ≥ 0, α + β ≤ 1 minimising Σ_t 2^−(T−t) (r_t − α a_t − β b_t)²
    (eq. 27, 28 in the relative mode: r_t, a_t, b_t are x_t, x̂^SV_t and x̂^CV_t minus
    x_{t−1}; :func:`~handvar.predictors.rvar.fit_trust_weights`' problem, solved from
    five discounted sums).  x̂^SV = x_T + v_T + ŷ with ŷ = C_b D_b⁻¹ y_T per VAR block
    b, C_b = Σ λ_V^{T−t} y_t y_{t−1}ᵀ, D_b = Σ λ_V^{T−t} y_{t−1} y_{t−1}ᵀ + εI
    (ε = 10⁻⁹ tr D_b / k), each ŷ_j clipped to the block's largest |y_T(i)| and the
    step v_T + ŷ to ±max_step; ŷ = 0 until a block of k coordinates has k + 1
    equations.  Until a scored prediction has moved, α and β are not fitted and the
    fast blend carries `first_step` of the step (above).

    The weights start uniform; with one frame seen every expert predicts that frame.
    Every expert is offset-equivariant, and the weights depend only on errors, so
    x + c ↦ x̂ + c.  :attr:`weights` gives the current weights, (n_groups, M), in
    the order of :data:`EXPERTS`.

    Examples
    --------
    >>> import numpy as np
    >>> bank = AdaptiveBank()
    >>> for t in range(200):
    ...     bank.update([2.0 * t])          # constant velocity
    >>> round(float(bank.predict()[0]), 3)
    400.0
    """

    def __init__(
        self,
        blocks: Sequence[Sequence[int]] | None = None,
        *,
        memory: float = 400.0,
        ar_memory: float = 50.0,
        rate: float = 30.0,
        sweeps: int = 3,
        ridge: float = 1e-6,
        prior_frames: float = 30.0,
        pool: float = 1000.0,
        experts: str | Sequence[str] = "all",
        gamma: float = 0.8,
        var_blocks: Sequence[Sequence[int]] | None = None,
        var_memory: float = 30.0,
        max_step: float | None = 10.0,
        ar_gate: float | None = 4.0,
        join: float | None = None,
        first_step: float | None = None,
    ) -> None:
        self.ar_gate = (
            None
            if ar_gate is None
            else as_float(ar_gate, "ar_gate", minimum=0.0, exclusive_minimum=True)
        )
        self.max_step = (
            None
            if max_step is None
            else as_float(max_step, "max_step", minimum=0.0, exclusive_minimum=True)
        )
        self.gamma = as_float(gamma, "gamma", minimum=0.0, maximum=1.0)
        self.first_step = (
            self.gamma
            if first_step is None
            else as_float(first_step, "first_step", minimum=0.0, maximum=1.0)
        )
        self.var_memory = as_float(var_memory, "var_memory", minimum=1.0, exclusive_minimum=True)
        self.var_blocks = None if var_blocks is None else [[int(i) for i in b] for b in var_blocks]
        self.memory = as_float(memory, "memory", minimum=1.0, exclusive_minimum=True)
        self.ar_memory = as_float(ar_memory, "ar_memory", minimum=1.0, exclusive_minimum=True)
        self.rate = as_float(rate, "rate", minimum=0.0, exclusive_minimum=True)
        self.sweeps = as_int(sweeps, "sweeps", minimum=1)
        self.ridge = as_float(ridge, "ridge", minimum=0.0)
        self.prior_frames = as_float(prior_frames, "prior_frames", minimum=0.0)
        self.pool = as_float(pool, "pool", minimum=0.0)
        self.blocks = None if blocks is None else [[int(i) for i in b] for b in blocks]
        presets = {"all": EXPERTS, "steering": STEERING_EXPERTS}
        if isinstance(experts, str):
            if experts not in presets:
                raise ValueError(f"experts: expected 'all', 'steering' or names; got {experts!r}")
            names = presets[experts]
        else:
            names = tuple(experts)
            if not names or any(not isinstance(e, str) or e not in EXPERTS for e in names):
                raise ValueError(
                    f"experts: expected names among {', '.join(EXPERTS)}; got {experts!r}"
                )
        self._experts_arg = experts if isinstance(experts, str) else list(names)
        self.experts = tuple(e for e in EXPERTS if e in names)
        self._allowed = np.array([e in names for e in EXPERTS])
        self._joinable = np.array([e in JOINING for e in EXPERTS])
        self.join = (
            (0.25 if isinstance(experts, str) and experts == "steering" else 0.0)
            if join is None
            else as_float(join, "join", minimum=0.0)
        )
        # w₀: the fast blend when it is an expert, else decelerating ρ = 0.4, else uniform.
        if self._allowed[_FAST]:
            self._prior = np.zeros(_M)
            self._prior[_FAST] = 1.0
        elif self._allowed[2]:
            self._prior = _PRIOR
        else:
            self._prior = self._allowed / self._allowed.sum()
        self.reset()

    def reset(self) -> None:
        """Forget every frame (weights included); the next update starts a new series."""
        self._d: int | None = None

    def _allocate(self, d: int) -> None:
        self._index, self._sizes = _partition(self.blocks, d, "blocks")
        ng = len(self._sizes)
        self._S = np.zeros((_ROWS, d))
        self._G = np.zeros((ng, _M, _M))
        self._N = np.zeros(ng)
        self._W = np.zeros((ng, _M))
        self._aux = np.zeros(2)
        self._cfg = np.array([
            1.0 - 1.0 / self.memory, 1.0 - 1.0 / self.ar_memory, one_euro_alpha(1.0, self.rate),
            1.0, 0.0, self.rate, self.ridge, self.pool, self.prior_frames, self.sweeps,
            self.gamma, 0.5, 1.0 - 1.0 / self.var_memory,
            np.inf if self.max_step is None else self.max_step,
            np.inf if self.ar_gate is None else self.ar_gate, self.join, self.first_step,
        ])  # fmt: skip
        self._vindex, self._vsizes = _partition(self.var_blocks, d, "var_blocks")
        nvb, vmax = self._vindex.shape
        self._Vyy = np.zeros((nvb, vmax, vmax))
        self._Vxy = np.zeros((nvb, vmax, vmax))
        self._d = d
        self._clear()

    def _clear(self) -> None:
        self._S[...] = 0.0
        self._Vyy[...] = 0.0
        self._Vxy[...] = 0.0
        self._G[...] = 0.0
        self._N[...] = 0.0
        self._W[...] = self._allowed / self._allowed.sum()
        self._aux[:] = (0.0, 1.0)

    def update(self, x) -> None:
        """Take the estimate `x` (d,) of the newest frame; refit the weights."""
        if self._d is None:
            x = as_vector(x, "x")
            self._allocate(x.size)
        else:
            x = np.asarray(x, dtype=float)
            if x.shape != (self._d,):
                as_vector(x, "x", self._d)  # raises, naming the shape
        if not _bank_update(
            x,
            self._S,
            self._G,
            self._N,
            self._W,
            self._index,
            self._sizes,
            self._cfg,
            self._aux,
            self._allowed,
            self._joinable,
            self._prior,
            self._vindex,
            self._vsizes,
            self._Vyy,
            self._Vxy,
        ):
            raise ValueError("x: expected finite values; got NaN or infinity")

    def predict(self) -> np.ndarray:
        """The weighted prediction (d,) of the next frame."""
        if self._d is None or self._aux[0] == 0:
            raise RuntimeError("predict() needs at least one update()")
        return self._S[_OUT].copy()

    @property
    def weights(self) -> np.ndarray:
        """The current weights, (n_groups, M), rows on the simplex, columns :data:`EXPERTS`."""
        if self._d is None:
            raise RuntimeError("weights needs at least one update()")
        return self._W.copy()

    @property
    def expert_predictions(self) -> np.ndarray:
        """Every expert's prediction of the next frame, (M, d)."""
        if self._d is None or self._aux[0] == 0:
            raise RuntimeError("expert_predictions needs at least one update()")
        return self._S[_P0 : _P0 + _M].copy()

    def __repr__(self) -> str:
        blocks = "None" if self.blocks is None else f"<{len(self.blocks)} blocks>"
        return (
            f"AdaptiveBank(blocks={blocks}, memory={self.memory}, ar_memory={self.ar_memory}, "
            f"rate={self.rate}, experts={self._experts_arg!r})"
        )
