"""Vertex normals of a triangle mesh: what the renderer shades by and the glTF carries."""

from __future__ import annotations

import numpy as np

__all__ = ["vertex_normals"]


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(V, 3) unit outward vertex normals: sums of the adjacent faces' area normals.

    A vertex on no triangle gets the zero vector.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> vertex_normals(square, np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    """
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    face = np.cross(b - a, c - a)  # 2 · area · normal (counter-clockwise = outward)
    # each face's normal onto its three corners (bincount: np.add.at's sums, faster)
    corners, n = triangles.T.ravel(), len(vertices)
    normals = np.stack(
        [np.bincount(corners, weights=np.tile(face[:, k], 3), minlength=n) for k in range(3)], 1
    )
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    return normals / np.where(norm > 0, norm, 1.0)
