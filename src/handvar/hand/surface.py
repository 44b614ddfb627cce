"""The hand's surface: a sphere-mesh of cone-spheres.

Every primitive is a *cone-sphere*: the convex hull of two spheres (centres c1, c2,
radii r1, r2), i.e. two spherical caps joined by the frustum of their common tangent
cone. Each finger and thumb bone carries one; the palm carries one per finger ray
plus one for the thenar eminence (`hand_primitives`). Centres are stored in their
bone's frame, so the forward kinematics moves them rigidly.

Geometry of one cone-sphere (used throughout, also in 2D for the projected outlines):
with ``d = |c2 − c1|``, axis ``u = (c2 − c1)/d`` and ``sin α = (r1 − r2)/d`` (we
require ``d > |r1 − r2|``), the outward normal of the lateral surface is
``n = sin α · u + cos α · e`` (e ⟂ u, unit); the tangent points are ``c_i + r_i n``.
In coordinates along the axis ``a = (p − c1)·u`` and off it ``q = |p − c1 − a u|``:

- ``k = a cos α − q sin α < 0``: nearest to sphere 1, distance ``|p − c1| − r1``;
- ``k > d cos α``: nearest to sphere 2, distance ``|p − c2| − r2``;
- otherwise nearest to the lateral surface, distance ``a sin α + q cos α − r1``.

Areas (exact): cap 1 ``2π r1² (1 + sin α)``, cap 2 ``2π r2² (1 − sin α)``, lateral
``π (r1 + r2) d cos² α``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from handvar.hand.anthropometry import BONES, HandShape, bone_index
from handvar.params import N_PARAMS

_TWO_PI = 2.0 * math.pi


def _readonly(a, dtype=float) -> np.ndarray:
    arr = np.array(a, dtype=dtype)
    arr.flags.writeable = False
    return arr


# --- primitives ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Primitives:
    """The cone-spheres of a sphere-mesh, each attached to a bone.

    Attributes
    ----------
    bone : (P,) int ndarray
        Bone index (into `BONES`) of each primitive.
    centres : (P, 2, 3) ndarray
        Centres of the two end spheres in the bone's frame, mm.
    radii : (P, 2) ndarray
        Radii of the two end spheres, mm.
    names : tuple of str
        A name per primitive (the bone's name; ``palm_<finger>`` / ``thenar`` on the palm).
    """

    bone: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        bone = np.asarray(self.bone)
        centres = np.asarray(self.centres, dtype=float)
        radii = np.asarray(self.radii, dtype=float)
        p = bone.shape[0] if bone.ndim == 1 else -1
        if bone.ndim != 1 or p < 1:
            raise ValueError(f"bone: expected a non-empty (P,) array; got shape {bone.shape}")
        if centres.shape != (p, 2, 3):
            raise ValueError(f"centres: expected shape ({p}, 2, 3); got shape {centres.shape}")
        if radii.shape != (p, 2):
            raise ValueError(f"radii: expected shape ({p}, 2); got shape {radii.shape}")
        if not (np.all(np.isfinite(centres)) and np.all(np.isfinite(radii))):
            raise ValueError("centres, radii: expected finite values; got NaN or infinity")
        if np.any(radii <= 0):
            raise ValueError(f"radii: expected positive radii; got minimum {radii.min()}")
        d = np.linalg.norm(centres[:, 1] - centres[:, 0], axis=1)
        bad = d <= np.abs(radii[:, 0] - radii[:, 1]) * (1 + 1e-9)
        if np.any(bad):
            raise ValueError(
                "centres, radii: expected end spheres that do not contain each other "
                f"(|c2 - c1| > |r1 - r2|); got primitives {np.flatnonzero(bad).tolist()}"
            )
        object.__setattr__(self, "bone", _readonly(bone, np.intp))
        object.__setattr__(self, "centres", _readonly(centres))
        object.__setattr__(self, "radii", _readonly(radii))
        names = tuple(self.names) or tuple(f"primitive{i}" for i in range(p))
        if len(names) != p:
            raise ValueError(f"names: expected {p} names; got {len(names)}")
        object.__setattr__(self, "names", names)

    def __len__(self) -> int:
        return int(self.bone.shape[0])


def hand_primitives(shape: HandShape) -> Primitives:
    """The sphere-mesh of a hand: palm cone-spheres first, then one per digit bone.

    Parameters
    ----------
    shape : HandShape

    Returns
    -------
    Primitives
        ``P = Q + 15`` primitives (Q palm cone-spheres, 5 for `HandShape.from_size`).
        A digit bone's cone-sphere runs from its proximal joint (local origin) to the
        next joint (local ``(0, L, 0)``) with the radii of those joints; the distal bones
        end one tip radius short of the fingertip so that their surface reaches it.
    """
    q = shape.palm_centres.shape[0]
    bones = [0] * q
    centres = [c for c in shape.palm_centres]
    radii = [r for r in shape.palm_radii]
    palm_names = ["palm_index", "palm_middle", "palm_ring", "palm_little", "thenar"]
    names = palm_names[:q] if q == 5 else [f"palm{i}" for i in range(q)]
    for k in range(5):
        for level in range(3):
            length = shape.segments[k, level] if level < 2 else shape.tip_offsets[k]
            b = bone_index(k, level)
            bones.append(b)
            centres.append(np.array([[0.0, 0.0, 0.0], [0.0, length, 0.0]]))
            radii.append(shape.radii[k, level : level + 2])
            names.append(BONES[b])
    return Primitives(np.array(bones), np.array(centres), np.array(radii), tuple(names))


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
    points = np.asarray(points, dtype=float)
    prim = np.asarray(primitive)
    dim = centres.shape[-1]
    if points.ndim != 2 or points.shape[1] != dim:
        raise ValueError(f"points: expected shape (N, {dim}) like centres; got {points.shape}")
    if prim.shape != (points.shape[0],):
        raise ValueError(
            f"primitive: expected shape ({points.shape[0]},) like points; got {prim.shape}"
        )
    if prim.size and prim.dtype.kind not in "iu":
        raise ValueError(f"primitive: expected integer indices; got dtype {prim.dtype}")
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


# --- surface samples ---------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SurfaceSamples:
    """Points on the model surface, stored per bone in the bone's frame.

    Move them with ``HandModel.points(x, samples.bone, samples.local)``.

    Attributes
    ----------
    bone : (n,) int ndarray
        Bone index of each sample (into `BONES`).
    local : (n, 3) ndarray
        Position in the bone's frame, mm.
    normal : (n, 3) ndarray or None
        Outward unit surface normal in the bone's frame.
    primitive : (n,) int ndarray or None
        Index of the primitive the sample lies on.
    """

    bone: np.ndarray
    local: np.ndarray
    normal: np.ndarray | None = None
    primitive: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.bone.shape[0])


class SurfacePool:
    """A dense, fixed pool of area-uniform surface samples to draw from quickly.

    The tracker draws a few hundred fresh samples per optimiser iteration; drawing them
    from a pool (uniformly with replacement) costs a few microseconds, whereas sampling
    the cone-spheres afresh costs tens. The pool is drawn once with a fixed seed
    (`sample_cone_spheres`), so a model's pool is the same in every process.

    Samples buried in the union: every candidate is tested, in the rest pose (x = 0, the
    open hand), against the primitives of its own bone and of the bones next to it in the
    skeleton (parent and children); a candidate more than `tolerance` inside one of
    them is not on the union's outer surface and is kept only in the ``exposed=False``
    set. These overlaps (the palm's cone-spheres among themselves and with the thenar,
    the digits' bases inside the palm, the shared sphere at each finger joint) hardly
    change with the pose. Overlaps that do depend on the pose (adjacent fingers touching,
    a fingertip pressed on the palm, the back of a strongly flexed knuckle opening up)
    are not accounted for: such samples still project inside the model's silhouette, so
    they cost nothing in the silhouette term.

    Parameters
    ----------
    primitives : Primitives
    rest_frames : ((B, 3, 3), (B, 3)) tuple of ndarray
        world_from_bone rotations and origins of the bones in the rest pose.
    size : int
        Number of candidate samples.
    parents : (B,) int ndarray
        Parent bone of each bone, −1 for the root.
    seed : int, optional
        Seed of the pool.
    tolerance : float, optional
        How deep (mm) a candidate must lie inside a neighbour to count as buried.
    """

    def __init__(
        self,
        primitives: Primitives,
        rest_frames,
        *,
        size: int,
        parents,
        seed: int = 0,
        tolerance: float = 1e-6,
    ) -> None:
        rng = np.random.default_rng(seed)
        prim, local, normal = sample_cone_spheres(primitives.centres, primitives.radii, size, rng)
        bone = primitives.bone[prim]
        rot, org = (np.asarray(a, dtype=float) for a in rest_frames)
        world = np.einsum("nij,nj->ni", rot[bone], local) + org[bone]
        b = primitives.bone
        parents = np.asarray(parents)
        same = b[:, None] == b[None, :]
        adjacent = (parents[b][:, None] == b[None, :]) | (b[:, None] == parents[b][None, :])
        neighbours = (same | adjacent) & ~np.eye(len(b), dtype=bool)
        rest_centres = np.einsum("pij,pkj->pki", rot[b], primitives.centres) + org[b][:, None, :]
        buried = np.zeros(size, dtype=bool)
        for start in range(0, size, 16384):
            sl = slice(start, start + 16384)
            sdf = cone_sphere_sdf(rest_centres, primitives.radii, world[sl])
            buried[sl] = np.any((sdf < -tolerance) & neighbours[prim[sl]], axis=1)
        self.all = SurfaceSamples(
            _readonly(bone, np.intp), _readonly(local), _readonly(normal), _readonly(prim, np.intp)
        )
        keep = ~buried
        self.exposed = SurfaceSamples(
            _readonly(bone[keep], np.intp),
            _readonly(local[keep]),
            _readonly(normal[keep]),
            _readonly(prim[keep], np.intp),
        )

    def draw(self, n: int, rng: np.random.Generator, *, exposed: bool = True) -> SurfaceSamples:
        """Draw `n` samples uniformly (with replacement) from the pool.

        Parameters
        ----------
        n : int
            Number of samples, ≥ 0.
        rng : numpy.random.Generator
        exposed : bool, optional
            Draw from the samples on the union's outer surface (default) or from all
            candidates (area-uniform over every primitive's whole surface).

        Returns
        -------
        SurfaceSamples
            New arrays (writeable copies).
        """
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n: expected a non-negative integer; got {n!r}")
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng: expected a numpy.random.Generator; got {type(rng).__name__}")
        src = self.exposed if exposed else self.all
        idx = rng.integers(0, src.bone.shape[0], int(n))
        return SurfaceSamples(src.bone[idx], src.local[idx], src.normal[idx], src.primitive[idx])


# --- ray intersection -------------------------------------------------------------------


def _check_rays(origins, directions) -> tuple[np.ndarray, np.ndarray]:
    o = np.asarray(origins, dtype=float)
    v = np.asarray(directions, dtype=float)
    if o.ndim != 2 or o.shape[1] != 3:
        raise ValueError(f"origins: expected shape (N, 3); got shape {o.shape}")
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


# --- projection ---------------------------------------------------------------------------


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


def project_cone_spheres(centres, radii, camera, jacobian=None):
    """Project cone-spheres into a camera (circle approximation of the sphere outlines).

    A sphere's exact image is an ellipse; we approximate it by the circle centred at the
    projection of the sphere's centre with radius ``ρ = f r / sqrt(z² − r²)``
    (``f = (fx + fy) / 2``, z the camera-frame depth of the centre), exact for a sphere
    on the optical axis of an undistorted camera. At an angle θ off the axis the true
    outline is an ellipse whose tangential semi-axis is about ρ and whose radial
    semi-axis is about ρ / cos θ (2 % longer at 0.2 rad, i.e. a hand near the image
    centre; 17 % at the corner of a 640×480 image with f = 650 px). Each primitive's
    image is approximated by the 2D hull of its two circles.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
        World centres, mm.
    radii : (P, 2) array_like
        Radii, mm.
    camera : Camera
        Anything with ``fx, fy, R, project_jacobian, camera_from_world``.
    jacobian : (P, 2, 3, 26) array_like, optional
        ``d centres / d x``; when given the derivatives of the projection are returned.

    Returns
    -------
    projected : ProjectedPrimitives
    dtheta : (P, 6, 26) ndarray or None
        With `jacobian`: derivatives of ``(c1u, c1v, c2u, c2v, ρ1, ρ2)`` w.r.t. x.
    """
    if not all(hasattr(camera, a) for a in ("fx", "fy", "R", "project_jacobian")):
        raise ValueError(f"camera: expected a handvar.camera.Camera; got {type(camera).__name__}")
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    p = centres.shape[0]
    X = centres.reshape(-1, 3)
    uv, Jp = camera.project_jacobian(X, jacobian=jacobian is not None)
    z = camera.camera_from_world(X)[:, 2]
    f = 0.5 * (camera.fx + camera.fy)
    r = radii.reshape(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        zz = z * z - r * r
        rho = f * r / np.sqrt(zz)
    visible = np.all((z > r).reshape(p, 2), axis=1)
    projected = ProjectedPrimitives(
        uv.reshape(p, 2, 2), rho.reshape(p, 2), z.reshape(p, 2), visible
    )
    if jacobian is None:
        return projected, None
    J = np.asarray(jacobian, dtype=float).reshape(-1, 3, N_PARAMS)
    duv = Jp @ J  # (2P, 2, 26)
    dz = np.einsum("j,njk->nk", np.asarray(camera.R, dtype=float)[2], J)  # (2P, 26)
    with np.errstate(divide="ignore", invalid="ignore"):
        drho = (-rho * z / zz)[:, None] * dz  # ρ = f r (z² − r²)^(−1/2): dρ = −ρ z/(z² − r²) dz
    dtheta = np.concatenate(
        [duv.reshape(p, 4, N_PARAMS), drho.reshape(p, 2, N_PARAMS)], axis=1
    )  # (P, 6, 26): c1u, c1v, c2u, c2v, ρ1, ρ2
    return projected, dtheta


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
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    s_px = np.asarray(pixels, dtype=float)
    if s_px.ndim != 2 or s_px.shape[1] != 2:
        raise ValueError(f"pixels: expected shape (M, 2); got shape {s_px.shape}")
    if not np.all(np.isfinite(s_px)):
        raise ValueError("pixels: expected finite coordinates; got NaN or infinity")
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
        _closest_2d_kernel(centres, radii, valid, s_px, h, dh, prim, dist)
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


def closest_point_projected(centres, radii, jacobian, camera, pixels):
    """h(x) and dh/dx of the filling cost (eq. 1) for world cone-spheres and a camera.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
        World centres, mm.
    radii : (P, 2) array_like
        Radii, mm.
    jacobian : (P, 2, 3, 26) array_like
        d centres / d x.
    camera : Camera
    pixels : (M, 2) array_like

    Returns
    -------
    h : (M, 2) ndarray
        Closest point of the model's (approximate, see `project_cone_spheres`) image.
        Primitives not entirely in front of the camera are ignored.
    dh : (M, 2, 26) ndarray
        d h / d x.
    """
    projected, dtheta = project_cone_spheres(centres, radii, camera, jacobian)
    h, dh6, prim, _ = closest_point_cone_spheres_2d(
        projected.centres, projected.radii, pixels, valid=projected.visible
    )
    dh = dh6 @ dtheta[np.maximum(prim, 0)]
    dh[prim < 0] = 0.0
    return h, dh


# --- compiled loops -------------------------------------------------------------------------
# The same maths as the numpy routes above (tests check that both agree), one ray or
# pixel at a time: no (N, P) temporaries, and primitives a ray cannot hit are skipped.


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


@njit(cache=True)
def _closest_2d_kernel(centres, radii, valid, pixels, h, dh, prim, dist):  # pragma: no cover
    """Fill h, dh, prim, dist as `closest_point_cone_spheres_2d` (numpy route) does."""
    P = centres.shape[0]
    Dp, u, sa, ca = _axes_kernel(centres, radii)
    ux, uy = u[:, 0], u[:, 1]
    strip_end = Dp * ca
    for j in range(P):
        if Dp[j] <= abs(radii[j, 0] - radii[j, 1]) * (1.0 + 1e-12) + 1e-12:
            sa[j], ca[j] = 0.0, 1.0  # one circle inside the other: never the flank
            strip_end[j] = -np.inf
    for i in range(pixels.shape[0]):
        sx, sy = pixels[i, 0], pixels[i, 1]
        best = -1
        bestd = np.inf
        bflank = False
        buse2 = False
        bperp = 0.0
        for j in range(P):
            if not valid[j]:
                continue
            wx = sx - centres[j, 0, 0]
            wy = sy - centres[j, 0, 1]
            a = wx * ux[j] + wy * uy[j]
            perp = wy * ux[j] - wx * uy[j]
            q = abs(perp)
            d1 = math.sqrt(a * a + perp * perp) - radii[j, 0]
            a2 = a - Dp[j]
            d2 = math.sqrt(a2 * a2 + perp * perp) - radii[j, 1]
            k = a * ca[j] - q * sa[j]
            if k >= 0.0 and k <= strip_end[j]:
                sd = a * sa[j] + q * ca[j] - radii[j, 0]
                flank = True
            else:
                sd = min(d1, d2)
                flank = False
            if sd < bestd:
                bestd, best, bflank, buse2, bperp = sd, j, flank, d2 < d1, perp
        prim[i] = best
        dist[i] = bestd
        h[i, 0], h[i, 1] = sx, sy
        if best < 0 or bestd <= 0.0:
            continue
        j = best
        if bflank:
            uxj, uyj = ux[j], uy[j]
            jux, juy = -uyj, uxj
            sigma = 1.0 if bperp >= 0.0 else -1.0
            nx = sa[j] * uxj + sigma * ca[j] * jux
            ny = sa[j] * uyj + sigma * ca[j] * juy
            tx, ty = -ny, nx
            wx = sx - centres[j, 0, 0]
            wy = sy - centres[j, 0, 1]
            delta = nx * wx + ny * wy - radii[j, 0]
            h[i, 0] = sx - delta * nx
            h[i, 1] = sy - delta * ny
            tw = tx * wx + ty * wy
            mx = tw * nx + delta * tx
            my = tw * ny + delta * ty
            gx = (jux + sigma * sa[j] / ca[j] * uxj) / Dp[j]
            gy = (juy + sigma * sa[j] / ca[j] * uyj) / Dp[j]
            kr = sigma / (Dp[j] * ca[j])
            n_ = (nx, ny)
            m_ = (mx, my)
            for r in range(2):
                dh[i, r, 0] = n_[r] * nx + m_[r] * gx
                dh[i, r, 1] = n_[r] * ny + m_[r] * gy
                dh[i, r, 2] = -m_[r] * gx
                dh[i, r, 3] = -m_[r] * gy
                dh[i, r, 4] = n_[r] + kr * m_[r]
                dh[i, r, 5] = -kr * m_[r]
        else:
            e = 1 if buse2 else 0
            cx, cy, ri = centres[j, e, 0], centres[j, e, 1], radii[j, e]
            wx, wy = sx - cx, sy - cy
            ni = math.sqrt(wx * wx + wy * wy)
            if ni <= 0.0:
                ni = 1.0
            ex, ey = wx / ni, wy / ni
            h[i, 0] = cx + ri * ex
            h[i, 1] = cy + ri * ey
            f = ri / ni
            col = 2 * e
            dh[i, 0, col] = 1.0 - f * (1.0 - ex * ex)
            dh[i, 0, col + 1] = f * ex * ey
            dh[i, 1, col] = f * ey * ex
            dh[i, 1, col + 1] = 1.0 - f * (1.0 - ey * ey)
            dh[i, 0, 4 + e] = ex
            dh[i, 1, 4 + e] = ey


__all__ = [
    "Primitives",
    "ProjectedPrimitives",
    "SurfacePool",
    "SurfaceSamples",
    "closest_point_cone_spheres_2d",
    "closest_point_projected",
    "cone_sphere_areas",
    "cone_sphere_normals",
    "cone_sphere_sdf",
    "hand_primitives",
    "intersect_cone_spheres",
    "project_cone_spheres",
    "sample_cone_spheres",
]
