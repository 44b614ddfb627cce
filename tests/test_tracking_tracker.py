"""Tests of the tracker (handvar.tracking.tracker) on synthetic frames with ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.camera import Rig
from handvar.evaluation.metrics import mean_joint_error
from handvar.hand import HandModel
from handvar.predictors import RVAR, NoMotion
from handvar.render import silhouettes
from handvar.synth import synthetic_keypoints
from handvar.synth.sequences import benchmark, make_sequence
from handvar.tracking.tracker import Tracker, TrackingWarning
from handvar.vision.keypoints import Keypoints2D


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


# --- the hand in front, fit quality, lost and empty frames (design §13) -----------------


@pytest.fixture(scope="module")
def frame90():
    hand, rig = HandModel(), Rig.default()
    truth = benchmark(0)[90]
    return hand, rig, truth, silhouettes(hand, truth, rig)


@pytest.mark.parametrize(("shift", "seed"), [(2000.0, 0), (2000.0, 1), (-1000.0, 0)])
def test_a_start_far_off_or_behind_never_beats_the_truth(frame90, shift, seed):
    # the palm 2 m too far along the left camera's axis, or 1 m behind it (behind both
    # cameras); before the front term such starts walked behind the cameras to cost 0
    hand, rig, truth, masks = frame90
    x0 = truth.copy()
    x0[:3] += shift * rig.cameras[0].axis
    tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(seed))
    tracker.reset(x0)
    frame = tracker.prepare(masks)
    rng = np.random.default_rng(50)
    at_truth = max(tracker.cost.evaluate(truth, frame, tracker.cost.draw(frame, rng)).cost
                   for _ in range(10))  # fmt: skip
    for _ in range(4):
        r = tracker.step(masks)
        assert r.cost > at_truth
        assert np.all(r.costs > at_truth)
        for cam in rig:  # every joint in front of every camera
            assert cam.camera_from_world(hand.joints(r.pose))[:, 2].min() > 0.0
        err = mean_joint_error(hand.joints(truth)[None], hand.joints(r.pose)[None])[0]
        if err > 40.0:  # lost: flagged
            assert r.lost, (err, r.mean_iou, r.cost)


def test_fit_quality_of_a_good_track(first60):
    seq = first60
    res = Tracker(seq.rig, rng=np.random.default_rng(2)).track(seq, seq.truth.poses[0], frames=20)
    assert res.iou.shape == (20, 2) and res.lost.shape == (20,) and res.empty.shape == (20, 2)
    assert not res.lost.any() and not res.empty.any()
    assert np.all(res.mean_iou > 0.85)
    assert np.all(np.isnan(res.keypoint_error))
    np.testing.assert_array_equal(res.final_costs, res.cost)
    # the IoU is that of the rendered fitted pose against the masks, per camera
    model = silhouettes(HandModel(), res.poses[7], seq.rig)
    m = np.asarray(seq.masks[7])
    expect = [(model[j] & m[j]).sum() / (model[j] | m[j]).sum() for j in range(2)]
    np.testing.assert_allclose(res.iou[7], expect)


@pytest.mark.parametrize("kind", ["white", "blob"])
def test_degenerate_masks_are_lost(frame90, kind):
    hand, rig, truth, masks = frame90
    if kind == "white":
        m = np.ones_like(masks)
    else:
        m = np.zeros_like(masks)
        m[:, 239:242, 319:322] = True
    tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
    tracker.reset(truth)
    r = tracker.step(m)
    assert r.lost and r.mean_iou < 0.5


def test_empty_cameras_are_flagged_not_fatal(frame90):
    hand, rig, truth, masks = frame90
    tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
    tracker.reset(truth)
    tracker.step(masks)
    one = masks.copy()
    one[1] = False
    with pytest.warns(TrackingWarning, match=r"frame 1: empty silhouette in camera 'right'"):
        r = tracker.step(one)
    assert r.empty.tolist() == [False, True] and np.isnan(r.iou[1]) and r.iterations >= 1
    assert mean_joint_error(hand.joints(truth)[None], hand.joints(r.pose)[None])[0] < 10.0
    none = np.zeros_like(masks)
    with pytest.warns(TrackingWarning, match=r"frame 2: .*'left', 'right'.*prediction"):
        r = tracker.step(none)
    assert r.lost and r.iterations == 0 and np.isnan(r.cost) and r.empty.all()
    np.testing.assert_array_equal(r.pose, r.start)


def test_track_with_keypoints_reports_keypoint_error(first60):
    seq = first60
    kp = synthetic_keypoints(seq, 3.0, 0.0, np.random.default_rng(0))
    kp[3] = np.nan  # a frame without keypoints: silhouettes only
    res = Tracker(seq.rig, rng=np.random.default_rng(1)).track(
        seq, seq.truth.poses[0], frames=6, keypoints=kp
    )
    assert np.isnan(res.keypoint_error[3])
    ok = np.delete(res.keypoint_error, 3)
    assert np.all(ok < 0.05)  # 3 px of noise on a hand about 100 px long
    # the same keypoints per camera, as Keypoints2D
    per_cam = [Keypoints2D.from_array(kp[:, j]) for j in range(2)]
    again = Tracker(seq.rig, rng=np.random.default_rng(1)).track(
        seq, seq.truth.poses[0], frames=6, keypoints=per_cam
    )
    assert np.array_equal(again.poses, res.poses)


def test_keypoints_keep_the_thumb_that_silhouettes_lose():
    # the thumb's return (frames 160-174 of the benchmark), tracked from frame 145 with
    # synthetic keypoints (3 px noise, 10 % outliers) and without: silhouettes alone lose
    # the thumb tip (about 80 mm off), keypoints keep it (studies/keypoints_synthetic.py
    # runs the whole sequence, mono and stereo, over ten trials)
    seq = make_sequence("benchmark")
    hand = HandModel()
    kp = synthetic_keypoints(seq, 3.0, 0.1, np.random.default_rng(7))
    out = {}
    for use in (False, True):
        tracker = Tracker(seq.rig, hand, NoMotion(), np.random.default_rng(0))
        tracker.reset(seq.truth.poses[145])
        err = []
        for t in range(145, 175):
            r = tracker.step(seq.masks[t], keypoints=kp[t] if use else None)
            err.append(np.linalg.norm(hand.joints(r.pose) - seq.truth.joints[t], axis=1))
        err = np.array(err)
        out[use] = (err.mean(), err[15:, 4].max())  # all joints; thumb tip, 160-175
    assert out[False][1] > 40.0  # silhouettes lose the thumb here
    assert out[True][1] < 20.0
    assert out[True][0] < 0.5 * out[False][0]
