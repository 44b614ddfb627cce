"""Segment lengths, joint positions and thickness of an adult hand from its size.

The skeleton has 16 bones (`BONES`): the palm and three bones per digit. For the
four fingers these are the proximal, middle and distal phalanges; for the thumb the
metacarpal, the proximal and the distal phalanx (the thumb's metacarpal moves at the
carpometacarpal (CMC) joint, the fingers' metacarpals are part of the rigid palm).

Lengths follow the proportions of Buchholz, Armstrong & Goldstein (1992),
"Anthropometric data for describing the kinematics of the human hand", *Ergonomics*
35(3), 261–273: every phalanx length is a fixed fraction of the hand length (wrist
crease to the tip of the middle finger), and the joint centres of the MCP joints and
of the thumb's CMC joint are fixed fractions of hand length (along the hand) and hand
breadth (across it). With these ratios the tip of the extended middle finger lies
0.99 hand lengths from the wrist.

Thickness (the radii of the sphere-mesh, see :mod:`handvar.hand.surface`) scales with
hand breadth; the fractions below give a 185 × 85 mm hand fingers of 19 mm (index,
proximal phalanx) tapering to 13 mm at the tip and a palm about 30 mm thick, as in
adult anthropometric surveys.

Hand frame (millimetres): origin at the wrist, x towards the thumb (radial) side,
y from the wrist towards the middle finger, z out of the palm (palmar side); a right
hand. A left hand (`HandShape.mirrored`, ``from_size(side="left")``) is its mirror image
in the hand frame's y–z plane, with the same parameters: x still points to the thumb
side, which for a left hand is −x of the right hand's frame (design §2). See
:mod:`handvar.params` for the signs of the joint angles.
"""

from __future__ import annotations

import enum
import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from handvar.params import DIGITS
from handvar.validate import as_array, as_instance, one_of, readonly

#: The 16 bones, in the order used by `HandModel.bone_frames` and by
#: `SurfaceSamples.bone`: the palm, then three bones per digit, proximal first.
BONES: tuple[str, ...] = (
    "palm",
    "thumb_metacarpal", "thumb_proximal", "thumb_distal",
    "index_proximal", "index_middle", "index_distal",
    "middle_proximal", "middle_middle", "middle_distal",
    "ring_proximal", "ring_middle", "ring_distal",
    "little_proximal", "little_middle", "little_distal",
)  # fmt: skip

#: The 21 keypoints returned by `HandModel.joints` (the paper's G(x), eq. 19–20), in the
#: common 21-keypoint order.
JOINTS: tuple[str, ...] = (
    "wrist",
    "thumb_cmc", "thumb_mcp", "thumb_ip", "thumb_tip",
    "index_mcp", "index_pip", "index_dip", "index_tip",
    "middle_mcp", "middle_pip", "middle_dip", "middle_tip",
    "ring_mcp", "ring_pip", "ring_dip", "ring_tip",
    "little_mcp", "little_pip", "little_dip", "little_tip",
)  # fmt: skip


class HandLandmark(enum.IntEnum):
    """The 21 points of `JOINTS` by name, MediaPipe's names (``HandLandmark.INDEX_FINGER_TIP``
    indexes a (21, ...) array as 8)."""

    WRIST = 0
    THUMB_CMC = 1
    THUMB_MCP = 2
    THUMB_IP = 3
    THUMB_TIP = 4
    INDEX_FINGER_MCP = 5
    INDEX_FINGER_PIP = 6
    INDEX_FINGER_DIP = 7
    INDEX_FINGER_TIP = 8
    MIDDLE_FINGER_MCP = 9
    MIDDLE_FINGER_PIP = 10
    MIDDLE_FINGER_DIP = 11
    MIDDLE_FINGER_TIP = 12
    RING_FINGER_MCP = 13
    RING_FINGER_PIP = 14
    RING_FINGER_DIP = 15
    RING_FINGER_TIP = 16
    PINKY_MCP = 17
    PINKY_PIP = 18
    PINKY_DIP = 19
    PINKY_TIP = 20


#: The fingertips, thumb to little finger.
FINGERTIPS: tuple[HandLandmark, ...] = (
    HandLandmark.THUMB_TIP, HandLandmark.INDEX_FINGER_TIP, HandLandmark.MIDDLE_FINGER_TIP,
    HandLandmark.RING_FINGER_TIP, HandLandmark.PINKY_TIP,
)  # fmt: skip
#: Indices into `JOINTS` of the wrist and the middle finger's MCP joint: the two points
#: that give a hand's size and direction in an image (keypoint scale, wrist cut).
WRIST, MIDDLE_MCP = JOINTS.index("wrist"), JOINTS.index("middle_mcp")
#: The digit (0 thumb … 4 little, `handvar.params.DIGITS`) each of `JOINTS` belongs to;
#: −1 for the wrist.
JOINT_DIGIT: tuple[int, ...] = (-1, *(i // 4 for i in range(20)))

#: Abduction sign per digit: abduction `a` turns the digit by ``Rz(ABDUCTION_SIGN[k]·a)``
#: about the palm normal, so positive values move the thumb, index and middle finger
#: towards +x (the thumb side) and the ring and little fingers towards −x.
ABDUCTION_SIGN = np.array([-1.0, -1.0, -1.0, 1.0, 1.0])
ABDUCTION_SIGN.flags.writeable = False
_LEFT_ABDUCTION_SIGN = readonly(-ABDUCTION_SIGN)

#: The sides a hand may be (`HandShape.side`).
SIDES: tuple[str, ...] = ("right", "left")


def other_side(side: str) -> str:
    """The other hand's side: "left" for "right" and back.

    Examples
    --------
    >>> other_side("right")
    'left'
    """
    return SIDES[1 - SIDES.index(side)]


def bone_index(digit: int, level: int) -> int:
    """Index into `BONES` of bone `level` (0 proximal … 2 distal) of digit `digit`."""
    return 1 + 3 * digit + level


@dataclass(frozen=True)
class HandProportions:
    """Anthropometric ratios of an adult hand (Buchholz, Armstrong & Goldstein 1992).

    All lengths are fractions of hand length HL (wrist crease to middle fingertip) or of
    hand breadth HB (across the palm at the MCP joints); angles in degrees. Digits are
    in the order thumb, index, middle, ring, little.

    Attributes
    ----------
    breadth_ratio : float
        Default hand breadth as a fraction of hand length (HB ≈ 0.46 HL, 85 mm for a
        185 mm hand).
    segments : 5 × 3 tuple of float
        Bone lengths / HL, proximal to distal: thumb metacarpal, proximal and distal
        phalanx; for each finger the proximal, middle and distal phalanx (to the tip).
    base_along, base_across : 5-tuples of float
        Joint centre of the thumb CMC and of the finger MCP joints: distance from the
        wrist along the hand (/HL, hand y) and across it towards the thumb (/HB, hand x).
    base_palmar : 5-tuple of float
        Height of those joint centres above the mid-plane of the palm, /HB (hand z).
        The trapezium sits on the palmar side of the carpus, the MCP joints in the plane.
    finger_splay : 4-tuple of float
        Rest direction of each finger in the palm plane, degrees towards the thumb
        side: the extended, adducted fingers fan out slightly.
    thumb_yaw, thumb_pitch, thumb_roll : float
        Rest orientation of the thumb's metacarpal: it leaves the CMC joint turned
        `thumb_yaw` from the hand's y axis towards the thumb side and `thumb_pitch` out
        of the palm plane; its flexion axis is rolled by `thumb_roll` about the bone so
        that flexion carries the thumb across the palm (towards −x and the palmar side),
        as the opposition of a real thumb does.
    radii : 5 × 4 tuple of float
        Digit thickness (sphere-mesh radius) / HB at the base joint (thumb CMC, finger
        MCP), the next two joints, and at the tip.
    palm_radius_knuckles, palm_radius_heel : float
        Radius / HB of the palm's cone-spheres at the MCP joints and at the heel of the
        hand. The knuckle value makes the palm exactly HB wide (0.251 + 0.402 + 2·0.1735
        = 1).
    palm_heel_along, palm_heel_narrowing : float
        The palm cone-spheres start `palm_heel_along` HL from the wrist, at
        `palm_heel_narrowing` times their MCP's distance from the hand's y axis
        (the palm narrows towards the wrist).
    thenar : 2 × 4 tuple of float
        The thenar eminence, a cone-sphere on the palm: each end is (across /HB,
        along /HL, palmar /HB, radius /HB).
    """

    breadth_ratio: float = 0.46
    segments: tuple[tuple[float, float, float], ...] = (
        (0.251, 0.196, 0.158),
        (0.245, 0.143, 0.097),
        (0.266, 0.170, 0.108),
        (0.244, 0.165, 0.107),
        (0.204, 0.117, 0.093),
    )
    base_along: tuple[float, ...] = (0.073, 0.447, 0.446, 0.409, 0.368)
    base_across: tuple[float, ...] = (0.196, 0.251, 0.000, -0.206, -0.402)
    base_palmar: tuple[float, ...] = (0.08, 0.0, 0.0, 0.0, 0.0)
    finger_splay: tuple[float, ...] = (3.0, 0.0, -4.0, -9.0)
    thumb_yaw: float = 38.0
    thumb_pitch: float = 12.0
    thumb_roll: float = -65.0
    radii: tuple[tuple[float, float, float, float], ...] = (
        (0.130, 0.118, 0.105, 0.094),
        (0.110, 0.097, 0.086, 0.078),
        (0.112, 0.100, 0.089, 0.080),
        (0.105, 0.094, 0.084, 0.076),
        (0.094, 0.084, 0.076, 0.069),
    )
    palm_radius_knuckles: float = 0.1735
    palm_radius_heel: float = 0.16
    palm_heel_along: float = 0.075
    palm_heel_narrowing: float = 0.65
    thenar: tuple[tuple[float, float, float, float], ...] = (
        (0.14, 0.10, 0.08, 0.17),
        (0.30, 0.26, 0.06, 0.13),
    )


def _rot_x(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _check(value, shape: tuple[int, ...], name: str, *, positive: bool = False) -> np.ndarray:
    arr = as_array(value, name, shape)
    if positive and not np.all(arr > 0):
        raise ValueError(f"{name}: expected positive values; got minimum {arr.min()}")
    return readonly(arr)


def _positive_mm(value, name: str) -> float:
    """`value` as a float, or raise naming `name` unless a positive number (mm)."""
    want = f"a positive hand {name} in mm"
    number = float(as_instance(value, numbers.Real, name, what=want))
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{name}: expected a positive hand {name} in mm; got {value!r}")
    return number


@dataclass(frozen=True, eq=False)
class HandShape:
    """The fixed geometry of one hand: bone lengths, joint positions, thickness.

    Build it with :meth:`from_size`; the constructor takes the arrays directly (for a
    hand measured or fitted otherwise) and checks them. Lengths in millimetres, all
    positions in the hand frame (see the module docstring). Digits in the order thumb,
    index, middle, ring, little.

    Attributes
    ----------
    segments : (5, 3) ndarray
        Length of the three bones of each digit, proximal to distal, mm. The last one
        ends at the fingertip (the surface of the distal cone-sphere touches it).
    bases : (5, 3) ndarray
        Joint centre of the thumb's CMC joint and of each finger's MCP joint, mm.
    base_rotations : (5, 3, 3) ndarray
        Rest orientation of each digit's proximal bone (hand_from_bone at zero angles).
        A bone's local y axis points along the bone, rotation about its local x axis
        by a positive angle is flexion (it turns y towards the local z axis).
    radii : (5, 4) ndarray
        Sphere radii of each digit at the base joint, the next two joints and the tip.
    palm_centres : (Q, 2, 3) ndarray
        End centres of the palm's cone-spheres (palm bone = hand frame), mm.
    palm_radii : (Q, 2) ndarray
        Their radii, mm.
    length, breadth : float
        The hand length and breadth this shape was made for, mm (informative).
    side : {"right", "left"}
        Which hand: a left hand is the mirror image of a right one (`mirrored`).

    Examples
    --------
    >>> shape = HandShape.from_size(185.0)
    >>> round(shape.breadth, 1), shape.segments.shape
    (85.1, (5, 3))
    """

    segments: np.ndarray
    bases: np.ndarray
    base_rotations: np.ndarray
    radii: np.ndarray
    palm_centres: np.ndarray
    palm_radii: np.ndarray
    length: float = 185.0
    breadth: float = 85.1
    side: str = "right"
    tip_offsets: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "segments", _check(self.segments, (5, 3), "segments", positive=True))
        set_(self, "bases", _check(self.bases, (5, 3), "bases"))
        rot = _check(self.base_rotations, (5, 3, 3), "base_rotations")
        eye = np.broadcast_to(np.eye(3), rot.shape)
        if not np.allclose(rot @ rot.transpose(0, 2, 1), eye, atol=1e-9) or np.any(
            np.linalg.det(rot) < 0
        ):
            raise ValueError("base_rotations: expected five rotation matrices; got others")
        set_(self, "base_rotations", rot)
        set_(self, "radii", _check(self.radii, (5, 4), "radii", positive=True))
        palm = np.asarray(self.palm_centres, dtype=float)
        if palm.ndim != 3 or palm.shape[1:] != (2, 3) or palm.shape[0] < 1:
            raise ValueError(f"palm_centres: expected shape (Q, 2, 3); got shape {palm.shape}")
        set_(self, "palm_centres", _check(palm, palm.shape, "palm_centres"))
        q = palm.shape[0]
        set_(self, "palm_radii", _check(self.palm_radii, (q, 2), "palm_radii", positive=True))
        for name in ("length", "breadth"):
            set_(self, name, _positive_mm(getattr(self, name), name))
        one_of(self.side, SIDES, "side")
        # The distal cone-sphere's last sphere touches the fingertip: its centre lies one
        # tip radius short of the end of the bone.
        tip = self.segments[:, 2] - self.radii[:, 3]
        if np.any(tip <= 0):
            raise ValueError("radii: expected tip radii shorter than the distal bones")
        set_(self, "tip_offsets", readonly(tip))

    @property
    def abduction_sign(self) -> np.ndarray:
        """(5,) abduction signs of this hand (`ABDUCTION_SIGN`, negated for a left hand)."""
        return ABDUCTION_SIGN if self.side == "right" else _LEFT_ABDUCTION_SIGN

    def mirrored(self) -> HandShape:
        """The same hand of the other side: its mirror image in the hand frame's y–z plane.

        With M = diag(−1, 1, 1): the digit bases and the palm's cone-sphere centres
        become M b, the digits' rest orientations M B M (rotations again: a reflection
        on both sides), and the abduction signs flip (M Rz(θ) M = Rz(−θ)); flexion,
        about a bone's x axis, keeps its sign (M Rx(θ) M = Rx(θ)). At any pose x every
        point of the mirrored hand is then the mirror image, in the plane of the hand's
        y and z axes, of the same point of this one (`tests/test_hand_side.py`).

        Examples
        --------
        >>> left = HandShape.from_size().mirrored()
        >>> left.side, left.mirrored().side
        ('left', 'right')
        """
        m = np.array([-1.0, 1.0, 1.0])
        return HandShape(
            segments=self.segments,
            bases=self.bases * m,
            base_rotations=self.base_rotations * m[None, :, None] * m[None, None, :],
            radii=self.radii,
            palm_centres=self.palm_centres * m,
            palm_radii=self.palm_radii,
            length=self.length,
            breadth=self.breadth,
            side=other_side(self.side),
        )

    @classmethod
    def from_size(
        cls,
        length: float = 185.0,
        breadth: float | None = None,
        *,
        proportions: HandProportions | None = None,
        side: str = "right",
    ) -> HandShape:
        """A hand of the given length and breadth with Buchholz et al. (1992) proportions.

        Parameters
        ----------
        length : float, optional
            Hand length (wrist crease to the tip of the middle finger), mm.
        breadth : float, optional
            Hand breadth across the MCP joints, mm; ``proportions.breadth_ratio ·
            length`` (85 mm for the default length) when omitted.
        proportions : HandProportions, optional
            The ratios; the published adult averages by default.
        side : {"right", "left"}, keyword-only
            Which hand (a left hand is the right one `mirrored`).

        Returns
        -------
        HandShape

        Examples
        --------
        >>> s = HandShape.from_size(200.0, 90.0)
        >>> round(float(s.segments[2].sum() + s.bases[2, 1]), 1)  # wrist to middle tip
        198.0
        """
        p = HandProportions() if proportions is None else proportions
        hl = _positive_mm(length, "length")
        hb = p.breadth_ratio * hl if breadth is None else _positive_mm(breadth, "breadth")

        segments = np.asarray(p.segments) * hl
        bases = np.stack(
            [np.asarray(p.base_across) * hb, np.asarray(p.base_along) * hl,
             np.asarray(p.base_palmar) * hb],
            axis=1,
        )  # fmt: skip
        # Thumb: yaw towards the radial side, pitch out of the palm, roll of the flexion
        # axis about the bone; fingers: a small splay in the palm plane.
        thumb = _rot_z(-p.thumb_yaw) @ _rot_x(p.thumb_pitch) @ _rot_y(p.thumb_roll)
        fingers = [_rot_z(-a) for a in p.finger_splay]
        rotations = np.stack([thumb, *fingers])
        radii = np.asarray(p.radii) * hb

        # Palm: one cone-sphere per finger ray, from the heel of the hand to the MCP
        # joint centre, and one for the thenar eminence.
        knuckles = bases[1:]
        heel = np.stack(
            [knuckles[:, 0] * p.palm_heel_narrowing, np.full(4, p.palm_heel_along * hl),
             np.zeros(4)],
            axis=1,
        )  # fmt: skip
        rays = np.stack([heel, knuckles], axis=1)
        ray_radii = np.tile([p.palm_radius_heel * hb, p.palm_radius_knuckles * hb], (4, 1))
        th = np.asarray(p.thenar)
        thenar = np.stack([th[:, 0] * hb, th[:, 1] * hl, th[:, 2] * hb], axis=1)
        palm_centres = np.concatenate([rays, thenar[None]], axis=0)
        palm_radii = np.concatenate([ray_radii, th[None, :, 3] * hb], axis=0)
        one_of(side, SIDES, "side")
        right = cls(
            segments=segments,
            bases=bases,
            base_rotations=rotations,
            radii=radii,
            palm_centres=palm_centres,
            palm_radii=palm_radii,
            length=hl,
            breadth=hb,
        )
        return right if side == "right" else right.mirrored()


__all__ = [
    "ABDUCTION_SIGN",
    "BONES",
    "DIGITS",
    "FINGERTIPS",
    "JOINTS",
    "JOINT_DIGIT",
    "SIDES",
    "HandLandmark",
    "HandProportions",
    "HandShape",
    "bone_index",
    "other_side",
]
