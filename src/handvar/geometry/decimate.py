"""A triangle mesh with fewer vertices, its vertices a subset of the original's.

`decimate_mesh` collapses edges, each one onto one of its ends (a *half-edge collapse*:
the removed vertex's triangles are re-attached to the kept one and the two triangles on
the edge disappear), the cheapest first by Garland and Heckbert's quadric error
("Surface simplification using quadric error metrics", SIGGRAPH 1997): a vertex
carries the planes of its triangles, and gathers those of the vertices collapsed onto
it; collapsing u onto w costs the sum of squared distances of w to u's planes,
``[w 1] Q_u [w 1]ᵀ`` (their eq. 2), plus a thousandth of the edge's squared length, which
decides between collapses that cost nothing (a flat region: the shorter first). Since
every kept vertex is an original one, a mesh that moves (a skinned hand over a track)
is decimated once, at rest, and every frame takes its kept vertices by index: no new
positions to compute per frame.

A collapse is made only when it keeps the surface a surface:

- the *link condition*: the two ends share no neighbour but the far corners of the
  triangles on the edge (otherwise the collapse pinches the surface into a
  non-manifold edge);
- no re-attached triangle turns by more than `max_turn` degrees or becomes degenerate
  (no fold-over);
- a vertex on the boundary (an edge with one triangle, e.g. the wrist's opening) is
  never removed, so that holes keep their outline.

The Euler characteristic V − E + F is unchanged by such collapses (each removes one
vertex, three edges and two triangles), which the tests check.
"""

from __future__ import annotations

import heapq

import numpy as np

from handvar.validate import as_array

__all__ = ["decimate_mesh"]


def _normal(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.cross(b - a, c - a)


def decimate_mesh(vertices, triangles, n_vertices: int, *, max_turn: float = 60.0):
    """Collapse the edges of a triangle mesh, cheapest first, until `n_vertices` remain.

    Parameters
    ----------
    vertices : (V, 3) array_like
        Vertex positions (any unit).
    triangles : (F, 3) array_like of int
        Vertex indices of each triangle, consistently wound.
    n_vertices : int
        The number of vertices to keep; fewer collapses are made when no valid one is
        left (module notes), so that more may remain.
    max_turn : float, keyword-only
        The largest turn of a re-attached triangle's normal, degrees.

    Returns
    -------
    kept : (K,) int ndarray
        The indices of the kept vertices into `vertices`, ascending.
    triangles : (F', 3) int ndarray
        The decimated mesh's triangles, indices into `kept` (so its vertices are
        ``vertices[kept]``), with the original winding.

    Examples
    --------
    A flat 5 x 5 grid of a square: its 9 inner points go, its 16 on the border stay.

    >>> i, j = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    >>> grid = np.column_stack([i.ravel(), j.ravel(), np.zeros(25)])
    >>> corner = (5 * i + j)[:4, :4].ravel()  # each cell's lower-left point
    >>> tri = np.vstack([np.column_stack([corner, corner + 5, corner + 6]),
    ...                  np.column_stack([corner, corner + 6, corner + 1])])
    >>> kept, small = decimate_mesh(grid, tri, 3)
    >>> len(kept), len(small)
    (16, 14)
    """
    v = as_array(vertices, "vertices", (None, 3))
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or not np.issubdtype(tri.dtype, np.integer):
        raise ValueError(f"triangles: expected an (F, 3) integer array; got {tri.dtype} "
                         f"{tri.shape}")  # fmt: skip
    if tri.size and (tri.min() < 0 or tri.max() >= len(v)):
        raise ValueError(f"triangles: expected indices into the {len(v)} vertices; got "
                         f"{tri.min()} to {tri.max()}")  # fmt: skip
    if not isinstance(n_vertices, int | np.integer) or n_vertices < 3:
        raise ValueError(f"n_vertices: expected an integer of at least 3; got {n_vertices!r}")
    faces = [list(map(int, f)) for f in tri]
    alive = [True] * len(faces)
    around: list[set[int]] = [set() for _ in range(len(v))]  # vertex -> its triangles
    edge_faces: dict[tuple[int, int], int] = {}  # edge (low, high) -> its triangles
    quadric = np.zeros((len(v), 4, 4))  # Q_v: the planes of v's triangles (their eq. 2)
    for f, corners in enumerate(faces):
        a, b, c = v[corners]
        normal = _normal(a, b, c)
        size = np.linalg.norm(normal)
        if size > 0.0:
            plane = np.append(normal / size, -(normal / size) @ a)  # n·x + d = 0
            quadric[corners] += np.outer(plane, plane)
        for k in range(3):
            around[corners[k]].add(f)
            p, q = sorted((corners[k], corners[(k + 1) % 3]))
            edge_faces[p, q] = edge_faces.get((p, q), 0) + 1
    border = {p for edge, n in edge_faces.items() if n == 1 for p in edge}
    present = np.zeros(len(v), dtype=bool)
    present[np.unique(tri)] = True
    left = int(present.sum())
    cos_turn = np.cos(np.radians(max_turn))

    def neighbours(p: int) -> set[int]:
        return {w for f in around[p] for w in faces[f]} - {p}

    def cost(u: int, w: int) -> float:
        """Collapsing u onto w: w's squared distance to u's planes, and the tie-break."""
        h = np.append(v[w], 1.0)
        return float(h @ quadric[u] @ h) + 1e-3 * float(np.sum((v[u] - v[w]) ** 2))

    def can_remove(u: int, w: int) -> bool:
        """Whether u can be collapsed onto w (module notes)."""
        if u in border:
            return False
        shared = [f for f in around[u] if w in faces[f]]
        if len(shared) != 2:
            return False
        far = {x for f in shared for x in faces[f]} - {u, w}
        if neighbours(u) & neighbours(w) != far:
            return False
        for f in around[u]:
            if f in shared:
                continue
            a, b, c = (v[x] for x in faces[f])
            before = _normal(a, b, c)
            a, b, c = (v[w if x == u else x] for x in faces[f])
            after = _normal(a, b, c)
            size = np.linalg.norm(before) * np.linalg.norm(after)
            if size <= 1e-12 * max(1.0, float(np.linalg.norm(before)) ** 2):
                return False
            if float(before @ after) < cos_turn * size:
                return False
        return True

    heap = [(cost(u, w), u, w) for p, q in edge_faces for u, w in ((p, q), (q, p))
            if u not in border]  # fmt: skip
    heapq.heapify(heap)
    while left > n_vertices and heap:
        key, u, w = heapq.heappop(heap)
        if not (present[u] and present[w]) or w not in neighbours(u):
            continue
        now = cost(u, w)
        if now != key:  # u gathered planes since: queue it again at its cost
            heapq.heappush(heap, (now, u, w))
            continue
        if not can_remove(u, w):
            continue
        for f in list(around[u]):
            if w in faces[f]:  # a triangle on the edge: gone
                alive[f] = False
                for x in faces[f]:
                    around[x].discard(f)
            else:
                faces[f] = [w if x == u else x for x in faces[f]]
                around[w].add(f)
        around[u].clear()
        present[u] = False
        quadric[w] += quadric[u]
        left -= 1
        for x in neighbours(w):
            for a, b in ((w, x), (x, w)):
                if a not in border:
                    heapq.heappush(heap, (cost(a, b), a, b))
    kept = np.flatnonzero(present)
    index = np.full(len(v), -1)
    index[kept] = np.arange(len(kept))
    out = np.array([faces[f] for f in range(len(faces)) if alive[f]], dtype=np.int64)
    return kept, index[out.reshape(-1, 3)]
