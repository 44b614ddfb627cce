"""Keypoints carried by optical flow between detections (design §14.5).

Against known image motion (a texture shifted by a known sub-pixel amount), against the
forward–backward rule (a point whose surroundings change is dropped), and against the
detector on the example video (its keypoints withheld on the frames between).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from handvar.data import example_path
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.vision.carry import CarrySettings, KeypointCarrier, TwoWayCarrier, carry_keypoints
from handvar.vision.keypoints import Keypoints2D, read_keypoints
from handvar.vision.sources import open_source

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")


def texture(size: int = 160, seed: int = 0) -> np.ndarray:
    """Smooth random grey texture, float32 in [0, 255]."""
    noise = np.random.default_rng(seed).uniform(0, 255, (size, size)).astype(np.float32)
    return cv2.GaussianBlur(noise, (0, 0), 2.0) * 4.0 - 384.0


def shifted(image: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """`image` moved by (dx, dy) pixels (bicubic), as uint8."""
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    moved = cv2.warpAffine(image, m, image.shape[::-1], flags=cv2.INTER_CUBIC,
                           borderMode=cv2.BORDER_REFLECT)  # fmt: skip
    return np.clip(moved, 0, 255).astype(np.uint8)


def points(n: int = 21, seed: int = 1) -> np.ndarray:
    xy = np.random.default_rng(seed).uniform(50, 110, (n, 2))
    return np.column_stack([xy, np.full(n, 0.9)])


def test_the_carried_points_follow_a_known_motion():
    base, step = texture(), np.array([1.3, -0.7])
    frames = [shifted(base, *(t * step)) for t in range(5)]
    detected = np.full((5, 21, 3), np.nan)
    detected[0] = points()
    carried = carry_keypoints(frames, Keypoints2D.from_array(detected))
    for t in range(1, 5):
        assert carried.present[t].all()
        # LK stops at 0.01 px a step; over four frames the error stays a tenth of a pixel
        np.testing.assert_allclose(carried.xy[t], detected[0, :, :2] + t * step, atol=0.1)
        np.testing.assert_allclose(carried.confidence[t], 0.9)  # the detector's, times 1


@pytest.mark.parametrize("hold", [0.0, 0.5])
def test_a_point_whose_surroundings_change_is_held_or_dropped(hold):
    base = texture()
    later = base.copy()
    later[60:100, 60:100] = texture(seed=7)[60:100, 60:100]  # something moved in front
    frames = [shifted(base, 2, 0), shifted(later, 0, 0), shifted(later, 0, 0)]
    detected = np.full((3, 21, 3), np.nan)
    detected[0, :2] = [[80.0, 80.0, 1.0], [30.0, 30.0, 1.0]]  # occluded, and not
    carried = carry_keypoints(frames, Keypoints2D.from_array(detected), CarrySettings(hold=hold))
    assert carried.present[1:, 1].all()
    np.testing.assert_allclose(carried.xy[1:, 1], [[28.0, 30.0]] * 2, atol=0.05)  # followed
    np.testing.assert_allclose(carried.confidence[1:, 1], 1.0)
    if hold:  # held where the detection put it (one point followed: too few to move it)
        assert carried.present[1:, 0].all()
        np.testing.assert_allclose(carried.xy[1:, 0], 80.0)
        np.testing.assert_allclose(carried.confidence[1:, 0], hold)
    else:
        assert not carried.present[1:, 0].any()
    assert not carried.present[:, 2:].any()  # missing points are not invented


def test_a_held_point_moves_as_the_followed_ones_move():
    base, step = texture(), np.array([1.5, 1.0])
    later = base.copy()
    later[60:100, 60:100] = texture(seed=7)[60:100, 60:100]  # something moved in front
    frames = [shifted(base, 0, 0)] + [shifted(later, *(t * step)) for t in range(1, 4)]
    detected = np.full((4, 21, 3), np.nan)
    detected[0, 0] = [80.0, 80.0, 1.0]  # lost on frame 1
    detected[0, 1:6, :2] = [[25, 25], [30, 130], [130, 30], [130, 130], [35, 80]]
    detected[0, 1:6, 2] = 1.0  # followed: the texture moves by `step` a frame
    carried = carry_keypoints(frames, Keypoints2D.from_array(detected), CarrySettings())
    moved = np.arange(1, 4)[:, None] * step  # frames 1–3
    np.testing.assert_allclose(carried.xy[1:, 1:6], detected[0, 1:6, :2] + moved[:, None], atol=0.1)
    np.testing.assert_allclose(carried.confidence[1:, 0], 0.5)  # held
    # moved as the texture moved, not left where the detection put it
    np.testing.assert_allclose(carried.xy[1:, 0], 80.0 + moved, atol=0.1)


def test_a_lost_point_is_held_for_hold_frames_then_dropped_while_the_others_go_on():
    base = texture()
    later = base.copy()
    later[60:100, 60:100] = texture(seed=7)[60:100, 60:100]
    frames = [shifted(base, 2, 0)] + [shifted(later, 0, 0)] * 3
    detected = np.full((4, 21, 3), np.nan)
    detected[0, :2] = [[80.0, 80.0, 1.0], [30.0, 30.0, 1.0]]
    settings = CarrySettings(hold=0.5, hold_frames=2)
    carried = carry_keypoints(frames, Keypoints2D.from_array(detected), settings)
    assert carried.present[1:3, 0].all() and not carried.present[3, 0]  # held 2 frames
    np.testing.assert_allclose(carried.confidence[1:3, 0], 0.5)
    assert carried.present[1:, 1].all()  # the followed point is carried on
    with pytest.raises(ValueError, match="hold_frames"):
        CarrySettings(hold_frames=-1)


def test_detections_pass_unchanged_and_restart_the_carry():
    base = texture()
    frames = [shifted(base, t, 0) for t in range(6)]
    detected = np.full((6, 21, 3), np.nan)
    detected[0] = points()
    detected[3] = points(seed=2)
    carried = carry_keypoints(frames, Keypoints2D.from_array(detected))
    np.testing.assert_array_equal(carried.to_array()[[0, 3]], detected[[0, 3]])
    np.testing.assert_allclose(carried.xy[5], detected[3, :, :2] + [2.0, 0.0], atol=0.05)


def test_the_carry_is_causal_stops_after_max_frames_and_scales_the_confidence():
    base = texture()
    frames = [shifted(base, 0.5 * t, 0) for t in range(6)]
    detected = np.full((6, 21, 3), np.nan)
    detected[0] = points()
    kp = Keypoints2D.from_array(detected)
    settings = CarrySettings(max_frames=3, confidence=0.5)
    whole = carry_keypoints(frames, kp, settings)
    first = carry_keypoints(frames[:3], kp, settings)  # later frames change nothing before
    np.testing.assert_array_equal(first.to_array()[:3], whole.to_array()[:3])
    assert whole.present[1:4].all() and not whole.present[4:].any()
    np.testing.assert_allclose(whole.confidence[1:4], 0.45)


def test_the_carrier_names_its_wrong_inputs():
    carrier = KeypointCarrier()
    carrier.step(np.zeros((20, 30), np.uint8), points())
    with pytest.raises(ValueError, match=r"image: expected the size of the previous frame"):
        carrier.step(np.zeros((20, 31), np.uint8))
    with pytest.raises(ValueError, match=r"image: expected an \(H, W\) grey"):
        carrier.step(np.zeros((20, 30, 4), np.uint8))
    with pytest.raises(ValueError, match="keypoints: expected keypoints of shape"):
        carrier.step(np.zeros((20, 30), np.uint8), np.zeros((20, 2)))
    with pytest.raises(ValueError, match="max_error"):
        CarrySettings(max_error=0.0)
    with pytest.raises(TypeError, match="settings"):
        KeypointCarrier(settings={"window": 15})


@pytest.mark.parametrize("both, kept", [(False, 0.75), (True, 0.9)])
def test_on_the_example_video_the_carried_points_agree_with_the_withheld_detections(both, kept):
    source = open_source(VIDEO, scale=0.5)
    detected = read_keypoints(KEYPOINTS)
    followed = CarrySettings(hold=0.0)  # the points the flow followed, not those held
    carried = source.carried_keypoints([detected.every(5)], None, followed, both=both)[0]
    truth = source.scaled_keypoints([detected])[0]
    between = np.flatnonzero(np.arange(truth.n_frames) % 5 != 0)
    size = np.linalg.norm(truth.xy[between, MIDDLE_MCP] - truth.xy[between, WRIST], axis=1)
    d = np.linalg.norm(carried.xy[between] - truth.xy[between], axis=2) / size[:, None]
    present = carried.present[between] & truth.present[between]
    # measured forwards: 0.016 hand sizes on average, 99.4 % within 0.2, 85 % of the
    # points kept; both ways 0.014, 99.5 %, 94 %
    assert np.mean(d[present]) < 0.03
    assert np.mean(d[present] < 0.2) > 0.98
    assert present.sum() / truth.present[between].sum() > kept


# --- both ways -----------------------------------------------------------------------------


def test_both_ways_spreads_the_next_detections_disagreement_linearly():
    base, step = texture(), np.array([1.0, 0.5])
    frames = [shifted(base, *(t * step)) for t in range(5)]
    detected = np.full((5, 21, 3), np.nan)
    detected[0] = points()
    error = np.array([0.8, -0.6])  # the second detection is off the image's motion by this
    detected[4] = detected[0] + np.r_[4 * step + error, 0.0]
    carried = carry_keypoints(frames, Keypoints2D.from_array(detected), both=True)
    for t in range(1, 4):
        # forward p0 + t·step, backward p0 + t·step + e; weights (4 - t)/4 and t/4
        want = detected[0, :, :2] + t * step + t / 4 * error
        np.testing.assert_allclose(carried.xy[t], want, atol=0.1)
    forward = carry_keypoints(frames, Keypoints2D.from_array(detected))
    assert np.abs(forward.xy[3] - carried.xy[3]).max() > 0.4  # the blend moved them


def test_at_the_end_only_the_frames_the_detector_did_not_look_at_keep_the_forward_carry():
    base, step = texture(), np.array([1.0, 0.5])
    frames = [shifted(base, *(t * step)) for t in range(6)]
    detected = points()
    carrier = TwoWayCarrier(reach=2)
    for t, image in enumerate(frames):
        carrier.step(image, detected if t == 0 else None)
    # a detector on every 3rd frame did not look at frames 1, 2: carried forward there
    ends = dict(carrier.flush())
    for t in (1, 2):
        np.testing.assert_allclose(ends[t][:, :2], detected[:, :2] + t * step, atol=0.1)
    assert ends[3] is None and ends[5] is None  # it looked at frame 3 and found no hand


def test_before_a_run_its_first_detection_is_carried_back_as_far_as_the_flow_follows_it():
    base, step = texture(), np.array([1.0, 0.5])
    frames = [shifted(base, *(t * step)) for t in range(7)]
    detected = np.full((7, 21, 3), np.nan)
    detected[6] = points()  # the detector found the hand only on frame 6
    kp = Keypoints2D.from_array(detected)
    carried = carry_keypoints(frames, kp, both=True)
    for t in range(6):  # the texture was there all along: carried back to frame 0
        np.testing.assert_allclose(carried.xy[t], detected[6, :, :2] - (6 - t) * step, atol=0.1)
    # as before the rule: only the frames a detector on every 3rd frame did not look at
    skipped = carry_keypoints(frames, kp, CarrySettings(lead_points=None), both=True, every=3)
    assert not skipped.present[:4].any()
    for t in (4, 5):
        np.testing.assert_allclose(skipped.xy[t], detected[6, :, :2] - (6 - t) * step, atol=0.1)
    assert not carry_keypoints(frames, kp, CarrySettings(lead_points=None), both=True).present[
        :6].any()  # fmt: skip


def test_before_a_cut_nothing_is_carried_back_but_to_the_frames_the_detector_skipped():
    base, other, step = texture(), texture(seed=11), np.array([1.0, 0.5])
    # frames 0-2 show another scene: the flow follows no point across the cut
    frames = [shifted(other if t < 3 else base, *(t * step)) for t in range(7)]
    detected = np.full((7, 21, 3), np.nan)
    detected[6] = points()
    kp = Keypoints2D.from_array(detected)
    carried = carry_keypoints(frames, kp, both=True)
    assert not carried.present[:3].any()  # no hand drawn before the cut
    assert carried.present[3:6].all()
    skipped = carry_keypoints(frames, kp, both=True, every=6)  # frames 1-5 not looked at
    assert skipped.present[1:6].all() and not skipped.present[0].any()


def test_both_ways_recovers_a_point_lost_forwards():
    base = texture()
    hidden = base.copy()
    hidden[60:100, 60:100] = texture(seed=7)[60:100, 60:100]  # occluded in frame 1 only
    frames = [shifted(im, 0, 0) for im in (base, hidden, base, base, base)]
    detected = np.full((5, 21, 3), np.nan)
    detected[[0, 4], 0] = [80.0, 80.0, 1.0]
    kp = Keypoints2D.from_array(detected)
    dropping = CarrySettings(hold=0.0)
    forward = carry_keypoints(frames, kp, dropping)
    both = carry_keypoints(frames, kp, dropping, both=True)
    assert not forward.present[1:4, 0].any()  # dropped at the occlusion, not recovered
    assert both.present[2:4, 0].all() and not both.present[1, 0]
    np.testing.assert_allclose(both.xy[2:4, 0], 80.0, atol=0.05)


def test_both_ways_a_point_followed_one_way_and_held_the_other_is_the_followed_one():
    base, patch = texture(), texture(seed=7)[60:100, 60:100]
    frames = []
    for t in range(5):  # from frame 1 a patch covers the point, moving 2 px a frame
        image = base.copy()
        if t:
            image[60:100, 60 + 2 * t : 100 + 2 * t] = patch
        frames.append(shifted(image, 0, 0))
    detected = np.full((5, 21, 3), np.nan)
    still = [[25.0, 25.0], [30.0, 130.0], [130.0, 30.0], [130.0, 135.0]]  # off the patch
    detected[[0, 4], 1:5, :2], detected[[0, 4], 1:5, 2] = still, 1.0
    detected[0, 0], detected[4, 0] = [80.0, 80.0, 1.0], [88.0, 80.0, 1.0]
    kp = Keypoints2D.from_array(detected)
    forward = carry_keypoints(frames, kp)
    np.testing.assert_allclose(forward.confidence[1:4, 0], 0.5)  # lost, held where it was
    np.testing.assert_allclose(forward.xy[1:4, 0], 80.0, atol=0.05)
    both = carry_keypoints(frames, kp, both=True)
    # followed back from frame 4 on the patch: where it is, not a blend with the held one
    # (which would put it 1.5, 2 and 1.5 px short on frames 1-3)
    truth = np.column_stack([80.0 + 2 * np.arange(1, 4), np.full(3, 80.0)])
    np.testing.assert_allclose(both.xy[1:4, 0], truth, atol=0.1)
    np.testing.assert_allclose(both.confidence[1:4, 0], 1.0)
    np.testing.assert_allclose(both.xy[1:4, 1:5], np.broadcast_to(still, (3, 4, 2)), atol=0.05)


def test_a_stereo_source_carries_each_cameras_keypoints_in_its_scaled_pixels(tmp_path):
    from handvar.camera import Rig
    from tests.test_vision_sources import write_folder

    # camera 0 sees a texture move 2 px right a frame, camera 1 2 px left (full size)
    base = texture(size=512)
    folders = []
    for j, step in enumerate((2.0, -2.0)):
        frames = [
            cv2.cvtColor(shifted(base, step * t, 0.0)[16:496, :], cv2.COLOR_GRAY2BGR)
            for t in range(4)
        ]
        frames = [np.pad(f, ((0, 0), (64, 64), (0, 0)), mode="reflect") for f in frames]
        folders.append(write_folder(tmp_path / f"cam{j}", frames))
    calib = tmp_path / "stereo.yml"
    Rig.default().save(calib)
    source = open_source(folders, calib, scale=0.5)
    detected = np.full((4, 21, 3), np.nan)
    detected[0, :3] = [[300.0, 200.0, 1.0], [320.0, 240.0, 1.0], [340.0, 260.0, 1.0]]
    kp = Keypoints2D.from_array(detected)
    left, right = source.carried_keypoints([kp, kp])
    none = source.carried_keypoints([kp, None])[1]
    assert none is None
    start = kp.scaled(0.5, (640, 480)).xy[0, :3]
    for t in range(1, 4):
        np.testing.assert_allclose(left.xy[t, :3], start + np.array([t, 0.0]), atol=0.1)
        np.testing.assert_allclose(right.xy[t, :3], start - np.array([t, 0.0]), atol=0.1)
