"""One trial of an experiment: a predictor tracking the sequence from its first pose (design §7).

A trial tracks the whole sequence from its true first pose with one predictor; trials
differ only by the seed of the optimiser's random generator, ``default_rng([seed,
trial])``, which is the same for every predictor, so trial k of a predictor is compared
with trial k of no motion (R̃², eq. 18 and 21).

The frames' preprocessing (distance fields) depends only on the silhouettes and the
cost settings, so the trials a worker runs on one sequence share it through a
:class:`FrameCache`, held by the worker's :class:`TrialRunner`.
"""

from __future__ import annotations

import dataclasses
import functools
import threading
import time
from collections.abc import Callable

import numpy as np

from handvar import params
from handvar.evaluation.config import ExperimentConfig, tracker_settings
from handvar.tracking.tracker import TIMING_PARTS
from handvar.validate import as_instance, as_int

__all__ = ["TIMING_PARTS", "FrameCache", "TrialResult", "TrialRunner", "run_trial"]


@functools.lru_cache(maxsize=2)
def _hand(surface: str = "spheres"):
    from handvar.hand.kinematics import HandModel

    return HandModel(surface=surface)


@dataclasses.dataclass(frozen=True, eq=False)
class TrialResult:
    """What one trial produced.

    Attributes
    ----------
    poses : (T, 26) ndarray
        Estimated poses (mm, degrees); ``poses[0]`` is fitted from the true first pose.
    joints : (T, 21, 3) ndarray
        G(poses), mm.
    cost : (T,) ndarray
        Cost at the last iteration of each frame (NaN in open-loop trials).
    iterations : (T,) int ndarray
        Cost evaluations per frame (0 in open-loop trials).
    timings : (T, 3) ndarray
        Seconds per frame spent on preprocessing, optimisation and prediction
        (:data:`TIMING_PARTS`).
    """

    poses: np.ndarray
    joints: np.ndarray
    cost: np.ndarray
    iterations: np.ndarray
    timings: np.ndarray


class FrameCache:
    """The prepared frames of one sequence, shared by the trials that track it.

    Holds one sequence at a time (bounded memory): asking for another sequence, or
    for other cost settings, prepares afresh and forgets the previous frames.  The
    sequence is recognised by identity, and the entry keeps it alive, so a new
    object can never be mistaken for an old one.  A pickled cache travels empty.

    Examples
    --------
    >>> cache = FrameCache()
    >>> len(cache)
    0
    """

    def __init__(self) -> None:
        self._held: tuple[object, str, list] | None = None
        self._lock = threading.Lock()

    def __len__(self) -> int:
        """Frames held."""
        held = self._held
        return 0 if held is None else len(held[2])

    def __getstate__(self) -> dict:
        return {}

    def __setstate__(self, state: dict) -> None:
        self.__init__()

    def frames(self, tracker, sequence, key: str) -> list:
        """Every frame of `sequence` prepared by `tracker` (``tracker.prepare``).

        Parameters
        ----------
        tracker : handvar.tracking.Tracker
            Prepares the frames that are not held yet.
        sequence : handvar.io.Sequence
        key : str
            What else the preparation depends on (the cost settings' repr).

        Returns
        -------
        list of FrameData
            One per frame of `sequence`.
        """
        with self._lock:
            held = self._held
            if held is None or held[0] is not sequence or held[1] != key:
                self._held = None  # one sequence at a time: bounded memory
                frames = [
                    tracker.prepare(np.asarray(sequence.masks[t])) for t in range(sequence.n_frames)
                ]
                held = self._held = (sequence, key, frames)
            return held[2]


def _openloop_trial(config, spec, rng, sequence, cache) -> TrialResult:
    """One step ahead along the truth plus noise: the predictions are the 'estimates'."""
    truth = sequence.truth.poses[: config.frames]
    observed = params.clamp(truth + rng.normal(0.0, config.noise, truth.shape))
    observed[0] = truth[0]
    predictor = spec.build()
    n = len(truth)
    poses = np.empty_like(truth)
    timings = np.zeros((n, len(TIMING_PARTS)))
    poses[0] = truth[0]
    predictor.update(observed[0])
    for t in range(1, n):
        start = time.perf_counter()
        poses[t] = params.clamp(predictor.predict())
        predictor.update(observed[t])
        timings[t, 2] = time.perf_counter() - start
    hand = _hand()
    joints = np.stack([hand.joints(x) for x in poses])
    return TrialResult(poses, joints, np.full(n, np.nan), np.zeros(n, dtype=np.int16), timings)


def _tracker_trial(config, spec, rng, sequence, cache) -> TrialResult:
    """The SMD tracker with this predictor on the sequence, from the true first pose.

    With a `cache`, the frames are prepared once per cache and sequence, so the
    timings' preprocessing column is zero for the trials that reuse them.
    """
    from handvar.tracking import Tracker

    settings = tracker_settings(config.tracker)
    tracker = Tracker(sequence.rig, _hand(config.tracker_model), spec.build(), rng, settings)
    prepared = (
        None
        if cache is None
        else cache.frames(tracker, sequence, f"{config.tracker_model} {settings.cost!r}")
    )
    result = tracker.track(sequence, sequence.truth.poses[0], prepared=prepared)
    return TrialResult(
        result.poses,
        result.joints,
        result.final_costs,
        result.iterations.astype(np.int16),
        result.seconds,
    )


_TRIALS: dict[str, Callable] = {"tracker": _tracker_trial, "openloop": _openloop_trial}


def run_trial(
    config: ExperimentConfig, key: str, trial: int, sequence, *, cache: FrameCache | None = None
) -> TrialResult:
    """Run one trial: predictor `key` of `config`, trial number `trial`.

    Parameters
    ----------
    config : ExperimentConfig
    key : str
        Key or label of one of ``config.predictors``.
    trial : int
        Trial number; the generator is ``default_rng([config.seed, trial])``.
    sequence : handvar.io.Sequence
        The sequence, with truth, cut to ``config.frames`` frames.
    cache : FrameCache, keyword-only, optional
        Prepared frames shared with other trials on the same sequence; without one,
        the tracker prepares every frame itself.

    Returns
    -------
    TrialResult
    """
    as_instance(config, ExperimentConfig, "config")
    spec = config.spec(key)
    trial = as_int(trial, "trial", minimum=0)
    if sequence.truth is None:
        raise ValueError("sequence: expected a sequence with ground truth; it has none")
    if sequence.n_frames != config.frames:
        raise ValueError(
            f"sequence: expected {config.frames} frames (config.frames); got {sequence.n_frames}"
        )
    if cache is not None:
        as_instance(cache, FrameCache, "cache")
    rng = np.random.default_rng([config.seed, trial])
    return _TRIALS[config.trial_kind](config, spec, rng, sequence, cache)


class TrialRunner:
    """The worker side of an experiment: the sequence and the frames prepared from it.

    One runner is sent to every worker (``client.scatter(..., broadcast=True)``), which
    keeps its copy for the whole run, so each worker prepares the frames once and
    shares them between all the trials it runs.

    Parameters
    ----------
    sequence : handvar.io.Sequence
        The sequence of the experiment, with truth.
    cache : FrameCache, optional
        A fresh one by default.
    """

    def __init__(self, sequence, cache: FrameCache | None = None) -> None:
        self.sequence = sequence
        self.cache = FrameCache() if cache is None else as_instance(cache, FrameCache, "cache")

    def run(self, config: ExperimentConfig, key: str, trial: int) -> TrialResult:
        """:func:`run_trial` on this runner's sequence with its cache."""
        return run_trial(config, key, trial, self.sequence, cache=self.cache)
