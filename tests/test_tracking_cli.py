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


def test_track_out_keeps_the_hand_cameras_and_frame_rate(tmp_path):
    """What `handvar track --out` writes, `Track.load` rebuilds: the hand it was told,
    the sequence's cameras (cameras.yml) and frame rate, its name."""
    from handvar.camera import Rig
    from handvar.hand.anthropometry import HandShape
    from handvar.pipeline import Track

    seq = make_sequence("benchmark", n_frames=2)
    write_sequence(seq, tmp_path / "seq")
    out = tmp_path / "out"
    res = CliRunner().invoke(
        main,
        ["track", str(tmp_path / "seq"), "--hand", "left", "--hand-length", "170",
         "--out", str(out), "--no-video"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    back = Track.load(out)
    want = HandShape.from_size(170.0, side="left")
    assert back.shape.side == "left"
    np.testing.assert_array_equal(back.shape.bases, want.bases)
    np.testing.assert_array_equal(back.shape.radii, want.radii)
    assert back.rig == seq.rig and Rig.load(out / "cameras.yml") == seq.rig
    assert back.fps == seq.fps and back.name == seq.name
