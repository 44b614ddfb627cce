"""Frames without a hand: which frames of a track have one, and poses held over the rest.

The tracker writes a frame where it found no hand (`TrackQuality.no_hand`) as a pose
that is NaN as a whole, and its joints likewise, so that a track keeps the frame count
and timing of its recording. A frame that is NaN in part, or holds an infinity, is not
such a frame but an error, and is refused.

Each exporter does with those frames what its format's readers expect (docs/outputs.md):
the keypoint files write no points, the viewer draws no skeleton, and BVH and glTF,
which have a value on every frame, hold a tracked pose (`held_poses`).
"""

from __future__ import annotations

import numpy as np

from handvar.validate import as_array

__all__ = ["hand_frames", "held_poses"]


def hand_frames(values, name: str, shape: tuple[int | None, ...], *, what: str = "poses"):
    """`values` as float64 of `shape` and which of its frames (first axis) have a hand.

    A frame without a hand is NaN as a whole; any other value must be finite.

    Parameters
    ----------
    values : array_like
        Per frame values, e.g. poses (T, 26) or joints (T, 21, 3).
    name : str
        The argument's name, for the messages.
    shape : tuple of int or None
        Required shape (`as_array`), frames first.
    what : str, keyword-only
        How the expected value reads in the messages.

    Returns
    -------
    values : ndarray
        float64, as given (NaN frames kept).
    present : (T,) bool ndarray
        The frames with a hand.

    Raises
    ------
    ValueError
        If the shape differs, a value is infinite, or a frame is NaN only in part.

    Examples
    --------
    >>> poses = [[1.0, 2.0], [np.nan, np.nan], [3.0, 4.0]]
    >>> hand_frames(poses, "poses", (None, 2))[1].tolist()
    [True, False, True]
    >>> hand_frames([[1.0, np.nan]], "poses", (None, 2))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: poses: expected poses finite, or NaN ...; got NaN in part of frame 0
    """
    arr = as_array(values, name, shape, finite=False, what=what)
    flat = arr.reshape(arr.shape[0], -1)
    nan = np.isnan(flat)
    expect = f"{name}: expected {what} finite, or NaN as a whole on a frame without a hand"
    if np.isinf(flat).any():
        frame = int(np.flatnonzero(np.isinf(flat).any(axis=1))[0])
        raise ValueError(f"{expect}; got infinity in frame {frame}")
    partial = nan.any(axis=1) & ~nan.all(axis=1)
    if partial.any():
        raise ValueError(f"{expect}; got NaN in part of frame {int(np.flatnonzero(partial)[0])}")
    return arr, ~nan.any(axis=1)


def held_poses(poses, *, name: str = "poses") -> np.ndarray:
    """(T, 26) the poses with each frame without a hand holding a tracked frame's pose.

    The held pose is that of the last tracked frame before it, or, before the first
    tracked frame, of the first one: what a format that needs a pose on every frame
    (BVH, glTF) shows while the hand is away.

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without a hand (`hand_frames`).
    name : str, keyword-only
        The argument's name, for the messages.

    Raises
    ------
    ValueError
        If no frame has a hand (or as `hand_frames`).

    Examples
    --------
    >>> poses = np.full((5, 26), np.nan)
    >>> poses[1], poses[3] = 1.0, 3.0
    >>> held_poses(poses)[:, 0].tolist()
    [1.0, 1.0, 1.0, 3.0, 3.0]
    """
    poses, present = hand_frames(poses, name, (None, 26))
    if not present.any():
        raise ValueError(
            f"{name}: expected a hand on at least one frame; got none on the "
            f"{poses.shape[0]} frames (every pose NaN)"
        )
    frames = np.arange(poses.shape[0])
    last = np.maximum.accumulate(np.where(present, frames, -1))  # last tracked, -1 before
    return poses[np.where(last >= 0, last, np.flatnonzero(present)[0])]
