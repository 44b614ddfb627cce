"""Two hands at once: ``result = tracker.process(frame)`` with an identity per hand (design §17).

`HandsTracker` holds one `HandTracker` per hand, each with its own model (a left and a
right hand), shape, predictor and quality, and gives them the detector's hands frame
by frame.  Which detection is which hand is decided by tracking, not by the
detector's label:

1. **Where each hand is expected.**  A tracked hand's 21 points in every camera,
   extrapolated from its last two fits at constant velocity (only from its last one
   after a gap), or where its last fit put them, whichever is nearer a detection; its
   size s the wrist → middle-MCP distance there.
2. **Assignment.**  Per camera, the cost of giving detection d to hand h is the median
   over their common points of |p_h − p_d| / s_h, plus `LABEL_COST` · (2 score − 1)
   when the detector labels d with the other side (twice when d is labelled at least
   `SIDE_SURE` sure the side of a free hand, one expected nowhere: given to h it would
   be taken from that hand too); the assignment of least total cost
   (`least_cost_pairs`) keeps the pairs under `GATE` hand sizes
   (wider by `GATE_GROWTH` for each frame since the hand was last fitted, or for each
   of the detector's frames since it was last given a detection if more: a hand
   followed by optical flow is less sure of its place than a detected one).  Two
   detections so given that lie within `DUPLICATE` hand sizes of each other are one
   hand found twice (MediaPipe does so): only the one nearer where its hand is expected
   is kept, else the other hand, fitted to it in one camera, is drawn on it at a depth
   no other camera checks.  A hand given none takes the nearest detection left over
   within `NEW_HAND` hand sizes labelled at least `SIDE_SURE` sure its side, not one
   given found again (`_labelled_back`): the flow may have carried it off its hand,
   beyond the gate.  On the two-hand benchmark with MediaPipe on every 5th frame, a
   hand the flow had carried off between two of its frames took the other hand's
   detection, sure of the other side, and the two swapped; with the label counted
   twice it took none, and its own detection brought it back
   (docs/results/two-hands.md).  The label is
   one vote among others: a hand that crosses the other keeps its identity when the
   detector's labels swap.  With two cameras or more (`_agree`), a hand given views
   whose rays do not meet within `RAY_GAP` (two hands) keeps the one nearer where it
   is expected; the other goes to the other hand if that has none in its camera and
   it is that hand's (its rays meet that hand's other view, or, without one, it lies
   within that hand's gate).  One hand's views given to two hands (one camera's
   detection to one, another's to the other, their rays meeting) go both to the hand
   whose last joints lie nearer the points they triangulate, in 3D, where the hand
   in front and the one it hides are apart in depth, if within `SAME_HAND` of its
   palm's length: two views of two hands may meet too, at a point where neither is
   (a ghost).  A hand given a view in some camera and none in another gets the
   detection left over there whose rays meet its view's within `RAY_GAP`, the
   nearest (`_complete`): where it is expected in that camera, the flow may have
   followed the other hand.  The points two views triangulate must make a palm
   (wrist → middle MCP) within `PALM_MM`, lest two hands' views whose rays meet by
   chance be paired; not bounded below (`ALONE_PALM`) where camera j's detections are
   all given, one is left over in the other camera and every other hand has its view
   there (`_alone`): it can be no other hand's.  MediaPipe's points of one rendered
   hand made a palm of 28–35 mm, and that hand was fitted to one view, off in depth
   (docs/results/two-hands.md).
3. **A new hand.**  A detection left over in any camera (the first camera's first),
   not within `DUPLICATE` hand sizes of a tracked hand's detection (MediaPipe
   sometimes finds one hand twice), nor within `NEW_HAND` of the detection of a
   tracked hand of the side it is labelled (found twice, labelled alike), nor within
   `NEW_HAND` of a tracked hand given none (that hand's, off by a gross error, unless
   it is labelled at least `SIDE_SURE` sure the side of a free hand: that hand coming
   back), starts the free hand (in the other cameras, the detection whose rays pass
   nearest its own, within `RAY_GAP` mm).  A hand is free where it is expected
   nowhere, or, given no detection, where it lies on the other hand's detections
   (within `DUPLICATE`) in two cameras or more: the flow followed it onto the other
   hand (on one camera's alone it may be hidden behind it).  Its side: the other side
   than that of the hand tracked or found on this frame if there is one (two hands of
   one person), else the detector's label.  So a hand that leaves and comes back is
   re-acquired with its side.
4. **The side of a hand** never changes within a track, except on overwhelming
   evidence: of the labels given to a new hand over its first `SIDE_FRAMES` frames
   (with the detector on every K-th frame, `SIDE_FRAMES` / K of them), a weighted
   share `SIDE_SWAP` or more for the other side; or, at any time, `SIDE_RUN`
   labelled detections in a row each for the other side with a score of `SIDE_SURE`
   or more.  Either turns it and the other hand's with it (the two staying opposite,
   their sides then decided); the model is built again on the new side at the next
   frame.  On the two-hand benchmark with the run rule off, MediaPipe's labels sure
   of the other side came at most 8 in a row on a hand whose side was right, and up
   to 30 on one whose side was wrong (``studies/two_hands.py --detector mediapipe``,
   its side-run option at 1000).
5. **One hand hiding the other.**  Per camera, the keypoints of a hand that fall
   inside the other hand's expected outline (the convex hull of its points, widened
   by 0.15 of its size) while the other is nearer the camera by `FRONT` mm or more
   get their confidence times `HIDDEN_WEIGHT`.  Where the fit is given the
   silhouettes (the silhouette term, `RecoverySettings.with_silhouette_term`, or the
   IoU of `RecoverySettings.keypoint_iou`), the skin is shared between the two hands
   (`handvar.vision.silhouette.split_silhouette`): each pixel goes to the hand whose
   model, at its predicted pose, lies nearest it, the one in front where both cover
   it, and a hand is given its share and the shares of the hands in front of it
   (where its hidden parts may lie): touching hands make one skin component, and the
   hand in front is compared with its own part of it.
6. **A hand the detector misses.**  With a detector that can look at part of a frame
   (``look``: MediaPipe's, `handvar.vision.mediapipe.MediaPipeCrop`), a tracked hand
   in the open (not behind the other, rule 5) that no detection lies near in a camera
   is looked for again in a box `LOOK_PAD` hand sizes around where it is expected: a
   hand small in the frame, or beside the other, that the detector's look at the
   whole frame missed is often found there.  What is found joins that camera's
   detections if it lies within the hand's gate, nearer it than the other hand, is
   not one of them found again (`DUPLICATE`), and, with two cameras or more, its
   rays meet those of the hand's detection in another camera (`RAY_GAP`): found in
   one view only it would be fitted along that camera's rays (3 hand sizes chosen
   among 2, 3 and 4, and the two conditions, on the two-hand benchmark with MediaPipe:
   without them, identity switches).  Otherwise its last detection's points are followed by
   optical flow (`handvar.vision.carry.KeypointCarrier`, the points the flow loses
   dropped) for up to `MISSED_CARRY` frames, and the hand is fitted to them (rule 5
   applied to them too), while the detector has found it on `FOUND_SHARE` of its
   frames or more since its track began (a detector's false hand, found now and then,
   is not carried between its finds); after `BEHIND_CARRY` frames, only while no hand
   in front of it (rule 5's) overlaps it by `BEHIND_SHARE` of its expected points: in
   the open the flow sees the hand it follows, behind another it follows the front
   one.  With two cameras or more, a hand the flow follows in one camera only needs
   `ONE_VIEW_POINTS` points there: fitted to fewer, it drifted along that camera's
   rays, off the hand in the other (4 chosen among 2, 4 and 6 on the two-hand
   benchmark with MediaPipe, docs/results/two-hands.md); with that many, a hand the
   detector missed is held in the other cameras at its last fit's points, with
   confidence `HELD_VIEW`: one view tells its depth only by its size, which the flow's
   points do not keep (0.5 chosen among 0.2, 0.5 and 1 there).  Once
   no point is followed, a hand fitted until a frame ago is carried, held where it was
   last fitted (``hidden``, its quality ``empty``; `HandTracker.carried`): for up to
   `HIDDEN_FRAMES` frames while `BEHIND_SHARE` of its expected points or more lie
   inside the other hand's outline (behind it, or touching it), for up to
   `MISSED_FRAMES` in the open; after that it is a frame without that hand.  Carried on
   by its motion prediction instead, a hand that had stopped against the other one
   drifted off it (on the two-hand benchmark with MediaPipe, one camera: 51 frames
   lost while visible against 44 held; docs/results/two-hands.md).  With a detector
   on every K-th frame (``keypoint_every``) the flow carries each detection to the
   frames it skips, the points it loses held there as one hand's
   (`CarrySettings.hold`), and a hand missed on the detector's frame is followed on
   as above: carried by its prediction alone there, a hand half hidden by the other
   drifted onto it and the two swapped on the two-hand benchmark
   (docs/results/two-hands.md).
7. **A hand found late** (a recording, ``HandsTracker(back=True)``, `back_fill`).  A
   hand's first detection after frames without it is carried back by optical flow to
   those frames, at most `CarrySettings.max_frames`, while the flow follows at least
   `BACK_POINTS` of its points in some camera and they do not lie on the other hand's
   fit (within `DUPLICATE` hand sizes), and only if the detector finds it on
   `BACK_SHARE` of its frames or more from that detection over as many frames on, as
   one hand's track on a recording is
   (design §14.5); once every frame is tracked, those frames are fitted to them,
   backwards from the detection, with the hand's final shape.  One hand's track wants
   6 points (`CarrySettings.lead_points`): there the frames carried back are among the
   first that shape the hand; here the shape is fitted before.  2 was chosen among 2,
   6 and 11 on the two-hand benchmark with MediaPipe (docs/results/two-hands.md).
   With two cameras or more, a hand fitted to one camera's keypoints on the frames
   before it is first fitted to two is fitted to them again (at most 30 frames back),
   backwards from its `SETTLE_FRAMES`-th frame in two, with its final shape: from one
   view its depth is its shape's, and only two views tell the shape, over some frames
   (10 chosen among 1, 5, 10, 20 and 30 on the two-hand benchmark with MediaPipe).
   Once every frame is tracked, a track the detector found on fewer than
   `CONFIRM_FOUND` of its frames is taken off its frames: a detector's false hand
   found once, then followed and carried for a few frames.

A frame's `HandsResult` holds one `FrameResult` per hand, under its id (0, 1: the order
in which the hands were first seen) with its side.  With ``hands=1`` it tracks the
first hand it sees by the same rules; the one-hand `HandTracker` and ``handvar.track``
are not changed by it.  Only detections drive it: without any it draws nothing (the
silhouette tracker is one hand's).

Examples
--------
>>> import numpy as np
>>> tracker = HandsTracker(detector=lambda image: None)  # a detector that finds nothing
>>> result = tracker.process(np.zeros((48, 64, 3), np.uint8))
>>> [(h.id, h.no_hand) for h in result.hands]
[(0, True), (1, True)]
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import itertools
import math
import time
from dataclasses import dataclass

import cv2
import numpy as np

from handvar.hand.anthropometry import other_side
from handvar.validate import as_int
from handvar.vision.keypoints import PALM_MM, RAY_GAP, ray_points

__all__ = [
    "ALONE_PALM",
    "BEHIND_CARRY",
    "BEHIND_SHARE",
    "DUPLICATE",
    "FRONT",
    "GATE",
    "GATE_GROWTH",
    "HELD_VIEW",
    "HIDDEN_FRAMES",
    "HIDDEN_WEIGHT",
    "LABEL_COST",
    "LOOK_PAD",
    "MISSED_CARRY",
    "MISSED_FRAMES",
    "NEW_HAND",
    "ONE_VIEW_POINTS",
    "RAY_GAP",
    "SAME_HAND",
    "SETTLE_FRAMES",
    "SIDE_FRAMES",
    "SIDE_RUN",
    "SIDE_SURE",
    "SIDE_SWAP",
    "HandsResult",
    "HandsTracker",
    "assign",
    "expected_points",
]

#: Hand sizes (wrist → middle MCP) within which a detection may be a tracked hand's.
GATE = 1.0
#: Hand sizes the gate widens by for each frame since the hand was last fitted.
GATE_GROWTH = 0.2
#: Hand sizes added to the cost of a detection labelled the other side, times its
#: score's margin 2·score − 1.
LABEL_COST = 0.25
#: Hand sizes within which a second detection is the same hand found twice.
DUPLICATE = 0.35
#: Palm lengths (its wrist → middle MCP) from a hand's last joints within which the
#: points two hands' views triangulate must lie for the views to be that one hand's.
SAME_HAND = 0.5
#: mm: the shortest palm (wrist → middle MCP) a hand's views in two cameras may
#: triangulate to where no other hand's view is left over to pair with (`PALM_MM`'s
#: lower bound keeps two hands' views whose rays meet by chance apart): none.
ALONE_PALM = 0.0
#: Hand sizes from a tracked hand given no detection within which a detection left over
#: is that hand's, off by a detector's gross error, not a new hand (given to it if
#: labelled at least `SIDE_SURE` sure its side).
NEW_HAND = 2.0
#: Frames of a new hand's labelled detections after which its side may turn (with
#: the detector on every K-th frame, the labels of as many frames: 30 / K).
SIDE_FRAMES = 30
#: Weighted share of labels for the other side that turns a new hand's side.
SIDE_SWAP = 0.8
#: Score of a label for the other side that counts towards `SIDE_RUN`.
SIDE_SURE = 0.8
#: Labelled detections in a row, each for the other side with a score of `SIDE_SURE` or
#: more, that turn a hand's side at any time.
SIDE_RUN = 10
#: mm nearer the camera that the other hand must be to hide a hand's points.
FRONT = 30.0
#: Confidence factor of a keypoint inside the outline of the hand in front (0.2 chosen
#: among 0.05, 0.2 and 0.5 on the two-hand benchmark with MediaPipe).
HIDDEN_WEIGHT = 0.2
#: Frames a hand hidden behind the other, or against it, is carried (held).  At most
#: `GONE_FRAMES` + 1, after which the hand is no longer expected; 10 lost more on the
#: two-hand benchmark with MediaPipe.
HIDDEN_FRAMES = 11
#: Share of a hand's expected points inside the nearer hand's outline that makes it hidden.
BEHIND_SHARE = 0.2
#: Frames a hand given no detection in the open is carried (held) once the
#: optical flow follows none of its points (a detector's miss).  1 drew fewer hands
#: off the hand than 2 on each of the two-hand benchmark's eight runs, 3 more.
MISSED_FRAMES = 1
#: Frames a hand the detector misses is followed by optical flow from its last detection.
MISSED_CARRY = 60
#: Of those, the frames it is followed while a hand in front of it overlaps it.
BEHIND_CARRY = 10
#: Points the optical flow must follow of a hand given no detection, carried in one
#: camera only of two or more, for it to be fitted to them (rule 6).
ONE_VIEW_POINTS = 4
#: Confidence of the points a hand followed in one camera only is held at in the others,
#: its last fit's (rule 6).
HELD_VIEW = 0.5
#: Hand sizes around a missed hand's expected points of the box the detector looks at
#: again (rule 6).
LOOK_PAD = 3.0
#: Frames without a detection after which a hand is no longer expected anywhere.
GONE_FRAMES = 10
#: Frames in two views or more after which a hand first fitted to one is fitted again,
#: backwards from there, on those frames and the ones before (rule 7).
SETTLE_FRAMES = 10
#: Points of a hand found late that the optical flow must still follow for its first
#: detection to be carried back to a frame (rule 7).
BACK_POINTS = 2
#: Share of the detector's frames since its track began that a hand must have been
#: found on to be followed through a miss (rule 6).  On the two-hand benchmark it
#: changes no run with MediaPipe (docs/results/two-hands.md).
FOUND_SHARE = 1 / 3
#: Share of the detector's frames over the `CarrySettings.max_frames` from a hand's first
#: detection after frames without it that it must be found on to be carried back from
#: it (rule 7).  `FOUND_SHARE` here lost a real hand MediaPipe finds on few frames
#: there; 0.1 changes no run with MediaPipe.
BACK_SHARE = 0.1
#: The detector's frames a track must be found on for a recording to keep it (rule 7):
#: 2, by reason; it loses no frame on the two-hand benchmark (docs/results/two-hands.md).
CONFIRM_FOUND = 2


@dataclass(frozen=True, eq=False)
class HandsResult:
    """What `HandsTracker.process` gives for one frame.

    Attributes
    ----------
    index : int
        The frame's number, from 0.
    hands : tuple of FrameResult
        One per hand, in the order of their ids (``hands[k].id == k``), each with its
        ``side`` ("" before the hand was first seen), ``no_hand`` where it is not in
        the frame and ``hidden`` where it was carried behind the other.
    seconds : float
        Wall time of the frame (assignment and fits), seconds.
    """

    index: int
    hands: tuple
    seconds: float

    def side(self, side: str):
        """The hand of `side` ("right" or "left"), or None where no hand has it."""
        for h in self.hands:
            if h.side == side:
                return h
        return None


def expected_points(last, before) -> np.ndarray | None:
    """A hand's points expected in this frame per camera, (n_cams, 21, 2), from its last
    two `FrameResult` with a hand (`before` None or not the frame before `last`: the last
    one's points); None without any."""
    if last is None:
        return None
    p = last.projected
    if before is not None and before.index == last.index - 1:
        p = p + (p - before.projected)  # constant velocity
    return p


def _size(*hands: np.ndarray) -> float:
    """Hand size in pixels: wrist → middle MCP, the smallest of `hands` (21, 2) where
    both points are seen, at least 8 px."""
    from handvar.vision.keypoints import HandLandmark

    sizes = [float(np.hypot(*(p[HandLandmark.MIDDLE_FINGER_MCP] - p[HandLandmark.WRIST])))
             for p in hands]  # fmt: skip
    sizes = [s for s in sizes if np.isfinite(s)]
    return max(min(sizes), 8.0) if sizes else 8.0


def _distance(expected: np.ndarray, detected: np.ndarray) -> float:
    """Median distance of the common points over the hand size, inf without any; of
    several places a hand may be (k, 21, 2), the nearest."""
    if expected.ndim == 3:
        return min(_distance(e, detected) for e in expected)
    d = np.linalg.norm(expected - detected[:, :2], axis=1)
    d = d[np.isfinite(d) & (detected[:, 2] > 0)]
    size = _size(expected, detected[:, :2])  # the smaller: a far hand is far
    return float(np.median(d)) / size if d.size else np.inf


def assign(expected: list, sides: list, found: list, gates: list) -> dict[int, int]:
    """Detections given to tracked hands in one camera (module notes, rule 2).

    Parameters
    ----------
    expected : list of (21, 2) or (k, 21, 2) ndarray or None
        Per hand, its expected points, or k places it may be (the nearest counts);
        None: not expected anywhere.
    sides : list of str
        Per hand, its side.
    found : list of Detection
    gates : list of float
        Per hand, the largest cost of a detection given to it, hand sizes.

    Returns
    -------
    dict
        Hand index → detection index.

    Examples
    --------
    >>> from handvar.vision.keypoints import Detection
    >>> a, b = np.zeros((21, 2)), np.zeros((21, 2))
    >>> a[9], b[:, 0], b[9] = (0, 40), 100, (100, 40)
    >>> found = [Detection(np.c_[b, np.ones(21)], side="left"),
    ...          Detection(np.c_[a, np.ones(21)], side="left", score=0.9)]
    >>> assign([a, b], ["right", "left"], found, [1.0, 1.0])  # the labels are outvoted
    {0: 1, 1: 0}
    """
    rows = [h for h, e in enumerate(expected) if e is not None]
    if not rows or not found:
        return {}
    free = {side for e, side in zip(expected, sides, strict=True) if e is None}
    cost = np.full((len(rows), len(found)), np.inf)
    for r, h in enumerate(rows):
        for k, d in enumerate(found):
            c = _distance(expected[h], d.points)
            if d.side and d.side != sides[h]:
                claimed = d.score >= SIDE_SURE and d.side in free
                c += LABEL_COST * (2.0 * d.score - 1.0) * (2 if claimed else 1)
            cost[r, k] = c
    pairs = least_cost_pairs(np.where(np.isfinite(cost), cost, 1e6))
    return {rows[r]: k for r, k in pairs if cost[r, k] <= gates[rows[r]]}


def least_cost_pairs(cost: np.ndarray) -> list[tuple[int, int]]:
    """The pairs (row, column) of the one-to-one assignment of least total `cost`, every
    row paired if there are no more rows than columns, else every column: the linear
    assignment problem, solved by trying every assignment.

    There are two hands at most, so there are at most ``m (m − 1)`` assignments for `m`
    detections; this gives what `scipy.optimize.linear_sum_assignment` gives (the tests
    compare them) without importing SciPy's optimisers, a large part of a run's
    start-up (`benchmarks/two_hands.py` times the command on 5 frames).

    Examples
    --------
    >>> least_cost_pairs(np.array([[4.0, 1.0, 5.0], [2.0, 0.0, 6.0]]))
    [(0, 1), (1, 0)]
    """
    import itertools

    n, m = cost.shape
    if n > m:
        return sorted((r, c) for c, r in least_cost_pairs(cost.T))
    best, pairs = np.inf, []
    for columns in itertools.permutations(range(m), n):
        total = sum(cost[r, c] for r, c in enumerate(columns))
        if total < best:
            best, pairs = total, list(enumerate(columns))
    return pairs


def _inside(hand: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Which of `points` (21, 2) lie inside the outline of `hand` (21, 2): the convex
    hull of its finite points, widened by 0.15 of its size (rule 5)."""
    import cv2

    out = np.zeros(len(points), dtype=bool)
    p = hand[np.isfinite(hand).all(axis=1)]
    if len(p) < 3:
        return out
    outline, margin = cv2.convexHull(p.astype(np.float32)), 0.15 * _size(hand)
    for i, (x, y) in enumerate(points):
        if np.isfinite(x) and np.isfinite(y):
            out[i] = cv2.pointPolygonTest(outline, (float(x), float(y)), True) >= -margin
    return out


@dataclass
class _Hand:
    """One tracked hand: its id, side, per-frame tracker and recent fits."""

    id: int
    side: str
    tracker: object  # HandTracker
    last: object = None  # its last FrameResult with a hand
    before: object = None  # the one before it
    missing: int = 0  # frames since it was last fitted
    hidden: int = 0  # frames it has been carried hidden
    votes: list = dataclasses.field(default_factory=list)  # signed label scores, while new
    against: int = 0  # labelled detections in a row sure of the other side
    carriers: list | None = None  # per camera: its detections carried by optical flow
    undetected: int = 0  # the detector's frames since it was last given a detection
    single: list = dataclasses.field(default_factory=list)  # (t, kps, images) in one view
    settled: int = -1  # frames since first fitted to two views or more (-1: not yet)
    looked: int = 0  # the detector's frames since its track began
    found: int = 0  # of them, those it was given a detection on
    detected: dict = dataclasses.field(default_factory=dict)  # detector's frame → given one
    firsts: list = dataclasses.field(default_factory=list)  # each track's first frame

    def count(self, t: int, ran: bool) -> None:
        """Note frame t: the detector's frame or not, the hand given a detection there or
        not (`undetected` as now)."""
        if ran:
            found = self.undetected == 0
            self.looked, self.found = self.looked + 1, self.found + found
            self.detected[t] = found

    def begin(self, t: int) -> None:
        """A new track from frame t: the counts of `count` start again."""
        self.firsts.append(t)
        self.last = self.before = None
        self.looked = self.found = 0

    def track_end(self, t: int, stop: int) -> int:
        """`stop`, or the first frame of the hand's next track after frame t if sooner."""
        return min([stop] + [first for first in self.firsts if first > t])

    def finds(self, start: int, stop: int) -> tuple[int, int]:
        """The detector's frames in [start, stop) within the track of frame `start`, and
        those of them the hand was given a detection on."""
        stop = self.track_end(start, stop)
        ran = [self.detected[t] for t in range(start, stop) if t in self.detected]
        return len(ran), sum(ran)

    @property
    def followed(self) -> bool:
        """Found on `FOUND_SHARE` of the detector's frames or more since its track began
        (rule 6)."""
        return self.found >= FOUND_SHARE * self.looked

    @property
    def expected(self):
        if self.last is None or self.missing > GONE_FRAMES:
            return None
        return expected_points(self.last, self.before)

    def places(self, j: int):
        """Where it may be in camera j, (2, 21, 2): extrapolated and as last fitted (a
        glitch of the last fit is not extrapolated alone); None if not expected."""
        e = self.expected
        return None if e is None else np.stack([e[j], self.last.projected[j]])

    def distance(self, points: np.ndarray) -> float:
        """Mean distance (mm) of its last joints to 3D `points` (21, 3), over the points
        given (NaN elsewhere); inf without a last fit."""
        if self.last is None:
            return np.inf
        d = np.linalg.norm(self.last.joints - points, axis=1)
        return float(np.nanmean(d)) if np.isfinite(d).any() else np.inf

    @property
    def gate(self) -> float:
        """The largest cost of a detection given to it, hand sizes (rule 2)."""
        return GATE + GATE_GROWTH * max(self.missing, self.undetected)

    def palm(self) -> float:
        """Wrist → middle-MCP length of its last joints, mm (0 without a last fit)."""
        from handvar.vision.keypoints import HandLandmark as L

        if self.last is None:
            return 0.0
        joints = self.last.joints
        return float(np.linalg.norm(joints[L.MIDDLE_FINGER_MCP] - joints[L.WRIST]))

    def depth(self, camera) -> float:
        """Mean depth of its last joints in `camera`, mm."""
        return float(np.nanmean(camera.camera_from_world(self.last.joints)[:, 2]))


class HandsTracker:
    """Track up to two hands frame by frame (module notes).

    Parameters
    ----------
    rig : Rig, path-like or None
        The cameras (as `HandTracker`).
    hands : {1, 2}, keyword-only
        Hands tracked at most.
    detector : {"auto", "mediapipe", "none"} or callable, keyword-only
        The keypoint detector (`handvar.vision.detector.make_detectors`), asked for
        every hand it finds; "none" needs `process` to be given the detections.
    mirrored : bool, keyword-only
        MediaPipe: the frames are mirrored (a selfie camera).
    keypoint_every : int, keyword-only
        Run the detector on every K-th frame only; on the frames between, each hand's
        last detection is carried forward by optical flow (module notes, rule 6).
    back : bool, keyword-only
        Keep the last `CarrySettings.max_frames` frames, so that `back_fill` can carry
        a hand found late back to them (module notes, rule 7): a recording's way, not
        a live camera's.
    look : {"auto", "mediapipe", None} or callable, keyword-only
        Where a hand expected was missed, look for it again (module notes, rule 6):
        "mediapipe", MediaPipe on a box of the frame (`MediaPipeCrop`, its graph
        built now); "auto", so when the detector is MediaPipe; a callable
        ``(image, (x0, y0, x1, y1)) -> list[Detection]`` (the hands found in that box
        of the BGR image, in the image's pixels), or a list of one per camera; None:
        not.
    **options
        For each hand's `HandTracker`: ``predictor``, ``hand_length``, ``model``,
        ``keypoint_tips``, ``recovery``, ``seed``, ``fov``.
    """

    def __init__(self, rig=None, *, hands: int = 2, detector="auto", mirrored: bool = False,
                 keypoint_every: int = 1, back: bool = False, look="auto",
                 **options) -> None:  # fmt: skip
        from handvar.camera import Rig
        from handvar.tracking.hand_tracker import HandTracker
        from handvar.vision.detector import make_detectors

        n_hands = as_int(hands, "hands", minimum=1, maximum=2)
        self.every = as_int(keypoint_every, "keypoint_every", minimum=1)
        if "hand" in options:
            raise TypeError("hand: not an option of HandsTracker (each hand's side is "
                            "decided by tracking)")  # fmt: skip
        if rig is not None and not isinstance(rig, Rig):
            rig = Rig.load(rig)
        self.rig = rig
        n = 1 if rig is None else len(rig)
        self.detectors = make_detectors(detector, n, mirrored=mirrored) if detector else None
        if isinstance(look, str) and look == "auto":  # MediaPipe's if it is the detector
            look = "mediapipe" if self.detectors and not callable(detector) else None
        if isinstance(look, str) and look == "mediapipe":
            from handvar.vision.mediapipe import MediaPipeCrop

            crop = MediaPipeCrop(mirrored=mirrored)  # a still image: one serves every camera
            crop.load()  # before the first frame, not at the first miss
            look = [crop] * n
        elif callable(look):
            look = [look] * n
        elif look is not None and (
            isinstance(look, str) or len(look) != n or not all(map(callable, look))
        ):
            raise ValueError(f"look: expected auto, mediapipe, None, a callable (image, box) "
                             f"-> hands or one per camera ({n}); got {look!r}")  # fmt: skip
        self.look = look
        self.looks = 0  # boxes looked at again (rule 6)
        # each hand fitted from the detections given to it (its side set at its birth)
        self.hands = [_Hand(k, "", HandTracker(rig, hand="right", detector=None, **options))
                      for k in range(n_hands)]  # fmt: skip
        self.frame_count = 0
        fit = self.hands[0].tracker.settings  # every hand's
        self._split = n_hands > 1 and (fit.keypoint_iou or fit.frame_fit.silhouette > 0)
        self._skin = None
        # rule 7: the last frames (images, greys) and, per hand found late, what to carry
        self._recent = None
        if back:
            from handvar.vision.carry import CARRY_SETTINGS

            self._recent = collections.deque(maxlen=CARRY_SETTINGS.max_frames)
        self._late: list[tuple] = []  # (hand id, frame, keypoints, greys, frames before)
        self._views: list[tuple] = []  # (hand id, frame, its frames in one view before)

    # -- one frame ----------------------------------------------------------------------

    def process(self, frames, *, detections=None) -> HandsResult:
        """Track the next frame.

        Parameters
        ----------
        frames : (H, W, 3) uint8 ndarray or list of them
            The BGR colour frame of every camera.
        detections : list of list of Detection, keyword-only, optional
            Per camera the hands found in this frame (pixels of the frames given),
            instead of the tracker's detector; with ``keypoint_every`` > 1, None on a
            frame the detector skipped (given ones are used on any frame: a real-time
            run may drop the detector's frames).

        Returns
        -------
        HandsResult
        """
        from handvar.tracking.hand_tracker import _images

        t0 = time.perf_counter()
        n = 1 if self.rig is None else len(self.rig)
        images = _images(frames, n)
        if detections is None and self.detectors and self.frame_count % self.every == 0:
            detections = [d(image, frame=self.frame_count)
                          for d, image in zip(self.detectors, images, strict=True)]  # fmt: skip
        ran = detections is not None  # the detector's frame
        if not ran:
            if self.every == 1:
                raise ValueError(
                    "detections: expected the hands found per camera with detector none; got None"
                )
            detections = [[] for _ in images]
        if len(detections) != n:
            raise ValueError(
                f"detections: expected one list per camera ({n}); got {len(detections)}"
            )
        if self.rig is None:  # one assumed camera of the first frame's size, for every hand
            from handvar.camera import Rig
            from handvar.vision.sources import SOURCE_SETTINGS, assumed_camera

            height, width = images[0].shape[:2]
            fov = self.hands[0].tracker.fov or SOURCE_SETTINGS.fov
            self.rig = Rig([assumed_camera((width, height), fov=fov)])
            for h in self.hands:
                h.tracker.rig = self.rig
        if ran and self.look is not None:
            detections = self._look_again(images, detections)
        given = self._given(detections) if ran else {}
        greys = [cv2.cvtColor(np.ascontiguousarray(i), cv2.COLOR_BGR2GRAY) for i in images]
        shares = (
            self._shares(images, self.frame_count, self._expected_now()) if self._split else None
        )
        results = []
        for h in self.hands:
            kps, world = given.get(h.id, ([None] * n, None))
            if ran:
                h.undetected = 0 if any(k is not None for k in kps) else h.undetected + 1
            h.count(self.frame_count, ran)
            carried = self._carry(h, greys, kps)
            for j, carrier in enumerate(h.carriers):  # the flow would follow the hand in front
                if kps[j] is None and carrier.age > BEHIND_CARRY and self._behind(h, j):
                    carried[j] = None
            _one_view(h, kps, carried)
            followed = [c if k is None else None for c, k in zip(carried, kps, strict=True)]
            self._down_weighted(h, followed)  # rule 5 on them too, in place
            results.append(self._fit(h, images, carried, world, shares))
        self._note_late(results, images, greys)
        for h, r in zip(self.hands, results, strict=True):
            if not r.no_hand and not r.hidden:
                h.before, h.last, h.missing = h.last, _skeleton(h, r), 0
            elif not r.no_hand:  # carried: its place moves on, it stays expected
                h.before, h.last = h.last, _skeleton(h, r)
                h.missing += 1
            else:
                h.missing += 1
        index, self.frame_count = self.frame_count, self.frame_count + 1
        return HandsResult(index, tuple(results), time.perf_counter() - t0)

    def _look_again(self, images, detections) -> list:
        """Rule 6: per camera, a tracked hand in the open that no detection lies near
        (within its gate) looked for again in a box around where it is expected; what
        is found there, nearer it than the other hand, joins the camera's detections
        unless it is one of them found again, and with two cameras or more only if its
        rays meet those of the hand's detection in another camera."""
        out = []
        for j, found in enumerate(detections):
            found = list(found)
            for h in self.hands:
                places = h.places(j)
                if places is None or any(_distance(places, d.points) <= h.gate for d in found):
                    continue  # not tracked, or found
                if self._behind(h, j):
                    continue
                others = [o.places(j) for o in self.hands if o is not h and o.expected is not None]
                for d in self._look_around(images[j], places, j):
                    near = _distance(places, d.points)
                    if (
                        near <= h.gate
                        and all(_distance(o, d.points) > near for o in others)
                        and all(_distance(e.points[:, :2], d.points) >= DUPLICATE for e in found)
                        and (len(detections) == 1 or self._seen_elsewhere(h, d, j, detections))
                    ):
                        found.append(d)
            out.append(found)
        return out

    def _seen_elsewhere(self, h: _Hand, d, j: int, detections) -> bool:
        """Detection d of camera j meets, within `RAY_GAP`, the rays of a detection of
        another camera that lies within `h`'s gate there."""
        cameras = self.rig.cameras
        for k, found in enumerate(detections):
            for e in found if k != j else ():
                gap = ray_points(cameras[j], d.points, cameras[k], e.points)[1]
                if gap <= RAY_GAP and _distance(h.places(k), e.points) <= h.gate:
                    return True
        return False

    def _look_around(self, image, places, j: int) -> list:
        """The detector's hands in the box `LOOK_PAD` hand sizes around `places` (the
        points a hand is expected at in camera j), none where its centre is off the
        image."""
        p = places[np.isfinite(places).all(axis=-1)]
        if not len(p):
            return []
        low, high = p.min(axis=0), p.max(axis=0)
        centre = (low + high) / 2
        half = (high - low).max() / 2 + LOOK_PAD * _size(places[0])
        height, width = image.shape[:2]
        if not (0 <= centre[0] < width and 0 <= centre[1] < height):
            return []
        self.looks += 1
        return self.look[j](image, (*(centre - half), *(centre + half)))

    def _note_late(self, results, images, greys) -> None:
        """Rule 7: note each hand fitted to a detection after a frame without it, with
        the frames kept before this one, and each first fitted to two views after frames
        in one, with those frames; keep this frame (with ``back`` only)."""
        if self._recent is None:
            return
        for h, r in zip(self.hands, results, strict=True):
            frames = h.tracker.frames
            found = not r.no_hand and not r.hidden and r.keypoints is not None
            if found and self._recent and len(frames) > 1 and frames[-2].no_hand:
                self._late.append((h.id, r.index, r.keypoints, greys, list(self._recent)))
            if len(images) > 1 and h.settled < SETTLE_FRAMES:
                self._note_views(h, r, images, found)
        self._recent.append((images, greys))

    def _note_views(self, h: _Hand, r, images, found: bool) -> None:
        """Rule 7, two cameras or more: keep h's frames in one view before its first in
        two (at most `CarrySettings.max_frames`), and the next ones up to its
        `SETTLE_FRAMES`-th in two; then note them to be fitted again from that frame."""
        from handvar.vision.carry import CARRY_SETTINGS

        views = 0 if not found else sum(k is not None for k in r.keypoints)
        if views == 0:  # the run is broken: what was kept is not fitted again
            h.single = []
            if h.settled >= 0:
                h.settled = SETTLE_FRAMES
            return
        if h.settled < 0 and views > 1:  # its first frame in two views
            if not h.single:  # seen in two from the start: nothing to fit again
                h.settled = SETTLE_FRAMES
                return
            h.settled = 0
        if h.settled >= 0:
            h.settled += 1
            if h.settled == SETTLE_FRAMES:
                self._views.append((h.id, r.index, h.single))
                h.single = []
                return
        keep = CARRY_SETTINGS.max_frames - 1
        h.single = [*h.single[-keep:], (r.index, r.keypoints, images)]

    def back_fill(self) -> dict[int, dict[int, np.ndarray]]:
        """Rule 7 (module notes): each hand found late fitted, with its shape now, on
        the frames kept before that detection that it was not on, backwards from it;
        each first seen in two views, on its frames in one before, the same way; each
        track found on fewer than `CONFIRM_FOUND` of the detector's frames taken off.
        Replaces those frames in the hand's track (`HandTracker.recovered`); returns
        their poses (NaN where taken off), per frame index and hand id (none without
        ``back``).  Once, after the last frame."""
        from handvar.vision.carry import CARRY_SETTINGS, KeypointCarrier

        out, late, self._late = {}, self._late, []
        unfound = self._unconfirmed()
        for hid, t0, kps, greys0, before in late:
            h = self.hands[hid]
            # its side turned at the end (no model yet), or a track to be taken off
            if h.tracker.recovery is None or t0 in unfound.get(hid, ()):
                continue
            looked, found = h.finds(t0, t0 + CARRY_SETTINGS.max_frames)
            if found < BACK_SHARE * looked:  # the detector did not keep finding it
                continue
            other = next((o for o in self.hands if o is not h), None)
            carriers = [KeypointCarrier(CARRY_SETTINGS) for _ in greys0]
            for c, g, k in zip(carriers, greys0, kps, strict=True):
                c.step(g, k)
            recovery = _recovery_from(h, t0)
            for back, (images, greys) in enumerate(reversed(before), start=1):
                t = t0 - back  # the frames kept end with the one before t0
                if not h.tracker.frames[t].no_hand:
                    break
                carried = []
                for c, g in zip(carriers, greys, strict=True):
                    k = c.step(g)
                    carried.append(k if k is not None and c.followed >= BACK_POINTS else None)
                if all(k is None for k in carried) or self._on_fit(other, t, carried):
                    break
                shares = self._refit_shares(h, recovery, t, images)
                if not _refit(h, recovery, t, images, carried, out, shares):
                    break
        self._refit_views(out)
        self._take_off(unfound, out)
        return out

    def _take_off(self, unfound: dict, out: dict) -> None:
        """Rule 7: the frames `_unconfirmed` gives made frames without the hand, their
        NaN poses added to `out` (frame → hand id → pose)."""
        from handvar.tracking.recovery import _Frame

        for hid, frames in unfound.items():
            for t in frames:
                self.hands[hid].tracker.frames[t] = _Frame.without_hand()
                out.setdefault(t, {})[hid] = self.hands[hid].tracker.frames[t].pose

    def _unconfirmed(self) -> dict[int, set[int]]:
        """Rule 7: per hand, the frames drawn by its tracks the detector found on fewer
        than `CONFIRM_FOUND` of its frames (a track's frames run to the next one's
        first), before any is carried back; none without ``back``."""
        out = {}
        if self._recent is None:
            return out
        for h in self.hands:
            frames = h.tracker.frames
            for first in h.firsts:
                if h.finds(first, len(frames))[1] < CONFIRM_FOUND:
                    end = h.track_end(first, len(frames))
                    drawn = {t for t in range(first, end) if not frames[t].no_hand}
                    out.setdefault(h.id, set()).update(drawn)
        return out

    def _refit_views(self, out: dict) -> None:
        """Rule 7, two cameras or more: each hand's frames in one view before it was
        first fitted to two, fitted again backwards from there with its shape now;
        their poses added to `out` (frame → hand id → pose)."""
        views, self._views = self._views, []
        for hid, t1, run in views:
            h = self.hands[hid]
            if h.tracker.recovery is None:  # its side turned at the end: no model yet
                continue
            recovery = _recovery_from(h, t1)
            for t, kps, images in reversed(run):
                shares = self._refit_shares(h, recovery, t, images)
                if h.tracker.frames[t].no_hand or not _refit(h, recovery, t, images, kps, out,
                                                             shares):  # fmt: skip
                    break

    def _on_fit(self, other: _Hand | None, t: int, kps: list) -> bool:
        """Rule 7: points `kps` per camera lie on `other`'s fit of frame t (within
        `DUPLICATE` hand sizes in some camera)."""
        if other is None or other.tracker.hand is None:
            return False
        pose = other.tracker.frames[t].pose
        if not np.isfinite(pose).all():
            return False
        joints = other.tracker.hand.joints(pose)
        return any(k is not None and _distance(cam.project(joints), k) < DUPLICATE
                   for cam, k in zip(self.rig.cameras, kps, strict=True))  # fmt: skip

    def _given(self, detections) -> dict[int, tuple]:
        """Per hand id, its keypoints per camera and the first camera's world points."""
        n = len(detections)
        given: dict[int, list] = {h.id: [None] * n for h in self.hands}
        for j, found in enumerate(detections):
            expected = [h.places(j) for h in self.hands]
            pairs = assign(expected, [h.side for h in self.hands], found,
                           [h.gate for h in self.hands])  # fmt: skip
            pairs = _found_once(pairs, expected, found)
            _labelled_back(pairs, expected, [h.side for h in self.hands], found)
            for hand, k in pairs.items():
                given[self.hands[hand].id][j] = found[k]
        self._agree(given)
        self._complete(given, detections)
        self._born(given, detections)
        out = {}
        for h in self.hands:
            first = given[h.id][0]
            self._vote(h, first)
            kps = [None if d is None else d.points.copy() for d in given[h.id]]
            out[h.id] = (self._down_weighted(h, kps), None if first is None else first.world)
        return out

    def _agree(self, given) -> None:
        """Rule 2, two cameras or more: two hands' views given to one hand are parted
        (it keeps the view nearer where it is expected, the other goes to the other
        hand if it fits there); one hand's views given to two hands go to the one whose
        last joints lie nearer the points the views triangulate (module notes); the
        other keeps neither."""
        cameras = self.rig.cameras
        for j in range(1, len(cameras)):
            for h in self.hands:
                d0, dj = given[h.id][0], given[h.id][j]
                if d0 is None or dj is None or h.expected is None:
                    continue
                if ray_points(cameras[0], d0.points, cameras[j], dj.points)[1] <= RAY_GAP:
                    continue  # one hand
                far = max((0, j), key=lambda i: _distance(h.places(i), given[h.id][i].points))
                self._give_other(h, given, far)
            for a, b in itertools.permutations(self.hands, 2):
                d0, dj = given[a.id][0], given[b.id][j]
                if d0 is None or dj is None or given[a.id][j] is not None \
                        or given[b.id][0] is not None:  # fmt: skip
                    continue
                points, gap = ray_points(cameras[0], d0.points, cameras[j], dj.points)
                if gap > RAY_GAP:
                    continue  # two hands
                keep = min((a, b), key=lambda h: h.distance(points))
                if keep.distance(points) > SAME_HAND * keep.palm():
                    continue  # two hands whose rays happen to meet (a ghost)
                given[keep.id][0], given[keep.id][j] = d0, dj
                lose = b if keep is a else a
                given[lose.id][0] = given[lose.id][j] = None

    def _give_other(self, h: _Hand, given, i: int) -> None:
        """Camera i's view taken from `h` (not its hand: `_agree`) and given to the other
        hand if it has none there and the view is its: its rays meet that hand's view in
        another camera within `RAY_GAP`, or, without any view, it lies within the
        hand's gate of where it is expected."""
        d, given[h.id][i] = given[h.id][i], None
        cameras = self.rig.cameras
        for other in self.hands:
            views = given[other.id]
            if other is h or views[i] is not None:
                continue
            seen = [k for k, v in enumerate(views) if v is not None]
            if seen:
                k = seen[0]
                mine = ray_points(cameras[i], d.points, cameras[k], views[k].points)[1] <= RAY_GAP
            else:
                mine = (
                    other.expected is not None
                    and _distance(other.places(i), d.points) <= other.gate
                )
            if mine:
                views[i] = d
                return

    def _born(self, given, detections) -> None:
        """Start the free hands on the detections left over, the first camera's first."""
        for j, found in enumerate(detections):
            rest = [d for d in found if d not in _given_values(given, j)]
            for d in sorted(rest, key=lambda d: -np.count_nonzero(d.points[:, 2] > 0)):
                if not self._new_hand(d, j, given):
                    continue
                free = [h for h in self.hands if not _has_view(given, h)
                        and (h.expected is None or self._on_other(h, given))]  # fmt: skip
                if not free:
                    return
                placed = [h for h in self.hands if h not in free  # tracked, or found now
                          and (h.expected is not None or _has_view(given, h))]  # fmt: skip
                others = [h.side for h in placed if h.side]
                side = other_side(others[0]) if others else (d.side or "right")
                hand = next((h for h in free if h.side == side), free[0])
                if hand.side != side:
                    self._set_side(hand, side)
                hand.begin(self.frame_count)  # a new track
                other = next((h for h in self.hands if h is not hand), None)
                if other is not None and not other.side:
                    other.side = other_side(side)
                    other.tracker.side = other.side
                hand.votes = []
                given[hand.id][j] = d
                self._match_cameras(hand, given, detections, j)

    def _new_hand(self, d, j: int, given) -> bool:
        """Detection d of camera j left over is a new hand's (rule 3): not the same hand
        found twice, nor a tracked hand's off by more than its gate."""
        for h in self.hands:
            g = given[h.id][j]
            if g is not None and _distance(g.points[:, :2], d.points) < (
                NEW_HAND if d.side and d.side == h.side else DUPLICATE
            ):
                return False  # the same hand found twice (labelled as it: farther apart)
            if (h.expected is not None and g is None and not self._on_other(h, given)
                    and not self._comes_back(h, d, given)
                    and _distance(h.places(j), d.points) < NEW_HAND):  # fmt: skip
                return False  # a tracked hand's detection off by more than the gate
        return True

    def _comes_back(self, h: _Hand, d, given) -> bool:
        """Detection d is labelled, `SIDE_SURE` sure or more, the side of another hand
        than `h`, one that is free (expected nowhere and given no detection): that
        hand coming back, not `h`'s detection off by a gross error."""
        if not d.side or d.side == h.side or d.score < SIDE_SURE:
            return False
        return any(o is not h and o.side == d.side and o.expected is None
                   and not _has_view(given, o) for o in self.hands)  # fmt: skip

    def _on_other(self, h: _Hand, given) -> bool:
        """`h`, given no view, is expected on the other hand's detections (within
        `DUPLICATE`) in two cameras or more: followed onto it, not hidden behind it
        (which one camera alone cannot tell)."""
        if h.expected is None or _has_view(given, h):
            return False
        for other in self.hands:
            views = [(j, v) for j, v in enumerate(given[other.id]) if v is not None]
            if (
                other is not h
                and len(views) >= 2
                and all(_distance(h.places(j), v.points) < DUPLICATE for j, v in views)
            ):
                return True
        return False

    def _complete(self, given, detections) -> None:
        """Rule 2, two cameras or more: a hand given a view in some camera and none in
        another gets the detection left over there whose rays meet its view's."""
        for h in self.hands:
            j = next((j for j, v in enumerate(given[h.id]) if v is not None), None)
            if j is not None:
                self._match_cameras(h, given, detections, j)

    def _match_cameras(self, hand: _Hand, given, detections, j: int = 0) -> None:
        """A hand's detections in the other cameras than j where it has none: the one
        left over whose rays meet its camera j's (`RAY_GAP`), the nearest; the palm
        they make not bounded below where no other hand's view is left over
        (`_alone`)."""
        cameras, d = self.rig.cameras, given[hand.id][j]
        for k in range(len(detections)):
            if k == j or given[hand.id][k] is not None:
                continue
            rest = [e for e in detections[k] if e not in _given_values(given, k)]
            alone = len(rest) == 1 and self._alone(hand, given, detections[j], j, k)
            palm = (ALONE_PALM, PALM_MM[1]) if alone else PALM_MM
            gaps = [ray_points(cameras[j], d.points, cameras[k], e.points, palm)[1]
                    for e in rest]  # fmt: skip
            near = [e for e, g in zip(rest, gaps, strict=True) if g <= RAY_GAP]
            if near:
                given[hand.id][k] = min(near, key=lambda e: gaps[rest.index(e)])

    def _alone(self, hand: _Hand, given, found_j: list, j: int, k: int) -> bool:
        """Rule 2, for the one detection left over in camera k: camera j's detections
        (`found_j`) are all given and the other hand (tracking two) has been given its
        view in k, so that detection is no other hand's view and the palm the views make
        is bounded below by `ALONE_PALM`, not `PALM_MM` (which keeps two hands' views
        whose rays meet by chance apart).  Tracking one hand, a second one may be in
        view, untracked."""
        if len(self.hands) < 2 or any(o is not hand and given[o.id][k] is None
                                      for o in self.hands):  # fmt: skip
            return False
        taken = _given_values(given, j)
        return all(e in taken for e in found_j)

    def _carry(self, h: _Hand, greys, kps: list) -> list:
        """Per camera, the hand's last detection carried forward by optical flow
        (`handvar.vision.carry.KeypointCarrier`) where it has none: through a
        detector's miss for `MISSED_CARRY` frames, the points the flow loses dropped,
        while the hand is `_Hand.followed` (rule 6); with a slower detector, held up to
        its next frame."""
        from handvar.vision.carry import CARRY_SETTINGS, KeypointCarrier

        if h.carriers is None:
            # with a slower detector, held as one hand's up to the detector's next frame
            held = {"hold": 0.0} if self.every == 1 else {"hold_frames": self.every - 1}
            settings = dataclasses.replace(CARRY_SETTINGS, max_frames=MISSED_CARRY, **held)
            h.carriers = [KeypointCarrier(settings) for _ in greys]
        carried = [c.step(grey, k) for c, grey, k in zip(h.carriers, greys, kps, strict=True)]
        if h.undetected and not h.followed:  # a detector's false hand, found now and then
            return [None] * len(carried)
        return carried

    def _vote(self, h: _Hand, d) -> None:
        """Rule 4: a hand's side turned by overwhelming labels (module notes)."""
        if d is None or not d.side:
            return
        sure_against = d.side != h.side and d.score >= SIDE_SURE
        h.against = h.against + 1 if sure_against else 0
        if h.against >= SIDE_RUN:
            self._turn_sides()
            return
        if h.votes is None:
            return
        h.votes.append(d.score if d.side == h.side else -d.score)
        if len(h.votes) < math.ceil(SIDE_FRAMES / self.every):  # SIDE_FRAMES frames' labels
            return
        against = -sum(v for v in h.votes if v < 0) / sum(abs(v) for v in h.votes)
        h.votes = None  # decided
        if against >= SIDE_SWAP:
            self._turn_sides()

    def _turn_sides(self) -> None:
        """Both hands' sides turned, the two staying opposite; the sides decided."""
        for other in self.hands:
            other.against, other.votes = 0, None
            if other.side:
                self._set_side(other, other_side(other.side))

    def _set_side(self, h: _Hand, side: str) -> None:
        """The hand's side set; its model is built again on it at its next frame with
        a hand (where it is expected stays as it was)."""
        h.side = side
        h.tracker.side = side
        h.tracker.recovery = None

    def _down_weighted(self, h: _Hand, kps: list) -> list:
        """Rule 5: its keypoints inside the outline of the hand in front, down-weighted."""
        for other in self.hands:
            if other is h or other.expected is None or h.last is None:
                continue
            for j, k in enumerate(kps):
                if k is None or not _in_front(other, h, self.rig.cameras[j]):
                    continue
                inside = _inside(other.expected[j], k[:, :2])
                k[inside, 2] *= HIDDEN_WEIGHT
        return kps

    def _fit(self, h: _Hand, images, kps, world, shares=None):
        """The hand's frame: fitted to its keypoints, carried hidden, or without it;
        `shares`: the frame's skin shared between the hands (`_shares`), or None."""
        tracker = h.tracker
        present = any(k is not None for k in kps)
        if not present and self._hidden(h):
            h.hidden += 1
            r = tracker.carried()
        else:
            if present:
                h.hidden = 0
            mine = None if shares is None else (lambda: shares()[h.id])
            r = tracker.process(images, keypoints=kps, world=world, silhouettes=mine)
        return dataclasses.replace(r, id=h.id, side=h.side)

    def _shares(self, images, index: int, expected: dict):
        """Rule 5: a callable giving, once asked, each hand's silhouettes (hand id →
        (n_cameras, H, W)) in frame `index` of `images`: per camera `split_silhouette`
        of the skin components where the hands are expected, between their models at
        the poses `expected` gives (hand id → (model, pose), where expected), front to
        back by the poses' depths; each hand's share with those of the hands in front
        of it, where its hidden parts may lie."""
        from handvar.render import silhouettes
        from handvar.vision.silhouette import split_silhouette
        from handvar.vision.skin import SkinModel
        from handvar.vision.sources import frame_silhouettes

        @functools.cache
        def shares() -> dict[int, np.ndarray]:
            if self._skin is None:
                self._skin = SkinModel()
            drawn = {k: silhouettes(model, pose, self.rig) for k, (model, pose) in expected.items()}
            near = np.any(list(drawn.values()), axis=0) if drawn else None
            skin = frame_silhouettes(images, self._skin, index=index, names=self.rig.names,
                                     wrist=False, allow_empty=True, near=near,
                                     cleanup={"keep": len(self.hands)})  # fmt: skip
            out = {h.id: np.zeros_like(skin) for h in self.hands}
            joints = {k: model.joints(pose) for k, (model, pose) in expected.items()}
            for j, camera in enumerate(self.rig.cameras):
                depth = {k: camera.camera_from_world(g)[:, 2].mean() for k, g in joints.items()}
                order = sorted(out, key=lambda k: (k not in depth, depth.get(k, 0.0)))
                split = split_silhouette(skin[j], [drawn[k][j] if k in drawn else None
                                                   for k in order])  # fmt: skip
                front = np.zeros_like(skin[j])  # the shares of the hands in front
                for k, share in zip(order, split, strict=True):
                    front |= share
                    out[k][j] = front.copy() if k in drawn else share
            return out

        return shares

    def _expected_now(self) -> dict:
        """Rule 5: per hand expected at the frame to come, its model and the pose its
        predictor expects there (`_shares`), before any hand is fitted to it."""
        out = {}
        for h in self.hands:
            recovery = h.tracker.recovery
            if h.expected is not None and recovery is not None and recovery.previous is not None:
                out[h.id] = (recovery.hand, recovery.tracker.prediction())
        return out

    def _refit_shares(self, h: _Hand, recovery, t: int, images):
        """Rule 5 for rule 7: the skin of frame t shared between `h`, at the pose
        `recovery` expects, and the other hands where their tracks put them; None
        without the split."""
        if not self._split:
            return None
        expected = {h.id: (recovery.hand, recovery.tracker.prediction())}
        for other in self.hands:
            pose = other.tracker.frames[t].pose if other is not h else None
            if pose is not None and np.isfinite(pose).all() and other.tracker.hand is not None:
                expected[other.id] = (other.tracker.hand, pose)
        return self._shares(images, t, expected)

    def _behind(self, h: _Hand, j: int) -> bool:
        """Rule 6: in camera j, a hand in front of `h` (rule 5) overlaps it by
        `BEHIND_SHARE` of its expected points (or `h` is expected nowhere)."""
        if h.expected is None or h.last is None:
            return True
        camera = self.rig.cameras[j]
        for other in self.hands:
            if other is h or other.expected is None or not _in_front(other, h, camera):
                continue
            if _inside(other.expected[j], h.expected[j]).mean() >= BEHIND_SHARE:
                return True
        return False

    def _hidden(self, h: _Hand) -> bool:
        """A hand fitted until a frame ago, carried since, given no detection: carried on
        behind the nearer hand (up to `HIDDEN_FRAMES`) or through a detector's miss in
        the open (up to `MISSED_FRAMES`) (rule 5)."""
        if h.expected is None or h.tracker.recovery is None or h.missing != h.hidden:
            return False
        if h.hidden < MISSED_FRAMES:
            return True
        if h.hidden >= HIDDEN_FRAMES:
            return False
        for other in self.hands:  # in front of it, or touching it (no depth asked)
            if other is h or other.last is None or other.missing:
                continue
            if _inside(other.expected[0], h.expected[0]).mean() >= BEHIND_SHARE:
                return True
        return False

    # -- tracks -------------------------------------------------------------------------

    def close(self) -> None:
        """Release the detectors (one serving every camera is closed more than once:
        closing is idempotent)."""
        for d in (*(self.detectors or ()), *(self.look or ())):
            if hasattr(d, "close"):
                d.close()

    def __enter__(self) -> HandsTracker:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _in_front(other: _Hand, h: _Hand, camera) -> bool:
    """`other`'s last joints nearer `camera` than `h`'s by `FRONT` mm or more (rule 5)."""
    return other.depth(camera) <= h.depth(camera) - FRONT


def _has_view(given: dict, h: _Hand) -> bool:
    """`h` was given a detection in some camera."""
    return any(v is not None for v in given[h.id])


def _given_values(given: dict, j: int) -> list:
    """The detections of camera `j` already given to a hand."""
    return [g[j] for g in given.values() if g[j] is not None]


def _found_once(pairs: dict[int, int], expected: list, found: list) -> dict[int, int]:
    """Rule 2: of two detections given to two hands in one camera that lie within
    `DUPLICATE` hand sizes of each other (one hand found twice), only the one nearer
    where its hand is expected is kept."""
    if len(pairs) < 2:
        return pairs
    (a, i), (b, k) = list(pairs.items())[:2]
    if _distance(found[i].points[:, :2], found[k].points) >= DUPLICATE:
        return pairs
    far = max((a, i), (b, k), key=lambda p: _distance(expected[p[0]], found[p[1]].points))
    return {h: d for h, d in pairs.items() if h != far[0]}


def _labelled_back(pairs: dict[int, int], expected: list, sides: list, found: list) -> None:
    """Rule 2, in place: each hand expected and given no detection takes the nearest
    left over within `NEW_HAND` hand sizes labelled at least `SIDE_SURE` sure its side,
    unless it lies within `DUPLICATE` of a detection given (that hand found twice)."""
    for h, e in enumerate(expected):
        if h in pairs or e is None:
            continue
        given = [found[k].points[:, :2] for k in pairs.values()]
        sure = [k for k, d in enumerate(found) if k not in pairs.values()
                and d.side == sides[h] and d.score >= SIDE_SURE
                and all(_distance(g, d.points) >= DUPLICATE for g in given)]  # fmt: skip
        near = {k: _distance(e, found[k].points) for k in sure}
        k = min(near, key=near.get, default=None)
        if k is not None and near[k] < NEW_HAND:
            pairs[h] = k


def _skeleton(h: _Hand, r):
    """`r` with its joints and their projections at the skeleton's joints G(x), as the
    rules see a hand's last fit: their bounds were chosen so on the two-hand benchmark
    (the result handed out reports the points where a detector marks them; with those
    the rules took another hand's identity on `occlude` with MediaPipe)."""
    joints = h.tracker.hand.joints(r.pose)
    projected = np.stack([cam.project(joints) for cam in h.tracker.rig.cameras])
    return dataclasses.replace(r, joints=joints, projected=projected)


def _one_view(h: _Hand, kps: list, carried: list) -> None:
    """Rule 6, two cameras or more, in place: a hand given no detection and carried by
    the flow in one camera only is not fitted to fewer than `ONE_VIEW_POINTS` points
    followed there (so few points in one view tell no depth); followed by that many in
    one camera only and missed by the detector (not between its frames), it is held in
    the others at its last fit's points, with confidence `HELD_VIEW`: fitted to one view
    alone, it drifted along that camera's rays, off the hand in the others."""
    if len(carried) < 2 or any(k is not None for k in kps):
        return
    views = [j for j, c in enumerate(carried) if c is not None]
    enough = [j for j in views if h.carriers[j].followed >= ONE_VIEW_POINTS]
    if len(views) == 1 and not enough:
        carried[views[0]] = None
    elif len(enough) == 1 and h.last is not None and h.undetected:
        for j in range(len(carried)):
            if j != enough[0]:
                carried[j] = np.c_[h.last.projected[j], np.full(21, HELD_VIEW)]


def _recovery_from(h: _Hand, t: int):
    """Rule 7: a recovery for `h` with its shape now, started at its pose of frame t."""
    held = dataclasses.replace(h.tracker.settings, shape=None)  # its shape as now
    recovery = h.tracker.recovery_for(h.tracker.hand, held)
    recovery.start(h.tracker.frames[t].pose)
    return recovery


def _refit(h: _Hand, recovery, t: int, images, kps: list, out: dict, shares=None) -> bool:
    """Rule 7: frame t of `h` fitted again by `recovery` to `kps` (per camera) and put in
    its track and in `out` (frame → hand id → pose); False, and nothing put, where the
    fit finds no hand or is lost.  `shares`: frame t's skin shared (`_refit_shares`)."""
    from handvar.tracking.recovery import _frame_quality

    mine = None if shares is None else (lambda: shares()[h.id])
    f, seconds = recovery.step(h.tracker.masks(images, mine), kps, None, with_keypoints=True)
    if f.no_hand or _frame_quality(f.result, f.empty).lost:
        return False
    h.tracker.frames[t], h.tracker.seconds[t] = f, h.tracker.seconds[t] + seconds
    out.setdefault(t, {})[h.id] = f.pose
    return True
