"""Two runs writing the same output at once, and a track over an earlier one (design §13.1).

`track` locks its --out for the whole run (`handvar.atomic.lock_directory`): a second
run into it stops at once with one line. `experiment` locks its store: a second run
says so, waits, and resumes the store once the first has ended; two runs creating the
same new store create it once. Runs are separate processes, as a user starts them.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main

SRC = str(Path(__file__).parents[1] / "src")
ENV = {**os.environ, "PYTHONPATH": SRC}


def handvar(*args: str) -> subprocess.Popen:
    """`handvar ARGS` started in its own process (output captured, as bytes)."""
    command = [sys.executable, "-c", "from handvar.cli import main; main()", *args]
    return subprocess.Popen(command, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def lines(output: bytes) -> list[str]:
    """What a terminal shows: progress bars erased by carriage returns are gone."""
    shown = (line.rsplit("\r", 1)[-1] for line in output.decode().split("\n"))
    return [line for line in shown if line.strip()]


def hold(directory: Path) -> subprocess.Popen:
    """Another process that locks `directory` until its standard input closes."""
    code = (
        "import sys; from handvar.atomic import lock_directory; "
        f"lock = lock_directory({str(directory)!r}, 'out'); print('locked', flush=True); "
        "sys.stdin.read()"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], env=ENV, stdin=subprocess.PIPE, stdout=subprocess.PIPE
    )
    assert proc.stdout.readline() == b"locked\n"
    return proc


def busy(out: Path) -> str:
    return f"handvar: error: --out: another run is writing {out}; wait for it to end"


def snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def test_a_track_owns_its_folder(tmp_path):
    out = tmp_path / "t"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    runner = CliRunner()
    first = runner.invoke(main, ["track", "flip", "--frames", "1", "--recover", "--out", str(out)])
    assert first.exit_code == 0, first.output
    assert {"quality.csv", "overlay.mp4"} <= {p.name for p in out.iterdir()}
    again = runner.invoke(main, ["track", "flip", "--frames", "1", "--no-video", "--out", str(out)])
    assert again.exit_code == 0, again.output
    # the earlier run's quality.csv and overlay.mp4 went; the user's own file stayed
    assert sorted(p.name for p in out.iterdir()) == [
        "cameras.yml", "joints.csv", "notes.txt", "overlay.png", "poses.csv", "track.npz"
    ]  # fmt: skip
    assert (out / "notes.txt").read_text() == "mine"


def test_a_second_track_into_the_same_out_stops_with_one_line(tmp_path):
    out = tmp_path / "t"
    out.mkdir()
    (out / "poses.csv").write_text("an earlier track\n")
    holder = hold(out)
    try:
        second = handvar("track", "flip", "--frames", "1", "--out", str(out))
        _, err = second.communicate(timeout=300)
    finally:
        holder.communicate(b"")
    assert second.returncode == 2
    assert lines(err) == [busy(out)]
    assert snapshot(out) == {"poses.csv": b"an earlier track\n"}
    # once the first has ended the folder is free again
    third = handvar("track", "flip", "--frames", "1", "--no-video", "--out", str(out))
    _, err = third.communicate(timeout=300)
    assert third.returncode == 0, err


def test_two_tracks_started_together_leave_one_whole_track(tmp_path):
    out = tmp_path / "t"
    args = ("track", "flip", "--frames", "2", "--no-video", "--out", str(out))
    runs = [handvar(*args), handvar(*args)]
    results = [(lines(p.communicate(timeout=300)[1]), p.returncode) for p in runs]
    results = [(code, err) for err, code in results]
    codes = sorted(code for code, _ in results)
    assert codes in ([0, 0], [0, 2]), results  # [0, 0]: one ended before the other began
    for code, err in results:
        if code == 2:
            assert err == [busy(out)]
    assert sorted(p.name for p in out.iterdir()) == [
        "cameras.yml", "joints.csv", "overlay.png", "poses.csv", "track.npz"
    ]  # fmt: skip
    poses = np.loadtxt(out / "poses.csv", delimiter=",", skiprows=1)
    assert poses.shape == (2, 26)


EXPERIMENT = (
    "experiment", "--set", "trials=1", "--set", "frames=4", "--set", "trial_kind=openloop",
    "--set", "predictors=none,decelerating", "--workers", "1", "--no-progress",
)  # fmt: skip


@pytest.mark.slow
def test_a_second_experiment_on_a_store_waits_then_resumes_it(tmp_path):
    from handvar.evaluation.store import damaged_trials, open_store

    store = tmp_path / "e.zarr"
    first = handvar(*EXPERIMENT, "--out", str(store))
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    holder = hold(store)  # a run still writing it
    try:
        second = handvar(*EXPERIMENT, "--out", str(store))
        said = second.stderr.readline().decode()  # blocks until it says why it waits
        assert second.poll() is None  # waiting, not finished
    finally:
        holder.communicate(b"")
    _, err = second.communicate(timeout=600)
    assert second.returncode == 0, err
    assert said == (
        f"handvar: warning: store: another run is writing {store}; waiting for it to end\n"
    )
    assert lines(err) == []
    assert damaged_trials(store) == []
    assert bool(open_store(store)["done"].values.all())


@pytest.mark.slow  # two clusters: 25 s; the waiting itself is checked above
def test_two_experiments_started_together_on_a_new_store_leave_a_sound_one(tmp_path):
    from handvar.evaluation.store import damaged_trials, open_store

    store = tmp_path / "e.zarr"
    runs = [handvar(*EXPERIMENT, "--out", str(store)) for _ in range(2)]
    results = [(p.communicate(timeout=600)[1], p.returncode) for p in runs]
    results = [(code, err) for err, code in results]
    assert [code for code, _ in results] == [0, 0], results
    assert damaged_trials(store) == []
    assert bool(open_store(store)["done"].values.all())
    assert [p.name for p in tmp_path.iterdir()] == ["e.zarr"]  # no temporaries left
    report = CliRunner().invoke(main, ["report", str(store), "--out", str(tmp_path / "r")])
    assert report.exit_code == 0, report.output
