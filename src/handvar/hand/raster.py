"""Scan conversion of projected triangles: masks, depth and triangle ids (design §15).

Pixel ``[i, j]`` is centred on ``(u, v) = (j, i)`` (OpenCV's convention, as in
:mod:`handvar.render`). Two coverage rules, the same as the sphere-mesh renderer's:

- ``"centre"``: the pixel is set when its centre lies in a triangle (edges included);
  the point-sampled image of a renderer. With a depth buffer, each set pixel also gets
  the nearest triangle there and its depth (``1/z`` interpolated linearly in the image,
  exact for a planar triangle under a pinhole projection).
- ``"touch"``: the pixel is set when its square ``[j − ½, j + ½] × [i − ½, i + ½]``
  meets a triangle. A triangle and a square are disjoint exactly when one of their
  edge normals separates them (separating axis theorem): the square's two axes (the
  triangle's bounding box) and the triangle's three edge normals n, for which the test
  is the edge function at the square's most inward corner, ``e(c) + ½ (|n_u| + |n_v|)``.

The loops are compiled (numba); a triangle costs its bounding box in pixels.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["rasterize_triangles"]

_COVERAGE = ("touch", "centre")


def rasterize_triangles(uv, triangles, size, *, coverage: str = "touch", depth=None):
    """Pixels covered by 2D triangles, and optionally a depth buffer.

    Parameters
    ----------
    uv : (V, 2) array_like
        Vertex pixel coordinates.
    triangles : (T, 3) int array_like
        Vertex indices; triangles with a vertex that is not finite are skipped.
    size : (int, int)
        Image (width, height).
    coverage : {"touch", "centre"}, optional
        Which pixels count as covered (module docstring).
    depth : (V,) array_like, optional
        Camera depth z of each vertex, mm (> 0). With it (``coverage="centre"`` only),
        also return the nearest triangle and its depth at every covered pixel.

    Returns
    -------
    mask : (H, W) bool ndarray
    tri_id : (H, W) int ndarray
        Only with `depth`: the nearest triangle at each pixel, −1 where none.
    zbuf : (H, W) ndarray
        Only with `depth`: its depth, mm (inf where none).

    Examples
    --------
    >>> m = rasterize_triangles([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]], [[0, 1, 2]], (6, 5),
    ...                         coverage="centre")
    >>> m.astype(int)
    array([[1, 1, 1, 1, 1, 0],
           [1, 1, 1, 1, 0, 0],
           [1, 1, 1, 0, 0, 0],
           [1, 1, 0, 0, 0, 0],
           [1, 0, 0, 0, 0, 0]])
    """
    if coverage not in _COVERAGE:
        raise ValueError(f"coverage: expected one of {', '.join(_COVERAGE)}; got {coverage!r}")
    uv = np.ascontiguousarray(uv, dtype=float)
    tri = np.ascontiguousarray(triangles, dtype=np.int64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"uv: expected shape (V, 2); got shape {uv.shape}")
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise ValueError(f"triangles: expected shape (T, 3); got shape {tri.shape}")
    if tri.size and (tri.min() < 0 or tri.max() >= uv.shape[0]):
        raise ValueError(f"triangles: expected indices in 0..{uv.shape[0] - 1}")
    w, h = int(size[0]), int(size[1])
    mask = np.zeros((h, w), dtype=np.bool_)
    with_depth = depth is not None
    if with_depth:
        if coverage != "centre":
            raise ValueError("depth: expected coverage='centre' with a depth buffer")
        z = np.ascontiguousarray(depth, dtype=float)
        if z.shape != (uv.shape[0],):
            raise ValueError(f"depth: expected shape ({uv.shape[0]},); got shape {z.shape}")
    else:
        z = np.ones(uv.shape[0])
    tri_id = np.full((h, w) if with_depth else (0, 0), -1, dtype=np.int64)
    zbuf = np.full((h, w) if with_depth else (0, 0), np.inf)
    _raster_kernel(uv, z, tri, coverage == "touch", with_depth, mask, tri_id, zbuf)
    return (mask, tri_id, zbuf) if with_depth else mask


@njit(cache=True)
def _raster_kernel(uv, z, tri, touch, with_depth, mask, tri_id, zbuf):  # pragma: no cover
    """Scan-convert every triangle into `mask` (and the depth buffer); see the module."""
    h, w = mask.shape
    pad = 0.5 if touch else 0.0
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ax, ay, bx, by, cx, cy = uv[a, 0], uv[a, 1], uv[b, 0], uv[b, 1], uv[c, 0], uv[c, 1]
        if not (
            math.isfinite(ax) and math.isfinite(ay) and math.isfinite(bx)
            and math.isfinite(by) and math.isfinite(cx) and math.isfinite(cy)
        ):  # fmt: skip
            continue
        area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if area == 0.0 and not touch:
            continue
        sgn = 1.0 if area >= 0.0 else -1.0
        # edge functions e_i(p) = n_i · p + k_i, ≥ 0 inside (orientation-corrected)
        n0u, n0v = -(cy - by) * sgn, (cx - bx) * sgn  # edge b→c, opposite a
        n1u, n1v = -(ay - cy) * sgn, (ax - cx) * sgn  # edge c→a, opposite b
        n2u, n2v = -(by - ay) * sgn, (bx - ax) * sgn  # edge a→b, opposite c
        k0 = -(n0u * bx + n0v * by)
        k1 = -(n1u * cx + n1v * cy)
        k2 = -(n2u * ax + n2v * ay)
        g0 = pad * (abs(n0u) + abs(n0v))
        g1 = pad * (abs(n1u) + abs(n1v))
        g2 = pad * (abs(n2u) + abs(n2v))
        umin = max(math.ceil(min(ax, bx, cx) - pad), 0)
        umax = min(math.floor(max(ax, bx, cx) + pad), w - 1)
        vmin = max(math.ceil(min(ay, by, cy) - pad), 0)
        vmax = min(math.floor(max(ay, by, cy) + pad), h - 1)
        for i in range(vmin, vmax + 1):
            for j in range(umin, umax + 1):
                e0 = n0u * j + n0v * i + k0
                e1 = n1u * j + n1v * i + k1
                e2 = n2u * j + n2v * i + k2
                if e0 + g0 < 0.0 or e1 + g1 < 0.0 or e2 + g2 < 0.0:
                    continue
                mask[i, j] = True
                if with_depth:
                    s = e0 + e1 + e2  # = |2 area|
                    inv = (e0 / z[a] + e1 / z[b] + e2 / z[c]) / s
                    d = 1.0 / inv
                    if d < zbuf[i, j]:
                        zbuf[i, j] = d
                        tri_id[i, j] = t
