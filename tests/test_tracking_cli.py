"""Tests of `handvar track`."""

from __future__ import annotations

import numpy as np
from click.testing import CliRunner

from handvar.cli import main
from handvar.hand import HandModel
from handvar.io import write_sequence
from handvar.synth.sequences import make_sequence


def test_track_writes_outputs_and_reports_error(tmp_path):
    seq = make_sequence("benchmark", n_frames=4)
    write_sequence(seq, tmp_path / "seq")
    out = tmp_path / "out"
    res = CliRunner().invoke(
        main,
        [
            "track",
            str(tmp_path / "seq"),
            "--predictor",
            "decel",
            "--seed",
            "2",
            "--out",
            str(out),
            "--no-video",
        ],
    )
    assert res.exit_code == 0, res.output
    assert "mean joint error" in res.output
    poses = np.loadtxt(out / "poses.csv", delimiter=",", skiprows=1)
    joints = np.loadtxt(out / "joints.csv", delimiter=",", skiprows=1)
    with np.load(out / "track.npz") as npz:
        data = {k: npz[k] for k in npz.files}
    assert poses.shape == (4, 26)
    np.testing.assert_allclose(poses, data["poses"], atol=1e-6)  # CSV round trip
    np.testing.assert_allclose(joints.reshape(4, 21, 3), data["joints"], atol=1e-4)
    np.testing.assert_allclose(data["joints"][3], HandModel().joints(data["poses"][3]))
    assert (out / "overlay.png").stat().st_size > 0
    err = np.linalg.norm(data["joints"] - seq.truth.joints, axis=-1).mean()
    assert f"{err:.2f} mm" in res.output


def test_track_errors_are_one_line(tmp_path):
    runner = CliRunner()
    res = runner.invoke(main, ["track", "nonesuch", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert res.output.strip().startswith("handvar: error: SEQ: expected")
    assert len(res.output.strip().splitlines()) == 1
    res = runner.invoke(main, ["track", "benchmark", "--frames", "2", "--init", "nope",
                               "--out", str(tmp_path / "o")])  # fmt: skip
    assert res.exit_code == 2 and "POSE" in res.output
