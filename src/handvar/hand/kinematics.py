"""Forward kinematics of the 26-parameter hand and its exact Jacobians.

`HandModel.joints` is the paper's G(x) (eq. 19–20): the 21 joint and fingertip
positions in the world frame, millimetres. `HandModel.points` moves any points attached
to bones and, on request, returns their derivatives with respect to all 26 parameters
in the same call; everything is vectorised over the five digits and over the points.

Frames and conventions (see also :mod:`handvar.params`):

- World from hand: ``p_world = R(rx, ry, rz) p_hand + t`` with ``R = Rx(rx) Ry(ry)
  Rz(rz)`` (intrinsic x-y-z Euler angles, degrees) and ``t = (tx, ty, tz)`` the wrist
  position (mm).
- Hand frame: origin at the wrist, x towards the thumb (radial) side, y from the wrist
  towards the middle finger, z out of the palm on its palmar side; a right hand.
- Bone frames: every bone's local y axis points along the bone from its proximal
  joint; its local origin is that joint. The palm bone's frame is the hand frame.
- Digit k (thumb, index, middle, ring, little) with abduction ``a`` and flexions
  ``f1, f2, f3`` (degrees)::

      hand_from_bone1 = Rz(s_k a) · B_k · Rx(f1),   origin b_k (CMC / MCP centre)
      hand_from_bone2 = hand_from_bone1 · Rx(f2),   origin b_k + L1 · y(bone1)
      hand_from_bone3 = hand_from_bone2 · Rx(f3),   origin + L2 · y(bone2)
      tip             = origin(bone3) + L3 · y(bone3)

  ``B_k`` is the digit's rest orientation (`HandShape.base_rotations`), ``s_k`` its
  abduction sign (`HandShape.abduction_sign`: for a right hand −1 for thumb, index,
  middle, so that positive abduction moves them towards +x, +1 for ring and little;
  negated for a left hand, `HandShape.mirrored`). Abduction is a rotation
  about the palm normal (hand z) through the base joint; the three flexions are
  rotations about one and the same axis, the local x axis of the proximal bone, which
  for the fingers is (about) the hand's x axis so that flexion turns the finger towards
  +z. For the thumb, `B_0` turns its metacarpal diagonally out of the palm (towards +x,
  +y and +z) and rolls its flexion axis so that flexion carries the thumb towards −x
  and +z: a flexed thumb lies across the palm.

Jacobians (degrees for angles, hence the factor π/180): translation is the identity;
Euler angles ``dp/drx = (dR/drx) p_hand`` etc.; a revolute joint with world axis ω
through the world point a contributes ``ω × (p − a)``. The Euler angles are revolute
joints too (``dR/drx Rᵀ`` is the cross-product matrix of the world x axis, and so on),
so every column is linear in p (`_Pose.linear_jacobian`).

Two routes compute the same numbers: compiled loops (numba, ``cache=True``; the
default) and vectorised numpy (``HandModel(compiled=False)``, the reference the tests
compare with). ``benchmarks/hand.py`` prints their speed.
"""

from __future__ import annotations

import math
import threading

import numpy as np
from numba import njit

from handvar.hand.anthropometry import BONES, JOINTS, HandShape, bone_index
from handvar.params import N_PARAMS, check_pose
from handvar.validate import as_instance, as_int, one_of

DEG = math.pi / 180.0
N_BONES = len(BONES)
N_JOINTS = len(JOINTS)

# Parameter column of each of the (up to) four joints that move a bone: abduction and
# the three flexions of its digit, in that order; N_PARAMS marks "no joint" (a spare
# column that is dropped).
_BONE_COLS = np.full((N_BONES, 4), N_PARAMS, dtype=np.intp)
for _k in range(5):
    for _level in range(3):
        _b = bone_index(_k, _level)
        _BONE_COLS[_b, 0] = 6 + _k
        _BONE_COLS[_b, 1 : 2 + _level] = 11 + 3 * _k + np.arange(_level + 1)
_BONE_COLS.flags.writeable = False
# 1 where parameter i moves bone b: the palm pose moves every bone, a joint its digit's
# bones from its own level on.
_BONE_MASK = np.zeros((N_BONES, N_PARAMS + 1))
_BONE_MASK[:, :6] = 1.0
_BONE_MASK[np.arange(N_BONES)[:, None], _BONE_COLS] = 1.0
_BONE_MASK = np.ascontiguousarray(_BONE_MASK[:, :N_PARAMS])
_BONE_MASK.flags.writeable = False
_NO_A = np.zeros((4, 3 * N_PARAMS))  # placeholders for the compiled loop without Jacobian
_NO_J = np.zeros((0, 3, N_PARAMS))

# The bone each of the 21 points of G(x) is attached to (its position in that bone's
# frame depends on the shape for the tips: `HandModel.joint_attachment`).
_JOINT_BONE = np.array(
    [0] + [bone_index(k, lv) for k in range(5) for lv in (0, 1, 2, 2)], dtype=np.intp
)
_JOINT_BONE.flags.writeable = False


def _euler_matrix(angles_deg) -> np.ndarray:
    """``Rx(rx) Ry(ry) Rz(rz)`` for angles in degrees, (3, 3)."""
    rx, ry, rz = (float(a) * DEG for a in angles_deg)
    cx, sx = math.cos(rx), math.sin(rx)
    cy, sy = math.cos(ry), math.sin(ry)
    cz, sz = math.cos(rz), math.sin(rz)
    return np.array(
        [
            [cy * cz, -cy * sz, sy],
            [cx * sz + sx * sy * cz, cx * cz - sx * sy * sz, -sx * cy],
            [sx * sz - cx * sy * cz, sx * cz + cx * sy * sz, cx * cy],
        ]
    )


def world_from_hand_rotation(angles_deg) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``R = Rx(rx) Ry(ry) Rz(rz)`` and its derivatives.

    Parameters
    ----------
    angles_deg : (3,) array_like
        ``(rx, ry, rz)``, degrees (intrinsic x-y-z Euler angles).

    Returns
    -------
    R : (3, 3) ndarray
        world_from_hand rotation.
    dR : (3, 3, 3) ndarray
        ``dR[i] = dR / d angle_i`` per **radian**.

    Examples
    --------
    >>> R, dR = world_from_hand_rotation([180.0, 0.0, 0.0])
    >>> R.round(12) + 0.0
    array([[ 1.,  0.,  0.],
           [ 0., -1.,  0.],
           [ 0.,  0., -1.]])
    """
    rx, ry, rz = (float(a) * DEG for a in angles_deg)
    cx, sx = math.cos(rx), math.sin(rx)
    cy, sy = math.cos(ry), math.sin(ry)
    cz, sz = math.cos(rz), math.sin(rz)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    dRx = np.array([[0.0, 0.0, 0.0], [0.0, -sx, -cx], [0.0, cx, -sx]])
    dRy = np.array([[-sy, 0.0, cy], [0.0, 0.0, 0.0], [-cy, 0.0, -sy]])
    dRz = np.array([[-sz, -cz, 0.0], [cz, -sz, 0.0], [0.0, 0.0, 0.0]])
    RyRz = Ry @ Rz
    R = Rx @ RyRz
    dR = np.stack([dRx @ RyRz, Rx @ dRy @ Rz, Rx @ Ry @ dRz])
    return R, dR


def euler_from_matrix(R) -> np.ndarray:
    """Intrinsic x-y-z Euler angles of rotation matrices: the inverse of ``Rx Ry Rz``.

    With ``R = Rx(a) Ry(b) Rz(c)`` (`world_from_hand_rotation`):
    ``R[0, 2] = sin b``, ``R[1, 2] = −sin a cos b``, ``R[2, 2] = cos a cos b``,
    ``R[0, 1] = −cos b sin c``, ``R[0, 0] = cos b cos c``.  At gimbal lock
    (``cos b = 0``) ``c = 0`` is chosen and ``a`` taken from ``R[2, 1] = sin a`` (for
    ``b = +90°``) or its opposite.

    Parameters
    ----------
    R : (..., 3, 3) array_like
        Rotation matrices.

    Returns
    -------
    (..., 3) ndarray
        ``(a, b, c) = (rx, ry, rz)``, degrees, a and c in (−180, 180], b in [−90, 90].
    """
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"R: expected rotation matrices of shape (..., 3, 3); got {R.shape}")
    cb = np.hypot(R[..., 0, 0], R[..., 0, 1])
    b = np.arctan2(R[..., 0, 2], cb)
    locked = cb < 1e-9
    a = np.where(
        locked, np.arctan2(R[..., 2, 1], R[..., 1, 1]), np.arctan2(-R[..., 1, 2], R[..., 2, 2])
    )
    c = np.where(locked, 0.0, np.arctan2(-R[..., 0, 1], R[..., 0, 0]))
    return np.degrees(np.stack([a, b, c], axis=-1))


class _Pose:
    """Forward kinematics of one pose, in the world frame (cached by HandModel).

    Because the three flexions of a digit share one axis, bone l of digit k has the
    orientation ``R · Rz(s_k a_k) B_k · Rx(f1 + … + fl)``: its x axis is that of the
    digit's base, its y and z axes are ``cos F · b_y + sin F · b_z`` and
    ``−sin F · b_y + cos F · b_z`` with F the cumulative flexion.
    """

    __slots__ = (
        "_compiled", "_euler_axes", "_linear", "anchors", "axes", "joints", "origins",
        "rotations", "t",
    )  # fmt: skip

    def __init__(self, shape: HandShape, x: np.ndarray, compiled: bool = True) -> None:
        self._compiled = compiled
        self._linear: np.ndarray | None = None
        if compiled:
            self.t = x[0:3].copy()
            self.rotations = np.empty((N_BONES, 3, 3))
            self.origins = np.empty((N_BONES, 3))
            self.axes = np.empty((5, 4, 3))
            self.anchors = np.empty((5, 4, 3))
            self.joints = np.empty((N_JOINTS, 3))
            self._euler_axes = np.empty((3, 3))
            _fk_kernel(
                x, shape.bases, shape.base_rotations, shape.segments, shape.abduction_sign,
                self.rotations, self.origins, self.axes, self.anchors, self.joints,
                self._euler_axes,
            )  # fmt: skip
            return
        t = x[0:3].copy()
        R = _euler_matrix(x[3:6])
        ang = x[6:26] * DEG
        cos, sin = np.cos(ang), np.sin(ang)
        sign = shape.abduction_sign
        ca, sa = cos[:5], sin[:5] * sign  # Rz(s_k a_k)
        # base_k = R · Rz(s_k a_k) · B_k, (5, 3, 3)
        B = shape.base_rotations
        rzb = np.empty((5, 3, 3))
        rzb[:, 0] = ca[:, None] * B[:, 0] - sa[:, None] * B[:, 1]
        rzb[:, 1] = sa[:, None] * B[:, 0] + ca[:, None] * B[:, 1]
        rzb[:, 2] = B[:, 2]
        base = R @ rzb
        bx, by, bz = base[:, :, 0], base[:, :, 1], base[:, :, 2]  # (5, 3) world
        cum = np.cumsum(x[11:26].reshape(5, 3), axis=1) * DEG  # cumulative flexion F
        cf, sf = np.cos(cum)[..., None], np.sin(cum)[..., None]  # (5, 3, 1)
        Y = cf * by[:, None] + sf * bz[:, None]  # (5, 3 levels, 3)
        Z = cf * bz[:, None] - sf * by[:, None]
        o1 = shape.bases @ R.T + t  # (5, 3)
        chain = o1[:, None] + np.cumsum(shape.segments[..., None] * Y, axis=1)  # o2, o3, tip

        rotations = np.empty((N_BONES, 3, 3))
        rotations[0] = R
        rot = rotations[1:].reshape(5, 3, 3, 3)  # (digit, level, row, col)
        rot[..., 0] = bx[:, None]
        rot[..., 1] = Y
        rot[..., 2] = Z
        origins = np.empty((N_BONES, 3))
        origins[0] = t
        org = origins[1:].reshape(5, 3, 3)
        org[:, 0] = o1
        org[:, 1:] = chain[:, :2]
        # Revolute joints of each digit (world): abduction about s_k · (R z) through o1;
        # the three flexions about b_x through o1, o2, o3.
        axes = np.empty((5, 4, 3))
        axes[:, 0] = sign[:, None] * R[:, 2]
        axes[:, 1:] = bx[:, None]
        anchors = np.empty((5, 4, 3))
        anchors[:, 0] = o1
        anchors[:, 1:] = org
        joints = np.empty((N_JOINTS, 3))
        joints[0] = t
        jnt = joints[1:].reshape(5, 4, 3)
        jnt[:, 0] = o1
        jnt[:, 1:] = chain

        # world axes of the Euler angles: e_x, Rx e_y, Rx Ry e_z (dR_i Rᵀ = [axis_i]×)
        rx, ry = x[3] * DEG, x[4] * DEG
        cx, sx, cy, sy = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry)
        self._euler_axes = np.array([[1.0, 0.0, 0.0], [0.0, cx, sx], [sy, -sx * cy, cx * cy]])
        self.t = t
        self.rotations = rotations  # world_from_bone, (16, 3, 3)
        self.origins = origins  # (16, 3)
        self.axes = axes  # (5, 4, 3)
        self.anchors = anchors  # (5, 4, 3)
        self.joints = joints  # (21, 3)

    def linear_jacobian(self) -> np.ndarray:
        """(4, 78) matrix A with ``J(p) = [p, 1] A`` reshaped to (3, 26), unmasked.

        Every angle is a revolute joint: the Euler angles turn the hand about the world
        axes ``e_x``, ``Rx e_y`` and ``Rx Ry e_z`` through the wrist (``dR_i Rᵀ`` is the
        cross-product matrix of those axes), the articulation about the axes above.
        Column i of the Jacobian of a point p moved by joint i is therefore
        ``(π/180) ω_i × (p − a_i) = (π/180) [ω_i]× (p − a_i)``, linear in p; translation
        columns are constant (identity). Columns of joints that do not move a point's
        bone are zeroed afterwards by a per-bone mask.
        """
        if self._linear is None and self._compiled:
            A = np.empty((4, 3 * N_PARAMS))
            _linear_kernel(self._euler_axes, self.t, self.axes, self.anchors, A)
            self._linear = A
        if self._linear is None:
            omega = np.empty((N_PARAMS, 3))
            anchor = np.empty((N_PARAMS, 3))
            omega[0:3] = 0.0
            anchor[0:3] = 0.0
            omega[3:6] = self._euler_axes
            anchor[3:6] = self.t
            omega[6:11] = self.axes[:, 0]
            anchor[6:11] = self.anchors[:, 0]
            omega[11:26] = np.repeat(self.axes[:, 1], 3, axis=0)
            anchor[11:26] = self.anchors[:, 1:].reshape(15, 3)
            omega *= DEG
            # A[m, r, col] = [ω_col]×[r, m] for m < 3;  A[3, r, col] = −(ω_col × a_col)_r
            wx, wy, wz = omega[:, 0], omega[:, 1], omega[:, 2]
            ax, ay, az = anchor[:, 0], anchor[:, 1], anchor[:, 2]
            A = np.zeros((4, 3, N_PARAMS))
            A[1, 0], A[2, 0] = -wz, wy  # row r = 0: (ω × p)_x = ω_y p_z − ω_z p_y
            A[0, 1], A[2, 1] = wz, -wx
            A[0, 2], A[1, 2] = -wy, wx
            A[3, 0] = wz * ay - wy * az
            A[3, 1] = wx * az - wz * ax
            A[3, 2] = wy * ax - wx * ay
            A[3, 0, 0] = A[3, 1, 1] = A[3, 2, 2] = 1.0  # translation: identity
            self._linear = A.reshape(4, 3 * N_PARAMS)
        return self._linear


def _check_bone_local(bone, local, *, values: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """`bone` as (N,) intp and `local` as (N, 3) float64 arrays, or raise.

    Shapes and dtypes are always checked (a few attribute look-ups); with `values`
    also the bone range and finite coordinates (full passes over the data). The
    compiled route checks the values inside its loop at no extra cost, and calls this
    with ``values=True`` only to name what is wrong.
    """
    b = np.asarray(bone)
    if b.ndim != 1:
        raise ValueError(f"bone: expected a (N,) array of bone indices; got shape {b.shape}")
    if b.size and b.dtype.kind not in "iu":
        raise TypeError(f"bone: expected integer bone indices; got dtype {b.dtype}")
    loc = np.asarray(local, dtype=float)
    if loc.shape != (b.shape[0], 3):
        raise ValueError(
            f"local: expected shape ({b.shape[0]}, 3) to match bone; got shape {loc.shape}"
        )
    if values and b.size and (b.min() < 0 or b.max() >= N_BONES):
        raise ValueError(
            f"bone: expected indices in 0..{N_BONES - 1}; got values {b.min()}..{b.max()}"
        )
    if values and not np.all(np.isfinite(loc)):
        raise ValueError("local: expected finite coordinates; got NaN or infinity")
    return b.astype(np.intp, copy=False), loc


class HandModel:
    """The kinematic hand with its sphere-mesh surface.

    Parameters
    ----------
    shape : HandShape, optional
        Bone lengths, joint positions and thickness; a 185 mm hand
        (`HandShape.from_size()`) by default.
    pool_size : int, optional
        Number of precomputed surface samples `sample_surface` draws from (built on
        first use, see :mod:`handvar.hand.surface`).
    compiled : bool, optional
        Compute the kinematics with compiled loops (numba, default) or with the
        vectorised numpy reference; both agree to rounding.
    surface : {"spheres", "mesh"}, optional
        The surface that renders the hand: the sphere-mesh (default) or the skinned
        mesh (`mesh`, :mod:`handvar.hand.mesh`, design §15). Both are driven by the
        same bone frames, so G(x) is the same; the sphere-mesh stays available either
        way (`world_spheres`).
    tips : {"end", "pad"}, optional
        Which 21 points the model reports (`landmarks`): G(x) itself ("end", default),
        or the points a detector marks, the fingertips at their pads and the thumb's
        base up its metacarpal ("pad", `keypoint_points`; design §14.6).

    Attributes
    ----------
    shape : HandShape
    tips : str
        Which 21 points `landmarks` reports.
    primitives : Primitives
        The cone-spheres of the surface: ``bone (P,)``, ``centres (P, 2, 3)`` in their
        bone's frame, ``radii (P, 2)``.

    Notes
    -----
    The constructor is cheap (no sampling, no caches filled). The model keeps the
    forward kinematics of the last pose it was given, so several calls with the same
    `x` (points, spheres, projections of one optimiser iteration) compute it once.

    Examples
    --------
    >>> model = HandModel()
    >>> G = model.joints(named_pose("open"))
    >>> G.shape
    (21, 3)
    """

    n_params = N_PARAMS

    def __init__(
        self,
        shape: HandShape | None = None,
        *,
        pool_size: int = 100_000,
        compiled: bool = True,
        surface: str = "spheres",
        tips: str = "end",
    ) -> None:
        from handvar.hand.surface import hand_primitives

        one_of(tips, TIPS, "tips")

        if shape is None:
            shape = HandShape.from_size()
        as_instance(shape, HandShape, "shape")
        pool_size = as_int(pool_size, "pool_size", minimum=1000)
        self.shape = shape
        self.primitives = hand_primitives(shape)
        self.pool_size = pool_size
        self.compiled = bool(compiled)
        local = np.zeros((N_JOINTS, 3))
        local[4::4, 1] = shape.segments[:, 2]  # fingertips: end of the distal bones
        self._joint_local = local
        self.tips = tips
        self._cache: tuple[bytes, _Pose] | None = None
        self._pool = None
        self._lock = threading.Lock()
        self._init_surface(surface)

    # -- forward kinematics ---------------------------------------------------------
    def _pose(self, x) -> _Pose:
        arr = np.asarray(x, dtype=float)
        key = arr.tobytes()
        cached = self._cache
        if cached is not None and arr.shape == (N_PARAMS,) and cached[0] == key:
            return cached[1]  # checked when it was cached
        x = check_pose(arr)
        pose = _Pose(self.shape, x, self.compiled)
        self._cache = (key, pose)
        return pose

    def bone_frames(self, x) -> tuple[np.ndarray, np.ndarray]:
        """World poses of the 16 bones.

        Parameters
        ----------
        x : (26,) array_like
            Pose (mm, degrees).

        Returns
        -------
        rotations : (16, 3, 3) ndarray
            world_from_bone rotations, in the order of `BONES`.
        origins : (16, 3) ndarray
            World position of each bone's proximal joint (the palm's: the wrist), mm.
        """
        pose = self._pose(x)
        return pose.rotations.copy(), pose.origins.copy()

    def joints(self, x) -> np.ndarray:
        """G(x) (eq. 19–20): the 21 joint and fingertip positions, (21, 3), mm, world.

        Order (`JOINTS`): wrist; thumb CMC, MCP, IP, tip; then index, middle, ring,
        little finger MCP, PIP, DIP, tip.
        """
        return self._pose(x).joints.copy()

    def landmarks(self, x) -> np.ndarray:
        """The 21 points the model reports at pose `x`, (21, 3) mm, world, in G(x)'s
        order: G(x) with ``tips="end"``, the points a detector marks with ``"pad"``
        (`keypoint_points`).  What a track's joints, keypoint files, overlays and viewer
        show."""
        return keypoint_points(self, x, self.tips)

    def joints_jacobian(self, x) -> np.ndarray:
        """d G / d x: (21, 3, 26), mm per mm (translation) or mm per degree (angles)."""
        return self.joints_with_jacobian(x)[1]

    def joints_with_jacobian(self, x) -> tuple[np.ndarray, np.ndarray]:
        """G(x) and d G / d x together: (21, 3) mm and (21, 3, 26)."""
        return self.points(x, _JOINT_BONE, self._joint_local, jacobian=True)

    def joint_attachment(self) -> tuple[np.ndarray, np.ndarray]:
        """Where the 21 points of G(x) sit: each one's bone, (21,) int, and its position
        in that bone's frame, (21, 3) mm (the tips at the end of the distal bones), as
        `points` takes them."""
        return _JOINT_BONE, self._joint_local.copy()

    def points(self, x, bone, local, jacobian: bool = False):
        """World positions of points attached to bones, and optionally d points / d x.

        Parameters
        ----------
        x : (26,) array_like
            Pose (mm, degrees).
        bone : (N,) int array_like
            Bone of each point (index into `BONES`).
        local : (N, 3) array_like
            Each point in its bone's frame, mm.
        jacobian : bool, optional
            Also return the Jacobian.

        Returns
        -------
        points : (N, 3) ndarray
            World positions, mm.
        J : (N, 3, 26) ndarray
            Only with ``jacobian=True``: ``J[n, :, i] = d points[n] / d x[i]``, in mm per
            mm for the translation and mm per degree for the angles.
        """
        pose = self._pose(x)
        if self.compiled:
            b, loc = _check_bone_local(bone, local, values=False)
            n = b.shape[0]
            p = np.empty((n, 3))
            J = np.empty((n, 3, N_PARAMS)) if jacobian else _NO_J
            A = pose.linear_jacobian() if jacobian else _NO_A
            if _points_kernel(pose.rotations, pose.origins, b, loc, A, _BONE_MASK, p, J,
                              jacobian) >= 0:  # fmt: skip
                _check_bone_local(bone, local)  # names the bad index or coordinate
            return (p, J) if jacobian else p
        bone, local = _check_bone_local(bone, local)
        p = np.einsum("nij,nj->ni", pose.rotations[bone], local)
        p += pose.origins[bone]
        if not jacobian:
            return p
        return p, _points_jacobian(pose, bone, p)

    # -- surface --------------------------------------------------------------------
    def world_spheres(self, x, jacobian: bool = False):
        """The cone-spheres' end spheres in the world frame.

        Parameters
        ----------
        x : (26,) array_like
            Pose.
        jacobian : bool, optional
            Also return d centres / d x.

        Returns
        -------
        centres : (P, 2, 3) ndarray
            World centres, mm.
        radii : (P, 2) ndarray
            Radii, mm (independent of the pose).
        J : (P, 2, 3, 26) ndarray
            Only with ``jacobian=True``.
        """
        prim = self.primitives
        bone = np.repeat(prim.bone, 2)
        local = prim.centres.reshape(-1, 3)
        n = prim.bone.shape[0]
        if jacobian:
            c, J = self.points(x, bone, local, jacobian=True)
            return c.reshape(n, 2, 3), prim.radii.copy(), J.reshape(n, 2, 3, N_PARAMS)
        c = self.points(x, bone, local)
        return c.reshape(n, 2, 3), prim.radii.copy()

    def sample_surface(self, n: int, rng: np.random.Generator, *, exposed: bool = True):
        """Area-uniform random points on the model surface, in bone coordinates.

        See :meth:`handvar.hand.surface.SurfacePool.draw`. The pool of candidate samples
        is built on the first call (under a second) and reused.

        Parameters
        ----------
        n : int
            Number of samples.
        rng : numpy.random.Generator
            Source of randomness.
        exposed : bool, optional
            Only samples of the union's outer surface (True, default) or of every
            primitive's own surface (False).

        Returns
        -------
        SurfaceSamples
        """
        return self.surface_pool.draw(n, rng, exposed=exposed)

    @property
    def surface_pool(self):
        """The `SurfacePool` of this model (built on first access)."""
        if self._pool is None:
            from handvar.hand.surface import SurfacePool

            with self._lock:
                if self._pool is None:
                    rest = self.bone_frames(np.zeros(N_PARAMS))
                    self._pool = SurfacePool(
                        self.primitives, rest, size=self.pool_size, parents=_parents()
                    )
        return self._pool

    def intersect_rays(self, x, origins, directions, *, return_primitive: bool = False):
        """First intersection of rays with the model surface.

        Parameters
        ----------
        x : (26,) array_like
            Pose.
        origins : (N, 3) array_like
            Ray origins, world, mm; assumed outside the model.
        directions : (N, 3) array_like
            Ray directions (need not be unit vectors).
        return_primitive : bool, optional
            Also return the index of the primitive hit (−1 for a miss).

        Returns
        -------
        depth : (N,) ndarray
            Ray parameter of the first hit, ``hit = origin + depth · direction``
            (the distance in mm for unit directions); ``inf`` for a miss.
        primitive : (N,) int ndarray
            Only with ``return_primitive=True``.
        """
        from handvar.geometry.cone_spheres import intersect_cone_spheres

        centres, radii = self.world_spheres(x)
        return intersect_cone_spheres(
            centres, radii, origins, directions, return_primitive=return_primitive
        )

    def project_primitives(self, x, camera):
        """The model's primitives as seen by a camera (circle approximation).

        See :func:`handvar.hand.projection.project_cone_spheres`.

        Returns
        -------
        ProjectedPrimitives
            ``centres (P, 2, 2)`` pixels, ``radii (P, 2)`` pixels, ``depth (P, 2)`` mm.
        """
        from handvar.hand.projection import project_cone_spheres

        centres, radii = self.world_spheres(x)
        return project_cone_spheres(centres, radii, camera)[0]

    def closest_projected_point(self, x, camera, pixels):
        """Closest point of the model's image to each pixel, and its Jacobian.

        The h_ij(x) of the filling cost (eq. 1). Each end sphere of a primitive is
        imaged as a circle (centre: the projection of the sphere's centre, radius:
        ``f r / sqrt(depth² − r²)``, ``f = (fx + fy) / 2``), each primitive as the convex hull
        of its two circles; the model's image is the union of these hulls.

        Parameters
        ----------
        x : (26,) array_like
            Pose.
        camera : Camera
            `handvar.camera.Camera`.
        pixels : (M, 2) array_like
            Pixel coordinates.

        Returns
        -------
        h : (M, 2) ndarray
            Closest point of the model's image, pixels; equal to the pixel where the
            model covers it.
        dh : (M, 2, 26) ndarray
            ``d h / d x`` (zero where the model covers the pixel), pixels per mm /
            pixels per degree.
        """
        from handvar.hand.projection import closest_point_projected

        centres, radii, J = self.world_spheres(x, jacobian=True)
        return closest_point_projected(centres, radii, J, camera, pixels)

    # -- the skinned mesh (design §15) -----------------------------------------------
    def _init_surface(self, surface: str) -> None:
        if surface not in SURFACES:
            raise ValueError(f"surface: expected one of {', '.join(SURFACES)}; got {surface!r}")
        if surface == "mesh" and self.shape.side != "right":
            raise ValueError(
                f"surface: expected 'spheres' for a {self.shape.side} hand (the skinned mesh "
                f"is a right hand); got 'mesh'"
            )
        self.surface = surface
        self._mesh = None

    @property
    def mesh(self):
        """The skinned mesh registered to this model's shape (`MeshSurface`, built once)."""
        if self._mesh is None:
            from handvar.hand.mesh import MeshSurface

            with self._lock:
                if self._mesh is None:
                    self._mesh = MeshSurface(self)
        return self._mesh


#: Surfaces a `HandModel` renders with.
SURFACES: tuple[str, ...] = ("spheres", "mesh")


#: Where the detected fingertips are compared with the model (design §14.6): the end of
#: the distal bone, G(x)'s tip ("end"), or the centre of the fingertip's pad with the
#: thumb's base up its metacarpal ("pad").
TIPS = ("end", "pad")
#: Where a detector marks the thumb's base with ``tips="pad"``: this share of the thumb
#: metacarpal's length from the carpometacarpal joint towards the MCP.  MediaPipe's
#: median on the realistic benchmark's renders, against the true joints (quartiles 0.31
#: and 0.43; `studies/detector_joints.py --cases DIR`).
THUMB_BASE = 0.36


def keypoint_attachment(hand, tips: str = "end") -> tuple[np.ndarray, np.ndarray]:
    """Where the 21 points compared with keypoints sit on the hand's bones.

    Parameters
    ----------
    hand : HandModel
    tips : {"end", "pad"}
        G(x)'s points (`HandModel.joint_attachment`), or the points a detector marks:
        each fingertip one tip radius short of the end, at the centre of its pad
        (``HandShape.tip_offsets``), and the thumb's base `THUMB_BASE` up its
        metacarpal (design §14.6).

    Returns
    -------
    bone : (21,) int ndarray
        Each point's bone (index into `BONES`).
    local : (21, 3) ndarray
        Its position in that bone's frame, mm.

    Examples
    --------
    >>> hand = HandModel()
    >>> _, end = keypoint_attachment(hand)
    >>> _, pad = keypoint_attachment(hand, "pad")
    >>> [round(float(d), 1) for d in end[4::4, 1] - pad[4::4, 1]]  # the tip radii, mm
    [8.0, 6.6, 6.8, 6.5, 5.9]
    """
    one_of(tips, TIPS, "tips")
    bone, local = hand.joint_attachment()
    if tips == "pad":
        local[4::4, 1] = hand.shape.tip_offsets  # fingertips: the thumb's and each finger's
        local[1, 1] = THUMB_BASE * hand.shape.segments[0, 0]  # on the thumb's metacarpal
    return bone, local


def keypoint_points(hand, x, tips: str = "end", *, jacobian: bool = False):
    """The 21 points of pose `x` compared with keypoints, (21, 3) mm, world.

    ``tips="end"``: G(x) (`HandModel.joints`); ``"pad"``: the same with the fingertips
    at the centres of their pads and the thumb's base up its metacarpal
    (`keypoint_attachment`).  With `jacobian`, also their Jacobian (21, 3, 26), as
    ``(points, jacobian)``.
    """
    one_of(tips, TIPS, "tips")
    if tips == "end":
        return hand.joints_with_jacobian(x) if jacobian else hand.joints(x)
    return hand.points(x, *keypoint_attachment(hand, tips), jacobian=jacobian)


def _points_jacobian(pose: _Pose, bone: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(N, 3, 26) Jacobian of world points `p` on bones `bone` (see `HandModel.points`).

    One matrix product gives every column for every point as if all joints moved it
    (`_Pose.linear_jacobian`); the per-bone mask then keeps the joints on the bone's
    path from the palm.
    """
    n = p.shape[0]
    ph = np.empty((n, 4))
    ph[:, :3] = p
    ph[:, 3] = 1.0
    J = (ph @ pose.linear_jacobian()).reshape(n, 3, N_PARAMS)
    J *= _BONE_MASK[bone][:, None, :]
    return J


# --- compiled forward kinematics ---------------------------------------------------------
# The same maths as `_Pose` (numpy route) and `_points_jacobian`, as loops: a pose is a
# few hundred flops spread over dozens of tiny arrays, where numpy's per-call overhead
# would dominate. Tests check that both routes agree.


@njit(cache=True)
def _fk_kernel(
    x, bases, base_rot, segments, sign, rotations, origins, axes, anchors, joints, euler_axes
):  # pragma: no cover
    """Fill the world-frame kinematics of pose x (see `_Pose`)."""
    deg = math.pi / 180.0
    cx, sx = math.cos(x[3] * deg), math.sin(x[3] * deg)
    cy, sy = math.cos(x[4] * deg), math.sin(x[4] * deg)
    cz, sz = math.cos(x[5] * deg), math.sin(x[5] * deg)
    R = np.empty((3, 3))
    R[0, 0], R[0, 1], R[0, 2] = cy * cz, -cy * sz, sy
    R[1, 0], R[1, 1], R[1, 2] = cx * sz + sx * sy * cz, cx * cz - sx * sy * sz, -sx * cy
    R[2, 0], R[2, 1], R[2, 2] = sx * sz - cx * sy * cz, sx * cz + cx * sy * sz, cx * cy
    euler_axes[0, 0], euler_axes[0, 1], euler_axes[0, 2] = 1.0, 0.0, 0.0
    euler_axes[1, 0], euler_axes[1, 1], euler_axes[1, 2] = 0.0, cx, sx
    euler_axes[2, 0], euler_axes[2, 1], euler_axes[2, 2] = sy, -sx * cy, cx * cy
    t = x[0:3]
    for i in range(3):
        for j in range(3):
            rotations[0, i, j] = R[i, j]
        origins[0, i] = t[i]
        joints[0, i] = t[i]
    rzb = np.empty((3, 3))
    base = np.empty((3, 3))
    o = np.empty(3)
    for k in range(5):
        ca = math.cos(x[6 + k] * deg)
        sa = math.sin(x[6 + k] * deg) * sign[k]
        for j in range(3):  # Rz(s a) B
            rzb[0, j] = ca * base_rot[k, 0, j] - sa * base_rot[k, 1, j]
            rzb[1, j] = sa * base_rot[k, 0, j] + ca * base_rot[k, 1, j]
            rzb[2, j] = base_rot[k, 2, j]
        for i in range(3):  # R Rz(s a) B, and o1 = R b_k + t
            o[i] = t[i]
            for j in range(3):
                base[i, j] = R[i, 0] * rzb[0, j] + R[i, 1] * rzb[1, j] + R[i, 2] * rzb[2, j]
                o[i] += R[i, j] * bases[k, j]
        for i in range(3):
            axes[k, 0, i] = sign[k] * R[i, 2]
            anchors[k, 0, i] = o[i]
            joints[1 + 4 * k, i] = o[i]
        cum = 0.0
        for level in range(3):
            cum += x[11 + 3 * k + level] * deg
            cf, sf = math.cos(cum), math.sin(cum)
            b = 1 + 3 * k + level
            for i in range(3):
                y = cf * base[i, 1] + sf * base[i, 2]
                rotations[b, i, 0] = base[i, 0]
                rotations[b, i, 1] = y
                rotations[b, i, 2] = cf * base[i, 2] - sf * base[i, 1]
                origins[b, i] = o[i]
                axes[k, 1 + level, i] = base[i, 0]
                anchors[k, 1 + level, i] = o[i]
                o[i] += segments[k, level] * y
                joints[2 + 4 * k + level, i] = o[i]


@njit(cache=True)
def _linear_kernel(euler_axes, t, axes, anchors, A):  # pragma: no cover
    """Fill A (4, 78) of `_Pose.linear_jacobian`."""
    deg = math.pi / 180.0
    n = 26
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            A[i, j] = 0.0
    for r in range(3):
        A[3, r * n + r] = 1.0  # translation: identity
    for col in range(3, n):
        if col < 6:
            wx, wy, wz = euler_axes[col - 3, 0], euler_axes[col - 3, 1], euler_axes[col - 3, 2]
            ax, ay, az = t[0], t[1], t[2]
        elif col < 11:
            k, slot = col - 6, 0
            wx, wy, wz = axes[k, slot, 0], axes[k, slot, 1], axes[k, slot, 2]
            ax, ay, az = anchors[k, slot, 0], anchors[k, slot, 1], anchors[k, slot, 2]
        else:
            k, slot = (col - 11) // 3, 1 + (col - 11) % 3
            wx, wy, wz = axes[k, slot, 0], axes[k, slot, 1], axes[k, slot, 2]
            ax, ay, az = anchors[k, slot, 0], anchors[k, slot, 1], anchors[k, slot, 2]
        wx, wy, wz = wx * deg, wy * deg, wz * deg
        # (ω × (p − a))_r = Σ_m [ω]×[r, m] p_m − (ω × a)_r
        A[1, 0 * n + col], A[2, 0 * n + col] = -wz, wy
        A[0, 1 * n + col], A[2, 1 * n + col] = wz, -wx
        A[0, 2 * n + col], A[1, 2 * n + col] = -wy, wx
        A[3, 0 * n + col] = wz * ay - wy * az
        A[3, 1 * n + col] = wx * az - wz * ax
        A[3, 2 * n + col] = wy * ax - wx * ay


@njit(cache=True)
def _points_kernel(rotations, origins, bone, local, A, mask, p, J, jacobian):  # pragma: no cover
    """p = R_b l + o_b per point and, if `jacobian`, J[n] = mask_b ⊙ ([p, 1] A).

    Returns −1, or the first point whose bone is out of range or whose local
    coordinates are not finite (the remaining points are then left unset).
    """
    n_par = mask.shape[1]
    for n in range(bone.shape[0]):
        b = bone[n]
        if b < 0 or b >= rotations.shape[0]:
            return n
        l0, l1, l2 = local[n, 0], local[n, 1], local[n, 2]
        if not (math.isfinite(l0) and math.isfinite(l1) and math.isfinite(l2)):
            return n
        for i in range(3):
            p[n, i] = (
                rotations[b, i, 0] * l0 + rotations[b, i, 1] * l1 + rotations[b, i, 2] * l2
                + origins[b, i]
            )  # fmt: skip
        if jacobian:
            p0, p1, p2 = p[n, 0], p[n, 1], p[n, 2]
            for r in range(3):
                for c in range(n_par):
                    if mask[b, c] == 0.0:
                        J[n, r, c] = 0.0
                    else:
                        j = r * n_par + c
                        J[n, r, c] = p0 * A[0, j] + p1 * A[1, j] + p2 * A[2, j] + A[3, j]
    return -1


def _parents() -> np.ndarray:
    """(16,) parent bone of each bone (−1 for the palm)."""
    parent = np.full(N_BONES, -1, dtype=np.intp)
    for k in range(5):
        parent[bone_index(k, 0)] = 0
        parent[bone_index(k, 1)] = bone_index(k, 0)
        parent[bone_index(k, 2)] = bone_index(k, 1)
    return parent


# --- named poses ---------------------------------------------------------------------

# Articulation (degrees) of the named poses, keyed by parameter name; everything else 0.
_NAMED_POSES: dict[str, dict[str, float]] = {
    "open": {},
    "fist": {
        "abd_thumb": -10.0, "thumb_cmc": 35.0, "thumb_mcp": 45.0, "thumb_ip": 35.0,
        "index_mcp": 85.0, "index_pip": 100.0, "index_dip": 60.0,
        "middle_mcp": 85.0, "middle_pip": 100.0, "middle_dip": 60.0,
        "ring_mcp": 85.0, "ring_pip": 100.0, "ring_dip": 60.0,
        "little_mcp": 85.0, "little_pip": 100.0, "little_dip": 60.0,
    },
    "point": {
        "abd_thumb": -10.0, "thumb_cmc": 35.0, "thumb_mcp": 45.0, "thumb_ip": 35.0,
        "middle_mcp": 85.0, "middle_pip": 100.0, "middle_dip": 60.0,
        "ring_mcp": 85.0, "ring_pip": 100.0, "ring_dip": 60.0,
        "little_mcp": 85.0, "little_pip": 100.0, "little_dip": 60.0,
    },
    "pinch": {
        "abd_thumb": 12.0, "thumb_cmc": 33.0, "thumb_mcp": 18.0, "thumb_ip": 13.0,
        "index_mcp": 39.0, "index_pip": 55.0, "index_dip": 29.0,
        "middle_mcp": 20.0, "middle_pip": 25.0, "middle_dip": 10.0,
        "ring_mcp": 15.0, "ring_pip": 20.0, "ring_dip": 10.0,
        "little_mcp": 10.0, "little_pip": 15.0, "little_dip": 10.0,
    },
    "spread": {
        "abd_thumb": 35.0, "abd_index": 20.0, "abd_middle": 0.0, "abd_ring": 15.0,
        "abd_little": 30.0,
    },
    "thumb_across": {
        "abd_thumb": -10.0, "thumb_cmc": 40.0, "thumb_mcp": 40.0, "thumb_ip": 20.0,
    },
}  # fmt: skip

#: Names accepted by `named_pose`.
POSE_NAMES: tuple[str, ...] = tuple(_NAMED_POSES)


def named_pose(name: str) -> np.ndarray:
    """A named hand posture, placed in front of the default cameras.

    The global pose is ``rx = 180°``, ``ty = 90 mm`` and zero otherwise: seen from
    cameras on the world −z side looking along +z with image-up = world −y, the right
    hand shows its palm, fingers up, thumb on the image's right, centred near the world
    origin.

    Parameters
    ----------
    name : str
        One of `POSE_NAMES`: ``open`` (all joints 0), ``fist``, ``point`` (index
        extended), ``pinch`` (thumb and index tips touching), ``spread`` (fingers
        abducted), ``thumb_across`` (thumb flexed across the palm).

    Returns
    -------
    (26,) ndarray
        The pose, mm and degrees, within the joint limits.

    Examples
    --------
    >>> x = named_pose("fist")
    >>> float(x[3]), float(x[1]), float(x[14])
    (180.0, 90.0, 85.0)
    """
    from handvar.params import NAMES

    if name not in _NAMED_POSES:
        raise ValueError(f"name: expected one of {', '.join(POSE_NAMES)}; got {name!r}")
    x = np.zeros(N_PARAMS)
    x[NAMES.index("rx")] = 180.0
    x[NAMES.index("ty")] = 90.0
    for key, value in _NAMED_POSES[name].items():
        x[NAMES.index(key)] = value
    return check_pose(x, "named pose")


__all__ = [
    "BONES",
    "JOINTS",
    "POSE_NAMES",
    "SURFACES",
    "THUMB_BASE",
    "TIPS",
    "HandModel",
    "euler_from_matrix",
    "keypoint_attachment",
    "keypoint_points",
    "named_pose",
    "world_from_hand_rotation",
]
