"""Tests of handvar.vision.silhouette: clean-up, wrist cut, distance field, real video."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import ndimage

from handvar.data import example_path
from handvar.vision import (
    EmptySilhouetteError,
    HistogramSkinModel,
    SkinModel,
    clean_mask,
    cut_wrist,
    find_wrist,
    nearest_silhouette_pixel,
    silhouettes_from_frames,
    silhouettes_from_videos,
)
from handvar.vision.keypoints import read_keypoints
from handvar.vision.silhouette import split_silhouette

VIDEO = example_path("video")


@pytest.fixture(scope="module")
def model() -> SkinModel:
    return SkinModel()


# --- clean_mask -------------------------------------------------------------------------


def test_clean_mask_removes_speckle_and_fills_holes():
    rng = np.random.default_rng(0)
    truth = np.zeros((120, 160), np.uint8)
    cv2.ellipse(truth, (80, 60), (40, 25), 30, 0, 360, 1, -1)
    truth = truth > 0
    noisy = truth.copy()
    noisy[rng.random(truth.shape) < 0.01] = True  # salt outside
    noisy[50:54, 70:74] = False  # a hole
    noisy[rng.random(truth.shape) < 0.01] = False  # pepper inside
    out = clean_mask(noisy)
    # Opening/closing with disks round the outline by at most a pixel or two.
    assert (out & truth).sum() / (out | truth).sum() > 0.97
    assert out[52, 72]
    assert ndimage.label(out)[1] == 1


def test_clean_mask_keeps_the_largest_components_like_scipy_label():
    rng = np.random.default_rng(1)
    m = rng.random((80, 90)) < 0.45
    labels, _ = ndimage.label(m, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel())[1:]
    top = np.argsort(-sizes, kind="stable")[:3] + 1
    expected = np.isin(labels, top)
    got = clean_mask(m, open_radius=0, close_radius=0, keep=3, fill_holes=False, min_area=0)
    # Ties in size may be resolved differently; compare the kept areas.
    assert got.sum() == expected.sum()
    assert len(np.unique(labels[got])) == 3
    got1 = clean_mask(m, open_radius=0, close_radius=0, fill_holes=False, min_area=0)
    np.testing.assert_array_equal(got1, labels == top[0])


def test_clean_mask_min_area_and_holes():
    m = np.zeros((60, 60), bool)
    m[5:45, 5:45] = True
    m[15:35, 15:35] = False  # a 400-px hole
    m[20:24, 20:24] = True  # an island inside it
    m[50:53, 50:53] = True  # a 9-px blob
    kw = {"open_radius": 0, "close_radius": 0}
    out = clean_mask(m, keep=5, min_area=10, **kw)
    assert not out[51, 51]
    assert out[16:34, 16:34].all()  # hole filled (the island is inside the fill)
    out = clean_mask(m, keep=5, min_area=5, max_hole_area=100, **kw)
    assert out[51, 51]
    assert not out[30, 30]  # the large hole stays open
    # A notch open to the image border is not a hole.
    n = np.zeros((30, 30), bool)
    n[:, 5:25] = True
    n[:10, 12:18] = False
    out = clean_mask(n, **kw)
    assert not out[:10, 12:18].any()


def test_clean_mask_near_keeps_the_component_where_the_hand_is_expected():
    m = np.zeros((100, 120), bool)
    m[5:95, 5:55] = True  # a skin-coloured wall, the largest
    m[30:60, 70:100] = True  # the hand
    expected = np.zeros_like(m)
    expected[35:65, 75:110] = True  # the model's predicted silhouette, a little off
    labels, _ = ndimage.label(m, structure=np.ones((3, 3)))
    out = clean_mask(m, open_radius=0, close_radius=0, near=expected)
    assert np.array_equal(out, labels == labels[45, 85])
    # nothing overlapping where the hand is expected: the largest, as without `near`
    far = np.zeros_like(m)
    far[97:, 110:] = True
    assert np.array_equal(clean_mask(m, near=far), clean_mask(m))
    # two kept: the overlapping one first, then the largest of the rest
    m[70:80, 60:70] = True
    two = clean_mask(m, open_radius=0, close_radius=0, keep=2, near=expected)
    assert two[45, 85] and two[50, 30] and not two[75, 65]
    with pytest.raises(ValueError, match=r"near: expected the mask's shape \(100, 120\)"):
        clean_mask(m, near=np.zeros((10, 10)))


def _disc(shape, centre, radius):
    ys, xs = np.mgrid[: shape[0], : shape[1]]
    return (xs - centre[0]) ** 2 + (ys - centre[1]) ** 2 <= radius**2


def _iou(a, b):
    return (a & b).sum() / (a | b).sum()


@pytest.mark.parametrize("shift", [0, 4])
def test_split_silhouette_gives_each_hand_what_it_covers_the_front_one_the_overlap(shift):
    """Two overlapping discs, one component of skin: each share against the pixels the
    disc shows (the front one whole, the back one where the front does not cover it),
    with the expected discs `shift` px off, as a prediction is; a far blob (a face)
    goes to no hand."""
    shape = (120, 200)
    front, back = _disc(shape, (80, 60), 30), _disc(shape, (125, 60), 30)
    face = _disc(shape, (180, 15), 10)
    skin = front | back | face
    expected = [_disc(shape, (80 + shift, 60 - shift), 30), _disc(shape, (125 - shift, 60), 30)]
    a, b = split_silhouette(skin, expected)
    assert not (a & b).any() and not ((a | b) & face).any()
    assert _iou(a, front) > 0.9 and _iou(b, back & ~front) > 0.85
    # back to front: the overlap goes to the other disc
    b2, a2 = split_silhouette(skin, expected[::-1])
    assert _iou(b2, back) > 0.9 and _iou(a2, front & ~back) > 0.85


def test_split_silhouette_a_hand_expected_nowhere_and_wrong_input():
    shape = (60, 100)
    hand, blob = _disc(shape, (25, 30), 15), _disc(shape, (80, 30), 12)
    first, second = split_silhouette(hand | blob, [_disc(shape, (27, 30), 15), None])
    assert np.array_equal(first, hand) and np.array_equal(second, blob)
    assert [int(s.sum()) for s in split_silhouette(np.zeros(shape), [hand, None])] == [0, 0]
    with pytest.raises(ValueError, match=r"expected\[1\]: expected the mask's shape \(60, 100\)"):
        split_silhouette(hand, [hand, np.zeros((10, 10))])


def test_clean_mask_empty_and_bad_input():
    assert not clean_mask(np.zeros((10, 10), bool)).any()
    with pytest.raises(ValueError, match=r"mask: expected a 2-D \(H, W\) mask"):
        clean_mask(np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match="keep"):
        clean_mask(np.zeros((4, 4)), keep="all")
    with pytest.raises(ValueError, match="open_radius"):
        clean_mask(np.zeros((4, 4)), open_radius=-1)


# --- wrist ------------------------------------------------------------------------------


def synthetic_arm(angle_deg: float, *, forearm: bool = True, size=(480, 480)):
    """A hand-and-forearm silhouette: palm disk, five fingers, a narrowing wrist.

    Drawn in a local frame (palm centre at the origin, forearm along +y, R = 50 px),
    then rotated by ``angle_deg`` about the image centre.  Returns the mask, the true
    wrist point (x, y) and the forearm direction.
    """
    h, w = size
    R = 50.0
    c = np.array([w / 2, h / 2 - 40])
    a = np.deg2rad(angle_deg)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])

    def px(points):
        return np.rint(np.asarray(points, float) @ rot.T + c).astype(np.int32)

    m = np.zeros((h, w), np.uint8)
    cv2.circle(m, tuple(int(v) for v in px([[0, 0]])[0]), int(R), 1, -1)
    for fx in (-0.7, -0.25, 0.2, 0.6):  # fingers up (-y)
        cv2.line(m, tuple(px([[fx * R, -0.6 * R]])[0]), tuple(px([[fx * R, -2.8 * R]])[0]), 1, 16)
    cv2.line(m, tuple(px([[-0.8 * R, 0.1 * R]])[0]), tuple(px([[-2.0 * R, -0.9 * R]])[0]), 1, 18)
    wrist_t = 1.4 * R
    if forearm:
        # Half-width: 0.75 R where it joins the palm, 0.5 R at the wrist, widening to
        # 0.65 R and running far out of the image.
        ts = np.array([0.6, wrist_t / R, 4.0, 12.0]) * R
        hw = np.array([0.75, 0.5, 0.65, 0.7]) * R
        poly = np.concatenate([np.stack([-hw, ts], 1), np.stack([hw, ts], 1)[::-1]])
        cv2.fillPoly(m, [px(poly)], 1)
    wrist = px([[0, wrist_t]])[0].astype(float)
    direction = rot @ np.array([0.0, 1.0])
    return m > 0, wrist, direction, R


@pytest.mark.parametrize("angle", [0.0, 25.0, -40.0, 180.0 + 15.0])
def test_find_wrist_on_synthetic_arm(angle):
    m, wrist, direction, R = synthetic_arm(angle)
    cut = find_wrist(m)  # the forearm leaves the image: followed until its width changes
    assert cut is not None
    assert np.degrees(np.arccos(np.clip(cut.direction @ direction, -1, 1))) < 10
    # Near the narrowest point: the cut is where the widening starts, 0.18 R palmwards
    # of it in this drawing (11 % wider), plus rounding.
    assert np.linalg.norm(cut.wrist - wrist) < 0.35 * R
    hand = cut_wrist(m)
    # Everything beyond the wrist (by 0.4 R) is gone; the palm and fingers stay.
    beyond = ((np.argwhere(m)[:, ::-1] - wrist) @ direction) > 0.4 * R
    assert not hand[m][beyond].any()
    no_arm, *_ = synthetic_arm(angle, forearm=False)
    assert (hand & no_arm).sum() / no_arm.sum() > 0.98


@pytest.mark.parametrize("blob", [1.8, 1.2])
def test_a_silhouette_wider_where_it_enters_the_image_is_still_cut_at_the_wrist(blob):
    # Skin beside the forearm at the image's edge (a shadow, a sleeve's gap) makes the
    # first cross-sections wider: the narrowing after them has no forearm before it.
    m, wrist, _, R = synthetic_arm(0.0)
    h, w = m.shape
    m = m.copy()
    m[h - 25 :, int(w / 2 - blob * R) : int(w / 2 + blob * R)] = True
    cut = find_wrist(m)
    assert cut is not None
    assert np.linalg.norm(cut.wrist - wrist) < 0.35 * R
    assert not cut_wrist(m)[h - 25 :].any()


def test_no_forearm_means_no_cut():
    m, *_ = synthetic_arm(10.0, forearm=False)
    assert find_wrist(m) is None
    np.testing.assert_array_equal(cut_wrist(m), m)


@pytest.mark.parametrize("hand_width", [30, 50, 110])
def test_edge_on_hand_and_fist_on_a_forearm_are_cut_at_the_wrist(hand_width):
    # A forearm leaving the image with a hand narrower (edge-on) or wider (a fist, an
    # open palm) on top: the cut is where the width changes, whichever way.
    m = np.zeros((300, 200), bool)
    m[150:, 60:140] = True  # forearm, 80 px wide, to the bottom border
    m[30:150, 100 - hand_width // 2 : 100 + hand_width // 2] = True
    cut = find_wrist(m)
    assert cut is not None
    assert np.degrees(np.arccos(np.clip(cut.direction @ [0.0, 1.0], -1, 1))) < 5
    assert abs(cut.wrist[1] - 150) < 8  # pixels; the forearm is 80 px wide
    hand = cut_wrist(m)
    assert not hand[160:].any() and hand[30:145].sum() == m[30:145].sum()


def test_thickest_part_at_the_border_is_not_cut_as_palm():
    # Without a change of width (a forearm alone) there is no cut.
    m = np.zeros((300, 200), bool)
    m[100:, 60:140] = True
    assert find_wrist(m) is None
    with pytest.raises(ValueError, match="non-empty"):
        find_wrist(np.zeros((5, 5)))


def test_keypoint_cut_on_synthetic_arm():
    m, wrist, direction, R = synthetic_arm(25.0)
    k = np.full((21, 3), np.nan)
    k[:, 2] = 0.0
    k[0] = (*wrist, 0.9)
    k[9] = (*(wrist - 2.0 * R * direction), 0.9)  # middle MCP towards the fingers
    cut = find_wrist(m, k)
    # 0.1 hand sizes (here 2 R) beyond the detected wrist, perpendicular to its axis
    np.testing.assert_allclose(cut.wrist, wrist + 0.2 * R * direction, atol=1e-9)
    np.testing.assert_allclose(cut.direction, direction, atol=1e-9)
    hand = cut_wrist(m, k)
    beyond = (np.argwhere(m)[:, ::-1] - wrist) @ direction > 0.2 * R + 1
    assert not hand[m][beyond].any()
    # missing wrist: the forearm heuristic decides
    k[0] = (np.nan, np.nan, 0.0)
    assert np.allclose(find_wrist(m, k).wrist, find_wrist(m).wrist)


# --- distance field ---------------------------------------------------------------------


def test_nearest_silhouette_pixel_matches_brute_force():
    rng = np.random.default_rng(2)
    m = rng.random((23, 31)) < 0.05
    nearest, dist = nearest_silhouette_pixel(m)
    inside = np.argwhere(m)[:, ::-1]  # (x, y)
    ys, xs = np.mgrid[0 : m.shape[0], 0 : m.shape[1]]
    grid = np.stack([xs.ravel(), ys.ravel()], 1)
    d = np.linalg.norm(grid[:, None, :] - inside[None, :, :], axis=2)
    np.testing.assert_allclose(dist.ravel(), d.min(axis=1), atol=1e-9)
    # The returned pixel is inside and at the minimum distance (ties allowed).
    assert m[nearest[..., 1], nearest[..., 0]].all()
    got = np.linalg.norm(nearest.reshape(-1, 2) - grid, axis=1)
    np.testing.assert_allclose(got, d.min(axis=1), atol=1e-9)
    with pytest.raises(ValueError, match="non-empty"):
        nearest_silhouette_pixel(np.zeros((3, 3)))


# --- cameras ----------------------------------------------------------------------------


def _skin_scene(h=120, w=160):
    img = np.full((h, w, 3), (150, 120, 90), np.uint8)  # BGR blue-grey
    truth = np.zeros((h, w), np.uint8)
    cv2.ellipse(truth, (w // 2, h // 2), (35, 25), 20, 0, 360, 1, -1)
    img[truth > 0] = (110, 140, 200)  # BGR skin tone
    return img, truth > 0


def test_silhouettes_from_frames_for_several_cameras(model):
    a, ta = _skin_scene()
    b, tb = _skin_scene(90, 200)
    masks = silhouettes_from_frames([a, b], model)
    assert len(masks) == 2
    for got, truth in zip(masks, [ta, tb], strict=True):
        assert got.shape == truth.shape
        assert (got & truth).sum() / (got | truth).sum() > 0.97
    (single,) = silhouettes_from_frames(a, model)
    np.testing.assert_array_equal(single, masks[0])
    rgb = silhouettes_from_frames([a[..., ::-1].copy()], model, order="rgb")
    np.testing.assert_array_equal(rgb[0], masks[0])


def test_skin_colour_touching_every_border_is_not_a_hand(model):
    from handvar.vision import NotAHandError

    a, _ = _skin_scene()
    everywhere = np.full_like(a, (110, 140, 200))  # the scene's skin tone, wall to wall
    with pytest.raises(NotAHandError, match=r"camera 'right', frame 3: not a hand .* 100%"):
        silhouettes_from_frames([a, everywhere], model, frame=3, cameras=["left", "right"])
    # skin reaching three borders is kept: a hand close to the camera leaves one free
    for free in (slice(0, 8), slice(-8, None)):  # the top rows, then the bottom ones
        b = everywhere.copy()
        b[free] = (150, 120, 90)
        (mask,) = silhouettes_from_frames([b], model)
        assert 0.85 < mask.mean() < 0.95


def test_empty_silhouette_names_camera_and_frame(model):
    a, _ = _skin_scene()
    empty = np.full_like(a, (150, 120, 90))
    with pytest.raises(EmptySilhouetteError, match=r"camera 'right', frame 7: empty") as err:
        silhouettes_from_frames([a, empty], model, frame=7, cameras=["left", "right"])
    assert err.value.camera == "right"
    assert err.value.frame == 7
    assert isinstance(err.value, ValueError)
    with pytest.raises(ValueError, match=r"frames \(camera 0\): image: expected a uint8"):
        silhouettes_from_frames([a.astype(np.float32)], model)
    with pytest.raises(ValueError, match="cameras: expected 2 names"):
        silhouettes_from_frames([a, a], model, cameras=["x"])


def test_silhouettes_with_a_histogram_model():
    a, ta = _skin_scene()
    hist = HistogramSkinModel.fit([a], [ta], bins=32)
    (got,) = silhouettes_from_frames([a], hist)
    assert (got & ta).sum() / (got | ta).sum() > 0.97


# --- the real video ---------------------------------------------------------------------
#
# Area bounds for a hand-and-forearm silhouette in this 1280×720 video: the hand (wrist
# to fingertip) is 230–280 px long and a spread hand fills roughly half of its square
# bounding box (25–40 k px); the forearm from the wrist to the bottom edge is
# 300–400 px long and 80–110 px wide (25–45 k px).  Observed: 50–81 k px.  Bounds
# [35 k, 110 k] allow for a fist or an edge-on hand and reject both a lost hand and a
# merge with the background.  Regions that are background in every frame (checked by
# eye): the wall strip at the top, the monitor at the left, the toy and the cup at the
# bottom left, the checked shirt at the bottom right.
AREA_BOUNDS = (35_000, 110_000)
BACKGROUND_BOXES = {  # name: (x0, x1, y0, y1), pixels
    "wall": (0, 1280, 0, 60),
    "monitor": (0, 60, 0, 720),
    "toy and cup": (150, 560, 500, 720),
    "shirt": (1080, 1280, 560, 720),
}


KEYPOINTS = read_keypoints(example_path("video-keypoints"))


def check_video_silhouette(index: int, sil: np.ndarray) -> None:
    n = ndimage.label(sil, structure=np.ones((3, 3)))[1]
    assert n == 1, f"frame {index}: {n} components"
    area = int(sil.sum())
    assert AREA_BOUNDS[0] <= area <= AREA_BOUNDS[1], f"frame {index}: area {area}"
    for name, (x0, x1, y0, y1) in BACKGROUND_BOXES.items():
        assert not sil[y0:y1, x0:x1].any(), f"frame {index}: silhouette reaches the {name}"
    # The forearm leaves the image at the bottom.
    assert sil[-1].any(), f"frame {index}: no forearm at the bottom edge"
    hand = cut_wrist(sil, KEYPOINTS.frame(index))  # at the detected wrist
    if hand.sum() < area:  # a cut was made: the hand part no longer reaches the bottom
        assert not hand[-1].any(), f"frame {index}: hand part reaches the bottom"
        assert 15_000 <= hand.sum() <= 60_000, f"frame {index}: hand area {hand.sum()}"


@pytest.mark.parametrize("index", [0, 100, 262, 270, 510, 527])
def test_forearm_cut_on_real_frames_meets_the_detected_wrist(model, index):
    """Without keypoints the cut still lands near MediaPipe's wrist (open, fist, edge-on)."""
    cap = cv2.VideoCapture(str(VIDEO))
    cap.set(cv2.CAP_PROP_POS_FRAMES, index)
    ok, image = cap.read()
    cap.release()
    assert ok
    (sil,) = silhouettes_from_frames([image], model)
    k = KEYPOINTS.frame(index)
    size = np.linalg.norm(k[9, :2] - k[0, :2])
    cut = find_wrist(sil)
    assert abs((cut.wrist - k[0, :2]) @ cut.direction) < 0.25 * size


def test_real_video_silhouettes_subset(model):
    seen = 0
    for index, (sil,) in silhouettes_from_videos([VIDEO], model, step=31):
        check_video_silhouette(index, sil)
        seen += 1
    assert seen == 21  # 621 frames


@pytest.mark.slow
def test_real_video_silhouettes_every_frame(model):
    seen = 0
    for index, (sil,) in silhouettes_from_videos([VIDEO], model):
        check_video_silhouette(index, sil)
        seen += 1
    assert seen == 621


def test_real_video_agrees_with_an_independent_skin_rule(model):
    # Chai & Ngan (1999) YCrCb box (Cr 133–173, Cb 77–127), computed by OpenCV, with the
    # same clean-up.  The Jones–Rehg silhouette lies inside it and covers most of it
    # above row 500 (below, the YCrCb box also takes the desk and the shirt).
    cap = cv2.VideoCapture(str(VIDEO))
    try:
        for _ in range(3):
            for _ in range(150):
                ok, frame = cap.read()
                assert ok
            ours = silhouettes_from_frames([frame], model)[0][:500]
            ycc = cv2.cvtColor(frame, cv2.COLOR_BGR2YCrCb)
            ref = clean_mask(cv2.inRange(ycc, (0, 133, 77), (255, 173, 127)) > 0)[:500]
            both = (ours & ref).sum()
            assert both / ours.sum() > 0.98
            assert both / ref.sum() > 0.85
    finally:
        cap.release()


def test_silhouettes_from_videos_rejects_missing_file(tmp_path, model):
    with pytest.raises(ValueError, match="paths: expected a readable video file"):
        list(silhouettes_from_videos([tmp_path / "none.mp4"], model))
