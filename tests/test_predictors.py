"""The motion predictors against independent references.

References: statsmodels' VAR (least squares, Lütkepohl 2006) on the US macroeconomic
data shipped with statsmodels; per-block numpy.linalg.lstsq; a brute-force search
over the RVAR weight triangle; and a plain batch implementation of eq. 5, 14, 22,
26–28 that refits everything from scratch every frame.
"""

from __future__ import annotations

import numpy as np
import pytest
from statsmodels.datasets import macrodata
from statsmodels.tsa.api import VAR as SmVAR

from handvar.predictors import (
    RVAR,
    VAR,
    Decelerating,
    KalmanCV,
    NoMotion,
    Predictor,
    fit_affine_weights,
    fit_trust_weights,
    hand_blocks,
    one_step_predictions,
    second_differences,
    select_order,
)


@pytest.fixture(scope="module")
def macro() -> np.ndarray:
    """log real GDP, consumption, investment (1959Q1–2009Q3), 203 × 3."""
    data = macrodata.load_pandas().data
    return np.log(data[["realgdp", "realcons", "realinv"]].to_numpy())


def feed(predictor, X):
    for x in X:
        predictor.update(x)
    return predictor


# -- VAR against statsmodels ------------------------------------------------------------
@pytest.mark.parametrize("p", [1, 2])
def test_var_matches_statsmodels_full_memory(macro, p):
    # statsmodels' VAR(second_differences).fit(p, trend="n"): OLS, Lütkepohl eq. 3.2.10.
    ref = SmVAR(second_differences(macro)).fit(p, trend="n").coefs
    ours = feed(VAR(order=p, memory=len(macro), blocks=None, max_step=None), macro).coefs
    assert ours.shape == ref.shape == (p, 3, 3)
    np.testing.assert_allclose(ours, ref, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("p", [1, 2])
def test_var_sliding_window_matches_statsmodels_on_last_window(macro, p):
    # 203 frames, memory 40: the window slides 150+ times (and is refreshed exactly
    # every 40 drops), ending on the last 40 equations, i.e. the last 40 + p y's.
    memory = 40
    y = second_differences(macro)
    ref = SmVAR(y[-(memory + p) :]).fit(p, trend="n").coefs
    var = feed(VAR(order=p, memory=memory, max_step=None), macro)
    assert var.n_equations == memory
    np.testing.assert_allclose(var.coefs, ref, rtol=1e-8, atol=1e-10)


def test_var_prediction_is_eq_5_with_statsmodels_forecast(macro):
    p = 2
    y = second_differences(macro)
    fit = SmVAR(y).fit(p, trend="n")
    y_next = fit.forecast(y[-p:], steps=1)[0]
    x_hat = feed(VAR(order=p, memory=len(macro), max_step=None), macro).predict()
    np.testing.assert_allclose(x_hat, y_next + 2 * macro[-1] - macro[-2], rtol=0, atol=1e-12)


# -- structured VAR -------------------------------------------------------------------
def test_structured_var_blocks_equal_separate_least_squares(fingerfist):
    X = fingerfist[:400]
    memory = 60
    var = feed(VAR(order=1, memory=memory, blocks=hand_blocks(), max_step=None), X)
    A = var.coefs[0]
    y = second_differences(X)[-(memory + 1) :]
    inside = np.zeros((26, 26), dtype=bool)
    for block in hand_blocks():
        b = np.array(block)
        inside[np.ix_(b, b)] = True
        # y_t[b] ≈ A_bb y_{t-1}[b]: lstsq of this block alone on the same window.
        sol, *_ = np.linalg.lstsq(y[:-1][:, b], y[1:][:, b], rcond=None)
        np.testing.assert_allclose(A[np.ix_(b, b)], sol.T, rtol=1e-7, atol=1e-9)
    assert np.all(A[~inside] == 0.0)
    assert np.count_nonzero(A[inside]) > 0.9 * inside.sum()


def test_blocks_must_partition_the_parameters():
    with pytest.raises(ValueError, match=r"^blocks: expected disjoint"):
        VAR(blocks=[[0, 1], [1, 2]])  # at construction
    var = VAR(blocks=[[0, 1], [3]])
    with pytest.raises(ValueError, match=r"^blocks: expected a partition"):
        var.update(np.zeros(3))  # once the dimension is known


def test_var_cost_does_not_keep_equations_beyond_memory(fingerfist):
    var = feed(VAR(memory=30, blocks=hand_blocks()), fingerfist[:200])
    assert var.n_equations == 30


# -- RVAR weights: the constrained optimum of eq. 27 -----------------------------------
def _objective(x, a, b, w, alpha, beta):
    r = x[:, None] - alpha[None] * a[:, None] - beta[None] * b[:, None]
    return (w[:, None] * r * r).sum(0)


@pytest.mark.parametrize("seed", range(6))
def test_trust_weights_are_the_constrained_optimum(seed):
    rng = np.random.default_rng(seed)
    n, d = 9, 26
    w = 0.5 ** np.arange(n - 1, -1, -1.0)  # eq. 28
    truth = rng.normal(size=(n, d)).cumsum(0)
    # Predictions of varying quality, some nearly collinear with the truth.
    a = truth + rng.normal(scale=rng.uniform(0.01, 2.0, d), size=(n, d))
    b = rng.uniform(-1, 2, d) * truth + rng.normal(scale=0.5, size=(n, d))
    alpha, beta = fit_trust_weights(truth, a, b, w)
    assert np.all(alpha >= 0) and np.all(beta >= 0) and np.all(alpha + beta <= 1 + 1e-12)
    # Brute force: a fine grid over the triangle finds nothing better.
    g = np.linspace(0.0, 1.0, 301)
    ga, gb = np.meshgrid(g, g)
    keep = ga + gb <= 1.0 + 1e-12
    ga, gb = ga[keep], gb[keep]
    for i in range(d):
        ours = _objective(truth[:, i], a[:, i], b[:, i], w, alpha[i : i + 1], beta[i : i + 1])
        grid = _objective(truth[:, i], a[:, i], b[:, i], w, ga, gb)
        # Nothing is added to eq. 27: the exact minimum is at most the grid's.
        assert ours[0] <= grid.min() * (1 + 1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_affine_weights_are_the_optimum_on_the_edge(seed):
    rng = np.random.default_rng(seed)
    n, d = 9, 26
    w = 0.5 ** np.arange(n - 1, -1, -1.0)  # eq. 28
    truth = rng.normal(size=(n, d)).cumsum(0) + 300.0  # far from zero, as the palm is
    a = truth + rng.normal(scale=rng.uniform(0.01, 2.0, d), size=(n, d))
    b = truth + rng.normal(scale=0.5, size=(n, d)) + rng.uniform(-1, 1, d)
    alpha, beta = fit_affine_weights(truth, a, b, w)
    np.testing.assert_array_equal(alpha + beta, 1.0)
    assert np.all((alpha >= 0) & (alpha <= 1))
    # Brute force: a fine grid over the edge α + β = 1 finds nothing better.
    g = np.linspace(0.0, 1.0, 2001)
    for i in range(d):
        ours = _objective(truth[:, i], a[:, i], b[:, i], w, alpha[i : i + 1], beta[i : i + 1])
        grid = _objective(truth[:, i], a[:, i], b[:, i], w, g, 1.0 - g)
        assert ours[0] <= grid.min() * (1 + 1e-12)


def test_affine_weights_tie_at_one_half_when_both_predictors_agree():
    x = np.arange(12.0).reshape(4, 3) + 100.0
    alpha, beta = fit_affine_weights(x, x + 1.0, x + 1.0, 0.5 ** np.arange(3, -1, -1.0))
    np.testing.assert_array_equal(alpha, 0.5)
    np.testing.assert_array_equal(beta, 0.5)


def test_rvar_weights_stay_in_the_triangle_on_real_motion(fingerfist):
    rvar = RVAR()
    for x in fingerfist[:300]:
        rvar.update(x)
        assert np.all(rvar.alpha >= 0) and np.all(rvar.beta >= 0)
        assert np.all(rvar.alpha + rvar.beta <= 1 + 1e-12)


# -- online against a plain batch implementation ----------------------------------------
def _batch_var(X, T, order, memory, blocks, max_step):
    """x̂_{T+1} from X[:T+1] by refitting eq. 14 with lstsq (eq. 5, max step of paper §4.2)."""
    x = X[: T + 1]
    if len(x) < 2:
        return x[-1].copy()
    y = second_differences(x)
    y_hat = np.zeros(X.shape[1])
    n_eq = min(max(len(y) - order, 0), memory)
    if len(y) >= order:
        for block in blocks:
            b = np.array(block)
            if n_eq < len(b) * order:
                continue
            rows = range(len(y) - n_eq, len(y))
            W = np.array([np.concatenate([y[t - l][b] for l in range(1, order + 1)]) for t in rows])
            Y = np.array([y[t][b] for t in rows])
            B, *_ = np.linalg.lstsq(W, Y, rcond=None)  # eq. 14
            W_T = np.concatenate([y[len(y) - l][b] for l in range(1, order + 1)])
            y_hat[b] = W_T @ B  # eq. 15
    step = np.clip(y_hat + x[-1] - x[-2], -max_step, max_step)  # eq. 5, bounded
    return x[-1] + step


def _batch_trust(target, a, b, w):
    """Eq. 27 over every face of the triangle by lstsq; ties go to the smallest norm."""
    sw = np.sqrt(w)

    def cost(al, be):
        return np.sum(w * (target - al * a - be * b) ** 2)

    def solve(cols, rhs):  # minimum-norm weighted least squares
        sol, *_ = np.linalg.lstsq(np.stack(cols, 1) * sw[:, None], rhs * sw, rcond=None)
        return sol

    interior = solve((a, b), target)
    t_a = np.clip(solve((a,), target)[0], 0, 1)
    t_b = np.clip(solve((b,), target)[0], 0, 1)
    t_ab = np.clip(solve((a - b,), target - b)[0], 0, 1) if np.any(a != b) else 0.5
    candidates = [
        tuple(interior),
        (t_a, 0.0),
        (0.0, t_b),
        (t_ab, 1 - t_ab),
        (0.5, 0.5),  # the smallest-norm point of the edge α + β = 1 when it is flat
        (0.0, 0.0),
        (1.0, 0.0),
        (0.0, 1.0),
    ]
    feasible = [(al, be) for al, be in candidates if al >= 0 and be >= 0 and al + be <= 1]
    best = min(cost(*ab) for ab in feasible)
    scale = np.sum(w * (np.abs(target) + np.abs(a) + np.abs(b)) ** 2)
    ties = [ab for ab in feasible if cost(*ab) <= best * (1 + 1e-9) + 1e-24 * scale]
    return min(ties, key=lambda ab: ab[0] ** 2 + ab[1] ** 2)


def _batch_affine(target, a, b, w):
    """Eq. 27 on the edge α + β = 1 by lstsq in α, clipped; a flat edge gives ½."""
    if np.all(a == b):
        return 0.5, 0.5
    sw = np.sqrt(w)
    sol, *_ = np.linalg.lstsq(((a - b) * sw)[:, None], (target - b) * sw, rcond=None)
    t = float(np.clip(sol[0], 0.0, 1.0))
    return t, 1.0 - t


def _batch_rvar(X, gamma=0.8, cutoff=8, mode="absolute"):
    T_all, d = X.shape
    blocks = hand_blocks()
    sv = [_batch_var(X, t, 1, 30, blocks, 10.0) for t in range(T_all)]  # x̂^SV_{t+1}
    dec = [X[t] + (X[t] - X[t - 1]) if t > 0 else X[t] for t in range(T_all)]  # eq. 22, ρ=1
    out = np.full_like(X, np.nan)
    for T in range(T_all - 1):  # predict frame T + 1 from X[:T+1]
        ts = range(max(1, T - cutoff), T + 1)  # frames with a scored past prediction
        alpha, beta = np.full(d, 0.5), np.full(d, 0.5)
        if len(ts):
            w = np.array([0.5 ** (T - t) for t in ts])  # eq. 28
            for i in range(d):
                tgt = np.array([X[t, i] for t in ts])
                a = np.array([sv[t - 1][i] for t in ts])
                b = np.array([dec[t - 1][i] for t in ts])
                if mode == "relative":  # changes from each frame's predecessor
                    o = np.array([X[t - 1, i] for t in ts])
                    alpha[i], beta[i] = _batch_trust(tgt - o, a - o, b - o, w)
                else:  # positions, on the edge α + β = 1
                    alpha[i], beta[i] = _batch_affine(tgt, a, b, w)
        if mode == "relative":  # eq. 26 on changes from x_T
            xT = X[T]
            out[T + 1] = xT + gamma * (alpha * (sv[T] - xT) + beta * (dec[T] - xT))
        else:  # eq. 26 as printed, x̂⁰ = x_T
            out[T + 1] = (1 - gamma) * X[T] + gamma * (alpha * sv[T] + beta * dec[T])
    return out


@pytest.fixture(scope="module")
def real_degrees(fingerfist):
    # A stretch of real motion in degrees / millimetres, 120 frames.
    X = fingerfist[1000:1120].copy()
    X[:, 3:] = np.degrees(X[:, 3:])
    X[:, :3] *= 10.0
    return X


def test_structured_var_online_equals_batch_refit(real_degrees):
    X = real_degrees
    online = one_step_predictions(VAR(order=1, memory=30, blocks=hand_blocks()), X)
    batch = np.array([_batch_var(X, t, 1, 30, hand_blocks(), 10.0) for t in range(len(X) - 1)])
    np.testing.assert_allclose(online[1:], batch, rtol=0, atol=1e-6)


def test_full_var_order_2_online_equals_batch_refit(real_degrees):
    X = real_degrees[:, :6]
    online = one_step_predictions(VAR(order=2, memory=25, max_step=None), X)
    batch = np.array([_batch_var(X, t, 2, 25, [range(6)], np.inf) for t in range(len(X) - 1)])
    np.testing.assert_allclose(online[1:], batch, rtol=0, atol=1e-6)


@pytest.mark.parametrize("mode", ["absolute", "relative"])
def test_rvar_online_equals_batch_refit(real_degrees, mode):
    X = real_degrees[:70]
    online = one_step_predictions(RVAR(mode=mode), X)
    np.testing.assert_allclose(online[1:], _batch_rvar(X, mode=mode)[1:], rtol=0, atol=1e-6)


# -- simple predictors and baselines --------------------------------------------------
def test_simple_predictors_by_hand():
    X = np.array([[0.0, 10.0], [1.0, 12.0], [3.0, 11.0]])
    np.testing.assert_array_equal(one_step_predictions(NoMotion(), X)[1:], X[:-1])
    dec = one_step_predictions(Decelerating(0.4), X)
    np.testing.assert_allclose(dec[1], X[0])
    np.testing.assert_allclose(dec[2], [1.0 + 0.4, 12.0 + 0.8])  # eq. 22


def test_kalman_equals_matrix_form():
    rng = np.random.default_rng(3)
    z = rng.normal(size=(40, 2)).cumsum(0)
    q, r = 0.3, 0.7
    ours = one_step_predictions(KalmanCV(q=q, r=r), z)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = q * np.array([[1 / 3, 1 / 2], [1 / 2, 1.0]])
    H = np.array([[1.0, 0.0]])
    for i in range(2):
        m, P = np.array([z[0, i], 0.0]), np.diag([r, 1e4])
        for t in range(1, len(z)):
            m, P = F @ m, F @ P @ F.T + Q
            assert ours[t, i] == pytest.approx(m[0], abs=1e-9)
            K = P @ H.T / (H @ P @ H.T + r)
            m = m + (K * (z[t, i] - m[0])).ravel()
            P = (np.eye(2) - K @ H) @ P


def test_every_predictor_meets_the_protocol():
    for p in (NoMotion(), Decelerating(), VAR(), RVAR(), KalmanCV()):
        assert isinstance(p, Predictor)
        with pytest.raises(RuntimeError):
            p.predict()
        p.update(np.zeros(26))
        assert p.predict().shape == (26,)
        p.reset()
        with pytest.raises(RuntimeError):
            p.predict()


# -- order selection against statsmodels ------------------------------------------------
def test_select_order_matches_statsmodels(macro):
    y = np.diff(macro, axis=0) * 100
    ref = SmVAR(y).select_order(maxlags=6, trend="n")
    ours = select_order(y, 6)
    for name in ("aic", "bic", "hqic", "fpe"):
        np.testing.assert_allclose(getattr(ours, name), ref.ics[name], rtol=1e-9)
        assert ours.selected[name] == getattr(ref, name)


# -- wrong input ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "make", [NoMotion, Decelerating, VAR, RVAR, KalmanCV], ids=lambda m: m.__name__
)
@pytest.mark.parametrize(
    "bad", [np.array([np.nan] * 26), np.array([np.inf] * 26), np.zeros((2, 13)), np.zeros(25)]
)
def test_bad_input_names_the_argument(make, bad):
    p = make()
    p.update(np.zeros(26))
    with pytest.raises(ValueError, match=r"^x: expected"):
        p.update(bad)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: VAR(order=0), "order"),
        (lambda: VAR(memory=0), "memory"),
        (lambda: VAR(max_step=-1.0), "max_step"),
        (lambda: RVAR(gamma=1.5), "gamma"),
        (lambda: RVAR(cutoff=-1), "cutoff"),
        (lambda: RVAR(mode="sideways"), "mode"),
        (lambda: Decelerating(rho=np.nan), "rho"),
        (lambda: one_step_predictions(NoMotion(), [[0.0], [np.nan]]), "X"),
        (lambda: select_order(np.zeros((10, 3)), 5), "max_order"),
    ],
)
def test_bad_parameters_name_the_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name}: expected"):
        call()


def test_compiled_trust_weights_equal_the_numpy_reference():
    from handvar.predictors import _kernels

    rng = np.random.default_rng(11)
    n, d = 9, 26
    w = 0.5 ** np.arange(n - 1, -1, -1.0)
    x = rng.normal(size=(n, d)).cumsum(0) + 50.0
    a = x + rng.normal(scale=0.3, size=(n, d))
    b = x + rng.normal(scale=0.3, size=(n, d))
    b[:, :3] = a[:, :3]  # exact ties: both predictors agree
    ref = fit_trust_weights(x, a, b, w)
    alpha, beta = np.empty(d), np.empty(d)
    _kernels.trust_weights(np.stack([x, a, b]), w, alpha, beta)
    np.testing.assert_allclose(alpha, ref[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(beta, ref[1], rtol=0, atol=1e-12)
    ref = fit_affine_weights(x, a, b, w)
    _kernels.affine_weights(np.stack([x, a, b]), w, alpha, beta)
    np.testing.assert_allclose(alpha, ref[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(beta, ref[1], rtol=0, atol=1e-12)


def test_a_parameter_that_never_moves_gets_the_minimum_norm_fit(real_degrees):
    # Its block's W W' is singular: the minimum-norm solution (zero), as lstsq gives.
    X = real_degrees[:60].copy()
    X[:, 7] = 3.0  # abduction of the index finger held still
    X[:, 14:17] = X[0, 14:17]  # index finger flexion held still (a 3 × 3 block)
    online = one_step_predictions(VAR(order=1, memory=30, blocks=hand_blocks()), X)
    batch = np.array([_batch_var(X, t, 1, 30, hand_blocks(), 10.0) for t in range(len(X) - 1)])
    np.testing.assert_allclose(online[1:], batch, rtol=0, atol=1e-6)
    var = VAR(order=1, memory=30, blocks=hand_blocks())
    for x in X:
        var.update(x)
    assert np.all(var.coefs[0][7] == 0.0) and np.all(var.coefs[0][14:17] == 0.0)
