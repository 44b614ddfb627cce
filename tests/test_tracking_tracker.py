"""Tests of the tracker (handvar.tracking.tracker) on synthetic frames with ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.camera import Rig
from handvar.evaluation.metrics import mean_joint_error
from handvar.hand import HandModel
from handvar.predictors import RVAR, NoMotion
from handvar.render import silhouettes
from handvar.synth.sequences import benchmark, make_sequence
from handvar.tracking.tracker import Tracker


@pytest.fixture(scope="module")
def first60():
    return make_sequence("benchmark", n_frames=60)


@pytest.mark.parametrize("seed", [0, 1])
def test_one_frame_recovers_a_perturbed_pose(seed):
    # frame 90 of the benchmark (a three-quarter view of the hand), every finger angle
    # 10° off and the palm 10 mm off along each axis
    hand, rig = HandModel(), Rig.default()
    truth = benchmark(0)[90]
    x0 = truth.copy()
    x0[:3] += 10.0
    x0[6:] += 10.0 if seed else -10.0
    masks = silhouettes(hand, truth, rig)
    before = mean_joint_error(hand.joints(truth), hand.joints(x0))
    tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(seed))
    tracker.reset(x0)
    result = tracker.step(masks)
    after = mean_joint_error(hand.joints(truth), hand.joints(result.pose))
    assert before > 15.0
    assert after < 5.0


def test_tracks_sixty_frames_without_prediction_reproducibly(first60):
    seq = first60
    runs = []
    for _ in range(2):
        tracker = Tracker(seq.rig, HandModel(), NoMotion(), np.random.default_rng(7))
        runs.append(tracker.track(seq, seq.truth.poses[0]))
    a, b = runs
    err = mean_joint_error(seq.truth.joints, a.joints)
    assert err.mean() < 10.0
    assert np.array_equal(a.poses, b.poses)  # bitwise
    assert np.array_equal(a.costs, b.costs, equal_nan=True)
    assert a.poses.shape == (60, 26) and a.joints.shape == (60, 21, 3)
    assert np.all((a.iterations >= 1) & (a.iterations <= 50))
    np.testing.assert_allclose(a.joints[5], HandModel().joints(a.poses[5]))
    # a different seed gives a different (stochastic) track
    c = Tracker(seq.rig, HandModel(), NoMotion(), np.random.default_rng(8)).track(
        seq, seq.truth.poses[0], frames=10
    )
    assert not np.array_equal(c.poses, a.poses[:10])


def test_step_matches_track(first60):
    seq = first60
    x0 = seq.truth.poses[0]
    whole = Tracker(seq.rig, rng=np.random.default_rng(3)).track(seq, x0, frames=5)
    live = Tracker(seq.rig, rng=np.random.default_rng(3))
    live.reset(x0)
    poses = np.stack([live.step(seq.masks[t]).pose for t in range(5)])
    assert np.array_equal(poses, whole.poses)
    assert whole.seconds.shape == (5, 3) and np.all(whole.seconds >= 0)


def test_bad_input_raises(first60):
    rig = Rig.default()
    with pytest.raises(ValueError, match="x0"):
        Tracker(rig).step(first60.masks[0])
    with pytest.raises(TypeError, match="predictor"):
        Tracker(rig, predictor=object())
    with pytest.raises(TypeError, match="rng"):
        Tracker(rig, rng=0)
    with pytest.raises(ValueError, match="x0"):
        Tracker(rig).track(first60, np.zeros(25))


def test_prepared_frames_give_the_same_track(first60):
    # The preprocessing depends on the silhouettes only: prepared once and shared
    # between trials, it must not change a single bit of the result.
    seq = first60
    x0 = seq.truth.poses[0]
    tracker = Tracker(seq.rig, predictor=RVAR(), rng=np.random.default_rng(5))
    prepared = [tracker.prepare(seq.masks[t]) for t in range(8)]
    shared = tracker.track(seq, x0, frames=8, prepared=prepared)
    again = Tracker(seq.rig, predictor=RVAR(), rng=np.random.default_rng(5))
    fresh = again.track(seq, x0, frames=8)
    np.testing.assert_array_equal(shared.poses, fresh.poses)
    with pytest.raises(ValueError, match="prepared"):
        tracker.track(seq, x0, frames=8, prepared=prepared[:4])
