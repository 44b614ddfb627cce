"""2D hand keypoints per camera: the 21 points of `G(x)` seen in the images (design §14.1).

A keypoint detector (e.g. MediaPipe Hands, `handvar.vision.mediapipe`) gives, per frame,
the image positions of the 21 points of the hand model's `G(x)`, in its order
(`KEYPOINT_NAMES`, the order of MediaPipe Hands and of the common 21-keypoint layout):
0 wrist; thumb CMC, MCP, IP, tip; then index, middle, ring and little finger MCP, PIP,
DIP, tip.  Silhouettes cannot see what lies inside them (a fist, a hand edge-on, the
wrist on a forearm); keypoints can.

Conventions
-----------
- Pixels ``(x, y)`` = (column, row) of the **full-resolution** frame, pixel centres at
  integers (as `handvar.camera.Camera` projects).  `Keypoints2D.scaled` maps them into
  frames resized by ``--scale``.
- A confidence in [0, 1] per point (1 when the file has none).
- Missing: a whole frame or single points are NaN in the file.  In a `Keypoints2D` a
  missing point has ``xy = NaN`` and ``confidence = 0``.

Files
-----
- ``.npy``: a float array of shape (T, 21, 2) or (T, 21, 3) (x, y[, confidence]).
- ``.csv``: one row per frame (blank lines are skipped), 42 columns
  ``x0, y0, x1, y1, …, x20, y20`` or 63 columns ``x0, y0, c0, x1, y1, c1, …``; an
  optional header row (any first row with a cell that is not a number); empty cells
  and ``nan`` are missing.  `write_keypoints` writes 63 columns with the header
  ``x0,y0,c0,…``.
- ``.npz``: ``keypoints`` (T, 21, 2|3) as the ``.npy``, and what a detector may know
  besides, each optional: ``world`` (T, 21, 3) its metric 3D points, mm, in axes of
  the camera (x right, y down, z away from it), any origin (MediaPipe's world
  landmarks are hand-centred); ``depth`` (T, 21) each point's depth relative to the
  wrist, in the detector's units (MediaPipe's landmark z, about the image width);
  ``presence`` (T,) the probability that a hand is there; ``handedness`` (T,) the side
  of the hand seen, ``"right"``, ``"left"`` or ``""`` (unknown), as the image shows it
  (MediaPipe's label, which assumes a mirrored image, is turned into that by the
  adapter, `handvar.vision.mediapipe`); ``handedness_score`` (T,) the probability that
  the handedness is right.  NaN (or ``""``) where missing.  With a handedness score the
  points' confidences are the detector's own, not yet weighted by the side: a reader
  weighs them once the side tracked is known (`Keypoints2D.for_side`, which
  `check_keypoints` applies), as the detector inside the pipeline weighs its
  detections (`choose`).  The ``.npy``
  and ``.csv`` formats hold only the first part, and files without the rest read
  as before.  World points in metres (MediaPipe's own unit) are recognised by the hand's
  size (`world_in_mm`): read in mm with a `KeypointUnitWarning`; a size that is a hand's
  in neither unit is refused.
- ``.json``, every hand found (two hands, `read_detections`): a list with one entry
  per frame, each a list of the hands found there (any order, empty for none), each
  ``{"points": 21 × [x, y, confidence] (null where missing), "side": "right", "left"
  or "", "score": the probability that the side is right}`` and optionally
  ``"world": 21 × [x, y, z]``, mm, as the ``.npz``'s.  `write_detections` writes it.

Examples
--------
>>> import numpy as np
>>> kp = Keypoints2D.from_array(np.zeros((4, 21, 2)))
>>> kp.n_frames, kp.confidence[0, 0]
(4, np.float64(1.0))
>>> kp.every(2).present.any(axis=1).tolist()
[True, False, True, False]
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
import warnings
import zipfile
import zlib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handvar.atomic import write_atomic
from handvar.hand.anthropometry import HandLandmark
from handvar.validate import as_array, as_float, as_int, one_of

__all__ = [
    "KEYPOINT_NAMES",
    "MCP",
    "N_KEYPOINTS",
    "PALM",
    "PALM_LENGTH_MM",
    "PALM_MM",
    "RAY_GAP",
    "SIDE_FRAMES",
    "Detection",
    "KeypointUnitWarning",
    "Keypoints2D",
    "as_frame_keypoints",
    "check_detections",
    "check_keypoints",
    "check_output_suffix",
    "chirality",
    "choose",
    "decide_side",
    "found_chirality",
    "hand_side",
    "ray_points",
    "read_detections",
    "read_keypoints",
    "scaled_pixels",
    "shape_side",
    "two_view_chirality",
    "vote_side",
    "world_in_camera",
    "world_in_mm",
    "write_detections",
    "write_keypoints",
]

#: The 21 points, in the order of `G(x)` (and of MediaPipe Hands).
KEYPOINT_NAMES: tuple[str, ...] = (
    "wrist",
    *(
        f"{digit}_{joint}"
        for digit, joints in (
            ("thumb", ("cmc", "mcp", "ip", "tip")),
            ("index", ("mcp", "pip", "dip", "tip")),
            ("middle", ("mcp", "pip", "dip", "tip")),
            ("ring", ("mcp", "pip", "dip", "tip")),
            ("little", ("mcp", "pip", "dip", "tip")),
        )
        for joint in joints
    ),
)
N_KEYPOINTS = len(KEYPOINT_NAMES)
#: Indices of the four finger MCPs (index, middle, ring, little).
MCP: tuple[int, ...] = (
    HandLandmark.INDEX_FINGER_MCP, HandLandmark.MIDDLE_FINGER_MCP,
    HandLandmark.RING_FINGER_MCP, HandLandmark.PINKY_MCP,
)  # fmt: skip
#: The palm: the wrist and the four finger MCPs (rigid in the hand model).
PALM: tuple[int, ...] = (HandLandmark.WRIST, *MCP)
#: The range (mm) of a hand's wrist → middle-MCP distance that world points must show:
#: the hand model's is 22 to 178 mm at the hand lengths the commands take (--hand-length
#: 50 to 400 mm); real adult hands measure about 60 to 110 mm, MediaPipe's world points
#: of the shipped clips 101 and 105 mm (median). The same range in metres is MediaPipe's
#: own unit (`world_in_mm`).
PALM_LENGTH_MM = (20.0, 200.0)


class KeypointUnitWarning(UserWarning):
    """A keypoint file's world points were read in another unit and converted to mm."""


@dataclass(frozen=True, eq=False)
class Detection:
    """One hand found in one frame.

    Attributes
    ----------
    points : (21, 3) ndarray
        x, y (pixels of the frame, centres at integers) and confidence in [0, 1];
        NaN, NaN, 0 where a point was not found.
    world : (21, 3) ndarray or None
        The detector's metric 3D of the points, mm, any origin, as a view along the ray
        through the palm sees them (MediaPipe's world landmarks;
        `handvar.camera.Camera.ray_rotation`).
    side : str
        "right", "left", or "" when the detector does not say.
    score : float
        The probability that `side` is right (the detector's handedness score); 1
        without a side.
    """

    points: np.ndarray
    world: np.ndarray | None = None
    side: str = ""
    score: float = 1.0

    def __post_init__(self) -> None:
        p = np.array(self.points, dtype=float)
        if p.shape != (N_KEYPOINTS, 3):
            raise ValueError(f"points: expected shape (21, 3); got {p.shape}")
        missing = np.isnan(p[:, :2]).any(axis=1) | ~(p[:, 2] > 0)
        p[missing] = (np.nan, np.nan, 0.0)
        object.__setattr__(self, "points", p)
        if self.side not in ("right", "left", ""):
            raise ValueError(f"side: expected right, left or empty; got {self.side!r}")


def choose(found: list[Detection], hand: str) -> tuple[np.ndarray | None, Detection | None]:
    """The hand tracked among `found`: its (21, 3) points and its detection.

    Of the hands found, the one most probably of side `hand` ("auto": the most
    confident of either side): probability ``score`` if its side is `hand`, ``1 −
    score`` if it is the other, ``score`` without a side.  Its points' confidences are
    multiplied by that probability, so a hand of doubtful side is kept but
    down-weighted (design §14.1).

    Returns
    -------
    points : (21, 3) ndarray or None
        None when nothing was found.
    detection : Detection or None
    """
    best, chosen = -1.0, None
    for d in found:
        p = d.score if hand in ("auto", d.side) or not d.side else 1.0 - d.score
        if p > best:
            best, chosen = p, d
    if chosen is None:
        return None, None
    points = chosen.points.copy()
    points[:, 2] *= best
    return points, chosen


def chirality(points) -> float:
    """Which hand 21 points in 3D are, by their shape: > 0 a right hand, < 0 a left.

    With n = (index MCP − little MCP) × (middle MCP − wrist), the normal of the palm
    that points to its inner side on a right hand and to its back on a left, the score
    is how far the thumb's tip lies from its MCP along n, plus how far the fingers'
    further joints lie from their MCPs along it on average, in palm lengths (wrist →
    middle MCP): a thumb and fingers bent towards the palm, as hands hold them, lie on
    the inner side.  A hand and its mirror image score opposite.  NaN where a point it
    needs is missing.

    Parameters
    ----------
    points : (21, 3) array_like
        The points in the order of `KEYPOINT_NAMES` (any metric frame).

    Examples
    --------
    >>> from handvar.hand.anthropometry import HandShape
    >>> from handvar.hand.kinematics import HandModel, named_pose
    >>> from handvar.tracking.keypoint_cost import keypoint_points
    >>> right = keypoint_points(HandModel(HandShape.from_size(185.0)), named_pose("fist"), "pad")
    >>> bool(chirality(right) > 0), bool(chirality(right * [-1.0, 1.0, 1.0]) < 0)
    (True, True)
    """
    P = as_array(points, "points", (N_KEYPOINTS, 3), finite=False)
    L = HandLandmark
    n = np.cross(P[L.INDEX_FINGER_MCP] - P[L.PINKY_MCP], P[L.MIDDLE_FINGER_MCP] - P[L.WRIST])
    length = np.linalg.norm(P[L.MIDDLE_FINGER_MCP] - P[L.WRIST])
    n = n / (np.linalg.norm(n) * length)
    thumb = (P[L.THUMB_TIP] - P[L.THUMB_MCP]) @ n
    fingers = np.mean([(P[m + k] - P[m]) @ n for m in MCP for k in (1, 2, 3)])
    return float(thumb + fingers)


#: mm: two cameras' points are one hand's where the median distance between their rays
#: is within this (`ray_points`).
RAY_GAP = 20.0
#: mm: the wrist → middle-MCP length a hand's points seen by two cameras may make.
PALM_MM = (50.0, 130.0)


def ray_points(camera_a, points_a: np.ndarray, camera_b, points_b: np.ndarray,
               palm: tuple[float, float] = PALM_MM):  # fmt: skip
    """The hand two cameras see, from their (21, 3) points (pixels, confidence): per
    point the middle of the closest approach of its two rays, (21, 3) mm (NaN where a
    camera lacks it), and the median distance between the rays (mm): small when the
    points are one hand's (each point's two rays meet), inf when fewer than three points
    are seen in both or the points where the rays meet do not make a hand (wrist →
    middle MCP outside `palm`, mm: `PALM_MM`, as two hands at one height in a
    side-by-side rig would pair)."""
    mid = np.full((len(points_a), 3), np.nan)
    seen = (points_a[:, 2] > 0) & (points_b[:, 2] > 0)
    if seen.sum() < 3:
        return mid, np.inf
    oa, da = camera_a.rays(points_a[seen, :2])
    ob, db = camera_b.rays(points_b[seen, :2])
    w = oa - ob  # closest points oa + s da, ob + t db of each pair of rays
    a, b, c = (da * da).sum(1), (da * db).sum(1), (db * db).sum(1)
    d, e = (da * w).sum(1), (db * w).sum(1)
    den = np.maximum(a * c - b * b, 1e-12)
    pa = oa + ((b * e - c * d) / den)[:, None] * da
    pb = ob + ((a * e - b * d) / den)[:, None] * db
    mid[seen] = 0.5 * (pa + pb)
    wrist, mcp = HandLandmark.WRIST, HandLandmark.MIDDLE_FINGER_MCP
    length = np.linalg.norm(mid[mcp] - mid[wrist])  # NaN (no test) without both
    if length < palm[0] or length > palm[1]:
        return mid, np.inf
    return mid, float(np.median(np.linalg.norm(pa - pb, axis=1)))


def two_view_chirality(camera_a, points_a: np.ndarray, camera_b, points_b: np.ndarray) -> float:
    """The `chirality` of the hand two cameras see, from their (21, 3) points (pixels,
    confidence) triangulated by `ray_points`, where the rays meet within `RAY_GAP` (one
    hand, its points labelled alike); else NaN."""
    points, gap = ray_points(camera_a, points_a, camera_b, points_b)
    return chirality(points) if gap <= RAY_GAP else math.nan


def found_chirality(found, cameras, pixels=None) -> float:
    """The `two_view_chirality` of the hand the first two cameras found on a frame, each
    its most confident (`choose`); NaN with fewer.  `pixels(points, j)`: camera j's
    points in the pixels of `cameras` (default: as found)."""
    if len(found) < 2:
        return math.nan
    (a, _), (b, _) = choose(found[0], "auto"), choose(found[1], "auto")
    if a is None or b is None:
        return math.nan
    if pixels is not None:
        a, b = pixels(a, 0), pixels(b, 1)
    return two_view_chirality(cameras[0], a, cameras[1], b)


def _side_of(score: float) -> str | None:
    """The side a summed `chirality` gives: right where positive, left where negative,
    None at 0."""
    return None if score == 0.0 else ("right" if score > 0.0 else "left")


#: Frames with a detected hand whose handedness decides the side of a track with
#: ``hand`` "auto": a second at 30 fps.  On the realistic benchmark's renders the
#: majority of 10 gave the true side on 27 of 32 runs, of 20, 30 or 60 on 29
#: (docs/detector.md).
SIDE_FRAMES = 30


def vote_side(found_per_frame: Iterable[list[Detection]]) -> str | None:
    """The side of the hand by the handedness of the most confident hand of each frame,
    weighted by its score: "right", "left", or None without a side said."""
    votes = {"right": 0.0, "left": 0.0}
    for found in found_per_frame:
        _, d = choose(found, "auto")
        if d is not None and d.side:
            votes[d.side] += d.score
    return _winner(votes)


def decide_side(found_per_frame: Iterable[list[Detection]], shape: float) -> tuple[str, bool]:
    """The side of a hand found on frames, and whether its labels still weigh which
    hand a detection is.

    The side is that of the hand's 3D shape where `shape`, the sum of the frames'
    `two_view_chirality` (0 without two cameras), is not 0; else of the handedness
    (`vote_side`; right where none is said).  The labels weigh the detections unless
    the shape overrules them (`choose` then keeps the most confident hand).
    """
    by_shape = _side_of(shape)
    by_label = vote_side(found_per_frame)
    return by_shape or by_label or "right", by_shape is None or by_label in (None, by_shape)


@dataclass(frozen=True, eq=False)
class Keypoints2D:
    """Keypoints of one camera over T frames.

    Attributes
    ----------
    xy : (T, 21, 2) ndarray
        Pixels (x, y) in the frame the keypoints belong to; NaN where missing.
    confidence : (T, 21) ndarray
        In [0, 1]; 0 where missing.
    name : str
        Where the keypoints came from (a file name), used in messages.
    """

    xy: np.ndarray
    confidence: np.ndarray
    name: str = "keypoints"
    world: np.ndarray | None = None
    depth: np.ndarray | None = None
    presence: np.ndarray | None = None
    handedness: np.ndarray | None = None
    handedness_score: np.ndarray | None = None

    def __post_init__(self) -> None:
        self._check_extras()
        xy = np.array(self.xy, dtype=float)
        c = np.array(self.confidence, dtype=float)
        if xy.ndim != 3 or xy.shape[1:] != (N_KEYPOINTS, 2) or c.shape != xy.shape[:2]:
            raise ValueError(
                f"{self.name}: expected xy (T, 21, 2) and confidence (T, 21); "
                f"got {xy.shape} and {c.shape}"
            )
        missing = np.isnan(xy).any(axis=2) | np.isnan(c) | (c == 0)
        xy[missing] = np.nan
        c[missing] = 0.0
        xy.flags.writeable = False
        c.flags.writeable = False
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "confidence", c)

    def _check_extras(self) -> None:
        n = np.shape(self.xy)[0] if np.ndim(self.xy) == 3 else None
        for field_, tail in (("world", (N_KEYPOINTS, 3)), ("depth", (N_KEYPOINTS,)),
                             ("presence", ()), ("handedness", ()),
                             ("handedness_score", ())):  # fmt: skip
            value = getattr(self, field_)
            if value is None:
                continue
            if field_ == "handedness":
                a = np.array(value, dtype=str)
                bad = sorted(set(a.ravel().tolist()) - {"right", "left", ""})
                if bad:
                    raise ValueError(
                        f"{self.name}: expected handedness right, left or empty; got {bad[0]!r}"
                    )
            else:
                a = np.array(value, dtype=float)
                if np.isinf(a).any():
                    raise ValueError(f"{self.name}: expected finite {field_} or NaN; got infinity")
                if field_ == "handedness_score" and ((a < 0) | (a > 1)).any():
                    raise ValueError(f"{self.name}: expected handedness_score in [0, 1]; got "
                                     f"{float(a[(a < 0) | (a > 1)][0])!r}")  # fmt: skip
            if a.shape != (n, *tail):
                raise ValueError(
                    f"{self.name}: expected {field_} of shape {(n, *tail)}; got {a.shape}"
                )
            a.flags.writeable = False
            object.__setattr__(self, field_, a)

    def _with(self, xy, confidence, keep=None) -> Keypoints2D:
        """These keypoints with new points, the extras kept (missing where not `keep`)."""
        extras = {}
        for name in _EXTRAS:
            v = getattr(self, name)
            if v is not None and keep is not None:
                blank = "" if name == "handedness" else np.nan
                v = np.where(keep.reshape((-1,) + (1,) * (v.ndim - 1)), v, blank)
            extras[name] = v
        return Keypoints2D(xy, confidence, self.name, **extras)

    def _padded(self, n_frames: int) -> Keypoints2D:
        """These keypoints followed by frames without a hand, `n_frames` in all."""
        extra = n_frames - self.n_frames

        def pad(v, blank):
            return np.concatenate([v, np.full((extra, *v.shape[1:]), blank, dtype=v.dtype)])

        extras = {name: None if v is None else pad(v, "" if name == "handedness" else np.nan)
                  for name in _EXTRAS for v in [getattr(self, name)]}  # fmt: skip
        return Keypoints2D(pad(self.xy, np.nan), pad(self.confidence, 0.0), self.name, **extras)

    def side(self) -> str | None:
        """The side of the hand by its frames' handedness: "right" or "left", the one
        of most frames with a detection (weighted by the presence when given); None
        without handedness or on a tie."""
        return _winner(self.side_votes())

    def side_votes(self) -> dict[str, float]:
        """Per side, the frames with a detection whose handedness names it (weighted
        by the presence and the handedness score when given, as `vote_side` weighs the
        detections); none without handedness."""
        if self.handedness is None:
            return {"right": 0.0, "left": 0.0}
        seen = self.present.any(axis=1) & (self.handedness != "")
        w = np.ones(self.n_frames)
        for weight in (self.presence, self.handedness_score):
            if weight is not None:
                w = w * np.nan_to_num(weight, nan=1.0)
        return {side: float(w[seen & (self.handedness == side)].sum())
                for side in ("right", "left")}  # fmt: skip

    @classmethod
    def from_array(cls, array, *, name: str = "keypoints") -> Keypoints2D:
        """Check a (T, 21, 2) or (T, 21, 3) array (x, y[, confidence]) and wrap it.

        Parameters
        ----------
        array : (T, 21, 2) or (T, 21, 3) array_like
            Pixels and optional confidence; NaN for missing points or frames.
        name : str, keyword-only
            Named in error messages (the file).

        Raises
        ------
        TypeError
            If `array` is not numeric.
        ValueError
            If its shape is wrong, a coordinate is infinite or a confidence lies
            outside [0, 1].
        """
        a = as_array(array, name, finite=False, what="keypoints of shape (T, 21, 2) or (T, 21, 3)")
        if a.ndim != 3 or a.shape[1] != N_KEYPOINTS or a.shape[2] not in (2, 3):
            raise ValueError(
                f"{name}: expected keypoints of shape (T, 21, 2) or (T, 21, 3) "
                f"(frames, points, x y [confidence]); got shape {a.shape}"
            )
        if a.shape[0] == 0:
            raise ValueError(f"{name}: expected at least one frame; got 0")
        if np.isinf(a).any():
            t, k = np.argwhere(np.isinf(a))[0][:2]
            raise ValueError(
                f"{name}: expected finite values or NaN; got infinity at frame {t}, point {k}"
            )
        if a.shape[2] == 3:
            c = a[..., 2]
            bad = ~np.isnan(c) & ((c < 0) | (c > 1))
            if bad.any():
                t, k = np.argwhere(bad)[0]
                raise ValueError(
                    f"{name}: expected confidences in [0, 1]; got {float(c[t, k])!r} "
                    f"at frame {t}, point {k}"
                )
            conf = np.where(np.isnan(c), 0.0, c)
        else:
            conf = np.ones(a.shape[:2])
        return cls(a[..., :2], conf, name)

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return self.xy.shape[0]

    def __len__(self) -> int:
        return self.n_frames

    @property
    def present(self) -> np.ndarray:
        """(T, 21) bool: the points that were detected."""
        return self.confidence > 0

    def frame(self, t: int) -> np.ndarray:
        """(21, 3) array of frame `t`: x, y, confidence (NaN, NaN, 0 where missing)."""
        t = as_int(t, "frame", minimum=0, maximum=self.n_frames - 1)
        return np.concatenate([self.xy[t], self.confidence[t, :, None]], axis=1)

    def to_array(self) -> np.ndarray:
        """(T, 21, 3) float64: x, y, confidence — the layout `from_array` reads."""
        return np.concatenate([self.xy, self.confidence[..., None]], axis=2)

    def scaled(self, factor: float, size: tuple[int, int] | None = None) -> Keypoints2D:
        """The keypoints in frames resized by `factor` (``--scale``).

        The pixel grid is that of `handvar.camera.Camera.scaled`: a pixel centre
        ``u`` maps to ``(u + ½)·s − ½``, with ``s = round(W·factor) / W`` per axis when
        the full-resolution frame size ``(W, H)`` is given, else ``s = factor``.

        Examples
        --------
        >>> kp = Keypoints2D.from_array(np.full((1, 21, 2), 99.5))
        >>> float(kp.scaled(0.5).xy[0, 0, 0])
        49.5
        """
        return self._with(scaled_pixels(self.xy, factor, size), self.confidence)

    def for_side(self, side: str | None) -> Keypoints2D:
        """These keypoints with each frame's confidences weighted by how probably its
        hand is of `side`, as the detector inside the pipeline weighs a detection
        (`choose`): by the handedness score where the handedness names `side`, by one
        minus it where it names the other; by the score alone with `side` None (labels
        that say nothing of the side tracked).  The score is then dropped: the
        confidences are weighted once.  Unchanged without a handedness score.

        Examples
        --------
        >>> kp = Keypoints2D(np.zeros((2, 21, 2)), np.ones((2, 21)),
        ...                  handedness=np.array(["right", "left"]),
        ...                  handedness_score=np.array([0.9, 0.8]))
        >>> kp.for_side("right").confidence[:, 0].round(2).tolist()
        [0.9, 0.2]
        """
        if self.handedness_score is None:
            return self
        score = np.nan_to_num(self.handedness_score, nan=1.0)
        if side is not None:
            one_of(side, ("right", "left"), "side")
            other = (self.handedness != side) & (self.handedness != "")
            score = np.where(other, 1.0 - score, score)
        return dataclasses.replace(self, confidence=self.confidence * score[:, None],
                                   handedness_score=None)  # fmt: skip

    def every(self, k: int, *, offset: int = 0) -> Keypoints2D:
        """Keep every `k`-th frame (``t ≡ offset mod k``); the others become missing.

        A detector run at a fraction of the tracker's frame rate: at 6 fps beside a
        30 fps tracker, ``every(5)``.
        """
        k = as_int(k, "k", minimum=1)
        offset = as_int(offset, "offset", minimum=0)
        keep = (np.arange(self.n_frames) - offset) % k == 0
        conf = np.where(keep[:, None], self.confidence, 0.0)
        return self._with(self.xy, conf, keep)


def scaled_pixels(xy, factor: float, size: tuple[int, int] | None = None) -> np.ndarray:
    """Pixels (…, 2) of a frame mapped to the frame resized by `factor` (`Keypoints2D.scaled`:
    a pixel centre ``u`` goes to ``(u + ½)·s − ½``, ``s = round(W·factor) / W`` per axis
    with the frame's size ``(W, H)``, else ``s = factor``).

    Examples
    --------
    >>> scaled_pixels(np.array([[99.5, 9.5]]), 0.5).tolist()
    [[49.5, 4.5]]
    """
    factor = as_float(factor, "factor", minimum=0.0, exclusive_minimum=True)
    if size is None:
        s = np.array([factor, factor])
    else:
        w, h = (as_int(v, "size", minimum=1) for v in size)
        s = np.array([max(1, round(w * factor)) / w, max(1, round(h * factor)) / h])
    return (np.asarray(xy, dtype=float) + 0.5) * s - 0.5


def as_frame_keypoints(value, name: str = "keypoints") -> np.ndarray:
    """Check one frame's keypoints of one camera: (21, 3) x, y, confidence.

    Parameters
    ----------
    value : (21, 2) or (21, 3) array_like
        Pixels and optional confidence; NaN for missing points.
    name : str
        Named in error messages.

    Returns
    -------
    (21, 3) ndarray
        x, y, confidence (NaN, NaN, 0 where missing).
    """
    a = as_array(value, name, finite=False, what="keypoints of shape (21, 2) or (21, 3)")
    if a.ndim != 2 or a.shape[0] != N_KEYPOINTS or a.shape[1] not in (2, 3):
        raise ValueError(
            f"{name}: expected keypoints of shape (21, 2) or (21, 3); got shape {a.shape}"
        )
    return Keypoints2D.from_array(a[None], name=name).frame(0)


def check_keypoints(keypoints, n_frames: int, sizes, hand: str, short=None, cameras=None):
    """Check a recording's keypoints before tracking; return them cleaned and the side.

    - Each camera's keypoints must have the recording's `n_frames` frames and at least
      one frame with a detected point.  Where `short` allows it (a video opened with
      ``allow_short``, whose decoding may stop before its container's count), fewer
      frames are taken, the rest as frames without a hand, with a warning.
    - Coordinates all within [−0.5, 1.5] on a frame larger than 16 pixels are normalised
      coordinates, not pixels: an error.
    - Points more than half a frame beyond its border are not the hand's: they are
      dropped (missing), and their count returned.
    - `hand` "auto" takes the side of the hand's 3D shape with two `cameras`, else of
      the keypoints' handedness (`hand_side`); a side that the handedness contradicts
      and the shape does not give is an error.
    - Confidences with a handedness score are weighted for the side
      (`Keypoints2D.for_side`; by the score alone where the shape overrules the
      handedness).

    Parameters
    ----------
    keypoints : list of Keypoints2D or None
        Per camera (None: a camera without), pixels of the full-resolution frames.
    n_frames : int
        Frames of the recording.
    sizes : sequence of (int, int)
        Per camera the full-resolution frame size (width, height).
    hand : {"right", "left", "auto"}
    short : sequence of bool, optional
        Per camera, whether fewer frames than `n_frames` are taken.
    cameras : sequence of Camera, optional
        Per camera, the calibrated camera of the full-resolution frames.

    Returns
    -------
    keypoints : list of Keypoints2D or None
    side : {"right", "left"}
    dropped : int
        Points dropped as outside the frames.

    Raises
    ------
    ValueError
        Naming the keypoints (the file) or ``hand``, what was expected and what came.
    """
    out, dropped = [], 0
    short = [False] * len(sizes) if short is None else list(short)
    for k, (w, h), may_be_short in zip(keypoints, sizes, short, strict=True):
        if k is None:
            out.append(None)
            continue
        if may_be_short and 0 < k.n_frames < n_frames:
            warnings.warn(
                f"{k.name}: keypoints of {k.n_frames} frames, the video's container states "
                f"{n_frames}; frames after {k.n_frames} taken without a hand (--allow-short)",
                stacklevel=2,
            )
            k = k._padded(n_frames)
        if k.n_frames != n_frames:
            raise ValueError(
                f"{k.name}: expected keypoints of {n_frames} frames (the recording's); "
                f"got {k.n_frames}"
            )
        present = k.present
        if not present.any():
            raise ValueError(
                f"{k.name}: expected at least one frame with a detected point; got none"
            )
        outside = _outside_frame(k.xy, present, (w, h), k.name)
        if outside.any():
            dropped += int(outside.sum())
            k = k._with(k.xy, np.where(outside, 0.0, k.confidence))
        out.append(k)
    side, labelled = _side_and_labels(out, hand, cameras)
    out = [None if k is None else k.for_side(side if labelled else None) for k in out]
    return out, side, dropped


def _outside_frame(xy, present, size, name: str) -> np.ndarray:
    """Which points `xy` (..., 2) lie more than half a frame of `size` (w, h) beyond
    its border (not the hand's: `check_keypoints`); coordinates all within [−0.5, 1.5]
    of the `present` points on a frame larger than 16 pixels are refused as normalised."""
    w, h = size
    seen = xy[present]
    if seen.size and max(w, h) > 16 and seen.min() >= -0.5 and seen.max() <= 1.5:
        raise ValueError(
            f"{name}: expected pixels of the {w}x{h} frames; got coordinates all "
            f"within [{seen.min():.2f}, {seen.max():.2f}] (normalised coordinates?)"
        )
    margin = 0.5 * np.array([w, h])
    return present & (
        (xy < -margin - 0.5).any(axis=-1) | (xy > np.array([w, h]) - 0.5 + margin).any(axis=-1)
    )


def check_detections(frames: list[list[Detection]], size, name: str):
    """Check one camera's hands found (`read_detections`) against its frames, as
    `check_keypoints` checks one hand's: normalised coordinates are an error, points
    more than half a frame beyond the border are dropped (missing) and counted.

    Parameters
    ----------
    frames : list of list of Detection
        Per frame the hands found, pixels of the full-resolution frames.
    size : (int, int)
        The full-resolution frame size (width, height).
    name : str
        Named in the message (the file).

    Returns
    -------
    frames : list of list of Detection
    dropped : int
        Points dropped as outside the frames.
    """
    hands = [d for found in frames for d in found]
    if not hands:
        return frames, 0
    points = np.stack([d.points for d in hands])
    outside = _outside_frame(points[..., :2], points[..., 2] > 0, size, name)
    if not outside.any():
        return frames, 0
    points[outside] = (np.nan, np.nan, 0.0)
    kept = iter(dataclasses.replace(d, points=p) for d, p in zip(hands, points, strict=True))
    return [[next(kept) for _ in found] for found in frames], int(outside.sum())


def hand_side(keypoints, hand: str, cameras=None) -> str:
    """The side of the hand tracked: `hand`, checked against the keypoints' handedness;
    with `hand` "auto", the side the hand's 3D shape gives, else the handedness's.

    Parameters
    ----------
    keypoints : list of Keypoints2D or None
        Per camera (None: a camera without).
    hand : {"right", "left", "auto"}
    cameras : sequence of Camera, optional
        Per camera, the camera of the keypoints' pixels.  With two cameras' keypoints
        the hand's shape decides (`shape_side`), as the detector inside the pipeline
        decides it: a detector run on each view can label the hand of both views the
        other side.

    Where the cameras' handedness disagree (a detector run on each view labels the
    same hand apart), it says nothing sure: `hand` is taken as given, and "auto" takes
    the side of most frames over all the cameras, as the detector inside the pipeline
    votes over them.

    Raises
    ------
    ValueError
        When the handedness of every camera contradicts `hand` and the shape does not
        give it, or with "auto" when neither the shape nor the handedness gives a side.
    """
    return _side_and_labels(keypoints, hand, cameras)[0]


def _side_and_labels(keypoints, hand: str, cameras=None) -> tuple[str, bool]:
    """`hand_side`'s side, and whether the keypoints' handedness says which hand a
    detection is: not where the hand's shape overrules it."""
    one_of(hand, ("right", "left", "auto"), "hand")
    by_shape = shape_side(keypoints, cameras)
    votes = [k.side_votes() for k in keypoints if k is not None]
    pooled = {side: sum(v[side] for v in votes) for side in ("right", "left")}
    if by_shape is not None and hand in ("auto", by_shape):
        return by_shape, _winner(pooled) in (None, by_shape)
    sides = {_winner(v) for v in votes} - {None}
    if len(sides) > 1:  # the cameras disagree
        sides = set() if hand != "auto" else {_winner(pooled)} - {None}
    seen = next(iter(sides), None)
    if hand == "auto":
        if seen is None and any(sum(v.values()) for v in votes):
            raise ValueError("hand: auto found the keypoints' handedness split evenly "
                             "between right and left; give the side")  # fmt: skip
        if seen is None:
            raise ValueError(
                "hand: auto expected keypoints with handedness (a .npz written by handvar "
                "keypoints) or two calibrated cameras' keypoints; got neither"
            )
        return seen, True
    if seen is not None and seen != hand:
        raise ValueError(
            f"hand: expected the side the keypoints' handedness gives ({seen}); got {hand}"
        )
    return hand, True


def shape_side(keypoints, cameras) -> str | None:
    """The side the hand's 3D shape gives: the sign of the sum of the
    `two_view_chirality` of the first two cameras' keypoints over the frames both
    have (right where positive); None without two cameras' keypoints or a sum of 0.

    Parameters
    ----------
    keypoints : list of Keypoints2D or None
        Per camera (None: a camera without).
    cameras : sequence of Camera or None
        Per camera, the camera of the keypoints' pixels.
    """
    if cameras is None:
        return None
    pairs = [(c, k) for c, k in zip(cameras, keypoints, strict=True) if k is not None][:2]
    if len(pairs) < 2:
        return None
    (camera_a, a), (camera_b, b) = pairs
    both = np.flatnonzero((a.present.sum(1) >= 3) & (b.present.sum(1) >= 3))
    score = float(np.nansum([two_view_chirality(camera_a, a.frame(t), camera_b, b.frame(t))
                             for t in both]))  # fmt: skip
    return _side_of(score)


def _winner(votes: dict[str, float]) -> str | None:
    """The side with more votes; None on a tie (none at all included)."""
    if votes["right"] == votes["left"]:
        return None
    return max(votes, key=votes.get)


# --- files -----------------------------------------------------------------------------


def _float_cell(cell: str) -> float:
    cell = cell.strip()
    return math.nan if cell == "" else float(cell)


def _is_number(cell: str) -> bool:
    try:
        _float_cell(cell)
    except ValueError:
        return False
    return True


def _read_csv(path: Path) -> np.ndarray:
    name = str(path)
    with open(path, newline="", encoding="utf-8") as fh:
        # blank lines are skipped; a row of empty cells is a frame without keypoints
        rows = [row for row in csv.reader(fh) if len(row) > 1 or (row and row[0].strip())]
    if rows:
        try:
            [_float_cell(c) for c in rows[0]]
        except ValueError:
            rows = rows[1:]  # a header
    if not rows:
        raise ValueError(f"{name}: expected one row of keypoints per frame; got no rows")
    values = []
    for i, row in enumerate(rows):
        if len(row) not in (2 * N_KEYPOINTS, 3 * N_KEYPOINTS):
            raise ValueError(
                f"{name}: expected 42 columns (x, y per point) or 63 (x, y, confidence) "
                f"per row; got {len(row)} in data row {i}"
            )
        if len(row) != len(rows[0]):
            raise ValueError(
                f"{name}: expected {len(rows[0])} columns in every row (as in the first); "
                f"got {len(row)} in data row {i}"
            )
        try:
            values.append([_float_cell(c) for c in row])
        except ValueError:
            bad = next(c for c in row if not _is_number(c))
            raise ValueError(f"{name}: expected numbers; got {bad!r} in data row {i}") from None
    a = np.asarray(values)
    return a.reshape(len(rows), N_KEYPOINTS, -1)


def read_keypoints(path: str | os.PathLike) -> Keypoints2D:
    """Read one camera's keypoints from a ``.npy`` or ``.csv`` file (module notes).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    Keypoints2D
        Named after the file.

    Raises
    ------
    ValueError
        If the file is missing, unreadable, of another format or holds anything but
        (T, 21, 2|3) keypoints; the message names the file.

    Examples
    --------
    >>> import tempfile
    >>> kp = Keypoints2D.from_array(np.arange(2 * 21 * 3).reshape(2, 21, 3) / 200)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     write_keypoints(f"{d}/kp.csv", kp)
    ...     back = read_keypoints(f"{d}/kp.csv")
    >>> bool(np.array_equal(back.to_array(), kp.to_array()))
    True
    """
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise ValueError(f"{name}: expected a keypoint file (.npy, .csv or .npz); got no such file")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            array = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise ValueError(f"{name}: expected a NumPy .npy array; got {exc}") from None
    elif suffix == ".csv":
        try:
            array = _read_csv(path)
        except UnicodeDecodeError:
            raise ValueError(f"{name}: expected a text CSV file; got binary data") from None
    elif suffix == ".npz":
        return _read_npz(path)
    elif suffix == ".json":
        raise ValueError(f"{name}: expected one hand's keypoints (.npy, .csv or .npz); got a "
                         f".json, every hand found, which --hands 2 reads")  # fmt: skip
    else:
        raise ValueError(f"{name}: expected a .npy, .csv or .npz keypoint file; got {suffix!r}")
    return Keypoints2D.from_array(array, name=name)


#: The optional arrays of a ``.npz`` keypoint file (module notes).
_EXTRAS = ("world", "depth", "presence", "handedness", "handedness_score")


def _read_npz(path: Path) -> Keypoints2D:
    name = str(path)
    expected = f"{name}: expected a .npz archive (the file `handvar keypoints` writes)"
    with open(path, "rb") as fh:  # closed whatever np.load makes of it
        magic = fh.read(6)
        if magic == b"\x93NUMPY":
            raise ValueError(f"{expected}; got a single .npy array (not a .npz archive)")
        if not magic.startswith(b"PK"):
            raise ValueError(f"{expected}; got a file that is not a .npz archive")
        fh.seek(0)
        try:
            with np.load(fh, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
            raise ValueError(f"{expected}; got a damaged or truncated archive ({exc})") from None
    if "keypoints" not in arrays:
        raise ValueError(
            f"{name}: expected a .npz with a 'keypoints' array; got {sorted(arrays) or 'none'}"
        )
    kp = Keypoints2D.from_array(arrays["keypoints"], name=name)
    kp = Keypoints2D(kp.xy, kp.confidence, name, **{k: arrays.get(k) for k in _EXTRAS})
    if kp.world is None:
        return kp
    return dataclasses.replace(kp, world=world_in_mm(kp.world, name))


def world_in_camera(world, points, camera) -> np.ndarray:
    """A detector's 3D points, seen along the ray through the palm, in `camera`'s axes.

    A detector that infers 3D from a crop around the hand (MediaPipe's world landmarks)
    gives the hand as a camera looking straight at the crop would see it: in axes whose
    z is the ray through the hand, not the camera's optical axis (the same hand at the
    centre and at the border of a wide image gets the same world landmarks).  They are
    turned by `handvar.camera.Camera.ray_rotation` at the mean of the palm's points
    (`PALM`); where none of them is found, returned as they are.

    Parameters
    ----------
    world : (21, 3) array_like
        mm, any origin.
    points : (21, 2) or (21, 3) array_like
        The same detection's pixels in `camera`'s image (a third column, the
        confidence, is ignored); NaN where a point was not found.
    camera : handvar.camera.Camera

    Returns
    -------
    (21, 3) ndarray
        In `camera`'s axes (not its position: the origin stays the detector's).

    Examples
    --------
    >>> from handvar.camera import Camera
    >>> cam = Camera.assumed((640, 480), fov=60.0)
    >>> w, px = np.eye(21, 3), np.full((21, 2), [cam.cx, cam.cy])  # the palm on the axis
    >>> bool(np.allclose(world_in_camera(w, px, cam), w))
    True
    """
    world = np.asarray(world, dtype=float)
    palm = np.asarray(points, dtype=float)[list(PALM), :2]
    palm = palm[np.isfinite(palm).all(axis=1)]
    if not len(palm):
        return world.copy()
    return world @ camera.ray_rotation(palm.mean(axis=0)).T


def world_in_mm(world, name: str = "world") -> np.ndarray:
    """World points in mm, recognised by the hand's size: the median over the frames of
    the wrist → middle-MCP distance.

    Within `PALM_LENGTH_MM` the points are mm and returned as they are; within it
    divided by 1000 they are metres (MediaPipe's own unit): returned × 1000 with a
    `KeypointUnitWarning`. Frames without both points do not count; without any, the
    points are returned as they are.

    Parameters
    ----------
    world : (T, 21, 3) array_like
        3D points per frame, NaN where missing.
    name : str
        Named in the messages (the file).

    Returns
    -------
    (T, 21, 3) ndarray
        In mm.

    Raises
    ------
    ValueError
        When the size is a hand's in neither unit (points × 1000 too large, say).

    Examples
    --------
    >>> w = np.zeros((1, 21, 3))
    >>> w[0, KEYPOINT_NAMES.index("middle_mcp"), 1] = -0.09  # 9 cm: metres
    >>> import warnings
    >>> with warnings.catch_warnings(record=True):
    ...     warnings.simplefilter("always")
    ...     float(world_in_mm(w, "k.npz")[0, 9, 1])
    -90.0
    """
    world = np.asarray(world, dtype=float)
    wrist, middle = KEYPOINT_NAMES.index("wrist"), KEYPOINT_NAMES.index("middle_mcp")
    lengths = np.linalg.norm(world[:, middle] - world[:, wrist], axis=-1)
    lengths = lengths[np.isfinite(lengths)]
    if lengths.size == 0:
        return world
    length = float(np.median(lengths))
    lo, hi = PALM_LENGTH_MM
    if lo <= length <= hi:
        return world
    if lo <= 1000.0 * length <= hi:
        warnings.warn(
            f"{name}: world points taken as metres and converted to mm (the hand's wrist "
            f"to middle MCP measures {length:.3g}; a hand's is {lo:g} to {hi:g} mm)",
            KeypointUnitWarning,
            stacklevel=2,
        )
        return 1000.0 * world
    raise ValueError(
        f"{name}: expected world points in mm (a hand's wrist to middle MCP measures "
        f"{lo:g} to {hi:g} mm); got {length:.3g} (median over the frames), a hand's in "
        f"neither mm nor metres"
    )


def check_output_suffix(path: str | os.PathLike) -> Path:
    """Check that `path` names a keypoint file `write_keypoints` can write."""
    path = Path(path)
    if path.suffix.lower() not in (".npy", ".csv", ".npz"):
        raise ValueError(
            f"{path}: expected a file name ending in .npy, .csv or .npz; got {path.suffix!r}"
        )
    return path


def write_keypoints(path: str | os.PathLike, keypoints: Keypoints2D | np.ndarray) -> None:
    """Write keypoints as ``.npy`` (T, 21, 3), ``.csv`` (63 columns with a header) or
    ``.npz`` (with the world points, depth, presence, handedness and its score given;
    module notes).  Only the ``.npz`` keeps those; the others hold the confidences
    weighted by the handedness score (`Keypoints2D.for_side` with no side).

    The file is written atomically (`handvar.atomic.write_atomic`).

    Parameters
    ----------
    path : path-like
        Ending in ``.npy`` or ``.csv``.
    keypoints : Keypoints2D or (T, 21, 2|3) array_like
    """
    path = Path(path)
    if not isinstance(keypoints, Keypoints2D):
        keypoints = Keypoints2D.from_array(keypoints, name="keypoints")
    suffix = path.suffix.lower()
    # a file without the handedness score holds confidences already weighted by it
    array = (keypoints if suffix == ".npz" else keypoints.for_side(None)).to_array()
    if suffix == ".npy":

        def write(tmp: str) -> None:
            with open(tmp, "wb") as fh:
                np.save(fh, array)

    elif suffix == ".npz":
        extras = {k: getattr(keypoints, k) for k in _EXTRAS if getattr(keypoints, k) is not None}

        def write(tmp: str) -> None:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, keypoints=array, **extras)

    elif suffix == ".csv":
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([f"{c}{k}" for k in range(N_KEYPOINTS) for c in "xyc"])
        for row in array.reshape(len(array), -1):
            writer.writerow(["nan" if np.isnan(v) else repr(float(v)) for v in row])

        def write(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(buf.getvalue())

    else:
        check_output_suffix(path)
    write_atomic(path, write)


def write_detections(path: str | os.PathLike, frames: Iterable[Iterable[Detection]]) -> None:
    """Write every hand found, frame by frame, as a ``.json`` detections file (module
    notes), atomically (`handvar.atomic.write_atomic`).

    Parameters
    ----------
    path : path-like
        Ending in ``.json``.
    frames : iterable of iterable of Detection
        Per frame the hands found.
    """
    import json

    path = Path(path)
    if path.suffix.lower() != ".json":
        raise ValueError(f"{path}: expected a .json detections file; got {path.suffix!r}")

    def numbers(rows) -> list:
        return [[float(v) if math.isfinite(v) else None for v in row] for row in rows]

    rows = []
    for found in frames:
        hands = []
        for d in found:
            hand = {"points": numbers(d.points), "side": d.side, "score": float(d.score)}
            if d.world is not None:
                hand["world"] = numbers(d.world)
            hands.append(hand)
        rows.append(hands)
    text = json.dumps(rows, separators=(",", ":"))

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    write_atomic(path, write)


def read_detections(path: str | os.PathLike) -> list[list[Detection]]:
    """Read a ``.json`` detections file (module notes): per frame, the hands found.

    Raises
    ------
    ValueError
        If the file is missing, not JSON, or any entry is not as the module notes say;
        the message names the file, and the frame and hand at fault.

    Examples
    --------
    >>> import tempfile
    >>> hand = Detection(np.c_[np.arange(42.0).reshape(21, 2), np.ones(21)], side="left",
    ...                  score=0.9)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     write_detections(f"{d}/hands.json", [[hand], []])
    ...     back = read_detections(f"{d}/hands.json")
    >>> [len(f) for f in back], back[0][0].side, bool(np.array_equal(back[0][0].points,
    ...                                                              hand.points))
    ([1, 0], 'left', True)
    """
    import json

    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise ValueError(f"{name}: expected a detections file (.json); got no such file")
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise ValueError(f"{name}: expected a JSON text file; got binary data") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{name}: expected JSON; got an error at line {exc.lineno}, "
                         f"column {exc.colno}: {exc.msg}") from None  # fmt: skip
    if not isinstance(rows, list):
        raise ValueError(f"{name}: expected a list with one entry per frame; got "
                         f"{type(rows).__name__}")  # fmt: skip
    out = []
    for t, found in enumerate(rows):
        if not isinstance(found, list):
            raise ValueError(f"{name}: frame {t}: expected a list of the hands found; got "
                             f"{type(found).__name__}")  # fmt: skip
        out.append([_detection(hand, f"{name}: frame {t}, hand {k}")
                    for k, hand in enumerate(found)])  # fmt: skip
    return _world_in_mm(out, name)


def _world_in_mm(frames: list[list[Detection]], name: str) -> list[list[Detection]]:
    """`frames` with their world points in mm, as a ``.npz``'s are read (`world_in_mm`
    over every hand of the file that has them)."""
    given = [(t, k) for t, found in enumerate(frames) for k, d in enumerate(found)
             if d.world is not None]  # fmt: skip
    if not given:
        return frames
    mm = world_in_mm(np.stack([frames[t][k].world for t, k in given]), name)
    for (t, k), world in zip(given, mm, strict=True):
        frames[t][k] = dataclasses.replace(frames[t][k], world=world)
    return frames


def _is_json_table(rows, shape: tuple[int, int]) -> bool:
    """Whether `rows` read from JSON is `shape` lists of numbers or null (no strings,
    booleans or lists among them)."""
    if not isinstance(rows, list) or len(rows) != shape[0]:
        return False
    return all(isinstance(row, list) and len(row) == shape[1] and all(
        v is None or (isinstance(v, int | float) and not isinstance(v, bool)) for v in row)
        for row in rows)  # fmt: skip


def _detection(hand, where: str) -> Detection:
    """One hand of a detections file (`read_detections`)."""
    if not isinstance(hand, dict) or "points" not in hand:
        raise ValueError(f"{where}: expected an object with 'points'; got {hand!r:.60}")

    def array(key: str, shape: tuple) -> np.ndarray:
        rows = hand[key]
        if not _is_json_table(rows, shape):
            raise ValueError(f"{where}: expected {key!r} as {shape[0]} × [{shape[1]} numbers "
                             f"or null]; got {rows!s:.60}")  # fmt: skip
        a = np.array([[np.nan if v is None else v for v in row] for row in rows], dtype=float)
        if np.isinf(a).any():
            k = np.argwhere(np.isinf(a))[0][0]
            raise ValueError(f"{where}: expected {key!r} finite numbers or null; got "
                             f"infinity at point {k}")  # fmt: skip
        return a

    points = array("points", (N_KEYPOINTS, 3))
    c = points[:, 2]
    bad = np.flatnonzero(~np.isnan(c) & ((c < 0) | (c > 1)))
    if bad.size:
        raise ValueError(f"{where}: expected confidences in [0, 1] (each point's third "
                         f"number); got {float(c[bad[0]])!r} at point {bad[0]}")  # fmt: skip
    world = array("world", (N_KEYPOINTS, 3)) if hand.get("world") is not None else None
    side = hand.get("side", "")
    score = hand.get("score", 1.0)
    if side not in ("right", "left", ""):
        raise ValueError(f"{where}: expected 'side' right, left or empty; got {side!r}")
    if isinstance(score, bool) or not isinstance(score, int | float) or not 0 <= score <= 1:
        raise ValueError(f"{where}: expected 'score' a number in [0, 1]; got {score!r}")
    return Detection(points, world=world, side=side, score=float(score))
