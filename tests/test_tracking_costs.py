"""Tests of the tracking cost (handvar.tracking.costs)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from handvar.camera import Camera, Rig
from handvar.hand import HandModel, named_pose
from handvar.render import silhouettes
from handvar.tracking.costs import (
    CostSettings,
    SilhouetteCost,
    cost_reference,
    nearest_silhouette_field,
)
from handvar.tracking.smd import SMDSettings


@pytest.fixture(scope="module")
def setup():
    hand, rig = HandModel(), Rig.default()
    truth = named_pose("pinch")
    cost = SilhouetteCost(hand, rig)
    frame = cost.prepare(silhouettes(hand, truth, rig))
    rng = np.random.default_rng(3)
    x = truth.copy()
    x[:3] += [4.0, -3.0, 5.0]
    x[6:] += rng.normal(0.0, 6.0, 20)
    return hand, rig, cost, frame, truth, x


def test_nearest_field_matches_exact_transform():
    # independent: scipy's exact Euclidean distance transform
    rng = np.random.default_rng(0)
    mask = ndimage.binary_dilation(rng.random((120, 160)) > 0.995, iterations=4)
    nearest, roi, pixels = nearest_silhouette_field(mask, margin=200)
    assert tuple(roi) == (0, 0, 160, 120)
    assert np.array_equal(mask[pixels[:, 1].astype(int), pixels[:, 0].astype(int)],
                          np.ones(len(pixels), bool))  # fmt: skip
    exact = ndimage.distance_transform_edt(~mask)
    v, u = np.mgrid[0:120, 0:160]
    ours = np.hypot(nearest[..., 0] - u, nearest[..., 1] - v)
    assert np.all(mask[nearest[..., 1].astype(int), nearest[..., 0].astype(int)])
    assert np.all(ours >= exact - 1e-9)
    assert np.all(ours <= exact * 1.05 + 0.5)  # approximate 5x5 mask, fraction of a pixel


def test_compiled_route_matches_numpy_route(setup):
    hand, rig, cost, frame, _, x = setup
    samples = cost.draw(frame, np.random.default_rng(1))
    fast = cost.evaluate(x, frame, samples, residuals=True)
    slow = cost_reference(hand, rig, frame, samples, x)
    assert fast.cost > 0.01
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-10)
    np.testing.assert_allclose(fast.silhouette, slow.silhouette, rtol=1e-10)
    np.testing.assert_allclose(fast.filling, slow.filling, rtol=1e-10)
    np.testing.assert_allclose(fast.gradient, slow.gradient, rtol=1e-8, atol=1e-12)
    # the stacked residuals reproduce the cost and the gradient
    np.testing.assert_allclose(0.5 * fast.residuals @ fast.residuals, fast.cost, rtol=1e-12)
    np.testing.assert_allclose(fast.jacobian.T @ fast.residuals, fast.gradient, atol=1e-14)
    np.testing.assert_allclose(
        fast.gauss_newton_diagonal, np.sum(fast.jacobian**2, axis=0), rtol=1e-10, atol=1e-16
    )


def test_gradient_matches_central_differences(setup):
    # same fixed samples: the matched targets s* are piecewise constant, so use steps
    # small enough not to move a projected point to another pixel
    _, _, cost, frame, _, x = setup
    samples = cost.draw(frame, np.random.default_rng(2))
    g = cost.evaluate(x, frame, samples).gradient
    eps = 1e-6
    fd = np.empty(26)
    for i in range(26):
        e = np.zeros(26)
        e[i] = eps
        fd[i] = (cost.evaluate(x + e, frame, samples).cost
                 - cost.evaluate(x - e, frame, samples).cost) / (2 * eps)  # fmt: skip
    np.testing.assert_allclose(g, fd, rtol=1e-4, atol=1e-6 * np.abs(g).max())


def test_cost_is_small_at_truth_and_grows_with_misfit(setup):
    _, _, cost, frame, truth, x = setup
    rng = np.random.default_rng(4)
    at_truth = [cost.evaluate(truth, frame, cost.draw(frame, rng)).cost for _ in range(5)]
    off = [cost.evaluate(x, frame, cost.draw(frame, rng)).cost for _ in range(5)]
    threshold = SMDSettings().threshold
    assert max(at_truth) < threshold
    assert min(off) > threshold


def test_distortion_matches_camera_projection():
    # a camera with distortion: the compiled projection equals Camera.project_jacobian
    hand = HandModel()
    base = Rig.default()
    cams = [Camera(c.fx, c.fy, c.cx, c.cy, dist=[-0.2, 0.05, 1e-3, -2e-3, 0.01, 0.01, 0.0, 0.02],
                   R=c.R, t=c.t) for c in base]  # fmt: skip
    rig = Rig(tuple(cams), base.names)
    truth = named_pose("open")
    cost = SilhouetteCost(hand, rig)
    frame = cost.prepare(silhouettes(hand, truth, rig))
    x = truth + np.r_[3.0, -2.0, 4.0, [2.0] * 23]
    samples = cost.draw(frame, np.random.default_rng(5))
    fast = cost.evaluate(x, frame, samples)
    slow = cost_reference(hand, rig, frame, samples, x)
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-10)
    np.testing.assert_allclose(fast.gradient, slow.gradient, rtol=1e-8, atol=1e-12)


def test_bad_input_raises():
    hand, rig = HandModel(), Rig.default()
    cost = SilhouetteCost(hand, rig)
    with pytest.raises(ValueError, match="masks"):
        cost.prepare(np.zeros((1, 480, 640), bool))
    with pytest.raises(ValueError, match="non-empty"):
        cost.prepare(np.zeros((2, 480, 640), bool))
    with pytest.raises(ValueError, match="pixel_scale"):
        CostSettings(pixel_scale=0.0)
    frame = cost.prepare(silhouettes(hand, named_pose("open"), rig))
    with pytest.raises(ValueError, match="x"):
        cost.evaluate(np.full(26, np.nan), frame, cost.draw(frame, np.random.default_rng(0)))
