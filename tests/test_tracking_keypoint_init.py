"""The pose of a frame from its keypoints alone (`reinitialise`, from the palm's
perspective-n-point poses) and the keypoint-aware initial pose (design §14.1)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.camera import Rig
from handvar.cli import main
from handvar.data import example_path
from handvar.hand import HandModel, named_pose
from handvar.hand.kinematics import world_from_hand_rotation
from handvar.render import silhouettes
from handvar.tracking.frame_fit import FrameFitSettings, reinitialise
from handvar.tracking.init import INIT_SETTINGS, InitSettings, initial_pose
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.tracking.keypoint_fit import keypoint_error, palm_candidates

HAND = HandModel()
RIG = Rig.default()
MONO = Rig((RIG.cameras[0],), (RIG.names[0],))


def fit_keypoints(keypoints, rig, hand, *, tips="end", shapes=INIT_SETTINGS.keypoint_shapes):
    """`reinitialise` as `handvar init` runs it."""
    if isinstance(keypoints, np.ndarray):  # one camera's
        keypoints = [keypoints]
    return reinitialise(keypoints, rig, hand, settings=FrameFitSettings(tips=tips), shapes=shapes)


def pixels(fit, rig, keypoints, tips="end") -> float:
    return keypoint_error(fit.pose, HAND, rig, keypoints, tips=tips)


def angle_between(a, b) -> float:
    Ra, Rb = world_from_hand_rotation(a)[0], world_from_hand_rotation(b)[0]
    return float(np.degrees(np.arccos(np.clip((np.trace(Ra.T @ Rb) - 1) / 2, -1, 1))))


def noisy_keypoints(x, rig, seed, sigma=3.0):
    rng = np.random.default_rng(seed)
    return [cam.project(HAND.joints(x)) + rng.normal(0, sigma, (21, 2)) for cam in rig]


def test_palm_candidates_contain_the_true_palm_pose():
    x = named_pose("spread")
    x[3:6] = (170.0, 20.0, -15.0)
    k = MONO.cameras[0].project(HAND.joints(x))
    cands = palm_candidates(k, MONO.cameras[0], HAND)
    assert len(cands) == 4  # the two planar solutions, each with the other side
    best = min(cands, key=lambda p: angle_between(p[3:6], x[3:6]))
    assert angle_between(best[3:6], x[3:6]) < 1e-3
    np.testing.assert_allclose(best[:3], x[:3], atol=1e-3)


def test_palm_poses_lie_in_front_of_the_camera_whatever_the_noise():
    """Noise can make the flat palm's five points look like a view no pose in front of
    the camera gives (IPPE's poses then lie behind it: a point reflection through the
    camera's centre projects alike); every candidate must still be in front of it.
    About 1 in 20 of these noisy views did that before SQPnP's fallback."""
    cam = MONO.cameras[0]
    rng = np.random.default_rng(0)
    for i in range(200):
        x = named_pose("spread")
        x[3:6] = (rng.uniform(120, 240), rng.uniform(-60, 60), rng.uniform(-60, 60))
        k = cam.project(HAND.joints(x)) + rng.normal(0, 3.0, (21, 2))
        cands = palm_candidates(k, cam, HAND)
        assert len(cands) and (cam.camera_from_world(cands[:, :3])[:, 2] > 0).all()
        if i % 20 == 0:  # and the fits from them
            fit = fit_keypoints(k, MONO, HAND, shapes=("open",))
            assert (cam.camera_from_world(HAND.joints(fit.pose))[:, 2] > 0).all()


# (pose name, palm orientation): palm towards the camera (rx = 180°) and the back of the
# hand towards it (turned 180° about the hand's long axis), tilted and rolled.
CASES = [
    ("spread", (180.0, 0.0, 0.0)),
    ("spread", (180.0, 180.0, 0.0)),
    ("fist", (160.0, 20.0, 25.0)),
    ("fist", (200.0, 160.0, -20.0)),
    ("point", (200.0, 30.0, -40.0)),
]


@pytest.mark.parametrize(("name", "rotation"), CASES)
def test_monocular_fit_recovers_the_pose_from_noisy_keypoints(name, rotation):
    """3 px noise, one camera, ten noisy views: the keypoints explained within the noise,
    the side of the hand facing the camera right on every view, the orientation a median
    of less than 20° off and the joints less than 25 mm.  A flat hand facing the camera
    squarely tilts by up to about 25° (one camera sees that tilt poorly); a turned or
    curled hand stays within 10°."""
    x = named_pose(name)
    x[3:6] = rotation
    view = MONO.cameras[0].R[2]
    nz_true = world_from_hand_rotation(x[3:6])[0][:, 2] @ view
    turns, errors = [], []
    for seed in range(10):
        k = noisy_keypoints(x, MONO, seed=seed)
        fit = fit_keypoints(k, MONO, HAND)
        assert pixels(fit, MONO, k) < 5.0  # about the noise
        # the side facing the camera: the palm normal (hand z) along the view as the truth's
        nz_fit = world_from_hand_rotation(fit.pose[3:6])[0][:, 2] @ view
        assert np.sign(nz_fit) == np.sign(nz_true)
        turns.append(angle_between(fit.pose[3:6], x[3:6]))
        errors.append(np.linalg.norm(HAND.joints(fit.pose) - HAND.joints(x), axis=1).mean())
    assert np.median(turns) < 20.0
    assert np.median(errors) < 25.0  # mm
    if name != "spread":
        assert max(turns) < 10.0


def test_fingertips_marked_at_the_pads_are_fitted_with_pad_tips():
    """Keypoints with the tips at the pads' centres (MediaPipe's, design §14.6), exact, stereo."""
    x = named_pose("point")
    P = keypoint_points(HAND, x, "pad")
    kps = [cam.project(P) for cam in RIG]
    pad = fit_keypoints(kps, RIG, HAND, tips="pad")
    end = fit_keypoints(kps, RIG, HAND)
    # pixels, each against its own model points
    assert pixels(pad, RIG, kps, "pad") < 0.1 < pixels(end, RIG, kps)
    truth = HAND.joints(x)
    assert np.abs(HAND.joints(pad.pose) - truth).max() < 0.5  # mm
    assert np.abs(HAND.joints(end.pose) - truth).max() > 1.0
    with pytest.raises(ValueError, match="tips: expected one of"):
        FrameFitSettings(tips="nail")


def test_the_two_sides_of_the_hand_are_told_apart():
    """Palm and back towards the camera, ten noisy views of each: every fit is turned
    far more from the other side's pose than from its truth's (one camera with 3 px of
    noise tilts a flat palm by up to about 25°)."""
    palm, back = named_pose("spread"), named_pose("spread")
    back[3:6] = (180.0, 180.0, 0.0)
    for x, other in ((palm, back), (back, palm)):
        fits = [fit_keypoints(noisy_keypoints(x, MONO, seed=s), MONO, HAND) for s in range(10)]
        assert max(angle_between(f.pose[3:6], x[3:6]) for f in fits) < 30.0
        assert min(angle_between(f.pose[3:6], other[3:6]) for f in fits) > 140.0


def test_stereo_fit_and_missing_points():
    x = named_pose("pinch")
    k = noisy_keypoints(x, RIG, seed=3)
    k[1][[3, 4, 8]] = np.nan  # occluded in the second camera
    fit = fit_keypoints(k, RIG, HAND)
    assert np.linalg.norm(HAND.joints(fit.pose) - HAND.joints(x), axis=1).mean() < 10.0
    assert fit.starts == 2 * 4 * 3  # two cameras' four palm poses, three postures each
    # no camera shows the whole palm: no fit
    k[0][5] = np.nan
    k[1][0] = np.nan
    assert fit_keypoints(k, RIG, HAND) is None
    with pytest.raises(ValueError, match=r"one .* per camera"):
        fit_keypoints(k[:1], RIG, HAND)


QUICK = InitSettings(
    shapes=("open",), roll=(0.0,), pitch=(0.0,), yaw=(0.0,), back=False, refine_passes=2
)


def test_initial_pose_uses_keypoints_and_falls_back_without_them():
    x = named_pose("fist")
    x[3:6] = (170.0, 150.0, 10.0)  # back of the hand towards the camera
    masks = silhouettes(HAND, x, MONO)
    k = noisy_keypoints(x, MONO, seed=4)
    res = initial_pose(masks, MONO, HAND, keypoints=k, settings=QUICK)
    assert res.shape == "keypoints"
    assert res.keypoint_error < 6.0
    assert angle_between(res.pose[3:6], x[3:6]) < 15.0
    assert res.iou > 0.6
    k[0][0] = np.nan  # no wrist: the silhouette search
    res = initial_pose(masks, MONO, HAND, keypoints=k, settings=QUICK)
    assert res.shape == "open" and np.isnan(res.keypoint_error)


def test_init_command_with_keypoints(tmp_path):
    video = example_path("video")
    kp = example_path("video-keypoints")
    out = tmp_path / "pose.txt"
    res = CliRunner().invoke(
        main,
        ["init", str(video), "--scale", "0.5", "--frame", "262", "--keypoints", str(kp),
         "--out", str(out)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "shape keypoints" in res.output
    error = float(res.output.split("keypoint error ")[1].split(" px")[0])
    assert error < 6.0  # pixels at half resolution; the hand is about 35 px to the MCP
    assert np.loadtxt(out).shape == (26,)
    bad = CliRunner().invoke(
        main, ["init", str(video), "--keypoints", str(kp), "--keypoints", str(kp)]
    )
    assert bad.exit_code == 2 and "expected one file per source (1); got 2" in bad.output


@pytest.mark.parametrize("wall", ["skin", "none"])
def test_init_command_with_keypoints_needs_no_silhouette(tmp_path, wall):
    """With keypoints the keypoints place the hand: a frame whose skin colour fills the
    image (not a hand) or is nowhere still gives the pose that explains them."""
    import cv2

    x = named_pose("spread")
    k = noisy_keypoints(x, MONO, seed=2)[0]
    w, h = MONO.cameras[0].size
    colour = (120, 150, 210) if wall == "skin" else (40, 160, 40)  # BGR: skin, green
    folder = tmp_path / "frames"
    folder.mkdir()
    cv2.imwrite(str(folder / "0000.png"), np.full((h, w, 3), colour, np.uint8))
    np.save(tmp_path / "kp.npy", k[None])
    MONO.save(tmp_path / "calib.yml")
    out = tmp_path / "x0.txt"
    res = CliRunner().invoke(
        main, ["init", str(folder), "--calib", str(tmp_path / "calib.yml"),
               "--keypoints", str(tmp_path / "kp.npy"), "--out", str(out)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    pose = np.loadtxt(out)
    G = keypoint_points(HAND, pose, "end")
    assert np.linalg.norm(MONO.cameras[0].project(G) - k[:, :2], axis=1).mean() < 6.0
    # without keypoints, the same frame is refused
    res = CliRunner().invoke(main, ["init", str(folder), "--calib", str(tmp_path / "calib.yml"),
                                    "--out", str(tmp_path / "y.txt")])  # fmt: skip
    assert res.exit_code == 2 and not (tmp_path / "y.txt").exists()
    if wall == "none":  # and a frame the detector missed: nothing to place the hand by
        cv2.imwrite(str(folder / "0001.png"), np.full((h, w, 3), colour, np.uint8))
        # (a file without any detection is refused as `handvar track` refuses it)
        np.save(tmp_path / "missed.npy", np.stack([np.full((21, 2), np.nan), k[:, :2]]))
        res = CliRunner().invoke(
            main, ["init", str(folder), "--calib", str(tmp_path / "calib.yml"),
                   "--keypoints", str(tmp_path / "missed.npy"), "--out", str(tmp_path / "z.txt")],
        )  # fmt: skip
        assert res.exit_code == 2 and not (tmp_path / "z.txt").exists()
        assert "--keypoints: expected keypoints or a hand's silhouette in frame 0" in res.output
