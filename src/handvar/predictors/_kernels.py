"""Compiled inner loops of the online predictors.

A predictor's frame is a few hundred floating-point operations spread over a dozen
small arrays; in numpy the interpreter's per-call overhead would dominate it (about
a microsecond per call), so the loops are compiled with numba.  The maths is the
same as the pure-numpy reference functions (``fit_trust_weights``) and the tests
check that both routes agree.

Blocks are stored padded: ``index`` (nb, kmax) parameter indices of each block,
``sizes`` (nb,) their sizes k, ``S_WW`` (nb, m, m) and ``S_YW`` (nb, kmax, m) the
sums Σ W Wᵀ and Σ y Wᵀ of eq. 14 with m = kmax·p, ``B`` (nb, kmax, m) the fitted
(A_1 … A_p) restricted to each block, regressors ordered lag-major
(y_{t−1}[block], y_{t−2}[block], …).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def add_equation(S_WW, S_YW, index, sizes, order, y, lags, sign):  # pragma: no cover
    """S_WW += sign · W Wᵀ and S_YW += sign · y Wᵀ for one equation, every block."""
    nb = index.shape[0]
    W = np.empty(S_WW.shape[1])
    for b in range(nb):
        k = sizes[b]
        kp = k * order
        for lag in range(order):
            for j in range(k):
                W[lag * k + j] = lags[lag, index[b, j]]
        for i in range(kp):
            wi = sign * W[i]
            for j in range(kp):
                S_WW[b, i, j] += wi * W[j]
        for i in range(k):
            yi = sign * y[index[b, i]]
            for j in range(kp):
                S_YW[b, i, j] += yi * W[j]


@njit(cache=True)
def fit_blocks(S_WW, S_YW, sizes, order, n_eq, B, ready):  # pragma: no cover
    """B̂ = Y W' (W W')⁻¹ (eq. 14) for every block with at least k·p equations.

    Cholesky of each block's W W'; where it is singular (a parameter that never
    moved), the minimum-norm solution via the pseudo-inverse, as lstsq gives.
    """
    nb = sizes.shape[0]
    m = S_WW.shape[1]
    L = np.zeros((m, m))
    for b in range(nb):
        k = sizes[b]
        kp = k * order
        ready[b] = n_eq >= kp
        if not ready[b]:
            continue
        ok = True
        for j in range(kp):
            s = S_WW[b, j, j]
            for q in range(j):
                s -= L[j, q] * L[j, q]
            if not s > 0.0:
                ok = False
                break
            L[j, j] = np.sqrt(s)
            for i in range(j + 1, kp):
                s = S_WW[b, i, j]
                for q in range(j):
                    s -= L[i, q] * L[j, q]
                L[i, j] = s / L[j, j]
        if ok:
            z = np.empty(kp)
            for r in range(k):  # solve (L Lᵀ) B[b, r]ᵀ = S_YW[b, r]ᵀ
                for i in range(kp):
                    s = S_YW[b, r, i]
                    for q in range(i):
                        s -= L[i, q] * z[q]
                    z[i] = s / L[i, i]
                for i in range(kp - 1, -1, -1):
                    s = z[i]
                    for q in range(i + 1, kp):
                        s -= L[q, i] * B[b, r, q]
                    B[b, r, i] = s / L[i, i]
        else:
            P = np.linalg.pinv(S_WW[b, :kp, :kp].copy())
            for r in range(k):
                for i in range(kp):
                    s = 0.0
                    for q in range(kp):
                        s += P[i, q] * S_YW[b, r, q]
                    B[b, r, i] = s


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


@njit(cache=True)
def trust_weights(hist, weights, ridge, alpha, beta):  # pragma: no cover
    """Eq. 27 per column, the same maths as ``rvar.fit_trust_weights``.

    hist (3, n, d): targets, predictions a, predictions b; weights (n,).
    """
    n = hist.shape[1]
    d = hist.shape[2]
    tiny = np.finfo(np.float64).tiny
    sw = np.sqrt(weights)
    A = np.empty(n + 2)
    Bv = np.empty(n + 2)
    X = np.empty(n + 2)
    for c in range(d):
        s_aa = 0.0
        s_bb = 0.0
        s_ax = 0.0
        s_bx = 0.0
        s_dd = 0.0
        s_dx = 0.0
        for t in range(n):
            x = hist[0, t, c]
            a = hist[1, t, c]
            b = hist[2, t, c]
            w = weights[t]
            s_aa += w * a * a
            s_bb += w * b * b
            s_ax += w * a * x
            s_bx += w * b * x
            s_dd += w * (a - b) * (a - b)
            s_dx += w * (a - b) * (x - b)
        eps = ridge * 0.5 * (s_aa + s_bb) + tiny
        root = np.sqrt(eps)
        # Unconstrained minimum by modified Gram–Schmidt on the augmented design.
        for t in range(n):
            A[t] = sw[t] * hist[1, t, c]
            Bv[t] = sw[t] * hist[2, t, c]
            X[t] = sw[t] * hist[0, t, c]
        A[n] = root
        A[n + 1] = 0.0
        Bv[n] = 0.0
        Bv[n + 1] = root
        X[n] = 0.0
        X[n + 1] = 0.0
        r11 = np.sqrt((A * A).sum())
        r12 = 0.0
        for t in range(n + 2):
            A[t] /= r11
            r12 += A[t] * Bv[t]
        for t in range(n + 2):
            Bv[t] -= r12 * A[t]
        r22 = np.sqrt((Bv * Bv).sum())
        beta_in = (Bv * X).sum() / (r22 * r22)
        alpha_in = ((A * X).sum() - r12 * beta_in) / r11
        # Edges, clipped.
        t_ab = min(max((s_dx + eps) / (s_dd + 2.0 * eps), 0.0), 1.0)
        cand_a = (alpha_in, min(max(s_ax / (s_aa + eps), 0.0), 1.0), 0.0, t_ab)
        cand_b = (beta_in, 0.0, min(max(s_bx / (s_bb + eps), 0.0), 1.0), 1.0 - t_ab)
        feasible = alpha_in >= 0.0 and beta_in >= 0.0 and alpha_in + beta_in <= 1.0
        best = np.inf
        for j in range(4):
            if j == 0 and not feasible:
                continue
            al = cand_a[j]
            be = cand_b[j]
            cost = eps * (al * al + be * be)
            for t in range(n):
                r = hist[0, t, c] - al * hist[1, t, c] - be * hist[2, t, c]
                cost += weights[t] * r * r
            if cost < best:
                best = cost
                alpha[c] = al
                beta[c] = be
