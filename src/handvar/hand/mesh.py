"""The skinned mesh hand: a scanned hand surface driven by the 26 parameters (design §15).

The paper tracks with "a deformable hand model … from a 3D scan" (paper §2); this is
that model, built on the right hand of the MakeHuman base mesh (package data
``mesh-hand.npz``, see ``src/handvar/data/README.md``).

Registration (once, at load time): the mesh's rest skeleton (21 keypoints) is mapped
onto the rest skeleton of a `HandShape` bone by bone, so that the mesh's joints are the
sphere-mesh's joints G(x) by construction:

- hand frames: the mesh's hand frame has its origin at the mesh's wrist, y towards its
  middle MCP, x along (index MCP − little MCP) made orthogonal to y, ``z = x × y``
  (palmar), as the model's (`handvar.hand.kinematics`);
- palm: a thin-plate spline in the palm plane (x, y) with a scaled z maps the mesh's six
  palm joints (wrist, thumb CMC, four MCPs) exactly onto the model's;
- digit bone b from joint j to joint j': the mesh's bone direction is turned onto the
  model's by the shortest rotation Q_b, and a vertex m is given bone coordinates
  ``l_b = S_b F_bᵀ (m − j)`` with ``F_b = Q_bᵀ R_b⁰`` (the model's rest bone frame
  turned back onto the mesh's bone) and ``S_b = diag(s_b, L_b / L_b^mesh, s_b)``: the
  bone's length becomes the model's, its thickness scales by the ratio s_b of the
  model's radius to the mesh's.

Skinning (linear blend): a vertex or surface sample with bones b_k, bone coordinates
l_k and weights w_k (Σ w_k = 1) sits at ``p(x) = Σ_k w_k (R_bk(x) l_k + o_bk(x))``,
with R_b, o_b the bone frames that `HandModel` computes. Its Jacobian is
``Σ_k w_k ∂(R_bk l_k + o_bk)/∂x``; every column of a bone-attached point is a revolute
joint's ``ω × (p − a)`` (or the identity for translation), so column c of the blend is
``ω_c × (q_c − m_c a_c)`` with ``q_c = Σ_{k moved by c} w_k p_k`` and
``m_c = Σ_{k moved by c} w_k``: one cross product per column whatever the number of
influences (`_skin_kernel`).

A point on a triangle with barycentric coordinates β is a blend of the three corners'
blends; its influences with the same bone merge into one (bone coordinates are linear),
so surface samples are stored like vertices: bones, bone coordinates, weights.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from importlib import resources

import numpy as np
from numba import njit

from handvar.geometry.rotations import shortest_rotation
from handvar.hand.anthropometry import HandShape, bone_index
from handvar.params import N_PARAMS

__all__ = ["MeshData", "MeshSamples", "SkinnedMesh", "load_mesh_data"]

DEG = math.pi / 180.0
N_BONES = 16
# keypoints at each end of a digit bone: bone (k, level) runs from 1+4k+level to +1
_PALM_JOINTS = np.array([0, 1, 5, 9, 13, 17])


@dataclass(frozen=True, eq=False)
class MeshData:
    """The raw mesh hand of the package data (mm, mesh frame, rest pose).

    Attributes
    ----------
    vertices : (V, 3) ndarray
        Rest positions, mm.
    triangles : (T, 3) int ndarray
        Vertex indices, counter-clockwise seen from outside.
    weights : (V, 16) ndarray
        Skinning weights over `BONES`, rows summing to 1.
    joints : (21, 3) ndarray
        Rest keypoints in the order of G(x), mm.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    weights: np.ndarray
    joints: np.ndarray


def load_mesh_data() -> MeshData:
    """Read ``handvar/data/mesh-hand.npz`` (see the data README for its provenance)."""
    raw = resources.files("handvar.data").joinpath("mesh-hand.npz").read_bytes()
    with np.load(io.BytesIO(raw)) as npz:
        return MeshData(
            np.asarray(npz["vertices"], dtype=float),
            np.asarray(npz["triangles"], dtype=np.int64),
            np.asarray(npz["weights"], dtype=float),
            np.asarray(npz["joints"], dtype=float),
        )


@dataclass(frozen=True, eq=False)
class MeshSamples:
    """Points on the mesh, each a blend of bone-attached points.

    Attributes
    ----------
    bone : (N, K) int ndarray
        Influencing bones (padding: bone 0 with weight 0).
    local : (N, K, 3) ndarray
        The point in each influence bone's frame, mm.
    weight : (N, K) ndarray
        Blend weights, rows summing to 1.
    triangle : (N,) int ndarray
        Triangle the point lies on (−1 for a vertex).
    barycentric : (N, 3) ndarray
        Its barycentric coordinates on that triangle.
    """

    bone: np.ndarray
    local: np.ndarray
    weight: np.ndarray
    triangle: np.ndarray
    barycentric: np.ndarray

    def __len__(self) -> int:
        return int(self.bone.shape[0])

    def take(self, index) -> MeshSamples:
        """The samples at `index` (an integer array)."""
        return MeshSamples(
            self.bone[index], self.local[index], self.weight[index], self.triangle[index],
            self.barycentric[index],
        )  # fmt: skip


def _hand_frame(joints: np.ndarray) -> np.ndarray:
    """(3, 3) columns x, y, z of the hand frame of a skeleton (module docstring)."""
    y = joints[9] - joints[0]
    y /= np.linalg.norm(y)
    x = joints[5] - joints[17]
    x -= (x @ y) * y
    x /= np.linalg.norm(x)
    return np.stack([x, y, np.cross(x, y)], axis=1)


class _PalmWarp:
    """Thin-plate spline of the palm plane, exact at the palm joints (module docstring)."""

    def __init__(self, src: np.ndarray, dst: np.ndarray, z_scale: float) -> None:
        self.src = src[:, :2].copy()
        self.z_scale = z_scale
        target = dst - np.column_stack([np.zeros((len(src), 2)), z_scale * src[:, 2]])
        n = len(src)
        L = np.zeros((n + 3, n + 3))
        L[:n, :n] = self._kernel(self.src, self.src)
        L[:n, n] = 1.0
        L[:n, n + 1 :] = self.src
        L[n, :n] = 1.0
        L[n + 1 :, :n] = self.src.T
        rhs = np.zeros((n + 3, 3))
        rhs[:n] = target
        self.coef = np.linalg.solve(L, rhs)

    @staticmethod
    def _kernel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        r2 = np.sum((a[:, None] - b[None]) ** 2, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(r2 > 0, 0.5 * r2 * np.log(np.where(r2 > 0, r2, 1.0)), 0.0)

    def __call__(self, m: np.ndarray) -> np.ndarray:
        n = len(self.src)
        xy = m[:, :2]
        out = self._kernel(xy, self.src) @ self.coef[:n]
        out += self.coef[n] + xy @ self.coef[n + 1 :]
        out[:, 2] += self.z_scale * m[:, 2]
        return out


def _bone_radius(m: np.ndarray, head: np.ndarray, tail: np.ndarray) -> float:
    """Median distance of points m (mesh frame) to the segment head–tail's axis."""
    d = tail - head
    length = np.linalg.norm(d)
    d = d / length
    w = m - head
    t = w @ d
    inside = (t > 0.1 * length) & (t < 0.9 * length)
    if inside.sum() < 5:
        inside = np.ones(len(m), dtype=bool)
    radial = w[inside] - np.outer(t[inside], d)
    return float(np.median(np.linalg.norm(radial, axis=1)))


class SkinnedMesh:
    """The mesh hand registered to a `HandShape`: vertices as blends of bone points.

    Parameters
    ----------
    shape : HandShape
        The hand whose rest skeleton the mesh is fitted to.
    rest_rotations : (16, 3, 3) ndarray
        hand_from_bone rotations of the model's bones at the rest pose (all angles 0).
    rest_origins : (16, 3) ndarray
        Their origins, mm (hand frame).
    data : MeshData, optional
        The raw mesh (`load_mesh_data()` by default).

    Attributes
    ----------
    triangles : (T, 3) int ndarray
    vertices : MeshSamples
        The V vertices as blends (``triangle`` −1).
    scales : (16,) ndarray
        Thickness scale s_b of each bone (the palm's: its z scale).
    """

    def __init__(
        self,
        shape: HandShape,
        rest_rotations: np.ndarray,
        rest_origins: np.ndarray,
        data: MeshData | None = None,
    ) -> None:
        data = load_mesh_data() if data is None else data
        joints = data.joints
        H = _hand_frame(joints)
        m = (data.vertices - joints[0]) @ H  # mesh hand frame
        mj = (joints - joints[0]) @ H
        W = data.weights
        V = m.shape[0]
        model_joints = _rest_joints(shape, rest_rotations, rest_origins)

        local = np.zeros((V, N_BONES, 3))
        scales = np.ones(N_BONES)
        # palm: z scale from the palm's thickness
        palm_v = m[W[:, 0] > 0.9]
        in_palm = (palm_v[:, 1] > 0.2 * mj[9, 1]) & (palm_v[:, 1] < 0.9 * mj[9, 1])
        zs = palm_v[in_palm, 2]
        half = 0.5 * (np.percentile(zs, 95) - np.percentile(zs, 5))
        scales[0] = float(np.mean(shape.palm_radii)) / half
        warp = _PalmWarp(mj[_PALM_JOINTS], model_joints[_PALM_JOINTS], scales[0])
        local[:, 0] = warp(m)
        for k in range(5):
            for level in range(3):
                b = bone_index(k, level)
                j0 = 1 + 4 * k + level
                head, tail = mj[j0], mj[j0 + 1]
                length = np.linalg.norm(tail - head)
                u = (tail - head) / length
                R0 = rest_rotations[b]
                Q = shortest_rotation(u, R0[:, 1])
                F = Q.T @ R0  # the model's bone frame turned onto the mesh's bone
                heavy = m[W[:, b] > 0.5]
                radius = _bone_radius(heavy, head, tail) if len(heavy) else 1.0
                s = float(np.mean(shape.radii[k, level : level + 2])) / radius
                scales[b] = s
                S = np.array([s, shape.segments[k, level] / length, s])
                local[:, b] = ((m - head) @ F) * S
        self.shape = shape
        self.scales = scales
        self.triangles = np.ascontiguousarray(data.triangles, dtype=np.int64)
        self._dense_local = local  # (V, 16, 3)
        self._dense_weight = W
        self._rest = (np.asarray(rest_rotations, float), np.asarray(rest_origins, float))
        self.vertices = _compress(W, local, np.full(V, -1), np.zeros((V, 3)))
        self.n_vertices = V

    def blend(self, triangle, barycentric) -> MeshSamples:
        """Points on triangles as blends of bone points (influences merged per bone).

        Parameters
        ----------
        triangle : (N,) int array_like
        barycentric : (N, 3) array_like
            Barycentric coordinates, rows summing to 1.

        Returns
        -------
        MeshSamples
        """
        tri = np.asarray(triangle, dtype=np.int64)
        beta = np.asarray(barycentric, dtype=float)
        corners = self.triangles[tri]  # (N, 3)
        # weight of bone b: Σ_i β_i w_ib; its point: Σ_i β_i w_ib l_ib / that weight
        wb = np.einsum("ni,nib->nb", beta, self._dense_weight[corners])
        lw = np.einsum("ni,nib,nibc->nbc", beta, self._dense_weight[corners],
                       self._dense_local[corners])  # fmt: skip
        with np.errstate(invalid="ignore", divide="ignore"):
            lb = np.where(wb[..., None] > 0, lw / np.where(wb > 0, wb, 1.0)[..., None], 0.0)
        return _compress(wb, lb, tri, beta)

    def sample(self, n: int, rng: np.random.Generator) -> MeshSamples:
        """n area-uniform random points on the mesh at its rest pose.

        Areas are those of the registered rest mesh (all angles zero).
        """
        rest = self.rest_vertices()
        a, b, c = (rest[self.triangles[:, i]] for i in range(3))
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
        tri = rng.choice(len(area), size=n, p=area / area.sum())
        r1, r2 = rng.random(n), rng.random(n)
        s = np.sqrt(r1)
        beta = np.column_stack([1.0 - s, s * (1.0 - r2), s * r2])
        return self.blend(tri, beta)

    def rest_vertices(self) -> np.ndarray:
        """(V, 3) vertices at the rest pose, hand frame, mm."""
        return np.einsum("vb,vbc->vc", self._dense_weight, self._rest_points())

    def _rest_points(self) -> np.ndarray:
        """(V, 16, 3) every vertex as a point of every bone, at the rest pose."""
        R, o = self._rest
        return np.einsum("bij,vbj->vbi", R, self._dense_local) + o


def _rest_joints(shape: HandShape, rotations: np.ndarray, origins: np.ndarray) -> np.ndarray:
    """(21, 3) rest keypoints of the model from its rest bone frames."""
    joints = np.empty((21, 3))
    joints[0] = origins[0]
    for k in range(5):
        for level in range(3):
            b = bone_index(k, level)
            joints[1 + 4 * k + level] = origins[b]
        b = bone_index(k, 2)
        joints[4 + 4 * k] = origins[b] + shape.segments[k, 2] * rotations[b][:, 1]
    return joints


def _compress(wb: np.ndarray, lb: np.ndarray, tri: np.ndarray, beta: np.ndarray) -> MeshSamples:
    """Dense (N, 16) weights and (N, 16, 3) points → the K = max influences layout."""
    nz = wb > 0
    K = max(int(nz.sum(axis=1).max()), 1) if len(wb) else 1
    order = np.argsort(-wb, axis=1, kind="stable")[:, :K]
    weight = np.take_along_axis(wb, order, axis=1)
    local = np.take_along_axis(lb, order[..., None], axis=1)
    bone = np.where(weight > 0, order, 0)
    local = np.where(weight[..., None] > 0, local, 0.0)
    return MeshSamples(
        np.ascontiguousarray(bone, dtype=np.int64), np.ascontiguousarray(local),
        np.ascontiguousarray(weight), np.asarray(tri, dtype=np.int64), np.asarray(beta),
    )  # fmt: skip


# --- skinning and its Jacobian ----------------------------------------------------------


def skin(pose, samples: MeshSamples, jacobian: bool = False):
    """World positions of blended points at a pose, and optionally their Jacobian.

    Parameters
    ----------
    pose : handvar.hand.kinematics._Pose
        The forward kinematics of the pose (`HandModel._pose`).
    samples : MeshSamples
    jacobian : bool, optional

    Returns
    -------
    points : (N, 3) ndarray
        mm, world.
    J : (N, 3, 26) ndarray
        Only with ``jacobian=True``: mm per mm (translation), mm per degree (angles).
    """
    n = len(samples)
    p = np.empty((n, 3))
    J = np.empty((n, 3, N_PARAMS)) if jacobian else np.empty((0, 3, N_PARAMS))
    _skin_kernel(
        pose.rotations, pose.origins, pose.t, pose._euler_axes, pose.axes, pose.anchors,
        samples.bone, samples.local, samples.weight, p, J, jacobian,
    )  # fmt: skip
    return (p, J) if jacobian else p


@njit(cache=True)
def _skin_kernel(
    rotations, origins, t, euler_axes, axes, anchors, bone, local, weight, p, J, jacobian
):  # pragma: no cover - compiled
    """p_n = Σ_k w_k (R_bk l_k + o_bk); J column c = ω_c × (q_c − m_c a_c) (module doc)."""
    deg = math.pi / 180.0
    S = np.empty((16, 3))
    Wb = np.empty(16)
    q = np.empty(3)
    for n in range(bone.shape[0]):
        for b in range(16):
            Wb[b] = 0.0
            S[b, 0] = 0.0
            S[b, 1] = 0.0
            S[b, 2] = 0.0
        p0 = 0.0
        p1 = 0.0
        p2 = 0.0
        wsum = 0.0
        for k in range(bone.shape[1]):
            w = weight[n, k]
            if w == 0.0:
                continue
            b = bone[n, k]
            l0, l1, l2 = local[n, k, 0], local[n, k, 1], local[n, k, 2]
            x0 = rotations[b, 0, 0] * l0 + rotations[b, 0, 1] * l1 + rotations[b, 0, 2] * l2
            x1 = rotations[b, 1, 0] * l0 + rotations[b, 1, 1] * l1 + rotations[b, 1, 2] * l2
            x2 = rotations[b, 2, 0] * l0 + rotations[b, 2, 1] * l1 + rotations[b, 2, 2] * l2
            x0 += origins[b, 0]
            x1 += origins[b, 1]
            x2 += origins[b, 2]
            p0 += w * x0
            p1 += w * x1
            p2 += w * x2
            wsum += w
            S[b, 0] += w * x0
            S[b, 1] += w * x1
            S[b, 2] += w * x2
            Wb[b] += w
        p[n, 0] = p0
        p[n, 1] = p1
        p[n, 2] = p2
        if not jacobian:
            continue
        for r in range(3):
            for c in range(3):
                J[n, r, c] = wsum if r == c else 0.0  # translation
        for c in range(3, 26):
            if c < 6:  # Euler angles: every bone, about the wrist
                w0, w1, w2 = euler_axes[c - 3, 0], euler_axes[c - 3, 1], euler_axes[c - 3, 2]
                a0, a1, a2 = t[0], t[1], t[2]
                q[0], q[1], q[2] = p0, p1, p2
                m = wsum
            else:
                if c < 11:
                    d, slot, first = c - 6, 0, 0
                else:
                    d = (c - 11) // 3
                    slot = 1 + (c - 11) % 3
                    first = slot - 1
                w0, w1, w2 = axes[d, slot, 0], axes[d, slot, 1], axes[d, slot, 2]
                a0, a1, a2 = anchors[d, slot, 0], anchors[d, slot, 1], anchors[d, slot, 2]
                q[0] = 0.0
                q[1] = 0.0
                q[2] = 0.0
                m = 0.0
                for level in range(first, 3):
                    b = 1 + 3 * d + level
                    q[0] += S[b, 0]
                    q[1] += S[b, 1]
                    q[2] += S[b, 2]
                    m += Wb[b]
            v0 = q[0] - m * a0
            v1 = q[1] - m * a1
            v2 = q[2] - m * a2
            J[n, 0, c] = deg * (w1 * v2 - w2 * v1)
            J[n, 1, c] = deg * (w2 * v0 - w0 * v2)
            J[n, 2, c] = deg * (w0 * v1 - w1 * v0)


# --- the mesh surface of a hand model -----------------------------------------------------


class MeshSurface:
    """The skinned mesh of a `HandModel`: its queries at a pose (module docstring).

    Built by ``HandModel.mesh`` (registration to the model's shape on first use); the
    bone frames come from the model, so the mesh's joints are G(x).

    Parameters
    ----------
    hand : HandModel
    data : MeshData, optional
    """

    def __init__(self, hand, data: MeshData | None = None) -> None:
        R, o = hand.bone_frames(np.zeros(N_PARAMS))
        self.hand = hand
        self.skinned = SkinnedMesh(hand.shape, R, o, data)
        self.triangles = self.skinned.triangles

    def points(self, x, samples: MeshSamples, jacobian: bool = False):
        """World positions of mesh samples at pose `x` and optionally d points / d x.

        Returns ``points (N, 3)`` mm and, with `jacobian`, ``J (N, 3, 26)`` (mm per mm,
        mm per degree), the exact derivative of the linear blend.
        """
        if not isinstance(samples, MeshSamples):
            raise TypeError(f"samples: expected MeshSamples; got {type(samples).__name__}")
        return skin(self.hand._pose(x), samples, jacobian)

    def vertices(self, x, jacobian: bool = False):
        """The V skinned vertices at pose `x`, (V, 3) mm world (and (V, 3, 26))."""
        return self.points(x, self.skinned.vertices, jacobian)

    def sample_surface(self, n: int, rng: np.random.Generator) -> MeshSamples:
        """n area-uniform random points of the mesh (areas at the rest pose)."""
        return self.skinned.sample(int(n), rng)

    def silhouette(self, x, camera, *, coverage: str = "touch") -> np.ndarray:
        """Silhouette mask (H, W) bool of the mesh at pose `x` in `camera`.

        Vertices are projected with the camera's full model (distortion included);
        triangles are scan-converted with straight edges
        (:func:`handvar.hand.raster.rasterize_triangles`, same coverage rules as the
        sphere-mesh's :func:`handvar.render.silhouette`). Triangles with a vertex
        behind the camera are not drawn.
        """
        from handvar.hand.raster import rasterize_triangles

        uv, _ = self._project(x, camera)
        return rasterize_triangles(uv, self.triangles, camera.size, coverage=coverage)

    def depth_buffer(self, x, camera):
        """Nearest triangle (H, W) int (−1: none) and its depth (H, W) mm at each pixel."""
        from handvar.hand.raster import rasterize_triangles

        uv, z = self._project(x, camera)
        _, tri, zbuf = rasterize_triangles(
            uv, self.triangles, camera.size, coverage="centre", depth=z
        )
        return tri, zbuf

    def visible(self, x, camera, samples: MeshSamples, *, tolerance: float = 1.0):
        """Whether each sample is seen by `camera`: (N,) bool.

        A sample is visible when it projects into the image, in front of the camera,
        and its depth is at most `tolerance` mm behind the depth buffer's at its pixel.
        """
        _, zbuf = self.depth_buffer(x, camera)
        p = self.points(x, samples)
        z = camera.camera_from_world(p)[:, 2]
        uv = camera.project(p)
        w, h = camera.size
        ij = np.floor(uv + 0.5)
        ok = (z > 0) & np.all(np.isfinite(ij), axis=1)
        ok &= (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
        out = np.zeros(len(p), dtype=bool)
        jj, ii = ij[ok, 0].astype(int), ij[ok, 1].astype(int)
        out[ok] = z[ok] <= zbuf[ii, jj] + tolerance
        return out

    def closest_projected_point(self, x, camera, pixels):
        """Closest point of the mesh's image to each pixel, and its Jacobian.

        The filling term's h_ij(x) (eq. 1) for the mesh. A pixel covered by the mesh
        (``coverage="touch"`` silhouette) is its own closest point (h = pixel, zero
        Jacobian). For any other pixel, h is the projection of the nearest projected
        vertex, and dh/dx that vertex's projection Jacobian times its skinning
        Jacobian: exact for the point chosen, which differs from the true closest point
        of the outline by at most half the projected vertex spacing (the choice and its
        reason: design §15).

        Returns
        -------
        h : (M, 2) ndarray
            Pixels.
        dh : (M, 2, 26) ndarray
        """
        from scipy.spatial import cKDTree

        s = np.asarray(pixels, dtype=float)
        if s.ndim != 2 or s.shape[1] != 2:
            raise ValueError(f"pixels: expected shape (M, 2); got shape {s.shape}")
        mask = self.silhouette(x, camera)
        p, Jp = self.vertices(x, jacobian=True)
        uv, Jc = camera.project_jacobian(p)
        w, h = camera.size
        ij = np.floor(s + 0.5).astype(int)
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
        covered = np.zeros(len(s), dtype=bool)
        covered[inside] = mask[ij[inside, 1], ij[inside, 0]]
        out = s.copy()
        dh = np.zeros((len(s), 2, N_PARAMS))
        todo = ~covered
        if np.any(todo):
            front = np.all(np.isfinite(uv), axis=1)
            index = np.flatnonzero(front)
            _, k = cKDTree(uv[index]).query(s[todo])
            v = index[k]
            out[todo] = uv[v]
            dh[todo] = np.einsum("nij,njk->nik", Jc[v], Jp[v])
        return out, dh

    def _project(self, x, camera):
        """Vertex pixels (V, 2) (NaN behind the camera) and depths (V,)."""
        p = self.vertices(x)
        z = camera.camera_from_world(p)[:, 2]
        uv = camera.project(p)
        uv[z <= 0] = np.nan
        return uv, z
