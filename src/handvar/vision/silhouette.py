"""Hand silhouettes from skin masks: clean-up, wrist cut, distance fields, cameras.

The paper's real-video tracker (section 6) fits the model to the hand silhouette in
each camera.  A raw skin mask (`handvar.vision.skin`) has speckle from skin-coloured
background, small holes where the palm is shaded, and usually the forearm.  This module
turns it into one clean silhouette per camera:

1. `clean_mask`: morphological opening (removes speckle) and closing (bridges thin
   gaps), the largest connected component(s), small components dropped, holes filled.
2. `handvar.vision.wrist.cut_wrist` (optional): removes a visible forearm so that it
   does not pull the hand model out of the image (at the detected wrist with keypoints,
   else where the forearm's width changes; see `handvar.vision.wrist`).
3. `silhouettes_from_frames`: both steps for the frames of any number of cameras;
   an empty silhouette raises `EmptySilhouetteError` naming the camera and frame, and
   so does one that touches all four borders of the image (`NotAHandError`): skin
   colour everywhere (a wall, a close-up of skin) is not a hand in view.

`split_silhouette` shares one camera's skin silhouette between several tracked hands
(`handvar.tracking.hands`): each pixel goes to the hand expected nearest it.

`nearest_silhouette_pixel` gives, for every pixel, the nearest silhouette pixel — the
``s*`` of the silhouette cost ``C_s`` (design §4).

Masks are ``(H, W)`` arrays; anything non-zero is inside.  Pixel coordinates are
``(x, y)`` = (column, row), in pixels.

One concept, a silhouette from a skin mask; the wrist cut has its own module.
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

from handvar.validate import as_int, as_mask, one_of
from handvar.vision.skin import SkinModel, _TableClassifier
from handvar.vision.wrist import cut_wrist

__all__ = [
    "CLEANUP_SETTINGS",
    "CleanupSettings",
    "EmptySilhouetteError",
    "NotAHandError",
    "clean_mask",
    "nearest_silhouette_pixel",
    "silhouettes_from_frames",
    "silhouettes_from_videos",
    "split_silhouette",
    "touches_every_border",
]


@dataclass(frozen=True)
class CleanupSettings:
    """Named settings of `clean_mask` (paper section 6: skin mask to hand silhouette).

    The paper gives no clean-up parameters. The radii were chosen on the realistic
    benchmark against the hand's true silhouettes (`studies/cleanup.py`; frames of
    640×360 with the hand about 100 px across, as the example video at ``--scale
    0.5``): an opening of 1 px and a closing of 2 px give a median IoU of 0.806 over
    its 16 cases, against 0.721 with the radii before (2 and 4, chosen on the example
    video), which bridged the gaps between the fingers and cut the fingertips short.
    No opening (0 and 2) scores 0.831 there but fails the cluttered synthetic frames of
    the skin test (`tests/test_vision_skin.py`): without an opening, the closing glues
    skin-coloured speckle to the hand.  The opening of 1 px leaves more of that clutter
    than 2 px did: on the same test's frames with one hand the IoU is at least 0.9 on
    26 of 36 frames, against 33 before.

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

    open_radius: int = 1
    close_radius: int = 2
    keep: Literal["largest"] | int = "largest"
    fill_holes: bool = True
    min_area: int = 200
    max_hole_area: int | None = None


CLEANUP_SETTINGS = CleanupSettings()


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


# --- clean-up --------------------------------------------------------------------------


def _disk(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def clean_mask(
    mask: np.ndarray,
    *,
    open_radius: int = CLEANUP_SETTINGS.open_radius,
    close_radius: int = CLEANUP_SETTINGS.close_radius,
    keep: Literal["largest"] | int = CLEANUP_SETTINGS.keep,
    fill_holes: bool = CLEANUP_SETTINGS.fill_holes,
    min_area: int = CLEANUP_SETTINGS.min_area,
    max_hole_area: int | None = CLEANUP_SETTINGS.max_hole_area,
    near: np.ndarray | None = None,
) -> np.ndarray:
    """Clean a raw skin mask into a silhouette.

    Steps, in order: opening with a disk of radius ``open_radius``, closing with a disk
    of radius ``close_radius``, connected components (8-connected,
    ``cv2.connectedComponentsWithStats``) of at least ``min_area`` pixels, the ``keep``
    largest of them, then (if ``fill_holes``) every enclosed background region (holes,
    4-connected) of at most ``max_hole_area`` pixels is filled.

    With `near` (where the hand is expected: the tracked model's predicted silhouette)
    the components kept are those overlapping it most, ties and components without
    overlap by area: a skin-coloured background larger than the hand (a wall, a
    fridge, a face) is not taken for it.  Where no component overlaps `near`, the
    largest are kept, as without it.

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
    near : (H, W) array_like, optional
        Where the hand is expected; non-zero is inside.

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
    >>> m[32:38, 32:40] = True    # a smaller skin-coloured patch, where the hand is expected
    >>> expected = np.zeros_like(m); expected[33:36, 30:36] = True
    >>> int(clean_mask(m, open_radius=0, close_radius=0, min_area=10, near=expected).sum())
    48
    """
    m = as_mask(mask)
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
    if near is not None:
        near = as_mask(near, "near")
        if near.shape != m.shape:
            raise ValueError(f"near: expected the mask's shape {m.shape}; got {near.shape}")

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
    if near is not None:
        overlap = np.bincount(labels[near != 0], minlength=n)[1:]
        overlap[areas < min_area] = 0
        if overlap.any():
            order = order[np.argsort(-overlap[order], kind="stable")]
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


# --- distance field --------------------------------------------------------------------


def split_silhouette(mask: np.ndarray, expected: Sequence) -> list[np.ndarray]:
    """Share one camera's skin silhouette between hands by where each is expected.

    Two hands that touch, clap or overlap make one skin component; fitted to it whole,
    each model would be asked to fill the other hand too.  Each pixel of `mask` goes to
    the hand whose expected silhouette (its model at its predicted pose) lies nearest
    it (Euclidean distance transform); a pixel inside several goes to the first of
    them, so `expected` is ordered front to back and a hand in front keeps the pixels
    where it covers the other.  Components that overlap no expected silhouette (a face,
    another arm) go to no hand.  A hand expected nowhere (None: not tracked yet) gets
    the largest component that overlaps none of the others.

    Parameters
    ----------
    mask : (H, W) array_like
        The camera's silhouette (`clean_mask`, every component that may be a hand).
    expected : sequence of (H, W) array_like or None
        Per hand, where it is expected, front to back; None where it is not.

    Returns
    -------
    list of (H, W) bool ndarray
        Each hand's share, in the order of `expected`; disjoint.

    Examples
    --------
    >>> import numpy as np
    >>> m = np.zeros((20, 40), bool)
    >>> m[5:15, 2:38] = True                  # two hands touching: one component
    >>> left = np.zeros_like(m); left[6:14, 4:16] = True
    >>> right = np.zeros_like(m); right[6:14, 24:36] = True
    >>> a, b = split_silhouette(m, [left, right])
    >>> int(a.sum()), int(b.sum()), bool((a & b).any()), bool(a[10, 19]), bool(b[10, 21])
    (180, 180, False, True, True)
    """
    m = as_mask(mask).astype(bool)
    regions = [None if e is None else as_mask(e, f"expected[{k}]").astype(bool)
               for k, e in enumerate(expected)]  # fmt: skip
    for k, r in enumerate(regions):
        if r is not None and r.shape != m.shape:
            raise ValueError(f"expected[{k}]: expected the mask's shape {m.shape}; got {r.shape}")
    shares = [np.zeros_like(m) for _ in regions]
    present = [k for k, r in enumerate(regions) if r is not None and r.any()]
    n, labels = cv2.connectedComponents(m.view(np.uint8), connectivity=8)
    if n <= 1:
        return shares
    touched = np.zeros(n, dtype=bool)
    for k in present:
        touched[np.unique(labels[regions[k]])] = True
    touched[0] = False
    if present:
        distance = np.stack([cv2.distanceTransform((~regions[k]).view(np.uint8),
                                                   cv2.DIST_L2, 5) for k in present])  # fmt: skip
        owner = np.asarray(present)[np.argmin(distance, axis=0)]  # ties: the first
        kept = touched[labels]
        for k in present:
            shares[k] = kept & (owner == k)
    areas = np.bincount(labels.ravel(), minlength=n)
    areas[touched] = 0
    areas[0] = 0
    free = [k for k, r in enumerate(regions) if k not in present]
    if free and areas.any():
        shares[free[0]] = labels == int(np.argmax(areas))
    return shares


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
    m = as_mask(mask)
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
    near: Sequence[np.ndarray] | None = None,
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
        detected wrist (`handvar.vision.wrist.find_wrist`).
    near : sequence of (H_j, W_j) array_like, optional
        Per camera where the hand is expected (`clean_mask`'s `near`): the components
        overlapping it are kept rather than the largest.

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
        sil = clean_mask(raw, **opts, near=None if near is None else near[j])
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
