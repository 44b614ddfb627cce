"""The benchmark, flexion and flip sequences: motion, ground truth, rendering, CLI."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.camera import Rig
from handvar.cli import main
from handvar.hand.kinematics import HandModel
from handvar.io import read_sequence
from handvar.params import clamp, index, within_limits
from handvar.render import silhouettes
from handvar.synth.motion import builtin_recording, replay
from handvar.synth.sequences import (
    SEQUENCE_NAMES,
    BenchmarkSettings,
    benchmark,
    flexion,
    flip,
    make_sequence,
    render_sequence,
    sequence_poses,
)

FPS = 25.0
TIPS = {"thumb": 4, "index": 8, "middle": 12, "ring": 16, "little": 20}
LENGTHS = {"benchmark": 175, "flexion": 280, "flip": 80}


@pytest.fixture(scope="module")
def hand() -> HandModel:
    return HandModel()


@pytest.fixture(scope="module")
def joints(hand):
    """G(x) of every frame of every sequence (seed 0), (T, 21, 3) mm."""
    return {
        name: np.stack([hand.joints(x) for x in sequence_poses(name, 0)]) for name in SEQUENCE_NAMES
    }


def _tip_speed(g: np.ndarray, tip: int) -> np.ndarray:
    """Fingertip speed (mm/s) per frame, central differences, (T,)."""
    return np.linalg.norm(np.gradient(g[:, tip], axis=0), axis=1) * FPS


@pytest.mark.parametrize("name", SEQUENCE_NAMES)
def test_sequences_have_their_length_stay_in_limits_and_are_deterministic(name):
    poses = sequence_poses(name, 0)
    assert poses.shape == (LENGTHS[name], 26)
    assert np.all(np.isfinite(poses))
    assert np.all(within_limits(poses, tol=0.0))
    np.testing.assert_array_equal(poses, sequence_poses(name, 0))
    other = sequence_poses(name, 1)
    assert other.shape == poses.shape
    assert np.abs(other - poses).max() > 1.0


@pytest.mark.parametrize("name", SEQUENCE_NAMES)
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_no_joint_moves_faster_than_1000_degrees_per_second(name, seed):
    poses = sequence_poses(name, seed)
    speed = np.abs(np.diff(poses[:, 3:], axis=0)) * FPS  # degrees per second
    assert speed.max() < 1000.0
    # and the translation stays below 1 m/s
    assert np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1).max() * FPS < 1000.0


def _event_ratio(g, tips, frame, window=2):
    speeds = np.mean([_tip_speed(g, TIPS[t]) for t in tips], axis=0)
    return speeds[frame - window : frame + window + 1].max() / np.median(speeds)


@pytest.mark.parametrize(
    ("tips", "frame"),
    [
        (("little",), 73),
        (tuple(TIPS), 100),
        (("thumb",), 150),
    ],
)
def test_benchmark_events_are_clearly_faster_than_usual(joints, tips, frame):
    assert _event_ratio(joints["benchmark"], tips, frame) > 3.0


@pytest.mark.parametrize("seed", [1, 7])
def test_benchmark_events_stay_at_their_frames_for_other_seeds(hand, seed):
    g = np.stack([hand.joints(x) for x in benchmark(seed)])
    for tips, frame in ((("little",), 73), (tuple(TIPS), 100), (("thumb",), 150)):
        ratio = _event_ratio(g, tips, frame)
        assert ratio > 3.0, (tips, frame, ratio)


def test_benchmark_fingers_replay_the_real_recording():
    # the index finger is moved by the recording alone: one of the allowed shifts of
    # the excerpt reproduces its three joint angles exactly
    poses = benchmark(0)
    s = BenchmarkSettings()
    cols = [index(n) for n in ("index_mcp", "index_pip", "index_dip")]
    rows = int(np.ceil((s.n_frames - 1) / s.fps * s.source_fps * s.replay_speed)) + 2
    recording = builtin_recording()
    errors = []
    for shift in range(-s.excerpt_jitter, s.excerpt_jitter + 1):
        start = s.excerpt_start + shift
        real = replay(recording, start=start, stop=start + rows, speed=s.replay_speed)
        errors.append(np.abs(clamp(real[: s.n_frames])[:, cols] - poses[:, cols]).max())
    assert min(errors) < 1e-9
    assert np.ptp(poses[:, cols[1]]) > 40.0  # real articulation, not a still finger


def test_flexion_moves_each_digit_alone_then_together(joints):
    poses = flexion(0)
    g = joints["flexion"]
    n = poses.shape[0]
    pip = {d: poses[:, index(f"{d}_pip")] for d in ("index", "middle", "ring", "little")}
    pip["thumb"] = poses[:, index("thumb_ip")]
    # the fingers first flex together where all four PIP joints pass 30°
    together = np.min([pip[d] for d in ("index", "middle", "ring", "little")], axis=0)
    first = int(np.argmax(together > 30.0))
    assert 0.4 * n < first < 0.8 * n
    assert together[first:].max() > 60.0
    # before that, each digit peaks alone, in turn: thumb, index, middle, ring, little
    peaks = [int(np.argmax(pip[d][:first])) for d in TIPS]
    assert peaks == sorted(peaks), peaks
    for d, peak in zip(TIPS, peaks, strict=True):
        assert pip[d][peak] > 40.0
        others = [pip[o][peak] for o in TIPS if o != d]
        assert max(others) < 0.5 * pip[d][peak], (d, others)
    # fingertips actually travel: each tip comes within 100 mm of the wrist
    for d, tip in TIPS.items():
        if d != "thumb":
            assert np.linalg.norm(g[:, tip] - g[:, 0], axis=1).min() < 100.0


def _palm_normal_angles(g: np.ndarray, rig: Rig) -> np.ndarray:
    """Angle (degrees) between the palm normal, from G(x), and the direction to the cameras."""
    across = g[:, 5] - g[:, 17]  # index MCP minus little MCP: towards the thumb (+x)
    along = g[:, 9] - g[:, 0]  # wrist to middle MCP (+y)
    normal = np.cross(across, along)  # x × y = z, out of the palm
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    centre = g[:, [0, 5, 9, 13, 17]].mean(axis=1)
    to_cameras = np.mean([cam.center for cam in rig], axis=0) - centre
    to_cameras /= np.linalg.norm(to_cameras, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(normal * to_cameras, axis=1), -1, 1)))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_flip_turns_the_palm_away_and_back(hand, seed):
    g = np.stack([hand.joints(x) for x in flip(seed)])
    angles = _palm_normal_angles(g, Rig.default())
    assert angles[0] < 30.0 and angles[-1] < 30.0
    assert angles.max() > 150.0
    peak = int(np.argmax(angles))
    assert 20 < peak < 60


@pytest.mark.parametrize("name", SEQUENCE_NAMES)
def test_the_hand_stays_inside_both_images(joints, name):
    rig = Rig.default()
    g = joints[name].reshape(-1, 3)
    for cam in rig:
        px = cam.project(g)
        w, h = cam.size
        assert px[:, 0].min() > 20 and px[:, 0].max() < w - 20
        assert px[:, 1].min() > 20 and px[:, 1].max() < h - 20


def test_rendered_truth_matches_the_model(hand):
    poses = benchmark(0)[[0, 73, 100, 150]]
    seq = render_sequence(poses, name="bits", hand=hand, rgb=True, seed=3)
    rig = Rig.default()
    assert seq.masks.shape == (4, 2, 480, 640) and seq.rgb.shape == (4, 2, 480, 640, 3)
    for t in range(4):
        np.testing.assert_array_equal(seq.truth.joints[t], hand.joints(poses[t]))
        np.testing.assert_array_equal(seq.masks[t], silhouettes(hand, poses[t], rig))
        # every joint projects onto (or within a few pixels of) the silhouette
        for j, cam in enumerate(rig):
            px = np.rint(cam.project(seq.truth.joints[t])).astype(int)
            assert seq.masks[t, j][px[:, 1], px[:, 0]].mean() > 0.8
    # colour frames are seeded; the background stays put from frame to frame
    again = render_sequence(poses[:1], name="bits", hand=hand, rgb=True, seed=3)
    np.testing.assert_array_equal(again.rgb[0], seq.rgb[0])
    outside = ~(seq.masks[0] | seq.masks[1])
    np.testing.assert_array_equal(seq.rgb[0][outside], seq.rgb[1][outside])
    other = render_sequence(poses[:1], name="bits", hand=hand, rgb=True, seed=4)
    assert np.mean(other.rgb[0] != seq.rgb[0]) > 0.5


def test_bad_requests_are_rejected():
    with pytest.raises(ValueError, match="name: expected one of benchmark, flexion, flip"):
        sequence_poses("wave")
    with pytest.raises(ValueError, match="seed: expected a non-negative integer"):
        benchmark(-1)
    with pytest.raises(ValueError, match=r"poses: expected an array of shape \(T, 26\)"):
        render_sequence(np.zeros((3, 25)), name="x")
    with pytest.raises(ValueError, match="n_frames: expected a positive integer"):
        make_sequence("flip", n_frames=0)


# --- the command line ---------------------------------------------------------------------


def _check_written(out, n_frames, hand):
    seq = read_sequence(out)
    assert seq.masks.shape == (n_frames, 2, 480, 640)
    assert seq.truth.poses.shape == (n_frames, 26)
    assert seq.truth.joints.shape == (n_frames, 21, 3)
    np.testing.assert_array_equal(seq.truth.poses, benchmark(0)[:n_frames])
    rig = Rig.default()
    for t in sorted({0, n_frames // 2, n_frames - 1}):
        np.testing.assert_array_equal(seq.masks[t], silhouettes(hand, seq.truth.poses[t], rig))
        np.testing.assert_allclose(seq.truth.joints[t], hand.joints(seq.truth.poses[t]))
    assert seq.provenance["seed"] == 0 and "htrack" in seq.provenance["motion_source"]
    return seq


def test_cli_writes_a_short_benchmark(tmp_path, hand):
    out = tmp_path / "bench"
    result = CliRunner().invoke(main, ["synth", "benchmark", str(out), "--frames", "5"])
    assert result.exit_code == 0, result.output
    assert "benchmark: 5 frames" in result.output
    _check_written(out, 5, hand)


def test_cli_rejects_an_unknown_name_in_one_line(tmp_path):
    result = CliRunner().invoke(main, ["synth", "wave", str(tmp_path / "w")])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "benchmark, flexion, flip" in lines[0]
    assert not (tmp_path / "w").exists()


def test_cli_writes_the_whole_benchmark(tmp_path, hand):
    out = tmp_path / "bench"
    result = CliRunner().invoke(main, ["synth", "benchmark", str(out)])
    assert result.exit_code == 0, result.output
    seq = _check_written(out, 175, hand)
    assert len(list((out / "cam0").glob("mask_*.png"))) == 175
    assert len(list((out / "cam1").glob("mask_*.png"))) == 175
    # reading back gives the arrays rendered in memory, bit for bit
    rendered = make_sequence("benchmark", seed=0)
    np.testing.assert_array_equal(seq.masks, rendered.masks)
    np.testing.assert_array_equal(seq.truth.poses, rendered.truth.poses)
    np.testing.assert_array_equal(seq.truth.joints, rendered.truth.joints)
    assert seq.rig.allclose(rendered.rig, rtol=0.0, atol=0.0)


def test_cli_writes_colour_frames(tmp_path):
    out = tmp_path / "flip"
    result = CliRunner().invoke(main, ["synth", "flip", str(out), "--rgb", "--frames", "2"])
    assert result.exit_code == 0, result.output
    seq = read_sequence(out)
    assert seq.rgb.shape == (2, 2, 480, 640, 3)
    frame = seq.rgb[1]
    # hand pixels are skin-coloured (red above blue) where the mask says hand
    hand_pixels = frame[seq.masks[1]].astype(int)
    assert np.mean(hand_pixels[:, 0] > hand_pixels[:, 2]) > 0.9


def test_cli_show_draws_a_frame_of_a_sequence(tmp_path):
    import cv2

    seq_dir = tmp_path / "bench"
    runner = CliRunner()
    assert runner.invoke(main, ["synth", "benchmark", str(seq_dir), "--frames", "3"]).exit_code == 0
    png = tmp_path / "frame.png"
    result = runner.invoke(main, ["show", str(seq_dir), "--frame", "2", "--out", str(png)])
    assert result.exit_code == 0, result.output
    image = cv2.imread(str(png))
    assert image is not None and image.shape[1] >= 2 * 640
    result = runner.invoke(main, ["show", str(seq_dir), "--frame", "3", "--out", str(png)])
    assert result.exit_code == 2
    assert "--frame: expected a frame below 3; got 3" in result.output


def test_cli_refuses_to_overwrite_a_file(tmp_path):
    target = tmp_path / "notes.txt"
    target.write_text("keep me")
    result = CliRunner().invoke(main, ["synth", "flip", str(target)])
    assert result.exit_code == 2
    assert "notes.txt exists and holds something else" in result.output
    assert "rendering" not in result.output  # refused before any work
    assert target.read_text() == "keep me"
