"""Cone-spheres in the image plane: projected outlines and the closest point of a union.

A camera sees a sphere of radius r at depth z (camera frame) approximately as the circle
of radius ``ρ = f r / sqrt(z² − r²)`` around the image of its centre (exact on the
optical axis of an undistorted camera; `outline_circles`), and a cone-sphere as the 2D
hull of its two circles: a 2D cone-sphere (`ProjectedPrimitives`). The filling cost
(paper eq. 1) needs, for a pixel s, the closest point h of the union of these hulls and
its derivatives w.r.t. every circle's centre and radius
(`closest_point_cone_spheres_2d`).

The closest point is written once as a compiled scalar, `closest_point_on_union` (one
pixel, numba), which the tracking cost's kernel calls directly and
`closest_point_cone_spheres_2d` calls in a loop; a vectorised numpy route of the same
geometry (``compiled=False``) serves as the independent reference of the tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from handvar.validate import as_array

__all__ = [
    "ProjectedPrimitives",
    "closest_point_cone_spheres_2d",
    "closest_point_on_union",
    "outline_circles",
    "union_axes",
]


@dataclass(frozen=True, eq=False)
class ProjectedPrimitives:
    """Cone-spheres as seen by a camera: each the 2D hull of its two end circles.

    Attributes
    ----------
    centres : (P, 2, 2) ndarray
        Image of the end sphere centres, pixels.
    radii : (P, 2) ndarray
        Circle radii ``f r / sqrt(depth² − r²)``, pixels (``f = (fx + fy) / 2``).
    depth : (P, 2) ndarray
        Camera-frame depth (z) of the sphere centres, mm.
    visible : (P,) bool ndarray
        Both end spheres lie in front of the camera (depth > their radius).
    """

    centres: np.ndarray
    radii: np.ndarray
    depth: np.ndarray
    visible: np.ndarray


def outline_circles(depth, radii, focal: float):
    """Radii of the circles that approximate the images of spheres.

    Parameters
    ----------
    depth : (...) array_like
        Camera-frame depth z of the sphere centres, mm.
    radii : (...) array_like
        Sphere radii r, mm (same shape).
    focal : float
        Focal length f, pixels.

    Returns
    -------
    rho : (...) ndarray
        ``ρ = f r / sqrt(z² − r²)``, pixels (NaN where ``z ≤ r``).
    drho_dz : (...) ndarray
        ``dρ/dz = −ρ z / (z² − r²)``.

    Examples
    --------
    >>> outline_circles([500.0], [10.0], 650.0)[0].round(4)
    array([13.0026])
    """
    z = np.asarray(depth, dtype=float)
    r = np.asarray(radii, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        zz = z * z - r * r
        rho = focal * r / np.sqrt(zz)
        drho_dz = -rho * z / zz  # ρ = f r (z² − r²)^(−1/2): dρ = −ρ z/(z² − r²) dz
    return rho, drho_dz


def closest_point_cone_spheres_2d(centres, radii, pixels, *, valid=None, compiled=True):
    """Closest point of a union of 2D cone-spheres to each pixel, with its derivatives.

    Parameters
    ----------
    centres : (P, 2, 2) array_like
        Circle centres, pixels.
    radii : (P, 2) array_like
        Circle radii, pixels.
    pixels : (M, 2) array_like
    valid : (P,) bool array_like, optional
        Primitives to consider (all by default).
    compiled : bool, optional
        Use the compiled loop (numba, default) rather than the vectorised numpy
        reference; both give the same result to rounding.

    Returns
    -------
    h : (M, 2) ndarray
        Closest point of the union; the pixel itself where it is covered.
    dh : (M, 2, 6) ndarray
        Derivative of `h` w.r.t. ``(c1u, c1v, c2u, c2v, ρ1, ρ2)`` of the primitive
        `primitive` (zero where covered).
    primitive : (M,) int ndarray
        The nearest primitive (−1 if none is valid).
    distance : (M,) ndarray
        Signed distance to the union (≤ 0 where covered).

    Notes
    -----
    A primitive whose one circle contains the other (a segment seen end-on) is its
    larger circle. Outside a cone-sphere the closest point lies

    - on circle i: ``h = c_i + ρ_i e`` with e the unit vector from c_i to the pixel s,
      ``dh/dc_i = I − ρ_i (I − e eᵀ) / |s − c_i|``, ``dh/dρ_i = e``;
    - or on the tangent line: ``h = s − δ n`` with outward normal ``n = (cos ψ, sin ψ)``,
      ``ψ = θ + σ (π/2 − α)`` (θ the direction of the axis u, σ = ±1 the side of the
      pixel, ``sin α = (ρ1 − ρ2)/D``) and ``δ = n·(s − c1) − ρ1``. With ``t = J n`` (J
      the 90° rotation), ``m = (t·(s − c1)) n + δ t`` and
      ``g = (J u + σ tan α · u) / D = dψ/dc2 = −dψ/dc1``:
      ``dh/dc1 = n nᵀ + m gᵀ``, ``dh/dc2 = −m gᵀ``,
      ``dh/dρ1 = n + σ m / (D cos α)``, ``dh/dρ2 = −σ m / (D cos α)``.
    """
    centres = np.ascontiguousarray(centres, dtype=float)
    radii = np.ascontiguousarray(radii, dtype=float)
    s_px = as_array(pixels, "pixels", (None, 2))
    m, p = s_px.shape[0], centres.shape[0]
    valid = np.ones(p, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    if valid.shape != (p,):
        raise ValueError(f"valid: expected shape ({p},); got shape {valid.shape}")
    if m == 0 or not valid.any():
        return (s_px.copy(), np.zeros((m, 2, 6)), np.full(m, -1, dtype=np.intp),
                np.full(m, np.inf))  # fmt: skip
    if compiled:
        h = np.empty((m, 2))
        dh = np.zeros((m, 2, 6))
        prim = np.empty(m, dtype=np.intp)
        dist = np.empty(m)
        _closest_all(centres, radii, valid, np.ascontiguousarray(s_px), h, dh, prim, dist)
        return h, dh, prim, dist

    # per primitive: axis, sin α, cos α (a degenerate primitive acts as its larger circle)
    c1x, c1y = centres[:, 0, 0], centres[:, 0, 1]
    dx, dy = centres[:, 1, 0] - c1x, centres[:, 1, 1] - c1y
    D = np.sqrt(dx * dx + dy * dy)
    r1, r2 = radii[:, 0], radii[:, 1]
    degenerate = D <= np.abs(r1 - r2) * (1.0 + 1e-12) + 1e-12
    Dsafe = np.where(D > 0.0, D, 1.0)
    ux, uy = np.where(D > 0.0, dx / Dsafe, 1.0), np.where(D > 0.0, dy / Dsafe, 0.0)
    sa = np.where(degenerate, 0.0, (r1 - r2) / Dsafe)
    ca = np.sqrt(np.maximum(1.0 - sa * sa, 0.0))
    strip_end = np.where(degenerate, -np.inf, D * ca)  # degenerate: never the flank

    # signed distance of every pixel to every primitive, (M, P) (module docstring)
    wx = s_px[:, 0, None] - c1x
    wy = s_px[:, 1, None] - c1y
    a = wx * ux + wy * uy
    perp = wy * ux - wx * uy  # (s − c1)·J u
    q = np.abs(perp)
    q2 = perp * perp
    d1 = np.sqrt(a * a + q2) - r1
    a2 = a - D
    d2 = np.sqrt(a2 * a2 + q2) - r2
    k = a * ca - q * sa
    flank = (k >= 0.0) & (k <= strip_end)
    sdf = np.minimum(d1, d2)
    np.copyto(sdf, a * sa + q * ca - r1, where=flank)
    sdf[:, ~valid] = np.inf

    best = np.argmin(sdf, axis=1)
    rows = np.arange(m)
    dist = sdf[rows, best]
    outside = dist > 0.0
    on_flank = flank[rows, best] & outside
    use2 = (d2[rows, best] < d1[rows, best]) & ~on_flank

    # the chosen primitive's quantities, (M,)
    u = np.stack([ux[best], uy[best]], axis=1)
    Ju = np.stack([-u[:, 1], u[:, 0]], axis=1)
    c1 = centres[best, 0]
    ci = np.where(use2[:, None], centres[best, 1], c1)
    ri = np.where(use2, r2[best], r1[best])
    w = s_px - c1
    wi = s_px - ci
    ni = np.sqrt(np.einsum("ij,ij->i", wi, wi))
    ni = np.where(ni > 0.0, ni, 1.0)
    e = wi / ni[:, None]

    # circle part
    h_circle = ci + ri[:, None] * e
    eye = np.eye(2)
    dci = eye - (ri / ni)[:, None, None] * (eye - e[:, :, None] * e[:, None, :])

    # flank part
    sb, cb, Db = sa[best], np.where(on_flank, ca[best], 1.0), Dsafe[best]
    sigma = np.where(perp[rows, best] >= 0.0, 1.0, -1.0)
    n = sb[:, None] * u + (sigma * cb)[:, None] * Ju
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    delta = np.einsum("ij,ij->i", n, w) - r1[best]
    h_flank = s_px - delta[:, None] * n
    mm = np.einsum("ij,ij->i", t, w)[:, None] * n + delta[:, None] * t
    g = (Ju + (sigma * sb / cb)[:, None] * u) / Db[:, None]
    mg = mm[:, :, None] * g[:, None, :]
    k_rho = (sigma / (Db * cb))[:, None] * mm

    h = np.where(on_flank[:, None], h_flank, h_circle)
    h[~outside] = s_px[~outside]
    dh = np.zeros((m, 2, 6))
    circ = outside & ~on_flank
    c1_sel = circ & ~use2
    c2_sel = circ & use2
    dh[c1_sel, :, 0:2] = dci[c1_sel]
    dh[c1_sel, :, 4] = e[c1_sel]
    dh[c2_sel, :, 2:4] = dci[c2_sel]
    dh[c2_sel, :, 5] = e[c2_sel]
    f = on_flank
    dh[f, :, 0:2] = n[f, :, None] * n[f, None, :] + mg[f]
    dh[f, :, 2:4] = -mg[f]
    dh[f, :, 4] = n[f] + k_rho[f]
    dh[f, :, 5] = -k_rho[f]
    return h, dh, np.where(np.isfinite(dist), best, -1), dist


# --- the compiled scalar --------------------------------------------------------------------


@njit(cache=True)
def closest_point_on_union(s0, s1, pc, prho, axes, visible, h, dh6):  # pragma: no cover
    """Closest point h of a union of 2D cone-spheres to pixel (s0, s1) and dh/dθ (numba).

    The one implementation of `closest_point_cone_spheres_2d` (see its Notes), one pixel
    at a time, for compiled loops.

    Parameters
    ----------
    s0, s1 : float
        The pixel, (u, v).
    pc : (P, 2, 2) ndarray
        Circle centres, pixels.
    prho : (P, 2) ndarray
        Circle radii, pixels.
    axes : (P, 6) ndarray
        `union_axes` of `pc`, `prho`.
    visible : (P,) bool ndarray
        Primitives to consider.
    h : (2,) ndarray
        Receives the closest point (the pixel itself where it is covered).
    dh6 : (2, 6) ndarray
        Receives dh/dθ, θ = ``(c1u, c1v, c2u, c2v, ρ1, ρ2)`` of the chosen primitive
        (zero where covered).

    Returns
    -------
    primitive : int
        The nearest primitive, −1 when none is visible.
    distance : float
        Signed distance to the union (≤ 0 where covered, inf when none is visible).
    """
    best = -1
    best_d = np.inf
    best_reg = 0
    for q in range(pc.shape[0]):
        if not visible[q]:
            continue
        r1 = prho[q, 0]
        r2 = prho[q, 1]
        w0 = s0 - pc[q, 0, 0]
        w1 = s1 - pc[q, 0, 1]
        if axes[q, 5] != 0.0:  # one circle inside the other
            v0 = s0 - pc[q, 1, 0]
            v1 = s1 - pc[q, 1, 1]
            sd1 = np.sqrt(w0 * w0 + w1 * w1) - r1
            sd2 = np.sqrt(v0 * v0 + v1 * v1) - r2
            if sd1 <= sd2:
                sd, reg = sd1, 0
            else:
                sd, reg = sd2, 2
        else:
            D, u0, u1, sa, ca = axes[q, 0], axes[q, 1], axes[q, 2], axes[q, 3], axes[q, 4]
            a = w0 * u0 + w1 * u1
            qq = abs(w1 * u0 - w0 * u1)
            kk = a * ca - qq * sa
            if kk < 0.0:
                sd, reg = np.sqrt(w0 * w0 + w1 * w1) - r1, 0
            elif kk > D * ca:
                v0 = s0 - pc[q, 1, 0]
                v1 = s1 - pc[q, 1, 1]
                sd, reg = np.sqrt(v0 * v0 + v1 * v1) - r2, 2
            else:
                sd, reg = a * sa + qq * ca - r1, 1
        if sd < best_d:
            best_d, best, best_reg = sd, q, reg
    h[0] = s0
    h[1] = s1
    for i in range(2):
        for c in range(6):
            dh6[i, c] = 0.0
    if best < 0 or best_d <= 0.0:
        return best, best_d
    q = best
    if best_reg != 1:  # circle i: h = c_i + ρ_i ê
        i = best_reg // 2
        c0, c1, ri = pc[q, i, 0], pc[q, i, 1], prho[q, i]
        w0, w1 = s0 - c0, s1 - c1
        n = np.sqrt(w0 * w0 + w1 * w1)
        e0, e1 = w0 / n, w1 / n
        h[0] = c0 + ri * e0
        h[1] = c1 + ri * e1
        f = ri / n  # dh/dc_i = I − ρ_i (I − ê êᵀ)/|s − c_i|, dh/dρ_i = ê
        dh6[0, 2 * i] = 1.0 - f * (1.0 - e0 * e0)
        dh6[0, 2 * i + 1] = f * e0 * e1
        dh6[1, 2 * i] = f * e0 * e1
        dh6[1, 2 * i + 1] = 1.0 - f * (1.0 - e1 * e1)
        dh6[0, 4 + i] = e0
        dh6[1, 4 + i] = e1
        return best, best_d
    # lateral: h = s − δ n, n = sin α u + σ cos α J u, δ = n·(s − c1) − ρ1
    r1 = prho[q, 0]
    D, u0, u1, ss, cc = axes[q, 0], axes[q, 1], axes[q, 2], axes[q, 3], axes[q, 4]
    w0 = s0 - pc[q, 0, 0]
    w1 = s1 - pc[q, 0, 1]
    sg = 1.0 if (w1 * u0 - w0 * u1) >= 0.0 else -1.0
    j0, j1 = -u1, u0  # J u
    n0 = ss * u0 + sg * cc * j0
    n1 = ss * u1 + sg * cc * j1
    delta = n0 * w0 + n1 * w1 - r1
    h[0] = s0 - delta * n0
    h[1] = s1 - delta * n1
    # derivatives w.r.t. θ = (c1u, c1v, c2u, c2v, ρ1, ρ2)
    for c in range(6):
        e0 = -1.0 if c == 0 else (1.0 if c == 2 else 0.0)  # d(c2 − c1)/dθ_c
        e1 = -1.0 if c == 1 else (1.0 if c == 3 else 0.0)
        # du = (I − u uᵀ) d(c2 − c1) / D
        t0 = (1.0 - u0 * u0) * e0 - u0 * u1 * e1
        t1 = -u0 * u1 * e0 + (1.0 - u1 * u1) * e1
        du0 = t0 / D
        du1 = t1 / D
        ud = u0 * e0 + u1 * e1
        ds = -ss * ud / D
        if c == 4:
            ds += 1.0 / D
        elif c == 5:
            ds -= 1.0 / D
        dc = -ss * ds / cc if cc > 0.0 else 0.0
        jd0, jd1 = -du1, du0  # J du
        dn0 = ds * u0 + ss * du0 + sg * (dc * j0 + cc * jd0)
        dn1 = ds * u1 + ss * du1 + sg * (dc * j1 + cc * jd1)
        dd = dn0 * w0 + dn1 * w1
        if c == 0:
            dd -= n0
        elif c == 1:
            dd -= n1
        elif c == 4:
            dd -= 1.0
        dh6[0, c] = -dd * n0 - delta * dn0
        dh6[1, c] = -dd * n1 - delta * dn1
    return best, best_d


@njit(cache=True)
def union_axes(pc, prho, visible, axes):  # pragma: no cover - compiled
    """Per visible 2D cone-sphere, into `axes` (P, 6): D, u (2), sin α, cos α, degenerate.

    D is the distance of the circle centres, u the unit axis, ``sin α = (ρ1 − ρ2)/D``;
    degenerate (1.0) marks one circle inside the other (then only D is set).
    """
    for q in range(pc.shape[0]):
        if not visible[q]:
            continue
        d0 = pc[q, 1, 0] - pc[q, 0, 0]
        d1 = pc[q, 1, 1] - pc[q, 0, 1]
        r1 = prho[q, 0]
        r2 = prho[q, 1]
        D = np.sqrt(d0 * d0 + d1 * d1)
        axes[q, 0] = D
        if D <= abs(r1 - r2) * (1.0 + 1e-12) + 1e-12:
            axes[q, 5] = 1.0
            continue
        axes[q, 5] = 0.0
        axes[q, 1] = d0 / D
        axes[q, 2] = d1 / D
        sa = (r1 - r2) / D
        axes[q, 3] = sa
        axes[q, 4] = np.sqrt(max(1.0 - sa * sa, 0.0))


@njit(cache=True)
def _closest_all(centres, radii, valid, pixels, h, dh, prim, dist):  # pragma: no cover
    """`closest_point_on_union` for every pixel, into h (M, 2), dh (M, 2, 6), prim, dist."""
    hi = np.empty(2)
    dhi = np.empty((2, 6))
    axes = np.zeros((centres.shape[0], 6))
    union_axes(centres, radii, valid, axes)
    for i in range(pixels.shape[0]):
        s0, s1 = pixels[i, 0], pixels[i, 1]
        q, d = closest_point_on_union(s0, s1, centres, radii, axes, valid, hi, dhi)
        prim[i] = q
        dist[i] = d
        h[i, 0] = hi[0]
        h[i, 1] = hi[1]
        for r in range(2):
            for col in range(6):
                dh[i, r, col] = dhi[r, col]
