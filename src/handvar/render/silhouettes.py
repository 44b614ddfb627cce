"""Exact silhouettes of the sphere-mesh hand model (design §2, §3).

The hand surface is a union of cone-spheres, each the convex hull of two spheres. Under
perspective projection segments map to segments, so the image of a cone-sphere is the
convex hull of the images of its two spheres, and the image of a sphere is an ellipse
bounded by the conic of its tangent cone. Silhouettes are therefore computed exactly:

1. per sphere, the image ellipse in closed form (:func:`sphere_ellipses`);
2. per cone-sphere, points of the convex hull of its two ellipses, taken as the support
   points in a dense set of outward normal directions (the polygon is inscribed in the
   true outline and differs from it by at most ``tol`` pixels);
3. all outlines are scan-converted at once by a winding-number rasteriser: pixel
   ``mask[i, j]`` is set exactly when its centre ``(u, v) = (j, i)`` lies inside an
   outline (OpenCV's pixel-centre convention, as in ``cv2.projectPoints``).

Which pixels count as covered (``coverage``): by default (``"touch"``) every pixel
whose square ``[j − ½, j + ½] × [i − ½, i + ½]`` meets the model's image, obtained by
growing each outline by half a pixel in u and v (its Minkowski sum with the pixel
square) before scan conversion. Then every point of the model surface, projected and
rounded to the nearest pixel, lands on a set pixel, and the mask equals a dense
projection of surface samples. ``"centre"`` gives the point-sampled mask of a
conventional renderer (pixel centre inside the image), about half a pixel thinner
along the outline; the colour renderer (:mod:`handvar.render.shading`) uses it.

Lens distortion: the outline is computed in undistorted normalised coordinates, its
edges are cut into pieces shorter than ``tol_distortion`` pixels and every vertex is
mapped through the distortion. This is exact up to that sampling as long as the
distortion is one-to-one over the outline, which holds for a calibrated lens inside its
calibrated field of view; outlines far outside the image may fold where the polynomial
model does.

Primitives not entirely in front of a camera (a sphere reaching the plane z_cam = 0) are
not drawn in that camera: their image is not bounded.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from handvar.camera import Camera, Rig
from handvar.geometry.distortion import distort_normalized
from handvar.params import check_pose
from handvar.render.common import check_rig
from handvar.validate import as_array, one_of

__all__ = [
    "SphereMeshModel",
    "outlines",
    "silhouette_of_spheres",
    "silhouettes",
    "sphere_ellipses",
]


class SphereMeshModel(Protocol):
    """What the renderer needs from a hand model (``handvar.hand.HandModel``)."""

    def world_spheres(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centres (P, 2, 3) mm and radii (P, 2) mm of the cone-spheres at pose x."""
        ...


# --- sphere images ------------------------------------------------------------------


def sphere_ellipses(centres: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image ellipses of spheres, in normalised image coordinates.

    The tangent cone from the optical centre to a sphere with centre ``c`` (camera
    frame) and radius ``r`` is ``dᵀ C d = 0`` with ``C = c cᵀ − (cᵀc − r²) I``; on the
    plane ``z = 1`` (``d = (x, y, 1)``) it is the conic ``xᵀ A x + 2 bᵀ x + e = 0`` with
    ``A = C[:2, :2]``, ``b = C[:2, 2]``, ``e = C[2, 2]``, whose inside is
    ``(x − x₀)ᵀ S⁻¹ (x − x₀) ≤ 1`` with ``x₀ = −A⁻¹ b`` and
    ``S = (e + bᵀ x₀) (−A)⁻¹``.

    Parameters
    ----------
    centres : (M, 3) ndarray
        Sphere centres in camera coordinates, mm. Each must satisfy ``z > r``.
    radii : (M,) ndarray
        Radii, mm (0 gives a point).

    Returns
    -------
    x0 : (M, 2) ndarray
        Ellipse centres (normalised coordinates; not the image of the sphere centre).
    S : (M, 2, 2) ndarray
        Shape matrices: the ellipse is ``{x₀ + S^{1/2} u : |u| ≤ 1}``; the support
        point for the outward normal ``n`` is ``x₀ + S n / sqrt(nᵀ S n)``.
    """
    c = np.asarray(centres, dtype=float)
    r = np.asarray(radii, dtype=float)
    cxy, cz = c[:, :2], c[:, 2]
    s = np.einsum("ij,ij->i", c, c) - r * r  # cᵀc − r²
    # A = c_xy c_xyᵀ − s I (negative definite when cz > r)
    a11 = cxy[:, 0] ** 2 - s
    a22 = cxy[:, 1] ** 2 - s
    a12 = cxy[:, 0] * cxy[:, 1]
    det = a11 * a22 - a12 * a12
    b = cxy * cz[:, None]  # b = cz c_xy
    e = cz * cz - s
    # x0 = −A⁻¹ b
    x0 = -np.stack([a22 * b[:, 0] - a12 * b[:, 1], a11 * b[:, 1] - a12 * b[:, 0]], -1)
    x0 /= det[:, None]
    m = e + np.einsum("ij,ij->i", b, x0)  # e − bᵀA⁻¹b
    # S = m (−A)⁻¹
    S = np.empty((c.shape[0], 2, 2))
    S[:, 0, 0] = -a22
    S[:, 1, 1] = -a11
    S[:, 0, 1] = S[:, 1, 0] = a12
    S *= (m / det)[:, None, None]
    return x0, S


def _n_normals(S_px: np.ndarray, tol: float) -> int:
    """Number of normal directions so the inscribed outline is within `tol` pixels.

    The sagitta of an arc of curvature radius ρ turning by Δθ is ρ Δθ² / 8; the largest
    curvature radius of an ellipse with semi-axes a ≥ b is a² / b.
    """
    if S_px.shape[0] == 0:
        return 32
    half_tr = 0.5 * (S_px[:, 0, 0] + S_px[:, 1, 1])
    det = S_px[:, 0, 0] * S_px[:, 1, 1] - S_px[:, 0, 1] ** 2
    disc = np.sqrt(np.maximum(half_tr**2 - det, 0.0))
    a2 = half_tr + disc
    b = np.sqrt(np.maximum(half_tr - disc, 0.0))
    rho = np.max(a2 / np.maximum(b, 1e-3))
    k = int(np.ceil(2.0 * np.pi / np.sqrt(8.0 * tol / max(rho, 1e-9))))
    return int(np.clip(k, 32, 2048))


def _hull_polygons(
    centres: np.ndarray, radii: np.ndarray, camera: Camera, tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Outlines of the cone-spheres in one camera, as polygons with K vertices each.

    Returns the vertices (P', K, 2), in pixels without distortion or in undistorted
    normalised coordinates with distortion, the outward normal direction of each
    vertex (K, 2) (in the same coordinates) and the indices (P',) of the primitives
    that are drawn (those entirely in front of the camera).
    """
    P = centres.shape[0]
    cam_c = (centres.reshape(-1, 3) @ camera.R.T + camera.t).reshape(P, 2, 3)
    keep = np.all(cam_c[:, :, 2] > radii * (1.0 + 1e-9) + 1e-9, axis=1)
    idx = np.flatnonzero(keep)
    x0, S = sphere_ellipses(cam_c[idx].reshape(-1, 3), radii[idx].reshape(-1))
    f = np.array([camera.fx, camera.fy])
    S_px = S * np.outer(f, f)
    K = _n_normals(S_px, tol)
    theta = np.linspace(0.0, 2.0 * np.pi, K, endpoint=False)
    n = np.stack([np.cos(theta), np.sin(theta)], -1)  # outward normals (K, 2)
    if not camera.has_distortion:
        x0 = x0 * f + (camera.cx, camera.cy)
        S = S_px
    Sn = np.einsum("kj,mij->mki", n, S)  # S n, (M, K, 2)
    q = np.sqrt(np.maximum(np.einsum("kj,mkj->mk", n, Sn), 0.0))
    h = x0 @ n.T + q  # support function h(n) = nᵀx₀ + sqrt(nᵀ S n), (M, K)
    pts = x0[:, None, :] + Sn / np.maximum(q, 1e-300)[:, :, None]  # support points
    h = h.reshape(-1, 2, K)
    pts = pts.reshape(-1, 2, K, 2)
    first = h[:, 0] >= h[:, 1]  # support of the hull of both: the larger of the two
    poly = np.where(first[..., None], pts[:, 0], pts[:, 1])
    return poly, n, idx


_COVERAGE = ("touch", "centre")


def outlines(
    centres,
    radii,
    camera: Camera,
    *,
    coverage: str = "touch",
    tol: float = 0.02,
    tol_distortion: float = 1.0,
) -> list[np.ndarray]:
    """Image outlines of cone-spheres, in pixels.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
        Sphere centres of each cone-sphere, mm (world).
    radii : (P, 2) array_like
        Sphere radii, mm.
    camera : Camera
    coverage : {"touch", "centre"}, optional
        ``centre``: the outline of the image itself; ``touch``: the outline grown by
        half a pixel in u and in v (its Minkowski sum with the pixel square), so that a
        pixel centre lies inside exactly when the pixel's square touches the image.
    tol : float, optional
        Largest distance (pixels) between the inscribed polygon and the true outline.
    tol_distortion : float, optional
        Longest polygon edge (pixels) mapped through the lens distortion as a straight
        piece.

    Returns
    -------
    list of (V, 2) ndarray
        One closed polygon per drawn primitive, in pixels (primitives reaching behind
        the camera plane are left out), all with the same orientation.
    """
    centres, radii = _check_spheres(centres, radii)
    verts, _, poly_id = _outline_vertices(centres, radii, camera, coverage, tol, tol_distortion)
    return [verts[poly_id == i] for i in np.unique(poly_id)]


def _outline_vertices(centres, radii, camera: Camera, coverage: str, tol, tol_distortion):
    """Polygon vertices (V, 2) in pixels, next-vertex index (V,), polygon index (V,)."""
    one_of(coverage, _COVERAGE, "coverage")
    poly, normals, _ = _hull_polygons(centres, radii, camera, tol)
    n_poly, K = poly.shape[:2]
    verts = poly.reshape(-1, 2)
    poly_id = np.repeat(np.arange(n_poly), K)
    f = np.array([camera.fx, camera.fy])
    c = np.array([camera.cx, camera.cy])
    if not camera.has_distortion:
        vnormals = np.broadcast_to(normals, poly.shape).reshape(-1, 2)
        nxt = _next_in_polygon(poly_id)
    else:
        # cut edges into pieces at most tol_distortion pixels long, then distort
        nxt = _next_in_polygon(poly_id)
        d = verts[nxt] - verts
        m = np.maximum(np.ceil(np.linalg.norm(d * f, axis=1) / tol_distortion), 1).astype(int)
        rep = np.repeat(np.arange(verts.shape[0]), m)
        j = np.arange(rep.size) - np.repeat(np.cumsum(m) - m, m)
        xy = verts[rep] + (j / m[rep])[:, None] * d[rep]
        poly_id = poly_id[rep]
        verts = distort_normalized(xy, camera.dist) * f + c
        nxt = _next_in_polygon(poly_id)
        if coverage == "touch":
            # outward vertex normals from the neighbours: perpendicular to next − previous
            prv = np.empty_like(nxt)
            prv[nxt] = np.arange(nxt.size)
            tangent = verts[nxt] - verts[prv]
            vnormals = np.stack([tangent[:, 1], -tangent[:, 0]], -1)
            vnormals *= _orientation(verts, nxt, poly_id, n_poly)[poly_id, None]
    if coverage == "touch":
        # support point of P ⊕ [−½, ½]²: h(n) + ½(|n_u| + |n_v|), i.e. move the vertex
        # to the corner of the pixel square that faces along its outward normal
        verts = verts + 0.5 * np.sign(vnormals)
    return verts, nxt, poly_id


def _next_in_polygon(poly_id: np.ndarray) -> np.ndarray:
    """Index of the next vertex in the same (contiguously stored, closed) polygon."""
    nxt = np.arange(1, poly_id.size + 1)
    if poly_id.size:
        last = np.flatnonzero(np.diff(poly_id, append=-1) != 0)  # last vertex of each
        first = np.concatenate([[0], last[:-1] + 1])
        nxt[last] = first
    return nxt


def _orientation(verts, nxt, poly_id, n_poly) -> np.ndarray:
    """±1 per polygon: +1 when the vertex normal (t_v, −t_u) points outwards."""
    cross = verts[:, 0] * verts[nxt, 1] - verts[:, 1] * verts[nxt, 0]
    area = np.bincount(poly_id, weights=cross, minlength=n_poly)  # twice the signed area
    # positive area: the order of increasing angle atan2(v, u), as for the support
    # points c + r (cos θ, sin θ) whose tangent (−sin θ, cos θ) gives (cos θ, sin θ)
    return np.where(area >= 0, 1.0, -1.0)


def _rasterize(starts: np.ndarray, ends: np.ndarray, sign: np.ndarray, size) -> np.ndarray:
    """Winding-number scan conversion of closed polygons given by their edges.

    A pixel is set when its centre has a non-zero winding number: for every row of
    pixel centres ``v = i``, each edge crossing it (half-open in v, so a vertex counts
    once) adds ±1 from its crossing column onwards, and the running sum along the row
    is the winding number.
    """
    w, h = size
    y0, y1 = starts[:, 1], ends[:, 1]
    lo = np.ceil(np.minimum(y0, y1))
    hi = np.ceil(np.maximum(y0, y1)) - 1.0  # rows i with min ≤ i < max
    lo = np.clip(lo, 0, h)
    hi = np.clip(hi, -1, h - 1)
    count = np.maximum(hi - lo + 1, 0).astype(np.int64)
    if count.sum() == 0:
        return np.zeros((h, w), dtype=bool)
    e = np.repeat(np.arange(starts.shape[0]), count)
    row = np.repeat(lo.astype(np.int64), count)
    row += np.arange(e.size) - np.repeat(np.cumsum(count) - count, count)
    x0, x1 = starts[e, 0], ends[e, 0]
    ya, yb = y0[e], y1[e]
    # crossing of the edge with the row v = row
    x = x0 + (row - ya) * (x1 - x0) / (yb - ya)
    col = np.clip(np.ceil(x), 0, w).astype(np.int64)
    direction = np.where(yb > ya, 1.0, -1.0) * sign[e]
    # accumulate only over the bounding box of the crossings: every row's crossings
    # sum to zero, so the winding number vanishes left of the first and from the last
    r0, r1 = int(row.min()), int(row.max()) + 1
    c0, c1 = int(col.min()), min(int(col.max()), w)
    out = np.zeros((h, w), dtype=bool)
    if c1 <= c0:
        return out
    bw = c1 - c0 + 1
    acc = np.bincount((row - r0) * bw + (col - c0), weights=direction, minlength=(r1 - r0) * bw)
    winding = np.cumsum(acc.reshape(r1 - r0, bw)[:, :-1], axis=1)
    out[r0:r1, c0:c1] = np.abs(winding) > 0.5
    return out


def _check_spheres(centres, radii) -> tuple[np.ndarray, np.ndarray]:
    centres = as_array(centres, "centres", (None, 2, 3))
    radii = as_array(radii, "radii", (None, 2))
    if radii.shape[0] != centres.shape[0]:
        raise ValueError(
            f"radii: expected shape ({centres.shape[0]}, 2) to match centres; got {radii.shape}"
        )
    if np.any(radii < 0):
        raise ValueError("radii: expected non-negative radii; got a negative one")
    return centres, radii


def silhouette_of_spheres(
    centres,
    radii,
    camera: Camera,
    *,
    coverage: str = "touch",
    tol: float = 0.02,
    tol_distortion: float = 1.0,
) -> np.ndarray:
    """Exact silhouette mask of a union of cone-spheres in one camera.

    Parameters
    ----------
    centres : (P, 2, 3) array_like
        The two sphere centres of each cone-sphere, mm (world).
    radii : (P, 2) array_like
        Their radii, mm.
    camera : Camera
    coverage : {"touch", "centre"}, optional
        ``touch`` (default): a pixel is set when the model's image touches its square
        ``[j − ½, j + ½] × [i − ½, i + ½]``, so every projected model point, rounded to
        the nearest pixel, lands on a set pixel. ``centre``: set when the image
        contains the pixel centre (the point-sampled mask of a renderer).
    tol, tol_distortion : float, optional
        Outline accuracy in pixels (see :func:`outlines`).

    Returns
    -------
    (H, W) bool ndarray
        ``mask[i, j]`` for the pixel centred on ``(u, v) = (j, i)``.
    """
    centres, radii = _check_spheres(centres, radii)
    verts, nxt, poly_id = _outline_vertices(centres, radii, camera, coverage, tol, tol_distortion)
    n_poly = int(poly_id.max()) + 1 if poly_id.size else 0
    sign = _orientation(verts, nxt, poly_id, n_poly)[poly_id]
    return _rasterize(verts, verts[nxt], sign, camera.size)


def silhouettes(
    hand: SphereMeshModel, x, rig: Rig, *, coverage: str = "touch", tol: float = 0.02
) -> np.ndarray:
    """Silhouette masks of the hand model at pose `x` in every camera of `rig`.

    Parameters
    ----------
    hand : HandModel
        Anything with ``world_spheres(x) -> (centres (P, 2, 3), radii (P, 2))``.
    x : (26,) array_like
        Pose (design §2).
    rig : Rig
        Cameras, all with the same image size.
    coverage : {"touch", "centre"}, optional
        Which pixels count as covered (see :func:`silhouette_of_spheres`).
    tol : float, optional
        Outline accuracy, pixels.

    Returns
    -------
    (n_cams, H, W) bool ndarray

    Examples
    --------
    >>> from handvar.hand.kinematics import HandModel, named_pose
    >>> masks = silhouettes(HandModel(), named_pose("open"), Rig.default())
    >>> masks.shape, masks.dtype
    ((2, 480, 640), dtype('bool'))
    """
    if getattr(hand, "surface", "spheres") == "mesh":  # the skinned mesh (design §15)
        from handvar.render.mesh import mesh_silhouettes

        return mesh_silhouettes(hand, x, rig, coverage=coverage)
    x = check_pose(x, "x")
    w, h = check_rig(rig)
    centres, radii = hand.world_spheres(x)
    out = np.empty((len(rig), h, w), dtype=bool)
    for k, cam in enumerate(rig):
        out[k] = silhouette_of_spheres(centres, radii, cam, coverage=coverage, tol=tol)
    return out
