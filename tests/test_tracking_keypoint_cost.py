"""Tests of the keypoint term C_k and the front term C_z (handvar.tracking.keypoint_cost)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.render import silhouettes
from handvar.synth import make_sequence, synthetic_keypoints
from handvar.tracking import CostSettings, SilhouetteCost
from handvar.tracking.keypoint_cost import (
    THUMB_BASE,
    frame_keypoints,
    hand_length,
    keypoint_attachment,
    keypoint_points,
    reprojection_error,
    sequence_keypoints,
)
from handvar.vision.keypoints import Keypoints2D

ONLY_JOINTS = CostSettings(weight_silhouette=0.0, weight_filling=0.0)


@pytest.fixture(scope="module")
def setup():
    hand, rig, x = HandModel(), Rig.default(), named_pose("open")
    frame = SilhouetteCost(hand, rig).prepare(silhouettes(hand, x, rig))
    return hand, rig, x, frame


def noisy_keypoints(hand, rig, x, rng, sigma=20.0):
    """Keypoints near the projected joints, with varied confidences and gaps."""
    G = hand.joints(x)
    kp = np.zeros((len(rig), 21, 3))
    for j, cam in enumerate(rig):
        kp[j, :, :2] = cam.project(G) + rng.normal(0.0, sigma, (21, 2))
        kp[j, :, 2] = rng.uniform(0.2, 1.0, 21)
    kp[0, 3, 2] = 0.0  # a missing point
    kp[1, 7, :2] += 120.0  # an outlier, beyond Huber's δ
    return kp


def central_differences(f, x, h=1e-5):
    return np.array([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(x.size)])


@pytest.mark.parametrize("loss", ["huber", "tukey"])
@pytest.mark.parametrize("behind", [False, True])
def test_gradient_matches_central_differences(setup, behind, loss):
    hand, rig, x, frame = setup
    rng = np.random.default_rng(4)
    cost = SilhouetteCost(hand, rig, dataclasses.replace(ONLY_JOINTS, keypoint_loss=loss))
    samples = cost.draw(frame, rng)
    kp = noisy_keypoints(hand, rig, x, rng)
    y = x + rng.normal(0.0, 3.0, 26)
    if behind:  # the palm 520 mm along the left camera's axis towards it: joints behind
        y[:3] -= 520.0 * rig.cameras[0].axis
    terms = cost.evaluate(y, frame, samples, residuals=True, keypoints=kp)
    fd = central_differences(lambda z: cost.evaluate(z, frame, samples, keypoints=kp).cost, y)
    np.testing.assert_allclose(terms.gradient, fd, rtol=1e-5, atol=1e-8 * np.abs(fd).max())
    # the stacked rows reproduce the cost (the robust loss included) and the gradient
    np.testing.assert_allclose(0.5 * terms.residuals @ terms.residuals, terms.cost, rtol=1e-12)
    np.testing.assert_allclose(terms.jacobian.T @ terms.residuals, terms.gradient, atol=1e-12)
    assert (terms.front > 0) == behind


def huber(d, delta):
    return np.where(d <= delta, 0.5 * d**2, delta * (d - 0.5 * delta))


def tukey(d, c):
    """Tukey's biweight as textbooks write it: c²/6 (1 − (1 − (d/c)²)³), c²/6 beyond c."""
    return np.where(d <= c, c**2 / 6.0 * (1.0 - (1.0 - (d / c) ** 2) ** 3), c**2 / 6.0)


@pytest.mark.parametrize(("loss", "rho"), [("huber", huber), ("tukey", tukey)])
def test_keypoint_term_matches_plain_reference(setup, loss, rho):
    hand, rig, x, frame = setup
    rng = np.random.default_rng(5)
    kp = noisy_keypoints(hand, rig, x, rng)
    s = CostSettings(keypoint_loss=loss, keypoint_huber=0.2)
    cost = SilhouetteCost(hand, rig, s)
    terms = cost.evaluate(x, frame, cost.draw(frame, rng), keypoints=kp)
    # reference: numpy projection, hand size f L / z of the palm point, the loss
    G, L, delta = hand.joints(x), hand_length(hand), s.keypoint_huber
    total = 0.0
    for j, cam in enumerate(rig):
        z = cam.camera_from_world(0.5 * (G[0] + G[9])[None])[0, 2]
        size = cam.fx * L / z  # fx = fy in the default rig
        d = np.linalg.norm(cam.project(G) - kp[j, :, :2], axis=1) / size
        assert np.any(d > delta) and np.any(d < delta)  # both branches of the loss
        total += np.sum(kp[j, :, 2] * rho(d, delta))
    assert terms.keypoints == pytest.approx(total / (21 * 2), rel=1e-10)
    plain = cost.evaluate(x, frame, cost.draw(frame, np.random.default_rng(5)))
    assert plain.keypoints == 0.0


def test_a_hand_behind_the_cameras_costs_more_than_the_truth(setup):
    hand, rig, x, frame = setup
    cost = SilhouetteCost(hand, rig)
    behind = x.copy()
    behind[:3] -= 1000.0 * rig.cameras[0].axis  # 500 mm behind the left camera
    assert np.all([c.camera_from_world(hand.joints(behind))[:, 2].max() < 0 for c in rig])
    rng = np.random.default_rng(0)
    at_truth = np.mean([cost.evaluate(x, frame, cost.draw(frame, rng)).cost for _ in range(5)])
    there = cost.evaluate(behind, frame, cost.draw(frame, rng))
    assert there.silhouette == 0.0 and there.filling == 0.0  # the silhouettes see nothing
    assert there.cost > 1e3 * max(at_truth, 1e-3)
    # without the front term the pose behind would fit perfectly
    off = SilhouetteCost(hand, rig, dataclasses.replace(CostSettings(), weight_front=0.0))
    assert off.evaluate(behind, frame, cost.draw(frame, rng)).cost == 0.0


def test_reprojection_error_in_hand_sizes(setup):
    hand, rig, x, _ = setup
    G, L = hand.joints(x), hand_length(hand)
    kp = np.zeros((2, 21, 3))
    for j, cam in enumerate(rig):
        size = cam.fx * L / cam.camera_from_world(0.5 * (G[0] + G[9])[None])[0, 2]
        kp[j, :, :2] = cam.project(G) + np.array([0.6, 0.8]) * size  # 1 hand size away
        kp[j, :, 2] = 1.0
    kp[1, :, 2] = 0.0
    kp[1, :, :2] = np.nan
    assert reprojection_error(G, rig, kp, L) == pytest.approx(1.0, rel=1e-9)
    assert np.isnan(reprojection_error(G, rig, None, L))


def test_keypoint_inputs():
    kp = np.zeros((21, 3))
    kp[:, 2] = 1.0
    kp[4] = np.nan
    a = frame_keypoints([kp, None], 2)
    assert a.shape == (2, 21, 3) and a[0, 4, 2] == 0.0 and np.all(a[1] == 0.0)
    assert np.all(a[0, 4] == 0.0)  # a missing point is (0, 0, 0)
    assert frame_keypoints([None, None], 2) is None
    assert frame_keypoints(np.full((2, 21, 3), np.nan), 2) is None
    with pytest.raises(ValueError, match="2 cameras"):
        frame_keypoints([kp], 2)
    with pytest.raises(ValueError, match="keypoints"):
        frame_keypoints(np.zeros((2, 20, 3)), 2)
    # a sequence: per camera Keypoints2D, (T, n_cams, 21, 3), or per frame
    seq = np.ones((3, 21, 3))
    per_cam = sequence_keypoints([Keypoints2D.from_array(seq), None], 5, 2)
    assert len(per_cam) == 5 and per_cam[3] is None and per_cam[0][1, 0, 2] == 0.0
    stacked = sequence_keypoints(np.ones((2, 2, 21, 3)), 3, 2)
    assert stacked[1].shape == (2, 21, 3) and stacked[2] is None
    per_frame = sequence_keypoints([None, [seq[0], seq[0]], None], 4, 2)
    assert per_frame[0] is None and per_frame[1].shape == (2, 21, 3) and per_frame[3] is None


def test_synthetic_keypoints_noise_and_outliers():
    seq = make_sequence("benchmark", n_frames=40)
    a = synthetic_keypoints(seq, 3.0, 0.1, np.random.default_rng(1))
    b = synthetic_keypoints(seq, 3.0, 0.1, np.random.default_rng(1))
    assert np.array_equal(a, b) and a.shape == (40, 2, 21, 3)
    G = seq.truth.joints
    L = np.linalg.norm(G[:, 0] - G[:, 9], axis=1)
    for j, cam in enumerate(seq.rig):
        uv = cam.project(G.reshape(-1, 3)).reshape(40, 21, 2)
        size = cam.fx * L / cam.camera_from_world(0.5 * (G[:, 0] + G[:, 9]))[:, 2]
        dev = a[:, j, :, :2] - uv
        assert np.all(np.abs(dev) <= size[:, None, None])  # outliers within ±1 hand size
        big = np.linalg.norm(dev, axis=2) > 20.0  # 20 px: 4.7 σ of the noise
        assert 0.07 < big.mean() < 0.11  # 10 % outliers, a few of them displaced little
        inliers = dev[np.abs(dev).max(axis=2) < 15.0]
        assert inliers.std() == pytest.approx(3.0, rel=0.1)
    clean = synthetic_keypoints(seq, 0.0, 0.0)
    np.testing.assert_allclose(clean[:, 0, :, :2], seq.rig.cameras[0].project(
        G.reshape(-1, 3)).reshape(40, 21, 2))  # fmt: skip


# --- where a detected fingertip is compared (design §14.6) ---------------------------------

TIPS_AT = [4, 8, 12, 16, 20]


def pad_keypoints(hand, rig, x):
    """Exact keypoints where MediaPipe marks them (`keypoint_points` with "pad")."""
    P = keypoint_points(hand, x, "pad")
    return np.stack([np.column_stack([cam.project(P), np.ones(21)]) for cam in rig])


def test_pad_points_are_the_pads_centres_and_the_thumb_base_up_its_metacarpal():
    hand = HandModel()
    rng = np.random.default_rng(11)
    for _ in range(5):
        x = named_pose("open") + rng.normal(0.0, 10.0, 26)
        G, P = hand.joints(x), keypoint_points(hand, x, "pad")
        others = np.setdiff1d(np.arange(21), [1, *TIPS_AT])
        np.testing.assert_array_equal(P[others], G[others])  # the other 15: G(x)'s
        # the thumb's base THUMB_BASE of the way from G(x)'s CMC to its MCP
        np.testing.assert_allclose(P[1], G[1] + THUMB_BASE * (G[2] - G[1]), atol=1e-9)
        along = G[TIPS_AT] - P[TIPS_AT]
        np.testing.assert_allclose(np.linalg.norm(along, axis=1), hand.shape.radii[:, 3])
        dip = G[[t - 1 for t in TIPS_AT]]
        bone = (G[TIPS_AT] - dip) / np.linalg.norm(G[TIPS_AT] - dip, axis=1)[:, None]
        np.testing.assert_allclose(along / hand.shape.radii[:, 3, None], bone, atol=1e-12)
    # the pad's centre is the centre of the distal cone-sphere's last sphere
    prim = hand.primitives
    _, local = keypoint_attachment(hand, "pad")
    for k, joint in enumerate(TIPS_AT):
        on_bone = prim.bone == 3 + 3 * k  # the distal bone of digit k
        centres = prim.centres[on_bone].reshape(-1, 3)
        radii = prim.radii[on_bone].ravel()
        last = np.argmax(centres[:, 1])
        np.testing.assert_allclose(centres[last], local[joint], atol=1e-12)
        assert radii[last] == pytest.approx(hand.shape.radii[k, 3])
    assert keypoint_points(hand, x, "end") is not None
    np.testing.assert_array_equal(keypoint_points(hand, x), hand.joints(x))


@pytest.mark.parametrize("loss", ["huber", "tukey"])
def test_gradient_with_pad_tips_matches_central_differences(setup, loss):
    hand, rig, x, frame = setup
    rng = np.random.default_rng(6)
    s = dataclasses.replace(ONLY_JOINTS, keypoint_loss=loss, keypoint_tips="pad")
    cost = SilhouetteCost(hand, rig, s)
    samples = cost.draw(frame, rng)
    kp = noisy_keypoints(hand, rig, x, rng)
    y = x + rng.normal(0.0, 3.0, 26)
    terms = cost.evaluate(y, frame, samples, residuals=True, keypoints=kp)
    fd = central_differences(lambda z: cost.evaluate(z, frame, samples, keypoints=kp).cost, y)
    np.testing.assert_allclose(terms.gradient, fd, rtol=1e-5, atol=1e-8 * np.abs(fd).max())
    np.testing.assert_allclose(terms.jacobian.T @ terms.residuals, terms.gradient, atol=1e-12)


def test_the_keypoint_term_compares_the_tips_chosen(setup):
    hand, rig, x, frame = setup
    kp = pad_keypoints(hand, rig, x)
    rng = np.random.default_rng(7)
    pad = SilhouetteCost(hand, rig, dataclasses.replace(ONLY_JOINTS, keypoint_tips="pad"))
    end = SilhouetteCost(hand, rig, ONLY_JOINTS)
    at_pad = pad.evaluate(x, frame, pad.draw(frame, rng), keypoints=kp).keypoints
    at_end = end.evaluate(x, frame, end.draw(frame, rng), keypoints=kp).keypoints
    assert at_pad < 1e-20
    # reference: G(x)'s five tips and thumb base off the keypoints, Huber's loss
    G, L = hand.joints(x), hand_length(hand)
    total = 0.0
    for j, cam in enumerate(rig):
        z = cam.camera_from_world(0.5 * (G[0] + G[9])[None])[0, 2]
        d = np.linalg.norm(cam.project(G) - kp[j, :, :2], axis=1) / (cam.fx * L / z)
        assert np.count_nonzero(d) == 6
        total += np.sum(huber(d, 0.1))
    assert at_end == pytest.approx(total / (21 * 2), rel=1e-10)
    assert at_end > 1e-6


def test_tips_are_checked():
    with pytest.raises(ValueError, match="keypoint_tips: expected one of"):
        CostSettings(keypoint_tips="tip")
    with pytest.raises(ValueError, match="tips: expected one of"):
        keypoint_attachment(HandModel(), "nail")
