"""Compiled inner loops of the online predictors.

A predictor's frame is a few hundred floating-point operations spread over a dozen
small arrays; in numpy the interpreter's per-call overhead would dominate it (about
a microsecond per call), so the loops are compiled with numba.  The maths is the
same as the pure-numpy reference functions (``fit_trust_weights``) and the tests
check that both routes agree.

Blocks are stored padded: ``index`` (nb, kmax) parameter indices of each block,
``sizes`` (nb,) their sizes k.  Block b's equation n is the row
[y_{n−1}[block], …, y_{n−p}[block] | y_n[block]] (regressors lag-major, then targets):
m = k·p regressor columns and k target columns.  A set of rows is held as the top m
rows of the R factor of its QR decomposition, ``R`` (mmax, mmax + kmax) per block:
R[:, :m] = R₁₁ (upper triangular, the R of the regressors W) and R[:, m:m+k] = R₁₂ =
Q₁ᵀY, from which the least-squares coefficients follow as R₁₁ B̂ᵀ = R₁₂ (eq. 14).
Rows only ever enter an R by Givens rotations, never leave one: there is no
downdating, so there is nothing to cancel.  ``B`` (nb, kmax, mmax) holds the fitted
(A_1 … A_p) restricted to each block.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_TRIANGULAR = 1e-10  # below this min/max ratio of R₁₁'s diagonal, solve by SVD instead


@njit(cache=True)
def _rotate_in(R, row, m, ncol, start):  # pragma: no cover
    """Add `row` (destroyed) to the upper-trapezoidal R (m, ncol) by Givens rotations.

    Entries of `row` before column `start` must be zero.  A column that is zero in R
    and in the row stays exactly zero (no rotation is applied for it).
    """
    for j in range(start, m):
        b = row[j]
        if b == 0.0:
            continue
        a = R[j, j]
        r = np.hypot(a, b)
        c = a / r
        s = b / r
        R[j, j] = r
        row[j] = 0.0
        for q in range(j + 1, ncol):
            u = R[j, q]
            v = row[q]
            R[j, q] = c * u + s * v
            row[q] = c * v - s * u


@njit(cache=True)
def _equation(y, capacity, n, index, b, k, order, row):  # pragma: no cover
    """Block b's equation with target y_n, written into row[: k·p + k]."""
    m = k * order
    for lag in range(order):
        src = y[(n - 1 - lag) % capacity]
        for j in range(k):
            row[lag * k + j] = src[index[b, j]]
    tgt = y[n % capacity]
    for j in range(k):
        row[m + j] = tgt[index[b, j]]


@njit(cache=True)
def push_equation(R_back, y, capacity, n, index, sizes, order):  # pragma: no cover
    """Rotate equation n (target y_n) into every block's R_back."""
    nb = index.shape[0]
    row = np.empty(R_back.shape[2])
    for b in range(nb):
        k = sizes[b]
        m = k * order
        _equation(y, capacity, n, index, b, k, order, row)
        _rotate_in(R_back[b], row, m, m + k, 0)


@njit(cache=True)
def build_suffixes(
    R_front, slots, y, capacity, first, last, index, sizes, order
):  # pragma: no cover
    """R_front[b, n % slots] = R of equations n … last, for n = last down to first."""
    nb = index.shape[0]
    row = np.empty(R_front.shape[3])
    for b in range(nb):
        k = sizes[b]
        m = k * order
        nxt = -1
        for n in range(last, first - 1, -1):
            cur = n % slots
            if nxt < 0:
                R_front[b, cur] = 0.0
            else:
                R_front[b, cur] = R_front[b, nxt]
            _equation(y, capacity, n, index, b, k, order, row)
            _rotate_in(R_front[b, cur], row, m, m + k, 0)
            nxt = cur


@njit(cache=True)
def fit_blocks(
    R_front, front_slot, R_back, n_back, sizes, order, n_eq, R, B, ready
):  # pragma: no cover
    """B̂ = Y Wᵀ (W Wᵀ)⁺ (eq. 14) for every block with at least k·p equations.

    The window's R is the front suffix R (when `front_slot` >= 0) with the rows of
    R_back rotated in.  B̂ is the minimum-norm least-squares solution, as
    numpy.linalg.lstsq gives it: R₁₁ B̂ᵀ = R₁₂ by back substitution when R₁₁ is
    clearly regular, otherwise through the SVD of R₁₁ (whose singular values are
    W's) with lstsq's relative cut-off ε·max(N, m).
    """
    nb = sizes.shape[0]
    row = np.empty(R.shape[2])
    eps = np.finfo(np.float64).eps
    for b in range(nb):
        k = sizes[b]
        m = k * order
        ready[b] = n_eq >= m
        if not ready[b]:
            continue
        W = R[b]
        if front_slot >= 0:
            W[:, :] = R_front[b, front_slot]
            if n_back > 0:
                for i in range(m):
                    for q in range(m + k):
                        row[q] = R_back[b, i, q] if q >= i else 0.0
                    _rotate_in(W, row, m, m + k, i)
        else:
            W[:, :] = R_back[b]
        dmax = 0.0
        dmin = np.inf
        for j in range(m):
            v = abs(W[j, j])
            dmax = max(dmax, v)
            dmin = min(dmin, v)
        if dmax == 0.0:
            B[b, :k, :m] = 0.0
        elif dmin > _TRIANGULAR * dmax:
            for r in range(k):  # back substitution, R₁₁ x = R₁₂[:, r]
                for i in range(m - 1, -1, -1):
                    s = W[i, m + r]
                    for q in range(i + 1, m):
                        s -= W[i, q] * B[b, r, q]
                    B[b, r, i] = s / W[i, i]
        else:
            U, sv, Vt = np.linalg.svd(W[:m, :m].copy())
            cut = eps * max(n_eq, m) * sv[0]
            for r in range(k):
                for q in range(m):
                    B[b, r, q] = 0.0
                for i in range(m):
                    if sv[i] <= cut:
                        break
                    c = 0.0
                    for q in range(m):
                        c += U[q, i] * W[q, m + r]
                    c /= sv[i]
                    for q in range(m):
                        B[b, r, q] += c * Vt[i, q]


@njit(cache=True)
def predict_blocks(B, index, sizes, order, ready, lags, y_hat):  # pragma: no cover
    """ŷ_{T+1} = B̂ W_T (eq. 15) for the ready blocks; the others stay 0."""
    nb = index.shape[0]
    for b in range(nb):
        if not ready[b]:
            continue
        k = sizes[b]
        for i in range(k):
            s = 0.0
            for lag in range(order):
                for j in range(k):
                    s += B[b, i, lag * k + j] * lags[lag, index[b, j]]
            y_hat[index[b, i]] = s


_RANK_TOL = 1e-13  # as rvar._RANK_TOL
_EPS = np.finfo(np.float64).eps


@njit(cache=True)
def affine_weights(hist, weights, alpha, beta):  # pragma: no cover
    """Eq. 27 on the edge α + β = 1 per column, the maths of ``rvar.fit_affine_weights``.

    hist (3, n, d): targets, predictions a, predictions b; weights (n,).  Writes α and
    β = 1 − α.
    """
    n = hist.shape[1]
    d = hist.shape[2]
    for c in range(d):
        s_dd = 0.0
        s_dx = 0.0
        S = 0.0
        for t in range(n):
            w = weights[t]
            dv = hist[1, t, c] - hist[2, t, c]  # a − b
            xv = hist[0, t, c] - hist[2, t, c]  # x − b
            s_dd += w * dv * dv
            s_dx += w * dv * xv
            m = abs(xv) + abs(dv)
            S += w * m * m
        t_ab = min(max(s_dx / s_dd, 0.0), 1.0) if s_dd > 0 else 0.5
        f_ab = 0.0
        f_half = 0.0
        for t in range(n):
            dv = hist[1, t, c] - hist[2, t, c]
            xv = hist[0, t, c] - hist[2, t, c]
            r = xv - t_ab * dv
            f_ab += weights[t] * r * r
            r = xv - 0.5 * dv
            f_half += weights[t] * r * r
        best = min(f_ab, f_half)
        tol = 1e-12 * best + 16.0 * _EPS * np.sqrt(best * S) + (16.0 * _EPS) ** 2 * S
        al = 0.5 if f_half <= best + tol else t_ab  # a tie: the smallest α² + β²
        alpha[c] = al
        beta[c] = 1.0 - al


@njit(cache=True)
def trust_weights(hist, weights, alpha, beta):  # pragma: no cover
    """Eq. 27 per column, the same maths as ``rvar.fit_trust_weights``.

    hist (3, n, d): targets, predictions a, predictions b; weights (n,).
    """
    n = hist.shape[1]
    d = hist.shape[2]
    X = np.empty(n)
    A = np.empty(n)
    B = np.empty(n)
    cand_a = np.empty(9)
    cand_b = np.empty(9)
    cost = np.empty(9)
    sws = np.sqrt(weights)
    for c in range(d):
        s_aa = 0.0
        s_bb = 0.0
        S = 0.0
        for t in range(n):
            sw = sws[t]
            xv = hist[0, t, c]
            av = hist[1, t, c]
            bv = hist[2, t, c]
            X[t] = sw * xv
            A[t] = sw * av
            B[t] = sw * bv
            s_aa += A[t] * A[t]
            s_bb += B[t] * B[t]
            m = abs(xv) + abs(av) + abs(bv)
            S += weights[t] * m * m
        # Interior: pivoted Gram–Schmidt of [A B], longer column first.
        swap = s_bb > s_aa
        r11 = np.sqrt(s_bb if swap else s_aa)
        r12 = 0.0
        c1 = 0.0
        for t in range(n):
            p1 = B[t] if swap else A[t]
            p2 = A[t] if swap else B[t]
            q1 = p1 / r11 if r11 > 0 else 0.0
            r12 += q1 * p2
            c1 += q1 * X[t]
        cc = 0.0
        for t in range(n):  # reorthogonalise once
            p1 = B[t] if swap else A[t]
            p2 = A[t] if swap else B[t]
            q1 = p1 / r11 if r11 > 0 else 0.0
            cc += q1 * (p2 - r12 * q1)
        r22sq = 0.0
        px = 0.0
        for t in range(n):
            p1 = B[t] if swap else A[t]
            p2 = A[t] if swap else B[t]
            q1 = p1 / r11 if r11 > 0 else 0.0
            pv = (p2 - r12 * q1) - cc * q1
            r22sq += pv * pv
            px += pv * X[t]
        r12 += cc
        r22 = np.sqrt(r22sq)
        full = r22 > _RANK_TOL * np.hypot(r11, r12)
        u1 = 0.0
        u2 = 0.0
        if full:
            u2 = px / r22sq
            u1 = (c1 - r12 * u2) / r11
        norm2 = r11 * r11 + r12 * r12
        v1 = r11 * c1 / norm2 if norm2 > 0 else 0.0
        v2 = r12 * c1 / norm2 if norm2 > 0 else 0.0
        cand_a[0], cand_b[0] = (u2, u1) if swap else (u1, u2)
        cand_a[1], cand_b[1] = (v2, v1) if swap else (v1, v2)
        # Edges β = 0, α = 0, α + β = 1 (α = t, β = 1 − t), clipped to [0, 1].
        s_ax = 0.0
        s_bx = 0.0
        s_dd = 0.0
        s_dx = 0.0
        for t in range(n):
            s_ax += A[t] * X[t]
            s_bx += B[t] * X[t]
            dv = A[t] - B[t]
            s_dd += dv * dv
            s_dx += dv * (X[t] - B[t])
        t_a = min(max(s_ax / s_aa, 0.0), 1.0) if s_aa > 0 else 0.0
        t_b = min(max(s_bx / s_bb, 0.0), 1.0) if s_bb > 0 else 0.0
        t_ab = min(max(s_dx / s_dd, 0.0), 1.0) if s_dd > 0 else 0.5
        cand_a[2], cand_b[2] = t_a, 0.0
        cand_a[3], cand_b[3] = 0.0, t_b
        cand_a[4], cand_b[4] = t_ab, 1.0 - t_ab
        cand_a[5], cand_b[5] = 0.5, 0.5
        cand_a[6], cand_b[6] = 0.0, 0.0
        cand_a[7], cand_b[7] = 1.0, 0.0
        cand_a[8], cand_b[8] = 0.0, 1.0
        best = np.inf
        for j in range(9):
            al = cand_a[j]
            be = cand_b[j]
            if al < 0.0 or be < 0.0 or al + be > 1.0 or (j == 0 and not full):
                cost[j] = np.inf
                continue
            f = 0.0
            for t in range(n):
                r = X[t] - al * A[t] - be * B[t]
                f += r * r
            cost[j] = f
            best = min(best, f)
        tol = 1e-12 * best + 16.0 * _EPS * np.sqrt(best * S) + (16.0 * _EPS) ** 2 * S
        small = np.inf
        for j in range(9):
            if cost[j] <= best + tol:
                nn = cand_a[j] * cand_a[j] + cand_b[j] * cand_b[j]
                if nn < small:
                    small = nn
                    alpha[c] = cand_a[j]
                    beta[c] = cand_b[j]
