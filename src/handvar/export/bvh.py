"""The 26 parameters of a track as a BVH skeleton and its motion.

The skeleton is built from the `HandShape` so that BVH forward kinematics gives G(x)
exactly (`handvar.hand.kinematics`); every BVH channel is one of the model's angles or a
constant of the shape:

- ``ROOT hand`` (the palm, at the wrist): channels ``Xposition Yposition Zposition
  Xrotation Yrotation Zrotation`` = ``tx ty tz rx ry rz``; BVH composes rotation
  channels in the order listed, ``Rx(rx) Ry(ry) Rz(rz)``, which is the model's
  ``world_from_hand``.
- per digit, ``JOINT <digit>_base`` at the digit's base joint (``OFFSET`` =
  `HandShape.bases`), channels ``Zrotation Xrotation Yrotation`` =
  ``(s_k a_k + γ_k, α_k, β_k)``: the abduction ``Rz(s_k a_k)`` followed by the digit's
  rest orientation ``B_k = Rz(γ_k) Rx(α_k) Ry(β_k)`` (`HandShape.base_rotations`, whose
  Z-X-Y Euler angles are constants of the shape).
- below it the digit's three bones, ``JOINT <bone>`` with ``OFFSET 0 L 0`` along the
  parent bone (0 for the first) and channels ``Zrotation Xrotation Yrotation`` =
  ``(0, f, 0)``: the flexion about the bone's x axis; an ``End Site`` at the fingertip.

Lengths in mm, angles in degrees. The BVH joints' world positions are then: the root
at the wrist, each ``<digit>_base`` (and its first bone) at the CMC/MCP joint, the
second and third bones at the next two joints, the end site at the tip: the 21 points
of G(x) (`bvh_joint_order`).

BVH has a value of every channel on every frame: a frame without a hand (its pose NaN
as a whole) holds the last tracked pose, or before the first tracked frame the first
one (`handvar.export.absent.held_poses`), so the motion keeps the recording's frames.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from handvar.atomic import write_atomic
from handvar.export.absent import held_poses
from handvar.hand.anthropometry import BONES, HandShape, bone_index
from handvar.params import DIGITS
from handvar.validate import as_instance

__all__ = ["bvh_joint_order", "bvh_text", "write_bvh"]

_ROOT = "hand"
_DEFAULT_FPS = 30.0


def _base_name(digit: int) -> str:
    return f"{DIGITS[digit]}_base"


def bvh_joint_order() -> list[str]:
    """Name of the BVH joint (or ``<bone>_end`` for an end site) at each of the 21
    keypoints of G(x), in the order of `JOINTS`.

    Examples
    --------
    >>> bvh_joint_order()[:5]
    ['hand', 'thumb_base', 'thumb_proximal', 'thumb_distal', 'thumb_distal_end']
    """
    names = [_ROOT]
    for k in range(5):
        bones = [BONES[bone_index(k, level)] for level in range(3)]
        names += [_base_name(k), bones[1], bones[2], f"{bones[2]}_end"]
    return names


def _euler_zxy(matrices: np.ndarray) -> np.ndarray:
    """Angles (γ, α, β), degrees, with ``matrix = Rz(γ) Rx(α) Ry(β)``."""
    return Rotation.from_matrix(matrices).as_euler("ZXY", degrees=True)


def _fmt(values) -> str:
    return " ".join(f"{v:.6f}" for v in values)


def bvh_text(poses, shape: HandShape, *, fps: float | None = None) -> str:
    """The BVH file of a track (module docstring).

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without a hand, which then holds a
        tracked pose (`held_poses`).
    shape : HandShape
        The tracked hand (either side).
    fps : float, keyword-only, optional
        Frame rate of the motion; 30 when unknown.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If no frame has a hand, or a pose is NaN in part.
    """
    poses = held_poses(poses)
    as_instance(shape, HandShape, "shape")
    fps = _DEFAULT_FPS if fps is None else float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate; got {fps}")
    rest = _euler_zxy(shape.base_rotations)  # (5, 3): γ, α, β
    sign = shape.abduction_sign
    root = "CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation"
    lines = ["HIERARCHY", f"ROOT {_ROOT}", "{", "  OFFSET 0.000000 0.000000 0.000000", f"  {root}"]
    rot = "CHANNELS 3 Zrotation Xrotation Yrotation"
    for k in range(5):
        lines += ["  JOINT " + _base_name(k), "  {", f"    OFFSET {_fmt(shape.bases[k])}",
                  f"    {rot}"]  # fmt: skip
        depth = 2
        for level in range(3):
            pad = "  " * depth
            offset = 0.0 if level == 0 else shape.segments[k, level - 1]
            lines += [f"{pad}JOINT {BONES[bone_index(k, level)]}", pad + "{",
                      f"{pad}  OFFSET {_fmt((0.0, offset, 0.0))}", f"{pad}  {rot}"]  # fmt: skip
            depth += 1
        pad = "  " * depth
        tip = _fmt((0.0, shape.segments[k, 2], 0.0))
        lines += [f"{pad}End Site", pad + "{", f"{pad}  OFFSET {tip}", pad + "}"]
        for level in range(3, -1, -1):
            lines.append("  " * (level + 1) + "}")
    lines.append("}")

    n = poses.shape[0]
    values = np.zeros((n, 6 + 5 * 4 * 3))
    values[:, :6] = poses[:, :6]
    for k in range(5):
        col = 6 + 12 * k
        values[:, col] = sign[k] * poses[:, 6 + k] + rest[k, 0]
        values[:, col + 1] = rest[k, 1]
        values[:, col + 2] = rest[k, 2]
        for level in range(3):
            values[:, col + 3 * (level + 1) + 1] = poses[:, 11 + 3 * k + level]
    lines += ["MOTION", f"Frames: {n}", f"Frame Time: {1.0 / fps:.8f}"]
    lines += [_fmt(row) for row in values]
    return "\n".join(lines) + "\n"


def write_bvh(path: str | os.PathLike, poses, shape: HandShape, *, fps=None) -> Path:
    """Write the BVH of a track (`bvh_text`) to `path`, atomically."""
    text = bvh_text(poses, shape, fps=fps)
    write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return Path(path)
