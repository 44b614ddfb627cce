"""Many recordings at once: one `handvar.track` task per recording on a Dask cluster.

`track_many` tracks every recording (a video file, an image folder, or several
separated by commas: the cameras of one rig) with the same options, one task per
recording on the embedded ``LocalCluster`` (as `handvar.evaluation.experiment` runs its
trials) or on an existing scheduler, and writes each into ``OUT/<name>/`` (``name``: the
stem of its first camera's file).  The design note is docs/live-and-batch.md.

- A recording's folder is written whole or not at all: the task saves the track
  (`Track.save`) into a temporary folder beside it and renames it into place
  (`handvar.atomic.OutputSet`, `replace_directory`).  A folder that exists is complete.
- A run does only what is missing: recordings whose folder exists are skipped, so a
  run interrupted (Ctrl-C, a killed machine) keeps what finished and the next run
  does the rest.  The temporaries a killed run left are removed by the next.  Ctrl-C
  reaches the client alone (the embedded cluster's workers ignore it,
  `handvar.evaluation.experiment.local_client`): the command says ``handvar: aborted``
  and nothing else.
- A recording that fails (unreadable, no hand found, a bad option for it) gets its
  one-line error and the others go on.  A task whose worker died (killed, out of
  memory) is run again by the scheduler (``distributed.scheduler.allowed-failures``)
  and then resubmitted for up to `rounds` rounds; after that it counts as failed.
- On an existing scheduler the workers write the folders themselves: they must see
  the same file system as the client.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from handvar.validate import as_instance, as_int

__all__ = ["BatchSummary", "recording_name", "track_many", "track_one"]


@dataclass(frozen=True)
class BatchSummary:
    """What `track_many` did.

    Attributes
    ----------
    out : Path
        The output folder.
    names : tuple of str
        Every recording's folder name, in the order given.
    already_done : tuple of str
        Folders complete before the run (skipped).
    computed : tuple of str
        Folders written by this run.
    failed : dict of str to str
        Folder name → the one-line error of the recordings that failed.
    seconds : float
        Wall time of the run.
    """

    out: Path
    names: tuple[str, ...]
    already_done: tuple[str, ...]
    computed: tuple[str, ...]
    failed: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0

    def text(self) -> str:
        """One line describing the run."""
        state = "complete" if not self.failed else f"{len(self.failed)} failed"
        return (
            f"{self.out}: {len(self.names)} recordings, {len(self.already_done)} already "
            f"done, {len(self.computed)} tracked in {self.seconds:.1f} s ({state})"
        )


def recording_name(recording: str) -> str:
    """The output folder's name of a recording: its first camera's file stem.

    Examples
    --------
    >>> recording_name("clips/left.mp4,clips/right.mp4")
    'left'
    """
    first = recording.split(",")[0].rstrip("/\\")
    return Path(first).stem or first


def track_one(recording: str, directory: str, keypoints, options: dict, video: bool) -> str:
    """Track one recording and write its folder whole (a task of `track_many`).

    Parameters
    ----------
    recording : str
        What `handvar.track` takes as its source.
    directory : str
        The recording's output folder; written under a temporary name beside it and
        renamed into place once `Track.save` finished.
    keypoints : path-like, list of them, or None
        The recording's keypoints (`handvar.track`'s `keypoints`).
    options : dict
        The other keyword arguments of `handvar.track`.
    video : bool
        Also write the overlay video.

    Returns
    -------
    str
        One line: frames tracked and the fit quality.
    """
    from handvar.atomic import OutputSet
    from handvar.pipeline import track

    result = track(recording, keypoints=keypoints, **options)
    with OutputSet() as outputs:
        tmp = outputs.temporary(directory, directory=True)
        result.save(tmp, video=video)
        outputs.place(tmp, directory, directory=True)
    line = f"{result.n_frames} frames"
    if result.quality is not None:
        line += f"; {result.quality.summary()}"
    return line


def _checked(recordings, keypoints) -> tuple[list[str], list]:
    recordings = list(recordings)
    if not recordings or not all(isinstance(r, str) and r for r in recordings):
        raise ValueError(f"recordings: expected one or more recordings; got {recordings!r}")
    names = [recording_name(r) for r in recordings]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(
            f"recordings: expected distinct file names (each is written to OUT/<name>); "
            f"got {', '.join(twice)} more than once"
        )
    if keypoints is None:
        return names, [None] * len(recordings)
    keypoints = list(keypoints)
    if len(keypoints) != len(recordings):
        raise ValueError(
            f"keypoints: expected one file per recording ({len(recordings)}), in order; "
            f"got {len(keypoints)}"
        )
    for r, k in zip(recordings, keypoints, strict=True):
        if k is not None and "," in r:
            raise ValueError(
                f"keypoints: expected none for a recording of several cameras in a batch; "
                f"got {k} for {r}"
            )
    return names, keypoints


def track_many(
    recordings: Sequence[str],
    out: str | os.PathLike,
    *,
    keypoints: Sequence | None = None,
    video: bool = True,
    client=None,
    scheduler: str | None = None,
    workers: int | None = None,
    rounds: int = 3,
    progress: bool = False,
    on_done: Callable[[str, str | None, str], None] | None = None,
    task: Callable = track_one,
    **options,
) -> BatchSummary:
    """Track every recording into ``out/<name>/``, one task per recording (module notes).

    Parameters
    ----------
    recordings : sequence of str
        Video files or image folders (several separated by commas: one rig's cameras,
        with `options` ``calib``), with distinct file stems.
    out : path-like
        Output folder, made if missing.
    keypoints : sequence, keyword-only, optional
        One entry per recording, in order: its keypoint file (or None); a recording of
        several cameras takes none here.
    video : bool, keyword-only
        Also write each recording's overlay video.
    client : distributed.Client, keyword-only, optional
        Run on this client; otherwise on `scheduler`, otherwise on an embedded
        ``LocalCluster`` of `workers` processes (default: the number of cores).
    scheduler : str, keyword-only, optional
        Address of an existing Dask scheduler (``tcp://host:8786``).
    workers : int, keyword-only, optional
        Worker processes of the embedded cluster.
    rounds : int, keyword-only
        Times the recordings whose worker was lost are resubmitted.
    progress : bool, keyword-only
        Show a progress bar.
    on_done : callable, keyword-only, optional
        Called as ``on_done(name, error, line)`` as each recording ends: error None
        and the task's line on success, else the one-line error.
    task : callable, keyword-only
        Run per recording as ``task(recording, directory, keypoints, options, video)``
        (`track_one`); another one may add outputs.
    **options
        Keyword arguments of `handvar.track` for every recording (``scale``,
        ``frames``, ``predictor``, ...).

    Returns
    -------
    BatchSummary

    Raises
    ------
    ValueError
        Bad recordings, keypoints or options, before anything runs.
    """
    from handvar.atomic import check_output_dir, recover_directory

    start = time.perf_counter()
    names, keypoints = _checked(recordings, keypoints)
    recordings = list(recordings)
    rounds = as_int(rounds, "rounds", minimum=1)
    if workers is not None:
        workers = as_int(workers, "workers", minimum=1)
    as_instance(video, bool, "video")
    for bad in ("source", "realtime", "on_frame", "progress"):
        if bad in options:
            raise ValueError(f"{bad}: expected not in a batch of recordings; got {bad}")
    check_output_dir(out, "out")
    root = Path(out)
    root.mkdir(parents=True, exist_ok=True)
    targets = {n: root / n for n in names}
    for target in targets.values():
        recover_directory(target)
    done = tuple(n for n in names if targets[n].is_dir())
    todo = [i for i, n in enumerate(names) if n not in done]
    computed, failed = [], {}
    if todo:
        from handvar.evaluation.experiment import cluster_client

        with cluster_client(client, scheduler, workers) as running:
            _run(
                running, task, recordings, names, keypoints, targets, todo, options, video,
                rounds, progress, computed, failed, on_done,
            )  # fmt: skip
    return BatchSummary(
        root, tuple(names), done, tuple(computed), failed, time.perf_counter() - start
    )


def _run(client, task, recordings, names, keypoints, targets, todo, options, video, rounds,
         progress, computed, failed, on_done) -> None:  # fmt: skip
    from concurrent.futures import CancelledError

    from distributed import KilledWorker, as_completed
    from tqdm import tqdm

    from handvar.atomic import user_paths

    bar = tqdm(total=len(todo), desc="recordings", unit="rec", disable=not progress)

    def report(i: int, error: str | None, line: str) -> None:
        if error is None:
            computed.append(names[i])
        else:
            failed[names[i]] = error
        bar.update(1)
        if on_done is not None:
            on_done(names[i], error, line)

    try:
        lost: list[int] = list(todo)
        for _ in range(rounds):
            if not lost:
                break
            futures = {
                client.submit(
                    _task, task, recordings[i], str(targets[names[i]]), keypoints[i], options,
                    video, pure=False, key=f"track-{names[i]}-{time.monotonic_ns()}",
                ): i
                for i in lost
            }  # fmt: skip
            lost = []
            for fut in as_completed(futures):
                i = futures[fut]
                try:
                    ok, text = fut.result()
                except (CancelledError, KilledWorker):  # lost worker: the next round
                    lost.append(i)
                    continue
                if ok:
                    report(i, None, text)
                else:
                    report(i, user_paths(" ".join(text.split())), "")
        for i in lost:
            report(i, f"{recordings[i]}: its worker was lost {rounds} times", "")
    except KeyboardInterrupt:  # Ctrl-C: the bar is erased, the command's one line stays
        bar.leave = False
        raise
    finally:
        bar.close()


def _task(task, recording, directory, keypoints, options, video) -> tuple[bool, str]:
    """Run `task` on a worker: (True, its line), or (False, the one-line error)."""
    from handvar.atomic import user_paths

    try:
        return True, task(recording, directory, keypoints, options, video)
    except (ValueError, TypeError, OSError) as exc:
        message = user_paths(str(exc))
        if recording not in message:
            message = f"{recording}: {message}"
        return False, message
    except Exception as exc:  # a fault of ours: reported, the others go on
        return False, f"{recording}: {type(exc).__name__}: {exc}"
