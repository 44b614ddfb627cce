"""The tracker's cost on the skinned mesh hand (design §4 and §15).

The same cost as :class:`handvar.tracking.costs.SilhouetteCost`, C = w_s C_s + w_f C_f
in (pixel_scale px)², with the same samples per iteration, the same per-frame data
(`prepare_frame`), the same stacked residuals and the same diagonals for the optimiser;
only the model's surface is the mesh:

- C_s: N area-uniform samples of the mesh (drawn from a pool made once), skinned with
  their exact Jacobians (`MeshSurface.points`), projected into every camera and matched
  with their nearest silhouette pixel;
- C_f: M silhouette pixels per camera against the closest point of the mesh's image,
  `MeshSurface.closest_projected_point` (the mesh's own ``touch`` silhouette decides
  coverage; outside it, the nearest projected vertex with its Jacobian).

Vectorised numpy over the samples (the compiled kernel of `costs` works on
bone-attached points and cone-spheres); about twenty times slower per iteration than the
sphere-mesh's (``python benchmarks/mesh.py``), dominated by the two silhouettes of C_f.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handvar.camera import Rig
from handvar.params import N_PARAMS, check_pose
from handvar.tracking.costs import CostSettings, CostTerms, FrameData, prepare_frame
from handvar.tracking.keypoint_cost import hand_length, keypoint_points

__all__ = ["MeshSamplesDrawn", "MeshSilhouetteCost"]


@dataclass(frozen=True, eq=False)
class MeshSamplesDrawn:
    """The random samples of one iteration: mesh points and silhouette pixels.

    Attributes
    ----------
    surface : handvar.hand.mesh.MeshSamples
        N points of the mesh.
    pixels : (n_cams, M, 2) ndarray
        Silhouette pixel samples per camera.
    """

    surface: object
    pixels: np.ndarray


class MeshSilhouetteCost:
    """C = w_s C_s + w_f C_f of a ``HandModel(surface="mesh")`` seen by a rig.

    Parameters
    ----------
    hand : HandModel
        With ``surface="mesh"``.
    rig : Rig
    settings : CostSettings, optional
    pool_size : int, optional
        Mesh samples drawn once, from which every iteration draws N.
    rng : numpy.random.Generator, optional
        Source of the pool (``default_rng(0)`` by default).
    """

    def __init__(
        self,
        hand,
        rig: Rig,
        settings: CostSettings | None = None,
        *,
        pool_size: int = 20_000,
        rng: np.random.Generator | None = None,
    ) -> None:
        if not isinstance(rig, Rig):
            raise ValueError(f"rig: expected a handvar.camera.Rig; got {type(rig).__name__}")
        if getattr(hand, "surface", None) != "mesh":
            raise ValueError("hand: expected a HandModel(surface='mesh')")
        settings = CostSettings() if settings is None else settings
        if not isinstance(settings, CostSettings):
            raise ValueError(f"settings: expected CostSettings; got {type(settings).__name__}")
        self.hand = hand
        self.rig = rig
        self.settings = settings
        rng = np.random.default_rng(0) if rng is None else rng
        self.pool = hand.mesh.sample_surface(int(pool_size), rng)
        self._cams = rig.packed()
        self.length = hand_length(hand)

    def prepare(self, masks) -> FrameData:
        """`prepare_frame` for this rig, with the settings' margin."""
        return prepare_frame(masks, self.rig, margin=self.settings.roi_margin)

    def draw(self, frame: FrameData, rng: np.random.Generator) -> MeshSamplesDrawn:
        """N mesh points (uniform from the pool) and M silhouette pixels per camera."""
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng: expected a numpy.random.Generator; got {type(rng).__name__}")
        s = self.settings
        idx = rng.integers(0, len(self.pool), s.n_surface)
        n = frame.n_cameras
        pixels = np.zeros((n, s.n_pixels, 2))
        for j in range(n):
            if frame.counts[j] > 0:
                pixels[j] = frame.pixels[j, rng.integers(0, frame.counts[j], s.n_pixels)]
        return MeshSamplesDrawn(self.pool.take(idx), pixels)

    def evaluate(
        self,
        x,
        frame: FrameData,
        samples: MeshSamplesDrawn,
        *,
        residuals: bool = False,
        keypoints=None,
    ) -> CostTerms:
        """Cost, its parts, gradient and diagonals at pose `x` (as `SilhouetteCost`).

        With the keypoint term C_k when `keypoints` (n_cams, 21, 3) are given and the
        front term C_z always (`handvar.tracking.keypoint_cost`).
        """
        x = check_pose(x, "x")
        if frame.n_cameras != len(self.rig):
            raise ValueError(
                f"frame: expected data of {len(self.rig)} cameras; got {frame.n_cameras}"
            )
        s = self.settings
        mesh = self.hand.mesh
        active = frame.counts > 0
        n_active = int(active.sum())
        N, M = len(samples.surface), samples.pixels.shape[1]
        scale2 = s.pixel_scale * s.pixel_scale
        a_s = np.sqrt(s.weight_silhouette / (N * n_active * scale2))
        a_f = np.sqrt(s.weight_filling / (M * n_active * scale2))
        n_cams = frame.n_cameras
        r = np.zeros(2 * (N + M) * n_cams)
        J = np.zeros((r.size, N_PARAMS))
        sens = np.zeros(N_PARAMS)
        parts = np.zeros(2)
        p, Jp = mesh.points(x, samples.surface, jacobian=True)
        nearest = frame.nearest
        for j, cam in enumerate(self.rig):
            if not active[j]:
                continue
            base = 2 * (N + M) * j
            z = cam.camera_from_world(p)[:, 2]
            uv, Jc = cam.project_jacobian(p)
            J2 = np.einsum("nij,njk->nik", Jc, Jp)  # (N, 2, 26)
            front = (z > 0) & np.all(np.isfinite(uv), axis=1)
            sens += a_s * a_s * np.einsum("nik,nik->k", J2[front], J2[front])
            u0, v0, w, h = frame.roi[j]
            iuv = np.floor(uv + 0.5)
            cu = np.clip(np.nan_to_num(iuv[:, 0]) - u0, 0, w - 1).astype(int)
            cv = np.clip(np.nan_to_num(iuv[:, 1]) - v0, 0, h - 1).astype(int)
            target = nearest[j, cv, cu]
            outside = front & ~np.all(target == iuv, axis=1)
            res = np.where(outside[:, None], uv - target, 0.0)  # p − s*(p)
            parts[0] += np.sum(res * res)
            r[base : base + 2 * N] = (a_s * res).ravel()
            J[base : base + 2 * N] = (a_s * np.where(outside[:, None, None], J2, 0.0)).reshape(
                2 * N, N_PARAMS
            )
            s_hat = samples.pixels[j]
            hh, dh = mesh.closest_projected_point(x, cam, s_hat)
            res_f = hh - s_hat
            parts[1] += np.sum(res_f * res_f)
            r[base + 2 * N : base + 2 * (N + M)] = (a_f * res_f).ravel()
            J[base + 2 * N : base + 2 * (N + M)] = (a_f * dh).reshape(2 * M, N_PARAMS)
        P, JP = keypoint_points(self.hand, x, s.keypoint_tips, jacobian=True)
        c_k, c_z, _, _, r_j, J_j = s.joint_terms(
            P, JP, self._cams, keypoints, length=self.length, residuals=True
        )
        r = np.concatenate([r, r_j])
        J = np.concatenate([J, J_j])
        g = J.T @ r
        gn = np.einsum("rk,rk->k", J, J)
        c_s = 0.5 * parts[0] / (N * n_active * scale2)
        c_f = 0.5 * parts[1] / (M * n_active * scale2)
        cost = s.total(c_s, c_f, c_k, c_z)
        return CostTerms(
            float(cost), float(c_s), float(c_f), g, sens, gn, r if residuals else None,
            J if residuals else None, c_k, c_z,
        )  # fmt: skip
