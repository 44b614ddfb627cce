"""Where the hand ends and the forearm begins in a silhouette: the wrist cut (design §14.1).

A skin silhouette of a real hand usually carries the forearm, which pulls the model down
the arm.  `cut_wrist` removes it along the line `find_wrist` finds, by the first of three
routes that applies:

1. `wrist_from_keypoints`: with 2D keypoints, the line through the detected wrist
   perpendicular to the wrist → middle-MCP direction, moved a little towards the forearm
   (`WristCutSettings.keypoint_offset` hand sizes; the hand size is the wrist →
   middle-MCP distance), so the heel of the palm stays.
2. `forearm_wrist`: without keypoints, from the forearm itself.  A forearm leaves the
   image; its silhouette is a band of nearly constant width.  Starting where the
   silhouette crosses the image border, the band's centre line is followed inwards
   (cross-sections perpendicular to the local direction, 1 px apart; the direction is
   re-estimated from the centres of the last cross-sections) while its width stays
   within ``1 ± tolerance`` of the forearm's width (the median of the preceding
   cross-sections, so that the forearm's gentle taper is followed).  The wrist is the
   first cross-section where the width leaves that band for good (for at least
   `WristCutSettings.persist` forearm widths): wider for a palm or a fist seen from the
   front (the thumb and the knuckles stick out), narrower for a hand seen edge-on.  The
   thickness of the hand, which the palm-centre heuristic relies on, plays no part: a
   fist is no thicker than the forearm, but it is wider, and an edge-on hand is
   narrower.
3. `palm_wrist`: the palm-centre heuristic, for a silhouette that stays inside the image
   or whose forearm cut would leave less than a hand (`WristCutSettings.min_hand`).

Each returns a `WristCut` (palm centre and radius, the direction towards the forearm,
the cut point, the width there); one `WristCutSettings` holds the settings of all three.
`studies/wrist.py` measures them against the detected wrists of the example video.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.validate import as_float, as_mask
from handvar.vision.keypoints import PALM, as_frame_keypoints

__all__ = [
    "WRIST_CUT_SETTINGS",
    "WristCut",
    "WristCutSettings",
    "cut_wrist",
    "find_wrist",
    "forearm_wrist",
    "hand_length",
    "palm_wrist",
    "wrist_from_keypoints",
]


@dataclass(frozen=True)
class WristCutSettings:
    """Named settings of the wrist cut's three routes (module notes; the paper has none).

    Attributes
    ----------
    keypoint_offset : float
        Route 1: the keypoint cut lies this many hand sizes (wrist → middle-MCP
        distance) beyond the wrist keypoint, towards the forearm.
    tolerance : float
        Route 2: relative widening, against the forearm's width, that marks the hand.
    narrowing : float
        Route 2: relative narrowing that marks the hand (larger: a forearm tapers
        towards the wrist).
    persist : float
        Route 2: the change must last over this many forearm widths along the axis.
    reference : float
        Route 2: the forearm's width is the median over this many forearm widths of
        cross-sections, ending `persist` forearm widths before the current one (so
        that a gradual widening is still seen as one).
    onset : float
        Route 2: the cut is moved back from where the change was found to the last
        cross-section within ``onset · tolerance`` of the forearm's width.
    min_forearm : float
        Route 2: forearm lengths (in forearm widths) followed before a change is looked
        for; a change whose onset lies closer to the image border is passed over (a
        silhouette that widens or narrows where it enters the image shows no forearm
        before it).
    direction_window : float
        Route 2: centres of the cross-sections over this many forearm widths give the
        local direction.
    min_hand : float
        Route 2's cut is kept only if the silhouette extends at least this many wrist
        widths beyond it on the hand's side: a hand is longer than its wrist is wide (a
        closed fist measures about 1.5 wrist widths on the example video, an edge-on
        hand 1.3 or more), so a cut that leaves less has cut into the hand (`find_wrist`
        then falls back to route 3).
    forearm_thickness : float
        Route 3, in units of the palm radius ``R`` (the largest inscribed circle of the
        silhouette, i.e. the maximum of its distance transform): a pixel belongs to a
        forearm candidate if its distance to the background is at least this × R
        (fingers are about 0.2 R thick in this sense, a forearm seen from the front
        0.5–0.6 R on the example video).
    forearm_start : float
        Route 3: forearm candidates must lie at least this × R from the palm centre.
    min_forearm_area : float
        Route 3: fewest candidate pixels, in units of R², to decide that a forearm is
        visible.
    search : tuple of float
        Route 3: interval ``(a, b)`` × R along the forearm axis, from the palm centre,
        in which the narrowest cross-section is taken as the wrist.
    palm_tolerance : float
        Route 3: relative width tolerance: the wrist is the cross-section nearest the
        palm whose width is within ``(1 + palm_tolerance)`` × the narrowest one (the
        forearm just above the wrist is nearly as narrow; this keeps the cut at the
        palm's end of it).
    """

    keypoint_offset: float = 0.1
    tolerance: float = 0.15
    narrowing: float = 0.25
    persist: float = 0.35
    reference: float = 1.0
    onset: float = 0.75
    min_forearm: float = 0.5
    direction_window: float = 1.0
    min_hand: float = 1.0
    forearm_thickness: float = 0.4
    forearm_start: float = 1.5
    min_forearm_area: float = 0.5
    search: tuple[float, float] = (0.9, 2.6)
    palm_tolerance: float = 0.05


WRIST_CUT_SETTINGS = WristCutSettings()


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
    mask: np.ndarray, keypoints=None, *, settings: WristCutSettings = WRIST_CUT_SETTINGS
) -> WristCut | None:
    """Locate the wrist of a hand-and-forearm silhouette, or None if no forearm shows.

    The first of three routes that applies (module notes):

    1. With `keypoints` (this frame's (21, 2|3) keypoints in the mask's pixels, wrist
       and middle MCP present): `wrist_from_keypoints`.
    2. A silhouette that leaves the image: `forearm_wrist`, unless the silhouette beyond
       that cut is shorter than `WristCutSettings.min_hand` wrist widths (the cut went
       into the hand).
    3. Otherwise the palm-centre heuristic, `palm_wrist`.

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette (one component is expected; the largest is used).
    keypoints : (21, 2|3) array_like, optional
        The frame's keypoints, pixels of the mask; NaN where missing.
    settings : WristCutSettings, keyword-only

    Returns
    -------
    WristCut or None
    """
    m = as_mask(mask)
    if not m.any():
        raise ValueError("mask: expected a non-empty silhouette, got an empty mask")
    if keypoints is not None:
        cut = wrist_from_keypoints(keypoints, m.shape, offset=settings.keypoint_offset)
        if cut is not None:
            return cut
    if m[0].any() or m[-1].any() or m[:, 0].any() or m[:, -1].any():
        cut = forearm_wrist(m, settings=settings)
        # A hand is longer than its wrist is wide: a cut that leaves less went into
        # the hand, so the palm-centre heuristic decides instead.
        if cut is None or hand_length(m, cut) >= settings.min_hand * cut.width:
            return cut
    return palm_wrist(m, settings=settings)


def cut_wrist(
    mask: np.ndarray, keypoints=None, *, settings: WristCutSettings = WRIST_CUT_SETTINGS
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
    settings : WristCutSettings, keyword-only

    Returns
    -------
    (H, W) bool ndarray
        The silhouette without the forearm.
    """
    m = as_mask(mask).astype(bool)
    cut = find_wrist(m, keypoints, settings=settings)
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


# --- route 1: keypoints ----------------------------------------------------------------


def wrist_from_keypoints(
    keypoints, shape: tuple[int, int], *, offset: float = WRIST_CUT_SETTINGS.keypoint_offset
) -> WristCut | None:
    """The wrist cut from one frame's 2D keypoints (module notes).

    Parameters
    ----------
    keypoints : (21, 2|3) array_like
        Pixels (x, y) of the mask's image in the order of `G(x)`; the wrist (0) and the
        middle MCP (9) are used.
    shape : (int, int)
        The mask's (H, W) (unused but for the check of the points' range).
    offset : float, keyword-only
        Hand sizes beyond the wrist keypoint, towards the forearm.

    Returns
    -------
    WristCut or None
        None when the wrist or the middle MCP is missing or they coincide.

    Examples
    --------
    >>> import numpy as np
    >>> k = np.full((21, 2), np.nan)
    >>> k[0], k[9] = (50.0, 80.0), (50.0, 40.0)    # fingers up, forearm down
    >>> cut = wrist_from_keypoints(k, (100, 100))
    >>> cut.wrist.tolist(), cut.direction.tolist()
    ([50.0, 84.0], [0.0, 1.0])
    """
    k = as_frame_keypoints(keypoints)
    offset = as_float(offset, "offset")
    if not (k[[WRIST, MIDDLE_MCP], 2] > 0).all():
        return None
    wrist, mcp = k[WRIST, :2], k[MIDDLE_MCP, :2]
    size = float(np.linalg.norm(mcp - wrist))
    if size < 1e-6:
        return None
    direction = (wrist - mcp) / size  # towards the forearm
    palm = k[list(PALM), :2]
    palm = palm[~np.isnan(palm).any(axis=1)]
    return WristCut(
        palm_centre=palm.mean(axis=0),
        palm_radius=0.5 * size,
        direction=direction,
        wrist=wrist + offset * size * direction,
        width=float("nan"),
    )


# --- route 2: the forearm's width ------------------------------------------------------


def _border_entry(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Where the silhouette leaves the image: the longest run of border pixels.

    Returns its midpoint (x, y), the inward normal of that side and its length, or None
    when the silhouette does not touch the border.
    """
    h, w = m.shape
    sides = (  # (pixels along the side, fixed coordinate, inward normal, axis)
        (m[-1, :], (None, h - 1), (0.0, -1.0)),
        (m[0, :], (None, 0), (0.0, 1.0)),
        (m[:, 0], (0, None), (1.0, 0.0)),
        (m[:, -1], (w - 1, None), (-1.0, 0.0)),
    )
    best = None
    for line, fixed, normal in sides:
        on = np.flatnonzero(np.diff(np.concatenate([[0], line.astype(np.int8), [0]])))
        for a, b in zip(on[::2], on[1::2], strict=True):
            if best is None or b - a > best[2]:
                mid = 0.5 * (a + b - 1)
                point = np.array(
                    [mid if fixed[0] is None else fixed[0], mid if fixed[1] is None else fixed[1]],
                    dtype=float,
                )
                best = (point, np.array(normal), float(b - a))
    return best


def _cross_section(m: np.ndarray, centre: np.ndarray, normal: np.ndarray, half: int):
    """Width and midpoint of the mask's run through `centre` along `normal`.

    Samples at 1-px steps over ±`half`; the run is the one containing the sample
    nearest `centre` that lies inside.  Returns (0, centre) when none does, and a NaN
    width when the run is cut short by the image's edge.
    """
    h, w = m.shape
    u = np.arange(-half, half + 1, dtype=float)
    pts = centre[None, :] + u[:, None] * normal[None, :]
    xi = np.rint(pts[:, 0]).astype(np.int64)
    yi = np.rint(pts[:, 1]).astype(np.int64)
    ok = (xi >= 0) & (xi < w) & (yi >= 0) & (yi < h)
    inside = np.zeros(len(u), dtype=bool)
    inside[ok] = m[yi[ok], xi[ok]] > 0
    if not inside.any():
        return 0.0, centre
    idx = np.flatnonzero(inside)
    i0 = idx[np.argmin(np.abs(u[idx]))]
    a = i0
    while a > 0 and inside[a - 1]:
        a -= 1
    b = i0
    while b < len(u) - 1 and inside[b + 1]:
        b += 1
    # a run that ends at the image's edge is cut short: its width is not the band's
    clipped = (a > 0 and not ok[a - 1]) or (b < len(u) - 1 and not ok[b + 1])
    if clipped:
        return np.nan, centre + 0.5 * (u[a] + u[b]) * normal
    return float(b - a + 1), centre + 0.5 * (u[a] + u[b]) * normal


def hand_length(m: np.ndarray, cut: WristCut) -> float:
    """How far the silhouette `m` reaches beyond the cut line on the hand's side, px."""
    ys, xs = np.nonzero(m)
    s = (xs - cut.wrist[0]) * cut.direction[0] + (ys - cut.wrist[1]) * cut.direction[1]
    return float(-s.min()) if s.size and s.min() < 0 else 0.0


def forearm_wrist(
    mask: np.ndarray, *, settings: WristCutSettings = WRIST_CUT_SETTINGS
) -> WristCut | None:
    """The wrist of a silhouette whose forearm leaves the image (module notes).

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette; the largest component is used.
    settings : WristCutSettings, keyword-only

    Returns
    -------
    WristCut or None
        None when the silhouette does not touch the image border or its width never
        changes along the band (no hand found at its end).
    """
    m = as_mask(mask)
    if not m.any():
        raise ValueError("mask: expected a non-empty silhouette; got an empty mask")
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n > 2:
        m = (labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))).astype(np.uint8)
    entry = _border_entry(m)
    if entry is None:
        return None
    point, direction, _ = entry
    h, w = m.shape
    half = int(max(h, w))
    normal = np.array([-direction[1], direction[0]])
    width0, centre = _cross_section(m, point, normal, half)
    centres, widths = [centre], [width0]
    change_at: tuple[int, float] | None = None  # (index, forearm width) of a change
    for _ in range(int(np.hypot(h, w))):
        if np.isnan(widths[-50:]).all():
            recent = float(np.hypot(h, w)) / 20.0  # only clipped sections so far
        else:
            recent = float(np.nanmedian(widths[-50:]))
        lag = max(5, int(settings.reference * recent))
        gap = int(settings.persist * recent)
        win = max(3, int(settings.direction_window * recent))
        if len(centres) > 3:  # the local direction from the last centres, smoothed
            d = centres[-1] - centres[max(0, len(centres) - win)]
            if np.linalg.norm(d) > 2.0:
                direction = 0.7 * direction + 0.3 * d / np.linalg.norm(d)
                direction /= np.linalg.norm(direction)
                normal = np.array([-direction[1], direction[0]])
        width, centre = _cross_section(m, centres[-1] + direction, normal, half)
        if width == 0:
            break  # the band ended without a change: no hand found at its end
        i = len(widths)
        past = np.asarray(widths[max(0, i - gap - lag) : max(1, i - gap)])
        if change_at is None:  # the forearm's width before the last `gap` sections
            ref = float(np.nanmedian(past)) if not np.isnan(past).all() else np.nan
        else:
            ref = change_at[1]
        if not np.isnan(width) and not np.isnan(ref) and i > settings.min_forearm * recent:
            rel = (width - ref) / ref
            off = rel > settings.tolerance or rel < -settings.narrowing
            if off and change_at is None:
                change_at = (i, ref)
            elif not off:
                change_at = None
            if change_at is not None and i - change_at[0] >= settings.persist * ref:
                k, ref = change_at
                # the onset: back to the last section within `onset` of the tolerance
                while (
                    k > 1
                    and not abs(widths[k - 1] - ref) <= settings.onset * settings.tolerance * ref
                ):
                    k -= 1
                if k >= settings.min_forearm * ref:  # else no forearm before it: no wrist
                    wrist = centres[k - 1]
                    d = centres[max(0, k - 1 - win)] - wrist
                    axis = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-9 else -direction
                    return WristCut(
                        palm_centre=wrist - ref * axis,
                        palm_radius=0.5 * ref,
                        direction=axis,
                        wrist=np.asarray(wrist, dtype=float),
                        width=float(widths[k - 1]) if not np.isnan(widths[k - 1]) else ref,
                    )
                change_at = None
        centres.append(centre)
        widths.append(width)
    return None


# --- route 3: the palm centre ----------------------------------------------------------


def palm_wrist(
    mask: np.ndarray, *, settings: WristCutSettings = WRIST_CUT_SETTINGS
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
       nearest the palm whose width is within ``1 + palm_tolerance`` of the narrowest.
    4. Check: a forearm in a real image leaves it.  If the silhouette touches the image
       border but at most half of its border pixels lie beyond the cut (the thickest
       part was the forearm, e.g. a hand seen edge-on), None is returned rather than
       cutting the hand off.

    Parameters
    ----------
    mask : (H, W) array_like
        Silhouette (one component is expected; the largest is used).
    settings : WristCutSettings, keyword-only
        Its ``forearm_thickness``, ``forearm_start``, ``min_forearm_area``, ``search``
        and ``palm_tolerance``.

    Returns
    -------
    WristCut or None
    """
    forearm_thickness = settings.forearm_thickness
    forearm_start = settings.forearm_start
    min_forearm_area = settings.min_forearm_area
    search = settings.search
    tolerance = settings.palm_tolerance
    m = as_mask(mask)
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
