"""The tracker's cost on the skinned mesh hand."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.render import silhouettes
from handvar.tracking import Tracker
from handvar.tracking.mesh_cost import MeshSilhouetteCost


@pytest.fixture(scope="module")
def setup():
    hand = HandModel(surface="mesh")
    rig = Rig.default()
    x = named_pose("pinch")
    cost = MeshSilhouetteCost(hand, rig)
    frame = cost.prepare(silhouettes(hand, x, rig))
    return hand, rig, x, cost, frame


def test_zero_at_the_true_pose(setup):
    """The mesh's own silhouettes: every sample inside, every pixel covered."""
    _, _, x, cost, frame = setup
    terms = cost.evaluate(x, frame, cost.draw(frame, np.random.default_rng(0)))
    assert terms.cost == 0.0
    assert not np.any(terms.gradient)


def test_gradient_is_jt_r_and_matches_central_differences(setup):
    """With the samples and matched targets fixed, the gradient is the derivative of
    the cost (targets do not switch for steps of 1e-4)."""
    _, _, x, cost, frame = setup
    rng = np.random.default_rng(1)
    xp = x + np.concatenate([[3.0, -2.0, 2.0], rng.normal(0, 3, 23)])
    samples = cost.draw(frame, rng)
    terms = cost.evaluate(xp, frame, samples, residuals=True)
    assert terms.cost > 0.01
    np.testing.assert_allclose(terms.gradient, terms.jacobian.T @ terms.residuals)
    np.testing.assert_allclose(0.5 * terms.residuals @ terms.residuals, terms.cost)
    eps = 1e-4
    fd = np.empty(26)
    for i in range(26):
        a, b = xp.copy(), xp.copy()
        a[i] += eps
        b[i] -= eps
        fd[i] = cost.evaluate(a, frame, samples).cost - cost.evaluate(b, frame, samples).cost
        fd[i] /= 2 * eps
    np.testing.assert_allclose(terms.gradient, fd, atol=1e-6 * np.abs(fd).max() + 1e-12)


def test_tracker_uses_the_mesh_cost_and_recovers_a_pose(setup):
    """A few frames of the same pose from a start 5 mm / 5° off: the joint error falls."""
    hand, rig, x, _, _ = setup
    tracker = Tracker(rig, hand, rng=np.random.default_rng(2))
    assert isinstance(tracker.cost, MeshSilhouetteCost)
    masks = silhouettes(hand, x, rig)
    start = x.copy()
    start[:3] += 5.0
    start[3:6] += 5.0
    tracker.reset(start)
    err0 = np.linalg.norm(hand.joints(start) - hand.joints(x), axis=1).mean()
    for _ in range(3):
        res = tracker.step(masks)
    err = np.linalg.norm(hand.joints(res.pose) - hand.joints(x), axis=1).mean()
    assert err < 0.5 * err0, (err0, err)


def test_needs_a_mesh_model():
    with pytest.raises(ValueError, match="hand: expected a HandModel"):
        MeshSilhouetteCost(HandModel(), Rig.default())
