"""All-or-nothing outputs, the directory swap, stale temporaries and permissions (design §13)."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from handvar import atomic
from handvar.atomic import OutputSet, recover_directory, replace_directory, user_paths
from handvar.cli import main
from handvar.io import read_sequence, write_sequence
from handvar.synth.sequences import make_sequence

SRC = str(Path(__file__).parents[1] / "src")


@pytest.fixture(scope="module")
def tiny():
    return make_sequence("flip", n_frames=2)


def test_output_set_commits_all_or_nothing(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    with pytest.raises(ZeroDivisionError), OutputSet() as out:
        out.add(tmp_path / "a.txt", lambda tmp: Path(tmp).write_text("new a"))
        out.add(tmp_path / "b.txt", lambda tmp: 1 / 0)
    assert sorted(os.listdir(tmp_path)) == ["a.txt"]
    assert (tmp_path / "a.txt").read_text() == "old a"
    with OutputSet() as out:
        out.add(tmp_path / "a.txt", lambda tmp: Path(tmp).write_text("new a"))
        out.add(tmp_path / "b.txt", lambda tmp: Path(tmp).write_text("new b"))
    assert (tmp_path / "a.txt").read_text() == "new a"
    assert sorted(os.listdir(tmp_path)) == ["a.txt", "b.txt"]


def test_failed_rename_during_commit_puts_earlier_files_back(tmp_path, monkeypatch):
    (tmp_path / "a.txt").write_text("old a")
    (tmp_path / "b.txt").write_text("old b")
    real = os.replace
    calls = []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 2:  # the second destination fails
            raise OSError("disk full")
        return real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", flaky)
    with pytest.raises(OSError, match="disk full"), OutputSet() as out:
        out.add(tmp_path / "a.txt", lambda tmp: Path(tmp).write_text("new a"))
        out.add(tmp_path / "b.txt", lambda tmp: Path(tmp).write_text("new b"))
    monkeypatch.undo()
    assert (tmp_path / "a.txt").read_text() == "old a"
    assert (tmp_path / "b.txt").read_text() == "old b"
    assert sorted(os.listdir(tmp_path)) == ["a.txt", "b.txt"]


def test_errors_name_the_users_path_not_the_temporary(tmp_path):
    def fail(tmp):
        raise OSError(f"{tmp}: cannot write the PNG")

    with pytest.raises(OSError) as info, OutputSet() as out:
        out.add(tmp_path / "x.png", fail)
    assert str(info.value) == f"{tmp_path / 'x.png'}: cannot write the PNG"
    tmp = atomic.temporary_name(tmp_path / "y.csv")
    assert user_paths(f"[Errno 13] Permission denied: '{tmp}'") == (
        f"[Errno 13] Permission denied: '{tmp_path / 'y.csv'}'"
    )


_KILL_DURING_SWAP = """
import os, signal, sys
sys.path.insert(0, {src!r})
from handvar import atomic
from handvar.io import write_sequence
from handvar.synth.sequences import make_sequence
seq = make_sequence("flip", n_frames=3)
real = os.replace
calls = []
def killing(src, dst):
    calls.append(dst)
    if str(dst) == {out!r}:  # OUT has just been moved aside: die before the new one lands
        os.kill(os.getpid(), signal.SIGKILL)
    return real(src, dst)
atomic.os.replace = killing
write_sequence(seq, {out!r})
"""


def test_a_swap_killed_half_way_leaves_out_recoverable(tmp_path, tiny):
    out = tmp_path / "seq"
    write_sequence(tiny, out)
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    script = textwrap.dedent(_KILL_DURING_SWAP).format(src=SRC, out=str(out))
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=300)
    assert proc.returncode == -9  # killed between the two renames
    assert not out.exists()  # the moment the swap exposes ...
    assert (tmp_path / ".seq.handvar-old").is_dir()  # ... with the old one kept aside
    seq = read_sequence(out)  # the next reader restores it
    assert seq.n_frames == 2
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    stale = [p.name for p in tmp_path.iterdir() if ".handvar-" in p.name]
    assert stale  # the killed run's new directory is still there ...
    res = CliRunner().invoke(main, ["synth", "flip", str(out), "--frames", "1"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seq"]  # ... until the next run
    assert read_sequence(out).n_frames == 1


def test_replace_directory_puts_the_old_one_back_on_failure(tmp_path, monkeypatch):
    old, new = tmp_path / "out", tmp_path / "new"
    old.mkdir()
    (old / "f").write_text("old")
    new.mkdir()
    (new / "f").write_text("new")
    real = os.replace

    def fail_second(src, dst):
        if Path(src) == new:
            raise OSError("no")
        return real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", fail_second)
    with pytest.raises(OSError):
        replace_directory(new, old)
    monkeypatch.undo()
    assert (old / "f").read_text() == "old"
    assert not recover_directory(old)  # nothing left to recover


def test_outputs_respect_the_umask(tmp_path, tiny):
    mask = os.umask(0o022)
    try:
        write_sequence(tiny, tmp_path / "seq")
        res = CliRunner().invoke(main, ["show", "open", "--out", str(tmp_path / "o.png")])
        assert res.exit_code == 0, res.output
    finally:
        os.umask(mask)
    assert stat.S_IMODE((tmp_path / "seq").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "seq" / "cam0").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "o.png").stat().st_mode) == 0o644


def test_failed_overlay_leaves_earlier_track_files_as_they_were(tmp_path, tiny, monkeypatch):
    import cv2

    from handvar.tracking import outputs

    write_sequence(tiny, tmp_path / "seq")
    out = tmp_path / "track"
    out.mkdir()
    for name in ("poses.csv", "joints.csv", "track.npz"):
        (out / name).write_bytes(b"old " + name.encode())
    real = cv2.imwrite
    monkeypatch.setattr(
        outputs.cv2, "imwrite", lambda path, *a: False if "overlay" in path else real(path, *a)
    )
    res = CliRunner().invoke(main, ["track", str(tmp_path / "seq"), "--out", str(out),
                                    "--no-video"])  # fmt: skip
    assert res.exit_code == 2
    last = res.output.strip().splitlines()[-1]  # after the progress bar (cleared on a tty)
    assert last == f"handvar: error: {out / 'overlay.png'}: cannot write the PNG"
    assert sorted(p.name for p in out.iterdir()) == ["joints.csv", "poses.csv", "track.npz"]
    for name in ("poses.csv", "joints.csv", "track.npz"):
        assert (out / name).read_bytes() == b"old " + name.encode()
    monkeypatch.undo()
    res = CliRunner().invoke(main, ["track", str(tmp_path / "seq"), "--out", str(out),
                                    "--no-video"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert np.loadtxt(out / "poses.csv", delimiter=",", skiprows=1).shape == (2, 26)
