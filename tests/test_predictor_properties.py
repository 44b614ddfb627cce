"""Properties of the predictors on random series (hypothesis), and their argument checks.

References: numpy.linalg.lstsq of the online VAR's window (the minimum-norm least
squares solution, eq. 14); every face of eq. 27's triangle solved apart by lstsq; the
property x + c ↦ x̂ + c that every predictor must have.  The series are drawn from
seeded generators whose seeds, sizes, offsets and scales hypothesis chooses.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from handvar.predictors import (
    RVAR,
    VAR,
    AdaptiveBank,
    Decelerating,
    KalmanCV,
    NoMotion,
    OneEuro,
    _kernels,
    fit_affine_weights,
    fit_trust_weights,
    hand_blocks,
    one_step_predictions,
    second_differences,
)

EPS = np.finfo(float).eps
FEW = settings(max_examples=50, deadline=None, database=None)
seeds = st.integers(0, 2**32 - 1)


def walk(seed: int, T: int, d: int, scale: float = 1.0) -> np.ndarray:
    """A smooth random motion: integrated random velocities plus a little noise."""
    rng = np.random.default_rng(seed)
    v = np.cumsum(rng.normal(scale=0.3, size=(T, d)), axis=0)
    return scale * (np.cumsum(v, axis=0) + rng.normal(scale=0.1, size=(T, d)))


# -- offset equivariance: x + c ↦ x̂ + c ---------------------------------------------
PREDICTORS = {
    "NoMotion": (NoMotion, 4),
    "Decelerating": (lambda: Decelerating(0.4), 4),
    "KalmanCV": (lambda: KalmanCV(q=0.5, r=2.0), 4),
    "VAR full": (lambda: VAR(order=2, memory=30, max_step=None), 4),
    "VAR structured": (lambda: VAR(memory=30, blocks=hand_blocks()), 26),
    "RVAR edge": (lambda: RVAR(mode="edge"), 26),
    "RVAR relative": (lambda: RVAR(mode="relative"), 26),
}


@pytest.mark.parametrize("name", list(PREDICTORS))
@FEW
@given(seed=seeds, offset=st.floats(-1e6, 1e6), T=st.integers(2, 70))
@example(seed=115, offset=16384.0, T=34)  # once off by 3e-5 against 1e-6 · scale alone
@example(seed=11929, offset=254.0, T=35)  # a full VAR's prediction of -43 230: off by 1.2e-4
def test_every_predictor_moves_with_a_constant_offset(name, seed, offset, T):
    make, d = PREDICTORS[name]
    X = walk(seed, T, d)
    base = one_step_predictions(make(), X)
    moved = one_step_predictions(make(), X + offset) - offset
    # The input itself is rounded to ε·|c|; the predictors may amplify that by the
    # conditioning of their fits (up to 1e8 for a full VAR on 30 frames of a smooth
    # walk: seed 115, c = 16384, T = 34 was off by 3e-5), never by the level of the data.
    # An ill-conditioned fit may also predict far outside the data (a full VAR without a
    # step cap: -43 230 from a walk within ±75, seed 11929, c = 254, T = 35), and its
    # rounding is then relative to that prediction (there 2.8e-9 of it): rtol 1e-8.
    scale = 1.0 + np.abs(X).max()
    np.testing.assert_allclose(moved, base, rtol=1e-8,
                               atol=1e-6 * scale + 1e8 * EPS * abs(offset))  # fmt: skip


@pytest.mark.parametrize("mode", ["edge", "relative"])
@pytest.mark.parametrize("offset", [1e9, -1e9])
def test_rvar_is_not_biased_by_a_large_offset(mode, offset):
    X = walk(7, 120, 26)
    base = one_step_predictions(RVAR(mode=mode), X)
    moved = one_step_predictions(RVAR(mode=mode), X + offset) - offset
    err = np.nanmean(np.abs(base[1:] - X[1:]))
    # The inputs carry ε·1e9 ≈ 1.2e-7 of rounding; the shift stays at that scale,
    # far below the predictor's own error.
    assert np.nanmax(np.abs(moved - base)) < 1e-4
    assert np.nanmax(np.abs(moved - base)) < 1e-3 * err


# -- the online VAR against lstsq of its window ---------------------------------------
def lstsq_window(X, order, memory, blocks):
    """Per block, (coefficients A_1..A_p in statsmodels' layout, cond) by lstsq."""
    y = second_differences(X)
    n_eq = min(max(len(y) - order, 0), memory)
    d = X.shape[1]
    A = np.zeros((order, d, d))
    conds = [1.0]
    for block in blocks:
        b = np.array(block)
        k = len(b)
        if n_eq < k * order:
            continue
        rows = range(len(y) - n_eq, len(y))
        W = np.array([np.concatenate([y[t - lag][b] for lag in range(1, order + 1)]) for t in rows])
        coef, _, _, sv = np.linalg.lstsq(W, y[len(y) - n_eq :][:, b], rcond=None)
        kept = sv[sv > EPS * max(W.shape) * sv[0]] if sv[0] > 0 else [1.0]
        conds.append(kept[0] / kept[-1])
        for lag in range(order):
            A[lag][np.ix_(b, b)] = coef[lag * k : (lag + 1) * k].T
    return A, max(conds)


@st.composite
def var_cases(draw):
    d = draw(st.integers(1, 5))
    order = draw(st.integers(1, 2))
    structured = draw(st.booleans()) and d > 1
    if structured:
        cut = draw(st.integers(1, d - 1))
        blocks = [list(range(cut)), list(range(cut, d))]
    else:
        blocks = [list(range(d))]
    kmax = max(len(b) for b in blocks)
    memory = draw(st.integers(kmax * order + 1, 40))
    T = draw(st.integers(3, 140))
    X = walk(draw(seeds), T, d)
    kind = draw(st.sampled_from(["plain", "frozen", "frozen some", "scale drop", "offset"]))
    if kind.startswith("frozen"):
        start = draw(st.integers(0, T - 1))
        stop = draw(st.integers(start, T))
        cols = slice(None) if kind == "frozen" else slice(0, draw(st.integers(1, d)))
        X[start:stop, cols] = X[start, cols]
        X[stop:, cols] += X[start, cols] - X[stop - 1, cols] if stop < T else 0.0
    elif kind == "scale drop":
        at = draw(st.integers(1, T - 1))
        X = np.concatenate([1e6 * X[:at], 1e-3 * (X[at:] - X[at])])
    else:
        X = X + draw(st.floats(-1e9, 1e9))
    return X, order, memory, blocks


@FEW
@given(case=var_cases())
def test_online_var_is_the_minimum_norm_lstsq_fit_of_its_window(case):
    X, order, memory, blocks = case
    var = VAR(order=order, memory=memory, blocks=blocks, max_step=None)
    for t, x in enumerate(X):
        var.update(x)
        ref, cond = lstsq_window(X[: t + 1], order, memory, blocks)
        # Both are backward-stable solutions: they agree to the conditioning of the
        # window times the rounding, relative to the coefficients' size.
        tol = (1e-10 + 1e-13 * cond) * (1.0 + np.abs(ref).max())
        np.testing.assert_allclose(var.coefs, ref, rtol=0, atol=tol)


def test_online_var_after_every_parameter_froze_is_zero():
    # The window holds only zero second differences: the minimum-norm fit is 0.
    X = np.concatenate([walk(3, 200, 26), np.repeat(walk(3, 200, 26)[-1:], 200, axis=0)])
    var = VAR(memory=150)
    for x in X:
        var.update(x)
    assert np.all(var.coefs == 0.0)
    np.testing.assert_array_equal(var.predict(), X[-1])


# -- eq. 27: the exact constrained minimum ----------------------------------------------
def exact_trust(x, a, b, w):
    """Min of eq. 27 over the triangle: every face by lstsq, vertices, best kept."""
    sw = np.sqrt(w)

    def cost(al, be):
        return float(np.sum(w * (x - al * a - be * b) ** 2))

    def solve(cols, rhs):
        sol, *_ = np.linalg.lstsq(np.stack(cols, 1) * sw[:, None], rhs * sw, rcond=None)
        return sol

    cands = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), tuple(solve((a, b), x))]
    t = np.clip(solve((a,), x)[0], 0, 1)
    cands.append((t, 0.0))
    t = np.clip(solve((b,), x)[0], 0, 1)
    cands.append((0.0, t))
    t = np.clip(solve((a - b,), x - b)[0], 0, 1)
    cands.append((t, 1 - t))
    return min(cost(al, be) for al, be in cands if al >= 0 and be >= 0 and al + be <= 1)


@st.composite
def trust_cases(draw):
    rng = np.random.default_rng(draw(seeds))
    n = draw(st.integers(1, 9))
    d = 6
    w = 0.5 ** np.arange(n - 1, -1, -1.0)
    level = draw(st.sampled_from([0.0, 1.0, 1e3, 1e6]))
    x = rng.normal(size=(n, d)).cumsum(0) + level
    a = x + rng.normal(scale=draw(st.floats(1e-6, 10.0)), size=(n, d))
    b = rng.uniform(-1, 2, d) * x + rng.normal(scale=0.5, size=(n, d))
    b[:, 0] = a[:, 0]  # a tie: both predictors agree
    a[:, 1] = 0.0  # one predictor says zero
    b[:, 2] = 2.0 * a[:, 2]  # collinear predictions
    return x, a, b, w


@FEW
@given(case=trust_cases())
def test_eq_27_reaches_the_exact_constrained_minimum(case):
    x, a, b, w = case
    alpha, beta = fit_trust_weights(x, a, b, w)
    assert np.all(alpha >= 0) and np.all(beta >= 0) and np.all(alpha + beta <= 1)
    for i in range(x.shape[1]):
        ours = float(np.sum(w * (x[:, i] - alpha[i] * a[:, i] - beta[i] * b[:, i]) ** 2))
        exact = exact_trust(x[:, i], a[:, i], b[:, i], w)
        S = np.sum(w * (np.abs(x[:, i]) + np.abs(a[:, i]) + np.abs(b[:, i])) ** 2)
        assert ours <= exact * (1 + 1e-9) + 64 * EPS * np.sqrt(exact * S) + 1e-28 * S
    # The compiled route gives the same weights.
    al, be = np.empty(x.shape[1]), np.empty(x.shape[1])
    _kernels.trust_weights(np.stack([x, a, b]), w, al, be)
    np.testing.assert_allclose(al, alpha, rtol=0, atol=1e-12)
    np.testing.assert_allclose(be, beta, rtol=0, atol=1e-12)


@FEW
@given(case=trust_cases(), offset=st.floats(-1e6, 1e6))
def test_eq_27_on_the_edge_is_exact_and_origin_free(case, offset):
    x, a, b, w = case
    alpha, beta = fit_affine_weights(x, a, b, w)
    np.testing.assert_array_equal(alpha + beta, 1.0)
    assert np.all((alpha >= 0) & (alpha <= 1))
    for i in range(x.shape[1]):
        xi, ai, bi = x[:, i], a[:, i], b[:, i]
        ours = float(np.sum(w * (xi - alpha[i] * ai - beta[i] * bi) ** 2))
        # The edge's minimum by lstsq in α, clipped, and its two ends.
        sol, *_ = np.linalg.lstsq(((ai - bi) * np.sqrt(w))[:, None], (xi - bi) * np.sqrt(w))
        ends = [0.0, 1.0, float(np.clip(sol[0], 0, 1))]
        exact = min(float(np.sum(w * (xi - t * ai - (1 - t) * bi) ** 2)) for t in ends)
        S = np.sum(w * (np.abs(xi - bi) + np.abs(ai - bi)) ** 2)
        assert ours <= exact * (1 + 1e-9) + 64 * EPS * np.sqrt(exact * S) + 1e-28 * S
    # The compiled route gives the same weights.
    al, be = np.empty(x.shape[1]), np.empty(x.shape[1])
    _kernels.affine_weights(np.stack([x, a, b]), w, al, be)
    np.testing.assert_allclose(al, alpha, rtol=0, atol=1e-12)
    np.testing.assert_allclose(be, beta, rtol=0, atol=1e-12)
    # Shifting all three columns moves the cost by nothing: α changes only where the
    # minimum is flat to rounding.
    moved, _ = fit_affine_weights(x + offset, a + offset, b + offset, w)
    cost = w[:, None] * ((x - b)[None] - np.stack([alpha, moved])[:, None] * (a - b)) ** 2
    best, shifted = cost.sum(1)
    # The shifted inputs are rounded to ε·(|x| + |c|): that is the only slack.
    S = (w[:, None] * (np.abs(x) + np.abs(a) + np.abs(b) + 3 * abs(offset)) ** 2).sum(0)
    assert np.all(shifted <= best * (1 + 1e-9) + 64 * EPS * np.sqrt(best * S) + 1e-28 * S)


@FEW
@given(seed=seeds, n=st.integers(1, 9), s=st.floats(0.05, 0.95))
def test_eq_27_ties_go_to_the_smallest_weights(seed, n, s):
    # a = b: every α + β = s minimises eq. 27 when x = s·a; the smallest is α = β = s/2.
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 1)) + 3.0
    alpha, beta = fit_trust_weights(s * a, a, a, 0.5 ** np.arange(n - 1, -1, -1.0))
    np.testing.assert_allclose([alpha[0], beta[0]], [s / 2, s / 2], rtol=1e-9)


# -- wrong configurations -------------------------------------------------------------------
def test_a_full_var_too_short_to_fit_is_refused_at_the_first_update():
    var = VAR(memory=10)
    with pytest.raises(ValueError) as info:
        var.update(np.zeros(26))
    assert str(info.value) == (
        "memory: expected an integer >= 27 for order 1 with a block of 26 parameters; got 10"
    )


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (
            lambda: VAR(order=3, memory=60, blocks=[range(26)]),
            ValueError,
            "memory: expected an integer >= 79 for order 3 with a block of 26 parameters; got 60",
        ),
        (lambda: VAR(blocks=[[0, 0.5]]), TypeError, "blocks: expected an integer >= 0; got 0.5"),
        (lambda: VAR(blocks=[[0, -1]]), ValueError, "blocks: expected an integer >= 0; got -1"),
        (lambda: VAR(blocks=[[0], []]), ValueError, "blocks: expected non-empty blocks"),
        (lambda: VAR(blocks=[[0, 1], [1]]), ValueError, "blocks: expected disjoint blocks"),
        (lambda: VAR(order=1.0), TypeError, "order: expected an integer >= 1; got 1.0"),
        (lambda: VAR(max_step=0.0), ValueError, "max_step: expected a finite number > 0.0"),
        (lambda: KalmanCV(q="a"), TypeError, "q: expected a finite number > 0.0; got 'a'"),
        (lambda: Decelerating(rho="a"), TypeError, "rho: expected"),
        (lambda: RVAR(cutoff=2.5), TypeError, "cutoff: expected an integer >= 0; got 2.5"),
        (lambda: RVAR(structured="svar"), TypeError, "structured: expected a predictor"),
        (lambda: RVAR(mode="sideways"), ValueError, "mode: expected one of paper, edge, relative"),
    ],
)
def test_misconfigurations_are_refused_naming_the_argument(call, error, message):
    with pytest.raises(error) as info:
        call()
    assert str(info.value).startswith(message)


@pytest.mark.parametrize(
    "make",
    [NoMotion, Decelerating, KalmanCV, VAR, RVAR, OneEuro, AdaptiveBank],
    ids=lambda m: m.__name__,
)
def test_an_empty_frame_is_refused_naming_the_argument(make):
    message = r"^x: expected a vector of at least one value; got shape \(0,\)"
    with pytest.raises(ValueError, match=message):
        make().update(np.array([]))


def test_every_paper_configuration_is_accepted():
    VAR(memory=150)  # the full VAR: 150 >= 27
    VAR(memory=30, blocks=hand_blocks())  # the structured VAR: 30 >= 4
    RVAR()
    VAR(memory=150).update(np.zeros(26))
