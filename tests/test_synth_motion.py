"""Minimum-jerk key poses and the replay of the htrack recording."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.data import example_path
from handvar.params import LOWER, NAMES, UPPER, index, within_limits
from handvar.synth.motion import (
    HTRACK_EXCERPT_FIRST_ROW,
    builtin_recording,
    htrack_to_handvar,
    keyframe_motion,
    load_htrack,
    minimum_jerk,
    minimum_jerk_rate,
    poses_from_keys,
    replay,
    retime,
    split_at_jumps,
)

RECORDING = example_path("htrack")
needs_recording = pytest.mark.skipif(not RECORDING.exists(), reason="examples/data not present")


@pytest.fixture(scope="module")
def recording() -> np.ndarray:
    if not RECORDING.exists():
        pytest.skip("examples/data not present")
    return load_htrack(RECORDING)


# --- minimum jerk ---------------------------------------------------------------------


def test_minimum_jerk_boundary_values_and_symmetry():
    tau = np.linspace(0.0, 1.0, 101)
    s = minimum_jerk(tau)
    assert s[0] == 0.0 and s[-1] == 1.0
    assert minimum_jerk(0.5) == pytest.approx(0.5, abs=1e-15)
    # s(τ) + s(1 − τ) = 1 (point symmetry of the quintic about τ = ½)
    np.testing.assert_allclose(s + s[::-1], 1.0, atol=1e-14)
    assert np.all(np.diff(s) > 0)
    np.testing.assert_array_equal(minimum_jerk([-1.0, 2.0]), [0.0, 1.0])


def test_minimum_jerk_rate_matches_finite_differences():
    tau = np.linspace(0.01, 0.99, 50)
    h = 1e-6
    numeric = (minimum_jerk(tau + h) - minimum_jerk(tau - h)) / (2 * h)
    np.testing.assert_allclose(minimum_jerk_rate(tau), numeric, atol=1e-7)
    assert minimum_jerk_rate(0.5) == pytest.approx(15 / 8)
    assert minimum_jerk_rate(0.0) == 0.0 and minimum_jerk_rate(1.0) == 0.0


def test_minimum_jerk_has_zero_acceleration_at_the_ends():
    # s''(τ) = 60τ − 180τ² + 120τ³ vanishes at 0 and 1; one-sided differences inside
    h = 1e-6
    assert abs((minimum_jerk_rate(h) - minimum_jerk_rate(0.0)) / h) < 1e-4
    assert abs((minimum_jerk_rate(1.0) - minimum_jerk_rate(1.0 - h)) / h) < 1e-4
    # and it is 60τ(1 − τ)(1 − 2τ) in between
    tau = 0.3
    acc = (minimum_jerk_rate(tau + h) - minimum_jerk_rate(tau - h)) / (2 * h)
    assert acc == pytest.approx(60 * tau * (1 - tau) * (1 - 2 * tau), rel=1e-6)


# --- key poses ------------------------------------------------------------------------


def _keys():
    return poses_from_keys(
        [
            {"tz": 0.0},
            {"tz": 40.0, "index_mcp": 80.0, "rx": 30.0},
            {"tz": 10.0, "index_mcp": 20.0, "abd_little": 15.0},
        ]
    )


def test_keyframe_motion_passes_through_key_poses_at_key_times():
    keys = _keys()
    poses = keyframe_motion(keys, [1.0, 0.6], fps=25)
    assert poses.shape == (int(1.6 * 25) + 1, 26)
    np.testing.assert_allclose(poses[0], keys[0])
    np.testing.assert_allclose(poses[25], keys[1], atol=1e-12)
    np.testing.assert_allclose(poses[40], keys[2], atol=1e-12)
    # halfway through the first transition: the average of the two key poses
    mid = keyframe_motion(keys[:2], [1.0], fps=2)[1]
    np.testing.assert_allclose(mid, 0.5 * (keys[0] + keys[1]), atol=1e-12)


def test_keyframe_motion_is_minimum_jerk_in_every_parameter():
    keys = _keys()
    fps = 50.0
    poses = keyframe_motion(keys, [1.0, 0.6], fps=fps)
    t = np.arange(51) / fps
    expected = keys[0] + minimum_jerk(t)[:, None] * (keys[1] - keys[0])
    np.testing.assert_allclose(poses[:51], expected, atol=1e-12)


def test_keyframe_motion_times_and_durations_agree_and_holds_keep_still():
    keys = _keys()
    a = keyframe_motion(keys, [1.0, 0.6], fps=25)
    b = keyframe_motion(keys, times=[0.0, 1.0, 1.6], fps=25)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    held = keyframe_motion(keys, [1.0, 0.6], holds=[0.2, 0.4, 0.0], fps=25)
    assert held.shape[0] == a.shape[0] + 15
    np.testing.assert_allclose(held[:6], np.repeat(keys[:1], 6, axis=0))
    np.testing.assert_allclose(held[30:41], np.repeat(keys[1:2], 11, axis=0), atol=1e-12)
    np.testing.assert_allclose(held[-1], keys[2], atol=1e-12)


def test_keyframe_motion_stays_within_limits_and_rejects_keys_outside():
    rng = np.random.default_rng(3)
    keys = LOWER + rng.random((5, 26)) * (UPPER - LOWER)
    keys[:, :3] = rng.normal(0.0, 50.0, (5, 3))
    poses = keyframe_motion(keys, rng.uniform(0.2, 1.0, 4), fps=25)
    assert np.all(within_limits(poses, tol=0.0))
    bad = keys.copy()
    bad[2, index("index_pip")] = 150.0
    with pytest.raises(ValueError, match=r"key_poses: .*key pose 2 has index_pip = 150"):
        keyframe_motion(bad, [1.0] * 4)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"durations": [1.0]}, r"durations: expected 2 values"),
        ({"durations": [1.0, -1.0]}, r"durations: expected finite, non-negative"),
        ({"durations": [1.0, 0.0]}, r"durations: expected positive seconds"),
        ({}, r"durations, times: expected exactly one of them; got neither"),
        ({"durations": [1, 1], "times": [0, 1, 2]}, r"got both"),
        ({"times": [0.0, 2.0, 1.0]}, r"times: expected non-decreasing"),
        ({"times": [0.5, 1.0, 2.0]}, r"times: expected non-decreasing key times starting at 0"),
        ({"durations": [1.0, 1.0], "fps": 0}, r"fps: expected a positive frame rate"),
        ({"durations": [1.0, 1.0], "holds": [1.0]}, r"holds: expected 3 values"),
    ],
)
def test_keyframe_motion_rejects_bad_timing(kwargs, message):
    with pytest.raises(ValueError, match=message):
        keyframe_motion(_keys(), **kwargs)


def test_keyframe_motion_rejects_bad_key_poses():
    with pytest.raises(ValueError, match=r"key_poses: expected an array of shape \(K, 26\)"):
        keyframe_motion(np.zeros((3, 25)), [1.0, 1.0])
    keys = _keys()
    keys[1, 4] = np.nan
    with pytest.raises(ValueError, match="key_poses: expected finite values"):
        keyframe_motion(keys, [1.0, 1.0])
    with pytest.raises(ValueError, match=r"keys\[0\]: expected parameter names"):
        poses_from_keys([{"index_tip": 3.0}])


# --- the htrack recording -------------------------------------------------------------


def test_htrack_mapping_reorders_and_flips_signs_analytically():
    row = np.zeros((1, 26))
    row[0, 2] = 20.0  # tz, htrack unit (cm)
    row[0, 5] = np.pi / 2  # rz
    row[0, 6 + 4 * 2 + 2] = -1.0  # middle finger, second flexion (PIP)
    row[0, 6 + 4 * 3] = 0.1  # ring abduction, htrack sign
    out = htrack_to_handvar(row)
    assert out[0, index("tz")] == pytest.approx(200.0)
    assert out[0, index("rz")] == pytest.approx(90.0)
    assert out[0, index("middle_pip")] == pytest.approx(np.degrees(1.0) + 2.0)  # −(−57.3° − 2°)
    assert out[0, index("abd_ring")] == pytest.approx(-(np.degrees(0.1) + 8.0))  # rest −8°
    assert out.shape == (1, 26)


def test_htrack_fist_maps_to_large_positive_flexions(recording):
    poses = htrack_to_handvar(recording)
    fist = poses[3470:3500]  # the closed fist of the recording
    for digit in ("index", "middle", "ring", "little"):
        pip = fist[:, index(f"{digit}_pip")]
        assert np.median(pip) > 60.0, digit
    # open, still hand: close to our straight zero posture (rest removed)
    rest = np.median(poses[3640:4000, 6:], axis=0)
    assert np.all(np.abs(rest) < 2.0), dict(zip(NAMES[6:], rest.round(1), strict=True))


def test_htrack_recording_has_one_discontinuity(recording):
    from handvar.synth.motion import _HTRACK_MAX_STEP

    segments = split_at_jumps(recording, _HTRACK_MAX_STEP)
    assert [(s.start, s.stop) for s in segments] == [(0, 4000), (4000, 6000)]
    with pytest.raises(ValueError, match="cross a discontinuity between rows 3999 and 4000"):
        replay(recording, start=3990, stop=4010)


def test_builtin_recording_is_the_stated_excerpt(recording):
    excerpt = builtin_recording()
    first = HTRACK_EXCERPT_FIRST_ROW
    np.testing.assert_array_equal(excerpt, recording[first : first + excerpt.shape[0]])
    assert excerpt.shape == (900, 26)


def test_load_htrack_names_the_file_on_bad_content(tmp_path):
    bad = tmp_path / "poses.txt"
    bad.write_text("1 2 3\n4 5 6\n")
    with pytest.raises(ValueError, match=r"poses\.txt: expected rows of 26 numbers"):
        load_htrack(bad)
    bad.write_text("1 2 x\n")
    with pytest.raises(ValueError, match=r"poses\.txt: expected a whitespace table"):
        load_htrack(bad)
    with pytest.raises(OSError):
        load_htrack(tmp_path / "missing.txt")


def test_retime_resamples_a_known_signal():
    source_fps, fps = 30.0, 25.0
    t = np.arange(301) / source_fps
    signal = np.stack([np.sin(2 * np.pi * 0.5 * t), np.cos(2 * np.pi * 0.3 * t)], axis=1)
    out = retime(signal, source_fps, fps, smooth_sigma=0.0)
    assert out.shape == (251, 2)
    t_out = np.arange(251) / fps
    expected = np.stack([np.sin(2 * np.pi * 0.5 * t_out), np.cos(2 * np.pi * 0.3 * t_out)], 1)
    np.testing.assert_allclose(out, expected, atol=1e-4)
    fast = retime(signal, source_fps, fps, speed=2.0, smooth_sigma=0.0)
    assert fast.shape == (126, 2)
    np.testing.assert_allclose(fast, expected[: 2 * 126 : 2], atol=1e-3)


def test_replay_of_the_builtin_excerpt_is_within_limits_and_smooth():
    poses = replay(builtin_recording(), source_fps=30.0, fps=25.0)
    assert poses.shape == (int(899 / 30 * 25) + 1, 26)
    assert np.all(within_limits(poses, tol=0.0))
    speed = np.abs(np.diff(poses[:, 6:], axis=0)) * 25.0  # degrees per second
    assert speed.max() < 1000.0
    # the index finger flexes fully in this excerpt
    assert poses[:, index("index_pip")].max() > 80.0


def test_replay_reads_a_path_and_checks_its_range(tmp_path):
    table = builtin_recording()[:40]
    file = tmp_path / "short.txt"
    np.savetxt(file, table)
    np.testing.assert_allclose(replay(file), replay(table))
    with pytest.raises(ValueError, match="start, stop: expected 0 <= start < stop <= 40"):
        replay(table, start=10, stop=50)


def test_minimum_jerk_path_through_knots_and_jumps():
    from handvar.synth.motion import minimum_jerk_path

    t = np.array([-1.0, 0.0, 0.25, 1.0, 2.0, 2.0 + 1e-12, 5.0])
    values = minimum_jerk_path(t, [0.0, 1.0, 2.0, 2.0], [0.0, 8.0, 8.0, -3.0])
    # s(¼) = 10/64 − 15/256 + 6/1024 = 53/512, by hand
    np.testing.assert_allclose(values, [0.0, 0.0, 8 * 53 / 512, 8.0, -3.0, -3.0, -3.0])
    two = minimum_jerk_path(t, [0.0, 1.0], np.array([[0.0, 1.0], [2.0, -1.0]]))
    assert two.shape == (7, 2)
    np.testing.assert_allclose(two[:, 0] + two[:, 1], 1.0)
    with pytest.raises(ValueError, match="key_times: expected non-decreasing"):
        minimum_jerk_path(t, [1.0, 0.0], [0.0, 1.0])
