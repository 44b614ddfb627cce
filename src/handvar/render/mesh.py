"""Silhouette and colour rendering of the skinned mesh hand (design §15).

The mesh counterparts of :func:`handvar.render.silhouettes` and
:func:`handvar.render.render_rgb`, which call these for a ``HandModel(surface="mesh")``.
Silhouettes scan-convert the projected triangles (:mod:`handvar.hand.raster`, the
sphere-mesh renderer's coverage rules). Colour images take a depth buffer
(``coverage="centre"``) and shade each pixel by Lambert's law with the normal
interpolated from the vertices' normals (area-weighted face normals of the posed mesh)
by the pixel's barycentric coordinates in its triangle (Phong interpolation), over the
same synthetic backgrounds and with the same sensor noise as the sphere-mesh.
"""

from __future__ import annotations

import numpy as np

from handvar.camera import Rig
from handvar.geometry.normals import vertex_normals
from handvar.params import check_pose
from handvar.render.common import BACKGROUNDS, Shading, check_rig, shade_views
from handvar.validate import one_of

__all__ = ["mesh_silhouettes", "pixel_normals", "render_mesh_rgb"]


def pixel_normals(uv, triangles, normals, rows, cols, tri) -> np.ndarray:
    """(n, 3) unit normals at pixels, interpolated from the vertices' normals (Phong).

    Parameters
    ----------
    uv : (V, 2) ndarray
        Projected vertices, pixels.
    triangles : (T, 3) int ndarray
    normals : (V, 3) ndarray
        Vertex normals (`handvar.geometry.vertex_normals`).
    rows, cols : (n,) int ndarray
        The pixels (centres at integers).
    tri : (n,) int ndarray
        The triangle seen at each pixel (a depth buffer's).
    """
    t = triangles[tri]
    a, b, c = uv[t[:, 0]], uv[t[:, 1]], uv[t[:, 2]]
    p = np.stack([cols, rows], -1).astype(float)
    # barycentric coordinates of the pixel centre in the projected triangle
    d = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    d = np.where(d == 0, 1.0, d)
    lb = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (p[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / d
    lc = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[:, 0] - a[:, 0])) / d
    lam = np.clip(np.stack([1.0 - lb - lc, lb, lc], -1), 0.0, 1.0)
    n = np.einsum("ni,nic->nc", lam, normals[t])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return n


def mesh_silhouettes(hand, x, rig: Rig, *, coverage: str = "touch") -> np.ndarray:
    """Silhouette masks (n_cams, H, W) bool of the mesh hand at pose `x` in every camera."""
    x = check_pose(x, "x")
    w, h = check_rig(rig)
    out = np.empty((len(rig), h, w), dtype=bool)
    for k, cam in enumerate(rig):
        out[k] = hand.mesh.silhouette(x, cam, coverage=coverage)
    return out


def render_mesh_rgb(hand, x, rig: Rig, *, background="clutter", rng=None, shading=None):
    """Shaded colour images (n_cams, H, W, 3) uint8 RGB of the mesh hand (module docstring).

    Parameters as :func:`handvar.render.render_rgb`.
    """
    x = check_pose(x, "x")
    one_of(background, BACKGROUNDS, "background")
    w, h = check_rig(rig)
    rng = np.random.default_rng(0) if rng is None else rng
    sh = Shading() if shading is None else shading
    mesh = hand.mesh
    tris = mesh.triangles
    verts = mesh.vertices(x)
    normals = vertex_normals(verts, tris)

    def surface_normals(cam):
        tri_id, _ = mesh.depth_buffer(x, cam)
        rows, cols = np.nonzero(tri_id >= 0)
        if not rows.size:
            return rows, cols, np.empty((0, 3))
        return rows, cols, pixel_normals(cam.project(verts), tris, normals, rows, cols,
                                         tri_id[rows, cols])  # fmt: skip

    return shade_views(rig, (w, h), background, rng, sh, surface_normals)
