"""Two hands at once (`handvar.tracking.hands`): identities by tracking, against the truth.

The detections are the true 21 points of a left and a right hand (projected, with
noise), given in a random order each frame with labels that lie on a share of the
frames, as a detector's do; every assertion compares the tracks with those true points.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from handvar.evaluation.realistic import motion_poses, realistic_rig
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import HandModel
from handvar.tracking.hands import (
    BEHIND_CARRY,
    CONFIRM_FOUND,
    FOUND_SHARE,
    GONE_FRAMES,
    HIDDEN_FRAMES,
    MISSED_CARRY,
    MISSED_FRAMES,
    NEW_HAND,
    SIDE_FRAMES,
    SIDE_RUN,
    SIDE_SURE,
    HandsTracker,
    assign,
    least_cost_pairs,
)
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.vision.keypoints import Detection

SIDES = ("left", "right")
IMAGE = np.zeros((360, 640, 3), np.uint8)
SLIDE = np.array([3.0, 1.0])  # px a frame the sliding textures and points move (x, y)


def _truth(T: int, *, swap: bool = True, leave=None):
    """Per side the true points (T, 21, 2) of camera 0 (NaN where out of view): the
    counting motion, the hands 260 mm apart and (`swap`) crossing, the left one 80 mm
    behind the right."""
    rig = realistic_rig(1)
    cam = rig.cameras[0]
    poses, _ = motion_poses("counting", 0)
    out = {}
    for s, sign in (("left", -1.0), ("right", 1.0)):
        P = poses[:T].copy()
        path = np.cos(np.linspace(0, np.pi, T)) if swap else np.ones(T)
        P[:, 0] += sign * 130.0 * path
        P[:, 2] += 40.0 * -sign
        model = HandModel(HandShape.from_size(180.0 if s == "left" else 190.0, side=s))
        pts = np.stack([cam.project(keypoint_points(model, x, "pad")) for x in P])
        if leave is not None and s == leave[0]:
            pts[leave[1] : leave[2]] = np.nan
        out[s] = pts
    return rig, out


def _detections(truth, t, rng, wrong: float):
    found = []
    for s in SIDES:
        p = truth[s][t]
        if np.isnan(p).all():
            continue
        label = s if rng.random() >= wrong else SIDES[1 - SIDES.index(s)]
        found.append(Detection(np.c_[p + rng.normal(0, 2.0, p.shape), np.ones(21)],
                               side=label, score=0.9))  # fmt: skip
    rng.shuffle(found)
    return found


def _run(rig, truth, T, wrong=0.2, seed=0, **kw):
    rng = np.random.default_rng(seed)
    tracker = HandsTracker(rig, detector=None, **kw)
    return [tracker.process(IMAGE, detections=[_detections(truth, t, rng, wrong)])
            for t in range(T)]  # fmt: skip


def _matched(results, truth):
    """Per hand id, per frame, the side whose true points its fit is nearest (None
    without a fit, or with none within 30 pixels) and the distance in pixels."""
    out = {}
    for k in (0, 1):
        rows = []
        for r in results:
            h = r.hands[k]
            if h.no_hand:
                rows.append((None, np.nan))
                continue
            d = {s: np.linalg.norm(h.projected[0] - truth[s][r.index], axis=1).mean()
                 for s in SIDES if np.isfinite(truth[s][r.index]).all()}  # fmt: skip
            s = min(d, key=d.get) if d else None
            if s is not None and d[s] > 30.0:  # pixels: on neither hand
                s = None
            rows.append((s, d[s] if s is not None else np.nan))
        out[k] = rows
    return out


def _texture(rng) -> np.ndarray:
    """A 360 × 640 grey frame of blurred noise, which the optical flow can follow."""
    import cv2

    noise = cv2.GaussianBlur(rng.integers(0, 256, (360, 640), dtype=np.uint8), (0, 0), 2.0)
    return cv2.normalize(noise, None, 0, 255, cv2.NORM_MINMAX)


def _sliding(T: int):
    """The rig and per side the true points of `_truth`'s first frame sliding 3 px right
    and 1 down a frame over `T` frames, as `_slid` slides a texture."""
    rig, first = _truth(1, swap=False)
    truth = {s: np.stack([first[s][0] + t * SLIDE for t in range(T)]) for s in SIDES}
    return rig, truth


def _slid(texture: np.ndarray, t: int) -> np.ndarray:
    """`texture` slid as `_sliding`'s points are at frame `t`, as a BGR frame."""
    import cv2

    return cv2.cvtColor(np.roll(texture, (t, 3 * t), axis=(0, 1)), cv2.COLOR_GRAY2BGR)


def _track_sliding(T: int, found, **options):
    """Track `_sliding(T)`'s hands over a texture slid with them, the detector given each
    hand's true points (2 px noise, its true side) on the frames ``found(t, side)``
    says, and only on every ``options["keypoint_every"]``-th frame; returns the truth,
    the tracker and its results."""
    rig, truth = _sliding(T)
    rng = np.random.default_rng(0)
    texture = _texture(rng)
    tracker = HandsTracker(rig, detector=None, **options)
    every = options.get("keypoint_every", 1)
    results = []
    for t in range(T):
        given = [d for d in _detections(truth, t, rng, 0.0) if found(t, d.side)]
        results.append(
            tracker.process(_slid(texture, t), detections=[given] if t % every == 0 else None)
        )
    return truth, tracker, results


def _apart() -> dict:
    """Per side the 21 points (mm) of a 185 mm hand at the counting motion's first pose,
    the left one 130 mm to the left and the right one 130 mm to the right of it."""
    x = motion_poses("counting", 0)[0][0]
    joints = {}
    for s, sign in (("left", -1.0), ("right", 1.0)):
        y = x.copy()
        y[0] += sign * 130.0
        joints[s] = keypoint_points(HandModel(HandShape.from_size(185.0, side=s)), y, "pad")
    return joints


def test_crossing_hands_keep_their_identity_when_the_labels_lie():
    T = 40
    rig, truth = _truth(T)
    results = _run(rig, truth, T, wrong=0.25)
    matched = _matched(results, truth)
    for k in (0, 1):
        sides = {s for s, _ in matched[k]}
        assert len(sides) == 1, f"hand {k} switched between {sides}"
        (s,) = sides
        assert {r.hands[k].side for r in results} == {s}  # its side is the true one's
        assert np.nanmax([d for _, d in matched[k]]) < 20.0  # pixels, on 40-pixel hands


def test_a_hand_that_leaves_comes_back_with_its_side_and_nothing_is_drawn_meanwhile():
    T = 45
    rig, truth = _truth(T, swap=False, leave=("left", 12, 30))
    results = _run(rig, truth, T, wrong=0.2)
    matched = _matched(results, truth)
    left = next(k for k in (0, 1) if {s for s, _ in matched[k]} - {None} == {"left"})
    gone = [results[t].hands[left].no_hand for t in range(12, 30)]
    assert sum(gone) >= 18 - MISSED_FRAMES  # carried through a miss at most, then no hand
    back = [results[t].hands[left] for t in range(32, T)]
    assert all(not h.no_hand and h.side == "left" for h in back)


def test_one_hand_leaves_the_other_hand_without_a_hand():
    T = 12
    rig, truth = _truth(T, swap=False, leave=("left", 0, T))
    results = _run(rig, truth, T, wrong=0.0)
    assert all(r.hands[1].no_hand for r in results)
    assert not any(r.hands[0].no_hand for r in results)
    assert {r.hands[0].side for r in results} == {"right"}


def test_a_hand_found_twice_is_one_hand():
    T = 10
    rig, truth = _truth(T, swap=False, leave=("left", 0, T))
    rng = np.random.default_rng(1)
    tracker = HandsTracker(rig, detector=None)
    for t in range(T):
        found = _detections(truth, t, rng, 0.0)
        twin = Detection(found[0].points + np.r_[3.0, -2.0, 0.0], side="left", score=0.6)
        r = tracker.process(IMAGE, detections=[[*found, twin]])
        assert r.hands[1].no_hand


def test_a_hand_found_twice_is_not_given_to_the_other_hand_near_it():
    """MediaPipe finds the right hand twice and misses the left one, expected within
    its gate of both: the left hand gets neither (fitted to one in one camera, it would
    be drawn there at a depth no other camera checks); the right hand keeps the one
    nearer where it is expected, in each camera."""
    rig, joints, tracker = _two_cameras()
    left, right = tracker.hands
    left.side, right.side = "left", "right"
    right.last = right.before = _placed(rig, joints)
    left.last = left.before = _placed(rig, joints + np.array([60.0, 0.0, 0.0]))  # mm
    views = [cam.project(joints) for cam in rig.cameras]
    size = np.linalg.norm(views[0][9] - views[0][0])
    twice = [[Detection(np.c_[v + np.r_[0.02 * size, 0.0], np.ones(21)], side="right", score=0.9),
              Detection(np.c_[v + np.r_[0.25 * size, 0.0], np.ones(21)], side="right", score=0.6)]
             for v in views]  # fmt: skip
    given = tracker._given(twice)
    for j in range(len(rig)):
        assert given[left.id][0][j] is None
        np.testing.assert_allclose(given[right.id][0][j][:, :2], twice[j][0].points[:, :2])


def test_a_hand_found_twice_with_its_label_is_one_hand_and_a_far_one_is_new():
    """A second detection labelled the tracked hand's side (MediaPipe's duplicate while
    hands touch) starts no hand within `NEW_HAND` hand sizes of that hand's detection,
    and does beyond it (a new hand whose first label lies)."""
    T = 6
    rig, truth = _truth(T, swap=False, leave=("left", 0, T))
    p = truth["right"]
    size = np.linalg.norm(p[0, 9] - p[0, 0])
    for shift, born in ((1.0, False), (NEW_HAND + 0.5, True)):
        tracker = HandsTracker(rig, detector=None)
        for t in range(T):
            hand = Detection(np.c_[p[t], np.ones(21)], side="right", score=0.9)
            twin = Detection(np.c_[p[t] + (shift * size, 0.0), np.ones(21)], side="right",
                             score=0.8)  # fmt: skip
            r = tracker.process(IMAGE, detections=[[hand, twin] if t else [hand]])
        assert r.hands[1].no_hand is not born
        assert r.hands[0].side == "right"


@pytest.mark.parametrize("score", [0.97, 0.6])
def test_a_hand_coming_back_sure_of_its_side_beside_the_other_is_taken_by_its_track(score):
    """The left hand leaves for longer than `GONE_FRAMES` and comes back 130 mm beside
    the right one on a frame the detector misses the right hand: its detection lies
    within `NEW_HAND` of the right hand's place. Labelled left with a score of
    `SIDE_SURE` or more it is the free left hand's; less sure, the right hand's off by
    a gross error, given to no hand (the clap of the two-hand benchmark, seed 1)."""
    rig = realistic_rig(1)
    joints = _apart()
    joints["left"] = joints["left"] + np.array([130.0, 0.0, 0.0])  # mm: 130 apart
    views = {s: rig.cameras[0].project(j) for s, j in joints.items()}
    hand = {s: Detection(np.c_[views[s], np.ones(21)], side=s, score=0.95) for s in SIDES}
    tracker = HandsTracker(rig, detector=None)
    frames = [[hand["left"], hand["right"]]] * 3 + [[hand["right"]]] * (GONE_FRAMES + 2)
    back = Detection(hand["left"].points, side="left", score=score)
    for found in [*frames, [back]]:
        r = tracker.process(IMAGE, detections=[found])
    size = np.linalg.norm(views["left"][9] - views["left"][0])  # pixels

    def off(h, s):  # mean distance of a hand's fit from side s's true points, hand sizes
        return np.linalg.norm(h.projected[0] - views[s], axis=1).mean() / size

    left, right = (next(h for h in r.hands if h.side == s) for s in SIDES)
    assert (score >= SIDE_SURE) is not left.no_hand
    assert left.no_hand or off(left, "left") < 0.1
    assert right.no_hand or off(right, "right") < 0.1


def _labelled(truth, t, labels):
    """Both hands' true points, left first, labelled `labels` (left's, right's)."""
    return [Detection(np.c_[truth[s][t], np.ones(21)], side=label, score=0.9)
            for s, label in zip(SIDES, labels, strict=True)]  # fmt: skip


def _sides(results, truth):
    """Per frame, the side each true hand (left, right) is tracked as."""
    out = []
    for r in results:
        by_hand = {}
        for h in r.hands:
            if not h.no_hand:
                d = [
                    np.linalg.norm(h.projected[0] - truth[s][r.index], axis=1).mean() for s in SIDES
                ]
                by_hand[SIDES[int(np.argmin(d))]] = h.side
        out.append((by_hand.get("left"), by_hand.get("right")))
    return out


def test_two_hands_found_on_one_frame_with_one_label_get_opposite_sides_then_the_true_ones():
    """Both hands labelled left on the first frame: one of them is made a right hand
    there (two hands of one person), and the labels of the frames after (true, each
    ≥ `SIDE_SURE`) turn a wrong pair within `SIDE_RUN` frames, long before a new hand's
    `SIDE_FRAMES` vote."""
    T = SIDE_RUN + 4
    assert T < SIDE_FRAMES
    rig, truth = _truth(T, swap=False)
    for first in (("left", "left"), ("right", "right")):
        tracker = HandsTracker(rig, detector=None)
        results = [tracker.process(IMAGE, detections=[_labelled(truth, t, first if t == 0
                                                                 else SIDES)])
                   for t in range(T)]  # fmt: skip
        sides = _sides(results, truth)
        assert all(set(s) == {"left", "right"} for s in sides), sides  # always opposite
        assert sides[-1] == SIDES


def test_with_a_detector_on_every_kth_frame_a_new_hands_side_is_voted_over_side_frames():
    """The detector on every 5th frame, both hands labelled the wrong sides on the
    first, then their own, never `SIDE_SURE` sure (no run turns them): the new hands'
    vote takes the labels of `SIDE_FRAMES` frames, not `SIDE_FRAMES` labels (which
    would need 5 × as many frames), and turns both sides by then."""
    every = 5
    T = SIDE_FRAMES + 1
    rig, truth = _truth(T, swap=False)
    tracker = HandsTracker(rig, detector=None, keypoint_every=every)
    results = []
    for t in range(T):
        found = None
        if t % every == 0:
            labels = SIDES[::-1] if t == 0 else SIDES
            found = [[Detection(np.c_[truth[s][t], np.ones(21)], side=label, score=0.7)
                      for s, label in zip(SIDES, labels, strict=True)]]  # fmt: skip
        results.append(tracker.process(IMAGE, detections=found))
    sides = [s for s in _sides(results, truth) if None not in s]
    assert sides[0] == SIDES[::-1]  # as labelled on the first frame
    assert sides[-1] == SIDES


def test_a_side_turns_on_a_run_of_sure_labels_against_it_and_not_on_a_shorter_one():
    """Sides decided by true labels; then both hands labelled the other side for a run
    of frames: a run shorter than `SIDE_RUN` (as a detector's label flips are) leaves
    the sides, a run of `SIDE_RUN` turns both, the two staying opposite."""
    settle = 5
    for run, turned in ((SIDE_RUN - 1, False), (SIDE_RUN, True)):
        T = settle + run + 3
        rig, truth = _truth(T, swap=False)
        tracker = HandsTracker(rig, detector=None)
        results = []
        for t in range(T):
            lying = settle <= t < settle + run
            labels = SIDES[::-1] if lying else SIDES
            results.append(tracker.process(IMAGE, detections=[_labelled(truth, t, labels)]))
        sides = [s for s in _sides(results, truth) if None not in s]
        assert sides[0] == SIDES
        assert all(set(s) == {"left", "right"} for s in sides)
        assert (sides[-1] == SIDES[::-1]) is turned


def test_a_label_sure_of_a_free_hands_side_counts_twice_against_the_other_hand():
    """A detection 0.75 hand sizes from where the right hand is expected, labelled left
    with a score of 0.92: its cost for the right hand is 0.75 + 0.25 · 0.84 = 0.96,
    under the gate of 1; while the left hand is free (expected nowhere) the label
    counts twice, 1.17, and it is not given (the left hand's coming back)."""
    a = np.zeros((21, 2))
    a[9] = (0.0, 40.0)  # a hand 40 pixels long
    d = Detection(np.c_[a + np.array([30.0, 0.0]), np.ones(21)], side="left", score=0.92)
    assert assign([a, a + 400.0], ["right", "left"], [d], [1.0, 1.0]) == {0: 0}
    assert assign([a, None], ["right", "left"], [d], [1.0, 1.0]) == {}
    unsure = Detection(d.points, side="left", score=SIDE_SURE - 0.05)
    assert assign([a, None], ["right", "left"], [unsure], [1.0, 1.0]) == {0: 0}


def test_a_hand_carried_off_takes_its_own_sure_detection_not_the_free_hands():
    """The left hand has left for longer than `GONE_FRAMES`; the right hand's last
    detections lie 1.4 of its sizes towards where the left one comes back (as the
    optical flow carried a hand off between a slower detector's frames: the two-hand
    benchmark's occlusion, seed 1, MediaPipe on every 5th frame).  Then both are found,
    each labelled sure of its side, the left one 0.7 sizes from the right track: the
    right track takes its own detection (beyond its gate, within `NEW_HAND`) and the
    left hand comes back on the other; the right track took the left one's before."""
    rig = realistic_rig(1)
    right = rig.cameras[0].project(_apart()["right"])
    size = np.linalg.norm(right[9] - right[0])  # pixels
    off = right - (1.4 * size, 0.0)  # where the flow carried the right hand
    left = right - (2.1 * size, 0.0)  # the left hand back beside it

    def found(p, side):
        return Detection(np.c_[p, np.ones(21)], side=side, score=0.92)

    tracker = HandsTracker(rig, detector=None)
    far_left = right - (6.0 * size, 0.0)
    frames = [[found(far_left, "left"), found(right, "right")]] * 3
    frames += [[found(off, "right")]] * (GONE_FRAMES + 3)
    for f in [*frames, [found(left, "left"), found(right, "right")]]:
        r = tracker.process(IMAGE, detections=[f])
    hands = {h.side: h for h in r.hands if not h.no_hand}
    assert set(hands) == {"left", "right"}
    for side, p in (("left", left), ("right", right)):
        assert np.linalg.norm(hands[side].projected[0] - p, axis=1).mean() < 0.3 * size


def test_a_hand_found_twice_is_not_taken_back_by_the_other_hand_for_its_label():
    """The left hand, 1.5 hand sizes beside the right one, is missed; the right one is
    found twice, the second detection labelled left and sure: within `NEW_HAND` of the
    left hand, but the right hand found again (within `DUPLICATE` of its detection),
    so the left track is not drawn on it."""
    rig = realistic_rig(1)
    right = rig.cameras[0].project(_apart()["right"])
    size = np.linalg.norm(right[9] - right[0])  # pixels
    left = right - (1.5 * size, 0.0)

    def found(p, side):
        return Detection(np.c_[p, np.ones(21)], side=side, score=0.95)

    tracker = HandsTracker(rig, detector=None)
    for _ in range(3):
        tracker.process(IMAGE, detections=[[found(left, "left"), found(right, "right")]])
    twice = [found(right, "right"), found(right + np.array([0.1 * size, 0.0]), "left")]
    r = tracker.process(IMAGE, detections=[twice])
    for h in r.hands:
        on_right = bool(np.linalg.norm(h.projected[0] - right, axis=1).mean() < 0.5 * size)
        assert h.no_hand or on_right is (h.side == "right"), h.side


def test_assign_keeps_identities_by_place_and_leaves_far_detections_out():
    a = np.zeros((21, 2))
    a[9] = (0.0, 40.0)
    far = Detection(np.c_[a + 500.0, np.ones(21)], side="right")
    near = Detection(np.c_[a + 2.0, np.ones(21)], side="left", score=0.99)
    assert assign([a], ["right"], [far, near], [1.0]) == {0: 1}
    assert assign([a], ["right"], [far], [1.0]) == {}


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 2), st.integers(1, 5), st.integers(0, 2**32 - 1))
def test_least_cost_pairs_is_scipys_linear_sum_assignment(n, m, seed):
    from scipy.optimize import linear_sum_assignment

    rng = np.random.default_rng(seed)
    cost = rng.exponential(1.0, (n, m))
    cost[rng.random((n, m)) < 0.2] = 1e6  # out of reach, as `assign` gives them
    for c in (cost, cost.T):
        rows, columns = linear_sum_assignment(c)
        pairs = least_cost_pairs(c)
        assert len(pairs) == min(c.shape)  # one to one, the smaller side all paired
        assert len({r for r, _ in pairs}) == len({k for _, k in pairs}) == len(pairs)
        assert sum(c[r, k] for r, k in pairs) == pytest.approx(c[rows, columns].sum())


def test_wrong_input_names_the_argument():
    with pytest.raises(ValueError, match="hands"):
        HandsTracker(hands=3, detector=None)
    tracker = HandsTracker(detector=None)
    with pytest.raises(ValueError, match="detections"):
        tracker.process(IMAGE)
    with pytest.raises(ValueError, match=r"look: expected auto, mediapipe, None, .*got 'crops'"):
        HandsTracker(detector=None, look="crops")
    with pytest.raises(ValueError, match=r"one per camera \(2\)"):
        HandsTracker(realistic_rig(2), detector=None, look=[lambda image, box: []])


def test_track_hands_keeps_each_true_hand_under_one_id_through_a_crossing(tmp_path):
    """The whole loop (`handvar.track(..., hands=2)`) on a rendered crossing, its
    detector the benchmark's (labels that flip, hands in random order), scored against
    the truth: no identity switch, each hand at or above the labels' PCK."""
    import handvar
    from handvar.evaluation.two_hands import (
        detections_as_tracks,
        score_two_hands,
        two_hand_case,
    )

    case = two_hand_case("cross", seed=0, frames=(20, 70), size=(320, 180))
    case.write(tmp_path / "case")
    frames = iter(case.detections[0])
    result = handvar.track(str(tmp_path / "case" / "cam0"), calib=tmp_path / "case" / "calib.yml",
                           hands=2, detector=lambda image: next(frames))  # fmt: skip
    assert sorted(t.shape.side for t in result.tracks.values()) == ["left", "right"]
    tracks = {k: {"points_2d": t.projected[0], "joints": None} for k, t in result.tracks.items()}
    fit, raw = score_two_hands(case, tracks), score_two_hands(case, detections_as_tracks(case))
    assert raw.switches > 0 and fit.switches == 0
    assert np.all(fit.pck >= raw.pck - 0.02)
    written = result.save(tmp_path / "out", video=False)
    assert {"left", "right", "hands"} <= set(written)
    back = handvar.HandsTrack.load(tmp_path / "out")
    assert {k: t.shape.side for k, t in back.tracks.items()} == {
        k: t.shape.side for k, t in result.tracks.items()
    }
    for k, t in back.tracks.items():
        np.testing.assert_array_equal(t.poses, result.tracks[k].poses)
        # the hand it loads reports the track's points (the detector's; the exports' too)
        posed = np.flatnonzero(np.isfinite(t.poses).all(axis=1))[-1]
        assert t.hand.tips == "pad"
        np.testing.assert_allclose(t.hand.landmarks(t.poses[posed]), t.joints[posed], atol=1e-9)


def test_track_hands_in_real_time_drops_frames_and_keeps_identities(tmp_path):
    """A recording played at its own rate (``realtime=True``) with a detector slower
    than its frames: frames are dropped, each hand's track holds every frame of the
    recording (its last pose on a dropped one) with the latency of the others, and the
    identities hold against the truth, though the detector's labels lie on some frames.
    (Two hands apart: how many frames are dropped depends on the machine's load, and a
    crossing seen on a few frames only is the offline tests' business.)"""
    import time

    import cv2

    import handvar
    from handvar.evaluation.two_hands import score_two_hands, two_hand_case

    case = two_hand_case("apart", seed=0, frames=(20, 60), size=(320, 180))
    assert case.wrong_label.any()
    written = case.write(tmp_path / "case")
    images = [cv2.imread(str(p)).astype(np.int16) for p in sorted(written["frames"][0].iterdir())]

    def detector(image):  # the benchmark's detections of the frame shown, 2 frame times late
        time.sleep(2.0 / case.fps)
        t = int(np.argmin([np.abs(image - i).mean() for i in images]))
        return case.detections[0][t]

    result = handvar.track(str(written["frames"][0]), calib=written["calib"], hands=2,
                           realtime=True, detector=detector)  # fmt: skip
    T = case.n_frames
    assert result.n_frames == T and len(result.tracks) == 2
    for track in result.tracks.values():
        dropped = track.dropped
        assert dropped.shape == (T,) and 0 < dropped.sum() < T
        assert np.all(np.isnan(track.latency[dropped]))
        assert np.all(track.latency[~dropped] > 0)
        first = np.flatnonzero(~dropped)[0]
        for t in np.flatnonzero(dropped[first:]) + first:  # the last pose held
            np.testing.assert_array_equal(track.poses[t], track.poses[t - 1])
    tracks = {k: {"points_2d": t.projected[0], "joints": None} for k, t in result.tracks.items()}
    assert score_two_hands(case, tracks).switches == 0
    back = handvar.HandsTrack.load(result.save(tmp_path / "out", video=False)["hands"].parent)
    for k, t in back.tracks.items():
        np.testing.assert_array_equal(t.dropped, result.tracks[k].dropped)


def test_track_hands_from_a_detections_file_as_with_the_detector_inside(tmp_path):
    """The benchmark's detections written to a .json detections file and given as
    ``keypoints`` give the same tracks as the same detections from a detector; by the
    command, a file of the wrong length or one hand's keypoints are refused."""
    from click.testing import CliRunner

    import handvar
    from handvar.cli import main
    from handvar.evaluation.two_hands import two_hand_case
    from handvar.vision.keypoints import write_detections

    case = two_hand_case("clap", seed=1, frames=(30, 50), size=(320, 180))
    written = case.write(tmp_path / "case")
    frames, calib, found = written["frames"][0], written["calib"], written["detections"][0]
    given = iter(case.detections[0])
    inside = handvar.track(str(frames), calib=calib, hands=2, detector=lambda image: next(given))
    from_file = handvar.track(str(frames), calib=calib, hands=2, keypoints=found)
    assert sorted(from_file.tracks) == sorted(inside.tracks) and len(inside.tracks) == 2
    for k, t in from_file.tracks.items():
        np.testing.assert_array_equal(t.poses, inside.tracks[k].poses)
        assert t.options["detector"] == "none"  # none ran

    def run(*extra):
        return CliRunner().invoke(main, ["track", str(frames), "--calib", str(calib), "--hands",
                                         "2", "--no-video", *extra])  # fmt: skip

    res = run("--keypoints", str(found), "--out", str(tmp_path / "o"))
    assert res.exit_code == 0, res.output
    assert (tmp_path / "o" / "hands.json").is_file()
    res = run("--keypoints", str(found), "--realtime", "--out", str(tmp_path / "rt"))
    assert res.exit_code == 0 and "realtime: 20 frames" in res.output, res.output
    # the silhouette as a cue of each hand's fit, the skin shared between them (rule 5)
    res = run("--keypoints", str(found), "--silhouette-term", "0.05", "--out", str(tmp_path / "s"))
    assert res.exit_code == 0, res.output
    back, without = handvar.HandsTrack.load(tmp_path / "s"), handvar.HandsTrack.load(tmp_path / "o")
    assert sorted(t.shape.side for t in back.tracks.values()) == ["left", "right"]
    assert any(not np.allclose(t.poses, without.tracks[k].poses, equal_nan=True)
               for k, t in back.tracks.items())  # fmt: skip
    short = tmp_path / "short.json"
    write_detections(short, case.detections[0][:-1])
    for bad, says in (
        (short, "expected the hands found in each of the recording's 20 frames"),
        (tmp_path / "case" / "truth.npz", "expected a .json detections file"),
    ):
        res = run("--keypoints", str(bad), "--out", str(tmp_path / "bad"))
        assert res.exit_code == 2 and says in res.output, res.output
        assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize(
    ("extra", "named"),
    [(["--carry", "forward"], "--carry"), (["--hand", "left"], "--hand"),
     (["--detector", "none"], "--detector")],
)  # fmt: skip
def test_the_command_refuses_one_hands_options_with_two_hands(tmp_path, extra, named):
    from click.testing import CliRunner

    from handvar.cli import main
    from handvar.data import example_path

    video = str(example_path("video"))
    res = CliRunner().invoke(main, ["track", video, "--hands", "2", "--out",
                                    str(tmp_path / "o"), *extra])  # fmt: skip
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and named in lines[0] and "--hands 2" in lines[0]
    assert not (tmp_path / "o").exists()


def test_both_hands_from_a_live_camera():
    """A video read as a camera (the same VideoCapture calls), MediaPipe inside: the one
    right hand of the example video is tracked, no second hand is drawn."""
    import cv2

    import handvar
    from handvar.data import example_path
    from handvar.vision.detector import mediapipe_available
    from handvar.vision.sources import open_camera

    if not mediapipe_available():
        pytest.skip("MediaPipe (the optional extra) is not installed")
    camera = open_camera(0, capture=cv2.VideoCapture(str(example_path("video"))), scale=0.5)
    try:
        result = handvar.track(camera, hands=2, frames=12)
    finally:
        camera.close()
    assert 1 <= result.n_frames <= 12 and result.source is None
    assert [t.shape.side for t in result.tracks.values()] == ["right"]
    with pytest.raises(ValueError, match="calib, fov, scale"):
        handvar.track(camera, hands=2, scale=0.5)


def test_a_slower_detector_carries_each_hand_to_the_frames_it_skips():
    T, every = 24, 3
    rig, truth = _truth(T, swap=False)  # blank frames: the points are held, not followed
    rng = np.random.default_rng(0)
    tracker = HandsTracker(rig, detector=None, keypoint_every=every)
    results = []
    for t in range(T):
        found = [_detections(truth, t, rng, 0.2)] if t % every == 0 else None
        results.append(tracker.process(IMAGE, detections=found))
    assert not any(h.no_hand for r in results for h in r.hands)  # carried between
    matched = _matched(results, truth)
    assert {tuple({s for s, _ in matched[k]}) for k in (0, 1)} == {("left",), ("right",)}


@pytest.mark.parametrize(
    ("T", "missed", "every"),
    [(20, range(8, 14), 1), (48, range(20, 45), 1), (48, range(20, 45), 3)],
)
def test_a_hand_the_detector_misses_is_followed_by_optical_flow(T, missed, every):
    """Textured frames sliding 3 px right and 1 down a frame, the hands' true points with
    them; the detector misses the left hand on 6 frames, or on 25 (more than
    `BEHIND_CARRY`, the hands apart: in the open), fewer than `MISSED_CARRY`, after
    finding it on 20 (so on `FOUND_SHARE` of its frames or more throughout).  There it
    is fitted to its last detection followed by the flow, within 0.15 hand sizes of its
    true points, where its prediction alone was carried only `MISSED_FRAMES` frames
    (and, before a hand in the open was followed longer, the flow only 10).  With the
    detector on every 3rd frame the same holds beyond its next frame (before, the flow
    carried a detection only up to it)."""
    assert len(missed) < MISSED_CARRY and (len(missed) < 10 or len(missed) > BEHIND_CARRY)
    assert missed[0] >= FOUND_SHARE * (missed[-1] + 1)  # found often enough to be followed
    truth, _, results = _track_sliding(
        T, lambda t, side: side == "right" or t not in missed, keypoint_every=every
    )
    matched = _matched(results, truth)
    left = next(k for k in (0, 1) if {s for s, _ in matched[k]} - {None} == {"left"})
    size = np.linalg.norm(truth["left"][0, 9] - truth["left"][0, 0])
    for t in missed:
        h = results[t].hands[left]
        assert not h.no_hand and not h.hidden, t
        error = np.linalg.norm(h.projected[0] - truth["left"][t], axis=1).mean()
        assert error < 0.15 * size, (t, error / size)


def test_a_hand_hidden_against_the_other_is_held_where_it_was_last_fitted():
    """Two cameras; the left hand slides 8 mm a frame towards the right one for 25
    frames and stops against it (43 % of its points within the right hand's outline in
    camera 0); from there the detector finds only the right hand (blank frames: no flow
    to follow).  The left hand is carried hidden for `HIDDEN_FRAMES`, held where it was
    last fitted: within 0.1 hand sizes of its true points on every one, where its motion
    prediction carried it on towards the right hand, up to 0.26 hand sizes off.  The
    right hand is drawn on every frame."""
    T, stop = 40, 25
    rig = realistic_rig(2)
    joints = _apart()
    slid = [min(t, stop) * np.array([8.0, 0.0, 0.0]) for t in range(T)]
    truths = [{"left": np.stack([camera.project(joints["left"] + d) for d in slid]),
               "right": np.stack([camera.project(joints["right"])] * T)}
              for camera in rig.cameras]  # fmt: skip
    rng = np.random.default_rng(0)
    tracker = HandsTracker(rig, detector=None)
    results = []
    for t in range(T):
        given = [[d for d in _detections(truth, t, rng, 0.0) if d.side == "right" or t <= stop]
                 for truth in truths]  # fmt: skip
        results.append(tracker.process([IMAGE, IMAGE], detections=given))
    left = next(h.id for h in results[0].hands if h.side == "left")
    carried = [t for t in range(stop + 1, T) if results[t].hands[left].hidden]
    assert carried == list(range(stop + 1, stop + 1 + HIDDEN_FRAMES))  # then no hand
    truth = truths[0]["left"]
    size = np.linalg.norm(truth[0, 9] - truth[0, 0])
    for t in carried:
        error = np.linalg.norm(results[t].hands[left].projected[0] - truth[t], axis=1)
        assert error.mean() < 0.1 * size, (t, error.mean() / size)
    assert not any(r.hands[1 - left].no_hand for r in results)


def test_a_hand_the_detector_finds_now_and_then_is_neither_followed_nor_carried_back(
    monkeypatch,
):
    """Textured frames sliding as above, which the optical flow follows anywhere; the
    right hand found on every frame, a left hand only on frames 6 and 26 (a detector's
    false hand, found now and then).  Followed through its misses and
    carried back from its finds (as a hand found on a third of the frames or more is),
    it would be drawn on nearly every frame; it is drawn only on the frames it is found
    and the few after (`FOUND_SHARE`, then `MISSED_FRAMES` by its prediction), and a
    recording's back-fill carries none back (`BACK_SHARE`; with `CONFIRM_FOUND` at 1,
    which would take each of its two tracks off).  The right hand is drawn on every
    frame."""
    monkeypatch.setattr("handvar.tracking.hands.CONFIRM_FOUND", 1)
    T, finds = 46, (6, 26)
    _, tracker, results = _track_sliding(
        T, lambda t, side: side == "right" or t in finds, back=True
    )
    left = next(h.id for h in results[finds[0]].hands if h.side == "left")
    drawn = [t for t, r in enumerate(results) if not r.hands[left].no_hand]
    followed = int(1 / FOUND_SHARE)  # frames since a find it is still followed
    assert set(drawn) <= {t + k for t in finds for k in range(followed + MISSED_FRAMES)}, drawn
    assert left not in {i for poses in tracker.back_fill().values() for i in poses}
    assert not any(r.hands[1 - left].no_hand for r in results)


def test_a_hand_followed_by_a_few_points_in_one_camera_of_two_is_not_fitted_to_them():
    """Two cameras, textured frames sliding as above; from frame 6 the detector misses
    the left hand in both, camera 0 goes blank (the flow follows none of its points) and
    camera 1 keeps texture only around 2 of them.  Fitted to those, the hand would lie
    anywhere along camera 1's rays; it is carried by its prediction for
    `MISSED_FRAMES` frames and then drawn nowhere, while the right hand stays on its
    true points in both cameras."""
    import cv2

    from handvar.tracking.hands import ONE_VIEW_POINTS

    assert ONE_VIEW_POINTS > 2
    rig = realistic_rig(2)
    T = 14
    truth = [
        {s: np.stack([cam.project(j) + t * SLIDE for t in range(T)]) for s, j in _apart().items()}
        for cam in rig.cameras
    ]  # per camera, per side
    texture = _texture(np.random.default_rng(0))
    tracker = HandsTracker(rig, detector=None)
    for t in range(T):
        image = np.roll(texture, (t, 3 * t), axis=(0, 1))
        images = [image.copy(), image.copy()]
        if t >= 6:
            images[0][:] = 128
            patch = np.zeros_like(image)
            for q in truth[1]["left"][t, :2]:
                cv2.circle(patch, tuple(int(v) for v in q), 10, 1, -1)
            images[1] = np.where(patch > 0, image, 128).astype(np.uint8)
        found = [[Detection(np.c_[truth[j][s][t], np.ones(21)], side=s, score=0.9)
                  for s in SIDES if t < 6 or s == "right"] for j in range(2)]  # fmt: skip
        r = tracker.process([cv2.cvtColor(i, cv2.COLOR_GRAY2BGR) for i in images],
                            detections=found)  # fmt: skip
    left = next(h for h in r.hands if h.side == "left")
    right = next(h for h in r.hands if h.side == "right")
    assert left.no_hand
    for j in range(2):
        assert np.linalg.norm(right.projected[j] - truth[j]["right"][T - 1], axis=1).mean() < 5.0


def test_a_hand_followed_in_one_camera_of_two_is_held_in_the_other():
    """Two cameras, still hands on a still texture; from frame 6 the detector misses
    the left hand in both, camera 0 goes blank (the flow follows none of its points)
    and camera 1's texture shrinks 3 % a frame about the left hand, so the flow there
    draws its points together.  Fitted to camera 1 alone, the hand moved away along
    that camera's rays (174 mm farther and 0.71 hand sizes off in camera 0 after 10
    frames); held in camera 0 at its last fit's points (`HELD_VIEW`), it stays within
    20 mm of its true depth and 0.15 hand sizes of its points there."""
    import cv2

    from handvar.tracking.hands import HELD_VIEW

    assert 0 < HELD_VIEW <= 1
    rig = realistic_rig(2)
    joints = _apart()
    truth = [{s: cam.project(j) for s, j in joints.items()} for cam in rig.cameras]
    texture = _texture(np.random.default_rng(0))
    centre = truth[1]["left"].mean(axis=0)
    tracker = HandsTracker(rig, detector=None)
    for t in range(16):
        images = [texture.copy(), texture.copy()]
        if t >= 6:
            images[0][:] = 128
            shrink = cv2.getRotationMatrix2D(tuple(map(float, centre)), 0.0, 0.97 ** (t - 5))
            images[1] = cv2.warpAffine(texture, shrink, texture.shape[::-1],
                                       borderMode=cv2.BORDER_REFLECT)  # fmt: skip
        found = [[Detection(np.c_[truth[j][s], np.ones(21)], side=s, score=0.9)
                  for s in SIDES if t < 6 or s == "right"] for j in range(2)]  # fmt: skip
        r = tracker.process([cv2.cvtColor(i, cv2.COLOR_GRAY2BGR) for i in images],
                            detections=found)  # fmt: skip
    left = next(h for h in r.hands if h.side == "left")
    assert not left.no_hand and not left.hidden
    camera = rig.cameras[0]
    depth = camera.camera_from_world(left.joints)[:, 2].mean()
    assert abs(depth - camera.camera_from_world(joints["left"])[:, 2].mean()) < 20.0
    size = np.linalg.norm(truth[0]["left"][9] - truth[0]["left"][0])
    assert np.linalg.norm(left.projected[0] - truth[0]["left"], axis=1).mean() < 0.15 * size


def _box_sees(points_of, boxes):
    """A second look (`HandsTracker`'s ``look``) that finds the hands whose true points
    (``points_of(box)``: per side, (21, 2) or NaN) lie wholly in the box, as a detector
    would on that part of the frame; the boxes asked are noted in `boxes`."""

    def look(image, box):
        x0, y0, x1, y1 = box
        boxes.append(box)
        found = []
        for s, p in points_of(box).items():
            if np.isfinite(p).all() and (p >= (x0, y0)).all() and (p <= (x1, y1)).all():
                found.append(Detection(np.c_[p, np.ones(21)], side=s, score=0.9))
        return found

    return look


def test_a_hand_the_detector_misses_is_found_in_a_box_around_where_it_is_expected():
    """Blank frames (the optical flow follows nothing); the detector misses the left
    hand on frames 8–19.  Looked for in a box around where it is expected, which holds
    its true points, it is fitted to what is found there, within 0.15 hand sizes of
    them; without the look it is drawn nowhere after `MISSED_FRAMES`.  Only the missed
    hand is looked for."""
    T, missed = 24, range(8, 20)
    rig, truth = _truth(T, swap=False)
    size = np.linalg.norm(truth["left"][0, 9] - truth["left"][0, 0])
    runs = {}
    for looking in (True, False):
        rng, boxes, frame = np.random.default_rng(0), [], [0]
        look = _box_sees(lambda _, now=frame: {s: truth[s][now[0]] for s in SIDES}, boxes)
        tracker = HandsTracker(rig, detector=None, look=look if looking else None)
        results = []
        for t in range(T):
            frame[0] = t
            found = _detections(truth, t, rng, 0.0)
            if t in missed:
                found = [d for d in found if d.side != "left"]
            results.append(tracker.process(IMAGE, detections=[found]))
        runs[looking] = results
        if looking:
            assert len(boxes) == len(missed)  # only where the left hand was missed
    matched = _matched(runs[True], truth)
    left = next(k for k in (0, 1) if {s for s, _ in matched[k]} - {None} == {"left"})
    for t in missed:
        h = runs[True][t].hands[left]
        assert not h.no_hand and not h.hidden, t
        error = np.linalg.norm(h.projected[0] - truth["left"][t], axis=1).mean()
        assert error < 0.15 * size, (t, error / size)
    assert runs[False][missed[-1]].hands[left].no_hand


def test_a_hand_found_again_in_one_camera_only_is_not_fitted_to_that_view_alone():
    """Two cameras, blank frames; from frame 5 the detector misses the left hand in both.
    The second look in camera 0 finds a hand where it is expected, drawn as the left
    hand 80 mm farther along camera 0's rays would be (smaller: a detector's error of
    scale); camera 1's finds nothing.  Fitted to that one view, the hand would be drawn
    tens of mm deep of its true joints; it is not: on every frame it is drawn within
    20 mm of them or not at all."""
    rig = realistic_rig(2)
    joints = _apart()
    views = [{s: cam.project(j) for s, j in joints.items()} for cam in rig.cameras]
    ray = joints["left"].mean(axis=0) - rig.cameras[0].center
    deeper = rig.cameras[0].project(joints["left"] + 80.0 * ray / np.linalg.norm(ray))
    nothing = np.full((21, 2), np.nan)
    look = [_box_sees(lambda _: {"left": deeper}, []), _box_sees(lambda _: {"left": nothing}, [])]
    tracker = HandsTracker(rig, detector=None, look=look)
    for t in range(12):
        found = [[Detection(np.c_[views[j][s], np.ones(21)], side=s, score=0.9)
                  for s in SIDES if s == "right" or t < 5] for j in range(2)]  # fmt: skip
        r = tracker.process([IMAGE, IMAGE], detections=found)
        left = next(h for h in r.hands if h.side == "left")
        if not left.no_hand:
            error = np.linalg.norm(left.joints - joints["left"], axis=1).mean()
            assert error < 20.0, (t, error)


def _one_camera_first(seed: int, size: float = 225.0, T: int = 30, one: int = 8):
    """A right hand of `size` mm found in camera 1 alone on the first `one` frames, then
    in both (1 px of noise); its mean 3D joint error (mm) on those frames as tracked
    and after `back_fill`, and the frames back-filled."""
    rig = realistic_rig(2)
    poses, _ = motion_poses("counting", 0)
    model = HandModel(HandShape.from_size(size, side="right"))
    joints = np.stack([keypoint_points(model, x, "pad") for x in poses[:T]])
    tracker = HandsTracker(rig, detector=None, back=True)
    rng = np.random.default_rng(seed)
    for t in range(T):
        views = [[Detection(np.c_[cam.project(joints[t]) + rng.normal(0, 1.0, (21, 2)),
                                  np.ones(21)], side="right", score=0.9)]
                 for cam in rig.cameras]  # fmt: skip
        if t < one:
            views[0] = []
        tracker.process([IMAGE, IMAGE], detections=views)
    hand = next(h for h in tracker.hands if h.side == "right")

    def error():
        fitted = [keypoint_points(hand.tracker.hand, hand.tracker.frames[t].pose, "pad")
                  for t in range(one)]  # fmt: skip
        return np.linalg.norm(np.stack(fitted) - joints[:one], axis=-1).mean()

    before = error()
    refitted = tracker.back_fill()
    return before, error(), sorted(t for t in refitted if hand.id in refitted[t])


def test_a_hand_seen_in_one_camera_first_is_fitted_again_with_the_shape_two_give():
    """Two cameras; a 225 mm right hand (the model starts at 185) found in camera 1
    alone on the first 8 frames, then in both.  From one view its depth is its assumed
    shape's; on a recording (`back_fill`) those frames are fitted again backwards, from
    its `SETTLE_FRAMES`-th frame in both, with the shape the two views gave, and land
    nearer the truth in 3D: over four noise draws, at most 0.7 times the error as
    tracked, and never worse by more than 1 mm on one."""
    from handvar.tracking.hands import SETTLE_FRAMES

    runs = [_one_camera_first(seed) for seed in range(4)]
    for before, after, frames in runs:  # refitted from its SETTLE_FRAMES-th in two views
        assert frames == list(range(8 + SETTLE_FRAMES - 1))
        assert after < before + 1.0, runs
    assert np.mean([a for _, a, _ in runs]) < 0.7 * np.mean([b for b, _, _ in runs]), runs


@pytest.mark.slow
def test_a_real_video_beside_its_mirror_keeps_each_hand_on_its_half(tmp_path):
    """Real pixels with MediaPipe inside: the fingerspelling clip beside its mirror image
    (a right hand and the same motion as a left hand, never crossing the middle; as
    `studies/two_hands_mirrored.py` makes it). Each side stays on one half of the frame
    on every frame it is drawn, and the two halves never swap."""
    import cv2

    import handvar
    from handvar.data import example_path

    pytest.importorskip("mediapipe")
    source = cv2.VideoCapture(str(example_path("video").parent / "tfjs-asl-hand.mp4"))
    video = tmp_path / "mirrored.mp4"
    writer = None
    for _ in range(120):
        ok, frame = source.read()
        assert ok
        both = np.hstack([frame, np.full_like(frame[:, :64], 128), cv2.flip(frame, 1)])
        if writer is None:
            size = (both.shape[1], both.shape[0])
            writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 25.0, size)
        writer.write(both)
    writer.release()
    result = handvar.track(str(video), hands=2, scale=0.5)
    halves = {}
    for track in result.tracks.values():
        drawn = ~track.quality.no_hand & np.isfinite(track.projected[0]).all(axis=(1, 2))
        assert drawn.mean() > 0.9
        x = track.projected[0, drawn, :, 0].mean(axis=1)
        halves[track.shape.side] = set((x > size[0] / 2).tolist())
    # the real (right) hand on the left half, its mirror (a left hand) on the right
    assert halves == {"right": {False}, "left": {True}}


def test_one_hands_views_given_to_two_hands_go_to_the_one_nearer_in_3d():
    # two cameras; the right hand's last joints here, the left one's 120 mm behind it:
    # camera 0's view of the right hand went to the left hand's track, camera 1's to
    # the right one's (each camera's assignment on its own): both go to the right hand
    from types import SimpleNamespace

    rig, joints, tracker = _two_cameras()
    left, right = tracker.hands
    right.last = SimpleNamespace(joints=joints)
    behind, aside = np.array([0.0, 0.0, 120.0]), np.array([90.0, 0.0, 0.0])  # mm
    left.last = SimpleNamespace(joints=joints + behind)
    views = [Detection(np.c_[cam.project(joints), np.ones(21)], side="left", score=0.9)
             for cam in rig.cameras]  # fmt: skip
    given = {left.id: [views[0], None], right.id: [None, views[1]]}
    tracker._agree(given)
    assert given == {left.id: [None, None], right.id: [views[0], views[1]]}
    # views of two hands (their rays do not meet) stay where they were given
    other = Detection(np.c_[rig.cameras[1].project(joints + aside), np.ones(21)])
    given = {left.id: [views[0], None], right.id: [None, other]}
    tracker._agree(given)
    assert given == {left.id: [views[0], None], right.id: [None, other]}


def _two_cameras():
    """The realistic stereo pair, a right hand's 21 points on it (mm) and a two-hand
    tracker on it."""
    rig = realistic_rig(2)
    model = HandModel(HandShape.from_size(185.0))
    joints = keypoint_points(model, motion_poses("counting", 0)[0][0], "pad")
    return rig, joints, HandsTracker(rig, detector=None)


def _placed(rig, joints):
    """A hand's last fit as `_agree` reads it: its joints and their projections."""
    from types import SimpleNamespace

    projected = np.stack([cam.project(joints) for cam in rig.cameras])
    return SimpleNamespace(joints=joints, index=0, projected=projected)


def test_views_of_two_hands_given_to_one_are_parted():
    # camera 0's view of the right hand and camera 1's of the left hand (90 mm aside)
    # both went to the right hand's track: their rays do not meet, so the right hand
    # keeps the view where it is expected and the other goes to the left hand
    rig, joints, tracker = _two_cameras()
    aside = np.array([90.0, 0.0, 0.0])  # mm
    left, right = tracker.hands
    right.last, left.last = _placed(rig, joints), _placed(rig, joints + aside)
    mine = Detection(np.c_[rig.cameras[0].project(joints), np.ones(21)])
    theirs = Detection(np.c_[rig.cameras[1].project(joints + aside), np.ones(21)])
    given = {left.id: [None, None], right.id: [mine, theirs]}
    tracker._agree(given)
    assert given == {left.id: [None, theirs], right.id: [mine, None]}


def test_views_whose_rays_meet_far_from_both_hands_are_not_merged():
    # one camera's view to each hand; the rays meet, but where neither hand is (both
    # 150 mm off, more than half a palm): two hands seen where their rays happen to
    # cross (a ghost), so each hand keeps its view
    rig, joints, tracker = _two_cameras()
    left, right = tracker.hands
    left.last = _placed(rig, joints + np.array([0.0, 0.0, 150.0]))
    right.last = _placed(rig, joints + np.array([150.0, 0.0, 0.0]))
    views = [Detection(np.c_[cam.project(joints), np.ones(21)]) for cam in rig.cameras]
    given = {left.id: [views[0], None], right.id: [None, views[1]]}
    tracker._agree(given)
    assert given == {left.id: [views[0], None], right.id: [None, views[1]]}


def test_a_hand_only_the_second_camera_finds_starts_a_track():
    # camera 0 misses the hand on the first frame; camera 1 finds it: a track starts,
    # drawn on its points there (before, hands started on camera 0's detections only)
    rig, joints, tracker = _two_cameras()
    seen = Detection(np.c_[rig.cameras[1].project(joints), np.ones(21)], side="right")
    frames = [np.zeros((cam.height, cam.width, 3), np.uint8) for cam in rig.cameras]
    result = tracker.process(frames, detections=[[], [seen]])
    drawn = [h for h in result.hands if not h.no_hand]
    assert len(drawn) == 1 and drawn[0].side == "right"
    size = np.linalg.norm(seen.points[9, :2] - seen.points[0, :2])
    off = np.linalg.norm(drawn[0].projected[1] - seen.points[:, :2], axis=1)
    assert np.median(off) < 0.2 * size


def test_a_hand_followed_onto_the_other_restarts_on_a_hand_left_over():
    # the left hand's track, given no detection, lies on the right hand's detections in
    # both cameras (its flow followed the right hand); a hand 200 mm aside, detected in
    # both cameras, is given to nobody: the left track restarts on it, keeping its side.
    # Lying on the right hand in camera 0 only (hidden behind it) it does not.
    rig, joints, tracker = _two_cameras()
    aside = joints + np.array([200.0, 0.0, 0.0])

    def views(points):
        return [Detection(np.c_[cam.project(points), np.ones(21)]) for cam in rig.cameras]

    right_views, other_views = views(joints), views(aside)
    detections = [[right_views[j], other_views[j]] for j in range(2)]
    left, right = tracker.hands
    left.side, right.side = "left", "right"
    right.last = _placed(rig, joints)
    left.last = _placed(rig, joints + np.array([3.0, 0.0, 0.0]))  # on the right hand
    given = {left.id: [None, None], right.id: list(right_views)}
    tracker._born(given, detections)
    assert given[left.id] == other_views and left.side == "left"
    # behind the right hand along camera 0's rays: there on camera 0 only
    centre = rig.cameras[0].center
    left.last = _placed(rig, centre + 1.25 * (joints - centre))
    given = {left.id: [None, None], right.id: list(right_views)}
    tracker._born(given, detections)
    assert given[left.id] == [None, None]


def test_a_hand_seen_in_one_camera_gets_the_other_cameras_view_whose_rays_meet_it():
    # the right hand was given camera 1's view only (in camera 0 it is expected
    # elsewhere); camera 0 has its detection and that of a hand 200 mm aside left over:
    # it gets its own, whose rays meet its camera 1 view, not the other
    rig, joints, tracker = _two_cameras()
    aside = joints + np.array([200.0, 0.0, 0.0])
    left, right = tracker.hands

    def view(j, points):
        return Detection(np.c_[rig.cameras[j].project(points), np.ones(21)])

    mine, other = view(0, joints), view(0, aside)
    given = {left.id: [None, None], right.id: [None, view(1, joints)]}
    tracker._complete(given, [[other, mine], [given[right.id][1]]])
    assert given[right.id][0] is mine and given[left.id] == [None, None]
    # only the other hand's detection left over: its rays do not meet, it stays
    given = {left.id: [None, None], right.id: [None, view(1, joints)]}
    tracker._complete(given, [[other], [given[right.id][1]]])
    assert given[right.id][0] is None


def test_a_hands_views_that_make_a_short_palm_are_paired_where_no_other_hands_are_left():
    # a hand whose points triangulate to a 32 mm palm (under PALM_MM's 50 mm, as
    # MediaPipe's points of a rendered hand did), given camera 0's view, the other hand
    # (200 mm aside) given its views in both: the one detection left over in camera 1
    # is the hand's (unpaired, the hand would be fitted to one view, off in depth).
    # Without the other hand's view in camera 1, the palm stays bounded:
    # the view left over may be that hand's, its rays meeting the first's by chance.
    from handvar.vision.keypoints import PALM_MM

    rig, joints, tracker = _two_cameras()
    small = joints[0] + 0.4 * (joints - joints[0])
    assert np.linalg.norm(small[9] - small[0]) < PALM_MM[0]
    aside = joints + np.array([200.0, 0.0, 0.0])
    left, right = tracker.hands

    def view(j, points):
        return Detection(np.c_[rig.cameras[j].project(points), np.ones(21)])

    mine, theirs = [view(0, small), view(1, small)], [view(0, aside), view(1, aside)]
    detections = [[mine[0], theirs[0]], [mine[1], theirs[1]]]
    given = {left.id: list(theirs), right.id: [mine[0], None]}
    tracker._complete(given, detections)
    assert given == {left.id: theirs, right.id: mine}
    given = {left.id: [None, None], right.id: [mine[0], None]}  # the other hand unseen
    tracker._complete(given, [[mine[0]], [mine[1]]])
    assert given[right.id] == [mine[0], None]


@pytest.mark.parametrize(
    ("finds", "back", "kept"),
    [((6,), True, False), ((6, 8), True, True), ((6,), False, True)],
)
def test_a_track_the_detector_found_once_is_taken_off_a_recording(finds, back, kept):
    """The sliding frames; the right hand found on every frame, a left hand only on the
    frames `finds` (a detector's false hand).  Found once, it is drawn there and on the
    frames after it is followed; on a recording (``back=True``) `back_fill` takes the
    track off all of them (its frames no hand, NaN poses returned); found on
    `CONFIRM_FOUND` frames it stays, and frame by frame nothing is taken off after the
    fact.  The right hand stays on every frame."""
    assert CONFIRM_FOUND == 2  # the cases' finds: once, and twice
    _, tracker, results = _track_sliding(
        24, lambda t, side: side == "right" or t in finds, back=back
    )
    left = next(h.id for h in results[finds[0]].hands if h.side == "left")
    drawn = [t for t, r in enumerate(results) if not r.hands[left].no_hand]
    assert finds[0] in drawn
    poses = tracker.back_fill()
    frames = tracker.hands[left].tracker.frames
    assert [t for t in drawn if not frames[t].no_hand] == (drawn if kept else [])
    if not kept:
        assert all(np.isnan(poses[t][left]).all() for t in drawn)
    assert not any(f.no_hand for f in tracker.hands[1 - left].tracker.frames)


@pytest.mark.parametrize("cut", [None, 4])
def test_a_hand_found_late_is_carried_back_on_a_recording_but_not_across_a_cut(cut):
    """The textured frames of the test above; the detector finds the left hand only from
    frame 8.  On a recording (``back=True``) `back_fill` fits it on frames 0-7 to its
    first detection carried back by the flow, within 0.15 hand sizes of its true
    points; with another scene before frame `cut` the flow loses it there, and those
    frames stay without it.  Frame by frame (``back=False``) it has none."""
    T, first_found = 12, 8
    rig, truth = _sliding(T)
    rng = np.random.default_rng(0)
    scenes = [_texture(rng) for _ in range(2)]
    trackers = {back: HandsTracker(rig, detector=None, back=back) for back in (True, False)}
    results = {back: [] for back in trackers}
    for t in range(T):
        scene = scenes[1 if cut is not None and t < cut else 0]
        image = _slid(scene, t)
        found = _detections(truth, t, rng, 0.0)
        if t < first_found:
            found = [d for d in found if np.linalg.norm(d.points[0, :2] - truth["left"][t, 0]) > 20]
        for back, tracker in trackers.items():
            results[back].append(tracker.process(image, detections=[list(found)]))
    matched = _matched(results[True], truth)
    left = next(k for k in (0, 1) if {s for s, _ in matched[k]} - {None} == {"left"})
    assert all(results[True][t].hands[left].no_hand for t in range(first_found))
    filled = trackers[True].back_fill()
    assert trackers[False].back_fill() == {}
    model = trackers[True].hands[left].tracker.hand
    size = np.linalg.norm(truth["left"][0, 9] - truth["left"][0, 0])
    start = 0 if cut is None else cut
    assert sorted(filled) == list(range(start, first_found))
    for t in range(start, first_found):
        projected = rig.cameras[0].project(keypoint_points(model, filled[t][left], "pad"))
        error = np.linalg.norm(projected - truth["left"][t], axis=1).mean()
        assert error < 0.15 * size, (t, error / size)
    track = trackers[True].hands[left].tracker.recovered(keypoints=True).track
    assert np.isfinite(track.poses[start:first_found]).all()
    assert np.isnan(track.poses[:start]).all()


def test_the_skin_of_two_hands_one_in_front_of_the_other_is_shared_between_them():
    """Rule 5's split, against the truth: on a rendered occlusion (`occlude`, seed 0;
    one skin component where the hands overlap), where both hands are expected the
    hand in front (at the poses their predictors expect) is given most of its own
    visible pixels and few of the other's (the skin alone gives it all of both), and
    the hand behind its own and the front hand's (where its hidden parts may lie)."""
    import cv2

    from handvar.evaluation.two_hands import two_hand_case

    case = two_hand_case("occlude", seed=0, frames=(20, 60), size=(320, 180))
    tracker = HandsTracker(case.rig, detector=None, look=None)
    camera = case.rig.cameras[0]
    own, taken, behind_own = [], [], []
    for t in range(case.n_frames):
        image = [cv2.cvtColor(case.frames[0, t], cv2.COLOR_RGB2BGR)]
        expected = tracker._expected_now()
        if case.overlap[0, t] and len(expected) == 2:
            silhouettes = tracker._shares(image, t, expected)()
            depth = {k: camera.camera_from_world(model.joints(pose))[:, 2].mean()
                     for k, (model, pose) in expected.items()}  # fmt: skip
            front, behind = (tracker.hands[k] for k in sorted(depth, key=depth.get))
            mine = case.masks[0, case.sides.index(front.side), t]
            other = case.masks[0, case.sides.index(behind.side), t]
            given = silhouettes[front.id][0]
            own.append((given & mine).sum() / mine.sum())
            taken.append((given & other).sum() / other.sum())
            assert (silhouettes[behind.id][0] >= given).all()
            behind_own.append((silhouettes[behind.id][0] & other).sum() / other.sum())
        tracker.process(image, detections=[case.detections[0][t]])
    assert len(own) >= 20
    assert np.median(own) > 0.85 and np.median(taken) < 0.5, (np.median(own), np.median(taken))
    assert np.median(behind_own) > 0.8
