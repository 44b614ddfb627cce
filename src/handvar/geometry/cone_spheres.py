"""Cone-spheres in 3D: areas, area-uniform samples, signed distance, normals, rays.

A *cone-sphere* is the convex hull of two spheres (centres c1, c2, radii r1, r2): two
spherical caps joined by the frustum of their common tangent cone. Geometry of one
cone-sphere (used throughout; `cone_sphere_sdf` and `cone_sphere_normals` work in 2D too):
with ``d = |c2 − c1|``, axis ``u = (c2 − c1)/d`` and ``sin α = (r1 − r2)/d`` (we
require ``d > |r1 − r2|``), the outward normal of the lateral surface is
``n = sin α · u + cos α · e`` (e ⟂ u, unit); the tangent points are ``c_i + r_i n``.
In coordinates along the axis ``a = (p − c1)·u`` and off it ``q = |p − c1 − a u|``:

- ``k = a cos α − q sin α < 0``: nearest to sphere 1, distance ``|p − c1| − r1``;
- ``k > d cos α``: nearest to sphere 2, distance ``|p − c2| − r2``;
- otherwise nearest to the lateral surface, distance ``a sin α + q cos α − r1``.

Areas (exact): cap 1 ``2π r1² (1 + sin α)``, cap 2 ``2π r2² (1 − sin α)``, lateral
``π (r1 + r2) d cos² α``.

Rays (`intersect_cone_spheres`) and points are vectorised numpy; the ray casting has a
compiled (numba) loop as well, checked against the numpy route by the tests.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from handvar.validate import as_array

__all__ = [
    "cone_sphere_areas",
    "cone_sphere_normals",
    "cone_sphere_sdf",
    "intersect_cone_spheres",
    "sample_cone_spheres",
]

_TWO_PI = 2.0 * math.pi


# --- geometry of cone-spheres ------------------------------------------------------------


def _axes(centres: np.ndarray, radii: np.ndarray):
    """Axis length d, unit axis u, sin α and cos α of cone-spheres (any dimension)."""
    delta = centres[..., 1, :] - centres[..., 0, :]
    d = np.linalg.norm(delta, axis=-1)
    u = delta / d[..., None]
    sin_a = (radii[..., 0] - radii[..., 1]) / d
    cos_a = np.sqrt(np.maximum(1.0 - sin_a * sin_a, 0.0))
    return d, u, sin_a, cos_a


def cone_sphere_areas(centres, radii) -> np.ndarray:
    """Exact surface areas of cone-spheres, split into their three parts.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
        End sphere centres, mm.
    radii : (P, 2) array_like
        End sphere radii, mm (``|c2 − c1| > |r1 − r2|``).

    Returns
    -------
    (P, 3) ndarray
        Areas of cap 1, the lateral surface and cap 2, mm².

    Examples
    --------
    A capsule of radius 1 and length 2 (two hemispheres and a cylinder):

    >>> a = cone_sphere_areas([[[0, 0, 0], [0, 0, 2]]], [[1.0, 1.0]])
    >>> np.allclose(a, [[2 * np.pi, 4 * np.pi, 2 * np.pi]])
    True
    """
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    d, _, s, c = _axes(centres, radii)
    r1, r2 = radii[..., 0], radii[..., 1]
    cap1 = _TWO_PI * r1 * r1 * (1.0 + s)
    lateral = math.pi * (r1 + r2) * d * c * c
    cap2 = _TWO_PI * r2 * r2 * (1.0 - s)
    return np.stack([cap1, lateral, cap2], axis=-1)


def _perpendicular_basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing each row of `u` (..., 3) to an orthonormal basis."""
    other = np.zeros_like(u)
    use_x = np.abs(u[..., 0]) < 0.9
    other[use_x, 0] = 1.0
    other[~use_x, 1] = 1.0
    e1 = np.cross(u, other)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(u, e1)
    return e1, e2


def sample_cone_spheres(centres, radii, n: int, rng: np.random.Generator):
    """Area-uniform samples on the surfaces of cone-spheres (each one whole).

    Each sample picks a primitive and a part (cap 1, lateral, cap 2) with probability
    proportional to its exact area (`cone_sphere_areas`), then a uniform point on it: on
    a cap, ``n·u`` uniform (Archimedes) and the azimuth uniform; on the lateral surface
    the azimuth uniform and the position ``τ ∈ [0, 1]`` along it with density ∝
    ``r(τ) = r1 + τ (r2 − r1)`` (the circumference there), by inverting its CDF.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
    radii : (P, 2) array_like
    n : int
    rng : numpy.random.Generator

    Returns
    -------
    primitive : (n,) int ndarray
    points : (n, 3) ndarray
        On the surface of their primitive, in the same frame as `centres`.
    normals : (n, 3) ndarray
        Outward unit normals there.
    """
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    areas = cone_sphere_areas(centres, radii)
    prob = (areas / areas.sum()).ravel()
    pick = rng.choice(prob.size, size=n, p=prob)
    prim, part = np.divmod(pick, 3)
    _, u, s, _ = _axes(centres, radii)
    e1, e2 = _perpendicular_basis(u)
    phi = rng.uniform(0.0, _TWO_PI, n)
    v = rng.uniform(0.0, 1.0, n)
    r1, r2 = radii[prim, 0], radii[prim, 1]
    sp = s[prim]
    # caps: axial normal component z uniform on [-1, sin α] (cap 1) or [sin α, 1] (cap 2)
    z = np.where(part == 0, -1.0 + v * (1.0 + sp), sp + v * (1.0 - sp))
    # lateral: normal component fixed at sin α; τ by inverse CDF of density ∝ r(τ)
    z = np.where(part == 1, sp, z)
    radial = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    ephi = np.cos(phi)[:, None] * e1[prim] + np.sin(phi)[:, None] * e2[prim]
    normals = z[:, None] * u[prim] + radial[:, None] * ephi
    # τ = (r1 + r2) v / (r1 + sqrt(r1² + (r2² − r1²) v)), the root of the CDF in [0, 1]
    tau = (r1 + r2) * v / (r1 + np.sqrt(r1 * r1 + (r2 * r2 - r1 * r1) * v))
    tau = np.where(part == 0, 0.0, np.where(part == 2, 1.0, tau))
    centre = centres[prim, 0] + tau[:, None] * (centres[prim, 1] - centres[prim, 0])
    radius = r1 + tau * (r2 - r1)
    points = centre + radius[:, None] * normals
    return prim.astype(np.intp), points, normals


def cone_sphere_sdf(centres, radii, points) -> np.ndarray:
    """Signed distance from points to cone-spheres (negative inside).

    Works in 2D and 3D (last axis of `centres` and `points` alike).

    Parameters
    ----------
    centres : (P, 2, D) array_like
    radii : (P, 2) array_like
    points : (N, D) array_like

    Returns
    -------
    (N, P) ndarray
        Signed distance of every point to every primitive's surface, mm (or pixels).
    """
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    points = np.asarray(points, dtype=float)
    d, u, s, c = _axes(centres, radii)
    w = points[:, None, :] - centres[None, :, 0, :]  # (N, P, D)
    a = np.einsum("npd,pd->np", w, u)
    q = np.sqrt(np.maximum(np.einsum("npd,npd->np", w, w) - a * a, 0.0))
    k = a * c - q * s
    lateral = a * s + q * c - radii[:, 0]
    sphere1 = np.linalg.norm(w, axis=-1) - radii[:, 0]
    sphere2 = np.linalg.norm(points[:, None, :] - centres[None, :, 1, :], axis=-1) - radii[:, 1]
    return np.where(k < 0.0, sphere1, np.where(k > d * c, sphere2, lateral))


def cone_sphere_normals(centres, radii, points, primitive) -> np.ndarray:
    """Outward unit normals of cone-spheres: the gradient of their signed distance.

    For each point, the gradient of `cone_sphere_sdf` of its own primitive, region by
    region as in the module docstring: ``(p − c1)/|p − c1|`` nearest to sphere 1,
    ``(p − c2)/|p − c2|`` nearest to sphere 2, and ``sin α · u + cos α · e`` nearest to
    the lateral surface (e the unit vector from the axis towards p). All three are the
    direction from the centre of the nearest ball of the sweep between the end spheres,
    which lies on the axis at ``m = clip(k / cos α, 0, d)`` (k as in the module
    docstring): ``n = (p − c1 − m u) / |p − c1 − m u|``. On the surface this is the
    outward normal; off it, the direction away from the nearest surface point. Works in
    2D and 3D.

    Parameters
    ----------
    centres : (P, 2, D) array_like
        End sphere centres, mm (or pixels).
    radii : (P, 2) array_like
        End sphere radii.
    points : (N, D) array_like
        Points, in the frame of `centres`.
    primitive : (N,) int array_like
        The primitive of each point (e.g. the one a ray hit); −1 gives a zero normal.

    Returns
    -------
    (N, D) ndarray
        Unit normals; zero for ``primitive = −1`` and where the gradient is undefined
        (a sphere's centre, the axis inside the frustum).

    Examples
    --------
    On the side of a capsule along z, the normal points away from the axis:

    >>> cone_sphere_normals([[[0, 0, 0], [0, 0, 2]]], [[1.0, 1.0]], [[0, 1.0, 1.0]], [0])
    array([[0., 1., 0.]])
    """
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    points = as_array(points, "points", finite=False, what="points")
    prim = np.asarray(primitive)
    dim = centres.shape[-1]
    if points.ndim != 2 or points.shape[1] != dim:
        raise ValueError(f"points: expected shape (N, {dim}) like centres; got {points.shape}")
    if prim.shape != (points.shape[0],):
        raise ValueError(
            f"primitive: expected shape ({points.shape[0]},) like points; got {prim.shape}"
        )
    if prim.size and prim.dtype.kind not in "iu":
        raise TypeError(f"primitive: expected integer indices; got dtype {prim.dtype}")
    if prim.size and (prim.min() < -1 or prim.max() >= centres.shape[0]):
        raise ValueError(
            f"primitive: expected indices in -1..{centres.shape[0] - 1}; "
            f"got values {prim.min()}..{prim.max()}"
        )
    normals = np.zeros_like(points)
    sel = np.flatnonzero(prim >= 0)
    k = prim[sel]
    d, u, s, c = _axes(centres, radii)
    uk = u[k]
    w = points[sel] - centres[k, 0]
    a = np.einsum("nd,nd->n", w, uk)
    q = np.sqrt(np.maximum(np.einsum("nd,nd->n", w, w) - a * a, 0.0))
    m = np.clip((a * c[k] - q * s[k]) / c[k], 0.0, d[k])  # nearest swept ball's centre
    w -= m[:, None] * uk
    norm = np.sqrt(np.einsum("nd,nd->n", w, w))[:, None]
    normals[sel] = np.divide(w, norm, out=np.zeros_like(w), where=norm > 0.0)
    return normals


# --- ray intersection -------------------------------------------------------------------


def _check_rays(origins, directions) -> tuple[np.ndarray, np.ndarray]:
    o = as_array(origins, "origins", (None, 3), finite=False)
    v = as_array(directions, "directions", finite=False)
    if v.shape != o.shape:
        raise ValueError(f"directions: expected shape {o.shape} like origins; got {v.shape}")
    if not (np.all(np.isfinite(o)) and np.all(np.isfinite(v))):
        raise ValueError("origins, directions: expected finite values; got NaN or infinity")
    if np.any(np.einsum("ij,ij->i", v, v) == 0):
        raise ValueError("directions: expected non-zero direction vectors; got a zero vector")
    return o, v


def _first_sphere_hit(w: np.ndarray, v: np.ndarray, vv: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Entry parameter of rays ``w + t v`` (w relative to the centre) into spheres."""
    b = np.einsum("npd,nd->np", w, v)
    cc = np.einsum("npd,npd->np", w, w) - r * r
    disc = b * b - vv[:, None] * cc
    with np.errstate(invalid="ignore"):
        t = (-b - np.sqrt(disc)) / vv[:, None]
    return np.where((disc >= 0.0) & (t >= 0.0), t, np.inf)


def intersect_cone_spheres(
    centres,
    radii,
    origins,
    directions,
    *,
    return_primitive: bool = False,
    compiled: bool = True,
    chunk: int = 8192,
):
    """First intersection of rays with a union of cone-spheres (exact).

    Each ray is intersected with both end spheres and with the lateral frustum
    ``a sin α + q cos α = r1`` restricted to the slab between the tangent circles
    (``r1 sin α ≤ a ≤ d + r2 sin α``), a quadratic in the ray parameter; the smallest
    non-negative parameter over all parts and primitives is the entry point. The
    compiled route (default) skips primitives whose bounding sphere the ray misses; the
    numpy route evaluates every ray against every primitive, `chunk` rays at a time.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
        World centres, mm.
    radii : (P, 2) array_like
    origins : (N, 3) array_like
        Ray origins (outside the primitives).
    directions : (N, 3) array_like
        Ray directions, not necessarily unit.
    return_primitive : bool, optional
        Also return the index of the primitive hit (−1 for a miss).
    compiled : bool, optional
        Use the compiled loop (numba) rather than the vectorised numpy reference; both
        give the same result to rounding.
    chunk : int, optional
        numpy route: rays processed at a time (memory about ``chunk · P · 200`` bytes).

    Returns
    -------
    depth : (N,) ndarray
        Ray parameter t of the first hit (``origin + t · direction``), ``inf`` for a
        miss.
    primitive : (N,) int ndarray
        Only with ``return_primitive=True``.
    """
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    o, v = _check_rays(origins, directions)
    n = o.shape[0]
    depth = np.full(n, np.inf)
    which = np.full(n, -1, dtype=np.intp)
    if compiled:
        _intersect_kernel(centres, radii, o, v, depth, which)
        return (depth, which) if return_primitive else depth
    d, u, s, c = _axes(centres, radii)
    r1, r2 = radii[:, 0], radii[:, 1]
    lo, hi = r1 * s, d + r2 * s  # slab of the lateral surface along the axis
    for start in range(0, n, chunk):
        sl = slice(start, start + chunk)
        oc, vc = o[sl], v[sl]
        vv = np.einsum("nd,nd->n", vc, vc)
        w = oc[:, None, :] - centres[None, :, 0, :]  # (n, P, 3)
        t1 = _first_sphere_hit(w, vc, vv, r1)
        t2 = _first_sphere_hit(oc[:, None, :] - centres[None, :, 1, :], vc, vv, r2)
        # lateral: c² q² − (r1 − s a)² = 0 with a = au0 + t au1, q² = |w + t v|² − a²
        au0 = np.einsum("npd,pd->np", w, u)
        au1 = vc @ u.T
        wv = np.einsum("npd,nd->np", w, vc)
        ww = np.einsum("npd,npd->np", w, w)
        c2 = c * c
        h = r1 - s * au0
        A = c2 * vv[:, None] - au1 * au1
        B = 2.0 * (c2 * (wv - au0 * au1) + s * au1 * h)
        C = c2 * (ww - au0 * au0) - h * h
        disc = B * B - 4.0 * A * C
        root = np.sqrt(np.maximum(disc, 0.0))
        qq = -0.5 * (B + np.copysign(root, B))
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = qq / A
            tb = C / qq
        tl = np.full_like(t1, np.inf)
        for t in (ta, tb):
            a = au0 + t * au1
            ok = (disc >= 0.0) & np.isfinite(t) & (t >= 0.0) & (a >= lo) & (a <= hi)
            tl = np.where(ok & (t < tl), t, tl)
        t_all = np.minimum(np.minimum(t1, t2), tl)  # (n, P)
        best = np.argmin(t_all, axis=1)
        tb_ = t_all[np.arange(t_all.shape[0]), best]
        depth[sl] = tb_
        which[sl] = np.where(np.isfinite(tb_), best, -1)
    if return_primitive:
        return depth, which
    return depth


# --- compiled loops -------------------------------------------------------------------------
# The same maths as the numpy route above (tests check that both agree), one ray at a
# time: no (N, P) temporaries, and primitives a ray cannot hit are skipped.


@njit(cache=True)
def _axes_kernel(centres, radii):  # pragma: no cover
    """`_axes` as a loop: d (P,), u (P, D) (``(1, 0, …)`` where d = 0), sin α, cos α."""
    P, D = centres.shape[0], centres.shape[2]
    d = np.empty(P)
    u = np.zeros((P, D))
    sa = np.zeros(P)
    ca = np.ones(P)
    for j in range(P):
        dd = 0.0
        for k in range(D):
            u[j, k] = centres[j, 1, k] - centres[j, 0, k]
            dd += u[j, k] * u[j, k]
        d[j] = math.sqrt(dd)
        if d[j] > 0.0:
            for k in range(D):
                u[j, k] /= d[j]
            sa[j] = (radii[j, 0] - radii[j, 1]) / d[j]
            ca[j] = math.sqrt(max(1.0 - sa[j] * sa[j], 0.0))
        else:
            u[j, 0] = 1.0
    return d, u, sa, ca


@njit(cache=True)
def _intersect_kernel(centres, radii, origins, directions, depth, which):  # pragma: no cover
    """Fill depth (N,) and which (N,) with the first hit of each ray (see the numpy route)."""
    P = centres.shape[0]
    d, u, sa, ca = _axes_kernel(centres, radii)
    c2 = ca * ca
    lo = radii[:, 0] * sa  # slab of the lateral surface along the axis
    hi = d + radii[:, 1] * sa
    mid = 0.5 * (centres[:, 0] + centres[:, 1])
    bound2 = (0.5 * d + np.maximum(radii[:, 0], radii[:, 1])) ** 2
    for i in range(origins.shape[0]):
        ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
        vx, vy, vz = directions[i, 0], directions[i, 1], directions[i, 2]
        vv = vx * vx + vy * vy + vz * vz
        best = np.inf
        hit = -1
        for j in range(P):
            # bounding sphere of the primitive: skip when missed or entered after `best`
            mx, my, mz = ox - mid[j, 0], oy - mid[j, 1], oz - mid[j, 2]
            b = mx * vx + my * vy + mz * vz
            disc = b * b - vv * (mx * mx + my * my + mz * mz - bound2[j])
            if disc < 0.0:
                continue
            root = math.sqrt(disc)
            if (-b + root) < 0.0 or (-b - root) / vv >= best:
                continue
            t_best = np.inf
            # the two end spheres (entry root)
            for e in range(2):
                wx = ox - centres[j, e, 0]
                wy = oy - centres[j, e, 1]
                wz = oz - centres[j, e, 2]
                r = radii[j, e]
                b = wx * vx + wy * vy + wz * vz
                disc = b * b - vv * (wx * wx + wy * wy + wz * wz - r * r)
                if disc >= 0.0:
                    t = (-b - math.sqrt(disc)) / vv
                    if t >= 0.0 and t < t_best:
                        t_best = t
            # the lateral frustum: c² q² − (r1 − s a)² = 0 inside the slab [lo, hi]
            wx = ox - centres[j, 0, 0]
            wy = oy - centres[j, 0, 1]
            wz = oz - centres[j, 0, 2]
            au0 = wx * u[j, 0] + wy * u[j, 1] + wz * u[j, 2]
            au1 = vx * u[j, 0] + vy * u[j, 1] + vz * u[j, 2]
            wv = wx * vx + wy * vy + wz * vz
            ww = wx * wx + wy * wy + wz * wz
            hh = radii[j, 0] - sa[j] * au0
            A = c2[j] * vv - au1 * au1
            B = 2.0 * (c2[j] * (wv - au0 * au1) + sa[j] * au1 * hh)
            C = c2[j] * (ww - au0 * au0) - hh * hh
            disc = B * B - 4.0 * A * C
            if disc >= 0.0:
                root = math.sqrt(disc)
                qq = -0.5 * (B + math.copysign(root, B))
                for e in range(2):
                    if e == 0:
                        if A == 0.0:
                            continue
                        t = qq / A
                    else:
                        if qq == 0.0:
                            continue
                        t = C / qq
                    a = au0 + t * au1
                    if t >= 0.0 and a >= lo[j] and a <= hi[j] and t < t_best:
                        t_best = t
            if t_best < best:
                best = t_best
                hit = j
        depth[i] = best
        which[i] = hit
