"""The tracker: per frame predict → optimise → update (paper §2 and §4, §1).

For every frame the motion predictor proposes the starting pose x̂ (the first frame
starts at the given x0), stochastic meta-descent minimises 1.7 C_s + 0.4 C_f from x̂
(:mod:`handvar.tracking.costs`, :mod:`handvar.tracking.smd`), and the result is fed back
to the predictor. Frames can be given one at a time (`Tracker.step`, for a live source)
or as a whole `handvar.io.Sequence` (`Tracker.track`).

Keypoints (design §14.2): a frame may come with 2D keypoints of the 21 points of G(x)
per camera; the cost then has the keypoint term w_k C_k, and after SMD a few
Levenberg–Marquardt steps refine the pose (`handvar.tracking.refine`, with Tukey's loss
on the keypoints; `TrackerSettings.refine`). A frame without keypoints is fitted on the
silhouettes alone, by SMD alone.

The hand in front (design §13): after every SMD step the palm's origin is moved in front
of every camera (`front_projection`), and the cost's C_z penalises joints closer than
`CostSettings.near`.

Fit quality (design §13): every frame reports the silhouette IoU of the fitted model
against the masks per camera and their mean, the final cost, the keypoint error (hand
sizes) and whether it is *lost*: mean IoU below `QualitySettings.lost_iou` (0.75) or
keypoint error above `QualitySettings.lost_keypoint_error` (0.3 hand sizes), or no
silhouette in any camera. A camera with an empty mask is left out of the fit and
flagged (`empty`, and a `TrackingWarning` naming frame and camera); when every camera's
mask is empty the frame is carried by the prediction.

Examples
--------
>>> import numpy as np
>>> from handvar.camera import Rig
>>> from handvar.hand import HandModel, named_pose
>>> from handvar.predictors import NoMotion
>>> from handvar.render import silhouettes
>>> hand, rig, x = HandModel(), Rig.default(), named_pose("open")
>>> tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
>>> tracker.reset(x)
>>> frame = tracker.step(silhouettes(hand, x, rig))
>>> frame.pose.shape, frame.iterations
((26,), 1)
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

import numpy as np

from handvar.camera import Rig
from handvar.params import N_PARAMS, check_pose, clamp
from handvar.tracking.costs import CostSettings, FrameData, SilhouetteCost
from handvar.tracking.keypoint_cost import (
    frame_keypoints,
    hand_length,
    keypoint_points,
    reprojection_error,
    sequence_keypoints,
)
from handvar.tracking.refine import RefineSettings, refine
from handvar.tracking.smd import SMDSettings, minimise
from handvar.validate import as_float, as_instance, as_int

__all__ = [
    "TIMING_PARTS",
    "FrameResult",
    "QualitySettings",
    "TrackResult",
    "Tracker",
    "TrackerSettings",
    "TrackingWarning",
    "front_projection",
    "silhouette_iou",
]


class TrackingWarning(UserWarning):
    """A frame the tracker could not fit as asked: an empty silhouette in some camera."""


#: The parts of a frame's wall time, in the order of ``FrameResult.seconds``.
TIMING_PARTS = ("preprocessing", "optimisation", "prediction")


@dataclass(frozen=True)
class QualitySettings:
    """The fit-quality check and the lost-frame rule (design §13).

    Attributes
    ----------
    lost_iou : float
        A frame whose mean silhouette IoU is below this is lost, 0.75.
    lost_keypoint_error : float
        A frame whose keypoint error exceeds this (hand sizes) is lost, 0.3.
    fit_quality : bool
        Render the fitted model to measure the IoU (about 5 ms a stereo frame at
        640×480); False leaves `iou` NaN and decides `lost` on the keypoints alone.
    """

    lost_iou: float = 0.75
    lost_keypoint_error: float = 0.3
    fit_quality: bool = True

    def __post_init__(self) -> None:
        as_float(self.lost_iou, "lost_iou", minimum=0.0, maximum=1.0)
        as_float(self.lost_keypoint_error, "lost_keypoint_error", minimum=0.0)
        as_instance(self.fit_quality, bool, "fit_quality")


@dataclass(frozen=True)
class TrackerSettings:
    """Settings of the tracker: the cost's, the optimiser's (paper §4 by default), the
    refinement's on frames with keypoints (`RefineSettings`, design §14.2) and the
    fit-quality check's (`QualitySettings`)."""

    cost: CostSettings = field(default_factory=CostSettings)
    smd: SMDSettings = field(default_factory=SMDSettings)
    quality: QualitySettings = field(default_factory=QualitySettings)
    refine: RefineSettings = field(default_factory=RefineSettings)

    def __post_init__(self) -> None:
        as_instance(self.cost, CostSettings, "cost")
        as_instance(self.smd, SMDSettings, "smd")
        as_instance(self.refine, RefineSettings, "refine")
        as_instance(self.quality, QualitySettings, "quality")


@dataclass(frozen=True, eq=False)
class FrameResult:
    """The outcome of tracking one frame.

    Attributes
    ----------
    pose : (26,) ndarray
        Fitted pose, mm and degrees.
    start : (26,) ndarray
        The starting pose (the prediction, or x0 for the first frame).
    costs : (k,) ndarray
        Cost at each iteration, (pixel_scale px)².
    iterations : int
        Number of SMD cost evaluations k (at most ``max_iterations``; 0 when no camera
        had a silhouette and the pose is the prediction). The Levenberg–Marquardt steps
        on a keypoint frame are not counted; a frame refined by
        `handvar.tracking.recovery` counts the refinement's iterations too.
    seconds : (3,) ndarray
        Wall time of preprocessing (the masks' distance fields and the fit-quality
        check), optimisation and prediction, seconds.
    iou : (n_cams,) ndarray
        Silhouette IoU of the fitted model's rendered silhouette and the observed mask
        per camera; NaN for an empty mask (or without ``fit_quality``).
    cost : float
        The cost at the last iteration (NaN when not fitted).
    keypoint_error : float
        Mean distance of the projected G(pose) to the frame's keypoints, hand sizes
        (`handvar.tracking.keypoint_cost.reprojection_error`); NaN without keypoints.
    lost : bool
        The fit failed by the rule of the module docstring (design §13).
    empty : (n_cams,) bool ndarray
        The cameras whose mask was empty (left out of the fit).
    """

    pose: np.ndarray
    start: np.ndarray
    costs: np.ndarray
    iterations: int
    seconds: np.ndarray
    iou: np.ndarray
    cost: float
    keypoint_error: float
    lost: bool
    empty: np.ndarray

    @property
    def mean_iou(self) -> float:
        """Mean IoU over the cameras with a silhouette (NaN if none)."""
        return _nanmean(self.iou)


@dataclass(frozen=True, eq=False)
class TrackResult:
    """The tracking of a sequence.

    Attributes
    ----------
    poses : (T, 26) ndarray
        Fitted poses, mm and degrees.
    joints : (T, 21, 3) ndarray
        G(poses), mm, world frame.
    starts : (T, 26) ndarray
        Starting pose of every frame (the predictions; x0 for the first).
    costs : (T, max_iterations) ndarray
        Cost per iteration, NaN after a frame's last iteration.
    iterations : (T,) int ndarray
        Cost evaluations per frame.
    seconds : (T, 3) ndarray
        Wall time per frame, seconds: preprocessing, optimisation, prediction
        (`TIMING_PARTS`).
    iou : (T, n_cams) ndarray
        Silhouette IoU per frame and camera (`FrameResult.iou`).
    cost : (T,) ndarray
        Cost at every frame's last iteration (NaN where not fitted).
    keypoint_error : (T,) ndarray
        Keypoint error per frame, hand sizes; NaN where the frame had no keypoints.
    lost : (T,) bool ndarray
        Frames whose fit failed (design §13).
    empty : (T, n_cams) bool ndarray
        Cameras whose mask was empty, per frame.
    """

    poses: np.ndarray
    joints: np.ndarray
    starts: np.ndarray
    costs: np.ndarray
    iterations: np.ndarray
    seconds: np.ndarray
    iou: np.ndarray
    cost: np.ndarray
    keypoint_error: np.ndarray
    lost: np.ndarray
    empty: np.ndarray

    @property
    def mean_iou(self) -> np.ndarray:
        """(T,) mean IoU over each frame's cameras with a silhouette (NaN if none)."""
        return np.array([_nanmean(row) for row in self.iou])

    @property
    def final_costs(self) -> np.ndarray:
        """(T,) cost at the last iteration of every frame (NaN where not fitted)."""
        return self.cost.copy()


def _nanmean(a: np.ndarray) -> float:
    a = np.asarray(a, dtype=float)
    ok = ~np.isnan(a)
    return float(a[ok].mean()) if ok.any() else float("nan")


def silhouette_iou(model: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """IoU |A ∩ B| / |A ∪ B| per camera of two stacks of masks, (n_cams,); NaN where B is empty.

    Parameters
    ----------
    model, masks : (n_cams, H, W) bool ndarray
        The model's rendered silhouettes (A) and the observed ones (B).

    Examples
    --------
    >>> a = np.zeros((1, 4, 4), bool); a[0, :2] = True
    >>> b = np.zeros((1, 4, 4), bool); b[0, 1:3] = True
    >>> silhouette_iou(a, b).tolist()
    [0.3333333333333333]
    """
    a = np.asarray(model, dtype=bool)
    b = np.asarray(masks, dtype=bool)
    inter = np.logical_and(a, b).sum(axis=(1, 2))
    union = np.logical_or(a, b).sum(axis=(1, 2))
    iou = inter / np.maximum(union, 1)
    return np.where(b.any(axis=(1, 2)), iou, np.nan)


def front_projection(rig: Rig, near: float) -> Callable[[np.ndarray], np.ndarray]:
    """A map moving the palm's origin x[:3] to depth ≥ `near` in every camera (design §13).

    For each camera in turn, a palm at depth z < near is moved by (near − z) along the
    camera's optical axis (in world coordinates); a few passes settle the rare case
    where moving it in front of one camera puts it behind another.

    Parameters
    ----------
    rig : Rig
    near : float
        Depth, mm.

    Returns
    -------
    callable
        ``project(x) -> x`` on (26,) poses, a new array.
    """
    R = np.stack([c.R for c in rig.cameras])
    t = np.stack([c.t for c in rig.cameras])

    def project(x: np.ndarray) -> np.ndarray:
        x = np.array(x, dtype=float)
        for _ in range(4):
            z = R[:, 2] @ x[:3] + t[:, 2]
            if np.all(z >= near):
                break
            j = int(np.argmin(z))
            x[:3] += (near - z[j]) * R[j, 2]  # R[2] is the optical axis in world coordinates
        return x

    return project


class Tracker:
    """Model-based hand tracker with a motion predictor (module docstring).

    Parameters
    ----------
    rig : Rig
        The calibrated cameras.
    hand : HandModel, optional
        The hand model (default 185 mm hand).
    predictor : Predictor, optional
        Anything with ``update(x)``, ``predict()`` and ``reset()``
        (`handvar.predictors`); `NoMotion` by default.
    rng : numpy.random.Generator, optional
        Source of the optimiser's random samples; ``default_rng(0)`` by default. A trial
        is reproducible (bitwise) from its seed.
    settings : TrackerSettings, optional
        The paper's by default.
    """

    def __init__(self, rig: Rig, hand=None, predictor=None, rng=None, settings=None) -> None:
        from handvar.hand.kinematics import HandModel
        from handvar.predictors import NoMotion

        as_instance(rig, Rig, "rig", what="a handvar.camera.Rig")
        hand = HandModel() if hand is None else as_instance(hand, HandModel, "hand")
        predictor = NoMotion() if predictor is None else predictor
        for name in ("update", "predict", "reset"):
            if not callable(getattr(predictor, name, None)):
                raise TypeError(
                    f"predictor: expected an object with update, predict and reset; "
                    f"got {type(predictor).__name__}, which has no {name}()"
                )
        rng = np.random.default_rng(0) if rng is None else rng
        as_instance(rng, np.random.Generator, "rng", what="a numpy.random.Generator")
        settings = TrackerSettings() if settings is None else settings
        as_instance(settings, TrackerSettings, "settings")
        self.rig = rig
        self.predictor = predictor
        self.rng = rng
        self.settings = settings
        self.set_hand(hand)
        self._x0: np.ndarray | None = None
        self._n = 0

    def set_hand(self, hand) -> None:
        """Track with the model `hand` from now on (e.g. a shape adapted to the person,
        `handvar.tracking.shape_fit`); the predictor and the track so far are kept."""
        from handvar.hand.kinematics import HandModel

        hand = as_instance(hand, HandModel, "hand")
        rig, settings = self.rig, self.settings
        self.hand = hand
        if hand.surface == "mesh":  # the skinned mesh (design §15)
            from handvar.tracking.mesh_cost import MeshSilhouetteCost

            self.cost = MeshSilhouetteCost(hand, rig, settings.cost)
        else:
            self.cost = SilhouetteCost(hand, rig, settings.cost)
        self._front = front_projection(rig, settings.cost.near)
        c, rs = settings.cost, settings.refine
        dense = replace(
            c, n_surface=rs.samples * c.n_surface, n_pixels=rs.samples * c.n_pixels,
            keypoint_loss=rs.keypoint_loss, keypoint_huber=rs.keypoint_scale,
            weight_keypoints=rs.weight_keypoints,
        )  # fmt: skip
        self._refine_cost = type(self.cost)(hand, rig, dense)
        self._length = hand_length(hand)

    def reset(self, x0) -> None:
        """Start a new track at pose `x0` (26,): the next frame's starting pose.

        The predictor is reset too; the random generator is not (seed a new one for an
        independent, reproducible trial).
        """
        self._x0 = clamp(check_pose(x0, "x0"))
        self._n = 0
        self.predictor.reset()

    @property
    def frames_tracked(self) -> int:
        """Frames tracked since the last `reset`."""
        return self._n

    def prediction(self) -> np.ndarray:
        """The next frame's starting pose (26,): x0 after `reset`, else the predictor's.

        As `step` starts from it: clamped to the joint limits and moved in front of
        every camera.
        """
        if self._x0 is None:
            raise ValueError("x0: expected a starting pose; call reset(x0) first")
        if self._n == 0:
            start = self._x0.copy()
        else:
            start = clamp(check_pose(self.predictor.predict(), "predictor.predict()"))
        return clamp(self._front(start))

    def accept(self, x) -> None:
        """Take pose `x` (26,) as the frame's fit made elsewhere: the predictor learns it.

        For a frame fitted outside `step` (the keypoint-first fit,
        `handvar.tracking.frame_fit`); the next `prediction` follows from it.
        """
        self.predictor.update(check_pose(x, "x"))
        self._n += 1

    def prepare(self, masks) -> FrameData:
        """The per-frame preprocessing of `masks` (distance fields), for `step(frame=...)`.

        It depends on the silhouettes only, so trials that track the same frames with
        other predictors or seeds can prepare them once and share the result.
        """
        return self.cost.prepare(masks)

    def step(self, masks=None, *, frame: FrameData | None = None, keypoints=None) -> FrameResult:
        """Track one frame: predict, optimise from the prediction, update the predictor.

        Parameters
        ----------
        masks : (n_cams, H, W) bool array_like
            The frame's silhouettes, one per camera of the rig. Needed for the fit
            quality (IoU) even when `frame` is given; without them `iou` is NaN.
        frame : FrameData, keyword-only, optional
            The frame already prepared (`prepare`); then `masks` is not needed for the
            fit.
        keypoints : keyword-only, optional
            The frame's 2D keypoints of the 21 points of G(x): an (n_cams, 21, 3) array
            (x, y, confidence; NaN or confidence 0 = missing) or one entry per camera —
            a (21, 2|3) array or None (`handvar.tracking.keypoint_cost.frame_keypoints`).
            Pixels of the images the rig describes. None: silhouettes only.

        Returns
        -------
        FrameResult

        Warns
        -----
        TrackingWarning
            When some camera's mask is empty (that camera is left out; with every mask
            empty the pose is the prediction), naming the frame and the cameras.
        """
        if self._x0 is None:
            raise ValueError("x0: expected a starting pose; call reset(x0) before step()")
        n_cams = len(self.rig)
        kp = frame_keypoints(keypoints, n_cams)
        t0 = time.perf_counter()
        if self._n == 0:
            start = self._x0.copy()
        else:
            start = clamp(check_pose(self.predictor.predict(), "predictor.predict()"))
        start = clamp(self._front(start))
        t1 = time.perf_counter()
        m = None
        if masks is not None:
            m = np.asarray(masks)
            if m.ndim != 3 or m.shape[0] != n_cams:
                raise ValueError(
                    f"masks: expected shape ({n_cams}, H, W), one silhouette per camera; "
                    f"got shape {m.shape}"
                )
            m = m.astype(bool, copy=False)
        if frame is None:
            if m is None:
                raise ValueError("masks: expected the frame's silhouettes or frame=; got None")
            empty = ~m.any(axis=(1, 2))
            frame = None if empty.all() else self.cost.prepare(m)
        else:
            empty = frame.counts == 0
        if empty.any():
            names = ", ".join(repr(self.rig.names[j]) for j in np.flatnonzero(empty))
            what = (
                "no camera has a silhouette; the pose is the prediction"
                if empty.all()
                else "left out of the fit"
            )
            warnings.warn(
                f"frame {self._n}: empty silhouette in camera {names}; {what}",
                TrackingWarning,
                stacklevel=2,
            )
        t2 = time.perf_counter()
        if frame is None:  # every mask empty: carried by the prediction
            x, costs, iterations = start, np.empty(0), 0
        else:
            cost, rng = self.cost, self.rng
            floor = self.settings.cost.curvature_floor
            w_k = self.settings.cost.weight_keypoints
            history: list[tuple[float, float]] = []  # (cost without C_k, C_k)

            def objective(x, need_jacobian):
                terms = cost.evaluate(
                    x, frame, cost.draw(frame, rng), residuals=need_jacobian, keypoints=kp
                )
                history.append((terms.cost - w_k * terms.keypoints, terms.keypoints))
                h = terms.curvature(floor)
                return terms.cost, terms.gradient, terms.jacobian, h

            res = minimise(
                objective, start, self.settings.smd, project=self._front,
                stop=None if kp is None else lambda c: self._stop(history),
            )  # fmt: skip
            x, costs, iterations = res.x, res.costs, res.iterations
            if kp is not None and self.settings.refine.steps > 0:
                x = self._refine(x, frame, kp)
        t3 = time.perf_counter()
        iou, kp_err, lost = self._quality(x, m, kp, empty)
        t4 = time.perf_counter()
        self.predictor.update(x)
        t5 = time.perf_counter()
        self._n += 1
        seconds = np.array([(t2 - t1) + (t4 - t3), t3 - t2, (t1 - t0) + (t5 - t4)])
        final = float(costs[-1]) if iterations else float("nan")
        return FrameResult(
            x, start, costs, iterations, seconds, iou, final, kp_err, lost, empty.copy()
        )

    def _refine(self, x: np.ndarray, frame: FrameData, kp: np.ndarray) -> np.ndarray:
        """Levenberg–Marquardt steps after SMD on a frame with keypoints (design §14.2)."""
        cost, rng = self._refine_cost, self.rng

        def draw():
            samples = cost.draw(frame, rng)

            def f(z, jacobian):
                t = cost.evaluate(z, frame, samples, residuals=jacobian, keypoints=kp)
                return t.cost, t.residuals, t.jacobian

            return f

        return refine(draw, x, self.settings.refine, project=self._front).x

    def _stop(self, history: list[tuple[float, float]]) -> bool:
        """SMD's stopping test with keypoints (`SMDSettings.keypoint_stop`)."""
        rest, c_k = history[-1]
        if rest >= self.settings.smd.threshold or len(history) < 2:
            return False
        return c_k >= (1.0 - self.settings.smd.keypoint_stop) * history[-2][1]

    def _quality(self, x: np.ndarray, masks, kp, empty: np.ndarray):
        """IoU per camera, keypoint error and the lost flag of the fitted pose `x`."""
        s = self.settings
        q = s.quality
        iou = np.full(len(self.rig), np.nan)
        if masks is not None and q.fit_quality and not empty.all():
            from handvar.render import silhouettes

            iou = silhouette_iou(silhouettes(self.hand, x, self.rig), masks)
        kp_err = np.nan  # no keypoints: no G(x) to compare
        if kp is not None:
            G = keypoint_points(self.hand, x, s.cost.keypoint_tips)  # G(x) by default
            kp_err = reprojection_error(G, self.rig, kp, self._length, near=s.cost.near)
        mean_iou = _nanmean(iou)
        lost = bool(
            empty.all() or mean_iou < q.lost_iou or kp_err > q.lost_keypoint_error
        )  # NaN compares False: a missing measure does not decide
        return iou, kp_err, lost

    def track(
        self,
        sequence,
        x0,
        *,
        frames: int | None = None,
        progress: Callable[[Iterable[int]], Iterable[int]] | None = None,
        prepared: list[FrameData] | None = None,
        keypoints=None,
    ) -> TrackResult:
        """Track a sequence from pose `x0` at its first frame.

        Parameters
        ----------
        sequence : handvar.io.Sequence
            Masks (T, n_cams, H, W) seen by this tracker's rig.
        x0 : (26,) array_like
            Pose at the first frame.
        frames : int, keyword-only, optional
            Track only the first `frames` frames.
        progress : callable, keyword-only, optional
            Wraps the frame iterator (for instance ``tqdm.tqdm``).
        prepared : list of FrameData, keyword-only, optional
            The frames already prepared (`prepare`), one per frame tracked; their
            distance fields' time is then not counted (the fit-quality check's is).
        keypoints : keyword-only, optional
            2D keypoints of the 21 points of G(x): one entry per camera, each a
            `handvar.vision.keypoints.Keypoints2D`, a (T, 21, 2|3) array or None; or a
            (T, n_cams, 21, 2|3) array; or a list of per-frame entries as `step` takes
            (`handvar.tracking.keypoint_cost.sequence_keypoints`). Frames without
            keypoints (missing, or beyond their count) use the silhouettes only.

        Returns
        -------
        TrackResult

        Warns
        -----
        TrackingWarning
            For every frame with an empty mask in some camera (see `step`).
        """
        from handvar.io import Sequence

        as_instance(sequence, Sequence, "sequence", what="a handvar.io.Sequence")
        if len(sequence.rig) != len(self.rig):
            raise ValueError(
                f"sequence: expected {len(self.rig)} cameras like the tracker's rig; "
                f"got {len(sequence.rig)}"
            )
        n = sequence.n_frames
        if frames is not None:
            n = min(n, as_int(frames, "frames", minimum=1))
        self.reset(x0)
        max_it = self.settings.smd.max_iterations
        poses = np.empty((n, N_PARAMS))
        starts = np.empty((n, N_PARAMS))
        costs = np.full((n, max_it), np.nan)
        iterations = np.zeros(n, dtype=np.int64)
        seconds = np.zeros((n, 3))
        n_cams = len(self.rig)
        iou = np.full((n, n_cams), np.nan)
        final = np.full(n, np.nan)
        kp_err = np.full(n, np.nan)
        lost = np.zeros(n, dtype=bool)
        empty = np.zeros((n, n_cams), dtype=bool)
        kps = [None] * n if keypoints is None else sequence_keypoints(keypoints, n, n_cams)
        it: Iterable[int] = range(n)
        if progress is not None:
            it = progress(it)
        if prepared is not None and len(prepared) < n:
            raise ValueError(f"prepared: expected {n} prepared frames; got {len(prepared)}")
        for t in it:
            masks = np.asarray(sequence.masks[t])
            if prepared is None:
                r = self.step(masks, keypoints=kps[t])
            else:
                r = self.step(masks, frame=prepared[t], keypoints=kps[t])
            poses[t] = r.pose
            starts[t] = r.start
            costs[t, : r.iterations] = r.costs
            iterations[t] = r.iterations
            seconds[t] = r.seconds
            iou[t], final[t], kp_err[t], lost[t], empty[t] = (
                r.iou, r.cost, r.keypoint_error, r.lost, r.empty
            )  # fmt: skip
        tips = self.settings.cost.keypoint_tips
        joints = np.stack([keypoint_points(self.hand, x, tips) for x in poses])
        return TrackResult(
            poses, joints, starts, costs, iterations, seconds, iou, final, kp_err, lost, empty
        )
