"""Tests of handvar.tracking.init: the orientation grid, IoU, the search."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.camera import Camera, Rig
from handvar.hand import HandModel, named_pose
from handvar.hand.kinematics import world_from_hand_rotation
from handvar.render import silhouettes
from handvar.tracking.init import (
    InitSettings,
    candidate_rotations,
    initial_pose,
    silhouette_iou,
)
from handvar.vision.sources import assumed_camera


@pytest.fixture(scope="module")
def hand() -> HandModel:
    return HandModel()


def test_candidate_rotations_face_the_camera_as_specified():
    # A camera looking along world +x: palm candidates without tilt must have the palm
    # normal (hand +z) towards the camera and the fingers (hand +y) up in its image.
    cam = Camera.look_at((-500.0, 0.0, 0.0), (0.0, 0.0, 0.0), fx=600.0)
    settings = InitSettings(roll=(0.0, 90.0), pitch=(0.0,), yaw=(0.0, 30.0), back=True)
    angles = candidate_rotations(cam, settings)
    assert angles.shape == (2 * 2 * 1 * 2, 3)
    R = np.stack([world_from_hand_rotation(a)[0] for a in angles])
    normal_cam = np.einsum("ij,kj->ki", cam.R, R[:, :, 2])  # hand z in camera coordinates
    fingers_cam = np.einsum("ij,kj->ki", cam.R, R[:, :, 1])
    # order: side (palm, back) × roll × yaw × pitch
    palm_straight, palm_rolled = 0, 2
    np.testing.assert_allclose(normal_cam[palm_straight], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(fingers_cam[palm_straight], [0, -1, 0], atol=1e-12)
    # roll 90° about the optical axis (x → y): fingers point along image +x
    np.testing.assert_allclose(fingers_cam[palm_rolled], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(normal_cam[palm_rolled], [0, 0, -1], atol=1e-12)
    back_straight = 4
    np.testing.assert_allclose(normal_cam[back_straight], [0, 0, 1], atol=1e-12)
    # yaw 30°: the palm normal leaves the optical axis by 30°
    tilt = np.degrees(np.arccos(-normal_cam[1, 2]))
    assert tilt == pytest.approx(30.0, abs=1e-9)


def test_candidate_rotations_reproduce_named_pose_in_front_of_a_plain_camera():
    cam = Camera(600.0, 600.0, 319.5, 239.5, t=[0.0, 0.0, 500.0])
    settings = InitSettings(roll=(0.0,), pitch=(0.0,), yaw=(0.0,), back=False)
    R = world_from_hand_rotation(candidate_rotations(cam, settings)[0])[0]
    np.testing.assert_allclose(R, world_from_hand_rotation(named_pose("open")[3:6])[0], atol=1e-12)


def test_silhouette_iou_hand_computed():
    a = np.zeros((2, 4, 4), bool)
    b = np.zeros((2, 4, 4), bool)
    a[0, :2, :2] = True  # 4 px
    b[0, :2, :3] = True  # 6 px, 4 shared -> 4/6
    a[1, 0, 0] = b[1, 3, 3] = True  # disjoint -> 0
    assert silhouette_iou(a, b) == pytest.approx((4 / 6 + 0.0) / 2)
    assert silhouette_iou(a[0], a[0]) == 1.0
    with pytest.raises(ValueError, match="rendered, observed: expected silhouettes of one shape"):
        silhouette_iou(a, b[:1])


@pytest.mark.slow
def test_initial_pose_stereo_recovers_an_off_grid_pose(hand):
    # Rotation 10–25° away from every grid point, the pinch shape, the paper's stereo rig.
    rig = Rig.default()
    truth = named_pose("pinch")
    truth[:6] = [20.0, 90.0, -10.0, 165.0, -20.0, 40.0]
    masks = silhouettes(hand, truth, rig)
    result = initial_pose(masks, rig, hand, rng=np.random.default_rng(0))
    error = np.linalg.norm(hand.joints(result.pose) - hand.joints(truth), axis=1).mean()
    assert result.iou > 0.9
    assert error < 8.0  # mm, measured 3.8
    assert result.n_candidates == 6 * 12 * 3 * 3 * 2


def test_initial_pose_monocular_fits_the_image_not_the_depth(hand):
    # One assumed camera: the image-plane fit is reliable, depth much less so.
    rig = Rig((assumed_camera((640, 480)),))
    truth = named_pose("point")
    truth[:6] = [-20.0, 80.0, 550.0, 200.0, 15.0, 100.0]
    settings = InitSettings(shapes=("open", "point", "fist"))
    result = initial_pose(silhouettes(hand, truth, rig)[0], rig, hand, settings=settings)
    pixels = np.linalg.norm(
        rig[0].project(hand.joints(result.pose)) - rig[0].project(hand.joints(truth)), axis=1
    )
    assert result.iou > 0.9
    assert pixels.mean() < 8.0  # px, measured 3.8
    assert abs(result.pose[2] - truth[2]) < 0.1 * truth[2]  # depth within 10 %


def test_initial_pose_bad_input(hand):
    rig = Rig.default()
    masks = silhouettes(hand, named_pose("open"), rig)
    with pytest.raises(ValueError, match=r"masks: expected \(n_cams, H, W\) silhouettes for 2"):
        initial_pose(masks[:1], rig, hand)
    with pytest.raises(ValueError, match="calibrated for 640x480 images; got masks of 320x480"):
        initial_pose(masks[:, :, :320], rig, hand)
    empty = masks.copy()
    empty[1] = False
    with pytest.raises(ValueError, match="non-empty silhouette in camera 'right'"):
        initial_pose(empty, rig, hand)
    with pytest.raises(ValueError, match="shapes: expected names among"):
        InitSettings(shapes=("claw",))
    with pytest.raises(ValueError, match="keep: expected an integer >= 1"):
        InitSettings(keep=0)
