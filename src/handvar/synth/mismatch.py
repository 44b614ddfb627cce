"""Model mismatch (docs/results/mismatch.md): sequences the tracker's model does not explain.

The paper's sequences are rendered by the very model that tracks them, so their
silhouettes hold no model error. Four departures, each deterministic for a seed:

- the generator's **surface**: the skinned mesh (``HandModel(surface="mesh")``)
  renders the frames while the tracker fits its sphere-mesh, or the other way round
  (:func:`generator_hand`);
- the generator's **shape**: its hand length and breadth scaled by factors around
  1 (±10%) against the tracker's default 185 × 85 mm hand (:func:`generator_hand`);
- the **speed** of the motion: the same motion replayed `speed` times faster at the
  same frame rate (:func:`faster`);
- **silhouette noise** (:func:`corrupt_silhouettes`): the outline moved in and out
  by a smooth random field, holes punched into the hand and a ragged cut at the wrist
  that leaves a stub of forearm or bites into the palm -- the errors of a real
  segmentation (skin colour, a wrist cut, design §9).

Examples
--------
>>> import numpy as np
>>> poses = np.arange(10.0)[:, None] * np.ones((1, 26))
>>> faster(poses, 2.0)[:, 0].tolist()
[0.0, 2.0, 4.0, 6.0, 8.0]
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.validate import as_array, as_float, as_int, one_of

__all__ = [
    "HAND_LENGTH",
    "SURFACES",
    "corrupt_silhouettes",
    "faster",
    "generator_hand",
]

#: The tracker's default hand length (mm): wrist crease to the middle fingertip.
HAND_LENGTH = 185.0
SURFACES = ("spheres", "mesh")


def generator_hand(model: str = "spheres", length: float = 1.0, breadth: float = 1.0):
    """The hand that renders a sequence: a surface and a size relative to the default.

    Parameters
    ----------
    model : {"spheres", "mesh"}
        The sphere-mesh or the skinned mesh (design §15).
    length, breadth : float
        Factors on the default hand length (185 mm) and breadth (85 mm). With equal
        factors every joint moves away from the wrist by that factor (all bones and
        bases scale with the hand, :meth:`HandShape.from_size`).

    Returns
    -------
    handvar.hand.kinematics.HandModel
    """
    from handvar.hand.anthropometry import HandProportions, HandShape
    from handvar.hand.kinematics import HandModel

    one_of(model, SURFACES, "model")
    length = as_float(length, "length", minimum=0.5, maximum=2.0)
    breadth = as_float(breadth, "breadth", minimum=0.5, maximum=2.0)
    shape = None
    if (length, breadth) != (1.0, 1.0):
        default_breadth = HandProportions().breadth_ratio * HAND_LENGTH  # ≈ 85 mm
        shape = HandShape.from_size(HAND_LENGTH * length, default_breadth * breadth)
    return HandModel(shape, surface=model)


def faster(poses, speed: float) -> np.ndarray:
    """The same motion replayed `speed` times faster at the same frame rate.

    Frame f shows the pose at time ``speed · f`` frames of the original, linearly
    interpolated between its frames, as long as that time lies in the original; the
    result has ``floor((T - 1) / speed) + 1`` frames.

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees.
    speed : float
        ≥ 1; 1 returns a copy.

    Returns
    -------
    (T', 26) ndarray
    """
    arr = as_array(poses, "poses", (None, None))
    speed = as_float(speed, "speed", minimum=1.0)
    n = arr.shape[0]
    times = speed * np.arange(int(np.floor((n - 1) / speed + 1e-9)) + 1)
    lo = np.minimum(np.floor(times).astype(int), n - 1)
    hi = np.minimum(lo + 1, n - 1)
    w = (times - lo)[:, None]
    return (1.0 - w) * arr[lo] + w * arr[hi]


def _smooth_field(rng, shape, sigma: float) -> np.ndarray:
    """A smooth random field of unit standard deviation (Gaussian-filtered noise)."""
    field = ndimage.gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap")
    return field / max(float(field.std()), 1e-12)


def _disk(radius: float) -> np.ndarray:
    r = int(np.ceil(radius))
    y, x = np.mgrid[-r : r + 1, -r : r + 1]
    return x * x + y * y <= radius * radius


def _corrupt_one(mask, wrist, base, px: float, rng) -> np.ndarray:
    """One silhouette corrupted at strength `px` (see :func:`corrupt_silhouettes`)."""
    h, w = mask.shape
    if not mask.any():
        return mask.copy()
    # 1. the outline moved in and out: signed distance + smooth field of amplitude px
    inside = ndimage.distance_transform_edt(mask)
    outside = ndimage.distance_transform_edt(~mask)
    signed = np.where(mask, inside - 0.5, 0.5 - outside)
    out = signed + px * _smooth_field(rng, (h, w), sigma=4.0 * px) > 0.0

    # 2. a ragged wrist cut along the line across the wrist, shifted by
    #    s ~ U(-px, 3 px) (negative: bites into the palm; positive: a forearm stub)
    axis = wrist - base
    norm = float(np.hypot(*axis))
    if norm > 1e-9:
        a = axis / norm  # towards the forearm
        n = np.array([-a[1], a[0]])
        yy, xx = np.mgrid[0:h, 0:w]
        du, dv = xx - wrist[0], yy - wrist[1]
        along, across = du * a[0] + dv * a[1], du * n[0] + dv * n[1]
        ragged = (
            rng.uniform(-px, 3.0 * px)
            + 0.5
            * px
            * _smooth_field(rng, (int(2 * norm) + 8,), sigma=px)[
                np.clip((across + norm + 4).astype(int), 0, int(2 * norm) + 7)
            ]
        )
        half_width = 0.35 * norm  # the forearm's half width, about the wrist's
        stub = (along >= 0) & (along <= ragged) & (np.abs(across) <= half_width)
        out = (out | stub) & ~((along > ragged) & (np.abs(across) <= 2.0 * half_width))

    # 3. holes: Poisson(2) discs of radius U(px / 2, 1.5 px) at random hand pixels
    ys, xs = np.nonzero(out)
    for _ in range(int(rng.poisson(2.0))):
        if not ys.size:
            break
        k = int(rng.integers(ys.size))
        disk = _disk(rng.uniform(0.5 * px, 1.5 * px))
        r = disk.shape[0] // 2
        y0, x0 = ys[k] - r, xs[k] - r
        sy = slice(max(y0, 0), min(y0 + disk.shape[0], h))
        sx = slice(max(x0, 0), min(x0 + disk.shape[1], w))
        out[sy, sx] &= ~disk[sy.start - y0 : sy.stop - y0, sx.start - x0 : sx.stop - x0]
    return out


def corrupt_silhouettes(masks, joints, rig, px: float, *, seed: int = 0) -> np.ndarray:
    """Silhouettes with the errors of a real segmentation, of strength `px` pixels.

    In each frame and camera, with the generator ``default_rng([seed, 4, frame,
    camera])``:

    1. the outline moves in and out by a smooth random field (Gaussian-filtered noise,
       σ = 4 `px` pixels, scaled to a standard deviation of `px` pixels) added to the
       mask's signed distance -- local erosion and dilation of about `px` pixels;
    2. a ragged wrist cut: across the wrist (perpendicular to the image of the line
       from the middle finger's base to the wrist) at a shift drawn from U(−`px`,
       3 `px`) pixels with a ragged edge of ±`px`/2 pixels; a positive shift adds a
       stub of forearm, a negative one cuts into the palm;
    3. holes: a Poisson(2) number of discs of radius U(`px`/2, 1.5 `px`) pixels at
       random hand pixels.

    Parameters
    ----------
    masks : (T, C, H, W) bool array_like
        Exact silhouettes.
    joints : (T, 21, 3) array_like
        The true joints (mm) that place the wrist cut.
    rig : handvar.camera.Rig
        The C cameras of the masks.
    px : float
        Strength in pixels; 0 returns a copy.
    seed : int, keyword-only

    Returns
    -------
    (T, C, H, W) bool ndarray
    """
    m = np.asarray(masks, dtype=bool)
    if m.ndim != 4:
        raise ValueError(f"masks: expected a (T, C, H, W) array; got shape {m.shape}")
    g = as_array(joints, "joints", (m.shape[0], 21, 3))
    px = as_float(px, "px", minimum=0.0, maximum=50.0)
    seed = as_int(seed, "seed", minimum=0)
    out = m.copy()
    if px == 0.0:
        return out
    for f in range(m.shape[0]):
        for c, camera in enumerate(rig.cameras):
            wrist, base = camera.project(g[f, [WRIST, MIDDLE_MCP]])
            rng = np.random.default_rng([seed, 4, f, c])
            out[f, c] = _corrupt_one(m[f, c], wrist, base, px, rng)
    return out
