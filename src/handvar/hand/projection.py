"""The hand's image in a camera: projected primitives and the closest point (eq. 1).

Each cone-sphere of the model is seen as the 2D hull of the circles that approximate
its end spheres' images (:mod:`handvar.geometry.projected`); the model's image is the
union of these hulls. :func:`closest_point_projected` gives the closest point h(x) of
that image to a pixel, the h_ij(x) of the filling cost (paper eq. 1), with dh/dx by the
chain rule through the camera's projection and the kinematics.
"""

from __future__ import annotations

import numpy as np

from handvar.camera import Camera
from handvar.geometry.projected import (
    ProjectedPrimitives,
    closest_point_cone_spheres_2d,
    outline_circles,
)
from handvar.params import N_PARAMS
from handvar.validate import as_instance

__all__ = ["closest_point_projected", "project_cone_spheres"]


def project_cone_spheres(centres, radii, camera: Camera, jacobian=None):
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
    jacobian : (P, 2, 3, 26) array_like, optional
        ``d centres / d x``; when given the derivatives of the projection are returned.

    Returns
    -------
    projected : ProjectedPrimitives
    dtheta : (P, 6, 26) ndarray or None
        With `jacobian`: derivatives of ``(c1u, c1v, c2u, c2v, ρ1, ρ2)`` w.r.t. x.
    """
    as_instance(camera, Camera, "camera", what="a handvar.camera.Camera")
    centres = np.asarray(centres, dtype=float)
    radii = np.asarray(radii, dtype=float)
    p = centres.shape[0]
    X = centres.reshape(-1, 3)
    uv, Jp = camera.project_jacobian(X, jacobian=jacobian is not None)
    z = camera.camera_from_world(X)[:, 2]
    r = radii.reshape(-1)
    rho, drho_dz = outline_circles(z, r, 0.5 * (camera.fx + camera.fy))
    visible = np.all((z > r).reshape(p, 2), axis=1)
    projected = ProjectedPrimitives(
        uv.reshape(p, 2, 2), rho.reshape(p, 2), z.reshape(p, 2), visible
    )
    if jacobian is None:
        return projected, None
    J = np.asarray(jacobian, dtype=float).reshape(-1, 3, N_PARAMS)
    duv = Jp @ J  # (2P, 2, 26)
    dz = np.einsum("j,njk->nk", camera.R[2], J)  # (2P, 26)
    with np.errstate(invalid="ignore"):
        drho = drho_dz[:, None] * dz
    dtheta = np.concatenate(
        [duv.reshape(p, 4, N_PARAMS), drho.reshape(p, 2, N_PARAMS)], axis=1
    )  # (P, 6, 26): c1u, c1v, c2u, c2v, ρ1, ρ2
    return projected, dtheta


def closest_point_projected(centres, radii, jacobian, camera: Camera, pixels):
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
