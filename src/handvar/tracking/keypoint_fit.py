"""The palm's pose from 2D keypoints, and how far a pose's joints project from them
(design §14.1).

A silhouette cannot tell the palm from the back of the hand, nor see fingers folded in
front of the palm; 2D keypoints of the 21 points of `G(x)` can.  The pose of a frame
from its keypoints alone (`handvar.tracking.frame_fit.reinitialise`: the first pose of
`handvar init` and `handvar track`, and the tracker's re-initialisation) starts from
the palm's pose:

*Palm pose* from the five palm points (wrist and the four finger MCPs), which are rigid
and coplanar in the model (hand z = 0): a perspective-n-point fit per camera with
keypoints (``cv2.solvePnPGeneric``, IPPE for planar points: it returns both solutions
of the planar ambiguity, a tilt towards or away from the camera), the model's palm
joints as the object points.  Both solutions, and each turned by 180° about the hand's
long axis (which side of the hand faces the camera is ambiguous when the palm is seen
edge-on), are candidates.  Position and distance come with it: the model's palm has a
known size (the hand length), so its image size fixes the depth.  Where the keypoints'
noise mirrors the flat arc of knuckles, IPPE's poses lie behind the camera (a point
reflection through its centre projects alike); SQPnP's proper pose
(``cv2.SOLVEPNP_SQPNP``) and its turn are taken instead, and no fit whose joints lie
behind a camera with keypoints is kept (`_behind`).
"""

from __future__ import annotations

import cv2
import numpy as np

from handvar.camera import Camera, Rig
from handvar.params import N_PARAMS
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.vision.keypoints import PALM, as_frame_keypoints

__all__ = ["keypoint_error", "palm_candidates"]


def _frames(keypoints, rig: Rig) -> list[np.ndarray | None]:
    """Check per-camera keypoints: a list of (21, 3) arrays or None, one per camera."""
    if isinstance(keypoints, np.ndarray) and keypoints.ndim == 2:
        keypoints = [keypoints]
    keypoints = list(keypoints)
    if len(keypoints) != len(rig):
        raise ValueError(
            f"keypoints: expected one (21, 2|3) array (or None) per camera, {len(rig)} "
            f"in all; got {len(keypoints)}"
        )
    return [
        None if k is None else as_frame_keypoints(k, f"keypoints (camera {rig.names[j]!r})")
        for j, k in enumerate(keypoints)
    ]


def keypoint_error(x, hand, rig: Rig, keypoints, *, tips: str = "end") -> float:
    """Mean pixel distance between the projected joints G(x) and the present keypoints.

    Parameters
    ----------
    x : (26,) array_like
        Pose, mm and degrees.
    hand : HandModel
    rig : Rig
    keypoints : sequence of (21, 2|3) array_like or None
        One per camera (None: no keypoints there), pixels of that camera's images.
    tips : {"end", "pad"}, keyword-only
        The fingertips of G(x) or the centres of their pads (`keypoint_points`).

    Returns
    -------
    float
        Pixels, unweighted, over every present point of every camera; NaN if none.
    """
    frames = _frames(keypoints, rig)
    G = keypoint_points(hand, x, tips)
    d = []
    for cam, k in zip(rig, frames, strict=True):
        if k is None:
            continue
        ok = k[:, 2] > 0
        d.append(np.linalg.norm(cam.project(G[ok]) - k[ok, :2], axis=1))
    d = np.concatenate(d) if d else np.empty(0)
    return float(d.mean()) if d.size else float("nan")


def palm_candidates(keypoints, camera: Camera, hand) -> np.ndarray:
    """Palm poses (module notes) from one camera's keypoints.

    Parameters
    ----------
    keypoints : (21, 2|3) array_like
        Pixels of `camera`'s image; the wrist and all four MCPs must be present.
    camera : Camera
    hand : HandModel

    Returns
    -------
    (K, 6) ndarray
        ``tx ty tz rx ry rz`` (mm, degrees) per candidate; K = 0 when a palm point is
        missing.
    """
    from handvar.hand.kinematics import euler_from_matrix

    k = as_frame_keypoints(keypoints)
    palm = np.asarray(PALM)
    if not (k[palm, 2] > 0).all():
        return np.empty((0, 6))
    rest = np.zeros(N_PARAMS)
    obj = hand.joints(rest)[palm]  # hand frame (x = 0 is the identity pose)
    _, rvecs, tvecs, _ = cv2.solvePnPGeneric(
        obj, k[palm, :2].copy(), camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE
    )
    if any(t.ravel()[2] <= 0 for t in tvecs):
        # the keypoints' noise mirrored the flat palm's arc of knuckles: IPPE's poses lie
        # behind the camera (a point reflection projects alike); SQPnP's proper pose
        _, rvec, tvec = cv2.solvePnP(obj, k[palm, :2].copy(), camera.K, camera.dist,
                                     flags=cv2.SOLVEPNP_SQPNP)  # fmt: skip
        rvecs, tvecs = (rvec,), (tvec,)
    # 180° about the hand's long axis (y): the other side of the hand towards the camera
    flip = np.diag([-1.0, 1.0, -1.0])
    out = []
    for rvec, tvec in zip(rvecs, tvecs, strict=True):
        R_ch = cv2.Rodrigues(rvec)[0]
        t_ch = tvec.ravel()
        for F in (np.eye(3), flip):
            R_wh = camera.R.T @ R_ch @ F  # world_from_hand
            t_wh = camera.R.T @ (t_ch - camera.t)
            out.append(np.concatenate([t_wh, euler_from_matrix(R_wh)]))
    return np.asarray(out)


def _behind(x, hand, rig, frames) -> bool:
    """Whether a joint of pose `x` lies behind a camera that has keypoints."""
    joints = hand.joints(x)
    return any(
        (cam.camera_from_world(joints)[:, 2] <= 0).any()
        for cam, k in zip(rig, frames, strict=True)
        if k is not None
    )
