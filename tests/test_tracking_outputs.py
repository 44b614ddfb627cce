"""Tests of `handvar.tracking.outputs`: the files of a track read back."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from handvar.hand import HandModel
from handvar.params import NAMES
from handvar.synth.sequences import make_sequence
from handvar.tracking import Tracker
from handvar.tracking.outputs import write_track_outputs


@pytest.fixture(scope="module")
def tracked():
    seq = make_sequence("benchmark", n_frames=5)
    hand = HandModel()
    tracker = Tracker(seq.rig, hand, rng=np.random.default_rng(4))
    return seq, hand, tracker.track(seq, seq.truth.poses[0])


def test_files_read_back_as_the_track(tracked, tmp_path):
    seq, hand, result = tracked
    written = write_track_outputs(
        tmp_path / "out", result, seq, hand, predictor="decel", seed=4, video=False
    )
    assert sorted(written) == ["joints", "overlay", "poses", "track"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "joints.csv",
        "overlay.png",
        "poses.csv",
        "track.npz",
    ]  # no temporary files left behind

    with open(written["poses"], encoding="utf-8") as fh:
        assert fh.readline().strip().split(",") == list(NAMES)
    poses = np.loadtxt(written["poses"], delimiter=",", skiprows=1)
    np.testing.assert_allclose(poses, result.poses, rtol=0, atol=5e-7)  # "%.6f"
    with open(written["joints"], encoding="utf-8") as fh:
        header = fh.readline().strip().split(",")
    assert len(header) == 63 and header[:4] == ["j0_x", "j0_y", "j0_z", "j1_x"]
    joints = np.loadtxt(written["joints"], delimiter=",", skiprows=1).reshape(5, 21, 3)
    np.testing.assert_allclose(joints, result.joints, rtol=0, atol=5e-5)  # "%.4f"

    with np.load(written["track"]) as npz:
        for field in dataclasses.fields(result):
            np.testing.assert_array_equal(npz[field.name], getattr(result, field.name))
        assert str(npz["predictor"]) == "decel" and int(npz["seed"]) == 4

    strip = cv2.imread(str(written["overlay"]), cv2.IMREAD_COLOR)
    w, h = seq.rig[0].size
    # five tiles of half the first camera, 4-pixel gaps, a 28-pixel title bar
    assert strip.shape == (h // 2 + 28, 5 * (w // 2) + 4 * 4, 3)


def test_video_has_every_frame_and_replaces_the_old_one(tracked, tmp_path):
    seq, hand, result = tracked
    (tmp_path / "overlay.mp4").write_bytes(b"old")
    written = write_track_outputs(tmp_path, result, seq, hand, predictor="rvar", seed=0)
    assert "video_error" not in written
    video = written["video"]
    if video.name == "overlay_frames":  # OpenCV without the mp4v codec
        assert len(list(video.glob("frame_*.png"))) == 5
        return
    assert video == tmp_path / "overlay.mp4"
    capture = cv2.VideoCapture(str(video))
    try:
        assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 5
    finally:
        capture.release()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_more_frames_than_the_sequence_are_refused(tracked, tmp_path):
    _, hand, result = tracked
    with pytest.raises(ValueError, match="result: expected 1 to 3 tracked frames"):
        write_track_outputs(
            tmp_path, result, make_sequence("benchmark", n_frames=3), hand,
            predictor="rvar", seed=0,
        )  # fmt: skip
    assert not list(tmp_path.iterdir())
