"""Colour rendering of the hand model: Lambert shading over synthetic backgrounds.

Colour images are RGB, ``uint8``, shape ``(H, W, 3)``; convert with
``cv2.cvtColor(image, cv2.COLOR_RGB2BGR)`` before ``cv2.imwrite``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from handvar.camera import Rig
from handvar.geometry.cone_spheres import cone_sphere_normals, intersect_cone_spheres
from handvar.params import check_pose
from handvar.render.silhouettes import SphereMeshModel, _check_rig, silhouette_of_spheres
from handvar.validate import one_of

__all__ = ["Shading", "background_image", "render_rgb"]


@dataclass(frozen=True)
class Shading:
    """Lambert shading of the hand and the synthetic camera noise.

    The paper's set-up (§2, figure 1) lights the hand strongly from above and behind
    one of the cameras; ``light`` is the world direction towards that light (world −y
    is up, the cameras are on the −z side).
    """

    skin_rgb: tuple[int, int, int] = (222, 170, 140)
    ambient: float = 0.45
    diffuse: float = 0.6
    light: tuple[float, float, float] = (-0.35, -0.6, -1.0)
    noise_sigma: float = 3.0  # grey levels, added to the whole image


_BACKGROUNDS = ("clutter", "texture", "plain")


def _non_skin_colours(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) uint8 RGB colours well away from skin tones.

    Hues are drawn from green through blue to purple (60°–300° in HSV, i.e. no reds,
    oranges or yellows), or the colour is a near-grey; either fails both the RGB skin
    rule of Kovač et al. (2003) and the YCrCb box of Chai & Ngan (1999).
    """
    hsv = np.empty((n, 1, 3), dtype=np.uint8)
    hsv[:, 0, 0] = rng.integers(45, 150, n)  # OpenCV hue = degrees / 2
    grey = rng.random(n) < 0.25
    hsv[:, 0, 1] = np.where(grey, rng.integers(0, 20, n), rng.integers(80, 256, n))
    hsv[:, 0, 2] = rng.integers(30, 256, n)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[:, 0]


def background_image(
    size: tuple[int, int], kind: str = "clutter", rng: np.random.Generator | None = None
) -> np.ndarray:
    """A synthetic background image without skin-coloured pixels.

    Parameters
    ----------
    size : (int, int)
        Image (width, height).
    kind : {"clutter", "texture", "plain"}
        ``clutter``: random filled rectangles, ellipses, polygons and thick lines in
        non-skin colours; ``texture``: smooth multi-scale noise blending non-skin
        colours; ``plain``: one non-skin colour.
    rng : numpy.random.Generator, optional
        Source of randomness (``default_rng(0)`` when omitted).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        RGB image.
    """
    one_of(kind, _BACKGROUNDS, "kind")
    rng = np.random.default_rng(0) if rng is None else rng
    w, h = int(size[0]), int(size[1])
    if kind == "plain":
        img = np.empty((h, w, 3), dtype=np.uint8)
        img[:] = _non_skin_colours(1, rng)[0]
        return img
    if kind == "texture":
        cols = _non_skin_colours(3, rng).astype(float)
        field = np.zeros((h, w, 2))
        for scale in (4, 8, 16, 32):
            small = rng.random((scale * h // w + 2, scale + 2, 2)).astype(np.float32)
            field += cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC) / scale
        field -= field.min(axis=(0, 1))
        field /= np.maximum(field.max(axis=(0, 1)), 1e-9)
        wts = np.concatenate([field, 1.0 - field.mean(axis=2, keepdims=True)], axis=2)
        wts /= wts.sum(axis=2, keepdims=True)
        # blends of green–blue–purple hues and greys stay away from skin tones
        img = wts @ cols
        return np.clip(img, 0, 255).astype(np.uint8)
    img = np.empty((h, w, 3), dtype=np.uint8)
    img[:] = _non_skin_colours(1, rng)[0]
    n_shapes = 60
    cols = _non_skin_colours(n_shapes, rng)
    for k in range(n_shapes):
        col = tuple(int(c) for c in cols[k])
        kind_k = rng.integers(4)
        cx, cy = int(rng.integers(-w // 8, w + w // 8)), int(rng.integers(-h // 8, h + h // 8))
        sx, sy = int(rng.integers(10, w // 4)), int(rng.integers(10, h // 4))
        if kind_k == 0:
            cv2.rectangle(img, (cx - sx, cy - sy), (cx + sx, cy + sy), col, -1)
        elif kind_k == 1:
            angle = float(rng.uniform(0, 180))
            cv2.ellipse(img, (cx, cy), (sx, sy), angle, 0, 360, col, -1, cv2.LINE_AA)
        elif kind_k == 2:
            pts = np.stack([cx + rng.integers(-sx, sx, 5), cy + rng.integers(-sy, sy, 5)], -1)
            cv2.fillPoly(img, [pts.astype(np.int32)], col, cv2.LINE_AA)
        else:
            thick = int(rng.integers(2, 12))
            cv2.line(img, (cx - sx, cy - sy), (cx + sx, cy + sy), col, thick, cv2.LINE_AA)
    return img


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
    with a skin colour; the background (:func:`background_image`, one per camera)
    and Gaussian sensor noise make the image a test for the real-video path (skin
    detection, clean-up).

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
    if getattr(hand, "surface", "spheres") == "mesh":  # the skinned mesh (§15)
        from handvar.render.mesh import render_mesh_rgb

        return render_mesh_rgb(hand, x, rig, background=background, rng=rng, shading=shading)
    x = check_pose(x, "x")
    one_of(background, _BACKGROUNDS, "background")
    w, h = _check_rig(rig)
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


def shade_views(rig, size, background, rng, shading: Shading, surface_normals) -> np.ndarray:
    """Lambert-shaded hand over a synthetic background in every camera of `rig`.

    The loop both surfaces share: ``surface_normals(camera)`` returns the hand's pixels
    ``(rows, cols)`` in that camera and the unit surface normal seen at each, (n, 3);
    every pixel gets ``skin · (ambient + diffuse · max(0, n·l))``, then the image gets
    the sensor noise of `shading`.

    Returns
    -------
    (n_cams, H, W, 3) uint8 ndarray
        RGB images.
    """
    w, h = size
    light = np.asarray(shading.light, dtype=float)
    light /= np.linalg.norm(light)
    skin = np.asarray(shading.skin_rgb, dtype=float)
    out = np.empty((len(rig), h, w, 3), dtype=np.uint8)
    for k, cam in enumerate(rig):
        img = background_image((w, h), background, rng).astype(np.float32)
        rows, cols, normals = surface_normals(cam)
        if rows.size:
            lambert = np.maximum(normals @ light, 0.0)  # Lambert: max(0, n·l)
            img[rows, cols] = skin * (shading.ambient + shading.diffuse * lambert)[:, None]
        img += np.float32(shading.noise_sigma) * rng.standard_normal(img.shape, dtype=np.float32)
        np.clip(np.rint(img, out=img), 0, 255, out=img)
        out[k] = img
    return out
