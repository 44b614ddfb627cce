"""Tests of stochastic meta-descent (handvar.tracking.smd)."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.tracking.smd import SMDSettings, initial_gains, minimise, smd_step


def _quadratic(A, b, rng, noise):
    """½ (x − b)ᵀ A (x − b) with a noisy gradient; residual Jacobian A^{1/2}."""
    w, V = np.linalg.eigh(A)
    L = V @ np.diag(np.sqrt(w)) @ V.T

    def objective(x, need_jacobian):
        d = x - b
        g = A @ d + noise * rng.normal(size=x.shape)
        return 0.5 * d @ A @ d, g, L, None

    return objective


@pytest.mark.parametrize("precondition", [True, False])
def test_converges_on_a_quadratic_with_known_minimum(precondition):
    rng = np.random.default_rng(0)
    Q, _ = np.linalg.qr(rng.normal(size=(5, 5)))
    A = Q @ np.diag([0.2, 0.5, 1.0, 2.0, 4.0]) @ Q.T
    b = rng.normal(size=5)
    s = SMDSettings(threshold=1e-10, max_iterations=400, precondition=precondition)
    res = minimise(_quadratic(A, b, rng, 1e-3), np.zeros(5), s, gains=np.full(5, 0.2),
                   lower=None, upper=None)  # fmt: skip
    np.testing.assert_allclose(res.x, b, atol=5e-3)
    assert res.costs[-1] < 1e-4 * res.costs[0]


def test_gains_grow_along_a_consistent_gradient():
    # 1-D, gradient always 1: p ← p (1 + μ p) (hand-computed), x moves by p each step
    x, p, v = np.array([0.0]), np.array([0.5]), np.zeros(1)
    xs = []
    for _ in range(3):
        x, p, v = smd_step(x, p, v, np.array([1.0]), meta_gain=0.1, lower=None, upper=None)
        xs.append((x[0], p[0]))
    p1 = 0.5
    p2 = p1 * (1 + 0.1 * p1)
    p3 = p2 * (1 + 0.1 * p2)
    np.testing.assert_allclose(xs, [(-p1, p1), (-p1 - p2, p2), (-p1 - p2 - p3, p3)])


def test_gain_shrinks_at_most_by_half_and_clamps():
    x, p, v = smd_step(np.array([0.0]), np.array([1.0]), np.array([100.0]), np.array([1.0]),
                       lower=np.array([-0.25]), upper=np.array([1.0]))  # fmt: skip
    assert p[0] == 0.5  # max(½, 1 − 0.1 · 100)
    assert x[0] == -0.25  # clamped to the lower limit
    assert v[0] == -0.5


def test_horizon_uses_the_curvature_product():
    # λ > 0: v ← λ v − p (g + λ G v), hand-computed
    _, p, v = smd_step(np.zeros(2), np.ones(2), np.array([1.0, -1.0]), np.array([0.5, 0.5]),
                       np.array([2.0, 3.0]), horizon=0.5, lower=None, upper=None)  # fmt: skip
    p_new = np.maximum(0.5, 1 - 0.1 * np.array([0.5, -0.5]))
    np.testing.assert_allclose(p, p_new)
    np.testing.assert_allclose(
        v, 0.5 * np.array([1.0, -1.0]) - p_new * (0.5 + 0.5 * np.array([2.0, 3.0]))
    )


def test_stops_below_threshold_and_initial_gains():
    calls = []

    def objective(x, need):
        calls.append(x.copy())
        return 0.001, np.ones(26), None, np.ones(26)

    res = minimise(objective, np.zeros(26))
    assert res.iterations == 1 and res.converged and len(calls) == 1
    p = initial_gains()
    assert p[0] == 2.5 and p[3] == 0.4 and p[6] == 0.2 and p[25] == 0.2


def test_bad_settings_raise():
    with pytest.raises(ValueError, match="max_iterations"):
        SMDSettings(max_iterations=0)
    with pytest.raises(ValueError, match="gain_finger"):
        SMDSettings(gain_finger=-1.0)
    with pytest.raises(ValueError, match="x0"):
        minimise(lambda x, n: (0.0, x, None, None), np.array([np.nan] * 26))


def test_gain_growth_is_bounded_per_step():
    # Aligned successive gradients make 1 − μ g v large; the factor is capped.
    x, p, v = np.zeros(2), np.ones(2), np.array([-10.0, 0.0])
    g = np.array([10.0, 1.0])
    _, p_new, _ = smd_step(x, p, v, g, meta_gain=0.1, max_factor=2.0, lower=None, upper=None)
    np.testing.assert_allclose(p_new, [2.0, 1.0])  # 1 + 0.1·100 = 11 → 2; factor 1 stays
    _, p_raw, _ = smd_step(x, p, v, g, meta_gain=0.1, lower=None, upper=None)
    np.testing.assert_allclose(p_raw, [11.0, 1.0])  # the paper's unbounded rule


def test_projection_keeps_the_iterates_in_the_set_and_stop_replaces_the_threshold():
    # minimum at b = (2, 2) outside the half-plane x0 + x1 ≤ 1; the constrained minimum is
    # (½, ½), cost 2.25 (hand-computed); per-parameter gains stop on the boundary near it
    rng = np.random.default_rng(0)
    A, b = np.eye(2), np.array([2.0, 2.0])

    def project(x):
        excess = x.sum() - 1.0
        return x - max(excess, 0.0) / 2.0

    seen = []

    def objective(x, need_jacobian):
        seen.append(x.copy())
        return _quadratic(A, b, rng, 0.0)(x, need_jacobian)

    s = SMDSettings(threshold=0.0, max_iterations=60)
    res = minimise(objective, np.array([3.0, -3.0]), s, gains=np.ones(2), lower=None,
                   upper=None, project=project)  # fmt: skip
    assert all(x.sum() <= 1.0 + 1e-12 for x in seen)  # the start is projected too
    assert res.x.sum() == pytest.approx(1.0, abs=1e-9)
    assert 0.5 * np.sum((res.x - b) ** 2) == pytest.approx(2.25, rel=0.01)
    stopped = minimise(objective, np.zeros(2), s, gains=np.ones(2), lower=None, upper=None,
                       stop=lambda cost: cost < 3.0)  # fmt: skip
    assert stopped.converged and stopped.costs[-1] < 3.0 and np.all(stopped.costs[:-1] >= 3.0)
