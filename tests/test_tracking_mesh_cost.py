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


def test_pad_tips_on_the_mesh_match_the_sphere_mesh_cost(setup):
    """C_k with the fingertips at the pads (design §14.6): the same on both surfaces, which share
    the bones; zero for keypoints at the pads, not for G(x)'s tips."""
    from handvar.tracking import CostSettings, SilhouetteCost
    from handvar.tracking.keypoint_cost import keypoint_points

    hand, rig, x, _, frame = setup
    P = keypoint_points(hand, x, "pad")
    kp = np.stack([np.column_stack([cam.project(P), np.ones(21)]) for cam in rig])
    y = x + np.random.default_rng(3).normal(0.0, 2.0, 26)
    for tips, zero in (("pad", True), ("end", False)):
        s = CostSettings(weight_silhouette=0.0, weight_filling=0.0, keypoint_tips=tips)
        mesh = MeshSilhouetteCost(hand, rig, s)
        spheres = SilhouetteCost(HandModel(), rig, s)
        at_x = mesh.evaluate(x, frame, mesh.draw(frame, np.random.default_rng(0)), keypoints=kp)
        assert (at_x.keypoints < 1e-20) == zero
        a = mesh.evaluate(y, frame, mesh.draw(frame, np.random.default_rng(0)), keypoints=kp)
        b = spheres.evaluate(
            y, spheres.prepare(silhouettes(hand, x, rig)),
            spheres.draw(frame, np.random.default_rng(0)), keypoints=kp,
        )  # fmt: skip
        assert a.keypoints == pytest.approx(b.keypoints, rel=1e-10)
        np.testing.assert_allclose(a.gradient, b.gradient, rtol=1e-8, atol=1e-12)
