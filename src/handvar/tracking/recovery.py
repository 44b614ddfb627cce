"""Lost frames and recovery: re-initialisation where the fit is lost (§14.3).

The tracker reports every frame's fit quality (`Tracker.step`, design §13): the
silhouette IoU of the fitted model per camera, the final cost, the distance of the
projected joints to the frame's keypoints in hand sizes, and whether the frame is
*lost* (mean IoU below `QualitySettings.lost_iou`, or keypoint error above
`QualitySettings.lost_keypoint_error`).

`track_with_recovery` tracks frame by frame and, on a lost frame (or a keypoint frame
whose fit drifted from its keypoints, `RecoverySettings.refit_keypoint_error`), searches
the pose again in that frame (`handvar.tracking.init.initial_pose`: from the frame's
keypoints when it has them, else the coarse silhouette search), restarts the tracker
there (which resets the motion predictor) and tracks the frame again.  A fit of poor
quality (lost, drifting, or on a frame with keypoints a silhouette IoU below
`RecoverySettings.refine_iou`) is first *refined*: the optimiser continues from it, with
fresh gains, for `RecoverySettings.refine_iterations` more iterations; on a frame with
keypoints a fit still poor after that is searched again from the keypoints.  A fit
whose silhouette IoU is still below `RecoverySettings.refine_iou`, with or without
keypoints, is then started again with one digit at a time set to a named hand shape's
(`digit_reseeds`, `RecoverySettings.reseed_digits`): the silhouette cost cannot bring
out a finger folded inside the silhouette.  On a frame with keypoints a fit still poor
is refined once more with the keypoint term's weight lowered
(`RecoverySettings.refine_keypoint_weight`).  Of all the fits of a frame the best by
its own quality is kept (`_score`: not lost, then the keypoint error down to the re-fit
threshold, then the higher IoU), and the motion predictor learns that one (its state
before the frame is restored when the kept fit is not the last one made).  A frame
still lost after that stays flagged.  A frame with no
silhouette in any camera is not judged: it is carried by the prediction and flagged
*empty* (the tracker leaves a single empty camera out of the fit).  Optionally the loop
cuts the forearm off the silhouettes itself, at the detected wrist or, between keypoint
frames, at the wrist of the model fitted to the previous frame (``cut_wrist``).

For evaluation against a detector, `joint_distances` and `pck` measure the projected
joints against keypoints in the detector's own hand size (its wrist → middle-MCP
distance in that frame), independent of the model.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.params import N_PARAMS
from handvar.predictors import NoMotion
from handvar.tracking.init import InitSettings, initial_pose
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.tracking.keypoint_fit import palm_seen
from handvar.tracking.tracker import Tracker, TrackResult
from handvar.validate import as_float, as_instance, as_int

__all__ = [
    "RECOVERY_DEFAULTS",
    "FrameQuality",
    "RecoveredTrack",
    "RecoverySettings",
    "TrackQuality",
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
    """

    iou: np.ndarray
    keypoint_error: np.ndarray
    cost: np.ndarray
    lost: np.ndarray
    reinit: np.ndarray
    empty: np.ndarray
    keypoints: np.ndarray

    def summary(self) -> str:
        """One line: frames lost, re-initialised and empty, IoU minimum and mean."""
        tracked = ~self.empty & ~np.isnan(self.iou)
        iou = self.iou[tracked]
        text = (
            f"{int(self.lost.sum())} lost, {int(self.reinit.sum())} re-initialised, "
            f"{int(self.empty.sum())} empty"
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
    the first ``max_iterations`` of them.
    """

    track: TrackResult
    quality: TrackQuality
    init_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))


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
        G(x)'s fingertips, or the centres of their pads (`keypoint_points`, §14.6).

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


def _score(r, keypoint_error: float) -> tuple[bool, float, float]:
    """Order of the fits of one frame by their own quality, best highest.

    Not lost first; then the lower keypoint error, down to `keypoint_error` (fits that
    close to their keypoints tie: the keypoints cannot tell them apart, the silhouette
    can); then the higher mean IoU.  Without keypoints only the IoU decides.
    """
    if r is None:
        return (False, -math.inf, -math.inf)
    e = r.keypoint_error
    iou = r.mean_iou
    return (
        not r.lost,
        0.0 if math.isnan(e) else -max(e, keypoint_error),
        -1.0 if math.isnan(iou) else iou,
    )


@dataclass(frozen=True)
class RecoverySettings:
    """When `track_with_recovery` searches the pose again (§14.3; the paper has no rule).

    Attributes
    ----------
    reinit : bool
        Search the pose again on a lost frame (False: only flag it).
    refit_keypoint_error : float
        Also search it again, from the keypoints, on a frame with keypoints whose fit
        is off them by more than this, mean over the points, hand sizes (not lost, but
        drifting).  0.1 is half the radius of PCK@0.2, the measure of §14.4: a fit off
        by more than that on average has points outside it.  ``inf`` turns it off.
    refine_iou : float
        Refine a fit on a frame with keypoints whose mean silhouette IoU is below this
        (and any lost or drifting fit): continue the optimisation from it (§14.3).  0.8,
        the IoU asked of every frame in §14.4; 0 refines only lost and drifting fits.
        A frame without keypoints is not refined for its IoU alone (unless
        `refine_without_keypoints`): without keypoints a higher IoU is no sign of a
        better pose (§14.1, §14.3).
    refine_iterations : int
        Iterations of that refinement, from the fit with the optimiser's initial
        gains; 100.  0 turns refinement off.
    refine_without_keypoints : bool
        Refine frames without keypoints for their IoU too; False (§14.3 says what it
        did on the example video).
    reseed_digits : int
        A fit whose mean silhouette IoU is still below `refine_iou` after the
        refinement and the search, with or without keypoints, is tried again with one
        digit at a time set to a named hand shape's (`digit_reseeds`): this many of
        those starts, the best by their silhouette IoU before any fit, are refined, and
        one is kept if better by the order of `_score` (§14.3 step 5); 4.  0 turns it
        off.  The silhouette cost cannot move a digit that lies inside the silhouette
        (a thumb across the palm) to where the silhouette shows it.
    reseed_margin : float
        On a frame without keypoints a re-seeded fit must raise the IoU by at least
        this much to be kept, 0.02: there the IoU is the only judge, and a digit moved
        for a smaller gain is as likely to be wrong as right.
    refine_keypoint_weight : float
        On a frame with keypoints whose fit is still poor after that (and after the
        search), one more refinement with the keypoint term's weight scaled by this
        (0.3: w_k = 30 for the tracker's 100, §14.2): where the detector and the
        silhouette disagree, the silhouette gets a larger say, and the fit is kept
        if better by the order of `_score` (its joints within `refit_keypoint_error`
        of the keypoints, or a lost fit no longer lost), or under
        `refine_keypoint_band` (its recorded cost is that of the scaled weight).  1
        turns it off.
    refine_keypoint_band : float
        That last refinement is also kept when it raises the silhouette IoU, is not
        lost and its joints stay within this many hand sizes of the keypoints (mean
        over the points); 0.15, three quarters of the PCK@0.2 radius.  It runs only on a
        frame still under `refine_iou` after every other fit: there the detector and
        the silhouette disagree (on the hand edge-on the detected MCPs lie up to 0.27
        hand sizes from where the silhouette puts them, §14.4), and the silhouette may
        decide what the keypoints leave within this band.  Set it to
        `refit_keypoint_error` to keep only fits by `_score`'s order.
    """

    reinit: bool = True
    refit_keypoint_error: float = 0.1
    refine_iou: float = 0.8
    refine_iterations: int = 100
    refine_without_keypoints: bool = False
    reseed_digits: int = 4
    reseed_margin: float = 0.02
    refine_keypoint_weight: float = 0.3
    refine_keypoint_band: float = 0.15

    def __post_init__(self) -> None:
        as_instance(self.reinit, bool, "reinit")
        as_float(self.refit_keypoint_error, "refit_keypoint_error", minimum=0.0,
                 exclusive_minimum=True)  # fmt: skip
        as_float(self.refine_iou, "refine_iou", minimum=0.0, maximum=1.0)
        as_int(self.refine_iterations, "refine_iterations", minimum=0)
        as_instance(self.refine_without_keypoints, bool, "refine_without_keypoints")
        as_int(self.reseed_digits, "reseed_digits", minimum=0)
        as_float(self.reseed_margin, "reseed_margin", minimum=0.0, maximum=1.0)
        as_float(self.refine_keypoint_weight, "refine_keypoint_weight", minimum=0.0,
                 maximum=1.0, exclusive_minimum=True)  # fmt: skip
        as_float(self.refine_keypoint_band, "refine_keypoint_band", minimum=0.0)


RECOVERY_DEFAULTS = RecoverySettings()


def track_with_recovery(
    tracker: Tracker,
    frames: Iterable,
    x0=None,
    *,
    keypoints: Sequence | Callable | None = None,
    settings: RecoverySettings = RECOVERY_DEFAULTS,
    init_settings: InitSettings | None = None,
    cut_wrist: bool = False,
    on_frame: Callable | None = None,
) -> RecoveredTrack:
    """Track frame by frame, refine poor fits, re-initialise lost ones (module notes).

    Parameters
    ----------
    tracker : Tracker
        The tracker (its rig, hand, predictor, generator and settings, with the lost
        rule's thresholds, are used).
    frames : iterable of (n_cams, H, W) bool array_like
        The silhouettes of each frame, in order.
    x0 : (26,) array_like, optional
        Pose at the first frame; by default `initial_pose` of the first frame.
    keypoints : sequence or callable, keyword-only, optional
        ``keypoints[i]`` (or ``keypoints(i)``) for the i-th frame: per camera a (21, 3)
        array (x, y in the masks' pixels, confidence) or None, or None for a frame
        without keypoints.  They go into the tracker's cost, its quality and the
        re-initialisation.
    settings : RecoverySettings, keyword-only
        When to search the pose again.
    init_settings : InitSettings, keyword-only, optional
        Settings of the pose search.
    cut_wrist : bool, keyword-only
        `frames` are silhouettes with the forearm still on; cut each camera's at the
        wrist here (`handvar.vision.silhouette.cut_wrist`), across the wrist → middle
        MCP line through the wrist point: the detected one on a frame with keypoints,
        else the previous frame's fitted model's (`model_wrist_keypoints`); before any
        fit, where the forearm's width changes.  Meant for tracks with keypoints, which keep
        the model, and so its wrist, anchored.
    on_frame : callable, keyword-only, optional
        Called as ``on_frame(i, pose, quality, masks)`` after each frame, quality a
        `FrameQuality` and masks the silhouettes tracked (for overlays written while
        tracking).

    Returns
    -------
    RecoveredTrack
        The track (`TrackResult`) and its `TrackQuality`.

    Raises
    ------
    ValueError
        No frame, or without `x0` no frame with a silhouette to search the pose in.
    """
    as_instance(tracker, Tracker, "tracker")
    as_instance(settings, RecoverySettings, "settings")
    init_kw = {} if init_settings is None else {"settings": init_settings}
    hand, rig = tracker.hand, tracker.rig
    max_it = tracker.settings.smd.max_iterations

    def frame_keypoints(i):
        if keypoints is None:
            return None
        kps = (
            keypoints(i) if callable(keypoints) else (keypoints[i] if i < len(keypoints) else None)
        )
        return kps if _present(kps) else None

    def search(masks, kps):
        t0 = time.perf_counter()
        result = initial_pose(
            masks, rig, hand, keypoints=kps, rng=tracker.rng,
            tracker_settings=tracker.settings, **init_kw,
        )  # fmt: skip
        tracker.reset(result.pose)
        return time.perf_counter() - t0

    refiners: dict[float, Tracker] = {}  # continue a fit: no motion, refine_iterations

    def refine(r, masks, kps, weight: float = 1.0):
        """`r` refined, the keypoint term's weight scaled by `weight`."""
        if weight not in refiners:
            smd = dataclasses.replace(
                tracker.settings.smd, max_iterations=settings.refine_iterations
            )
            cost = tracker.settings.cost
            cost = dataclasses.replace(cost, weight_keypoints=weight * cost.weight_keypoints)
            # its own generator, spawned from the tracker's without drawing from it: the
            # frames that need no refinement are fitted with the same draws as without it
            refiners[weight] = Tracker(
                rig, hand, NoMotion(), tracker.rng.spawn(1)[0],
                dataclasses.replace(tracker.settings, smd=smd, cost=cost),
            )  # fmt: skip
        refiner = refiners[weight]
        refiner.reset(r.pose)
        r2 = _quiet_step(refiner, masks, kps)
        if r2 is None:
            return None
        return dataclasses.replace(
            r2, start=r.start, costs=np.concatenate([r.costs, r2.costs]),
            iterations=r.iterations + r2.iterations, seconds=r.seconds + r2.seconds,
        )  # fmt: skip

    def drifting(r, kps) -> bool:
        return kps is not None and r.keypoint_error > settings.refit_keypoint_error

    def poor(r, kps) -> bool:
        if r is None or settings.refine_iterations == 0:
            return False
        # without keypoints a higher IoU is no better pose (§14.1): refined only when lost
        judged = kps is not None or settings.refine_without_keypoints
        return r.lost or drifting(r, kps) or (judged and r.mean_iou < settings.refine_iou)

    def better(a, b) -> bool:
        thr = settings.refit_keypoint_error
        return _score(a, thr) > _score(b, thr)

    results, flags, init_seconds = [], [], []
    previous = None if x0 is None else np.asarray(x0, dtype=float)
    started = False
    for i, masks in enumerate(frames):
        masks = np.asarray(masks, dtype=bool)
        if masks.ndim == 2:
            masks = masks[None]
        kps = frame_keypoints(i)
        if cut_wrist:
            masks = _cut(masks, kps, previous, hand, rig)
        empty = not masks.any()
        if not started and not empty:
            if x0 is None:
                init_seconds.append(search(masks, kps))
            else:
                tracker.reset(x0)
            started = True
        if not started:  # nothing seen yet: nothing to track from
            pose = np.full(N_PARAMS, np.nan) if previous is None else previous
            results.append(None)
            flags.append((pose, False, True, kps is not None))
            if on_frame is not None:
                on_frame(i, pose, FrameQuality(math.nan, math.nan, math.nan, False), masks)
            continue
        before = copy.deepcopy(tracker.predictor)  # its state before this frame
        r = _quiet_step(tracker, masks, kps)
        # `learned`: the tracker's predictor was last updated with `best`
        best, base, learned = r, before, True
        if not empty and poor(r, kps):
            refined = refine(r, masks, kps)
            if better(refined, best):
                best, learned = refined, False
        again = False
        if (
            settings.reinit
            and not empty
            and (
                best is None
                or best.lost
                or (palm_seen(kps) and (drifting(best, kps) or poor(best, kps)))
            )
        ):  # a fit not lost is searched again only from keypoints that give a pose
            init_seconds.append(search(masks, kps))
            again, learned = True, False
            restarted = copy.deepcopy(tracker.predictor)
            r2 = _quiet_step(tracker, masks, kps)
            if better(r2, best):
                best, base, learned = r2, restarted, True
            if poor(r2, kps):
                refined = refine(r2, masks, kps)
                if better(refined, best):
                    best, base, learned = refined, restarted, False
        if (
            settings.reseed_digits
            and settings.refine_iterations
            and not empty
            and best is not None
            and best.mean_iou < settings.refine_iou
        ):  # a digit the silhouette cannot move: start it elsewhere (§14.3 step 5)
            gain = settings.reseed_margin if kps is None else 0.0
            for start in digit_reseeds(best.pose, hand, rig, masks, settings.reseed_digits):
                refined = refine(dataclasses.replace(best, pose=start), masks, kps)
                if (
                    refined is not None
                    and refined.mean_iou >= best.mean_iou + gain
                    and better(refined, best)
                ):
                    best, learned = refined, False
        w = settings.refine_keypoint_weight
        if kps is not None and w < 1.0 and poor(best, kps):  # silhouette and keypoints disagree
            refined = refine(best, masks, kps, w)
            if better(refined, best) or (
                refined is not None
                and not refined.lost
                and refined.keypoint_error <= settings.refine_keypoint_band
                and refined.mean_iou > best.mean_iou
            ):  # a better silhouette fit, the joints within the band (§14.3 step 6)
                best, learned = refined, False
        if best is not None and not learned:  # the predictor learns the fit kept
            if tracker.frames_tracked == 0:  # the restart's step diverged
                tracker.reset(best.pose)
            _restore(tracker, base)
            tracker.predictor.update(best.pose)
        r = best
        if r is None:  # diverged and not recovered: keep the last finite pose
            pose = np.full(N_PARAMS, np.nan) if previous is None else previous
            if previous is not None:
                tracker.reset(previous)
        else:
            pose = r.pose
            previous = pose
        results.append(r)
        flags.append((pose, again, empty, kps is not None))
        if on_frame is not None:
            on_frame(i, pose, _frame_quality(r, empty), masks)
    if not results:
        raise ValueError("frames: expected at least one frame; got none")
    if not started and x0 is None:
        raise ValueError(
            f"frames: expected a frame with a silhouette to search the first pose in; "
            f"all {len(results)} are empty"
        )
    return _assemble(results, flags, hand, len(rig), max_it, init_seconds)


def digit_reseeds(x, hand, rig, masks, n: int) -> list[np.ndarray]:
    """Starts for a new fit: `x` with one digit set to a named hand shape's (§14.3).

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
    from handvar.hand.kinematics import POSE_NAMES, named_pose
    from handvar.params import DIGITS, digit_angles
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
    detector marks, so the silhouette it is fitted to ends there too (§14.3).
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


def _assemble(results, flags, hand, n_cams, max_it, init_seconds) -> RecoveredTrack:
    """The `TrackResult` and `TrackQuality` of the frames' results."""
    n = len(results)
    poses = np.array([f[0] for f in flags])
    costs = np.full((n, max_it), np.nan)
    starts = poses.copy()
    iterations = np.zeros(n, dtype=np.int64)
    seconds = np.zeros((n, 3))
    iou = np.full((n, n_cams), np.nan)
    final = np.full(n, np.nan)
    kp_err = np.full(n, np.nan)
    lost = np.zeros(n, dtype=bool)
    empty_cams = np.zeros((n, n_cams), dtype=bool)
    for t, (r, f) in enumerate(zip(results, flags, strict=True)):
        empty_cams[t] = f[2]
        if r is None:
            lost[t] = not f[2]
            continue
        starts[t] = r.start
        costs[t, : r.iterations] = r.costs[:max_it]
        iterations[t] = r.iterations
        seconds[t] = r.seconds
        iou[t], final[t], kp_err[t] = r.iou, r.cost, r.keypoint_error
        empty_cams[t] = r.empty
        lost[t] = r.lost and not f[2]
    joints = np.stack(
        [hand.joints(x) if np.all(np.isfinite(x)) else np.full((21, 3), np.nan) for x in poses]
    )
    track = TrackResult(
        poses, joints, starts, costs, iterations, seconds, iou, final, kp_err, lost, empty_cams
    )
    quality = TrackQuality(
        iou=track.mean_iou,
        keypoint_error=kp_err,
        cost=final,
        lost=lost,
        reinit=np.array([f[1] for f in flags]),
        empty=np.array([f[2] for f in flags]),
        keypoints=np.array([f[3] for f in flags]),
    )
    return RecoveredTrack(track, quality, np.array(init_seconds))
