"""Two-hand recordings (`handvar.evaluation.two_hands`) and their score.

The generator against its own truth (each scenario does what it says, the visible points
land on their hand's visible pixels, the same seed gives the same bytes), the detector's
labels and order against the rates it states, the files against a round trip, and the
score against hand-worked tracks (the truth itself, two tracks swapped halfway).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from handvar.evaluation.realistic import _render_view, realistic_rig
from handvar.evaluation.two_hands import (
    SCENARIOS,
    SwapErrors,
    detections_as_tracks,
    read_two_hand_case,
    score_two_hands,
    two_hand_case,
)
from handvar.synth.keypoints import hand_size_px

SMALL = (160, 90)


@pytest.fixture(scope="module")
def cases():
    return {name: two_hand_case(name, seed=1, size=SMALL) for name in SCENARIOS}


def _true_hand(case, j, t, detection) -> int:
    """Which true hand a detection reports (its points are that hand's keypoints)."""
    for k in range(2):
        if np.array_equal(case.keypoints[j, k, t], detection.points, equal_nan=True):
            return k
    raise AssertionError("a detection that is neither hand's keypoints")


def test_the_same_seed_gives_the_same_bytes():
    a = two_hand_case("clap", seed=2, size=SMALL, frames=(35, 45))
    b = two_hand_case("clap", seed=2, size=SMALL, frames=(35, 45))
    for name in ("frames", "masks", "keypoints", "visible", "in_view", "merged"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
    for fa, fb in zip(a.detections[0], b.detections[0], strict=True):
        assert [(d.side, d.score) for d in fa] == [(d.side, d.score) for d in fb]
        for da, db in zip(fa, fb, strict=True):
            assert np.array_equal(da.points, db.points, equal_nan=True)
    c = two_hand_case("clap", seed=3, size=SMALL, frames=(35, 45))
    assert not np.array_equal(a.frames, c.frames)


def test_two_hands_of_one_person(cases):
    c = cases["apart"]
    assert c.sides == ("left", "right")
    assert np.all((c.hand_length >= 165.0) & (c.hand_length <= 200.0))
    assert c.hand_length[0] != c.hand_length[1]
    # the true points' reach: wrist to the middle tip's pad, at most a little short of
    # the hand's length (the hands open at some time)
    reach = np.linalg.norm(c.joints[:, :, 12] - c.joints[:, :, 0], axis=-1).max(1)
    assert np.all(reach < c.hand_length) and np.all(reach > 0.85 * c.hand_length)
    # the left hand on the image's right, the right hand on its left, both in view
    assert c.in_view.all()
    assert np.all(c.truth_2d[0, 0, :, 0, 0] > c.truth_2d[0, 1, :, 0, 0])


def test_cross_hides_most_of_one_hand(cases):
    c = cases["cross"]
    visible = c.visible[0].mean(-1)  # (2, T)
    assert visible.min() < 0.5
    # the hands swap sides
    x = c.truth_2d[0, :, :, 0, 0]
    assert x[0, 0] > x[1, 0] and x[0, -1] < x[1, -1]


def test_leave_goes_out_of_view_and_comes_back(cases):
    c = cases["leave"]
    view = c.in_view[0]
    k = int(np.argmin(view.sum(1)))  # the hand that leaves
    assert view[1 - k].all()
    assert view[k, 0] and view[k, -1]
    out = np.flatnonzero(~view[k])
    assert out.size >= c.fps  # a second or more
    assert np.all(np.diff(out) == 1)  # one run
    assert not c.detected[0, k, out].any()


def test_clap_brings_the_hands_together(cases):
    c = cases["clap"]
    lo, hi = c.truth_2d[0].min(axis=2), c.truth_2d[0].max(axis=2)  # (2, T, 2)
    boxes_meet = np.all((lo[0] <= hi[1]) & (lo[1] <= hi[0]), axis=-1)
    assert boxes_meet.sum() >= 10
    assert c.overlap[0].any()


def test_visible_points_lie_on_their_own_hands_visible_pixels(cases):
    for name in ("cross", "occlude", "clap"):
        c = cases[name]
        near = []
        for k in range(2):
            for t in range(0, c.n_frames, 4):
                rows, cols = np.nonzero(c.masks[0, k, t])
                uv = c.truth_2d[0, k, t, c.visible[0, k, t]]
                if not len(uv) or not rows.size:
                    continue
                d = np.min(np.hypot(cols[None] - uv[:, :1], rows[None] - uv[:, 1:]), axis=1)
                near.append(d <= 2.0)
        assert np.mean(np.concatenate(near)) >= 0.95, name
        # a hand's visible pixels are its own: the two masks never share a pixel
        assert not (c.masks[0, 0] & c.masks[0, 1]).any()


def test_hidden_points_are_flagged_and_mostly_hidden_hands_not_detected(cases):
    c = cases["cross"]
    conf = c.keypoints[0, ..., 2]
    det = c.detected[0]
    assert np.all(conf[det] == np.where(c.visible[0][det], 1.0, SwapErrors().hidden_confidence))
    hidden = 1.0 - c.visible[0].mean(-1)
    assert not det[hidden > SwapErrors().hidden].any()
    assert np.isnan(c.keypoints[0][~det]).all()


def test_labels_are_wrong_on_about_the_requested_fraction(cases):
    wrong, total, first = 0, 0, []
    for c in cases.values():
        for t, found in enumerate(c.detections[0]):
            for d in found:
                k = _true_hand(c, 0, t, d)
                wrong += d.side != c.sides[k]
                total += 1
                assert 0.5 < d.score < 1.0
            if len(found) == 2:
                first.append(_true_hand(c, 0, t, found[0]))
    # runs of 1-5 frames at 10 %: over ~1000 detections, within a few points
    assert abs(wrong / total - SwapErrors().label) < 0.05, wrong / total
    # the order of a frame's detections says nothing of the hand
    assert 0.3 < np.mean(first) < 0.7


def test_merged_frames_give_the_front_hand_only(cases):
    merged = 0
    for c in cases.values():
        for t in np.flatnonzero(c.merged[0]):
            assert c.overlap[0, t]
            assert len(c.detections[0][t]) == 1
            merged += 1
    assert merged > 0
    nothing = dataclasses.replace(SwapErrors(), merge=0.0, label=0.0)
    c = two_hand_case("clap", seed=1, size=SMALL, frames=(36, 46), swaps=nothing)
    assert not c.merged.any()
    assert all(d.side == c.sides[_true_hand(c, 0, t, d)]
               for t, found in enumerate(c.detections[0]) for d in found)  # fmt: skip


def test_write_and_read_back(tmp_path):
    a = two_hand_case("occlude", seed=0, size=SMALL, frames=(40, 44))
    paths = a.write(tmp_path)
    assert [p.name for p in paths["detections"]] == ["detections0.json"]
    b = read_two_hand_case(tmp_path, frames=True)
    for name in ("poses", "joints", "truth_2d", "visible", "in_view", "masks", "keypoints",
                 "detected", "wrong_label", "merged", "hand_length"):  # fmt: skip
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
    assert b.frames.shape == a.frames.shape
    assert np.abs(b.frames.astype(int) - a.frames).mean() < 8.0  # JPEG of a noisy frame
    for fa, fb in zip(a.detections[0], b.detections[0], strict=True):
        assert [(d.side, d.score) for d in fa] == [(d.side, d.score) for d in fb]
        for da, db in zip(fa, fb, strict=True):
            assert np.array_equal(da.points, db.points, equal_nan=True)
    np.testing.assert_allclose(b.rig[0].project(a.joints[0, 0]), a.truth_2d[0, 0, 0], atol=1e-6)


def _true_tracks(case):
    return {side: {"points_2d": case.truth_2d[0, k].copy(), "joints": case.joints[k].copy()}
            for k, side in enumerate(case.sides)}  # fmt: skip


def test_the_truth_scores_perfectly(cases):
    c = cases["apart"]
    s = score_two_hands(c, _true_tracks(c))
    np.testing.assert_array_equal(s.pck, [1.0, 1.0])
    np.testing.assert_array_equal(s.mpjpe, [0.0, 0.0])
    np.testing.assert_allclose(s.mpjpe_relative, [0.0, 0.0], atol=1e-12)
    assert s.switches == 0 and s.lost.tolist() == [0, 0]
    assert s.frames_in_view.tolist() == [c.n_frames] * 2
    np.testing.assert_array_equal(s.match, [[0] * c.n_frames, [1] * c.n_frames])


def test_tracks_swapped_halfway_switch_identity_four_times(cases):
    c = cases["apart"]
    true = _true_tracks(c)
    m = c.n_frames // 2
    a = {key: value.copy() for key, value in true["left"].items()}
    b = {key: value.copy() for key, value in true["right"].items()}
    for key in ("points_2d", "joints"):
        a[key][m:], b[key][m:] = true["right"][key][m:], true["left"][key][m:]
    s = score_two_hands(c, {7: a, 9: b})
    # track 7 goes left → right, track 9 right → left; the left hand's track 7 → 9, the
    # right hand's 9 → 7
    assert (s.track_switches, s.hand_switches, s.switches) == (2, 2, 4)
    np.testing.assert_array_equal(s.pck, [1.0, 1.0])
    # a track that vanishes for a while and comes back on its hand is no switch
    a["points_2d"][m:] = np.nan
    a["points_2d"][m + 5 :] = true["right"]["points_2d"][m + 5 :]
    s = score_two_hands(c, {7: a, 9: b})
    assert s.switches == 4 and s.lost.tolist() == [0, 5]


def test_lost_while_visible_counts_the_frames_most_of_the_hand_is_seen(cases):
    """Without any track every frame in view is lost; those with at least 11 of the 21
    points visible are the ones counted as lost while visible (counted here from the
    truth's flags)."""
    c = cases["cross"]  # one hand mostly hidden behind the other for a while
    T = c.n_frames
    none = {0: {"points_2d": np.full((T, 21, 2), np.nan), "joints": None}}
    s = score_two_hands(c, none)
    assert s.lost.tolist() == c.in_view[0].sum(axis=1).tolist()
    seen = c.in_view[0] & (c.visible[0].sum(axis=2) >= 11)
    assert s.lost_visible.tolist() == seen.sum(axis=1).tolist()
    assert (s.lost_visible < s.lost).any()  # the hidden frames are in view, not visible
    assert score_two_hands(c, _true_tracks(c)).lost_visible.tolist() == [0, 0]


def test_a_hand_drawn_where_there_is_none_counts_as_drawn_off(cases):
    """A third track on the truth's frames shifted by 2 hand sizes is on no hand: each
    of its frames counts, as drawn away from both hands too; the true tracks count
    none."""
    c = cases["apart"]
    true = _true_tracks(c)
    s = score_two_hands(c, true)
    assert (s.drawn_off, s.drawn_away) == (0, 0)
    p = c.truth_2d[0, 0]
    size = np.linalg.norm(p[:, 9] - p[:, 0], axis=1)[:, None, None]
    ghost = p + 2.0 * size * np.array([0.0, 1.0])
    ghost[: c.n_frames // 2] = np.nan  # drawn on the second half only
    s = score_two_hands(c, {**true, "ghost": {"points_2d": ghost, "joints": None}})
    assert s.drawn_off == s.drawn_away == c.n_frames - c.n_frames // 2
    assert s.lost.tolist() == [0, 0]


def test_a_hand_drawn_off_its_hand_but_overlapping_it_is_not_drawn_away(cases):
    """The left hand's track shifted by 0.7 hand sizes is off its hand (unmatched:
    lost and drawn off on every frame in view) but still over it: not drawn away."""
    c = cases["apart"]
    true = _true_tracks(c)
    p = c.truth_2d[0, 0]
    size = hand_size_px(c.rig.cameras[0], c.joints[0])[:, None, None]
    left = c.sides[0]
    off = {**true[left], "points_2d": p + 0.7 * size * np.array([0.0, 1.0])}
    s = score_two_hands(c, {**true, left: off})
    assert s.lost[0] == c.in_view[0, 0].sum() > 0
    assert s.drawn_off == c.n_frames
    assert s.drawn_away == 0


def test_detections_as_tracks_take_the_label_as_identity(cases):
    c = cases["cross"]
    tracks = detections_as_tracks(c)
    assert set(tracks) == {"left", "right"}
    for t, found in enumerate(c.detections[0]):
        for side in ("left", "right"):
            mine = [d for d in found if d.side == side]
            got = tracks[side]["points_2d"][t]
            if not mine:
                assert np.isnan(got).all()
            else:
                best = max(mine, key=lambda d: d.score)
                np.testing.assert_array_equal(got, best.points[:, :2])
    s = score_two_hands(c, tracks)
    assert s.switches > 0  # the flipped labels
    assert np.all(s.pck < 1.0)


def test_render_view_labels_leave_the_image_and_mask_unchanged(cases):
    from handvar.evaluation.realistic import _HandScene
    from handvar.hand.anthropometry import HandShape

    c = cases["clap"]
    rig = realistic_rig(1)
    parts = []
    for k, side in enumerate(c.sides):
        scene = _HandScene(HandShape.from_size(float(c.hand_length[k]), side=side))
        x = c.poses[k, 45]
        v = scene.hand_vertices(x)
        parts += [(v, scene.triangles, (200, 150, 120), True),
                  (*scene.forearm(x, v, 450.0), (190, 140, 110), False)]  # fmt: skip
    bg = np.zeros((360, 640, 3), np.uint8)
    light = np.array([0.0, -0.6, -0.8])
    img, mask = _render_view(rig[0], parts, bg, light, 0.4, 0.6)
    img2, mask2, part, depth = _render_view(rig[0], parts, bg, light, 0.4, 0.6, labels=True)
    np.testing.assert_array_equal(img, img2)
    np.testing.assert_array_equal(mask, mask2)
    np.testing.assert_array_equal(mask, (part == 0) | (part == 2))
    assert set(np.unique(part)) <= {-1, 0, 1, 2, 3}
    assert np.all(np.isinf(depth[part < 0])) and np.all(depth[part >= 0] > 300.0)
