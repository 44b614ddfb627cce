"""R̃² (eq. 18, 21), the mean joint error and the 3D alignments (against scipy)."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.evaluation import mean_joint_error, r2_tilde, r2_tilde_acceleration, r2_tilde_joints
from handvar.evaluation.metrics import acceleration_error, joint_errors, lag, rotation_about_wrist


def test_r2_tilde_joints_by_hand():
    T = 5
    truth = np.zeros((T, 2, 3))
    with_model = truth.copy()
    without = truth.copy()
    with_model[:, 0, 0] = 1.0  # joint 0: error 1 with the model, 2 without
    without[:, 0, 0] = 2.0
    with_model[:, 1, 1] = 3.0  # joint 1: error 3 with the model, 1 without
    without[:, 1, 2] = 1.0
    np.testing.assert_allclose(r2_tilde_joints(truth, with_model, without), [1 - 1 / 4, 1 - 9])
    np.testing.assert_allclose(r2_tilde(truth, with_model, without), [0.75, -8.0])


def test_r2_tilde_acceleration_differences_the_series():
    # Truth with constant acceleration 2; the model run's acceleration errs by 1 at
    # one frame, the no-motion run's by 2 at the same frame: R̃² = 1 - 1/4.
    t = np.arange(6.0)
    truth = (t**2)[:, None]
    with_model = truth.copy()
    without = truth.copy()
    with_model[3] += 1.0  # shifts y at t = 3, 4, 5 by +1, -2, +1: Σ = 6
    without[3] += 2.0  # by +2, -4, +2: Σ = 24
    np.testing.assert_allclose(r2_tilde_acceleration(truth, with_model, without), [1 - 6 / 24])


def test_a_perfect_no_motion_run_has_no_score():
    z = np.zeros((3, 1, 3))
    assert np.isnan(r2_tilde(z, z + 1.0, z)[0])


def test_mean_joint_error():
    truth = np.zeros((2, 21, 3))
    est = truth.copy()
    est[0, :, 0] = 3.0
    est[1, 0] = (3.0, 4.0, 0.0)  # one joint 5 mm off
    np.testing.assert_allclose(mean_joint_error(truth, est), [3.0, 5.0 / 21])
    assert mean_joint_error(truth[0], est[0]) == pytest.approx(3.0)


@pytest.mark.parametrize(
    ("args", "name"),
    [
        ((np.zeros((4, 2, 3)), np.zeros((4, 2, 3)), np.zeros((4, 3, 3))), "with_model"),
        ((np.zeros((4, 2, 3)), np.full((4, 2, 3), np.nan), np.zeros((4, 2, 3))), "with_model"),
        ((np.zeros(4), np.zeros(4), np.zeros(4)), "truth"),
    ],
)
def test_bad_input_names_the_argument(args, name):
    with pytest.raises(ValueError, match=rf"^{name}"):
        r2_tilde(*args)


@pytest.mark.parametrize("seed", range(3))
def test_the_orientation_error_is_the_rotation_scipy_finds(seed):
    """`rotation_about_wrist` against scipy's own least-squares rotation of the
    wrist-centred points; turned by it, the estimate is never farther from the truth (in
    squared error) than taken at its wrist alone, and a turned copy is no error at all."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    truth = rng.normal(0.0, 50.0, (2, 21, 3))
    turn = Rotation.random(random_state=seed)
    estimate = turn.apply((truth - truth[:, :1]).reshape(-1, 3)).reshape(2, 21, 3) + 7.0
    estimate[1] += rng.normal(0.0, 5.0, (21, 3))
    reference, _ = Rotation.align_vectors(truth[1] - truth[1, 0], estimate[1] - estimate[1, 0])
    np.testing.assert_allclose(
        rotation_about_wrist(estimate[1], truth[1]), reference.as_matrix(), atol=1e-9
    )
    turned = joint_errors(truth, estimate, alignment="rotation")
    np.testing.assert_allclose(turned[0], 0.0, atol=1e-9)
    at_wrist = joint_errors(truth, estimate, alignment="wrist")
    assert (turned[1] ** 2).sum() < (at_wrist[1] ** 2).sum()


def _moving_hand(T: int = 120, seed: int = 0) -> np.ndarray:
    """(T, 21, 3) mm: every joint on its own slow sinusoid about the wrist (periods of
    40–80 frames, as fingers counting at 30 frames/s), the wrist itself moving too."""
    rng = np.random.default_rng(seed)
    t = np.arange(T, dtype=float)[:, None, None]
    period = rng.uniform(40.0, 80.0, (1, 21, 3))
    phase = rng.uniform(0.0, 2 * np.pi, (1, 21, 3))
    return rng.normal(0.0, 40.0, (1, 21, 3)) + 20.0 * np.sin(2 * np.pi * t / period + phase)


@pytest.mark.parametrize("seed", range(3))
def test_lag_finds_a_delay_and_an_exponential_averages_group_delay(seed):
    """A copy of the motion two frames late trails by 2.0; an exponential average of
    weight α = 0.5, by its group delay (1 − α)/α = 1 frame on slow motion; the truth with
    noise alone (and moved as a whole) does not trail."""
    rng = np.random.default_rng(seed)
    truth = _moving_hand(seed=seed)
    late = np.concatenate([np.full((2, 21, 3), np.nan), truth[:-2]])
    assert lag(truth, late) == pytest.approx(2.0, abs=0.051)
    averaged = truth.copy()
    for t in range(1, len(truth)):
        averaged[t] = 0.5 * truth[t] + 0.5 * averaged[t - 1]
    assert lag(truth[20:], averaged[20:]) == pytest.approx(1.0, abs=0.15)
    noisy = truth + rng.normal(0.0, 3.0, truth.shape) + 100.0
    assert abs(lag(truth, noisy)) <= 0.2
    other = _moving_hand(seed=seed + 10)
    late_other = np.concatenate([np.full((2, 21, 3), np.nan), other[:-2]])
    assert lag([truth, other], [late, late_other]) == pytest.approx(2.0, abs=0.051)


def test_jitter_is_the_second_difference_of_the_error_about_the_wrist():
    """Noise of σ on the joints (not the wrist) gives a second difference of variance
    6σ² per coordinate, so a norm of mean σ √6 · 1.596 (the mean of a χ with 3 degrees of
    freedom) on 20 of the 21 points, the wrist's 0 the 21st; a hand moved as a whole,
    none."""
    rng = np.random.default_rng(0)
    truth = _moving_hand(T=400)
    noise = rng.normal(0.0, 2.0, truth.shape)
    noise[:, 0] = 0.0
    assert acceleration_error(truth, truth + noise) == pytest.approx(
        2.0 * 6**0.5 * 1.596 * 20 / 21, rel=0.05
    )
    drift = np.arange(len(truth), dtype=float)[:, None, None] * np.array([1.0, -2.0, 0.5])
    assert acceleration_error(truth, truth + drift) == pytest.approx(0.0, abs=1e-9)
