"""What the renderers of both hand surfaces share: the rig's image size, the synthetic
backgrounds and the Lambert shading of every camera's view.

The sphere-mesh renderers (:mod:`handvar.render.silhouettes`, :mod:`handvar.render.shading`)
and the skinned-mesh ones (:mod:`handvar.render.mesh`) differ only in how they find the
hand's pixels and surface normals in a camera; the rest is here, so that neither imports
the other's module for it.

Colour images are RGB, ``uint8``, shape ``(H, W, 3)``; convert with
``cv2.cvtColor(image, cv2.COLOR_RGB2BGR)`` before ``cv2.imwrite``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from handvar.camera import Rig
from handvar.validate import as_instance, one_of

__all__ = ["BACKGROUNDS", "Shading", "background_image", "check_rig", "shade_views"]


def check_rig(rig: Rig) -> tuple[int, int]:
    """The image size (W, H) that every camera of `rig` shares, or a ValueError."""
    as_instance(rig, Rig, "rig", what="a handvar.camera.Rig")
    sizes = {cam.size for cam in rig}
    if len(sizes) != 1:
        raise ValueError(
            f"rig: expected cameras of one image size to stack; got sizes {sorted(sizes)}"
        )
    return sizes.pop()


@dataclass(frozen=True)
class Shading:
    """Lambert shading of the hand and the synthetic camera noise.

    The paper's set-up (paper §2, figure 1) lights the hand strongly from above and behind
    one of the cameras; ``light`` is the world direction towards that light (world −y
    is up, the cameras are on the −z side).
    """

    skin_rgb: tuple[int, int, int] = (222, 170, 140)
    ambient: float = 0.45
    diffuse: float = 0.6
    light: tuple[float, float, float] = (-0.35, -0.6, -1.0)
    noise_sigma: float = 3.0  # grey levels, added to the whole image


BACKGROUNDS = ("clutter", "texture", "plain")


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
    one_of(kind, BACKGROUNDS, "kind")
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
