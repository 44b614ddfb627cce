"""`decimate_mesh` against properties a decimated surface must keep: the same topology
(Euler characteristic, an oriented 2-manifold, the boundary kept), vertices that are
original ones, no degenerate triangle, the area and the shape close to the original's
(every original vertex near the decimated surface, measured by point-to-triangle
distance computed here)."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.export.gltf import rest_mesh
from handvar.geometry.decimate import decimate_mesh
from handvar.hand.anthropometry import HandShape


def _edges(triangles: np.ndarray) -> np.ndarray:
    """(3F, 2) directed edges of the triangles."""
    return np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])


def _euler(n_vertices: int, triangles: np.ndarray) -> int:
    undirected = {tuple(sorted(e)) for e in _edges(triangles).tolist()}
    return n_vertices - len(undirected) + len(triangles)


def _boundary(triangles: np.ndarray) -> set[int]:
    directed = [tuple(e) for e in _edges(triangles).tolist()]
    pairs = set(directed)
    return {v for a, b in directed if (b, a) not in pairs for v in (a, b)}


def _area(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def _point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Distance from each point p (N, 3) to the nearest of the triangles (a, b, c), by
    sampling each triangle densely (barycentric grid of step 1/24): an upper bound
    within the grid's spacing."""
    steps = 24
    i, j = np.meshgrid(np.arange(steps + 1), np.arange(steps + 1), indexing="ij")
    keep = i + j <= steps
    u, v = i[keep] / steps, j[keep] / steps
    samples = (a[:, None] + u[None, :, None] * (b - a)[:, None]
               + v[None, :, None] * (c - a)[:, None]).reshape(-1, 3)  # fmt: skip
    from scipy.spatial import cKDTree

    return cKDTree(samples).query(p)[0]


@pytest.fixture(scope="module")
def hand_mesh():
    vertices, triangles, _ = rest_mesh(HandShape.from_size())
    return vertices, triangles


@pytest.mark.parametrize("target", [800, 450, 300])
def test_the_hand_mesh_keeps_its_topology_and_shape(hand_mesh, target):
    vertices, triangles = hand_mesh
    kept, small = decimate_mesh(vertices, triangles, target)
    assert len(kept) == target
    assert np.all(np.diff(kept) > 0) and kept.min() >= 0 and kept.max() < len(vertices)
    v = vertices[kept]
    # the same topology: Euler characteristic, and an oriented 2-manifold (every
    # directed edge once, its reverse in the neighbouring triangle or on the boundary)
    assert _euler(len(kept), small) == _euler(len(vertices), triangles)
    directed = [tuple(e) for e in _edges(small).tolist()]
    assert len(set(directed)) == len(directed)
    assert set(np.unique(small)) == set(range(len(kept)))  # no vertex left unused
    # the boundary (the wrist's opening) kept vertex for vertex
    assert {int(kept[b]) for b in _boundary(small)} == _boundary(triangles)
    # no degenerate triangle; the area within 2 % of the original's
    area = _area(v, small)
    assert area.min() > 1e-3 * np.median(area)
    assert abs(area.sum() / _area(vertices, triangles).sum() - 1.0) < 0.02
    # every original vertex near the decimated surface
    a, b, c = (v[small[:, i]] for i in range(3))
    gap = _point_triangle_distance(vertices, a, b, c)
    assert gap.max() < {800: 1.0, 450: 1.5, 300: 3.0}[target], gap.max()  # mm


def _sphere(levels: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit sphere: an octahedron whose edges are split `levels` times at their
    midpoints, pushed onto the sphere; triangles wound outwards."""
    points = [np.array(p, float) for p in
              [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]]  # fmt: skip
    tri = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5],
           [0, 3, 5]]  # fmt: skip
    for _ in range(levels):
        middle: dict[tuple[int, int], int] = {}
        new = []
        for corners in tri:
            mids = []
            for p, q in zip(corners, np.roll(corners, -1), strict=True):
                key = (min(p, q), max(p, q))
                if key not in middle:
                    m = points[p] + points[q]
                    points.append(m / np.linalg.norm(m))
                    middle[key] = len(points) - 1
                mids.append(middle[key])
            (a, b, c), (ab, bc, ca) = corners, mids
            new += [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
        tri = new
    return np.array(points), np.array(tri)


def test_a_closed_surface_stays_closed():
    """A sphere (258 vertices) down to 60: closed (Euler characteristic 2, no
    boundary), its volume within 15 %."""
    verts, tri = _sphere(3)
    assert len(verts) == 258
    kept, small = decimate_mesh(verts, tri, 60)
    assert len(kept) == 60 and _euler(60, small) == 2 and not _boundary(small)
    v = verts[kept]
    a, b, c = (v[small[:, i]] for i in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0  # outward winding: > 0
    assert abs(volume / (4.0 / 3.0 * np.pi) - 1.0) < 0.15


def test_bad_inputs_name_the_argument(hand_mesh):
    vertices, triangles = hand_mesh
    with pytest.raises(ValueError, match=r"^vertices: "):
        decimate_mesh(vertices[:, :2], triangles, 100)
    with pytest.raises(ValueError, match=r"^triangles: expected an \(F, 3\) integer"):
        decimate_mesh(vertices, triangles.astype(float), 100)
    with pytest.raises(ValueError, match=r"^triangles: expected indices into the 1656"):
        decimate_mesh(vertices, triangles + 1000, 100)
    with pytest.raises(ValueError, match=r"^n_vertices: expected an integer of at least 3"):
        decimate_mesh(vertices, triangles, 2)
