"""The cost's terms on the 21 points G(x): the keypoint term C_k and the front term C_z.

Both are computed from the projected joints G(x) (eq. 19–20) in every camera, by one
compiled kernel that the silhouette cost (`handvar.tracking.costs.SilhouetteCost`) calls
with the joints' positions and exact Jacobians (design §14.2 and §13).

C_k, 2D keypoints (design §14.2)
--------------------------------
Per camera j, observed keypoints k_ij (pixels) with confidences c_ij ∈ [0, 1] (0 where
missing). The pixel distance is normalised by the hand's projected size::

    s_j(x) = f_j · L / z_j(x)           f_j = (fx + fy) / 2, L = |G_0 − G_9| of the model,
                                        z_j the depth of the palm point ½(G_0 + G_9)
    e_ij = (π_j(G_i(x)) − k_ij) / s_j   d_ij = |e_ij|  (hand sizes)
    C_k = Σ_j Σ_i c_ij ρ(d_ij) / (21 n_k)     n_k = cameras with any keypoint

with Huber's loss ρ(d) = ½ d² for d ≤ δ and δ (d − ½ δ) beyond (δ = `keypoint_huber`,
0.1 hand sizes), or Tukey's biweight ρ(d) = c²/6 (1 − (1 − d²/c²)³) for d ≤ c and c²/6
beyond (c = the same setting; ``loss="tukey"``, the tracker's refinement). The depth in
s_j is floored at `near`. Each point gives two residual rows r = a β(d) e with
β = √(2ρ(d)) / d, so that ½ |r|² = a² ρ(d) exactly (for Tukey's loss β² = 1 − u + u²/3,
u = d²/c², below c, and c / (√3 d) beyond); their Jacobian is exact (β's derivative
included) and the gradient is Jᵀ r.

C_z, the hand in front of every camera (design §13)
---------------------------------------------------
A hinge on the depth of every joint in every camera::

    C_z = Σ_j Σ_i ½ ((near − z_ij(x))₊ / front_scale)² / (21 n_c)

Points behind a camera project nowhere, so the silhouette terms ignore them; without C_z
a hand behind every camera fits perfectly (zero cost). C_z does not depend on the
frame and is always on.

Where a detector marks a fingertip and the thumb's base (design §14.6)
---------------------------------------------------------------------
G(x)'s fingertips are the ends of the distal bones, where the finger's surface ends,
and its thumb base is the carpometacarpal joint, deep in the palm.  A detector marks
neither there: MediaPipe marks a fingertip about one pad radius inside the end, and
the thumb's base `THUMB_BASE` of the metacarpal up from the joint.  ``tips="pad"``
(`CostSettings.keypoint_tips`) compares the detected tips with the centre of each
distal cone-sphere's last sphere, one tip radius (`HandShape.radii`) short of G(x)'s
tip on the distal bone (`HandShape.tip_offsets`), and the detected thumb base with
that point of the thumb's metacarpal; the other 15 points are G(x)'s.
`keypoint_attachment` and `keypoint_points` (`handvar.hand.kinematics`, where a
track's reported points come from too: `HandModel.landmarks`) give these points;
``tips="end"`` (the default) gives G(x) itself.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from handvar.geometry.distortion import project_point
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST  # the hand size L: their distance
from handvar.hand.kinematics import THUMB_BASE, TIPS, keypoint_attachment, keypoint_points
from handvar.validate import as_array

__all__ = [
    "LOSSES",
    "THUMB_BASE",
    "TIPS",
    "frame_keypoints",
    "hand_length",
    "joint_terms",
    "keypoint_attachment",
    "keypoint_points",
    "reprojection_error",
    "sequence_keypoints",
]


def hand_length(hand) -> float:
    """L = |G_0 − G_9|, wrist to middle MCP of the model, mm (rigid, pose independent)."""
    G = hand.joints(np.zeros(26))
    return float(np.linalg.norm(G[WRIST] - G[MIDDLE_MCP]))


def frame_keypoints(keypoints, n_cameras: int, name: str = "keypoints") -> np.ndarray | None:
    """One frame's keypoints of every camera as an (n_cameras, 21, 3) array, or None.

    Parameters
    ----------
    keypoints : None, (n_cameras, 21, 2|3) array_like, or a sequence of one entry per camera
        x, y (pixels) and an optional confidence; NaN or confidence 0 marks a missing
        point. A per-camera entry may be None (no keypoints in that camera).
    n_cameras : int
        Cameras of the rig.
    name : str
        Named in error messages.

    Returns
    -------
    (n_cameras, 21, 3) ndarray or None
        x, y, confidence with missing points at (0, 0, 0); None when no point is present.
    """
    from handvar.vision.keypoints import N_KEYPOINTS, as_frame_keypoints

    if keypoints is None:
        return None
    if isinstance(keypoints, np.ndarray) and keypoints.ndim == 3:
        entries = list(keypoints)
    elif isinstance(keypoints, np.ndarray):
        raise ValueError(
            f"{name}: expected an array of shape ({n_cameras}, 21, 2|3); "
            f"got shape {keypoints.shape}"
        )
    else:
        entries = list(keypoints)
    if len(entries) != n_cameras:
        raise ValueError(
            f"{name}: expected keypoints of {n_cameras} cameras (one entry per camera, None "
            f"for none); got {len(entries)}"
        )
    out = np.zeros((n_cameras, N_KEYPOINTS, 3))
    for j, k in enumerate(entries):
        if k is None:
            continue
        a = as_frame_keypoints(k, f"{name} (camera {j})")
        ok = a[:, 2] > 0
        out[j, ok] = a[ok]
    if not np.any(out[:, :, 2] > 0):
        return None
    return out


def sequence_keypoints(keypoints, n_frames: int, n_cameras: int) -> list:
    """Keypoints of a sequence, one `frame_keypoints` entry (array or None) per frame.

    Parameters
    ----------
    keypoints : sequence or array_like
        Either one entry per camera, each a `handvar.vision.keypoints.Keypoints2D`, a
        (T, 21, 2|3) array or None; or a (T, n_cameras, 21, 2|3) array; or a list of T
        per-frame entries as `frame_keypoints` takes. A list of n_cameras entries that
        are each None, a Keypoints2D or a (T, 21, 2|3) array is read per camera. Frames
        beyond the keypoints' own count have none.
    n_frames, n_cameras : int
        Frames tracked and cameras of the rig.

    Returns
    -------
    list of ((n_cameras, 21, 3) ndarray or None)
        Length `n_frames`.
    """
    from handvar.vision.keypoints import Keypoints2D

    if isinstance(keypoints, np.ndarray) and keypoints.ndim == 4:
        per_frame = [keypoints[t] for t in range(keypoints.shape[0])]
    else:
        entries = list(keypoints)
        per_camera = len(entries) == n_cameras and all(
            e is None
            or isinstance(e, Keypoints2D)
            or (np.ndim(e) == 3 and np.shape(e)[1:2] == (21,))
            for e in entries
        )
        if per_camera:
            cams = [
                None if e is None else e if isinstance(e, Keypoints2D) else
                Keypoints2D.from_array(e, name=f"keypoints (camera {j})")
                for j, e in enumerate(entries)
            ]  # fmt: skip
            n_kp = max((c.n_frames for c in cams if c is not None), default=0)
            per_frame = [
                [None if c is None or t >= c.n_frames else c.frame(t) for c in cams]
                for t in range(n_kp)
            ]
        else:
            per_frame = entries
    return [
        frame_keypoints(per_frame[t], n_cameras, f"keypoints (frame {t})")
        if t < len(per_frame)
        else None
        for t in range(n_frames)
    ]


def joint_terms(P, JP, cams, keypoints, *, length, huber, near, weight_keypoints,
                weight_front, front_scale, residuals=False, loss="huber"):  # fmt: skip
    """C_k and C_z (module docstring) with gradient, Gauss–Newton diagonal and residuals.

    Parameters
    ----------
    P : (21, 3) ndarray
        G(x), mm, world.
    JP : (21, 3, d) ndarray
        dG/dx.
    cams : handvar.camera.PackedRig
        The cameras (`Rig.packed`).
    keypoints : (n_cams, 21, 3) ndarray or None
        x, y, confidence per camera (`frame_keypoints`); None for no keypoint term.
    length, huber, near, weight_keypoints, weight_front, front_scale : float, keyword-only
        L (mm), the loss's scale δ or c (hand sizes), the near depth (mm), w_k, w_z and
        the hinge's unit (mm).
    residuals : bool, keyword-only
        Also return the residual rows and their Jacobian.
    loss : {"huber", "tukey"}, keyword-only
        C_k's loss ρ (module docstring).

    Returns
    -------
    c_k, c_z : float
        The unweighted terms (hand sizes², and (front_scale)² units).
    g : (d,) ndarray
        Gradient of w_k C_k + w_z C_z.
    gn : (d,) ndarray
        diag(JᵀJ) of the rows.
    r : (63 n_cams,) ndarray or None
        Per camera 42 keypoint rows (u, v per point), then 21 front rows; ½ rᵀr is the
        weighted cost.
    J : (63 n_cams, d) ndarray or None
    """
    n_cams = cams.R.shape[0]
    d = JP.shape[2]
    if keypoints is None:
        kp = np.zeros((n_cams, 21, 3))
    else:
        kp = np.ascontiguousarray(keypoints, dtype=float)
    has = (kp[:, :, 2] > 0).any(axis=1)
    n_k = int(has.sum())
    a_k = np.sqrt(weight_keypoints / (21.0 * n_k)) if n_k else 0.0
    a_z = np.sqrt(weight_front / (21.0 * n_cams)) / front_scale
    rows = 63 * n_cams
    r = np.zeros(rows)
    J = np.zeros((rows, d)) if residuals else np.zeros((0, d))
    g = np.zeros(d)
    gn = np.zeros(d)
    parts = np.zeros(2)
    _joint_kernel(
        np.ascontiguousarray(P, dtype=float), np.ascontiguousarray(JP, dtype=float),
        cams.intrinsics, cams.dist, cams.rational, cams.R, cams.t, kp, has,
        float(length), float(huber), LOSSES.index(loss), float(near), float(front_scale),
        a_k, a_z, residuals, r, J, g, gn, parts,
    )  # fmt: skip
    c_k = parts[0] / (21.0 * n_k) if n_k else 0.0
    c_z = parts[1] / (21.0 * n_cams)
    return float(c_k), float(c_z), g, gn, (r if residuals else None), (J if residuals else None)


#: The losses ρ of C_k, by their code in the compiled kernel.
LOSSES = ("huber", "tukey")


@njit(cache=True)
def _robust(d, c, loss):  # pragma: no cover - compiled
    """ρ(d), β(d) = √(2ρ(d)) / d and dβ/dd of Huber's (loss 0) or Tukey's (1) loss, scale c."""
    if loss == 0:  # Huber
        if d <= c:
            return 0.5 * d * d, 1.0, 0.0
        rho = c * (d - 0.5 * c)
        phi = np.sqrt(2.0 * rho)
        return rho, phi / d, (c / phi * d - phi) / (d * d)
    # Tukey's biweight: ρ = c²/6 (1 − (1 − u)³), u = d²/c², constant c²/6 beyond c
    if d >= c:
        b = c / (np.sqrt(3.0) * d)
        return c * c / 6.0, b, -b / d
    u = d * d / (c * c)
    b2 = 1.0 - u + u * u / 3.0  # β² = 2ρ/d², exact for small d
    b = np.sqrt(b2)
    return 0.5 * d * d * b2, b, (-1.0 + 2.0 * u / 3.0) * d / (c * c * b)


@njit(cache=True)
def _joint_kernel(P, JP, cam_k, cam_dist, cam_rational, cam_R, cam_t, kp, has, L, delta,
                  loss, near, scale, a_k, a_z, want_jacobian, r, J, g, gn,
                  parts):  # fmt: skip  # pragma: no cover - compiled
    """Rows, gradient and unweighted sums of C_k and C_z, in place (see `joint_terms`).

    Row layout per camera j (offset 63 j): 42 keypoint rows (C_k), then 21 depth rows
    (C_z)."""
    n_par = JP.shape[2]
    uv = np.empty(2)
    J2 = np.empty((2, n_par))
    ds = np.empty(n_par)
    de = np.empty((2, n_par))
    row_j = np.empty((2, n_par))
    for j in range(cam_k.shape[0]):
        base = 63 * j
        _depth_rows(P, JP, cam_R[j], cam_t[j], near, scale, a_z, base + 42, want_jacobian,
                    r, J, g, gn, parts)  # fmt: skip
        if not has[j]:
            continue
        camera = (cam_k[j], cam_dist[j], cam_rational[j], cam_R[j], cam_t[j])
        s = _hand_size(P, JP, camera, L, near, ds)
        _keypoint_rows(P, JP, camera, kp[j], s, ds, delta, loss, a_k, base, want_jacobian,
                       r, J, g, gn, parts, uv, J2, de, row_j)  # fmt: skip


@njit(cache=True)
def _depth_rows(P, JP, R, t, near, scale, a_z, base, want_jacobian, r, J, g, gn,
                parts):  # fmt: skip  # pragma: no cover - compiled
    """C_z of one camera: a hinge on every joint's depth, rows from `base`."""
    n_par = JP.shape[2]
    for i in range(P.shape[0]):
        z = R[2, 0] * P[i, 0] + R[2, 1] * P[i, 1] + R[2, 2] * P[i, 2] + t[2]
        if z >= near:
            continue
        row = base + i
        e = a_z * (near - z)
        parts[1] += 0.5 * ((near - z) / scale) ** 2
        r[row] = e
        for col in range(n_par):
            jz = -a_z * (R[2, 0] * JP[i, 0, col] + R[2, 1] * JP[i, 1, col]
                         + R[2, 2] * JP[i, 2, col])  # fmt: skip
            g[col] += e * jz
            gn[col] += jz * jz
            if want_jacobian:
                J[row, col] = jz


@njit(cache=True)
def _hand_size(P, JP, camera, L, near, ds):  # pragma: no cover - compiled
    """The hand size s = f L / z_c in one camera at the palm point ½(G_0 + G_9) (z_c held
    at `near` in front of the camera), and ds/dx into ``ds``."""
    k, _, _, R, t = camera
    f = 0.5 * (k[0] + k[1])
    zc = 0.0
    for c in range(3):
        zc += R[2, c] * 0.5 * (P[0, c] + P[9, c])
    zc += t[2]
    clamped = zc < near
    if clamped:
        zc = near
    s = f * L / zc
    for col in range(JP.shape[2]):
        v = 0.0
        if not clamped:
            for c in range(3):
                v += R[2, c] * 0.5 * (JP[0, c, col] + JP[9, c, col])
        ds[col] = -s / zc * v  # ds/dx = −s/z_c · dz_c/dx
    return s


@njit(cache=True)
def _keypoint_rows(P, JP, camera, kp, s, ds, delta, loss, a_k, base, want_jacobian, r, J, g,
                   gn, parts, uv, J2, de, row_j):  # fmt: skip  # pragma: no cover
    """C_k of one camera: each present keypoint against its projected joint, in hand sizes
    `s`, under the robust loss; rows from `base`."""
    k, dist_, rational, R, t = camera
    n_par = JP.shape[2]
    for i in range(P.shape[0]):
        conf = kp[i, 2]
        if not conf > 0.0:
            continue
        z = project_point(k, dist_, rational, R, t, P[i], JP[i], uv, J2)
        if not (z > 0.0 and np.isfinite(uv[0]) and np.isfinite(uv[1])):
            continue  # behind the camera: C_z pulls it in front
        e0 = (uv[0] - kp[i, 0]) / s
        e1 = (uv[1] - kp[i, 1]) / s
        dist = np.sqrt(e0 * e0 + e1 * e1)
        # de/dx = (dπ/dx − e · ds/dx) / s
        for col in range(n_par):
            de[0, col] = (J2[0, col] - e0 * ds[col]) / s
            de[1, col] = (J2[1, col] - e1 * ds[col]) / s
        rho, beta, dbeta = _robust(dist, delta, loss)
        parts[0] += conf * rho
        w = a_k * np.sqrt(conf)
        row = base + 2 * i
        r[row] = w * beta * e0
        r[row + 1] = w * beta * e1
        # r = w β(d) e: dr/dx = w (β de/dx + e β'(d) dd/dx), dd/dx = eᵀ de/dx / d
        for col in range(n_par):
            dd = (e0 * de[0, col] + e1 * de[1, col]) / dist if dist > 0.0 else 0.0
            row_j[0, col] = w * (beta * de[0, col] + e0 * dbeta * dd)
            row_j[1, col] = w * (beta * de[1, col] + e1 * dbeta * dd)
            g[col] += r[row] * row_j[0, col] + r[row + 1] * row_j[1, col]
            gn[col] += row_j[0, col] * row_j[0, col] + row_j[1, col] * row_j[1, col]
            if want_jacobian:
                J[row, col] = row_j[0, col]
                J[row + 1, col] = row_j[1, col]


def reprojection_error(G, rig, keypoints, length: float, *, near: float = 100.0) -> float:
    """Mean distance of the projected G(x) to the present keypoints, in hand sizes.

    Parameters
    ----------
    G : (21, 3) ndarray
        Joints, mm, world.
    rig : handvar.camera.Rig
    keypoints : (n_cams, 21, 3) ndarray or None
        From `frame_keypoints`.
    length : float
        L, mm (`hand_length`); the hand size in camera j is s_j = f_j L / z_j.
    near : float, keyword-only
        Floor of z_j, mm, as in C_k.

    Returns
    -------
    float
        Unweighted mean over every present point of every camera; NaN if none.
    """
    if keypoints is None:
        return float("nan")
    G = as_array(G, "G", shape=(21, 3))
    d = []
    for j, cam in enumerate(rig):
        ok = keypoints[j, :, 2] > 0
        if not ok.any():
            continue
        palm = cam.camera_from_world(0.5 * (G[WRIST] + G[MIDDLE_MCP])[None])[0]
        s = 0.5 * (cam.fx + cam.fy) * length / max(float(palm[2]), near)
        d.append(np.linalg.norm(cam.project(G[ok]) - keypoints[j, ok, :2], axis=1) / s)
    return float(np.concatenate(d).mean()) if d else float("nan")
