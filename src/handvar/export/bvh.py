"""The 26 parameters of a track as a BVH skeleton and its motion, for animation tools.

The skeleton is built from the `HandShape` so that BVH forward kinematics gives G(x)
(`handvar.hand.kinematics`), in the file's units and axes. Every joint but the root
lies away from its parent (no zero-length bone: a tool that draws a bone from a joint
to its child, as Blender does, draws the hand):

- ``ROOT forearm``: the end of the forearm, `FOREARM_STUB` palm lengths behind the
  wrist along the hand's y axis, so that its bone ends at the wrist. Channels
  ``Xposition Yposition Zposition Xrotation Yrotation Zrotation``: its position and the
  palm's orientation in the file's axes. The file's axes are the camera frame turned
  by a rotation C about x (`UP_FROM_CAMERA`: 180° for y up, −90° for z up), and
  ``C Rx(rx) Ry(ry) Rz(rz) = Rx(rx + θ) Ry(ry) Rz(rz)``, so the rotation channels are
  ``rx + θ, ry, rz`` (BVH composes rotation channels in the order listed).
- per digit, a joint at the wrist (``<finger>_metacarpal``; ``thumb_carpal`` for the
  thumb, whose metacarpal is the model's first thumb bone), ``OFFSET 0 stub 0``,
  channels ``Yrotation Zrotation Xrotation`` always 0: the bone from the wrist to the
  digit's base joint (CMC for the thumb, MCP for the fingers).
- the digit's first bone (`BONES`: ``thumb_metacarpal``, ``index_proximal``, …) at its
  base joint, ``OFFSET`` = `HandShape.bases`, channels ``Yrotation Zrotation
  Xrotation`` = the Y-Z-X Euler angles of the model's ``Rz(s_k a_k) B_k Rx(f1)``
  (abduction, rest orientation `HandShape.base_rotations`, flexion); for a finger,
  whose ``B_k = Rz(γ_k)``, that is ``0, s_k a_k + γ_k, f1``. The Y-Z-X order keeps the
  middle angle within ±45° over the joint limits, far from gimbal lock; the angles are
  unwrapped over the frames so that a tool interpolating them does not spin.
- the second and third bones, ``OFFSET 0 L 0`` along their parent, channels
  ``0, 0, f`` (the flexion about x); an ``End Site`` at the fingertip.

The BVH joints' positions are then: the wrist joints at the wrist, each first bone at
the digit's CMC/MCP joint, the next two at the next joints, the end site at the tip:
the 21 points of G(x) (`bvh_joint_order`), times `UNITS` and turned by C.

BVH has a value of every channel on every frame and no way to hide the hand: a frame
without a hand (its pose NaN as a whole) holds the last tracked pose, or before the
first tracked frame the first one (`handvar.export.absent.held_poses`), so the motion
keeps the recording's frames and times.

Several hands (`hands_bvh_text`): one ROOT hierarchy per hand in one file, every joint's
name prefixed by the hand's side, a frame's line holding each hand's channels in turn.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from handvar.atomic import write_atomic
from handvar.export.absent import held_poses
from handvar.export.hands import checked_hands
from handvar.hand.anthropometry import BONES, HandShape, bone_index
from handvar.params import DIGITS
from handvar.validate import as_instance, one_of

__all__ = ["FOREARM_STUB", "UNITS", "UP_FROM_CAMERA", "bvh_joint_order", "bvh_text",
           "hands_bvh_text", "write_bvh", "write_hands_bvh"]  # fmt: skip

#: File units per millimetre for ``units``. Blender's BVH importer reads the numbers as
#: metres at its default scale 1, so "m" shows a hand ~0.18 m long.
UNITS = {"mm": 1.0, "cm": 0.1, "m": 1e-3}
#: The file's axes from the camera frame (x right, y down, z forward) for ``up``: a
#: rotation about x by 180° (y up: x, −y, −z) or by −90° (z up: x, z, −y), proper and
#: right-handed. The camera's viewing direction becomes −z (y up) or +y (z up): the
#: front view of Blender (which imports a y-up file with −Z forward) looks along it.
UP_FROM_CAMERA = {
    "y": np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
    "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
}
_UP_ANGLE = {"y": 180.0, "z": -90.0}  # UP_FROM_CAMERA[up] = Rx(_UP_ANGLE[up])
#: Length of the forearm stub, the root's bone, in palm lengths (wrist → middle MCP).
FOREARM_STUB = 0.3
_ROOT = "forearm"
_DEFAULT_FPS = 30.0
_ROT = "CHANNELS 3 Yrotation Zrotation Xrotation"


def _wrist_name(digit: int) -> str:
    return "thumb_carpal" if digit == 0 else f"{DIGITS[digit]}_metacarpal"


def bvh_joint_order(prefix: str = "") -> list[str]:
    """Name of the BVH joint (or ``<bone>_end`` for an end site) at each of the 21
    keypoints of G(x), in the order of `JOINTS`; the wrist is the middle finger's
    metacarpal joint (the five wrist joints all lie there). `prefix` starts every name
    (``"left_"``: a hand's joints in `hands_bvh_text`).

    Examples
    --------
    >>> bvh_joint_order()[:6]
    ['middle_metacarpal', 'thumb_metacarpal', 'thumb_proximal', 'thumb_distal', \
'thumb_distal_end', 'index_proximal']
    """
    names = [_wrist_name(2)]
    for k in range(5):
        bones = [BONES[bone_index(k, level)] for level in range(3)]
        names += [*bones, f"{bones[2]}_end"]
    return [prefix + name for name in names]


def _first_bone_angles(poses: np.ndarray, shape: HandShape, digit: int) -> np.ndarray:
    """(T, 3) the Y, Z, X angles (degrees, unwrapped over frames) of the digit's first
    bone, ``Rz(s a) B Rx(f1) = Ry(Y) Rz(Z) Rx(X)``."""
    abd = Rotation.from_euler("z", shape.abduction_sign[digit] * poses[:, 6 + digit, None],
                              degrees=True)  # fmt: skip
    flex = Rotation.from_euler("x", poses[:, 11 + 3 * digit, None], degrees=True)
    rot = abd * Rotation.from_matrix(shape.base_rotations[digit]) * flex
    with warnings.catch_warnings():
        # at the lock the angles returned still compose to `rot` (the first takes the
        # sum); the middle angle stays within ±45° over the joint limits anyway
        warnings.filterwarnings("ignore", message="Gimbal lock", category=UserWarning)
        angles = rot.as_euler("YZX", degrees=True)
    return np.unwrap(angles, period=360.0, axis=0)


def _fmt(values, decimals: int) -> str:
    return " ".join(f"{v:.{decimals}f}" for v in values)


def bvh_text(poses, shape: HandShape, *, fps: float | None = None, units: str = "m",
             up: str = "y") -> str:  # fmt: skip
    """The BVH file of a track (module docstring).

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees, camera (world) frame; NaN as a whole on a frame without a hand,
        which then holds a tracked pose (`held_poses`).
    shape : HandShape
        The tracked hand (either side).
    fps : float, keyword-only, optional
        Frame rate of the recording: ``Frame Time`` is 1 / fps; 30 when unknown.
    units : {"m", "cm", "mm"}, keyword-only
        Length unit of the file (`UNITS`); metres by default, as Blender reads BVH.
    up : {"y", "z"}, keyword-only
        The file's up axis (`UP_FROM_CAMERA`); y by default, which Blender, Maya and
        MotionBuilder import upright.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If no frame has a hand, a pose is NaN in part, or an option is unknown.
    """
    poses = held_poses(poses)
    as_instance(shape, HandShape, "shape")
    scale, turn, fps = _options(units, up, fps)
    lines, rows = _hand(poses, shape, scale, turn, up, prefix="")
    return _file(lines, [rows], poses.shape[0], fps)


def hands_bvh_text(hands, *, fps: float | None = None, units: str = "m",
                   up: str = "y") -> str:  # fmt: skip
    """The BVH file of several hands: one ROOT hierarchy per hand, in the order given.

    Each hand's hierarchy and channels are `bvh_text`'s, every joint's name prefixed
    with the hand's side (``right_forearm``, ``left_index_proximal``, …; `bvh_joint_order`
    with ``prefix``), so that the names are unique in the file; a frame's line holds
    the first hand's channels, then the next one's. A frame without a hand holds that
    hand's last tracked pose (`held_poses`), as `bvh_text` does.

    Parameters
    ----------
    hands : sequence of TrackedHand
        At most one of each side, over the same frames (`checked_hands`); each with a
        hand on some frame.
    fps, units, up : keyword-only
        As `bvh_text`.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If a hand has no frame with a hand, a pose is NaN in part, or an option is
        unknown.
    """
    hands = checked_hands(hands)
    scale, turn, fps = _options(units, up, fps)
    lines: list[str] = []
    rows = []
    for h in hands:
        poses = held_poses(h.poses, name=f"hands ({h.side}) poses")
        hierarchy, values = _hand(poses, h.hand.shape, scale, turn, up, prefix=f"{h.side}_")
        lines += hierarchy
        rows.append(values)
    return _file(lines, rows, len(rows[0]), fps)


def _options(units: str, up: str, fps):
    """The file's scale (units per mm), its turn from the camera frame, the frame rate."""
    scale = UNITS[one_of(units, tuple(UNITS), "units")]
    turn = UP_FROM_CAMERA[one_of(up, tuple(UP_FROM_CAMERA), "up")]
    fps = _DEFAULT_FPS if fps is None else float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate; got {fps}")
    return scale, turn, fps


def _hand(poses: np.ndarray, shape: HandShape, scale: float, turn: np.ndarray, up: str, *,
          prefix: str) -> tuple[list[str], list[str]]:  # fmt: skip
    """One hand's ROOT hierarchy (lines, its joints' names prefixed with `prefix`) and
    its channels' values per frame, formatted (module docstring)."""
    digits = 6 + round(float(-np.log10(scale)))  # lengths to a micron in any unit
    stub = FOREARM_STUB * float(np.linalg.norm(shape.bases[2]))  # palm length: wrist-MCP

    def offset(pad: str, xyz) -> str:
        return f"{pad}OFFSET {_fmt(np.asarray(xyz, float) * scale, digits)}"

    root = "CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation"
    lines = [f"ROOT {prefix}{_ROOT}", "{", offset("  ", (0.0, 0.0, 0.0)), f"  {root}"]
    for k in range(5):
        lines += [f"  JOINT {prefix}{_wrist_name(k)}", "  {", offset("    ", (0.0, stub, 0.0)),
                  f"    {_ROT}"]  # fmt: skip
        depth = 2
        for level in range(3):
            pad = "  " * depth
            at = shape.bases[k] if level == 0 else (0.0, shape.segments[k, level - 1], 0.0)
            lines += [f"{pad}JOINT {prefix}{BONES[bone_index(k, level)]}", pad + "{",
                      offset(pad + "  ", at), f"{pad}  {_ROT}"]  # fmt: skip
            depth += 1
        pad = "  " * depth
        lines += [f"{pad}End Site", pad + "{",
                  offset(pad + "  ", (0.0, shape.segments[k, 2], 0.0)), pad + "}"]  # fmt: skip
        for level in range(4, 0, -1):
            lines.append("  " * level + "}")
    lines.append("}")

    n = poses.shape[0]
    palm = Rotation.from_euler("XYZ", poses[:, 3:6], degrees=True).as_matrix()
    forearm = poses[:, 0:3] - stub * palm[:, :, 1]  # the forearm's end: wrist − stub·y
    values = np.zeros((n, 6 + 5 * 4 * 3))
    values[:, 0:3] = forearm @ turn.T * scale
    values[:, 3:6] = poses[:, 3:6] + [_UP_ANGLE[up], 0.0, 0.0]
    for k in range(5):
        col = 6 + 12 * k + 3  # after the wrist joint's three zeros
        values[:, col : col + 3] = _first_bone_angles(poses, shape, k)
        for level in (1, 2):
            values[:, col + 3 * level + 2] = poses[:, 11 + 3 * k + level]  # X: flexion
    rows = [" ".join([_fmt(row[:3], digits), _fmt(row[3:], 6)]) for row in values]
    return lines, rows


def _file(hierarchies: list[str], rows: list[list[str]], n: int, fps: float) -> str:
    """The BVH text: the hierarchies, then per frame the hands' channels on one line."""
    lines = ["HIERARCHY", *hierarchies, "MOTION", f"Frames: {n}", f"Frame Time: {1.0 / fps:.8f}"]
    lines += [" ".join(frame) for frame in zip(*rows, strict=True)]
    return "\n".join(lines) + "\n"


def write_bvh(path: str | os.PathLike, poses, shape: HandShape, *, fps=None, units="m",
              up="y") -> Path:  # fmt: skip
    """Write the BVH of a track (`bvh_text`, same options) to `path`, atomically."""
    text = bvh_text(poses, shape, fps=fps, units=units, up=up)
    write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return Path(path)


def write_hands_bvh(path: str | os.PathLike, hands, *, fps=None, units="m", up="y") -> Path:
    """Write the BVH of several hands (`hands_bvh_text`, same options) to `path`,
    atomically."""
    text = hands_bvh_text(hands, fps=fps, units=units, up=up)
    write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return Path(path)
