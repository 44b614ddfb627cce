"""Hand silhouettes from skin masks: clean-up, wrist cut, distance fields, cameras.

The paper's real-video tracker (section 6) fits the model to the hand silhouette in
each camera.  A raw skin mask (`handvar.vision.skin`) has speckle from skin-coloured
background, small holes where the palm is shaded, and usually the forearm.  This module
turns it into one clean silhouette per camera:

1. `clean_mask`: morphological opening (removes speckle) and closing (bridges thin
   gaps), the largest connected component(s), small components dropped, holes filled.
2. `cut_wrist` (optional): removes a visible forearm so that it does not pull the hand
   model out of the image (at the detected wrist with keypoints, else where the
   forearm's width changes; see `find_wrist` and `handvar.vision.wrist`).
3. `silhouettes_from_frames`: both steps for the frames of any number of cameras;
   an empty silhouette raises `EmptySilhouetteError` naming the camera and frame, and
   so does one that touches all four borders of the image (`NotAHandError`): skin
   colour everywhere (a wall, a close-up of skin) is not a hand in view.

`nearest_silhouette_pixel` gives, for every pixel, the nearest silhouette pixel — the
``s*`` of the silhouette cost ``C_s`` (§4).

Masks are ``(H, W)`` arrays; anything non-zero is inside.  Pixel coordinates are
``(x, y)`` = (column, row), in pixels.

One concept, a silhouette from a skin mask, which is why the module is a little
over 600 lines.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
from scipy import ndimage

from handvar.validate import as_int, one_of
from handvar.vision.skin import SkinModel, _TableClassifier

__all__ = [
    "CLEANUP_SETTINGS",
    "WRIST_SETTINGS",
    "CleanupSettings",
    "EmptySilhouetteError",
    "NotAHandError",
    "WristCut",
    "WristSettings",
    "clean_mask",
    "cut_wrist",
    "find_wrist",
    "nearest_silhouette_pixel",
    "silhouettes_from_frames",
    "silhouettes_from_videos",
    "touches_every_border",
]


@dataclass(frozen=True)
class CleanupSettings:
    """Named settings of `clean_mask` (paper section 6: skin mask to hand silhouette).

    The paper gives no clean-up parameters; these were chosen on the real example
    video (1280×720, hand about 250 px across) and scale with image size only mildly.

    Attributes
    ----------
    open_radius : int
        Radius (pixels) of the elliptical opening that removes skin-coloured speckle.
    close_radius : int
        Radius (pixels) of the elliptical closing that bridges thin gaps (shading lines
        across the palm, compression artefacts at the finger edges).
    keep : "largest" or int
        Number of connected components kept, largest first.
    fill_holes : bool
        Fill background regions enclosed by the silhouette.
    min_area : int
        Components smaller than this (pixels) are dropped even if they would be kept.
    max_hole_area : int or None
        Holes larger than this (pixels) stay open (e.g. the ring of a pinch gesture);
        None fills every hole.
    """

    open_radius: int = 2
    close_radius: int = 4
    keep: Literal["largest"] | int = "largest"
    fill_holes: bool = True
    min_area: int = 200
    max_hole_area: int | None = None


CLEANUP_SETTINGS = CleanupSettings()


@dataclass(frozen=True)
class WristSettings:
    """Named settings of the wrist heuristic (`find_wrist`, `cut_wrist`).

    Lengths are in units of the palm radius ``R`` (the largest inscribed circle of the
    silhouette, i.e. the maximum of its distance transform).

    Attributes
    ----------
    forearm_thickness : float
        A pixel belongs to a forearm candidate if its distance to the background is at
        least this × R (fingers are about 0.2 R thick in this sense, a forearm seen from
        the front 0.5–0.6 R on the example video).
    forearm_start : float
        Forearm candidates must lie at least this × R from the palm centre.
    min_forearm_area : float
        Fewest candidate pixels, in units of R², to decide that a forearm is visible.
    search : tuple of float
        Interval ``(a, b)`` × R along the forearm axis, from the palm centre, in which
        the narrowest cross-section is taken as the wrist.
    tolerance : float
        Relative width tolerance: the wrist is the cross-section nearest the palm whose
        width is within ``(1 + tolerance)`` × the narrowest one (the forearm just above
        the wrist is nearly as narrow; this keeps the cut at the palm's end of it).
    """

    forearm_thickness: float = 0.4
    forearm_start: float = 1.5
    min_forearm_area: float = 0.5
    search: tuple[float, float] = (0.9, 2.6)
    tolerance: float = 0.05


WRIST_SETTINGS = WristSettings()


class EmptySilhouetteError(ValueError):
    """A camera's silhouette is empty after skin detection and clean-up.

    Attributes
    ----------
    camera : int or str
        Camera index or name.
    frame : int or None
        Frame index, if known.
    """

    def __init__(self, message: str, *, camera: int | str, frame: int | None) -> None:
        super().__init__(message)
        self.camera = camera
        self.frame = frame


class NotAHandError(EmptySilhouetteError):
    """A camera's silhouette touches all four borders of its image: not a hand in view.

    A hand seen whole, or entering the image with its forearm, leaves at least one
    border free; a silhouette reaching every border is skin colour filling the view.
    Readers that accept empty silhouettes (``allow_empty``) take it as an empty one.
    """


def touches_every_border(mask: np.ndarray) -> bool:
    """True if the (H, W) `mask` has a pixel in its first and last row and column.

    Examples
    --------
    >>> touches_every_border(np.ones((4, 5), bool))
    True
    >>> m = np.zeros((4, 5), bool); m[1:, :] = True
    >>> touches_every_border(m)
    False
    """
    m = np.asarray(mask) != 0
    return bool(m[0].any() and m[-1].any() and m[:, 0].any() and m[:, -1].any())


# --- checks ----------------------------------------------------------------------------


def _as_mask(mask: np.ndarray, name: str = "mask") -> np.ndarray:
    """Check a 2-D mask and return it as uint8 0/1 (C-contiguous)."""
    arr = np.asarray(mask)
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D (H, W) mask, got shape {arr.shape}")
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{name}: expected a boolean or numeric mask, got dtype {arr.dtype}")
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values, got NaN or inf")
    return np.ascontiguousarray(arr != 0, dtype=np.uint8)


def _disk(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


# --- clean-up --------------------------------------------------------------------------


def clean_mask(
    mask: np.ndarray,
    *,
    open_radius: int = CLEANUP_SETTINGS.open_radius,
    close_radius: int = CLEANUP_SETTINGS.close_radius,
    keep: Literal["largest"] | int = CLEANUP_SETTINGS.keep,
    fill_holes: bool = CLEANUP_SETTINGS.fill_holes,
    min_area: int = CLEANUP_SETTINGS.min_area,
    max_hole_area: int | None = CLEANUP_SETTINGS.max_hole_area,
) -> np.ndarray:
    """Clean a raw skin mask into a silhouette.

    Steps, in order: opening with a disk of radius ``open_radius``, closing with a disk
    of radius ``close_radius``, connected components (8-connected,
    ``cv2.connectedComponentsWithStats``) of at least ``min_area`` pixels, the ``keep``
    largest of them, then (if ``fill_holes``) every enclosed background region (holes,
    4-connected) of at most ``max_hole_area`` pixels is filled.

    Parameters
    ----------
    mask : (H, W) array_like
        Raw mask; non-zero is inside.
    open_radius, close_radius : int
        Radii in pixels; 0 skips the operation.
    keep : "largest" or int
        How many components to keep, largest first (``"largest"`` is 1).
    fill_holes : bool
        Fill holes inside the kept components.
    min_area : int
        Smallest component kept, in pixels.
    max_hole_area : int, optional
        Largest hole filled, in pixels; None fills all.

    Returns
    -------
    (H, W) bool ndarray
        The cleaned silhouette; all False when nothing survives (no error here: see
        `silhouettes_from_frames` for the check).

    Examples
    --------
    >>> import numpy as np
    >>> m = np.zeros((40, 40), bool)
    >>> m[5:30, 5:30] = True      # the hand
    >>> m[15, 15] = False         # a hole
    >>> m[35, 35] = True          # speckle
    >>> out = clean_mask(m, open_radius=0, min_area=10)
    >>> int(out.sum()), bool(out[15, 15]), bool(out[35, 35])
    (625, True, False)
    """
    m = _as_mask(mask)
    open_radius = as_int(open_radius, "open_radius", minimum=0)
    close_radius = as_int(close_radius, "close_radius", minimum=0)
    min_area = as_int(min_area, "min_area", minimum=0)
    if isinstance(keep, str):
        one_of(keep, ("largest",), "keep")
        n_keep = 1
    else:
        n_keep = as_int(keep, "keep", minimum=1)
    if max_hole_area is not None:
        max_hole_area = as_int(max_hole_area, "max_hole_area", minimum=0)

    if open_radius:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, _disk(open_radius))
    if close_radius:
        # Pad so that closing does not glue the silhouette to the image border.
        p = close_radius
        padded = cv2.copyMakeBorder(m, p, p, p, p, cv2.BORDER_CONSTANT, value=0)
        m = cv2.morphologyEx(padded, cv2.MORPH_CLOSE, _disk(close_radius))[p:-p, p:-p]
        m = np.ascontiguousarray(m)

    # Connected components; areas by bincount (faster than OpenCV's int32 statistics).
    n, labels = cv2.connectedComponents(m, connectivity=8)
    areas = np.bincount(labels.ravel(), minlength=n)[1:]
    order = np.argsort(-areas, kind="stable")
    chosen = order[:n_keep]
    chosen = chosen[areas[chosen] >= min_area] + 1
    if len(chosen) == 1:
        out = labels == chosen[0]
    else:
        lut = np.zeros(n, dtype=bool)
        lut[chosen] = True
        out = lut[labels]

    if fill_holes and len(chosen):
        out = _fill_holes(out, max_hole_area)
    return out


def _fill_holes(mask: np.ndarray, max_hole_area: int | None) -> np.ndarray:
    """Fill background regions (4-connected) that do not touch the image border.

    Works inside the silhouette's bounding box (holes cannot lie outside it), padded by
    one background pixel: a flood fill from the padding marks the outside; what is left
    unmarked and outside the silhouette is a hole.
    """
    x, y, w, h = cv2.boundingRect(mask.view(np.uint8))
    crop = cv2.copyMakeBorder(
        mask[y : y + h, x : x + w].view(np.uint8), 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0
    )
    outside = crop.copy()
    cv2.floodFill(outside, None, (0, 0), 1, flags=4)
    holes = (outside == 0)[1:-1, 1:-1]
    if max_hole_area is not None and holes.any():
        _, labels, stats, _ = cv2.connectedComponentsWithStats(holes.view(np.uint8), connectivity=4)
        small = stats[:, cv2.CC_STAT_AREA] <= max_hole_area
        small[0] = False
        holes = small[labels]
    out = mask.copy()
    out[y : y + h, x : x + w] |= holes
    return out


# --- wrist -----------------------------------------------------------------------------


@dataclass(frozen=True)
class WristCut:
    """Where `find_wrist` found the wrist.

    Attributes
    ----------
    palm_centre : (2,) ndarray
        Centre of the largest inscribed circle, pixels (x, y).
    palm_radius : float
        Its radius R, pixels.
    direction : (2,) ndarray
        Unit vector from the palm centre towards the forearm (x, y).
    wrist : (2,) ndarray
        The cut point on the axis, pixels (x, y); the cut line passes through it
        perpendicular to ``direction``.
    width : float
        Silhouette width at the cut, pixels.
    """

    palm_centre: np.ndarray
    palm_radius: float
    direction: np.ndarray
    wrist: np.ndarray
    width: float

    def forearm_side(self, shape: tuple[int, int]) -> np.ndarray:
        """(H, W) bool: the half-plane beyond the cut line (the forearm side)."""
        h, w = shape
        ys, xs = np.mgrid[0:h, 0:w]
        t = (xs - self.wrist[0]) * self.direction[0] + (ys - self.wrist[1]) * self.direction[1]
        return t > 0


def find_wrist(
    mask: np.ndarray,
    keypoints=None,
    **kwargs: float | tuple[float, float],
) -> WristCut | None:
    """Locate the wrist of a hand-and-forearm silhouette, or None if no forearm shows.

    Three routes (`handvar.vision.wrist`, §14.1):

    1. With `keypoints` (this frame's (21, 2|3) keypoints in the mask's pixels, wrist
       and middle MCP present): the line through the detected wrist perpendicular to
       the wrist → middle-MCP direction, a little towards the forearm
       (`handvar.vision.wrist.wrist_from_keypoints`).
    2. A silhouette that leaves the image: the forearm is followed from the border
       inwards until its width changes (`handvar.vision.wrist.forearm_wrist`), unless
       the silhouette beyond that cut is shorter than `WristCutSettings.min_hand`
       wrist widths (the cut went into the hand).
    3. Otherwise the palm-centre heuristic (`_palm_wrist`; its settings are `**kwargs`,
       see `WristSettings`).

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette (one component is expected; the largest is used).
    keypoints : (21, 2|3) array_like, optional
        The frame's keypoints, pixels of the mask; NaN where missing.
    **kwargs
        Settings of the palm-centre heuristic (`WristSettings`).

    Returns
    -------
    WristCut or None
    """
    from handvar.vision.wrist import (
        WRIST_CUT_SETTINGS,
        forearm_wrist,
        hand_length,
        wrist_from_keypoints,
    )

    m = _as_mask(mask)
    if not m.any():
        raise ValueError("mask: expected a non-empty silhouette, got an empty mask")
    if keypoints is not None:
        cut = wrist_from_keypoints(keypoints, m.shape)
        if cut is not None:
            return cut
    if m[0].any() or m[-1].any() or m[:, 0].any() or m[:, -1].any():
        cut = forearm_wrist(m)
        # A hand is longer than its wrist is wide: a cut that leaves less went into
        # the hand, so the palm-centre heuristic decides instead.
        if cut is None or hand_length(m, cut) >= WRIST_CUT_SETTINGS.min_hand * cut.width:
            return cut
    return _palm_wrist(m, **kwargs)


def _palm_wrist(
    mask: np.ndarray,
    *,
    forearm_thickness: float = WRIST_SETTINGS.forearm_thickness,
    forearm_start: float = WRIST_SETTINGS.forearm_start,
    min_forearm_area: float = WRIST_SETTINGS.min_forearm_area,
    search: tuple[float, float] = WRIST_SETTINGS.search,
    tolerance: float = WRIST_SETTINGS.tolerance,
) -> WristCut | None:
    """The palm-centre wrist heuristic (`find_wrist`'s route 3).

    Heuristic (all lengths in units of the palm radius R):

    1. Palm centre and R: the maximum of the Euclidean distance transform (the centre
       and radius of the largest inscribed circle; the palm is the thickest part of a
       hand, and thicker than the forearm seen from the front in typical views).
    2. Forearm direction: the forearm is the only other thick part.  Pixels at least
       ``forearm_thickness`` · R from the background and ``forearm_start`` · R from
       the palm centre are forearm candidates (fingers are too thin to qualify).  If
       there are fewer than ``min_forearm_area`` · R² of them, no forearm is visible
       and None is returned.  Otherwise the direction is the principal axis (second
       moments) of the silhouette pixels beyond the palm circle on the candidates'
       side, oriented towards the candidates' mean.
    3. Wrist: the silhouette's width profile along that axis (pixel count per 1-pixel
       slab perpendicular to it, lightly smoothed) is minimised over
       ``search`` = (a, b) · R from the palm centre; the wrist is the cross-section
       nearest the palm whose width is within ``1 + tolerance`` of the narrowest.
    4. Check: a forearm in a real image leaves it.  If the silhouette touches the image
       border but at most half of its border pixels lie beyond the cut (the thickest
       part was the forearm, e.g. a hand seen edge-on), None is returned rather than
       cutting the hand off.

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette (one component is expected; the largest is used).
    forearm_thickness, forearm_start, min_forearm_area, search, tolerance
        See `WristSettings`.

    Returns
    -------
    WristCut or None
    """
    m = _as_mask(mask)
    if not m.any():
        raise ValueError("mask: expected a non-empty silhouette, got an empty mask")
    a, b = (float(v) for v in search)
    if not 0 <= a < b:
        raise ValueError(f"search: expected 0 <= a < b (palm radii), got {search!r}")
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n > 2:
        biggest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        m = (labels == biggest).astype(np.uint8)

    # 1. Palm: largest inscribed circle.  Pad so the image border does not count as
    # background (a forearm leaving the image is not thin there).
    padded = cv2.copyMakeBorder(m, 1, 1, 1, 1, cv2.BORDER_REPLICATE)
    dist = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    iy, ix = np.unravel_index(int(np.argmax(dist)), dist.shape)
    radius = float(dist[iy, ix])
    centre = np.array([ix, iy], dtype=np.float64)
    if radius < 2.0:
        return None

    ys, xs = np.nonzero(m)
    rel = np.stack([xs - centre[0], ys - centre[1]], axis=1).astype(np.float64)
    r = np.hypot(rel[:, 0], rel[:, 1])

    # 2. Forearm candidates: thick and away from the palm.
    thick = (dist[ys, xs] >= forearm_thickness * radius) & (r >= forearm_start * radius)
    if thick.sum() < min_forearm_area * radius**2:
        return None
    towards = rel[thick].mean(axis=0)
    towards /= np.linalg.norm(towards)
    # Principal axis of the silhouette beyond the palm circle on the forearm's side.
    side = (r > radius) & (rel @ towards > 0)
    pts = rel[side]
    pts = pts - pts.mean(axis=0)
    cov = pts.T @ pts / len(pts)
    _, vecs = np.linalg.eigh(cov)
    axis = vecs[:, -1]
    direction = axis if axis @ towards >= 0 else -axis

    # 3. Width profile along the axis (pixel count per 1-px slab).
    t = rel @ direction
    ti = np.floor(t).astype(np.int64)
    lo = int(np.floor(a * radius))
    hi = int(np.ceil(b * radius))
    inside = (ti >= lo) & (ti <= hi)
    profile = np.bincount(ti[inside] - lo, minlength=hi - lo + 1).astype(np.float64)
    k = max(1, round(0.1 * radius))
    smooth = np.convolve(profile, np.ones(2 * k + 1) / (2 * k + 1), mode="same")
    # Edges of the convolution see zeros outside the interval: ignore them.
    valid = np.arange(len(smooth))
    valid = (valid >= k) & (valid < len(smooth) - k)
    if t.max() < lo + 2 * k or not valid.any():
        return None
    smooth[~valid] = np.inf
    j = int(np.argmax(smooth <= (1.0 + tolerance) * smooth.min()))
    width = float(profile[j])
    if width == 0:
        return None
    t_cut = lo + j + 0.5
    wrist = centre + t_cut * direction

    # 4. The forearm side must hold most of the silhouette's image-border pixels.
    h, w = m.shape
    edge = (xs == 0) | (ys == 0) | (xs == w - 1) | (ys == h - 1)
    if edge.any() and np.mean(t[edge] > t_cut) <= 0.5:
        return None
    return WristCut(
        palm_centre=centre,
        palm_radius=radius,
        direction=direction,
        wrist=wrist,
        width=width,
    )


def cut_wrist(
    mask: np.ndarray, keypoints=None, **kwargs: float | tuple[float, float]
) -> np.ndarray:
    """Remove a visible forearm from a silhouette by cutting at the wrist.

    The wrist is found by `find_wrist` (at the detected wrist when `keypoints` are
    given; else where the forearm's width changes, or by the palm-centre heuristic for
    a silhouette inside the image).  Everything beyond the cut line is removed and the
    largest remaining component is kept.  A silhouette without a visible forearm is
    returned unchanged.

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette; non-zero is inside.
    keypoints : (21, 2|3) array_like, optional
        The frame's keypoints in the mask's pixels (`handvar.vision.keypoints`).
    **kwargs
        Passed to `find_wrist` (see `WristSettings`).

    Returns
    -------
    (H, W) bool ndarray
        The silhouette without the forearm.
    """
    m = _as_mask(mask).astype(bool)
    cut = find_wrist(m, keypoints, **kwargs)
    if cut is None:
        return m
    # Remove the silhouette pixels beyond the cut line (only those are visited).
    ys, xs = np.nonzero(m)
    beyond = (xs - cut.wrist[0]) * cut.direction[0] + (ys - cut.wrist[1]) * cut.direction[1] > 0
    hand = m.astype(np.uint8)
    hand[ys[beyond], xs[beyond]] = 0
    n, labels = cv2.connectedComponents(hand, connectivity=8)
    if n <= 1:
        return m  # the cut would leave nothing: keep the silhouette
    areas = np.bincount(labels.ravel(), minlength=n)[1:]
    return labels == 1 + int(np.argmax(areas))


# --- distance field --------------------------------------------------------------------


def nearest_silhouette_pixel(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every pixel, the nearest silhouette pixel and the distance to it.

    Exact Euclidean nearest neighbour (``scipy.ndimage.distance_transform_edt`` with
    ``return_indices``; OpenCV's labelled transform supports only the approximate 5×5
    mask).  Inside the silhouette a pixel is its own nearest pixel at distance 0.

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette; non-zero is inside.  Must not be empty.

    Returns
    -------
    nearest : (H, W, 2) int32 ndarray
        Pixel coordinates (x, y) of the nearest silhouette pixel (ties broken by the
        transform).
    distance : (H, W) float64 ndarray
        Distance to it, pixels.
    """
    m = _as_mask(mask)
    if not m.any():
        raise ValueError("mask: expected a non-empty silhouette, got an empty mask")
    # The transform measures the distance to the nearest zero pixel: invert the mask.
    distance, (iy, ix) = ndimage.distance_transform_edt(m == 0, return_indices=True)
    nearest = np.stack([ix, iy], axis=-1).astype(np.int32)
    return nearest, distance


# --- cameras and frames ----------------------------------------------------------------


def silhouettes_from_frames(
    frames: Sequence[np.ndarray],
    model: _TableClassifier | None = None,
    *,
    threshold: float | None = None,
    order: str = "bgr",
    cleanup: dict | None = None,
    wrist: bool = False,
    frame: int | None = None,
    cameras: Sequence[str] | None = None,
    keypoints: Sequence[np.ndarray | None] | None = None,
) -> list[np.ndarray]:
    """Hand silhouettes of one time step seen by any number of cameras.

    For each camera: skin mask (``model.mask``), `clean_mask`, then optionally
    `cut_wrist`.

    Parameters
    ----------
    frames : sequence of (H_j, W_j, 3) uint8 ndarray
        One colour image per camera (sizes may differ), BGR unless ``order="rgb"``.
        A single image (an ndarray with 3 dimensions) is taken as one camera.
    model : SkinModel or HistogramSkinModel, optional
        Skin classifier; default the Jones–Rehg mixtures (`SkinModel()`).
    threshold : float, optional
        Likelihood-ratio threshold Θ passed to ``model.mask``.
    order : {"bgr", "rgb"}
        Channel order of the frames.
    cleanup : dict, optional
        Keyword arguments of `clean_mask` overriding `CLEANUP_SETTINGS`.
    wrist : bool
        Cut a visible forearm off at the wrist (`cut_wrist`).
    frame : int, optional
        Frame index, used in error messages.
    cameras : sequence of str, optional
        Camera names, used in error messages (default: their indices).
    keypoints : sequence of (21, 2|3) array_like or None, optional
        Per camera, the frame's keypoints in its pixels: the wrist cut is made at the
        detected wrist (`find_wrist`).

    Returns
    -------
    list of (H_j, W_j) bool ndarray
        One silhouette per camera.

    Raises
    ------
    EmptySilhouetteError
        If a camera's silhouette is empty; the message names camera and frame.
    NotAHandError
        (an `EmptySilhouetteError`) if a camera's silhouette touches all four
        borders of its image (`touches_every_border`).
    """
    if isinstance(frames, np.ndarray) and frames.ndim == 3:
        frames = [frames]
    frames = list(frames)
    if not frames:
        raise ValueError("frames: expected at least one camera image, got none")
    if cameras is not None and len(cameras) != len(frames):
        raise ValueError(
            f"cameras: expected {len(frames)} names (one per frame), got {len(cameras)}"
        )
    model = SkinModel() if model is None else model
    if not isinstance(model, _TableClassifier):
        raise ValueError(
            f"model: expected a SkinModel or HistogramSkinModel, got {type(model).__name__}"
        )
    opts = dict(cleanup or {})
    out = []
    for j, image in enumerate(frames):
        cam = cameras[j] if cameras is not None else j
        where = f"camera {cam!r}" + ("" if frame is None else f", frame {frame}")
        try:
            raw = model.mask(image, threshold=threshold, order=order)
        except ValueError as exc:
            raise ValueError(f"frames ({where}): {exc}") from exc
        sil = clean_mask(raw, **opts)
        if touches_every_border(sil):
            raise NotAHandError(
                f"{where}: not a hand (expected a hand inside the image; the skin-coloured "
                f"region touches all four borders and covers {sil.mean():.0%} of it)",
                camera=cam,
                frame=frame,
            )
        if wrist and sil.any():
            sil = cut_wrist(sil, None if keypoints is None else keypoints[j])
        if not sil.any():
            raise EmptySilhouetteError(
                f"{where}: empty silhouette (expected skin-coloured pixels; "
                f"{int(raw.sum())} raw skin pixels before clean-up)",
                camera=cam,
                frame=frame,
            )
        out.append(sil)
    return out


def silhouettes_from_videos(
    paths: Sequence[str | os.PathLike],
    model: _TableClassifier | None = None,
    *,
    start: int = 0,
    stop: int | None = None,
    step: int = 1,
    **kwargs,
) -> Iterator[tuple[int, list[np.ndarray]]]:
    """Silhouettes of synchronised videos, one per camera, frame by frame.

    Parameters
    ----------
    paths : sequence of path-like
        One video file per camera (anything ``cv2.VideoCapture`` reads), frames in
        lockstep.
    model : SkinModel or HistogramSkinModel, optional
        Skin classifier; default `SkinModel()`.
    start, stop, step : int
        Frame range, as in ``range(start, stop, step)``; ``stop=None`` reads to the end
        of the shortest video.
    **kwargs
        Passed to `silhouettes_from_frames` (threshold, cleanup, wrist, ...).

    Yields
    ------
    frame : int
        Frame index.
    masks : list of (H, W) bool ndarray
        One silhouette per camera.
    """
    paths = [Path(p) for p in paths]
    if not paths:
        raise ValueError("paths: expected at least one video, got none")
    if start < 0 or step < 1 or (stop is not None and stop < start):
        raise ValueError(f"start, stop, step: expected a forward range, got {start, stop, step}")
    model = SkinModel() if model is None else model
    caps = []
    try:
        for p in paths:
            cap = cv2.VideoCapture(str(p))
            if not p.is_file() or not cap.isOpened():
                cap.release()
                raise ValueError(f"paths: expected a readable video file, got {str(p)!r}")
            caps.append(cap)
        index = 0
        while stop is None or index < stop:
            images = []
            for cap in caps:
                ok, image = cap.read()
                if not ok:
                    return
                images.append(image)
            if index >= start and (index - start) % step == 0:
                names = [p.name for p in paths]
                yield (
                    index,
                    silhouettes_from_frames(images, model, frame=index, cameras=names, **kwargs),
                )
            index += 1
    finally:
        for cap in caps:
            cap.release()
