"""Bad inputs to every command: one clean line, exit 2, and nothing that existed is lost.

Each case of :data:`CASES` runs one command with one wrong input and asserts (design
design §13.1, §13.4): exit status 2, exactly one line of output starting ``handvar: error:``,
naming the argument or the user's path (never a temporary), no traceback, no
temporary left behind, and every file that existed before byte-identical afterwards.
`studies/bad_inputs.py` runs the same table and prints the count of outcomes.

Cases that need FFmpeg's own stderr (a damaged video) run in a subprocess, where a C
library's output on file descriptor 2 is seen.
"""

from __future__ import annotations

import dataclasses
import os
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main

KNOWN = b"known bytes that must survive\n"


# --- the inputs ---------------------------------------------------------------------------


def make_inputs(root: Path) -> Path:
    """Write every input the cases use into `root` (tiny files; one 2-frame sequence)."""
    from handvar.camera import Rig
    from handvar.evaluation.config import ExperimentConfig
    from handvar.evaluation.store import create_store, write_scores, write_trial
    from handvar.evaluation.trials import TrialRunner
    from handvar.hand.kinematics import named_pose
    from handvar.io import Sequence, write_sequence
    from handvar.synth.sequences import make_sequence

    root.mkdir(parents=True, exist_ok=True)
    (root / "existing.txt").write_bytes(KNOWN)
    (root / "existing.png").write_bytes(KNOWN)
    (root / "existing.csv").write_bytes(KNOWN)
    (root / "adir").mkdir()
    (root / "adir" / "keep.txt").write_bytes(KNOWN)
    (root / "empty.txt").write_text("")
    (root / "abc.txt").write_text("abc " * 26)
    (root / "short.txt").write_text("1 2 3")
    pose = named_pose("open")
    (root / "good_pose.txt").write_text(" ".join(map(str, pose)))
    (root / "nan_pose.txt").write_text(" ".join(["nan", *map(str, pose[1:])]))
    far = pose.copy()
    far[2] = 1e12
    (root / "far_pose.txt").write_text(" ".join(map(str, far)))
    spin = pose.copy()
    spin[3] = 1e6
    (root / "spin_pose.txt").write_text(" ".join(map(str, spin)))
    behind = pose.copy()
    behind[2] = -600.0
    (root / "behind_pose.txt").write_text(" ".join(map(str, behind)))
    rng = np.random.default_rng(0)
    np.savetxt(root / "series.txt", rng.normal(size=(30, 26)))
    np.savetxt(root / "series_huge.txt", 1e200 * rng.normal(size=(30, 26)))
    np.savetxt(root / "series_cols.txt", rng.normal(size=(30, 5)))
    series_nan = rng.normal(size=(30, 26))
    series_nan[4, 4] = np.nan
    np.savetxt(root / "series_nan.txt", series_nan)
    (root / "random.mp4").write_bytes(rng.integers(0, 256, 4000, dtype=np.uint8).tobytes())
    (root / "noise.npy").write_bytes(b"not an npy file")
    # an MP4 header and nothing else: FFmpeg itself logs "moov atom not found"
    (root / "header.mp4").write_bytes(
        b"\x00\x00\x00\x18ftypmp42\x00\x00\x00\x00mp42isom" + bytes(3000)
    )
    # a sequence of 2 frames, and damaged copies of it
    seq = make_sequence("benchmark", n_frames=2)
    write_sequence(seq, root / "seq")
    write_sequence(seq, root / "seq_trunc")
    png = root / "seq_trunc" / "cam0" / "mask_00001.png"
    png.write_bytes(png.read_bytes()[:50])
    write_sequence(seq, root / "seq_json")
    (root / "seq_json" / "sequence.json").write_text("{not json")
    # a 3x3 blob in both cameras: nothing the hand model can fit
    rig = Rig.default()
    w, h = rig.cameras[0].size
    blob = np.zeros((1, len(rig), h, w), bool)
    blob[:, :, h // 2 : h // 2 + 3, w // 2 : w // 2 + 3] = True
    write_sequence(Sequence("blob", 25.0, rig, blob), root / "blob")
    # an experiment store of one open-loop trial per predictor, and damaged copies
    config = ExperimentConfig(trials=1, frames=6, trial_kind="openloop")
    six = make_sequence("benchmark", n_frames=6)
    store = create_store(root / "store.zarr", config, six)
    runner = TrialRunner(six)
    for p, spec in enumerate(config.predictors):
        write_trial(store, p, 0, runner.run(config, spec.key, 0), six.truth.joints, 1)
    write_scores(store, config, 0)
    import shutil

    shutil.copytree(store, root / "corrupt.zarr")
    (root / "corrupt.zarr" / "error" / "2.0.0").write_bytes(b"garbage")
    shutil.copytree(store, root / "deleted.zarr")
    (root / "deleted.zarr" / "poses" / "1.0.0.0").unlink()
    shutil.copytree(store, root / "nanned.zarr")
    # NaN where a finished trial must have numbers: rewrite one trial's errors
    from handvar.evaluation.store import _write_region

    nan_err = {"error": (("predictor", "trial", "frame"), np.full((1, 1, 6), np.nan))}
    _write_region(root / "nanned.zarr", nan_err, 3, 0)
    (root / "report_out").mkdir()
    (root / "report_out" / "report.md").write_bytes(KNOWN)
    (root / "track_out").mkdir()
    (root / "track_out" / "poses.csv").write_bytes(KNOWN)
    return root


# --- the cases ----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Case:
    """One bad input: the command's arguments (``{r}`` = the inputs' folder) and what
    the one line must name."""

    id: str
    args: tuple[str, ...]
    names: str
    subprocess: bool = False
    slow: bool = False


def _c(id, args, names, **kw) -> Case:
    return Case(id, tuple(shlex.split(args)), names, **kw)


# fmt: off
CASES = [
    # synth
    _c("synth-unknown-name", "synth nonesuch {r}/s1", "nonesuch"),
    _c("synth-out-empty", "synth flip --frames 1 ''", "OUT"),
    _c("synth-out-is-file", "synth flip {r}/existing.txt", "existing.txt"),
    _c("synth-out-under-file", "synth flip {r}/existing.txt/sub", "existing.txt"),
    _c("synth-out-other-dir", "synth flip {r}/adir", "adir"),
    _c("synth-frames-zero", "synth flip {r}/s1 --frames 0", "--frames"),
    _c("synth-frames-negative", "synth flip {r}/s1 --frames -3", "--frames"),
    _c("synth-seed-negative", "synth flip {r}/s1 --seed -1", "--seed"),
    _c("synth-seed-text", "synth flip {r}/s1 --seed abc", "--seed"),
    _c("synth-model-unknown", "synth flip {r}/s1 --model cubes", "--model"),
    # show
    _c("show-unknown-pose", "show nonesuch --out {r}/existing.png", "POSE"),
    _c("show-short-file", "show {r}/short.txt --out {r}/existing.png", "short.txt"),
    _c("show-empty-file", "show {r}/empty.txt --out {r}/existing.png", "empty.txt"),
    _c("show-text-file", "show {r}/abc.txt --out {r}/existing.png", "abc.txt"),
    _c("show-nan-pose", "show {r}/nan_pose.txt --out {r}/existing.png", "nan_pose.txt"),
    _c("show-far-pose", "show {r}/far_pose.txt --out {r}/existing.png", "tz"),
    _c("show-spun-pose", "show {r}/spin_pose.txt --out {r}/existing.png", "rx"),
    _c("show-behind", "show {r}/behind_pose.txt --out {r}/existing.png", "in front"),
    _c("show-corrupt-npy", "show {r}/noise.npy --out {r}/existing.png", "noise.npy"),
    _c("show-hand-length-huge", "show open --hand-length 1e9 --out {r}/x.png", "--hand-length"),
    _c("show-hand-length-zero", "show open --hand-length 0 --out {r}/x.png", "--hand-length"),
    _c("show-hand-length-nan", "show open --hand-length nan --out {r}/x.png", "--hand-length"),
    _c("show-out-dir", "show open --out {r}/adir", "adir"),
    _c("show-out-suffix", "show open --out {r}/x.jpg", "--out"),
    _c("show-out-no-folder", "show open --out {r}/nodir/x.png", "--out"),
    _c("show-out-empty", "show open --out=", "--out"),
    _c("show-frame-too-big", "show {r}/seq --frame 9 --out {r}/existing.png", "--frame"),
    _c("show-frame-not-seq", "show {r}/adir --frame 0 --out {r}/existing.png", "adir"),
    _c("show-frame-negative", "show {r}/seq --frame -1 --out {r}/existing.png", "--frame"),
    # predict
    _c("predict-missing", "predict {r}/nofile.txt", "nofile.txt"),
    _c("predict-directory", "predict {r}/adir", "adir"),
    _c("predict-empty", "predict {r}/empty.txt", "empty.txt"),
    _c("predict-text", "predict {r}/abc.txt", "abc.txt"),
    _c("predict-nan", "predict {r}/series_nan.txt", "series_nan.txt"),
    _c("predict-columns", "predict {r}/series_cols.txt", "series_cols.txt"),
    _c("predict-huge", "predict {r}/series_huge.txt", "series_huge.txt"),
    _c("predict-stride-zero", "predict {r}/series.txt --stride 0", "--stride"),
    _c("predict-reset-beyond", "predict {r}/series.txt --reset-at 999", "--reset-at"),
    _c("predict-reset-negative", "predict {r}/series.txt --reset-at -1", "--reset-at"),
    _c("predict-layout", "predict {r}/series.txt --layout nonesuch", "--layout"),
    _c("predict-csv-dir", "predict {r}/series.txt --csv {r}/adir", "adir"),
    _c("predict-csv-no-folder", "predict {r}/series.txt --csv {r}/nodir/x.csv", "--csv"),
    _c("predict-csv-suffix", "predict {r}/series.txt --csv {r}/x.png", "--csv"),
    _c("predict-csv-empty", "predict {r}/series.txt --csv=", "--csv"),
    _c("predict-corrupt-npy", "predict {r}/noise.npy", "noise.npy"),
    # track
    _c("track-unknown-seq", "track nonesuch --out {r}/t1", "SEQ"),
    _c("track-out-is-file", "track {r}/seq --out {r}/existing.txt", "existing.txt"),
    _c("track-out-under-file", "track {r}/seq --out {r}/existing.txt/t", "existing.txt"),
    _c("track-predictor", "track {r}/seq --predictor nonesuch --out {r}/t1", "--predictor"),
    _c("track-frames-zero", "track {r}/seq --frames 0 --out {r}/t1", "--frames"),
    _c("track-init-unknown", "track {r}/seq --init nonesuch --out {r}/t1", "POSE"),
    _c("track-init-far", "track {r}/seq --init {r}/far_pose.txt --out {r}/t1", "far_pose"),
    _c("track-init-nan", "track {r}/seq --init {r}/nan_pose.txt --out {r}/t1", "nan_pose"),
    _c("track-hand-length", "track {r}/seq --hand-length 10 --out {r}/t1", "--hand-length"),
    _c("track-calib-on-seq", "track {r}/seq --calib {r}/existing.txt --out {r}/t1", "--calib"),
    _c("track-truncated-png", "track {r}/seq_trunc --out {r}/track_out", "mask_00001.png"),
    _c("track-bad-json", "track {r}/seq_json --out {r}/track_out", "sequence.json"),
    _c("track-other-dir", "track {r}/adir --out {r}/track_out", "adir"),
    _c("track-scale-zero", "track {r}/seq --scale 0 --out {r}/t1", "--scale"),
    _c("track-no-out", "track {r}/seq", "--out"),
    _c("track-carry-on-seq", "track {r}/seq --carry forward --out {r}/t1", "--carry"),
    _c("track-carry-unknown", "track {r}/seq --carry sideways --out {r}/t1", "--carry"),
    _c("track-tips-unknown", "track {r}/seq --keypoint-tips nail --out {r}/t1",
       "--keypoint-tips"),
    _c("track-hand-unknown", "track {r}/seq --hand middle --out {r}/t1", "--hand"),
    _c("track-left-mesh", "track {r}/seq --hand left --model mesh --out {r}/t1", "--model"),
    # init
    _c("init-missing-source", "init {r}/nofile.mp4 --out {r}/existing.txt", "nofile.mp4"),
    _c("init-out-dir", "init {r}/seq --out {r}/adir", "adir"),
    _c("init-overlay-no-folder",
       "init {r}/seq --out {r}/existing.txt --overlay {r}/nodir/o.png", "--overlay"),
    _c("init-overlay-suffix",
       "init {r}/seq --out {r}/existing.txt --overlay {r}/o.jpg", "--overlay"),
    _c("init-frame-beyond", "init {r}/seq --frame 7 --out {r}/existing.txt", "--frame"),
    _c("init-threshold-zero", "init {r}/seq --threshold 0 --out {r}/existing.txt", "--threshold"),
    _c("init-keypoints-count",
       "init {r}/seq --keypoints {r}/a.npy --keypoints {r}/b.npy --out {r}/existing.txt",
       "--keypoints"),
    _c("init-keypoints-corrupt",
       "init {r}/seq --keypoints {r}/noise.npy --out {r}/existing.txt", "noise.npy"),
    _c("init-blob", "init {r}/blob --out {r}/existing.txt", "IoU", slow=True),
    _c("init-calib-on-seq", "init {r}/seq --calib {r}/existing.txt --out {r}/x.txt", "--calib"),
    _c("init-random-video", "init {r}/random.mp4 --out {r}/existing.txt", "random.mp4",
       subprocess=True),
    _c("track-random-video", "track {r}/random.mp4 --init open --out {r}/track_out",
       "random.mp4", subprocess=True),
    _c("init-header-only-video", "init {r}/header.mp4 --out {r}/existing.txt", "header.mp4",
       subprocess=True),
    _c("track-header-only-video", "track {r}/header.mp4 --init open --out {r}/track_out",
       "header.mp4", subprocess=True),
    # experiment
    _c("experiment-set-unknown", "experiment --out {r}/e.zarr --set nothing=1", "--set"),
    _c("experiment-set-trials-zero", "experiment --out {r}/e.zarr --set trials=0", "trials"),
    _c("experiment-set-trials-text", "experiment --out {r}/e.zarr --set trials=abc", "trials"),
    _c("experiment-set-no-equals", "experiment --out {r}/e.zarr --set trials", "--set"),
    _c("experiment-set-predictors",
       "experiment --out {r}/e.zarr --set predictors=nonesuch", "predictors"),
    _c("experiment-set-gamma", "experiment --out {r}/e.zarr --set rvar.gamma=abc", "gamma"),
    _c("experiment-set-tracker",
       "experiment --out {r}/e.zarr --set tracker.nonesuch=1", "tracker"),
    _c("experiment-sweep-text", "experiment --out {r}/e.zarr --sweep rvar.gamma=abc", "--sweep"),
    _c("experiment-sweep-unknown",
       "experiment --out {r}/e.zarr --sweep nonesuch.x=1", "--sweep"),
    _c("experiment-sweep-no-arg", "experiment --out {r}/e.zarr --sweep rvar=1", "--sweep"),
    _c("experiment-sweep-empty", "experiment --out {r}/e.zarr --sweep rvar.gamma=", "--sweep"),
    _c("experiment-workers-zero", "experiment --out {r}/e.zarr --workers 0", "--workers"),
    _c("experiment-out-file", "experiment --out {r}/existing.txt", "existing.txt"),
    _c("experiment-out-other-dir", "experiment --out {r}/adir", "adir"),
    _c("experiment-other-config",
       "experiment --out {r}/store.zarr --set trials=2", "different experiment"),
    # report
    _c("report-missing-store", "report {r}/nostore.zarr --out {r}/report_out", "nostore.zarr"),
    _c("report-not-a-store", "report {r}/adir --out {r}/report_out", "adir"),
    _c("report-corrupt-chunk", "report {r}/corrupt.zarr --out {r}/report_out", "trial 0"),
    _c("report-deleted-chunk", "report {r}/deleted.zarr --out {r}/report_out", "trial 0"),
    _c("report-nan-trial", "report {r}/nanned.zarr --out {r}/report_out", "trial 0"),
    _c("report-out-is-file", "report {r}/store.zarr --out {r}/existing.txt", "existing.txt"),
    # keypoints
    _c("keypoints-suffix", "keypoints {r}/random.mp4 --out {r}/k.txt", "k.txt"),
    _c("keypoints-out-dir", "keypoints {r}/random.mp4 --out {r}/adir", "adir"),
    _c("keypoints-out-no-folder", "keypoints {r}/random.mp4 --out {r}/nodir/k.npy", "--out"),
    _c("keypoints-frames-zero", "keypoints {r}/random.mp4 --out {r}/k.npy --frames 0", "--frames"),
    _c("keypoints-hand", "keypoints {r}/random.mp4 --out {r}/k.npy --hand both", "--hand"),
]
# fmt: on


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every file under `root` (relative path -> bytes); directories as None."""
    out: dict[str, bytes | None] = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        out[rel] = None if path.is_dir() else path.read_bytes()
    return out


@dataclasses.dataclass
class Outcome:
    status: int
    lines: list[str]
    before: dict
    after: dict

    def problems(self, case: Case, root: Path) -> list[str]:
        """What is wrong with this outcome (empty: a clean error)."""
        found = []
        text = "\n".join(self.lines)
        if "Traceback" in text:
            found.append("traceback")
        if self.status != 2:
            found.append(f"exit status {self.status}")
        if len(self.lines) != 1:
            found.append(f"{len(self.lines)} lines")
        elif not self.lines[0].startswith("handvar: error: "):
            found.append("not an error line")
        if case.names.format(r=root) not in text:
            found.append(f"does not name {case.names!r}")
        if ".handvar-" in text:
            found.append("names a temporary")
        changed = [k for k, v in self.before.items() if self.after.get(k, "gone") != v]
        if changed:
            found.append(f"changed {changed[:3]}")
        left = [k for k in self.after if ".handvar-" in k]
        if left:
            found.append(f"left temporaries {left[:3]}")
        return found


def run_case(case: Case, root: Path) -> Outcome:
    """Run one case against the inputs in `root`."""
    args = [a.format(r=root) for a in case.args]
    before = snapshot(root)
    if case.subprocess:
        proc = subprocess.run(
            [sys.executable, "-c", "from handvar.cli import main; main()", *args],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")},
            timeout=300,
        )
        status, output = proc.returncode, proc.stdout + proc.stderr
    else:
        result = CliRunner().invoke(main, args)
        status, output = result.exit_code, result.output
        if result.exception is not None and not isinstance(result.exception, SystemExit):
            import traceback

            output += "".join(traceback.format_exception(result.exception))
    lines = [line for line in output.splitlines() if line.strip()]
    return Outcome(status, lines, before, snapshot(root))


# --- the tests ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("bad"))


@pytest.mark.parametrize(
    "case",
    [pytest.param(c, id=c.id, marks=[pytest.mark.slow] if c.slow else []) for c in CASES],
)
def test_bad_input_is_one_clean_line_and_loses_nothing(case, inputs):
    outcome = run_case(case, inputs)
    assert outcome.problems(case, inputs) == [], outcome.lines


def test_the_table_covers_every_command():
    commands = {c.args[0] for c in CASES}
    assert commands == {
        "synth", "show", "predict", "track", "init", "experiment", "report", "keypoints"
    }  # fmt: skip
    assert len(CASES) >= 90


def test_unwritable_folder_is_refused_before_rendering(tmp_path, monkeypatch):
    # root may write anywhere, so the folder's permission is simulated
    from handvar import atomic

    real = os.access
    monkeypatch.setattr(
        atomic.os, "access", lambda p, mode: False if Path(p) == tmp_path else real(p, mode)
    )
    for args, name in [
        (["synth", "flip", str(tmp_path / "s")], "OUT"),
        (["show", "open", "--out", str(tmp_path / "o.png")], "--out"),
        (["predict", "x.txt", "--csv", str(tmp_path / "o.csv")], "--csv"),
        (["track", "flip", "--out", str(tmp_path / "t")], "--out"),
        (["report", "x.zarr", "--out", str(tmp_path / "r")], "--out"),
    ]:
        res = CliRunner().invoke(main, args)
        assert res.exit_code == 2, res.output
        assert res.output == f"handvar: error: {name}: expected a writable folder; cannot " \
            f"write into {tmp_path}\n"  # fmt: skip
    assert list(tmp_path.iterdir()) == []
