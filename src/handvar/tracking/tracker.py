"""The tracker: per frame predict → optimise → update (paper §2 and §4, §1).

For every frame the motion predictor proposes the starting pose x̂ (the first frame
starts at the given x0), stochastic meta-descent minimises 1.7 C_s + 0.4 C_f from x̂
(:mod:`handvar.tracking.costs`, :mod:`handvar.tracking.smd`), and the result is fed back
to the predictor. Frames can be given one at a time (`Tracker.step`, for a live source)
or as a whole `handvar.io.Sequence` (`Tracker.track`).

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
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np

from handvar.camera import Rig
from handvar.params import N_PARAMS, check_pose, clamp
from handvar.tracking.costs import CostSettings, FrameData, SilhouetteCost
from handvar.tracking.smd import SMDSettings, minimise
from handvar.validate import as_instance, as_int

__all__ = ["TIMING_PARTS", "FrameResult", "TrackResult", "Tracker", "TrackerSettings"]

#: The parts of a frame's wall time, in the order of ``FrameResult.seconds``.
TIMING_PARTS = ("preprocessing", "optimisation", "prediction")


@dataclass(frozen=True)
class TrackerSettings:
    """Settings of the tracker: the cost's and the optimiser's (paper §4 by default)."""

    cost: CostSettings = field(default_factory=CostSettings)
    smd: SMDSettings = field(default_factory=SMDSettings)

    def __post_init__(self) -> None:
        as_instance(self.cost, CostSettings, "cost")
        as_instance(self.smd, SMDSettings, "smd")


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
        Number of cost evaluations k (at most ``max_iterations``).
    seconds : (3,) ndarray
        Wall time of preprocessing, optimisation and prediction, seconds.
    """

    pose: np.ndarray
    start: np.ndarray
    costs: np.ndarray
    iterations: int
    seconds: np.ndarray


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
    """

    poses: np.ndarray
    joints: np.ndarray
    starts: np.ndarray
    costs: np.ndarray
    iterations: np.ndarray
    seconds: np.ndarray

    @property
    def final_costs(self) -> np.ndarray:
        """(T,) cost at the last iteration of every frame."""
        return self.costs[np.arange(self.costs.shape[0]), self.iterations - 1]


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
        self.hand = hand
        self.predictor = predictor
        self.rng = rng
        self.settings = settings
        if hand.surface == "mesh":  # the skinned mesh (§15)
            from handvar.tracking.mesh_cost import MeshSilhouetteCost

            self.cost = MeshSilhouetteCost(hand, rig, settings.cost)
        else:
            self.cost = SilhouetteCost(hand, rig, settings.cost)
        self._x0: np.ndarray | None = None
        self._n = 0

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

    def prepare(self, masks) -> FrameData:
        """The per-frame preprocessing of `masks` (distance fields), for `step(frame=...)`.

        It depends on the silhouettes only, so trials that track the same frames with
        other predictors or seeds can prepare them once and share the result.
        """
        return self.cost.prepare(masks)

    def step(self, masks=None, *, frame: FrameData | None = None) -> FrameResult:
        """Track one frame: predict, optimise from the prediction, update the predictor.

        Parameters
        ----------
        masks : (n_cams, H, W) bool array_like
            The frame's silhouettes, one per camera of the rig.
        frame : FrameData, keyword-only, optional
            The frame already prepared (`prepare`); then `masks` is not needed.

        Returns
        -------
        FrameResult
        """
        if self._x0 is None:
            raise ValueError("x0: expected a starting pose; call reset(x0) before step()")
        t0 = time.perf_counter()
        if self._n == 0:
            start = self._x0.copy()
        else:
            start = clamp(check_pose(self.predictor.predict(), "predictor.predict()"))
        t1 = time.perf_counter()
        if frame is None:
            if masks is None:
                raise ValueError("masks: expected the frame's silhouettes or frame=; got None")
            frame = self.cost.prepare(masks)
        t2 = time.perf_counter()
        cost, rng = self.cost, self.rng
        floor = self.settings.cost.curvature_floor

        def objective(x, need_jacobian):
            terms = cost.evaluate(x, frame, cost.draw(frame, rng), residuals=need_jacobian)
            h = terms.curvature(floor)
            return terms.cost, terms.gradient, terms.jacobian, h

        res = minimise(objective, start, self.settings.smd)
        t3 = time.perf_counter()
        self.predictor.update(res.x)
        t4 = time.perf_counter()
        self._n += 1
        seconds = np.array([t2 - t1, t3 - t2, (t1 - t0) + (t4 - t3)])
        return FrameResult(res.x, start, res.costs, res.iterations, seconds)

    def track(
        self,
        sequence,
        x0,
        *,
        frames: int | None = None,
        progress: Callable[[Iterable[int]], Iterable[int]] | None = None,
        prepared: list[FrameData] | None = None,
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
            preprocessing time is then not counted.

        Returns
        -------
        TrackResult
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
        it: Iterable[int] = range(n)
        if progress is not None:
            it = progress(it)
        if prepared is not None and len(prepared) < n:
            raise ValueError(f"prepared: expected {n} prepared frames; got {len(prepared)}")
        for t in it:
            if prepared is None:
                r = self.step(np.asarray(sequence.masks[t]))
            else:
                r = self.step(frame=prepared[t])
            poses[t] = r.pose
            starts[t] = r.start
            costs[t, : r.iterations] = r.costs
            iterations[t] = r.iterations
            seconds[t] = r.seconds
        joints = np.stack([self.hand.joints(x) for x in poses])
        return TrackResult(poses, joints, starts, costs, iterations, seconds)
