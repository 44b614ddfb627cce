"""Evaluation measures: paper §3.3 (R̃², eq. 18 and 21, the mean joint error) and
those of a hand-pose benchmark against ground truth (docs/realistic-benchmark.md).

The benchmark's measures take arrays of points, (T, J, 2) pixels or (T, J, 3) mm, with
NaN where an estimate has no point (a missed frame): 2D PCK (`pck_2d`) counts a missing
point as wrong; the mean errors skip it (and say how many they scored).
"""

from __future__ import annotations

import numpy as np

from handvar.predictors.var import second_differences
from handvar.validate import as_int

__all__ = [
    "acceleration_error",
    "auc_pck_3d",
    "joint_errors",
    "lag",
    "mean_joint_error",
    "mean_point_error",
    "mpjpe",
    "pa_mpjpe",
    "pck_2d",
    "r2_tilde",
    "r2_tilde_acceleration",
    "r2_tilde_joints",
    "rotation_about_wrist",
    "rotation_angle",
    "similarity",
    "similarity_align",
    "thinned",
]

#: The reference length of 2D PCK: from the wrist to the middle finger's MCP (G(x)'s order).
_WRIST, _MIDDLE_MCP = 0, 9


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

    y, yv, y0 = second_differences(X), second_differences(V), second_differences(Z)
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


def _points(truth, estimate, dim: int | None = None):
    """truth and estimate as float arrays (T, J, D) of one shape (finite truth)."""
    Z = np.asarray(truth, dtype=float)
    E = np.asarray(estimate, dtype=float)
    if Z.ndim != 3 or (dim is not None and Z.shape[-1] != dim):
        what = f"(T, J, {dim})" if dim else "(T, J, D)"
        raise ValueError(f"truth: expected points {what}; got shape {Z.shape}")
    if E.shape != Z.shape:
        raise ValueError(f"estimate: expected the shape of truth {Z.shape}; got {E.shape}")
    if not np.isfinite(Z).all():
        raise ValueError("truth: expected finite values; got NaN or infinity")
    return Z, E


def pck_2d(truth, estimate, threshold: float = 0.2) -> float:
    """Fraction of the points within `threshold` reference lengths of the truth.

    The reference length of a frame is the true wrist → middle-MCP distance in the image
    (point 0 to point 9). A missing (NaN) estimate counts as wrong.

    Parameters
    ----------
    truth, estimate : (T, 21, 2) array_like
        Pixels.
    threshold : float

    Examples
    --------
    >>> truth = np.zeros((1, 21, 2)); truth[0, 9] = (0.0, 100.0)
    >>> est = truth.copy(); est[0, 1:4, 0] += (10.0, 30.0, np.nan)
    >>> round(pck_2d(truth, est), 4)  # 20 px allowed: points 2 and 3 are wrong
    0.9048
    """
    Z, E = _points(truth, estimate, 2)
    ref = np.linalg.norm(Z[:, _MIDDLE_MCP] - Z[:, _WRIST], axis=-1)  # (T,)
    d = np.linalg.norm(E - Z, axis=-1)
    with np.errstate(invalid="ignore"):
        ok = d <= threshold * ref[:, None]  # NaN compares False
    return float(ok.mean())


def thinned(points, every: int, interpolate: bool) -> np.ndarray:
    """Points (..., T, K, D) of a detector run on every `every`-th frame, the frames
    between filled as a user without a tracker would: each point held from the last
    detector frame that found it or, with `interpolate`, interpolated linearly between
    the last and the next that found it (which needs the future), held from the one
    there is where there is one only.  NaN before a point's first detection (held) or
    where none found it (interpolated).

    Examples
    --------
    >>> x = np.arange(7.0).reshape(7, 1, 1)
    >>> thinned(x, 2, True)[:, 0, 0].tolist(), thinned(x, 3, False)[:, 0, 0].tolist()
    ([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 6.0])
    >>> x[[0, 4]] = np.nan  # the detector found nothing on frames 0 and 4
    >>> thinned(x, 2, True)[:, 0, 0].tolist()
    [2.0, 2.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    """
    every = as_int(every, "every", minimum=1)
    p = np.moveaxis(np.asarray(points, dtype=float), -3, 0)
    T = len(p)
    flat = p.reshape(T, -1, p.shape[-1])  # (T, points, D)
    out = np.full_like(flat, np.nan)
    t = np.arange(T)
    for m in range(flat.shape[1]):
        found = np.flatnonzero(np.isfinite(flat[::every, m]).all(axis=-1)) * every
        if not found.size:
            continue
        before = np.searchsorted(found, t, side="right") - 1  # the last at or before t
        after = np.minimum(before + 1, found.size - 1)  # the next after it (or the last)
        t0, t1 = found[np.maximum(before, 0)], found[after]
        if interpolate:
            t0 = np.where(before < 0, t1, t0)  # before the first: held from it
            t1 = np.where(t1 < t, t0, t1)  # after the last: held from it
            w = np.where(t1 > t0, (t - t0) / np.maximum(t1 - t0, 1), 0.0)[:, None]
            out[:, m] = (1.0 - w) * flat[t0, m] + w * flat[t1, m]
        else:
            out[before >= 0, m] = flat[t0[before >= 0], m]
    return np.moveaxis(out.reshape(p.shape), 0, -3)


def mean_point_error(truth, estimate) -> tuple[float, int]:
    """Mean Euclidean distance over the points the estimate has, and how many.

    Parameters
    ----------
    truth, estimate : (T, J, D) array_like

    Returns
    -------
    (float, int)
        The mean (NaN when none) and the number of points scored.
    """
    Z, E = _points(truth, estimate)
    d = np.linalg.norm(E - Z, axis=-1)
    d = d[np.isfinite(d)]
    return (float(d.mean()) if d.size else float("nan")), int(d.size)


def _wrist_relative(P: np.ndarray) -> np.ndarray:
    return P - P[:, _WRIST : _WRIST + 1]


def _frame_errors(truth, estimate, align) -> np.ndarray:
    """(T, J) distances after `align` (per frame), NaN on frames the estimate lacks."""
    Z, E = _points(truth, estimate, 3)
    out = np.full(Z.shape[:2], np.nan)
    for t in range(Z.shape[0]):
        if np.isfinite(E[t]).all():
            out[t] = np.linalg.norm(align(E[t], Z[t]) - Z[t], axis=-1)
    return out


def joint_errors(truth, estimate, *, alignment: str = "wrist") -> np.ndarray:
    """(T, J) 3D errors after aligning each frame's estimate to the truth.

    ``"none"``: as they are (the absolute error in the world frame); ``"wrist"``: both
    taken relative to their wrist (point 0); ``"rotation"``: relative to their wrist, the
    estimate turned about it by the rotation that best fits it to the truth
    (`rotation_about_wrist`: what is left once the hand's orientation is right);
    ``"procrustes"``: the estimate moved by the similarity (`similarity_align`) that best
    fits it to the truth.  NaN rows: frames where the estimate has a missing point.
    """
    if alignment == "none":
        return _frame_errors(truth, estimate, lambda e, z: e)
    if alignment == "wrist":
        return _frame_errors(truth, estimate, lambda e, z: e - e[_WRIST] + z[_WRIST])
    if alignment == "rotation":
        return _frame_errors(
            truth, estimate,
            lambda e, z: (e - e[_WRIST]) @ rotation_about_wrist(e, z).T + z[_WRIST],
        )  # fmt: skip
    if alignment == "procrustes":
        return _frame_errors(truth, estimate, similarity_align)
    raise ValueError(f"alignment: expected none, wrist, rotation or procrustes; got {alignment!r}")


def mpjpe(truth, estimate) -> float:
    """Wrist-relative mean per-joint position error over the frames the estimate has.

    Both point sets are taken relative to their wrist (point 0); the mean runs over all
    J points (the wrist's zero included) of every scored frame.

    Parameters
    ----------
    truth, estimate : (T, J, 3) array_like
        mm.

    Examples
    --------
    >>> z = np.zeros((1, 2, 3)); e = z.copy(); e[0, :, 0] = (5.0, 9.0)
    >>> mpjpe(z, e)   # relative to the wrist: 0 and 4 mm
    2.0
    """
    return float(np.nanmean(joint_errors(truth, estimate, alignment="wrist")))


def pa_mpjpe(truth, estimate) -> float:
    """Mean per-joint error after a similarity Procrustes fit of each frame (mm)."""
    return float(np.nanmean(joint_errors(truth, estimate, alignment="procrustes")))


def similarity(source, target) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity p ↦ s R p + t that best fits `source` to `target`.

    Least squares over the points (Umeyama 1991): R a rotation (no reflection), s > 0.

    Parameters
    ----------
    source, target : (J, 3) array_like

    Returns
    -------
    s : float
    R : (3, 3) ndarray
    t : (3,) ndarray

    Examples
    --------
    >>> p = np.eye(3)
    >>> s, R, t = similarity(p, 2.0 * p[:, [1, 0, 2]] * [1, -1, 1])
    >>> round(s, 6), round(float(np.degrees(np.arccos((np.trace(R) - 1) / 2))), 6)
    (2.0, 90.0)
    """
    X, Y = _point_sets(source, target)
    mx, my = X.mean(0), Y.mean(0)
    A, B = X - mx, Y - my
    R, trace = _kabsch(A, B)
    var = (A**2).sum()
    s = float(trace / var) if var > 0 else 1.0
    return s, R, my - s * mx @ R.T


def rotation_about_wrist(source, target) -> np.ndarray:
    """The rotation R (no reflection) that best turns `source` about its wrist (point 0)
    onto `target` taken about its own: least squares over the points (Kabsch), no scale.

    Its angle is the error of the estimate's orientation, once its wrist is put on the
    truth's.

    Parameters
    ----------
    source, target : (J, 3) array_like

    Returns
    -------
    (3, 3) ndarray
        ``(source - source[0]) @ R.T`` is the turned source.

    Examples
    --------
    >>> p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 2, 0]])
    >>> R = rotation_about_wrist(p, p[:, [1, 0, 2]] * [-1, 1, 1])  # 90° about z
    >>> np.round(R, 6) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    X, Y = _point_sets(source, target)
    return _kabsch(X - X[_WRIST], Y - Y[_WRIST])[0]


def rotation_angle(R) -> float:
    """The angle of rotation `R` (3, 3), degrees.

    Examples
    --------
    >>> round(rotation_angle([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), 6)
    90.0
    """
    cos = (np.trace(np.asarray(R, dtype=float)) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def _point_sets(source, target) -> tuple[np.ndarray, np.ndarray]:
    X = np.asarray(source, dtype=float)
    Y = np.asarray(target, dtype=float)
    if X.ndim != 2 or X.shape != Y.shape:
        raise ValueError(f"source: expected the shape of target {Y.shape}; got {X.shape}")
    return X, Y


def _kabsch(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, float]:
    """The rotation R minimising Σ |R a − b|² over the rows of A and B, and the trace
    Σ σ_i d_i of the cross-covariance it reaches (Umeyama's scale numerator)."""
    U, S, Vt = np.linalg.svd(B.T @ A)  # cross-covariance Σ b aᵀ
    D = np.ones(len(S))
    D[-1] = np.sign(np.linalg.det(U @ Vt)) or 1.0  # a rotation, not a reflection
    return (U * D) @ Vt, float((S * D).sum())


def similarity_align(source, target) -> np.ndarray:
    """`source` moved by the similarity s R p + t that best fits it to `target`
    (`similarity`).

    Parameters
    ----------
    source, target : (J, 3) array_like

    Returns
    -------
    (J, 3) ndarray
    """
    s, R, t = similarity(source, target)
    return s * np.asarray(source, dtype=float) @ R.T + t


def auc_pck_3d(errors, low: float = 20.0, high: float = 50.0, steps: int = 31) -> float:
    """Area under the 3D PCK curve between `low` and `high` mm, normalised to [0, 1].

    PCK(τ) is the fraction of the finite `errors` at most τ; the curve is sampled at
    `steps` thresholds evenly from `low` to `high` and integrated by the trapezoid rule.

    Examples
    --------
    >>> auc_pck_3d([10.0, 60.0, 70.0, 80.0])  # PCK is 1/4 at every threshold
    0.25
    """
    e = np.asarray(errors, dtype=float).ravel()
    e = e[np.isfinite(e)]
    if not e.size:
        return float("nan")
    tau = np.linspace(low, high, steps)
    curve = (e[None, :] <= tau[:, None]).mean(1)
    return float(np.trapezoid(curve, tau) / (high - low))


def acceleration_error(truth, estimate) -> float:
    """Jitter: the mean |Δ²X − Δ²X_true| of the wrist-relative joints (mm per frame² with
    (T, J, 3) mm), over the frames whose two neighbours both have an estimate.

    Examples
    --------
    >>> z = np.zeros((3, 2, 3)); e = z.copy(); e[1, 1, 0] = 1.0  # one point off by 1
    >>> acceleration_error(z, e)   # Δ²: −2 at that point, 0 at the wrist
    1.0
    """
    Z, E = _points(truth, estimate, 3)
    d = np.linalg.norm(
        second_differences(_wrist_relative(E)) - second_differences(_wrist_relative(Z)), axis=-1
    )
    return float(np.nanmean(d)) if np.isfinite(d).any() else float("nan")


def lag(truth, estimate, *, most: float = 5.0, step: float = 0.1) -> float:
    """Frames by which an estimate's motion trails the truth's: the shift s that
    minimises the mean squared difference between the estimate's wrist-relative joint
    velocities (first differences) at frame t and the truth's at t − s (linearly
    interpolated between frames), searched from −`most` to `most` in steps of `step`,
    over the same frames for every shift (those `most` frames or more from either end
    whose neighbours the estimate has).  Velocities, so that a constant error (a hand
    turned a little wrong throughout) does not count.  `truth` and `estimate` may be
    lists of (T_k, J, 3) recordings: one shift for all, over all their frames.

    A filter that smooths by averaging the past trails by about its group delay (an
    exponential average of weight α, by (1 − α)/α frames on slow motion); an estimate
    with noise alone does not trail (s ≈ 0).  Positive: behind the truth.
    """
    pairs = list(zip(truth, estimate, strict=True)) if isinstance(truth, list) else [
        (truth, estimate)]  # fmt: skip
    margin = int(np.ceil(most))
    shifts = np.arange(-most, most + 0.5 * step, step)
    total, count = np.zeros(len(shifts)), 0
    for z, e in pairs:
        Z, E = _points(z, e, 3)
        Z, E = np.diff(_wrist_relative(Z), axis=0), np.diff(_wrist_relative(E), axis=0)
        T = len(Z)
        frames = np.arange(margin, T - margin)  # the same frames for every shift
        frames = frames[np.isfinite(E[frames]).all(axis=(1, 2))]
        for k, s in enumerate(shifts):
            u = frames - s  # the truth's time seen at each frame
            i = np.minimum(np.floor(u).astype(int), T - 2)
            w = (u - i)[:, None, None]
            total[k] += ((E[frames] - (1.0 - w) * Z[i] - w * Z[i + 1]) ** 2).sum()
        count += frames.size
    return float(shifts[np.argmin(total)]) if count >= 2 else float("nan")
