"""Evaluation measures of paper §3.3: R̃² (eq. 18 and 21) and the mean joint error."""

from __future__ import annotations

import numpy as np

__all__ = ["mean_joint_error", "r2_tilde", "r2_tilde_acceleration", "r2_tilde_joints"]


def _same_shape(truth, with_model, without_model, ndim: int, what: str):
    arrays = []
    for name, a in (("truth", truth), ("with_model", with_model), ("without_model", without_model)):
        a = np.asarray(a, dtype=float)
        if a.ndim != ndim:
            raise ValueError(f"{name}: expected {what}; got shape {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"{name}: expected finite values; got NaN or infinity")
        arrays.append(a)
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise ValueError(
            "with_model, without_model: expected the shape of truth "
            f"{arrays[0].shape}; got {arrays[1].shape} and {arrays[2].shape}"
        )
    return arrays


def _ratio_score(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    # A parameter the no-motion run got exactly right (den = 0) has no score.
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, 1.0 - num / np.where(den > 0, den, 1.0), np.nan)


def r2_tilde_acceleration(truth, with_model, without_model) -> np.ndarray:
    """R̃²_y(τ, i) of eq. 18: per parameter, in the acceleration domain.

    Parameters
    ----------
    truth, with_model, without_model : (T, d) array_like
        Pose series: the ground truth x*, the tracker's estimates with the motion
        predictor under test, and without motion prediction (x⁰).  Their second
        differences (eq. 3) are compared.

    Returns
    -------
    (d,) ndarray
        1 − Σ(y* − y^VAR)² / Σ(y* − y⁰)²; > 0 means the predictor helped; NaN where
        the denominator is zero.
    """
    X, V, Z = _same_shape(truth, with_model, without_model, 2, "a pose series (T, d)")
    if len(X) < 3:
        raise ValueError(f"truth: expected at least 3 frames; got {len(X)}")

    def acc(a):
        return a[2:] - 2.0 * a[1:-1] + a[:-2]  # eq. 3

    y, yv, y0 = acc(X), acc(V), acc(Z)
    return _ratio_score(((y - yv) ** 2).sum(0), ((y - y0) ** 2).sum(0))


def r2_tilde_joints(truth, with_model, without_model) -> np.ndarray:
    """R̃²(τ, j) of eq. 21: per joint, on 3D positions.

    Parameters
    ----------
    truth, with_model, without_model : (T, J, 3) array_like
        Joint positions z* = G(x*), z^VAR and z⁰ (any length unit).

    Returns
    -------
    (J,) ndarray
        1 − Σ‖z* − z^VAR‖² / Σ‖z* − z⁰‖².
    """
    Z, V, N = _same_shape(truth, with_model, without_model, 3, "joints (T, J, 3)")
    return _ratio_score(((Z - V) ** 2).sum((0, 2)), ((Z - N) ** 2).sum((0, 2)))


def r2_tilde(truth, with_model, without_model) -> np.ndarray:
    """R̃² of the paper: eq. 21 for joint series (T, J, 3), eq. 18 for pose series (T, d).

    Examples
    --------
    >>> import numpy as np
    >>> z = np.zeros((4, 1, 3))
    >>> r2_tilde(z, z + 1.0, z + 2.0)   # errors 1 with the model, 2 without
    array([0.75])
    """
    ndim = np.ndim(truth)
    if ndim == 3:
        return r2_tilde_joints(truth, with_model, without_model)
    if ndim == 2:
        return r2_tilde_acceleration(truth, with_model, without_model)
    raise ValueError(
        f"truth: expected joints (T, J, 3) or poses (T, d); got shape {np.shape(truth)}"
    )


def mean_joint_error(truth, estimate) -> np.ndarray:
    """Per-frame mean Euclidean error over the joints, in the joints' unit (mm).

    Parameters
    ----------
    truth, estimate : (T, J, 3) or (J, 3) array_like

    Returns
    -------
    (T,) ndarray, or a float for a single frame.
    """
    Z = np.asarray(truth, dtype=float)
    E = np.asarray(estimate, dtype=float)
    if Z.shape != E.shape or Z.ndim not in (2, 3) or Z.shape[-1] != 3:
        raise ValueError(
            f"estimate: expected the shape of truth, (T, J, 3) or (J, 3); got "
            f"{E.shape} against truth {Z.shape}"
        )
    err = np.linalg.norm(Z - E, axis=-1).mean(-1)
    return float(err) if Z.ndim == 2 else err
