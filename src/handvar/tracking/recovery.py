"""Tracking a recording frame by frame: the keypoint-first fit and a few rules.

`Recovery` (and `track_with_recovery`, one call) tracks frame by frame; the rules, and
why each exists, are in docs/keypoint-fit.md:

1. A frame with keypoints (detected, or carried by optical flow) is fitted to them by
   the keypoint-first fit (`handvar.tracking.frame_fit.fit_frame`) from the motion
   predictor's prediction, which also enters as the temporal prior, weighted by the
   predictor's recent accuracy (`PriorScale`).  The silhouettes enter that fit only
   with its silhouette term (`FrameFitSettings.silhouette`, off by default); their
   IoU with the fitted model is only reported.
2. Such a fit is *lost* when its kept keypoints lie farther than
   `QualitySettings.lost_keypoint_error` hand sizes on average or it rejects more than
   half of them; it is then fitted again directly from the keypoints
   (`reinitialise`, no grid search), the better of the two kept (fewer rejected, then
   closer), and the predictor restarts there.
3. In a track with keypoints, a frame without any whose silhouette is empty or does not
   overlap the model at the predicted pose (`RecoverySettings.no_hand_iou`) is flagged
   *no hand* and not fitted; the next frame with keypoints re-acquires the hand.
4. Any other frame is fitted by the paper's silhouette tracker (`Tracker.step`) from
   the prediction.  In a track without keypoints the frame's silhouettes, computed
   when asked, keep the skin component where the model at the prediction lies, not
   the largest (`handvar.vision.silhouette.clean_mask`'s ``near``); a lost fit is
   refined, then searched again from the silhouettes
   (`handvar.tracking.init.initial_pose`), and a fit under
   `RecoverySettings.refine_iou` re-seeded digit by digit (`digit_reseeds`), as
   design §14.3 describes.

Optionally the loop cuts the forearm off the silhouettes at the detected wrist or, on
frames without keypoints, at the wrist of the model fitted to the previous frame
(``cut_wrist``).

For evaluation against a detector, `joint_distances` and `pck` measure the projected
joints against keypoints in the detector's own hand size (its wrist → middle-MCP
distance in that frame), independent of the model; `TrackQuality.check` is the
keypoint check of docs/keypoint-fit.md.
"""

from __future__ import annotations

import collections
import copy
import dataclasses
import functools
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from handvar.hand.anthropometry import JOINT_DIGIT, MIDDLE_MCP, WRIST, HandShape
from handvar.hand.kinematics import (
    POSE_NAMES,
    euler_from_matrix,
    named_pose,
    world_from_hand_rotation,
)
from handvar.params import N_PARAMS, clamp, digit_angles
from handvar.predictors import NoMotion
from handvar.tracking.costs import FrameData, prepare_frame
from handvar.tracking.frame_fit import (
    CHECK_THRESHOLD,
    FRAME_FIT_DEFAULTS,
    FrameFit,
    FrameFitSettings,
    PriorScale,
    fit_frame,
    honoured,
    honoured_shares,
    keypoint_distances,
    reinitialise,
)
from handvar.tracking.init import InitSettings, initial_pose
from handvar.tracking.keypoint_cost import frame_keypoints, keypoint_points
from handvar.tracking.shape_fit import SHAPE_FIT_DEFAULTS, ShapeFitSettings, fit_shape
from handvar.tracking.tracker import FrameResult, Tracker, TrackResult, silhouette_iou
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = [
    "RECOVERY_DEFAULTS",
    "FrameQuality",
    "RecoveredTrack",
    "Recovery",
    "RecoverySettings",
    "TrackQuality",
    "depth_mirror",
    "digit_reseeds",
    "joint_distances",
    "model_wrist_keypoints",
    "pck",
    "track_with_recovery",
]


@dataclass(frozen=True)
class FrameQuality:
    """How well one frame's fit explains it.

    Attributes
    ----------
    iou : float
        Silhouette IoU, mean over the cameras with a silhouette (`FrameResult.mean_iou`);
        NaN when not tracked.
    keypoint_error : float
        Mean distance of the projected joints to the frame's keypoints, in the model's
        hand size at its depth (`FrameResult.keypoint_error`); NaN without keypoints.
    cost : float
        Final cost of the optimiser, (pixel_scale px)²; NaN when not tracked.
    lost : bool
        The tracker's lost rule (module notes), after recovery; False on empty frames.
    """

    iou: float
    keypoint_error: float
    cost: float
    lost: bool


@dataclass(frozen=True, eq=False)
class TrackQuality:
    """Per-frame quality of a track and what the recovery did.

    Attributes
    ----------
    iou, keypoint_error, cost : (T,) ndarray
        As in `FrameQuality`.
    lost : (T,) bool ndarray
        Frames lost after recovery.
    reinit : (T,) bool ndarray
        Frames where the pose was searched again.
    empty : (T,) bool ndarray
        Frames with no silhouette in any camera (carried by the prediction).
    keypoints : (T,) bool ndarray
        Frames that had keypoints.
    no_hand : (T,) bool ndarray
        Frames flagged *no hand* (no keypoints, no plausible silhouette; not fitted).
    rejected : (T,) int ndarray
        Keypoints the fit rejected as outliers, per frame.
    distances : (T, n_cams, 21) ndarray
        Distance of each projected joint to its keypoint in the detector's hand size
        (`joint_distances`), NaN where no keypoint or rejected; all NaN when not given.
    """

    iou: np.ndarray
    keypoint_error: np.ndarray
    cost: np.ndarray
    lost: np.ndarray
    reinit: np.ndarray
    empty: np.ndarray
    keypoints: np.ndarray
    no_hand: np.ndarray | None = None
    rejected: np.ndarray | None = None
    distances: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.lost)
        if self.no_hand is None:
            object.__setattr__(self, "no_hand", np.zeros(n, dtype=bool))
        if self.rejected is None:
            object.__setattr__(self, "rejected", np.zeros(n, dtype=np.int64))
        if self.distances is None:
            object.__setattr__(self, "distances", np.full((n, 1, 21), np.nan))

    def check(
        self, threshold: float = CHECK_THRESHOLD, share: float = 0.98, frames=None
    ) -> tuple[bool, float, int]:
        """The keypoint check (`handvar.tracking.frame_fit.honoured`) of this track.

        `frames`: a (T,) bool mask of the frames checked, e.g. those with a detection
        (not carried keypoints); all frames with keypoints by default.  The rejected
        count is over the same frames.
        """
        keep, d = self._checked(frames)
        ok, worst, _ = honoured(d, np.zeros(d.shape, dtype=bool), threshold=threshold,
                                share=share)  # fmt: skip
        return ok, worst, int(self.rejected[: len(keep)][keep].sum())

    def failing(self, threshold: float = CHECK_THRESHOLD, share: float = 0.98, frames=None) -> int:
        """How many frames (of the (T,) bool mask `frames`, default all) fail the keypoint
        check: they have kept keypoints, fewer than `share` of them within `threshold`."""
        return int(self.failing_frames(threshold, share, frames).sum())

    def failing_frames(
        self, threshold: float = CHECK_THRESHOLD, share: float = 0.98, frames=None
    ) -> np.ndarray:
        """(T,) bool: the frames (of the mask `frames`, default all) failing the keypoint
        check, as `failing` counts them."""
        keep, d = self._checked(frames)
        shares = honoured_shares(d, np.zeros(d.shape, dtype=bool), threshold=threshold)
        out = np.zeros(len(keep), dtype=bool)
        out[keep] = ~np.isnan(shares) & (np.nan_to_num(shares, nan=1.0) < share)
        return out

    def _checked(self, frames) -> tuple[np.ndarray, np.ndarray]:
        """The mask of the frames checked (`frames`, default all) and their distances."""
        keep = np.ones(len(self.lost), dtype=bool) if frames is None else np.asarray(frames)
        keep = keep[: len(self.lost)]
        return keep, self.distances[: len(keep)][keep]

    def summary(self) -> str:
        """One line: frames lost, re-initialised and empty, IoU minimum and mean."""
        tracked = ~self.empty & ~np.isnan(self.iou)
        iou = self.iou[tracked]
        text = (
            f"{int(self.lost.sum())} lost, {int(self.reinit.sum())} re-initialised, "
            f"{int(self.empty.sum())} empty, {int(self.no_hand.sum())} no hand"
        )
        if iou.size:
            text += f"; silhouette IoU min {iou.min():.3f} (frame "
            text += f"{int(np.flatnonzero(tracked)[iou.argmin()])}), mean {iou.mean():.3f}"
        return text


@dataclass(frozen=True, eq=False)
class RecoveredTrack:
    """The result of `track_with_recovery`: the track and its quality.

    A refined frame's ``track.iterations`` counts the refinements' iterations too (so
    it may exceed the tracker's ``max_iterations``); its row of ``track.costs`` keeps
    the first ``max_iterations`` of them.  `init_seconds` are the re-initialisations'
    times, `seconds` each frame's whole wall time in `Recovery.frame` (fit, rules,
    quality).
    """

    track: TrackResult
    quality: TrackQuality
    init_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    shape: HandShape | None = None


def _present(kps) -> bool:
    return kps is not None and any(k is not None and np.any(np.asarray(k)[:, 2] > 0) for k in kps)


def joint_distances(x, hand, rig, keypoints, *, tips: str = "end") -> np.ndarray:
    """Distances of the projected joints G(x) to the keypoints, in hand sizes.

    Parameters
    ----------
    x : (26,) array_like
        Pose, mm and degrees.
    hand : HandModel
    rig : Rig
    keypoints : sequence of (21, 3) array_like or None
        One per camera (None: none there): x, y in that camera's pixels, confidence.
    tips : {"end", "pad"}, keyword-only
        G(x)'s fingertips, or the centres of their pads (`keypoint_points`, design §14.6).

    Returns
    -------
    (n_cams, 21) ndarray
        ``‖π_j(G_k(x)) − k_jk‖ / ‖k_j,wrist − k_j,middle MCP‖``; NaN where a point, a
        camera's keypoints or its hand size is missing.

    Examples
    --------
    >>> from handvar.camera import Rig
    >>> from handvar.hand import HandModel, named_pose
    >>> hand, rig, x = HandModel(), Rig.default(), named_pose("open")
    >>> kps = [np.column_stack([cam.project(hand.joints(x)), np.ones(21)]) for cam in rig]
    >>> float(np.nanmax(joint_distances(x, hand, rig, kps)))
    0.0
    """
    out = np.full((len(rig), 21), np.nan)
    if not np.all(np.isfinite(x)):
        return out
    G = keypoint_points(hand, x, tips)
    for j, cam in enumerate(rig):
        k = None if keypoints is None else keypoints[j]
        if k is None:
            continue
        k = np.asarray(k, dtype=float)
        if not (k[[WRIST, MIDDLE_MCP], 2] > 0).all():
            continue
        size = float(np.linalg.norm(k[MIDDLE_MCP, :2] - k[WRIST, :2]))
        if size <= 0:
            continue
        ok = k[:, 2] > 0
        out[j, ok] = np.linalg.norm(cam.project(G[ok]) - k[ok, :2], axis=1) / size
    return out


def pck(x, hand, rig, keypoints, threshold: float = 0.2, *, tips: str = "end") -> float:
    """Fraction of the present keypoints within `threshold` hand sizes of G(x)'s image.

    PCK@`threshold` (percentage of correct keypoints) against the detector, over every
    camera; NaN when no camera has keypoints with a hand size.  `tips` as in
    `joint_distances`.
    """
    d = joint_distances(x, hand, rig, keypoints, tips=tips)
    d = d[~np.isnan(d)]
    return float(np.mean(d <= threshold)) if d.size else math.nan


def _quiet_step(tracker: Tracker, masks, kps):
    """One tracker step without its empty-camera warning (the quality records it)."""
    import warnings

    from handvar.tracking.tracker import TrackingWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrackingWarning)
        try:
            return tracker.step(masks, keypoints=kps)
        except ValueError:  # a lost track can drive the optimiser to non-finite values
            return None


def _score(r) -> tuple[bool, float]:
    """Order of the silhouette fits of one frame by their own quality, best highest:
    not lost first, then the higher mean IoU."""
    if r is None:
        return (False, -math.inf)
    iou = r.mean_iou
    return (not r.lost, -1.0 if math.isnan(iou) else iou)


@dataclass(frozen=True)
class RecoverySettings:
    """The rules of `Recovery` (docs/keypoint-fit.md, "recovery"; the paper has none).

    Attributes
    ----------
    reinit : bool
        Re-initialise a lost frame (False: only flag it): from its keypoints by a direct
        fit (`handvar.tracking.frame_fit.reinitialise`), or, in a track without
        keypoints, by the silhouette search (`handvar.tracking.init.initial_pose`).
    reinit_shapes : tuple of str
        The finger postures the direct fit from keypoints starts each palm pose from
        (`reinitialise`'s ``shapes``).  ("open",): with ("open", "fist", "point")
        the realistic benchmark's figures moved by no more than run-to-run noise, for
        three times the time (docs/keypoint-fit.md, "a pose from keypoints alone").
    refine_iou : float
        In a track without keypoints, a fit whose mean silhouette IoU is below this
        after the refinement and the search is tried again with one digit at a time
        set to a named hand shape's (`reseed_digits`); 0.8, the IoU asked of every
        frame in design §14.4.
    refine_iterations : int
        In a track without keypoints, a lost fit is first refined for this many more
        iterations from the optimiser's initial gains; 100.  0 turns refinement off.
    reseed_digits : int
        How many digit re-seeds (`digit_reseeds`) are refined; 4.  0 turns it off.
    reseed_margin : float
        A re-seeded fit must raise the IoU by at least this much to be kept, 0.02:
        the IoU is the only judge there, and a digit moved for a smaller gain is as
        likely to be wrong as right.
    skin_where_expected : bool
        In a track without keypoints, each frame's silhouettes keep the skin component
        the model at the predicted pose overlaps most (`Recovery.frame`); False: the
        largest, the clean-up's default.  True: chosen on the realistic benchmark's
        cases, against the truth; it also keeps the component where the model lies
        once the model has left the hand (docs/results/paper-real-video.md).
    no_hand_iou : float
        In a track with keypoints, a frame without any whose silhouette overlaps the
        model at the predicted pose by less than this IoU (or has none) is flagged
        *no hand* and not fitted; 0.3, the lowest IoU `handvar init` accepts of a
        hand (design §13.4).
    keypoint_iou : bool
        Also measure the silhouette IoU of the fit on frames with keypoints; False: the
        keypoint-first fit does not use the silhouette, so a frame with keypoints
        needs none (its IoU is NaN) and costs no silhouette, wrist cut or rendering.
    keypoint_reseeds : tuple of str
        Rule 1's second look: a keypoint fit that leaves a keypoint of a digit rejected,
        or kept but farther than the keypoint check's 0.2 hand sizes, is fitted again
        with that digit's four angles started from each of these named hand shapes
        (`handvar.hand.kinematics.POSE_NAMES`), the others where they were; the better
        fit by keypoints (fewer rejected or off, then closer) is kept.  ("open",
        "fist"); () turns it off.
    restart : bool
        Rule 2 also for a keypoint fit that is not lost but leaves a kept keypoint
        farther than the keypoint check's 0.2 hand sizes: the fit from the prediction
        fell into a local minimum the keypoints alone may avoid.  The direct fit is kept
        when it leaves fewer keypoints rejected or off; the predictor is not restarted.
        False: on the realistic benchmark it made the fit worse (docs/keypoint-fit.md,
        "rules"); it helps only the example video's keypoint check.
    prior_steps : int
        Levenberg–Marquardt steps with the temporal prior after the fit to the
        keypoints alone (rule 1); 3.  0: no temporal prior.
    depth_mirror : int
        With one camera, rule 1 also fits the keypoints from the fit's palm mirrored in
        depth (`depth_mirror`), this many Levenberg–Marquardt steps and then to the
        end if it is ahead, and keeps it if it explains them better; the predictor
        restarts there.  8; 0 turns it off.  Chosen on the realistic benchmark with
        the simulated detector and with MediaPipe, 4, 8 and the fit's full 12 steps
        (docs/keypoint-fit.md, "rules").
    frame_fit : FrameFitSettings
        The keypoint-first fit's settings (its ``tips`` replaced by the tracker's
        ``CostSettings.keypoint_tips``).
    shape : ShapeFitSettings or None
        In a track with keypoints, the hand's proportions are fitted to the first
        frames whose keypoint fit is not lost (`handvar.tracking.shape_fit`) and held
        fixed after; None keeps the given shape.
    world_frames : int
        The detector's 3D given to the fit (its weak cue w) is the mean of the 3D it
        gave over the last this many frames, this one included; a frame whose
        keypoints were carried by optical flow (no detection) gets the mean of the
        last ones (on a recording carried both ways, `handvar.track` gives such a
        frame the 3D of the detections around it, interpolated), and a frame without
        keypoints starts it anew.  One frame's 3D is
        noisy, far more than the hand moves between frames; the 2D keypoints keep the
        fit on time.  3: chosen on the realistic benchmark with the detector inside,
        1, 3, 5 and 9 (docs/keypoint-fit.md, "the fit of one frame").
    """

    reinit: bool = True
    reinit_shapes: tuple[str, ...] = ("open",)
    refine_iou: float = 0.8
    refine_iterations: int = 100
    reseed_digits: int = 4
    reseed_margin: float = 0.02
    skin_where_expected: bool = True
    no_hand_iou: float = 0.3
    keypoint_iou: bool = False
    keypoint_reseeds: tuple[str, ...] = ("open", "fist")
    restart: bool = False
    prior_steps: int = 3
    depth_mirror: int = 8
    frame_fit: FrameFitSettings = FRAME_FIT_DEFAULTS
    shape: ShapeFitSettings | None = SHAPE_FIT_DEFAULTS
    world_frames: int = 3

    def __post_init__(self) -> None:
        as_instance(self.reinit, bool, "reinit")
        as_float(self.refine_iou, "refine_iou", minimum=0.0, maximum=1.0)
        as_int(self.refine_iterations, "refine_iterations", minimum=0)
        as_int(self.reseed_digits, "reseed_digits", minimum=0)
        as_float(self.reseed_margin, "reseed_margin", minimum=0.0, maximum=1.0)
        as_instance(self.skin_where_expected, bool, "skin_where_expected")
        as_float(self.no_hand_iou, "no_hand_iou", minimum=0.0, maximum=1.0)
        as_instance(self.keypoint_iou, bool, "keypoint_iou")
        for option in ("reinit_shapes", "keypoint_reseeds"):
            as_instance(getattr(self, option), tuple, option)
            for name in getattr(self, option):
                one_of(name, POSE_NAMES, option)
        as_instance(self.restart, bool, "restart")
        as_int(self.prior_steps, "prior_steps", minimum=0)
        as_int(self.depth_mirror, "depth_mirror", minimum=0)
        as_instance(self.frame_fit, FrameFitSettings, "frame_fit")
        if self.shape is not None:
            as_instance(self.shape, ShapeFitSettings, "shape")
        as_int(self.world_frames, "world_frames", minimum=1)

    def with_silhouette_term(self, sigma: float) -> RecoverySettings:
        """These settings with the keypoint fit's silhouette term at σ_s = `sigma` hand
        sizes (`FrameFitSettings.silhouette`; 0: off)."""
        fit = dataclasses.replace(self.frame_fit, silhouette=sigma)
        return dataclasses.replace(self, frame_fit=fit)


RECOVERY_DEFAULTS = RecoverySettings()


@dataclass
class _Frame:
    """What `Recovery` keeps of one frame."""

    result: object  # FrameResult or None
    pose: np.ndarray
    reinit: bool = False
    empty: bool = False
    keypoints: bool = False
    no_hand: bool = False
    rejected: int = 0
    distances: np.ndarray | None = None

    @classmethod
    def without_hand(cls) -> _Frame:
        """A frame without a hand: nothing fitted, a NaN pose."""
        return cls(None, np.full(N_PARAMS, np.nan), no_hand=True)


class Recovery:
    """Track frame by frame with the keypoint-first fit and a few rules (module notes).

    Parameters
    ----------
    tracker : Tracker
        Its rig, hand, predictor, generator and settings are used.
    settings : RecoverySettings, keyword-only
    init_settings : InitSettings, keyword-only, optional
        Settings of the silhouette pose search.
    cut_wrist : bool, keyword-only
        Cut the silhouettes at the wrist (`track_with_recovery`).
    """

    def __init__(
        self,
        tracker: Tracker,
        *,
        settings: RecoverySettings = RECOVERY_DEFAULTS,
        init_settings: InitSettings | None = None,
        cut_wrist: bool = False,
    ) -> None:
        self.tracker = as_instance(tracker, Tracker, "tracker")
        self.settings = as_instance(settings, RecoverySettings, "settings")
        self.fit_settings = dataclasses.replace(
            settings.frame_fit, tips=tracker.settings.cost.keypoint_tips
        )
        self._prior_settings = dataclasses.replace(
            self.fit_settings, iterations=max(settings.prior_steps, 1)
        )
        self._mirror_settings = dataclasses.replace(
            self.fit_settings, iterations=max(settings.depth_mirror, 1), polish=0
        )
        self.init_kw = {} if init_settings is None else {"settings": init_settings}
        self.cut_wrist = cut_wrist
        self.hand, self.rig = tracker.hand, tracker.rig
        self.scale = PriorScale()
        self.previous: np.ndarray | None = None  # the last finite pose
        self.started = False
        self.init_seconds: list[float] = []
        self._refiner: Tracker | None = None
        self._shape_frames: list | None = [] if settings.shape is not None else None
        self._shape_between: list = []  # the frames between those kept, fitted again after
        self._silhouettes: FrameData | None = None  # the frame's, for the fit's term
        self.shape_seconds = 0.0  # the shape fit's time, within its frame's
        self._frame_no = 0  # frames seen
        self._worlds: collections.deque = collections.deque()  # (frame, the detector's 3D)

    # -- one frame ------------------------------------------------------------------

    def frame(
        self, masks, kps, world=None, *, with_keypoints: bool = False, absent: bool = False
    ) -> _Frame:
        """Track one frame: masks (n_cams, H, W), keypoints per camera or None.

        `masks` may be a callable ``near=None -> masks`` computing them: in a track
        without keypoints it is given where the hand is expected (`_expected`), so
        that the skin component there is kept rather than the largest.

        `with_keypoints`: the track has keypoints (so a frame without them may be a
        frame without a hand).  `absent`: the detector looked at this frame and found no
        hand, and none was carried to it: a frame without a hand (NaN pose), the
        predictor left as it was.
        """
        world = self._world_cue(world, kps)
        if absent and kps is None:
            return _Frame.without_hand()
        if kps is not None:
            lazy = masks if callable(masks) else (lambda: masks)
            wanted = self.settings.keypoint_iou or self.fit_settings.silhouette > 0
            return self.keypoint_frame(
                functools.cache(lambda: self._masks(lazy(), kps)) if wanted else None,
                kps, world,
            )  # fmt: skip
        if with_keypoints and not self.started:  # before the hand was first seen
            return _Frame(None, self._nan_pose(), no_hand=True)
        if callable(masks):  # a track without keypoints: the skin where the hand goes
            masks = masks(None if with_keypoints else self._expected())
        masks = self._masks(masks, None)
        empty = not masks.any()
        if with_keypoints and self.no_hand(masks):
            return _Frame(None, self._nan_pose(), empty=empty, no_hand=True)
        return self.silhouette_frame(masks, empty)

    def _world_cue(self, world, kps):
        """The detector's 3D the fit is given on this frame (`RecoverySettings.world_frames`)."""
        self._frame_no += 1
        if kps is None:  # no keypoints: the next detection starts anew
            self._worlds.clear()
            return None
        if world is not None:
            oldest = self._frame_no - self.settings.world_frames
            while self._worlds and self._worlds[0][0] <= oldest:
                self._worlds.popleft()
            self._worlds.append((self._frame_no, np.asarray(world, dtype=float)))
        if not self._worlds:
            return None
        return np.mean([w for _, w in self._worlds], axis=0)

    def _expected(self) -> np.ndarray | None:
        """Where the hand is expected: the model's silhouettes at the motion prediction
        (None before a pose), for choosing the skin components (`clean_mask`'s `near`)."""
        if not self.settings.skin_where_expected or self.previous is None:
            return None
        from handvar.render import silhouettes

        return silhouettes(self.hand, self.tracker.prediction(), self.rig)

    def _masks(self, masks, kps) -> np.ndarray:
        masks = np.asarray(masks, dtype=bool)
        if masks.ndim == 2:
            masks = masks[None]
        if self.cut_wrist:
            masks = _cut(masks, kps, self.previous, self.hand, self.rig)
        return masks

    def keypoint_frame(self, masks, kps, world=None) -> _Frame:
        """Rule 1: the keypoint-first fit from the prediction; rule 2: a lost one is
        fitted again directly from the keypoints, and the better kept.

        `masks`: a callable giving the frame's silhouettes, for their IoU with the fit
        (`RecoverySettings.keypoint_iou`), or None (IoU not measured).
        """
        t0 = time.perf_counter()
        tracker = self.tracker
        self._silhouettes = self._silhouette_data(masks)
        fit, mirrored, scale = self._from_prediction(kps, world)
        fit, again = self._from_keypoints(fit, kps, world)
        if fit is None:  # no palm to start from: nothing to track yet
            return _Frame(None, self._nan_pose(), keypoints=True, no_hand=not self.started)
        if not again:
            self.scale = scale
        if mirrored and not again:  # the other side in depth: the predictor restarts
            tracker.reset(fit.pose)
        else:
            tracker.accept(fit.pose)
        self.started = True
        self.previous = fit.pose
        t2 = time.perf_counter()
        iou = np.full(len(self.rig), np.nan)
        empty = np.zeros(len(self.rig), dtype=bool)
        if masks is not None and self.settings.keypoint_iou:
            m = masks()
            empty = ~m.any(axis=(1, 2))
            kp = frame_keypoints(kps, len(self.rig))
            iou = tracker._quality(fit.pose, m, kp, empty)[0]
        t3 = time.perf_counter()
        result = FrameResult(
            fit.pose, fit.pose, np.empty(0), 0, np.array([t3 - t2, t2 - t0, 0.0]), iou,
            fit.cost, fit.error, self._lost(fit), empty,
        )  # fmt: skip
        distances = joint_distances(fit.pose, self.hand, self.rig, kps,
                                    tips=self.fit_settings.tips)  # fmt: skip
        out = _Frame(result, fit.pose, again, bool(empty.all()), True, False, fit.n_rejected,
                     np.where(fit.rejected, np.nan, distances))  # fmt: skip
        if self._shape_frames is not None and not result.lost:
            self._adapt(out, kps, world)
        return out

    def _from_prediction(self, kps, world):
        """Rule 1 of `keypoint_frame`: the keypoints fitted from the prediction (with
        one camera, from its mirror image in depth if better), continued with the
        temporal prior, digits re-seeded and, in a rig, a camera left out.

        Returns
        -------
        fit : FrameFit or None
            None before the track started (no prediction yet).
        mirrored : bool
            The fit is the mirrored one (the predictor restarts there).
        scale : PriorScale
            The prior's scale after this frame (kept unless rule 2 re-initialises).
        """
        fit, mirrored, scale = None, False, self.scale
        if not self.started:
            return fit, mirrored, scale
        # the keypoints alone first, from the prediction: how far that fit lies from
        # the prediction is the predictor's accuracy (measured after the prior had
        # pulled the fit towards the prediction it would confirm itself)
        prediction = self.tracker.prediction()
        fit = self._fit(kps, prediction, world)
        if self.settings.depth_mirror and len(self.rig) == 1 and not self._lost(fit):
            alt = self._mirrored(fit, kps, world)
            if alt is not None:
                fit, mirrored = alt, True
        if not mirrored and self._with_prior():
            scale = self.scale.update(fit.pose, prediction)
            fit = self._prior_stage(fit, kps, world, prediction, scale)
        if self.settings.keypoint_reseeds and not self._lost(fit):
            fit = self._reseed_digits(fit, kps, world, prediction, scale)
        if len(self.rig) > 1:
            fit = self._leave_camera_out(fit, kps, world, prediction, scale)
        return fit, mirrored, scale

    def _from_keypoints(self, fit, kps, world):
        """Rule 2 of `keypoint_frame`: with no `fit`, or a lost one (or, with
        `RecoverySettings.restart`, one with keypoints off), the pose fitted directly
        from the keypoints (`reinitialise`), kept if better; a lost fit replaced is a
        re-initialisation, where the predictor restarts.

        Returns
        -------
        fit : FrameFit or None
            The fit kept; None when there was none and no palm to start from.
        again : bool
            The frame was re-initialised.
        """
        lost = fit is None or self._lost(fit)
        restart = not lost and self.settings.restart and fit.n_off > 0
        if not (fit is None or (self.settings.reinit and (lost or restart))):
            return fit, False
        t1 = time.perf_counter()
        direct = reinitialise(kps, self.rig, self.hand, world=world,
                              silhouettes=self._silhouettes,
                              settings=self.fit_settings,
                              shapes=self.settings.reinit_shapes)  # fmt: skip
        if lost:
            self.init_seconds.append(time.perf_counter() - t1)
        if direct is None or not (fit is None or direct.order < fit.order):
            return fit, False
        if lost:  # a re-initialisation: the predictor restarts there
            self.tracker.reset(direct.pose)
            self.scale = PriorScale()
        return direct, lost

    def _silhouette_data(self, masks) -> FrameData | None:
        """The frame's silhouettes prepared for the fit's silhouette term, or None (no
        term, or no silhouette in any camera)."""
        if masks is None or self.fit_settings.silhouette <= 0:
            return None
        m = masks()
        return prepare_frame(m, self.rig) if m.any() else None

    def _mirrored(self, fit, kps, world):
        """Rule 1 with one camera: the fit started again from its palm mirrored in
        depth (`depth_mirror`), `RecoverySettings.depth_mirror` steps, then to the end
        if it is ahead; returned if it explains the keypoints better (no more of them
        rejected or off, a lower cost), else None.

        Why: one camera sees a tilted palm and its mirror image in depth alike, and a
        fit from the prediction stays on the side it came from, wrong after the palm
        has turned through edge-on.  The joint limits and perspective tell the two
        apart where the keypoints can; the temporal prior, which pulls towards the
        side of the prediction, is left out of the comparison.
        """

        def better(alt) -> bool:
            return alt.order[0] <= fit.order[0] and alt.cost < fit.cost

        start = depth_mirror(fit.pose, self.hand, self.rig.cameras[0])
        alt = self._fit(kps, start, world, self._mirror_settings)
        if not better(alt):
            return None
        alt = self._fit(kps, alt.pose, world)
        return alt if better(alt) else None

    def _reseed_digits(self, fit, kps, world, prediction, scale):
        """Rule 1's second look (`RecoverySettings.keypoint_reseeds`): each digit with a
        keypoint rejected or off is fitted again from the named shapes' angles; the
        best fit by `FrameFit.order` is kept.

        Why: a digit that the fit from the prediction left in a wrong local minimum
        (a finger bent the wrong way after a fast motion) has its keypoints rejected as
        outliers, and once rejected they no longer pull it back; the prediction carries
        the wrong digit into the next frame.  A fresh start of that digit alone lets its
        keypoints decide again, without moving the palm or the other digits.
        """
        d = np.nan_to_num(fit.distances, nan=0.0)
        bad = (fit.rejected | (d > CHECK_THRESHOLD)).any(axis=0)
        digits = sorted({JOINT_DIGIT[i] for i in np.flatnonzero(bad)} - {-1})
        for digit in digits:
            angles = digit_angles(digit)
            for name in self.settings.keypoint_reseeds:
                start = fit.pose.copy()
                start[angles] = named_pose(name)[angles]
                again = self._fit(kps, start, world)
                if self._with_prior():
                    again = self._prior_stage(again, kps, world, prediction, scale)
                if again.order < fit.order:
                    fit = again
        return fit

    def _leave_camera_out(self, fit, kps, world, prediction, scale):
        """Rule 1 in a rig of cameras: a fit that rejects more than half of some camera's
        keypoints is fitted again (as rule 1, from the prediction) without the camera
        whose keypoints lie farthest from the prediction's projection (median over its
        points, hand sizes); that fit is kept if every camera left in keeps at least
        half of its keypoints, the camera left out counted as rejected.

        Why: a detector that places the whole hand wrongly in one camera (a shift, the
        other hand) leaves a fit that compromises between the cameras and rejects points
        in all of them.  Which camera is wrong the keypoints of two cameras cannot tell
        (each alone is explained by some pose); the motion can.
        """
        kp = frame_keypoints(kps, len(self.rig))
        present = kp[:, :, 2] > 0
        cameras = np.flatnonzero(present.any(axis=1))
        if len(cameras) < 2 or not np.any(_rejected_share(fit, present) > 0.5):
            return fit
        d = keypoint_distances(kps, self.rig, self.hand, prediction, settings=self.fit_settings)
        # a camera none of whose keypoints can be compared with the prediction goes first
        far = [np.nanmedian(d[c]) if np.isfinite(d[c]).any() else np.inf for c in cameras]
        j = cameras[int(np.argmax(far))]
        kept = [None if i == j else k for i, k in enumerate(kps)]
        again = self._fit(kept, prediction, world)
        if self._with_prior():
            again = self._prior_stage(again, kept, world, prediction, scale)
        share = _rejected_share(again, present)
        share[j] = 0.0
        if np.any(share > 0.5):
            return fit
        d = keypoint_distances(kps, self.rig, self.hand, again.pose, settings=self.fit_settings)
        rejected = again.rejected.copy()
        rejected[j] = present[j]
        return FrameFit(again.pose, d, rejected, again.cost, again.iterations)

    def _fit(self, kps, start, world, settings=None, **prior) -> FrameFit:
        """`fit_frame` of this frame's keypoints from `start` (the fit's settings unless
        others are given), with the frame's silhouettes when the fit has their term."""
        return fit_frame(kps, self.rig, self.hand, start, world=world,
                         silhouettes=self._silhouettes,
                         settings=self.fit_settings if settings is None else settings,
                         **prior)  # fmt: skip

    def _with_prior(self) -> bool:
        """Whether rule 1 has its second stage, the temporal prior."""
        return self.tracker.frames_tracked > 0 and self.settings.prior_steps > 0

    def _prior_stage(self, fit, kps, world, prediction, scale):
        """Rule 1's second stage: `fit` continued with the temporal prior of σ `scale`."""
        return self._fit(kps, fit.pose, world, self._prior_settings, prior=prediction,
                         prior_scale=scale)  # fmt: skip

    def _adapt(self, frame: _Frame, kps, world) -> None:
        """The shape fit (`RecoverySettings.shape`): keep every `ShapeFitSettings.stride`-th
        frame with keypoints while fewer than `ShapeFitSettings.frames` are kept; with
        that many, fit the hand's proportions to them, track with that hand from now on
        and re-fit their poses with it, and those of the frames between."""
        s = self.settings.shape
        kp = frame_keypoints(kps, len(self.rig))
        if int((kp[:, :, 2] > 0).sum(axis=1).max()) < s.min_points:
            return
        if len(self._shape_between) < len(self._shape_frames) * (s.stride - 1):
            self._shape_between.append((frame, kps, world))
            return
        self._shape_frames.append((frame, kps, world))
        if len(self._shape_frames) < s.frames:
            return
        from handvar.hand import HandModel

        frames, self._shape_frames = self._shape_frames, None
        t0 = time.perf_counter()
        fit = fit_shape([k for _, k, _ in frames], self.rig, self.hand,
                        [f.pose for f, _, _ in frames], world=[w for _, _, w in frames],
                        settings=s, frame_settings=self.fit_settings)  # fmt: skip
        self.hand = HandModel(fit.shape, surface=self.hand.surface)
        self.tracker.set_hand(self.hand)
        if self._refiner is not None:
            self._refiner.set_hand(self.hand)
        between, self._shape_between = self._shape_between, []
        again = [  # without silhouettes: the frame's own are not kept
            fit_frame(k, self.rig, self.hand, f.pose, world=w, settings=self.fit_settings).pose
            for f, k, w in between
        ]
        poses = [*fit.poses, *again]
        for (f, k, _), x in zip([*frames, *between], poses, strict=True):
            f.pose = x
            f.result = dataclasses.replace(f.result, pose=x)
            d = joint_distances(x, self.hand, self.rig, k, tips=self.fit_settings.tips)
            f.distances = np.where(np.isnan(f.distances), np.nan, d)
        self.tracker.reset(fit.poses[-1])
        self.previous = fit.poses[-1]
        self.scale = PriorScale()
        self.shape_seconds = time.perf_counter() - t0

    def no_hand(self, masks) -> bool:
        """Rule 3: no silhouette, or none where the predicted hand would be."""
        if not masks.any():
            return True
        if self.previous is None:
            return False
        from handvar.render import silhouettes

        model = silhouettes(self.hand, self.tracker.prediction(), self.rig)
        iou = silhouette_iou(model, masks)
        return not np.nanmax(iou) >= self.settings.no_hand_iou

    def silhouette_frame(self, masks, empty: bool) -> _Frame:
        """The paper's silhouette tracker from the prediction, as without keypoints;
        rules 4-6 (a track without keypoints): a lost fit is refined, then searched
        again, and one under `refine_iou` re-seeded digit by digit."""
        s, tracker = self.settings, self.tracker
        if not self.started and not empty:
            if self.previous is None:
                self._search(masks)
            self.started = True
        if not self.started:
            return _Frame(None, self._nan_pose(), empty=True)
        before = copy.deepcopy(tracker.predictor)
        best = _quiet_step(tracker, masks, None)
        base, learned, again = before, True, False
        if not empty and best is not None and best.lost and s.refine_iterations:
            refined = self._refine(best, masks)
            if _better(refined, best):
                best, learned = refined, False
        if s.reinit and not empty and (best is None or best.lost):
            best, base, learned = self._search_again(best, base, masks)
            again = True
        if (s.reseed_digits and s.refine_iterations and not empty and best is not None
                and best.mean_iou < s.refine_iou):  # fmt: skip
            best, learned = self._reseed_silhouette_digits(best, learned, masks)
        if best is not None and not learned:  # the predictor learns the fit kept
            if tracker.frames_tracked == 0:
                tracker.reset(best.pose)
            _restore(tracker, base)
            tracker.predictor.update(best.pose)
        if best is None:  # diverged and not recovered: keep the last finite pose
            pose = self._nan_pose()
            if self.previous is not None:
                tracker.reset(self.previous)
        else:
            pose = self.previous = best.pose
        return _Frame(best, pose, again, empty)

    def _search_again(self, best, base, masks):
        """Rule 4's search of `silhouette_frame`: a lost (or diverged) frame's pose
        searched again from the silhouettes and tracked from there, then refined if
        still lost; the best of those and `best` kept.

        Returns
        -------
        best : FrameResult or None
        base : predictor
            The predictor state the fit kept was made from (restored before it learns).
        learned : bool
            The predictor has already learned the fit kept.
        """
        tracker = self.tracker
        self._search(masks)
        learned = False
        restarted = copy.deepcopy(tracker.predictor)
        r2 = _quiet_step(tracker, masks, None)
        if _better(r2, best):
            best, base, learned = r2, restarted, True
        if r2 is not None and r2.lost and self.settings.refine_iterations:
            refined = self._refine(r2, masks)
            if _better(refined, best):
                best, base, learned = refined, restarted, False
        return best, base, learned

    def _reseed_silhouette_digits(self, best, learned: bool, masks):
        """Rule 4's re-seeding of `silhouette_frame`: each start of `digit_reseeds`
        refined, kept if its IoU is `RecoverySettings.reseed_margin` above the best's
        and it is better.  Returns the best and whether the predictor learned it."""
        s = self.settings
        for start in digit_reseeds(best.pose, self.hand, self.rig, masks, s.reseed_digits):
            refined = self._refine(dataclasses.replace(best, pose=start), masks)
            if (refined is not None and refined.mean_iou >= best.mean_iou + s.reseed_margin
                    and _better(refined, best)):  # fmt: skip
                best, learned = refined, False
        return best, learned

    # -- helpers ----------------------------------------------------------------------

    def _lost(self, fit) -> bool:
        """A keypoint fit is lost when its kept keypoints lie farther than the lost
        rule's keypoint error on average, or when it rejects more than half of them in
        every camera that has some (a camera left out whole by `_leave_camera_out` does
        not make the frame lost)."""
        present = ~np.isnan(fit.distances)
        cameras = present.any(axis=1)
        q = self.tracker.settings.quality
        most = cameras.any() and bool(np.all(_rejected_share(fit, present)[cameras] > 0.5))
        return bool(fit.error > q.lost_keypoint_error or most)

    def _nan_pose(self) -> np.ndarray:
        return np.full(N_PARAMS, np.nan) if self.previous is None else self.previous

    def _search(self, masks) -> None:
        t0 = time.perf_counter()
        tracker = self.tracker
        result = initial_pose(masks, self.rig, self.hand, rng=tracker.rng,
                              tracker_settings=tracker.settings, **self.init_kw)  # fmt: skip
        tracker.reset(result.pose)
        self.init_seconds.append(time.perf_counter() - t0)

    def _refine(self, r, masks):
        """`r` refined: the optimiser continues from it, with fresh gains, no motion."""
        tracker = self.tracker
        if self._refiner is None:
            smd = dataclasses.replace(
                tracker.settings.smd, max_iterations=self.settings.refine_iterations
            )
            # its own generator, spawned from the tracker's without drawing from it
            self._refiner = Tracker(self.rig, self.hand, NoMotion(), tracker.rng.spawn(1)[0],
                                    dataclasses.replace(tracker.settings, smd=smd))  # fmt: skip
        self._refiner.reset(r.pose)
        r2 = _quiet_step(self._refiner, masks, None)
        if r2 is None:
            return None
        return dataclasses.replace(
            r2, start=r.start, costs=np.concatenate([r.costs, r2.costs]),
            iterations=r.iterations + r2.iterations, seconds=r.seconds + r2.seconds,
        )  # fmt: skip

    # -- a whole track ----------------------------------------------------------------

    def start(self, x0) -> None:
        """Start the track at pose `x0` (26,) instead of searching or fitting it."""
        self.tracker.reset(x0)
        self.previous = np.asarray(x0, dtype=float)
        self.started = True

    def step(self, masks, kps, world=None, *, with_keypoints: bool = False,
             absent: bool = False) -> tuple[_Frame, float]:  # fmt: skip
        """`frame`, timed: the frame kept and its wall time, seconds; `kps` without a
        detected point is taken as None."""
        t0 = time.perf_counter()
        f = self.frame(masks, kps if _present(kps) else None, world,
                       with_keypoints=with_keypoints, absent=absent)  # fmt: skip
        return f, time.perf_counter() - t0

    def result(self, frames: list[_Frame], seconds, *, keypoints: bool) -> RecoveredTrack:
        """The track of the `frames` kept (in order) and their wall times.

        Raises
        ------
        ValueError
            No frame; or, a track without `keypoints`, no frame to start it in.
        """
        if not frames:
            raise ValueError("frames: expected at least one frame; got none")
        if not self.started and not keypoints:
            raise ValueError(
                f"frames: expected a frame with a silhouette to search the first pose in; "
                f"all {len(frames)} are empty"
            )
        max_it = self.tracker.settings.smd.max_iterations
        tips = self.tracker.settings.cost.keypoint_tips
        return _assemble(frames, self.hand, tips, len(self.rig), max_it, self.init_seconds,
                         np.asarray(seconds, dtype=float))  # fmt: skip

    def run(self, frames: Iterable, x0=None, *, keypoints=None, world=None,
            on_frame: Callable | None = None) -> RecoveredTrack:  # fmt: skip
        """Track `frames` from `x0` (`track_with_recovery`)."""
        if x0 is not None:
            self.start(x0)
        out: list[_Frame] = []
        seconds: list[float] = []
        for i, masks in enumerate(frames):
            f, s = self.step(masks, _at(keypoints, i), _at(world, i),
                             with_keypoints=keypoints is not None)  # fmt: skip
            out.append(f)
            seconds.append(s)
            if on_frame is not None:
                on_frame(i, f.pose, _frame_quality(f.result, f.empty or f.no_hand), masks)
        return self.result(out, seconds, keypoints=keypoints is not None)


def _at(values, i):
    if values is None:
        return None
    if callable(values):
        return values(i)
    return values[i] if i < len(values) else None


def _rejected_share(fit, present) -> np.ndarray:
    """Per camera, the share of its keypoints `fit` rejected (0 for a camera without)."""
    return fit.rejected.sum(axis=1) / np.maximum(present.sum(axis=1), 1)


def _better(a, b) -> bool:
    return _score(a) > _score(b)


def track_with_recovery(
    tracker: Tracker,
    frames: Iterable,
    x0=None,
    *,
    keypoints: Sequence | Callable | None = None,
    world: Sequence | Callable | None = None,
    settings: RecoverySettings = RECOVERY_DEFAULTS,
    init_settings: InitSettings | None = None,
    cut_wrist: bool = False,
    on_frame: Callable | None = None,
) -> RecoveredTrack:
    """Track frame by frame with the keypoint-first fit and the recovery's rules.

    Parameters
    ----------
    tracker : Tracker
        The tracker (its rig, hand, predictor, generator and settings, with the lost
        rule's thresholds, are used).
    frames : iterable of (n_cams, H, W) bool array_like
        The silhouettes of each frame, in order.
    x0 : (26,) array_like, optional
        Pose at the first frame; by default fitted to the first frame's keypoints, or
        searched in its silhouettes (a track without keypoints).
    keypoints : sequence or callable, keyword-only, optional
        ``keypoints[i]`` (or ``keypoints(i)``) for the i-th frame: per camera a (21, 3)
        array (x, y in the masks' pixels, confidence) or None, or None for a frame
        without keypoints.
    world : sequence or callable, keyword-only, optional
        ``world[i]``: the detector's 3D joints of frame i, (21, 3) mm (any origin, as
        the first camera looking along the ray through the palm sees them:
        `handvar.tracking.frame_fit`), or None: a weak cue of the fit.
    settings : RecoverySettings, keyword-only
    init_settings : InitSettings, keyword-only, optional
        Settings of the silhouette pose search.
    cut_wrist : bool, keyword-only
        `frames` are silhouettes with the forearm still on; cut each camera's at the
        wrist here (`handvar.vision.silhouette.cut_wrist`): the detected one on a frame
        with keypoints, else the previous frame's fitted model's
        (`model_wrist_keypoints`).
    on_frame : callable, keyword-only, optional
        Called as ``on_frame(i, pose, quality, masks)`` after each frame, quality a
        `FrameQuality` and masks the silhouettes given.

    Returns
    -------
    RecoveredTrack
        The track (`TrackResult`) and its `TrackQuality`.

    Raises
    ------
    ValueError
        No frame, or without `x0` no frame with a silhouette to search the pose in.
    """
    recovery = Recovery(tracker, settings=settings, init_settings=init_settings,
                        cut_wrist=cut_wrist)  # fmt: skip
    return recovery.run(frames, x0, keypoints=keypoints, world=world, on_frame=on_frame)


def digit_reseeds(x, hand, rig, masks, n: int) -> list[np.ndarray]:
    """Starts for a new fit: `x` with one digit set to a named hand shape's (design §14.3).

    For each digit and each named shape (`handvar.hand.kinematics.POSE_NAMES`), the
    digit's abduction and three flexions are set to that shape's; a setting within 10°
    of `x`'s in every angle, or of one already made, is skipped.  Each start's model is
    rendered and scored by its silhouette IoU against `masks`, and the `n` best are
    returned, best first.  The silhouette cost pulls a model's outline towards the
    silhouette's but cannot move a digit lying inside it; set elsewhere, the digit
    starts where the silhouette's own terms can place it.

    Parameters
    ----------
    x : (26,) array_like
        The fitted pose.
    hand : HandModel
    rig : Rig
    masks : (n_cams, H, W) bool array_like
        The frame's silhouettes, as the fit saw them.
    n : int
        How many starts to return.

    Returns
    -------
    list of (26,) ndarray
        At most `n` poses, each differing from `x` in one digit's four angles.
    """
    from handvar.params import DIGITS
    from handvar.render import silhouettes
    from handvar.tracking.init import silhouette_iou

    x = np.asarray(x, dtype=float)
    shapes = np.stack([named_pose(name) for name in POSE_NAMES])
    scored = []
    for d in range(len(DIGITS)):
        angles = digit_angles(d)
        made = [x[angles]]
        for values in shapes[:, angles]:
            if any(np.all(np.abs(values - m) <= 10.0) for m in made):
                continue
            made.append(values)
            start = x.copy()
            start[angles] = values
            scored.append((silhouette_iou(silhouettes(hand, start, rig), masks), start))
    scored.sort(key=lambda t: -t[0])
    return [start for _, start in scored[:n]]


def model_wrist_keypoints(x, hand, camera) -> np.ndarray | None:
    """The wrist and middle MCP of pose `x` seen by `camera`, as (21, 3) keypoints.

    The other 19 points are missing (confidence 0); None for a non-finite pose.  Given
    to `handvar.vision.silhouette.cut_wrist` after `_cut_at_joint`, they cut a silhouette
    at the model's wrist joint, where its hand ends.
    """
    if x is None or not np.all(np.isfinite(x)):
        return None
    k = np.full((21, 3), np.nan)
    k[:, 2] = 0.0
    k[[WRIST, MIDDLE_MCP], :2] = camera.project(hand.joints(x)[[WRIST, MIDDLE_MCP]])
    k[[WRIST, MIDDLE_MCP], 2] = 1.0
    return k


def _cut_at_joint(k: np.ndarray) -> np.ndarray:
    """Keypoints whose `cut_wrist` cut passes through the wrist point itself.

    `cut_wrist` cuts `WristCutSettings.keypoint_offset` (a) hand sizes beyond the wrist
    point, towards the forearm; moving the point a / (1 + a) of the way to the middle
    MCP cancels that.  The tracked model ends at its wrist joint, which is the point a
    detector marks, so the silhouette it is fitted to ends there too (design §14.3).
    """
    from handvar.vision.wrist import WRIST_CUT_SETTINGS

    a = WRIST_CUT_SETTINGS.keypoint_offset
    k = np.array(k, dtype=float)
    k[WRIST, :2] += a / (1.0 + a) * (k[MIDDLE_MCP, :2] - k[WRIST, :2])
    return k


def _cut(masks: np.ndarray, kps, previous, hand, rig) -> np.ndarray:
    """Each camera's silhouette cut at the wrist (`track_with_recovery`'s cut_wrist)."""
    from handvar.vision.wrist import cut_wrist

    out = []
    for j, (m, cam) in enumerate(zip(masks, rig, strict=True)):
        if not m.any():
            out.append(m)
            continue
        k = None if kps is None else kps[j]
        if k is None or not (np.asarray(k)[[WRIST, MIDDLE_MCP], 2] > 0).all():
            k = model_wrist_keypoints(previous, hand, cam)
        out.append(cut_wrist(m, None if k is None else _cut_at_joint(k)))
    return np.stack(out)


def _restore(tracker: Tracker, state) -> None:
    """Put the predictor state `state` (a copy of the tracker's predictor) back in place."""
    if hasattr(tracker.predictor, "__dict__"):
        tracker.predictor.__dict__.clear()
        tracker.predictor.__dict__.update(state.__dict__)
    else:
        tracker.predictor = state


def _frame_quality(r, empty: bool) -> FrameQuality:
    if r is None:
        return FrameQuality(0.0, math.nan, math.nan, not empty)
    return FrameQuality(r.mean_iou, r.keypoint_error, r.cost, bool(r.lost and not empty))


def _assemble(frames, hand, tips, n_cams, max_it, init_seconds, seconds) -> RecoveredTrack:
    """The `TrackResult` and `TrackQuality` of the frames kept by `Recovery`, its joints
    the points `tips` places (`keypoint_points`)."""
    n = len(frames)
    poses = np.array([f.pose for f in frames])
    costs = np.full((n, max_it), np.nan)
    starts = poses.copy()
    iterations = np.zeros(n, dtype=np.int64)
    parts = np.zeros((n, 3))
    iou = np.full((n, n_cams), np.nan)
    final = np.full(n, np.nan)
    kp_err = np.full(n, np.nan)
    lost = np.zeros(n, dtype=bool)
    empty_cams = np.zeros((n, n_cams), dtype=bool)
    distances = np.full((n, n_cams, 21), np.nan)
    for t, f in enumerate(frames):
        empty_cams[t] = f.empty or f.no_hand
        if f.distances is not None:
            distances[t] = f.distances
        r = f.result
        if r is None:
            lost[t] = not (f.empty or f.no_hand)
            continue
        starts[t] = r.start
        costs[t, : r.iterations] = r.costs[:max_it]
        iterations[t] = r.iterations
        parts[t] = r.seconds
        iou[t], final[t], kp_err[t] = r.iou, r.cost, r.keypoint_error
        empty_cams[t] = r.empty
        lost[t] = r.lost and not f.empty
    joints = np.stack(
        [
            keypoint_points(hand, x, tips) if np.all(np.isfinite(x)) else np.full((21, 3), np.nan)
            for x in poses
        ]
    )
    track = TrackResult(
        poses, joints, starts, costs, iterations, parts, iou, final, kp_err, lost, empty_cams
    )
    quality = TrackQuality(
        iou=track.mean_iou,
        keypoint_error=kp_err,
        cost=final,
        lost=lost,
        reinit=np.array([f.reinit for f in frames]),
        empty=np.array([f.empty for f in frames]),
        keypoints=np.array([f.keypoints for f in frames]),
        no_hand=np.array([f.no_hand for f in frames]),
        rejected=np.array([f.rejected for f in frames], dtype=np.int64),
        distances=distances,
    )
    return RecoveredTrack(track, quality, np.array(init_seconds), seconds, hand.shape)


def depth_mirror(x, hand, camera) -> np.ndarray:
    """`x` with its palm reflected in depth: the other pose one camera sees alike.

    In camera coordinates the hand's rotation R becomes M R H, M = diag(1, 1, −1) the
    reflection in depth and H = I − 2 n nᵀ the reflection through the palm's plane
    (n its normal in the hand's frame, across the wrist, the origin, and the index and
    little MCPs, `HandShape.bases`), a rotation again; the hand's origin stays where it
    is and the digits keep their angles.  Under weak perspective the palm projects as before.

    Parameters
    ----------
    x : (26,) array_like
    hand : HandModel
    camera : Camera

    Returns
    -------
    (26,) ndarray
        Within the joint limits.
    """
    x = np.asarray(x, dtype=float)
    n = np.cross(hand.shape.bases[1], hand.shape.bases[4])  # index and little MCP
    n /= np.linalg.norm(n)
    H = np.eye(3) - 2.0 * np.outer(n, n)
    R = camera.R @ world_from_hand_rotation(x[3:6])[0]
    out = x.copy()
    out[3:6] = euler_from_matrix(camera.R.T @ (np.diag([1.0, 1.0, -1.0]) @ R @ H))
    return clamp(out)
