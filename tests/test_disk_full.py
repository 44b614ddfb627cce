"""A full disk: every command names the path it could not write and says the disk is full.

The outputs go to a small tmpfs filled up first (mounted when the tests run as root,
as in the project's container); elsewhere every file opened for writing under the
folder fails its writes with ENOSPC, as a full disk does. Each command runs in its own
process, so a C library's output on file descriptor 2 (libpng's) would be seen.
Nothing is left behind: no temporary, no half-written file, the old files unchanged.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SRC = str(Path(__file__).parents[1] / "src")
FULL = "cannot write, the disk is full (No space left on device)"

# Fallback where no tmpfs can be mounted: a write under $HANDVAR_FULL fails with ENOSPC.
_FAKE_FULL = """
import builtins, errno, io, os
_open, _full = io.open, os.environ["HANDVAR_FULL"]
class _Full:
    def __init__(self, f): self._f = f
    def write(self, *_): raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    def __getattr__(self, name): return getattr(self._f, name)
    def __enter__(self): return self
    def __exit__(self, *exc): self._f.close()
def _open_full(file, mode="r", *args, **kwargs):
    f = _open(file, mode, *args, **kwargs)
    name = os.path.abspath(os.fspath(file)) if isinstance(file, (str, os.PathLike)) else ""
    return _Full(f) if set(mode) & set("wax+") and name.startswith(_full) else f
builtins.open = io.open = _open_full
"""


def fill(folder: Path) -> None:
    """Fill the disk of `folder` to the last byte (a file ``ballast``)."""
    with open(folder / "ballast", "ab") as fh:
        try:
            while True:
                fh.write(bytes(4096))
                fh.flush()
        except OSError:
            pass
        try:
            fh.close()
        except OSError:  # the buffer that did not fit
            pass


@pytest.fixture
def full(tmp_path):
    """A folder on a full disk, and how to run `handvar` with it: (folder, run)."""
    folder = tmp_path / "full"
    folder.mkdir()
    mounted = False
    if hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("mount"):
        mounted = (
            subprocess.run(
                ["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(folder)],
                capture_output=True,
            ).returncode
            == 0
        )
    (folder / "old.txt").write_bytes(b"old\n")  # a file that must survive
    if mounted:
        fill(folder)
    preamble = "" if mounted else _FAKE_FULL

    def run(*args: str) -> tuple[int, list[str]]:
        proc = subprocess.run(
            [sys.executable, "-c", preamble + "\nfrom handvar.cli import main; main()", *args],
            capture_output=True,
            env={**os.environ, "PYTHONPATH": SRC, "HANDVAR_FULL": str(folder)},
            timeout=600,
        )
        err = proc.stderr.decode(errors="replace")
        shown = [line.rsplit("\r", 1)[-1] for line in err.split("\n")]
        return proc.returncode, [line for line in shown if line.strip()]

    yield folder, run
    if mounted:
        subprocess.run(["umount", str(folder)], check=False)


def _left(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in ("ballast",))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("inputs")
    np.savetxt(root / "series.txt", np.random.default_rng(0).normal(size=(2000, 26)))
    return root


CASES = {  # command -> the path its one line must name (under the full folder)
    "predict": (["predict", "{i}/series.txt", "--csv", "{f}/x.csv"], "x.csv"),
    "show": (["show", "open", "--out", "{f}/o.png"], "o.png"),
    "synth": (["synth", "flip", "{f}/s", "--frames", "1"], "s/"),
    "track": (["track", "flip", "--frames", "1", "--no-video", "--out", "{f}/t"], "t/"),
    "init": (["init", "{i}/seq", "--out", "{f}/pose.txt", "--overlay", "{f}/o.png"], ""),
}


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n == "init" else n for n in CASES],  # its search
)
def test_a_full_disk_is_named_in_one_line(name, full, inputs):
    folder, run = full
    if name == "init" and not (inputs / "seq").exists():
        from handvar.io import write_sequence
        from handvar.synth.sequences import make_sequence

        write_sequence(make_sequence("flip", n_frames=1), inputs / "seq")
    args, names = CASES[name]
    status, lines = run(*(a.format(i=inputs, f=folder) for a in args))
    assert status == 2, lines
    assert len(lines) == 1, lines  # no "libpng error" line before it
    assert lines[0].startswith(f"handvar: error: {folder}/" + names), lines
    assert lines[0].endswith(FULL)
    assert ".handvar-" not in lines[0]
    assert _left(folder) == ["old.txt"]
    assert (folder / "old.txt").read_bytes() == b"old\n"


@pytest.mark.slow  # 11 s; track and predict on a full disk stay in the default run
def test_experiment_its_resume_and_report_on_a_full_disk(full, tmp_path):
    from handvar.evaluation.config import ExperimentConfig
    from handvar.evaluation.store import create_store, damaged_trials, write_scores, write_trial
    from handvar.evaluation.trials import TrialRunner
    from handvar.synth.sequences import make_sequence

    folder, run = full
    settings = [
        "--set", "trials=1", "--set", "frames=4", "--set", "trial_kind=openloop",
        "--set", "predictors=none,decelerating", "--workers", "1", "--no-progress",
    ]  # fmt: skip
    status, lines = run("experiment", "--out", f"{folder}/e.zarr", *settings)
    assert (status, lines) == (2, [f"handvar: error: {folder}/e.zarr: {FULL}"])
    assert _left(folder) == ["old.txt"]
    # a store whose trials are still to run, on the full disk: its resume
    config = ExperimentConfig().with_overrides([settings[k] for k in range(1, 8, 2)])
    mounted = (folder / "ballast").exists()
    if mounted:
        (folder / "ballast").unlink()  # room for the store, then full again
    sequence = make_sequence("benchmark", n_frames=4)
    create_store(folder / "r.zarr", config, sequence)
    if mounted:
        fill(folder)
    status, lines = run("experiment", "--out", f"{folder}/r.zarr", *settings)
    assert (status, lines) == (2, [f"handvar: error: {folder}/r.zarr: {FULL}"])
    assert damaged_trials(folder / "r.zarr") == []  # still a sound store, to resume later
    shutil.rmtree(folder / "r.zarr")
    if mounted:
        fill(folder)  # what the store took is free again
    # a finished store elsewhere, reported onto the full disk
    store = create_store(tmp_path / "e.zarr", config, sequence)
    runner = TrialRunner(sequence)
    for p, spec in enumerate(config.predictors):
        write_trial(store, p, 0, runner.run(config, spec.key, 0), sequence.truth.joints, 1)
    write_scores(store, config, 0)
    status, lines = run("report", str(store), "--out", f"{folder}/r")
    assert status == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"handvar: error: {folder}/r/") and lines[0].endswith(FULL)
    assert _left(folder) == ["old.txt"]
