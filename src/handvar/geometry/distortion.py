"""OpenCV's lens distortion model, with its Jacobian (design §3).

Normalised image coordinates ``(x, y) = (X/Z, Y/Z)`` are distorted as in
``cv2.projectPoints``::

    r² = x² + y²
    radial = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)
    x'' = x radial + 2 p1 x y + p2 (r² + 2 x²)
    y'' = y radial + p1 (r² + 2 y²) + 2 p2 x y

with 4 (``k1 k2 p1 p2``), 5 (``… k3``) or 8 (``… k4 k5 k6``, the rational model)
coefficients. The formula is written once, in :func:`distort_point` (one point, numba),
which compiled loops such as the tracking cost call directly; :func:`distort` applies it
to arrays of points.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from handvar.validate import as_array

__all__ = [
    "distort",
    "distort_normalized",
    "distort_point",
    "distortion_coefficients",
    "padded",
    "project_point",
]


def distortion_coefficients(dist) -> np.ndarray:
    """Check OpenCV distortion coefficients and put them in canonical form.

    Parameters
    ----------
    dist : array_like or None
        ``k1 k2 p1 p2 [k3 [k4 k5 k6]]``: 4, 5 or 8 values; None or empty for none.

    Returns
    -------
    (5,) or (8,) ndarray
        4 values gain ``k3 = 0``; 8 values whose ``k4 k5 k6`` are all zero become 5.

    Examples
    --------
    >>> distortion_coefficients([0.1, 0.0, 0.0, 0.0])
    array([0.1, 0. , 0. , 0. , 0. ])
    """
    arr = np.zeros(5) if dist is None else as_array(dist, "dist", finite=False).ravel()
    if arr.size == 0:
        arr = np.zeros(5)
    if arr.size == 4:
        arr = np.concatenate([arr, [0.0]])
    if arr.size not in (5, 8):
        raise ValueError(
            "dist: expected 4, 5 or 8 OpenCV distortion coefficients "
            f"(k1 k2 p1 p2 [k3 [k4 k5 k6]]); got {arr.size}"
        )
    if arr.size == 8 and not np.any(arr[5:]):
        arr = arr[:5]
    if not np.all(np.isfinite(arr)):
        raise ValueError("dist: expected finite values; got NaN or infinity")
    return arr


def padded(dist: np.ndarray) -> tuple[np.ndarray, bool]:
    """Coefficients padded with zeros to 8 and whether the rational model is in use.

    The form :func:`distort_point` takes: ``(k1 k2 p1 p2 k3 k4 k5 k6)`` and a flag that
    is True for 8 coefficients (`dist` as :func:`distortion_coefficients` returns it).
    """
    out = np.zeros(8)
    out[: dist.size] = dist
    return out, bool(dist.size == 8)


def distort_normalized(xy: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Apply OpenCV's lens distortion to normalised image coordinates.

    Parameters
    ----------
    xy : (N, 2) ndarray
        Undistorted normalised coordinates ``(X/Z, Y/Z)``.
    dist : (5,) or (8,) ndarray
        ``k1 k2 p1 p2 k3 [k4 k5 k6]``.

    Returns
    -------
    (N, 2) ndarray
        Distorted normalised coordinates (OpenCV ``projectPoints`` model).

    Examples
    --------
    >>> distort_normalized(np.array([[0.5, 0.0]]), np.array([0.1, 0, 0, 0, 0]))
    array([[0.5125, 0.    ]])
    """
    return distort(xy, dist, jacobian=False)[0]


def distort(xy: np.ndarray, dist: np.ndarray, *, jacobian: bool):
    """Distorted normalised coordinates and, optionally, their Jacobian.

    Every point goes through :func:`distort_point` in one compiled loop.

    Parameters
    ----------
    xy : (N, 2) ndarray
        Undistorted normalised coordinates.
    dist : (5,) or (8,) ndarray
        Coefficients as :func:`distortion_coefficients` returns them.
    jacobian : bool, keyword-only
        Also return ``d(x'', y'') / d(x, y)``.

    Returns
    -------
    xyd : (N, 2) ndarray
    J : (N, 2, 2) ndarray or None
    """
    xy = np.ascontiguousarray(xy, dtype=float)
    dist8, rational = padded(np.asarray(dist, dtype=float))
    out = np.empty_like(xy)
    J = np.empty((xy.shape[0], 2, 2))
    _distort_all(xy, dist8, rational, out, J)
    return out, (J if jacobian else None)


@njit(cache=True)
def _distort_all(xy, dist, rational, out, J):  # pragma: no cover - compiled
    """:func:`distort_point` for every row of `xy`, into `out` (N, 2) and `J` (N, 2, 2)."""
    for i in range(xy.shape[0]):
        xd, yd, a00, a01, a11 = distort_point(xy[i, 0], xy[i, 1], dist, rational)
        out[i, 0] = xd
        out[i, 1] = yd
        J[i, 0, 0] = a00
        J[i, 0, 1] = a01
        J[i, 1, 0] = a01
        J[i, 1, 1] = a11


@njit(cache=True)
def distort_point(x, y, dist, rational):  # pragma: no cover - compiled
    """:func:`distort` of one point, for compiled loops.

    Parameters
    ----------
    x, y : float
        Undistorted normalised coordinates.
    dist : (8,) ndarray
        Coefficients padded to 8 (:func:`padded`).
    rational : bool
        Use ``k4 k5 k6`` (the rational model).

    Returns
    -------
    xd, yd, a00, a01, a11 : float
        Distorted coordinates and the symmetric Jacobian ``[[a00, a01], [a01, a11]]``.
    """
    k1, k2, p1, p2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    r2 = x * x + y * y
    # radial factor (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d num / d r²
    if rational:
        k4, k5, k6 = dist[5], dist[6], dist[7]
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
        radial = num / den
        dradial = (dnum * den - num * dden) / (den * den)
    else:
        radial = num
        dradial = dnum
    # x'' = x radial + 2 p1 x y + p2 (r² + 2x²);  y'' = y radial + p1 (r² + 2y²) + 2 p2 x y
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    a00 = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
    a01 = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
    a11 = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, a00, a01, a11


@njit(cache=True)
def project_point(k, dist, rational, R, t, p, J3, uv, J2):  # pragma: no cover - compiled
    """Pixel (u, v) of world point p and d(u, v)/dx = d(u, v)/dp · J3; returns depth z.

    Pinhole with OpenCV's distortion (as handvar.camera.Camera.project_jacobian), one
    camera's parameters as packed by handvar.camera.Rig.packed: k (4,) fx fy cx cy,
    dist (8,), rational (bool), R (3, 3), t (3,). uv (2,) and J2 (2, d) are filled in
    place; J3 (3, d) is the Jacobian of p with respect to the d parameters.
    """
    X = R[0, 0] * p[0] + R[0, 1] * p[1] + R[0, 2] * p[2] + t[0]
    Y = R[1, 0] * p[0] + R[1, 1] * p[1] + R[1, 2] * p[2] + t[1]
    Z = R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2] + t[2]
    iz = 1.0 / Z
    x = X * iz
    y = Y * iz
    xd, yd, a00, a01, a11 = distort_point(x, y, dist, rational)  # and d(xd, yd)/d(x, y)
    a10 = a01
    uv[0] = k[0] * xd + k[2]
    uv[1] = k[1] * yd + k[3]
    # d(x, y)/d(X, Y, Z) = [[1/Z, 0, -x/Z], [0, 1/Z, -y/Z]]; then · R (world)
    P = np.empty((2, 3))
    for c in range(3):
        dx = iz * R[0, c] - x * iz * R[2, c]
        dy = iz * R[1, c] - y * iz * R[2, c]
        P[0, c] = k[0] * (a00 * dx + a01 * dy)
        P[1, c] = k[1] * (a10 * dx + a11 * dy)
    for i in range(2):
        for col in range(J3.shape[1]):
            J2[i, col] = P[i, 0] * J3[0, col] + P[i, 1] * J3[1, col] + P[i, 2] * J3[2, col]
    return Z
