"""The paper's tracking experiments at scale (paper §4–5, design §7), on Dask distributed.

One experiment is a set of predictors × trials on one synthetic sequence
(:class:`~handvar.evaluation.config.ExperimentConfig`); each trial
(:mod:`handvar.evaluation.trials`) runs as a Dask task, and everything goes to one
Zarr store (:mod:`handvar.evaluation.store`).

The store is created in full before any trial runs, and every finished trial is
written into its own chunks as soon as its result arrives, ``done`` last.  Killing a
worker or the whole run therefore loses no finished trial, the store stays readable
at any moment, and running again with the same store computes only the trials not
yet done.  The same configuration gives the same store (all arrays but ``timings``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handvar.atomic import lock_directory
from handvar.evaluation.config import ExperimentConfig, tracker_settings
from handvar.evaluation.store import (
    clear_done,
    create_store,
    damaged_trials,
    open_store,
    store_sequence,
    write_scores,
    write_trial,
)
from handvar.evaluation.trials import TrialRunner
from handvar.validate import as_instance, as_int

__all__ = ["RunSummary", "local_client", "run_experiment", "summary_text"]


@dataclasses.dataclass(frozen=True)
class RunSummary:
    """What one call of :func:`run_experiment` did.

    Attributes
    ----------
    store : Path
    total : int
        Trials in the experiment (predictors × trials).
    already_done : int
        Trials found finished in the store and not run again.
    computed : int
        Trials computed and written by this call.
    missing : tuple of (str, int)
        (predictor label, trial) still not done when the call ended.
    seconds : float
        Wall-clock time of the call.
    repaired : tuple of (str, int)
        (predictor label, trial) found damaged in the store (design §13.3), whose
        ``done`` flag was cleared so that they ran again.
    """

    store: Path
    total: int
    already_done: int
    computed: int
    missing: tuple[tuple[str, int], ...]
    seconds: float
    repaired: tuple[tuple[str, int], ...] = ()

    @property
    def complete(self) -> bool:
        """Every trial of the experiment is in the store."""
        return not self.missing


def _render(config: ExperimentConfig, progress: bool):
    from handvar.synth.sequences import make_sequence

    wrap = None
    if progress:
        from tqdm import tqdm

        def wrap(it):
            return tqdm(it, desc=f"rendering {config.sequence}", unit="frame", leave=False)

    from handvar.synth.mismatch import generator_hand

    hand = None
    if (config.sequence_model, config.sequence_length, config.sequence_breadth) != (
        "spheres",
        1.0,
        1.0,
    ):
        hand = generator_hand(
            config.sequence_model, config.sequence_length, config.sequence_breadth
        )
    return make_sequence(
        config.sequence,
        seed=config.sequence_seed,
        n_frames=config.frames,
        progress=wrap,
        hand=hand,
        speed=config.sequence_speed,
        silhouette_noise=config.sequence_noise,
    )


def _open_or_create(path: Path, config: ExperimentConfig, progress: bool):
    """(config, sequence, done, writes, damage) of the store, created if it does not exist.

    An existing store is verified first (`damaged_trials`): a damaged trial's ``done``
    flag is cleared so that it runs again.
    """
    P, N = len(config.predictors), config.trials
    if path.exists():
        ds = open_store(path)
        stored = ExperimentConfig.from_json(ds.attrs["config"])
        if stored != config:
            raise ValueError(
                f"store: {path} holds a different experiment (config {stored.to_json()}); "
                "choose another --out or the same settings"
            )
        sequence = store_sequence(path)
        damage = damaged_trials(path)
        if damage:
            clear_done(path, damage)
        import zarr

        group = zarr.open_group(str(path), mode="r", zarr_format=2)
        done = np.array([[bool(group["done"][p, t]) for t in range(N)] for p in range(P)])
        writes = np.zeros((P, N), np.int16)
        for p, t in zip(*np.nonzero(done), strict=True):
            try:
                writes[p, t] = group["writes"][p, t]
            except Exception:  # an unreadable counter: counted from 0 again
                pass
        return stored, sequence, done, writes, damage
    sequence = _render(config, progress)
    create_store(path, config, sequence)
    return config, sequence, np.zeros((P, N), bool), np.zeros((P, N), np.int16), []


#: Run by each worker process of the embedded cluster as it starts (a Dask preload, the
#: text of a script): the worker ignores Ctrl-C. A terminal sends Ctrl-C to the client and
#: its workers alike; the client stops the run and closes the cluster, and a worker
#: interrupted itself would only print its stack.
WORKER_PRELOAD = "import signal\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\n"


def local_client(workers: int | None):
    """An embedded Dask cluster of `workers` processes, one thread each: (client, cluster).

    Default: one worker per core.  The workers leave Ctrl-C to the client
    (`WORKER_PRELOAD`).  Close both when done.  The cluster logs only what is
    critical: a task's error reaches the caller through the client, and the errors
    the workers log when the cluster is closed under them (after a failure, a lost
    heartbeat) would be printed before the command's one line.
    """
    from distributed import Client, LocalCluster

    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.CRITICAL,
        preload=[WORKER_PRELOAD],
    )
    return Client(cluster), cluster


@contextlib.contextmanager
def cluster_client(client=None, scheduler: str | None = None, workers: int | None = None):
    """The Dask client to run on: `client` if given, else one connected to `scheduler`,
    else an embedded cluster of `workers` processes (`local_client`); the ones made here
    are closed on exit."""
    if client is not None:
        yield client
        return
    if scheduler is not None:
        from distributed import Client

        own = (Client(scheduler), None)
    else:
        own = local_client(workers)
    try:
        yield own[0]
    finally:
        own[0].close()
        if own[1] is not None:
            own[1].close()


def run_experiment(
    config: ExperimentConfig,
    store: str | os.PathLike,
    *,
    client=None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    rounds: int = 3,
    on_written: Callable[[str, int], None] | None = None,
) -> RunSummary:
    """Run (or resume) an experiment into one Zarr store.

    Parameters
    ----------
    config : ExperimentConfig
        What to run; must equal the configuration of an existing `store`.
    store : path-like
        The Zarr directory; created (with the rendered sequence) if missing.
    client : distributed.Client, keyword-only, optional
        Run on this client.  Otherwise on `scheduler`, otherwise on an embedded
        ``LocalCluster`` of `workers` processes with one thread each (default: the
        number of cores), closed on return.
    scheduler : str, keyword-only, optional
        Address of an existing Dask scheduler (``tcp://host:8786``).
    workers : int, keyword-only, optional
        Worker processes of the embedded cluster.
    progress : bool, keyword-only
        Show tqdm progress bars.
    rounds : int, keyword-only
        Times the trials still missing are resubmitted after losing workers or
        their data (``client.restart()``, killed processes).
    on_written : callable, keyword-only, optional
        Called with (predictor label, trial) after each trial is written.

    Returns
    -------
    RunSummary
        Trials already done, computed now, and still missing.

    Notes
    -----
    One process at a time runs an experiment into a store (`handvar.atomic.lock_directory`):
    a second one says so (a `handvar.atomic.BusyWarning`, ``store: another run is
    writing STORE; waiting for it to end``), waits, then resumes the store, computing
    what is still missing. Two runs creating the same new store at once create it once.
    """
    start = time.perf_counter()
    as_instance(config, ExperimentConfig, "config")
    if workers is not None:
        workers = as_int(workers, "workers", minimum=1)
    rounds = as_int(rounds, "rounds", minimum=1)
    if config.trial_kind == "tracker":
        tracker_settings(config.tracker)  # checks the overrides before anything runs
    for spec in config.predictors:
        spec.build()
    path = Path(store)
    if not path.exists():  # one run at a time creates it; a second one finds it there
        sequence = _render(config, progress)
        with lock_directory(path.parent, "store", wait=True):
            if not path.exists():
                create_store(path, config, sequence)
    with lock_directory(path, "store", wait=True):  # one run at a time writes trials
        return _run_locked(
            config, path, client, scheduler, workers, progress, rounds, on_written, start
        )


def _run_locked(config, path, client, scheduler, workers, progress, rounds, on_written, start):
    """`run_experiment` on the existing store `path`, which this process has locked."""
    config, sequence, done, writes, damage = _open_or_create(path, config, progress)
    labels = config.labels
    P, N = done.shape
    already = int(done.sum())
    todo = [(p, t) for t in range(N) for p in range(P) if not done[p, t]]
    computed = 0
    if todo:
        with cluster_client(client, scheduler, workers) as running:
            computed = _run_tasks(
                running, config, sequence, path, todo, done, writes, progress, rounds, on_written
            )
    # Scores a run stopped before writing (they are written after each trial).
    ds = open_store(path)
    done = ds["done"].values
    unscored = done & np.isnan(ds["r2_joints"].values).all(axis=2)
    for t in np.flatnonzero(unscored.any(axis=0)):
        write_scores(path, config, int(t))
    missing = tuple((labels[p], int(t)) for p, t in zip(*np.nonzero(~done), strict=True))
    repaired = tuple((d.label, d.trial) for d in damage)
    seconds = time.perf_counter() - start
    return RunSummary(path, P * N, already, computed, missing, seconds, repaired)


def _run_on_worker(runner: TrialRunner, config: ExperimentConfig, key: str, trial: int):
    """One trial on a worker, with the worker's own copy of the runner."""
    return runner.run(config, key, trial)


def _run_tasks(client, config, sequence, path, todo, done, writes, progress, rounds, on_written):
    from concurrent.futures import CancelledError

    from distributed import KilledWorker, as_completed
    from tqdm import tqdm

    labels = config.labels
    truth_joints = sequence.truth.joints
    computed = 0
    bar = tqdm(total=len(todo), desc="trials", unit="trial", disable=not progress)
    try:
        for _ in range(rounds):
            todo = [(p, t) for p, t in todo if not done[p, t]]
            if not todo:
                break
            # one runner per worker: its frame cache serves every trial it runs
            runner = client.scatter(TrialRunner(sequence), broadcast=True)
            futures = {}
            for p, t in todo:
                fut = client.submit(
                    _run_on_worker,
                    runner,
                    config,
                    config.predictors[p].key,
                    t,
                    pure=False,
                )
                futures[fut] = (p, t)
            lost = False
            for fut in as_completed(futures):
                p, t = futures[fut]
                try:
                    result = fut.result()
                except (CancelledError, KilledWorker):  # lost worker or data: next round
                    lost = True
                    continue
                except ValueError:
                    raise
                except Exception as exc:
                    raise RuntimeError(
                        f"trial {t} of predictor {labels[p]!r} failed: {exc!r}"
                    ) from exc
                writes[p, t] += 1
                write_trial(path, p, t, result, truth_joints, int(writes[p, t]))
                done[p, t] = True
                computed += 1
                bar.update(1)
                write_scores(path, config, t)
                if on_written is not None:
                    on_written(labels[p], t)
            del futures
            if not lost:
                break
    finally:
        bar.close()
    return computed


def summary_text(summary: RunSummary) -> str:
    """One line describing a run."""
    state = "complete" if summary.complete else f"{len(summary.missing)} trials missing"
    return (
        f"{summary.store}: {summary.total} trials, {summary.already_done} already done, "
        f"{summary.computed} computed in {summary.seconds:.1f} s ({state})"
    )
