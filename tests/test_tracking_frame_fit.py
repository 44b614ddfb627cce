"""The keypoint-first fit (docs/keypoint-fit.md): its result against the pose the
keypoints were made from, its outlier rejection, the keypoint check, and the recovery's
keypoint rules on synthetic frames whose truth is known."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.predictors import RVAR
from handvar.synth import make_sequence, synthetic_keypoints
from handvar.tracking.frame_fit import PriorScale, fit_frame, honoured, reinitialise
from handvar.tracking.recovery import Recovery, track_with_recovery
from handvar.tracking.tracker import Tracker


def keypoints(hand, rig, x):
    return [np.column_stack([cam.project(hand.joints(x)), np.ones(21)]) for cam in rig]


@pytest.fixture(scope="module")
def mono_sequence():
    seq = make_sequence("benchmark", n_frames=40)
    rig = Rig([seq.rig.cameras[0]], [seq.rig.names[0]])
    return seq, rig


def test_exact_keypoints_are_fitted_from_a_start_off_and_nothing_is_rejected():
    hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    start = x.copy()
    start[:3] += (15.0, -10.0, 20.0)
    start[6:] += 8.0
    fit = fit_frame(keypoints(hand, rig, x), rig, hand, start)
    assert fit.n_rejected == 0
    assert fit.error < 0.005  # hand sizes
    assert np.linalg.norm(hand.joints(fit.pose) - hand.joints(x), axis=1).mean() < 2.0  # mm


def test_a_gross_error_is_rejected_and_does_not_pull_the_fit():
    hand, rig, x = HandModel(), Rig.default(), named_pose("open")
    kps = keypoints(hand, rig, x)
    size = np.linalg.norm(kps[0][9, :2] - kps[0][0, :2])
    kps[0][8, :2] += 0.8 * size  # the index tip 0.8 hand sizes off in one camera
    fit = fit_frame(kps, rig, hand, x + 3.0)
    assert fit.rejected[0, 8] and fit.n_rejected == 1
    # the other joints where they are; the tip where the second camera sees it (along
    # that camera's ray it may settle a few mm off, the finger bent to meet the ray)
    error = np.linalg.norm(hand.joints(fit.pose) - hand.joints(x), axis=1)
    assert np.delete(error, 8).max() < 1.5 and error[8] < 8.0  # mm
    seen = rig.cameras[1].project(hand.joints(fit.pose)[8:9])[0]
    assert np.linalg.norm(seen - kps[1][8, :2]) < 1.0  # px


def test_the_temporal_prior_pulls_towards_the_prediction_by_its_scale():
    # no keypoints beyond the palm: the fingers are settled by the prior alone
    hand, rig, x = HandModel(), Rig.default(), named_pose("open")
    kps = keypoints(hand, rig, x)
    for k in kps:
        k[[i for i in range(21) if i not in (0, 5, 9, 13, 17)], 2] = 0.0
    prediction = named_pose("fist")
    prediction[:6] = x[:6]
    fit = fit_frame(kps, rig, hand, prediction, prior=prediction)
    np.testing.assert_allclose(fit.pose[6:], prediction[6:], atol=0.5)
    # a scale that grows with the predictor's misses, bounded below by the floor
    s = PriorScale()
    for _ in range(50):
        s = s.update(prediction, prediction)
    assert s.sigma == s.floor
    assert s.update(prediction + 20.0, prediction).sigma[0] > s.floor[0]


def test_reinitialise_finds_the_pose_from_keypoints_alone():
    hand, rig = HandModel(), Rig.default()
    for name in ("open", "point"):
        x = named_pose(name)
        fit = reinitialise(keypoints(hand, rig, x), rig, hand)
        assert fit.error < 0.02, name
        assert np.linalg.norm(hand.joints(fit.pose) - hand.joints(x), axis=1).mean() < 5.0


def test_reinitialise_keeps_the_start_that_explains_the_keypoints_not_the_cheapest():
    """One camera, 30 hands turned every way, 2 px of noise and no gross error: no fit
    kept rejects more than 4 of the 21 keypoints, and the joints are 25 mm off at most
    on average.  A start that ends far off rejects most keypoints, whose rows then cost
    nothing: chosen by the cost, fits rejecting 19–21 of them were kept (1.5 m off)."""
    hand, rig = HandModel(), Rig.default()
    mono = Rig([rig.cameras[0]], [rig.names[0]])
    rng = np.random.default_rng(0)
    rejected, errors = [], []
    for i in range(30):
        x = named_pose(("spread", "fist", "point", "pinch", "open")[i % 5])
        x[3:6] = (rng.uniform(140, 220), rng.uniform(-60, 60) + 180 * (i % 2),
                  rng.uniform(-40, 40))  # fmt: skip
        k = [np.column_stack([mono.cameras[0].project(hand.joints(x))
                              + rng.normal(0, 2.0, (21, 2)), np.ones(21)])]  # fmt: skip
        fit = reinitialise(k, mono, hand)
        rejected.append(fit.n_rejected)
        errors.append(np.linalg.norm(hand.joints(fit.pose) - hand.joints(x), axis=1).mean())
    assert max(rejected) <= 4
    assert np.mean(errors) < 25.0


def test_honoured_against_hand_counted_frames(capsys):
    d = np.full((2, 1, 21), 0.1)
    r = np.zeros((2, 1, 21), dtype=bool)
    assert honoured(d, r) == (True, 1.0, 0)
    d[1, 0, 3] = 0.3  # one of 21 kept points out: 20/21 = 95 % < 98 %
    ok, worst, _ = honoured(d, r)
    assert not ok and worst == pytest.approx(20 / 21)
    r[1, 0, 3] = True  # rejected: no longer counted, but counted as rejected
    assert honoured(d, r) == (True, 1.0, 1)
    with pytest.raises(ValueError, match="distances, rejected"):
        honoured(d[0], r)
    # a track's count of frames failing: frame 1 (a point out), not 0, not 2 (none kept)
    from handvar.tracking.recovery import TrackQuality

    d = np.concatenate([d, np.full((1, 1, 21), np.nan)])
    n = len(d)
    q = TrackQuality(
        iou=np.full((n, 1), np.nan), keypoint_error=np.zeros(n), cost=np.zeros(n),
        lost=np.zeros(n, bool), reinit=np.zeros(n, bool), empty=np.zeros((n, 1), bool),
        keypoints=np.ones(n, bool), distances=d,
    )  # fmt: skip
    assert q.failing() == 1 and q.failing(frames=np.array([True, False, True])) == 0
    assert q.failing_frames().tolist() == [False, True, False]
    assert q.check()[:2] == (False, pytest.approx(20 / 21))
    # `handvar track` says how many of the frames with a detection fail
    from types import SimpleNamespace

    from handvar.cli.track import _print_quality

    result = SimpleNamespace(quality=q, detections=np.ones(n, bool), options={"carry": "none"})
    _print_quality(result)
    assert "keypoint check: FAILS on 1 of 3 frames" in capsys.readouterr().out


def test_a_track_with_noisy_keypoints_holds_and_the_check_holds(mono_sequence):
    seq, rig = mono_sequence
    hand = HandModel()
    # 3 px noise, and on every 4th frame a fingertip 0.6 hand sizes off (a gross error)
    kp = synthetic_keypoints(seq, 3.0, 0.0, np.random.default_rng(5))[:, :1]
    size = np.linalg.norm(kp[:, 0, 9, :2] - kp[:, 0, 0, :2], axis=1)
    kp[::4, 0, 12, 0] += 0.6 * size[::4]
    tracker = Tracker(rig, hand, RVAR(), np.random.default_rng(0))
    masks = [np.asarray(seq.masks[t])[:1] for t in range(seq.n_frames)]
    result = track_with_recovery(tracker, masks, keypoints=lambda i: list(kp[i]))
    q = result.quality
    assert not q.lost.any()
    ok, worst, n_rejected = q.check()
    assert ok, worst
    assert q.rejected[::4].all() and n_rejected <= 12  # the 10 gross errors, few others
    err = np.linalg.norm(result.track.joints - seq.truth.joints, axis=2).mean()
    assert err < 20.0  # mm, mono; measured about 10


def test_frames_without_keypoints_or_hand_are_flagged_no_hand_and_the_hand_reacquired(
    mono_sequence,
):
    seq, rig = mono_sequence
    hand = HandModel()
    masks = [np.asarray(seq.masks[t])[:1] for t in range(12)]
    for t in (0, 1, 2, 6, 7):
        masks[t] = np.zeros_like(masks[t])  # no hand
    kps = [None if t in (0, 1, 2, 6, 7) else keypoints(hand, rig, seq.truth.poses[t])
           for t in range(12)]  # fmt: skip
    tracker = Tracker(rig, hand, RVAR(), np.random.default_rng(0))
    recovery = Recovery(tracker)
    result = recovery.run(masks, keypoints=kps)
    q = result.quality
    assert q.no_hand.tolist() == [t in (0, 1, 2, 6, 7) for t in range(12)]
    assert np.isnan(result.track.poses[:3]).all()  # not started before the hand
    assert q.reinit[3] and not q.lost.any()
    err = np.linalg.norm(result.track.joints[8:] - seq.truth.joints[8:12], axis=2).mean()
    assert err < 10.0  # mm, after the hand came back


@pytest.mark.parametrize("digit", [1, 2, 3, 4])
def test_a_digit_left_in_a_wrong_minimum_is_fitted_again_from_the_named_shapes(digit):
    """Ground truth: a fist whose prediction has one finger open.  From the prediction
    the fit rejects that finger's keypoints and stays open; the digit re-seeding
    (`RecoverySettings.keypoint_reseeds`) finds the fist."""
    import dataclasses

    from handvar.params import digit_angles
    from handvar.predictors import NoMotion
    from handvar.tracking.recovery import RECOVERY_DEFAULTS

    hand, full = HandModel(), Rig.default()
    rig = Rig([full.cameras[0]], [full.names[0]])
    truth = named_pose("fist")
    start = truth.copy()
    angles = digit_angles(digit)
    start[angles] = named_pose("open")[angles]
    errors = {}
    for seeds in ((), ("open", "fist")):
        tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
        settings = dataclasses.replace(RECOVERY_DEFAULTS, keypoint_reseeds=seeds, shape=None)
        recovery = Recovery(tracker, settings=settings)
        recovery.run([None], start, keypoints=[keypoints(hand, rig, truth)])
        pose = tracker.prediction()  # NoMotion: the pose kept
        errors[seeds] = np.linalg.norm(hand.joints(pose) - hand.joints(truth), axis=1).max()
    assert errors[()] > 50.0  # mm: the finger left open
    assert errors[("open", "fist")] < 2.0


def test_a_camera_whose_keypoints_are_shifted_as_a_whole_is_left_out():
    """Ground truth: in a stereo rig one camera's detection is shifted by a hand size.
    The fit to both compromises and rejects points in both cameras; the recovery leaves
    out the camera farthest from the prediction and ends on the true pose, that camera's
    keypoints counted as rejected, the frame not lost."""
    from handvar.predictors import NoMotion

    hand, rig, truth = HandModel(), Rig.default(), named_pose("point")
    kps = keypoints(hand, rig, truth)
    size = np.linalg.norm(kps[1][9, :2] - kps[1][0, :2])
    kps[1][:, :2] += (1.0 * size, 0.5 * size)
    both = fit_frame(kps, rig, hand, truth)
    assert np.linalg.norm(hand.joints(both.pose) - hand.joints(truth), axis=1).mean() > 10.0
    tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
    recovered = track_with_recovery(tracker, [None], truth, keypoints=[kps])
    pose = recovered.track.poses[0]
    assert np.linalg.norm(hand.joints(pose) - hand.joints(truth), axis=1).max() < 2.0  # mm
    assert recovered.quality.rejected[0] == 21 and not recovered.quality.lost[0]


def test_the_depth_mirror_reflects_the_palm_in_depth_in_the_cameras_frame():
    """The wrist and the index and little MCPs (the palm's plane) keep their position
    across the view and move to the other side in depth, about the wrist; twice is the
    pose again."""
    from handvar.camera import Camera
    from handvar.hand.kinematics import world_from_hand_rotation
    from handvar.tracking.recovery import depth_mirror

    hand = HandModel()
    R = world_from_hand_rotation([10.0, -20.0, 5.0])[0]
    camera = Camera(600.0, 600.0, 320.0, 240.0, R=R, t=np.array([5.0, -10.0, 20.0]))
    x = named_pose("open").copy()
    x[:3] = R.T @ (np.array([10.0, -20.0, 450.0]) - camera.t)  # 45 cm in front
    x[3:6] = [40.0, -25.0, 15.0]
    y = depth_mirror(x, hand, camera)

    def in_camera(pose):
        return hand.joints(pose)[[0, 5, 17]] @ camera.R.T + camera.t

    a, b = in_camera(x), in_camera(y)
    np.testing.assert_allclose(b[:, :2], a[:, :2], atol=1e-6)
    np.testing.assert_allclose(b[:, 2] - b[0, 2], -(a[:, 2] - a[0, 2]), atol=1e-6)
    assert np.ptp(a[:, 2]) > 20.0  # mm: the palm is tilted, so the mirror moves it
    np.testing.assert_allclose(hand.joints(depth_mirror(y, hand, camera)), hand.joints(x),
                               atol=1e-6)  # fmt: skip


@pytest.mark.parametrize("tilt", [20.0, 35.0])
def test_a_palm_on_the_wrong_side_in_depth_is_mirrored_back(tilt):
    """Ground truth: an open hand tilted away from the camera, the fit started from its
    mirror image in depth (one camera sees both alike but for perspective).  Without
    the rule the fit stays on that side; with it (`RecoverySettings.depth_mirror`) it
    ends on the true pose."""
    import dataclasses

    from handvar.predictors import NoMotion
    from handvar.tracking.recovery import RECOVERY_DEFAULTS, depth_mirror

    hand, full = HandModel(), Rig.default()
    rig = Rig([full.cameras[0]], [full.names[0]])
    truth = named_pose("open").copy()
    truth[3] += tilt
    start = depth_mirror(truth, hand, rig.cameras[0])
    errors = {}
    for steps in (0, RECOVERY_DEFAULTS.depth_mirror):
        tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
        settings = dataclasses.replace(RECOVERY_DEFAULTS, depth_mirror=steps, shape=None)
        Recovery(tracker, settings=settings).run(
            [None], start, keypoints=[keypoints(hand, rig, truth)]
        )
        pose = tracker.prediction()  # NoMotion: the pose kept
        errors[steps] = np.linalg.norm(hand.joints(pose) - hand.joints(truth), axis=1).max()
    assert errors[0] > 40.0  # mm: the palm left on the mirrored side
    assert errors[RECOVERY_DEFAULTS.depth_mirror] < 2.0


# --- the silhouette term (FrameFitSettings.silhouette) ----------------------------------


def _with_silhouette(sigma: float = 0.05):
    from handvar.tracking.frame_fit import FrameFitSettings

    return FrameFitSettings(silhouette=sigma)


def test_the_silhouette_rows_gradient_matches_finite_differences():
    from handvar.render import silhouettes
    from handvar.tracking.costs import prepare_frame
    from handvar.tracking.frame_fit import _clean, _Problem

    hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    data = prepare_frame(silhouettes(hand, x, rig), rig)
    kp = _clean(keypoints(hand, rig, x), len(rig), 0.05)
    moved = x.copy()
    moved[:3] += (4.0, -3.0, 0.0)
    moved[[14, 17, 20]] += (25.0, 30.0, -20.0)  # digits partly off the silhouette
    settings = _with_silhouette()
    problem = _Problem(hand, rig, kp * [1, 1, 0], None, None, None, settings, x, data)
    problem.agree[:] = True  # no keypoints: the silhouette rows alone
    r, J = problem.rows(moved)
    assert np.count_nonzero(r) > 0
    cost = lambda y: 0.5 * float(np.sum(problem.rows(y, jacobian=False)[0] ** 2))  # noqa: E731
    h = 1e-5
    numeric = np.array([(cost(moved + h * e) - cost(moved - h * e)) / (2 * h)
                        for e in np.eye(len(x))])  # fmt: skip
    np.testing.assert_allclose(J.T @ r, numeric, rtol=1e-4, atol=1e-6 * np.abs(numeric).max())


def test_the_keypoint_rows_are_the_projections_error_and_their_jacobian_its_derivative():
    import dataclasses

    from handvar.camera import Camera
    from handvar.tracking.frame_fit import FRAME_FIT_DEFAULTS, _clean, _Problem

    hand, x = HandModel(), named_pose("point")
    rig = Rig.default()  # the second camera with lens distortion, rational model too
    cam = rig.cameras[1].to_dict() | {"dist": [0.1, -0.05, 0.002, -0.001, 0.01, 0.02, 0.0, 0.01]}
    rig = Rig([rig.cameras[0], Camera.from_dict(cam)], rig.names)
    moved = x.copy()
    moved[:3] += (1.0, -1.0, 2.0)
    moved[[14, 17]] += (3.0, -2.0)
    kp = _clean(keypoints(hand, rig, x), len(rig), 0.05)
    kp[0, 5, 2] = 0.0  # a keypoint not found: no row
    kp[1, :, 2] = 0.6  # a less sure camera
    s = dataclasses.replace(FRAME_FIT_DEFAULTS, view_correlation=0.0)  # views independent
    problem = _Problem(hand, rig, kp, None, None, None, s, x)
    r, J = problem.rows(moved)
    # the rows by the camera's own projection (within Huber's quadratic part, β = 1)
    G = hand.joints(moved)
    expected = []
    for j, cam in enumerate(rig):
        ok = kp[j, :, 2] > 0
        e = (cam.project(G[ok]) - kp[j, ok, :2]) / problem.sizes[j]
        assert (np.linalg.norm(e, axis=1) <= s.huber).all()
        expected.append((np.sqrt(kp[j, ok, 2])[:, None] * e / s.noise).ravel())
    np.testing.assert_allclose(r, np.concatenate(expected), rtol=1e-9, atol=1e-9)
    h = 1e-5
    numeric = np.column_stack([(problem.rows(moved + h * e, jacobian=False)[0]
                                - problem.rows(moved - h * e, jacobian=False)[0]) / (2 * h)
                               for e in np.eye(len(x))])  # fmt: skip
    np.testing.assert_allclose(J, numeric, rtol=1e-4, atol=1e-6 * np.abs(numeric).max())


def test_the_rows_beyond_hubers_bend_and_of_the_3d_joints_are_their_costs():
    """The compiled rows (a camera without distortion) against the costs they stand for,
    computed by the camera's own projection: ½|r_i|² = c_i ρ(d_i) / σ_k² with Huber's ρ
    (d²/2, then h (d − h/2)), and the 3D joints' rows ((W_i − W_0) − (w_i − w_0)) / σ_w."""
    from handvar.tracking.frame_fit import FRAME_FIT_DEFAULTS as s
    from handvar.tracking.frame_fit import _clean, _Problem
    from handvar.vision.keypoints import world_in_camera

    hand, x = HandModel(), named_pose("point")
    cam = Rig.default().cameras[0]
    assert not cam.has_distortion
    rig = Rig([cam])
    rng = np.random.default_rng(3)
    kp = _clean(keypoints(hand, rig, x), 1, 0.05)
    kp[0, :, :2] += rng.normal(0.0, 6.0, (21, 2))
    kp[0, [4, 8, 13], :2] += [(60.0, -20.0), (-45.0, 50.0), (80.0, 0.0)]  # gross errors
    kp[0, :, 2] = rng.uniform(0.3, 1.0, 21)
    kp[0, 9, 2] = 0.0  # not found: no row
    world = hand.joints(x) + rng.normal(0.0, 4.0, (21, 3)) + 100.0  # any origin
    moved = x + rng.normal(0.0, 1.0, 26)
    problem = _Problem(hand, rig, kp, None, None, world, s, x)
    r, J = problem.rows(moved)
    np.testing.assert_array_equal(problem.rows(moved, jacobian=False)[0], r)
    assert J.shape == (r.size, 26)

    ok = np.flatnonzero(kp[0, :, 2] > 0)
    G = hand.joints(moved)
    d = np.linalg.norm(cam.project(G[ok]) - kp[0, ok, :2], axis=1) / problem.sizes[0]
    h = s.huber
    assert (d > h).sum() >= 3 and (d <= h).sum() >= 3  # both parts of Huber's loss
    rho = np.where(d <= h, 0.5 * d**2, h * (d - 0.5 * h))
    half = 0.5 * (r[: 2 * ok.size].reshape(-1, 2) ** 2).sum(axis=1)
    np.testing.assert_allclose(half, kp[0, ok, 2] * rho / s.noise**2, rtol=1e-9)

    w = world_in_camera(world, np.where(kp[0, :, 2:] > 0, kp[0, :, :2], np.nan), cam)
    W = hand.joints(moved) @ cam.R.T
    expected = ((W[1:] - W[0]) - (w[1:] - w[0])) / s.world_noise
    np.testing.assert_allclose(r[2 * ok.size:].reshape(-1, 3), expected, rtol=1e-9,
                               atol=1e-9)  # fmt: skip
    rows3d = lambda y: problem.rows(y, jacobian=False)[0][2 * ok.size :]  # noqa: E731
    numeric = np.column_stack([(rows3d(moved + 1e-5 * e) - rows3d(moved - 1e-5 * e)) / 2e-5
                               for e in np.eye(26)])  # fmt: skip
    np.testing.assert_allclose(J[2 * ok.size:], numeric, rtol=1e-4,
                               atol=1e-6 * np.abs(numeric).max())  # fmt: skip


def test_a_second_view_of_the_hand_weakens_the_detectors_3d():
    """σ_w is `world_noise_seen_twice` times larger where two cameras have keypoints (the
    3D rows a third as large as with one), and a biased 3D cue (the hand turned 25°)
    pulls a stereo fit of exact keypoints less off the truth than at full weight."""
    import dataclasses

    from handvar.hand.kinematics import world_from_hand_rotation
    from handvar.tracking.frame_fit import FRAME_FIT_DEFAULTS as s
    from handvar.tracking.frame_fit import _clean, _Problem

    hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    truth = hand.joints(x)
    turn = world_from_hand_rotation([25.0, 0.0, 0.0])[0]
    world = (truth - truth[0]) @ turn.T  # the detector's 3D, turned
    kp = _clean(keypoints(hand, rig, x), 2, 0.05)
    one_view = kp.copy()
    one_view[1] = 0.0
    moved = x + np.random.default_rng(4).normal(0.0, 2.0, 26)

    def rows3d(k):
        problem = _Problem(hand, rig, k, None, None, world, s, x)
        n = 2 * sum(p.size for p in problem.present)
        return problem.rows(moved, jacobian=False)[0][n:]

    assert s.world_noise_seen_twice > 1.0
    np.testing.assert_allclose(rows3d(kp) * s.world_noise_seen_twice, rows3d(one_view),
                               rtol=1e-12, atol=1e-12)  # fmt: skip

    def error(settings):
        fit = fit_frame(keypoints(hand, rig, x), rig, hand, x, world=world, settings=settings)
        return np.linalg.norm(hand.joints(fit.pose) - truth, axis=1).mean()

    full = dataclasses.replace(s, world_noise_seen_twice=1.0)
    assert error(s) < 0.6 * error(full)


def test_a_joint_seen_twice_costs_the_gaussian_of_an_offset_shared_by_its_views():
    """With `view_correlation` ρ, ½|r|² of the keypoint rows is ½ Σ_i a_iᵀ Σ_i⁻¹ a_i,
    Σ_i = (1 − ρ) I + σ² P_i P_iᵀ over the joint's views, P_i their projections'
    derivatives (by finite differences here) with respect to the joint; a joint one
    camera misses, or whose views disagree, keeps its plain rows; at ρ = 0 the plain
    cost; the Jacobian is the rows' derivative."""
    import dataclasses

    from handvar.tracking.frame_fit import FRAME_FIT_DEFAULTS, _clean, _Problem
    from handvar.tracking.keypoint_cost import keypoint_points

    hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    moved = x.copy()
    moved[:3] += (0.5, -0.5, 1.0)
    moved[[14, 17]] += (2.0, -1.5)
    kp = _clean(keypoints(hand, rig, x), len(rig), 0.05)
    kp[0, 5, 2] = 0.0  # seen by the second camera only
    kp[1, 8, :2] += 20.0  # the views disagree
    kp[1, :, 2] = 0.6  # a less sure camera
    rho = 0.9
    s = dataclasses.replace(FRAME_FIT_DEFAULTS, view_correlation=rho)
    problem = _Problem(hand, rig, kp, None, None, None, s, x)
    r, J = problem.rows(moved)
    G, G0 = hand.joints(moved), keypoint_points(hand, x, s.tips)
    a = np.full((2, 21, 2), np.nan)  # each view's rows as the plain fit has them
    P = np.empty((2, 21, 2, 3))
    for j, cam in enumerate(rig):
        ok = kp[j, :, 2] > 0
        e = (cam.project(G[ok]) - kp[j, ok, :2]) / problem.sizes[j]
        d = np.linalg.norm(e, axis=1)  # Huber's β: 1, or beyond its bend √(2h(d − h/2))/d
        bend = np.sqrt(2 * s.huber * np.maximum(d - s.huber / 2, 0.0)) / np.maximum(d, 1e-12)
        beta = np.where(d <= s.huber, 1.0, bend)
        a[j, ok] = (np.sqrt(kp[j, ok, 2]) * beta)[:, None] * e / s.noise
        for k in range(3):
            step = np.eye(3)[k] * 1e-4
            P[j, :, :, k] = (cam.project(G0 + step) - cam.project(G0 - step)) / 2e-4
        P[j] /= problem.sizes[j] * s.noise
    cost = 0.0
    for i in range(21):
        v = np.flatnonzero(np.isfinite(a[:, i, 0]))
        if v.size < 2 or i == 8:
            cost += 0.5 * np.sum(a[v, i] ** 2)
            continue
        Pi = P[v, i].reshape(-1, 3)
        cov = rho / np.mean(np.sum(Pi**2, axis=1)) * Pi @ Pi.T + (1.0 - rho) * np.eye(4)
        cost += 0.5 * a[v, i].ravel() @ np.linalg.solve(cov, a[v, i].ravel())
    np.testing.assert_allclose(0.5 * r @ r, cost, rtol=1e-6)
    h = 1e-5
    numeric = np.column_stack([(problem.rows(moved + h * e, jacobian=False)[0]
                                - problem.rows(moved - h * e, jacobian=False)[0]) / (2 * h)
                               for e in np.eye(len(x))])  # fmt: skip
    # beyond Huber's bend (the joint whose views disagree) the rows hold β: not compared
    bent = np.concatenate([np.repeat(p == 8, 2) for p in problem.present])
    np.testing.assert_allclose(J[~bent], numeric[~bent], rtol=1e-4,
                               atol=1e-6 * np.abs(numeric).max())  # fmt: skip
    plain = dataclasses.replace(s, view_correlation=0.0)
    r0 = _Problem(hand, rig, kp, None, None, None, plain, x).rows(moved, jacobian=False)[0]
    np.testing.assert_allclose(0.5 * r0 @ r0, 0.5 * np.nansum(a**2), rtol=1e-10)


def test_errors_alike_in_both_views_move_a_stereo_fit_less_when_the_fit_expects_them():
    """Keypoints off the truth by the same few pixels in both views (a detector marking a
    joint a little elsewhere, alike from both sides) and 0.5 px apart: the fit that
    expects errors alike (`view_correlation` 0.9) follows the views' agreement and lands
    nearer the truth than one taking the views as independent (0, the default), on each
    of five draws."""
    import dataclasses

    from handvar.tracking.frame_fit import FRAME_FIT_DEFAULTS as s

    hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    truth = hand.joints(x)
    alike = dataclasses.replace(s, view_correlation=0.9)
    errors = []
    for seed in range(5):
        rng = np.random.default_rng(seed)
        shared = rng.normal(0.0, 3.0, (21, 2))
        kps = [np.column_stack([cam.project(truth) + shared + rng.normal(0.0, 0.5, (21, 2)),
                                np.ones(21)]) for cam in rig]  # fmt: skip
        start = x + rng.normal(0.0, 2.0, 26)
        errors.append([
            np.linalg.norm(hand.joints(fit_frame(kps, rig, hand, start, settings=v).pose)
                           - truth, axis=1).mean()
            for v in (alike, dataclasses.replace(s, view_correlation=0.0))])  # fmt: skip
    errors = np.array(errors)
    assert (errors[:, 0] < errors[:, 1]).all()
    assert errors[:, 0].mean() < 0.85 * errors[:, 1].mean()


def test_skin_beyond_the_hand_does_not_move_the_fit_and_a_silhouette_elsewhere_is_ignored():
    from handvar.render import silhouettes
    from handvar.tracking.costs import prepare_frame

    hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    kps = keypoints(hand, rig, x)
    start = x.copy()
    start[6:] += 6.0
    plain = fit_frame(kps, rig, hand, start)
    masks = silhouettes(hand, x, rig)
    grown = masks.copy()
    grown[:, :, : grown.shape[2] // 2] = True  # a forearm, a face: skin where no hand is
    with_skin = fit_frame(kps, rig, hand, start, silhouettes=prepare_frame(grown, rig),
                          settings=_with_silhouette())  # fmt: skip
    np.testing.assert_allclose(with_skin.pose, plain.pose, atol=1e-9)
    away = np.roll(masks, masks.shape[2] // 3, axis=2)  # disagrees with the keypoints
    elsewhere = fit_frame(kps, rig, hand, start, silhouettes=prepare_frame(away, rig),
                          settings=_with_silhouette())  # fmt: skip
    np.testing.assert_allclose(elsewhere.pose, plain.pose, atol=1e-9)


def test_the_silhouette_pulls_a_digit_without_keypoints_back_onto_the_hand():
    from handvar.params import digit_angles
    from handvar.render import silhouettes
    from handvar.tracking.costs import prepare_frame

    hand, rig, x = HandModel(), Rig.default(), named_pose("open")
    kps = keypoints(hand, rig, x)
    for k in kps:
        k[5:9, 2] = 0.0  # no index finger keypoints
    start = x.copy()
    start[digit_angles(1)[1:]] += 25.0  # the index finger bent
    data = prepare_frame(silhouettes(hand, x, rig), rig)
    plain = fit_frame(kps, rig, hand, start)
    with_skin = fit_frame(kps, rig, hand, start, silhouettes=data, settings=_with_silhouette())

    def index_error(y):
        return np.linalg.norm(hand.joints(y)[5:9] - hand.joints(x)[5:9], axis=1).mean()

    assert index_error(with_skin.pose) < 0.75 * index_error(plain.pose)


def test_track_with_the_silhouette_term_from_the_command_line(tmp_path):
    from click.testing import CliRunner

    from handvar.cli import main
    from handvar.data import example_path

    out = tmp_path / "o"
    res = CliRunner().invoke(main, [
        "track", str(example_path("video")), "--scale", "0.5", "--frames", "6",
        "--keypoints", str(example_path("video-keypoints")), "--silhouette-term", "0.05",
        "--out", str(out), "--no-video",
    ])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "0 lost" in res.output


@pytest.mark.parametrize("seed", range(2))
def test_the_detectors_3d_over_three_frames_lowers_the_jitter_without_lag(mono_sequence, seed):
    """The detector's 3D with 10 mm of noise on each joint in each frame (MediaPipe's
    world landmarks jitter far more than a hand moves between frames), as it gives it
    (seen along the ray through the palm): the fit given its mean over the last 3
    frames (the default) jitters less against the truth than given each frame's own,
    by a fifth or more, and is no farther from it (a cue that trailed the motion
    would pull the hand behind it)."""
    import dataclasses

    from handvar.evaluation.metrics import acceleration_error, mpjpe
    from handvar.tracking.recovery import RECOVERY_DEFAULTS
    from handvar.vision.keypoints import PALM

    seq, rig = mono_sequence
    cam = rig.cameras[0]
    rng = np.random.default_rng(seed)
    kp = synthetic_keypoints(seq, 3.0, 0.0, rng)[:, :1]
    truth = seq.truth.joints
    world = []
    for t in range(seq.n_frames):  # in the camera's axes, then turned back off the ray
        ray = cam.ray_rotation(kp[t, 0, list(PALM), :2].mean(axis=0))
        world.append((truth[t] @ cam.R.T + rng.normal(0.0, 10.0, (21, 3))) @ ray)
    masks = [np.asarray(seq.masks[t])[:1] for t in range(seq.n_frames)]
    fits = {}
    for n in (1, 3):
        settings = dataclasses.replace(RECOVERY_DEFAULTS, world_frames=n)
        tracker = Tracker(rig, HandModel(), RVAR(), np.random.default_rng(0))
        fits[n] = track_with_recovery(tracker, masks, keypoints=lambda i: list(kp[i]),
                                      world=world, settings=settings).track.joints  # fmt: skip
    jitter = {n: acceleration_error(truth, j) for n, j in fits.items()}
    assert jitter[3] < 0.8 * jitter[1], jitter
    error = {n: mpjpe(truth, j) for n, j in fits.items()}
    assert error[3] <= error[1] + 0.5, error
