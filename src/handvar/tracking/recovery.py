"""Lost frames and recovery: per-frame fit quality, the lost rule, re-initialisation (§14.3).

The tracker of the paper never asks whether its fit still explains the frame.  Here
every frame gets a *quality*:

- the silhouette IoU of the fitted model with the observed silhouettes (mean over
  cameras, `handvar.tracking.init.silhouette_iou`);
- on a frame with 2D keypoints, the mean distance of the projected joints G(x) to them,
  in *hand sizes* (the detector's wrist → middle-MCP distance in that frame and camera),
  so that the rule does not depend on the image's resolution or the hand's distance;
- the final cost of the optimiser (reported, not judged: its scale depends on the
  frame).

A frame is **lost** when its pose is not finite, its IoU is below
`RecoverySettings.min_iou`, or its keypoint error exceeds
`RecoverySettings.max_keypoint_error`.  `track_with_recovery` tracks frame by frame;
on a lost frame it searches the pose again in that frame
(`handvar.tracking.init.initial_pose`: from the frame's keypoints when it has them,
else the coarse silhouette search), restarts the tracker there (which resets the
predictor) and tracks the frame again.  A frame still lost after that stays flagged.  A
frame with an empty silhouette in any camera is not tracked: it keeps the previous pose,
the predictor is not fed, and the frame is flagged *empty*.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from handvar.params import N_PARAMS
from handvar.tracking.init import InitSettings, initial_pose, silhouette_iou
from handvar.tracking.tracker import Tracker, TrackResult
from handvar.validate import as_float, as_instance

__all__ = [
    "RECOVERY_DEFAULTS",
    "FrameQuality",
    "RecoverySettings",
    "TrackQuality",
    "joint_distances",
    "pck",
    "track_with_recovery",
]

#: Keypoint indices of the wrist and the middle finger's MCP (the hand size).
_WRIST, _MIDDLE_MCP = 0, 9


@dataclass(frozen=True)
class RecoverySettings:
    """The lost rule and the recovery (§14.3; the paper has neither).

    Attributes
    ----------
    min_iou : float
        A frame whose silhouette IoU falls below this is lost.  A correct fit of the
        example video's hand scores 0.7–0.95 (§14.4); a model that slid down the
        forearm or left the hand scores under 0.5.
    max_keypoint_error : float
        A frame with keypoints whose mean joint distance to them exceeds this many hand
        sizes is lost (0.5: half the wrist → middle-MCP distance on average, about
        twice the error of a poor but recognisable fit).
    reinit : bool
        Search the pose again on a lost frame (False: only flag it).
    """

    min_iou: float = 0.5
    max_keypoint_error: float = 0.5
    reinit: bool = True

    def __post_init__(self) -> None:
        as_float(self.min_iou, "min_iou", minimum=0.0, maximum=1.0)
        as_float(self.max_keypoint_error, "max_keypoint_error", minimum=0.0,
                 exclusive_minimum=True)  # fmt: skip
        as_instance(self.reinit, bool, "reinit")


RECOVERY_DEFAULTS = RecoverySettings()


@dataclass(frozen=True)
class FrameQuality:
    """How well one frame's fit explains it.

    Attributes
    ----------
    iou : float
        Silhouette IoU, mean over cameras; 0 for a non-finite pose.
    keypoint_error : float
        Mean distance of the projected joints to the frame's keypoints, hand sizes;
        NaN without keypoints.
    cost : float
        Final cost of the optimiser, (pixel_scale px)²; NaN when not tracked.
    lost : bool
        The lost rule (module notes).
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
        Frames with an empty silhouette (not tracked).
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
        tracked = ~self.empty
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
    """The result of `track_with_recovery`: the track and its quality."""

    track: TrackResult
    quality: TrackQuality
    init_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _present(kps) -> bool:
    return kps is not None and any(k is not None and np.any(np.asarray(k)[:, 2] > 0) for k in kps)


def joint_distances(x, hand, rig, keypoints) -> np.ndarray:
    """Distances of the projected joints G(x) to the keypoints, in hand sizes.

    Parameters
    ----------
    x : (26,) array_like
        Pose, mm and degrees.
    hand : HandModel
    rig : Rig
    keypoints : sequence of (21, 3) array_like or None
        One per camera (None: none there): x, y in that camera's pixels, confidence.

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
    G = hand.joints(x)
    for j, cam in enumerate(rig):
        k = None if keypoints is None else keypoints[j]
        if k is None:
            continue
        k = np.asarray(k, dtype=float)
        if not (k[[_WRIST, _MIDDLE_MCP], 2] > 0).all():
            continue
        size = float(np.linalg.norm(k[_MIDDLE_MCP, :2] - k[_WRIST, :2]))
        if size <= 0:
            continue
        ok = k[:, 2] > 0
        out[j, ok] = np.linalg.norm(cam.project(G[ok]) - k[ok, :2], axis=1) / size
    return out


def pck(x, hand, rig, keypoints, threshold: float = 0.2) -> float:
    """Fraction of the present keypoints within `threshold` hand sizes of G(x)'s image.

    PCK@`threshold` (percentage of correct keypoints) against the detector, over every
    camera; NaN when no camera has keypoints with a hand size.
    """
    d = joint_distances(x, hand, rig, keypoints)
    d = d[~np.isnan(d)]
    return float(np.mean(d <= threshold)) if d.size else math.nan


def frame_quality(
    x, masks, hand, rig, keypoints=None, *, cost: float = math.nan,
    settings: RecoverySettings = RECOVERY_DEFAULTS,
) -> FrameQuality:  # fmt: skip
    """The quality of pose `x` on one frame and the lost rule (module notes)."""
    from handvar.render import silhouettes

    if not np.all(np.isfinite(x)):
        return FrameQuality(0.0, math.nan, cost, True)
    iou = silhouette_iou(silhouettes(hand, x, rig), masks)
    d = joint_distances(x, hand, rig, keypoints) if _present(keypoints) else np.full(1, np.nan)
    error = float(np.nanmean(d)) if np.isfinite(d).any() else math.nan
    lost = iou < settings.min_iou or (error > settings.max_keypoint_error)
    return FrameQuality(iou, error, cost, bool(lost))


def _step(tracker: Tracker, masks, kps):
    """One tracker step; keypoints go to the tracker's cost when it takes them."""
    try:
        if kps is not None and _takes_keypoints(tracker):
            return tracker.step(masks, keypoints=kps)
        return tracker.step(masks)
    except ValueError:  # a lost track can drive the optimiser to non-finite values
        return None


def _takes_keypoints(tracker: Tracker) -> bool:
    import inspect

    return "keypoints" in inspect.signature(tracker.step).parameters


def track_with_recovery(
    tracker: Tracker,
    frames: Iterable,
    x0=None,
    *,
    keypoints: Sequence | Callable | None = None,
    settings: RecoverySettings = RECOVERY_DEFAULTS,
    init_settings: InitSettings | None = None,
    on_frame: Callable | None = None,
) -> RecoveredTrack:
    """Track frame by frame, detect lost frames and re-initialise on them (module notes).

    Parameters
    ----------
    tracker : Tracker
        The tracker (its rig, hand, predictor, generator and settings are used).
    frames : iterable of (n_cams, H, W) bool array_like
        The silhouettes of each frame, in order.  A frame with an empty camera is
        flagged empty and not tracked.
    x0 : (26,) array_like, optional
        Pose at the first frame; by default `initial_pose` of the first frame.
    keypoints : sequence or callable, keyword-only, optional
        ``keypoints[i]`` (or ``keypoints(i)``) for the i-th frame: per camera a (21, 3)
        array (x, y in the masks' pixels, confidence) or None, or None for a frame
        without keypoints.  They go into the tracker's cost when it takes them
        (``Tracker.step(..., keypoints=)``), into the frame's quality, and into the
        re-initialisation.
    settings : RecoverySettings, keyword-only
    init_settings : InitSettings, keyword-only, optional
        Settings of the pose search.
    on_frame : callable, keyword-only, optional
        Called as ``on_frame(i, pose, quality)`` after each frame (streamed overlays).

    Returns
    -------
    RecoveredTrack
        The track (`TrackResult`; the poses of empty frames repeat the previous one)
        and its `TrackQuality`.
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

    rows = []  # per frame: pose, start, costs, iterations, seconds, quality, reinit, empty, kp
    previous = None if x0 is None else np.asarray(x0, dtype=float)
    started = False
    init_seconds = []
    for i, masks in enumerate(frames):
        masks = np.asarray(masks, dtype=bool)
        if masks.ndim == 2:
            masks = masks[None]
        kps = frame_keypoints(i)
        if not masks.reshape(len(masks), -1).any(axis=1).all():
            pose = np.full(N_PARAMS, np.nan) if previous is None else previous
            q = FrameQuality(0.0, math.nan, math.nan, False)
            rows.append((pose, pose, np.empty(0), 0, np.zeros(3), q, False, True, kps is not None))
            if on_frame is not None:
                on_frame(i, pose, q)
            continue
        if not started:
            if x0 is None:
                init_seconds.append(search(masks, kps))
            else:
                tracker.reset(x0)
            started = True
        r = _step(tracker, masks, kps)
        pose = np.full(N_PARAMS, np.nan) if r is None else r.pose
        cost = math.nan if r is None or not len(r.costs) else float(r.costs[-1])
        q = frame_quality(pose, masks, hand, rig, kps, cost=cost, settings=settings)
        reinit = False
        if q.lost and settings.reinit:
            init_seconds.append(search(masks, kps))
            reinit = True
            r2 = _step(tracker, masks, kps)
            if r2 is not None:
                cost2 = float(r2.costs[-1]) if len(r2.costs) else math.nan
                q2 = frame_quality(r2.pose, masks, hand, rig, kps, cost=cost2, settings=settings)
                if r is None or q2.iou >= q.iou or not q2.lost:
                    r, pose, q = r2, r2.pose, q2
        if not np.all(np.isfinite(pose)) and previous is not None:
            pose = previous  # diverged and not recovered: keep the last finite pose
        if r is None:
            row = (pose, pose, np.empty(0), 0, np.zeros(3))
        else:
            row = (pose, r.start, r.costs, r.iterations, r.seconds)
        rows.append((*row, q, reinit, False, kps is not None))
        if np.all(np.isfinite(pose)):
            previous = pose
        if on_frame is not None:
            on_frame(i, pose, q)
    if not rows:
        raise ValueError("frames: expected at least one frame; got none")
    n = len(rows)
    poses = np.array([r[0] for r in rows])
    costs = np.full((n, max_it), np.nan)
    for t, r in enumerate(rows):
        costs[t, : len(r[2])] = r[2][:max_it]
    joints = np.stack(
        [hand.joints(x) if np.all(np.isfinite(x)) else np.full((21, 3), np.nan) for x in poses]
    )
    track = TrackResult(
        poses=poses,
        joints=joints,
        starts=np.array([r[1] for r in rows]),
        costs=costs,
        iterations=np.array([r[3] for r in rows], dtype=np.int64),
        seconds=np.array([r[4] for r in rows]),
    )
    quality = TrackQuality(
        iou=np.array([r[5].iou for r in rows]),
        keypoint_error=np.array([r[5].keypoint_error for r in rows]),
        cost=np.array([r[5].cost for r in rows]),
        lost=np.array([r[5].lost for r in rows]),
        reinit=np.array([r[6] for r in rows]),
        empty=np.array([r[7] for r in rows]),
        keypoints=np.array([r[8] for r in rows]),
    )
    return RecoveredTrack(track, quality, np.array(init_seconds))
