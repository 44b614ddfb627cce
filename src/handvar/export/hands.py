"""Several hands in one file: the record of one hand that the two-hand exports take.

A track of both hands is one track per hand over the same frames (`handvar.HandsTrack`:
``DIR/hands.json`` and a track directory per side). Each format writes them together
(docs/outputs.md, "Both hands"): the keypoint JSON lists them under ``hands``, OpenPose
puts them in one person, BVH gives each its ROOT, glTF its skinned mesh, and the viewer
draws them in their sides' colours. Every two-hand function takes a sequence of
`TrackedHand` and checks it with `checked_hands`: the same number of frames, one hand
per side (the sides name the hands' joints, nodes and OpenPose lists).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handvar.export.absent import hand_frames
from handvar.hand.kinematics import HandModel
from handvar.params import N_PARAMS
from handvar.validate import as_instance

__all__ = ["TrackedHand", "checked_hands"]


@dataclass(frozen=True, eq=False)
class TrackedHand:
    """One hand of a track of several, as the exports take it.

    Attributes
    ----------
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without this hand.
    hand : HandModel
        The tracked model (``hand.shape.side``: which hand).
    id : int
        The hand's identity in the track (`handvar.HandsTrack.tracks`).
    confidence : (T,) array_like, optional
        Per-frame fit confidence (`handvar.export.keypoints.fit_confidence`).
    support : (T, 21) array_like, optional
        Per point what its evidence leaves of that (`~handvar.export.keypoints.
        point_support`).
    """

    poses: np.ndarray
    hand: HandModel
    id: int = 0
    confidence: np.ndarray | None = None
    support: np.ndarray | None = None

    @property
    def side(self) -> str:
        return self.hand.shape.side


def checked_hands(hands, name: str = "hands") -> list[TrackedHand]:
    """`hands` as a list of `TrackedHand`, checked: at least one, each a `TrackedHand`
    whose poses are (T, 26) with T the same for all, no two of the same side.

    Raises
    ------
    ValueError
        Naming the hand (its index and side) and what is wrong.

    Examples
    --------
    >>> from handvar.hand.anthropometry import HandShape
    >>> right = TrackedHand(np.zeros((3, 26)), HandModel(HandShape.from_size()))
    >>> [h.side for h in checked_hands([right])]
    ['right']
    >>> checked_hands([right, right])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: hands: expected at most one hand of each side; got sides ['right', 'right']
    """
    hands = list(hands) if isinstance(hands, list | tuple) else [hands]
    if not hands:
        raise ValueError(f"{name}: expected at least one hand; got none")
    for i, h in enumerate(hands):
        as_instance(h, TrackedHand, f"{name}[{i}]")
        as_instance(h.hand, HandModel, f"{name}[{i}].hand")
        hand_frames(h.poses, f"{name}[{i}] ({h.side}) poses", (None, N_PARAMS))
    sides = [h.side for h in hands]
    if len(set(sides)) != len(sides):
        raise ValueError(f"{name}: expected at most one hand of each side; got sides {sides}")
    lengths = [np.shape(h.poses)[0] for h in hands]
    if len(set(lengths)) != 1:
        raise ValueError(
            f"{name}: expected the same number of frames for every hand; got "
            + ", ".join(f"{s} {n}" for s, n in zip(sides, lengths, strict=True))
        )
    return hands
