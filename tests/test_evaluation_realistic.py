"""Realistic recordings (`handvar.evaluation.realistic`) and the benchmark's measures.

The generator against its own ground truth (the truth's points land on the rendered
hand, a left hand is the mirror image of the right one, the same seed gives the same
bytes), the detector's error model against the rates it states, the measures against
scipy's Procrustes and hand-worked cases, and one tiny case through `handvar init` and
`handvar track` as a user would run them.
"""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial import procrustes

from handvar.camera import Camera, Rig
from handvar.cli import main
from handvar.evaluation.metrics import (
    auc_pck_3d,
    joint_errors,
    mean_point_error,
    mpjpe,
    pa_mpjpe,
    pck_2d,
    similarity_align,
)
from handvar.evaluation.realistic import (
    FAST_PACE,
    GROSS_KINDS,
    DetectorErrors,
    counting_poses,
    detector_keypoints,
    motion_poses,
    personal_shape,
    read_case,
    realistic_case,
)
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import world_from_hand_rotation

SMALL = (320, 180)


@pytest.fixture(scope="module")
def right_case():
    return realistic_case("benchmark", seed=3, frames=(60, 64), size=SMALL, distractor="arm",
                          background="fridge")  # fmt: skip


def test_the_true_points_land_on_the_rendered_hand(right_case):
    c = right_case
    for t in range(c.n_frames):
        uv = np.rint(c.truth_2d[0, t]).astype(int)
        w, h = SMALL
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
        assert inside.all()
        # every point lies on the hand's mask or within 2 px of it (the wrist and a
        # fingertip's pad centre are inside the surface, seen through it)
        mask = c.masks[0, t]
        rows, cols = np.nonzero(mask)
        d = np.min(np.hypot(cols[None] - uv[:, :1], rows[None] - uv[:, 1:]), axis=1)
        assert np.mean(d <= 2.0) >= 0.95, d
        # and the mask is the hand's size, not a speck: about the bounding box's area
        span = np.ptp(c.truth_2d[0, t], axis=0)
        assert mask.sum() > 0.2 * span[0] * span[1]


def test_a_left_hand_is_the_mirror_image_of_the_right_hand():
    # a camera looking along the hand's mirror plane at a hand without rotation but the
    # named poses' (rx = 180): the left hand's image is the right hand's, flipped
    kw = dict(seed=1, frames=(0, 1), size=(200, 120), distractor="none", background="gradient")
    right = realistic_case("counting", side="right", **kw)
    left = realistic_case("counting", side="left", **kw)
    x = right.poses[0]
    np.testing.assert_array_equal(x, left.poses[0])
    R, _ = world_from_hand_rotation(x[3:6])
    mirror = R @ np.diag([-1.0, 1.0, 1.0]) @ R.T
    np.testing.assert_allclose(left.joints[0], (right.joints[0] - x[:3]) @ mirror + x[:3],
                               atol=1e-9)  # fmt: skip
    # a camera whose axis lies in the mirror plane sees the two hands' points mirrored
    cam = Camera.look_at(x[:3] - 560.0 * R[:, 2], x[:3], up=-R[:, 1], size=(200, 120))
    a, b = cam.project(right.joints[0]), cam.project(left.joints[0])
    np.testing.assert_allclose(b[:, 0] - cam.cx, cam.cx - a[:, 0], atol=1e-6)
    np.testing.assert_allclose(b[:, 1], a[:, 1], atol=1e-6)
    # the rendered masks of the two hands differ (not the same hand)...
    assert (right.masks[0, 0] != left.masks[0, 0]).sum() > 50


def test_the_left_masks_mirror_the_right_masks_in_a_camera_on_the_mirror_plane():
    from handvar.evaluation.realistic import _HandScene, _render_view
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import named_pose

    x = named_pose("spread")
    x[:6] = (0.0, -60.0, 0.0, 180.0, 0.0, 0.0)
    cam = Camera.look_at((0.0, -60.0, -500.0), (0.0, -60.0, 0.0), size=(161, 121), fx=300.0)
    bg = np.zeros((121, 161, 3), np.uint8)
    masks = []
    for side in ("right", "left"):
        scene = _HandScene(HandShape.from_size(185.0, side=side))
        hv = scene.hand_vertices(x)
        _, m = _render_view(cam, [(hv, scene.triangles, (200, 150, 120), True)], bg,
                            np.array([0.0, 0.0, -1.0]), 0.4, 0.6)  # fmt: skip
        masks.append(m)
    right, left = masks
    assert right.sum() > 500 and (right != right[:, ::-1]).sum() > 100  # not symmetric
    assert (left != right[:, ::-1]).mean() < 2e-3


def test_the_same_seed_gives_the_same_case_and_another_seed_another(right_case):
    again = realistic_case("benchmark", seed=3, frames=(60, 64), size=SMALL, distractor="arm",
                           background="fridge")  # fmt: skip
    np.testing.assert_array_equal(again.frames, right_case.frames)
    np.testing.assert_array_equal(again.keypoints, right_case.keypoints)
    other = realistic_case("benchmark", seed=4, frames=(60, 64), size=SMALL, distractor="arm",
                           background="fridge")  # fmt: skip
    assert not np.array_equal(other.frames, right_case.frames)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_fast_gestures_are_the_counting_gestures_at_their_pace(seed):
    from handvar.hand.kinematics import named_pose
    from handvar.params import digit_angles

    slow, fps = motion_poses("counting", seed)
    fast, fast_fps = motion_poses("fast", seed)
    fingers = np.concatenate([digit_angles(d) for d in range(1, 5)])

    def fastest(poses):  # the fastest finger angle's speed, degrees per frame
        return np.abs(np.diff(poses[:, fingers], axis=0)).max()

    # each transition 0.35–0.6 s divided by the pace: the fastest speeds' ratio is the
    # pace times at most 0.6 / 0.35 either way
    assert fps == fast_fps
    assert FAST_PACE * 0.35 / 0.6 < fastest(fast) / fastest(slow) < FAST_PACE * 0.6 / 0.35
    # from the fist and back to it, twice through the spread hand
    for poses in (slow, fast):
        np.testing.assert_allclose(
            poses[[0, -1]][:, fingers], named_pose("fist")[None, fingers].repeat(2, 0), atol=1e-6
        )
    spread = named_pose("spread")[fingers]
    at_spread = np.flatnonzero(np.abs(fast[:, fingers] - spread).max(axis=1) < 1e-6)
    assert np.any(np.diff(at_spread) > 1)  # reached, left, reached again
    with pytest.raises(ValueError, match="pace"):
        counting_poses(seed, pace=0.0)
    # the faster gestures: twice the pace, as many frames (to a frame's rounding each)
    faster, _ = motion_poses("faster", seed)
    assert abs(len(faster) - len(fast)) <= 2 and len(faster) >= 60
    assert 2 * 0.35 / 0.6 < fastest(faster) / fastest(fast) < 2 * 0.6 / 0.35


def test_a_persons_hand_moves_every_bone_and_knuckle_and_nothing_else():
    base = HandShape.from_size(185.0, side="left")
    one = personal_shape(base, 0.08, np.random.default_rng(0))
    ratios = one.segments / base.segments
    assert np.ptp(ratios) > 0.05 and np.all(np.abs(np.log(ratios)) < 0.5)
    assert not np.allclose(one.bases, base.bases)
    np.testing.assert_array_equal(one.radii, base.radii)
    assert one.side == "left"

    def tip(shape):  # wrist → middle fingertip along the bones
        return shape.bases[2, 1] + shape.segments[2].sum()

    assert one.length / base.length == pytest.approx(tip(one) / tip(base))
    same = personal_shape(base, 0.08, np.random.default_rng(0))
    np.testing.assert_array_equal(same.segments, one.segments)
    flat = personal_shape(base, 0.0, np.random.default_rng(0))
    np.testing.assert_array_equal(flat.segments, base.segments)


def test_a_written_case_reads_back(right_case, tmp_path):
    from handvar.vision.keypoints import read_keypoints

    paths = right_case.write(tmp_path)
    back = read_case(tmp_path, frames=True)
    np.testing.assert_array_equal(back.masks, right_case.masks)
    np.testing.assert_array_equal(back.joints, right_case.joints)
    assert Rig.load(paths["calib"]).allclose(right_case.rig)
    kp = read_keypoints(paths["keypoints"][0])
    np.testing.assert_array_equal(kp.to_array()[..., :2], right_case.keypoints[0])
    # JPEG at quality 92: close to the rendered frames, not equal
    assert np.abs(back.frames.astype(int) - right_case.frames).mean() < 3.0


def test_the_detector_errors_have_the_stated_rates():
    rng = np.random.default_rng(0)
    T = 20000
    truth = rng.uniform(100, 500, (T, 21, 2))
    size = np.full(T, 100.0)
    errors = DetectorErrors()
    kp, gross, missed = detector_keypoints(truth, size, rng, errors)
    # missed frames: NaN, at the stated rate (runs of 1-4 frames: a wider tolerance
    # than independent frames'; 3 standard errors of ~T·rate/2.5 runs)
    assert np.isnan(kp[missed]).all() and np.isfinite(kp[~missed]).all()
    assert abs(missed.mean() - errors.missed) < 0.006
    # gross errors on the detected frames: the stated fraction, every kind present
    detected = ~missed
    assert abs((gross[detected] > 0).mean() - errors.gross) < 0.008
    counts = np.bincount(gross[gross > 0], minlength=len(GROSS_KINDS) + 1)[1:]
    assert counts.min() > 0.25 * counts.sum()
    # clean frames: RMS 2D error 0.05 hand sizes, lag-1 correlation 0.8
    clean = detected & (gross == 0)
    e = (kp - truth) / 100.0
    rms = np.sqrt(np.mean(np.sum(e[clean] ** 2, axis=-1)))
    assert abs(rms - errors.noise) < 0.002
    both = clean[1:] & clean[:-1]
    r = np.corrcoef(e[1:][both].ravel(), e[:-1][both].ravel())[0, 1]
    assert abs(r - errors.correlation) < 0.02


def test_each_gross_error_does_what_it_says():
    rng = np.random.default_rng(5)
    truth = rng.uniform(100, 500, (4000, 21, 2))
    quiet = DetectorErrors(noise=0.0, missed=0.0, gross=0.2)
    kp, gross, _ = detector_keypoints(truth, np.full(4000, 100.0), rng, quiet)
    for t in np.flatnonzero(gross)[:200]:
        moved = np.flatnonzero(np.any(kp[t] != truth[t], axis=1))
        kind = GROSS_KINDS[gross[t] - 1]
        if kind == "shift":
            d = kp[t] - truth[t]
            assert np.ptp(d, axis=0).max() < 1e-9  # one shift for all
            assert 30.0 - 1e-9 <= np.linalg.norm(d[0]) <= 80.0 + 1e-9
        elif kind == "swap":  # a finger's four points and its neighbour's
            assert len(moved) == 8 and moved[0] in (5, 9, 13) and moved[-1] == moved[0] + 7
            np.testing.assert_array_equal(kp[t, moved[:4]], truth[t, moved[4:]])
        else:  # a fingertip at its knuckle
            assert len(moved) == 1 and moved[0] % 4 == 0 and moved[0] > 0
            knuckle = 2 if moved[0] == 4 else moved[0] - 3
            np.testing.assert_array_equal(kp[t, moved[0]], truth[t, knuckle])


def test_the_first_frame_is_clean_and_bad_input_is_named():
    rng = np.random.default_rng(1)
    for _ in range(20):
        _, gross, missed = detector_keypoints(np.zeros((3, 21, 2)), np.ones(3), rng,
                                               DetectorErrors(gross=0.5, missed=0.5))  # fmt: skip
        assert gross[0] == 0 and not missed[0]
    with pytest.raises(ValueError, match="truth_2d"):
        detector_keypoints(np.zeros((3, 20, 2)), np.ones(3), rng)
    with pytest.raises(ValueError, match="motion"):
        realistic_case("wave")
    with pytest.raises(ValueError, match="frames"):
        realistic_case("flip", frames=(10, 5))


# --- the measures --------------------------------------------------------------------------


def test_procrustes_alignment_matches_scipy():
    rng = np.random.default_rng(2)
    for _ in range(5):
        truth = rng.normal(0, 40, (21, 3))
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        q *= np.sign(np.linalg.det(q))  # a rotation
        est = 1.3 * truth @ q.T + rng.normal(0, 3, (21, 3)) + 50.0
        aligned = similarity_align(est, truth)
        # scipy standardises both (centred, unit Frobenius norm) and fits the second
        # to the first with a scale and an orthogonal matrix
        m1, m2, _ = procrustes(truth, est)
        c = truth - truth.mean(0)
        np.testing.assert_allclose((aligned - truth.mean(0)) / np.linalg.norm(c), m2, atol=1e-9)
        np.testing.assert_allclose(c / np.linalg.norm(c), m1, atol=1e-12)


def test_pa_mpjpe_is_zero_for_a_similar_copy_and_mpjpe_for_a_shift():
    rng = np.random.default_rng(3)
    truth = rng.normal(0, 40, (3, 21, 3))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    est = 0.8 * truth @ q.T + 7.0
    assert pa_mpjpe(truth, est) < 1e-9
    assert mpjpe(truth, truth + np.array([3.0, -4.0, 12.0])) < 1e-12  # wrist-relative
    shifted = truth + np.array([3.0, 4.0, 0.0])
    np.testing.assert_allclose(joint_errors(truth, shifted, alignment="none"), 5.0)
    est = truth.copy()
    est[1, 5] += (0.0, 0.0, 21.0)  # one point 21 mm off in one frame of three
    assert mpjpe(truth, est) == pytest.approx(21.0 / 63.0)
    est[2] = np.nan  # a missing frame is not scored
    assert mpjpe(truth, est) == pytest.approx(21.0 / 42.0)


def test_pck_and_mean_error_by_hand():
    truth = np.zeros((2, 21, 2))
    truth[:, 9] = (0.0, 50.0)  # reference length 50 px: 10 px allowed
    est = truth.copy()
    est[0, 3] += (6.0, 8.0)  # 10 px: counts
    est[1, 4] += (0.0, 10.5)  # wrong
    est[1, 7] = np.nan  # missing: wrong, and not in the mean
    assert pck_2d(truth, est) == pytest.approx(40 / 42)
    mean, n = mean_point_error(truth, est)
    assert n == 41 and mean == pytest.approx(20.5 / 41)


def test_auc_of_3d_pck_against_a_direct_integral():
    rng = np.random.default_rng(4)
    e = rng.uniform(0, 80, 500)
    # PCK(τ) is a step function: its mean over a fine grid of τ against the 31-point
    # trapezoid, within the trapezoid's error (steps of 1 mm)
    tau = np.linspace(20, 50, 30001)
    exact = np.mean((e[None, :] <= tau[:, None]).mean(1))
    assert auc_pck_3d(e) == pytest.approx(exact, abs=0.01)
    assert auc_pck_3d([1.0, 2.0]) == 1.0 and auc_pck_3d([60.0]) == 0.0


# --- end to end ------------------------------------------------------------------------------


def test_a_tiny_case_runs_through_init_and_track(tmp_path):
    case = realistic_case("flip", seed=0, frames=(0, 3), size=(320, 180), distractor="none",
                          background=np.full((90, 160, 3), 110, np.uint8),
                          skin="medium")  # fmt: skip
    paths = case.write(tmp_path / "case")
    runner = CliRunner()
    common = ["--calib", str(paths["calib"]), "--keypoints", str(paths["keypoints"][0])]
    res = runner.invoke(main, ["init", str(paths["frames"][0]), *common,
                               "--out", str(tmp_path / "x0.txt")])  # fmt: skip
    assert res.exit_code == 0, res.output
    res = runner.invoke(main, ["track", str(paths["frames"][0]), *common, "--init",
                               str(tmp_path / "x0.txt"), "--out", str(tmp_path / "fit"),
                               "--no-video"])  # fmt: skip
    assert res.exit_code == 0, res.output
    joints = np.loadtxt(tmp_path / "fit" / "joints.csv", delimiter=",", skiprows=1, ndmin=2)
    assert joints.shape == (3, 63)
    # the fit lands near the truth: a tenth of a metre absolute at most on 3 frames
    err = joint_errors(case.joints, joints.reshape(3, 21, 3), alignment="none")
    assert np.nanmean(err) < 100.0
