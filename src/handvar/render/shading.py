"""Colour rendering of the sphere-mesh hand: Lambert shading over synthetic backgrounds.

The backgrounds, the shading and the loop over the cameras are shared with the skinned
mesh (:mod:`handvar.render.common`); this module finds the sphere-mesh's pixels and
normals. Colour images are RGB, ``uint8``, shape ``(H, W, 3)``; convert with
``cv2.cvtColor(image, cv2.COLOR_RGB2BGR)`` before ``cv2.imwrite``.
"""

from __future__ import annotations

import numpy as np

from handvar.camera import Rig
from handvar.geometry.cone_spheres import cone_sphere_normals, intersect_cone_spheres
from handvar.params import check_pose
from handvar.render.common import BACKGROUNDS, Shading, check_rig, shade_views
from handvar.render.silhouettes import SphereMeshModel, silhouette_of_spheres
from handvar.validate import one_of

__all__ = ["render_rgb"]


def render_rgb(
    hand: SphereMeshModel,
    x,
    rig: Rig,
    *,
    background: str = "clutter",
    rng: np.random.Generator | None = None,
    shading: Shading | None = None,
) -> np.ndarray:
    """Shaded colour rendering of the hand over a synthetic background.

    Every pixel whose centre sees the model (``coverage="centre"``) is ray-cast
    against the cone-spheres (:func:`handvar.geometry.cone_spheres.intersect_cone_spheres`),
    given the outward normal of the primitive hit
    (:func:`handvar.geometry.cone_spheres.cone_sphere_normals`) and shaded by Lambert's law
    with a skin colour; the background
    (:func:`~handvar.render.common.background_image`, one per camera) and Gaussian
    sensor noise make the image a test for the real-video path (skin detection,
    clean-up).

    Parameters
    ----------
    hand : HandModel
        Anything with ``world_spheres(x)``.
    x : (26,) array_like
        Pose.
    rig : Rig
        Cameras, all of one image size.
    background : {"clutter", "texture", "plain"}, optional
    rng : numpy.random.Generator, optional
        Background and noise (``default_rng(0)`` when omitted).
    shading : Shading, optional

    Returns
    -------
    (n_cams, H, W, 3) uint8 ndarray
        RGB images.
    """
    if getattr(hand, "surface", "spheres") == "mesh":  # the skinned mesh (design §15)
        from handvar.render.mesh import render_mesh_rgb

        return render_mesh_rgb(hand, x, rig, background=background, rng=rng, shading=shading)
    x = check_pose(x, "x")
    one_of(background, BACKGROUNDS, "background")
    w, h = check_rig(rig)
    rng = np.random.default_rng(0) if rng is None else rng
    sh = Shading() if shading is None else shading
    centres, radii = hand.world_spheres(x)

    def surface_normals(cam):
        mask = silhouette_of_spheres(centres, radii, cam, coverage="centre")  # point sampling
        rows, cols = np.nonzero(mask)
        if not rows.size:
            return rows, cols, np.empty((0, 3))
        origins, dirs = cam.rays(np.stack([cols, rows], -1).astype(float))
        depth, prim = intersect_cone_spheres(centres, radii, origins, dirs, return_primitive=True)
        hit = prim >= 0
        # pixel centres on the outline that graze the surface: face the camera
        normals = -dirs
        points = origins[hit] + depth[hit, None] * dirs[hit]
        normals[hit] = cone_sphere_normals(centres, radii, points, prim[hit])
        return rows, cols, normals

    return shade_views(rig, (w, h), background, rng, sh, surface_normals)
