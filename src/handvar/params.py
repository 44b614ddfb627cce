"""The 26 hand parameters: names, units, limits, optimiser groups and VAR blocks.

The order follows design §2 and makes the block structure of the paper's
eq. 25 contiguous: palm translation (mm), palm orientation (degrees, intrinsic
x-y-z Euler angles), one abduction per digit (degrees), then three flexions per
digit (degrees), thumb first.

Sign conventions (hand frame: x towards the thumb side, y from the wrist towards
the middle finger, z out of the palm on its palmar side):

- flexion is positive when the digit curls towards the palm (+z);
- abduction is positive when the digit spreads away from the middle finger
  (for the middle finger itself: towards the thumb; for the thumb: away from
  the index finger, in the plane of the palm).
"""

from __future__ import annotations

import numpy as np

N_PARAMS = 26

DIGITS = ("thumb", "index", "middle", "ring", "little")

NAMES: tuple[str, ...] = (
    "tx", "ty", "tz",
    "rx", "ry", "rz",
    "abd_thumb", "abd_index", "abd_middle", "abd_ring", "abd_little",
    "thumb_cmc", "thumb_mcp", "thumb_ip",
    "index_mcp", "index_pip", "index_dip",
    "middle_mcp", "middle_pip", "middle_dip",
    "ring_mcp", "ring_pip", "ring_dip",
    "little_mcp", "little_pip", "little_dip",
)  # fmt: skip

UNITS: tuple[str, ...] = ("mm",) * 3 + ("deg",) * 23

TRANSLATION = slice(0, 3)
ROTATION = slice(3, 6)
ABDUCTION = slice(6, 11)
FLEXION = slice(11, 26)

# Joint limits (degrees; millimetres for the translation), anatomical ranges after
# Lee & Kunii (1995) and Cobos et al. (2008), slightly widened for hyperextension.
# Recorded real motion leaves them (the htrack recording on 47.5 % of its frames,
# studies/joint_limits.py; its replay is clamped).  Palm orientation is given two full
# turns so that clamping never cuts a continuous rotation.
_LIMITS = {
    "tx": (-2000.0, 2000.0), "ty": (-2000.0, 2000.0), "tz": (-2000.0, 2000.0),
    "rx": (-360.0, 360.0), "ry": (-360.0, 360.0), "rz": (-360.0, 360.0),
    "abd_thumb": (-20.0, 50.0), "abd_index": (-20.0, 25.0), "abd_middle": (-20.0, 20.0),
    "abd_ring": (-20.0, 20.0), "abd_little": (-20.0, 35.0),
    "thumb_cmc": (-20.0, 60.0), "thumb_mcp": (-15.0, 80.0), "thumb_ip": (-20.0, 90.0),
    "index_mcp": (-20.0, 90.0), "index_pip": (-5.0, 110.0), "index_dip": (-10.0, 90.0),
    "middle_mcp": (-20.0, 90.0), "middle_pip": (-5.0, 110.0), "middle_dip": (-10.0, 90.0),
    "ring_mcp": (-20.0, 90.0), "ring_pip": (-5.0, 110.0), "ring_dip": (-10.0, 90.0),
    "little_mcp": (-20.0, 90.0), "little_pip": (-5.0, 110.0), "little_dip": (-10.0, 90.0),
}  # fmt: skip

LOWER = np.array([_LIMITS[n][0] for n in NAMES])
UPPER = np.array([_LIMITS[n][1] for n in NAMES])
LOWER.flags.writeable = False
UPPER.flags.writeable = False

# Optimiser groups (paper §4: initial SMD gains 2.5 translation, 0.4 rotation,
# 0.2 finger and thumb joints).
GROUPS: tuple[str, ...] = ("translation",) * 3 + ("rotation",) * 3 + ("finger",) * 20


def index(name: str) -> int:
    """Position of parameter `name` in the vector."""
    try:
        return NAMES.index(name)
    except ValueError:
        raise ValueError(f"name: expected one of {', '.join(NAMES)}; got {name!r}") from None


def digit_angles(digit: int) -> list[int]:
    """Indices of the abduction and the three flexions of `digit` (0 thumb … 4 little).

    Examples
    --------
    >>> digit_angles(0), digit_angles(4)
    ([6, 11, 12, 13], [10, 23, 24, 25])
    """
    if not 0 <= digit < len(DIGITS):
        raise ValueError(f"digit: expected 0 to {len(DIGITS) - 1}; got {digit!r}")
    first = FLEXION.start + 3 * digit
    return [ABDUCTION.start + digit, first, first + 1, first + 2]


def hand_blocks() -> list[list[int]]:
    """The kinematic block structure of eq. 25 as a partition of parameter indices.

    The six palm parameters and the five abductions are each their own block (the
    diagonal G and R^Y of eq. 25); each digit's three flexions form one block (R^k).

    Examples
    --------
    >>> hand_blocks()[:2], hand_blocks()[-1]
    ([[0], [1]], [23, 24, 25])
    """
    singles = [[i] for i in range(11)]
    digits = [[11 + 3 * k, 12 + 3 * k, 13 + 3 * k] for k in range(5)]
    return singles + digits


def clamp(x: np.ndarray) -> np.ndarray:
    """Project a pose (or a stack of poses, last axis 26) onto the joint limits."""
    return np.clip(x, LOWER, UPPER)


def within_limits(x: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """True where every parameter of a pose lies inside its limits (last axis 26)."""
    x = np.asarray(x, dtype=float)
    return np.all((x >= LOWER - tol) & (x <= UPPER + tol), axis=-1)


def check_limits(x, name: str = "x") -> np.ndarray:
    """`x` (a pose, or poses on the last axis) if every parameter lies within its limits.

    Raises
    ------
    ValueError
        Naming `name`, the first parameter outside (and its frame, for several poses),
        its value and its limits.

    Examples
    --------
    >>> check_limits(np.r_[0.0, 0.0, 5e3, np.zeros(23)], "x")
    Traceback (most recent call last):
    ...
    ValueError: x: expected a pose within the parameter limits; tz = 5000 is outside [-2000, 2000]
    """
    x = np.asarray(x, dtype=float)
    outside = np.argwhere((x < LOWER) | (x > UPPER))
    if outside.size:
        *frame, i = (int(k) for k in outside[0])
        where = f" at frame {frame[0]}" if len(frame) == 1 else ""
        raise ValueError(
            f"{name}: expected a pose within the parameter limits; {NAMES[i]} = "
            f"{x[(*frame, i)]:g}{where} is outside [{LOWER[i]:g}, {UPPER[i]:g}]"
        )
    return x


def check_pose(x, name: str = "x") -> np.ndarray:
    """Return `x` as a float64 (26,) array, or raise ValueError naming `name`."""
    arr = np.asarray(x, dtype=float)
    if arr.shape != (N_PARAMS,):
        raise ValueError(f"{name}: expected a pose of shape (26,); got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name}: expected finite values; got NaN or infinity")
    return arr
