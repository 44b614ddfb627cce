"""Where the hand ends and the forearm begins in a silhouette: two wrist cuts (§14.1).

A skin silhouette of a real hand usually carries the forearm, which pulls the model down
the arm.  `handvar.vision.silhouette.cut_wrist` removes it along a line found here:

- `wrist_from_keypoints`: with 2D keypoints, the line through the detected wrist
  perpendicular to the wrist → middle-MCP direction, moved a little towards the forearm
  (`WristCutSettings.keypoint_offset` hand sizes; the hand size is the wrist →
  middle-MCP distance), so the heel of the palm stays.
- `forearm_wrist`: without keypoints, from the forearm itself.  A forearm leaves the
  image; its silhouette is a band of nearly constant width.  Starting where the
  silhouette crosses the image border, the band's centre line is followed inwards
  (cross-sections perpendicular to the local direction, 1 px apart; the direction is
  re-estimated from the centres of the last cross-sections) while its width stays
  within ``1 ± tolerance`` of the forearm's width (the median of the preceding
  cross-sections, so that the forearm's gentle taper is followed).  The wrist is the
  first cross-section where the width leaves that band for good (for at least
  `WristCutSettings.persist` forearm widths): wider for a palm or a fist seen from the
  front (the thumb and the knuckles stick out), narrower for a hand seen edge-on.  The
  thickness of the hand, which the palm-centre heuristic relied on, plays no part: a
  fist is no thicker than the forearm, but it is wider, and an edge-on hand is
  narrower.

Both return a `WristCut` (palm centre and radius, the direction towards the forearm,
the cut point, the width there).  `studies/wrist.py` measures both against the
detected wrists of the example video.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.validate import as_float
from handvar.vision.keypoints import as_frame_keypoints
from handvar.vision.silhouette import WristCut, _as_mask

__all__ = [
    "WRIST_CUT_SETTINGS",
    "WristCutSettings",
    "forearm_wrist",
    "hand_length",
    "wrist_from_keypoints",
]


@dataclass(frozen=True)
class WristCutSettings:
    """Named settings of the wrist cuts (module notes; the paper has no wrist cut).

    Attributes
    ----------
    keypoint_offset : float
        The keypoint cut lies this many hand sizes (wrist → middle-MCP distance) beyond
        the wrist keypoint, towards the forearm.
    tolerance : float
        Relative widening, against the forearm's width, that marks the hand.
    narrowing : float
        Relative narrowing that marks the hand (larger: a forearm tapers towards the
        wrist).
    persist : float
        The change must last over this many forearm widths along the axis.
    reference : float
        The forearm's width is the median over this many forearm widths of
        cross-sections, ending `persist` forearm widths before the current one (so
        that a gradual widening is still seen as one).
    onset : float
        The cut is moved back from where the change was found to the last
        cross-section within ``onset · tolerance`` of the forearm's width.
    min_forearm : float
        Forearm lengths (in forearm widths) followed before a change is looked for; a
        change whose onset lies closer to the image border is passed over (a silhouette
        that widens or narrows where it enters the image shows no forearm before it).
    direction_window : float
        Centres of the cross-sections over this many forearm widths give the local
        direction.
    min_hand : float
        A cut is kept only if the silhouette extends at least this many wrist widths
        beyond it on the hand's side: a hand is longer than its wrist is wide (a closed
        fist measures about 1.5 wrist widths on the example video, an edge-on hand 1.3 or
        more), so a cut that leaves less has cut into the hand (`find_wrist` then falls
        back to the palm-centre heuristic).
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


WRIST_CUT_SETTINGS = WristCutSettings()


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
    palm = k[[0, 5, 9, 13, 17], :2]
    palm = palm[~np.isnan(palm).any(axis=1)]
    return WristCut(
        palm_centre=palm.mean(axis=0),
        palm_radius=0.5 * size,
        direction=direction,
        wrist=wrist + offset * size * direction,
        width=float("nan"),
    )


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
    m = _as_mask(mask)
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
