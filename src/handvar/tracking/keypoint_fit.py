"""The pose whose projected joints G(x) fit given 2D keypoints (design §14.1).

Used by the initial pose (`handvar.tracking.init.initial_pose` with ``keypoints``): a
silhouette cannot tell the palm from the back of the hand, nor see fingers folded in
front of the palm; 2D keypoints of the 21 points of `G(x)` can.

1. *Palm pose* from the five palm points (wrist and the four finger MCPs), which are
   rigid and coplanar in the model (hand z = 0): a perspective-n-point fit per camera
   with keypoints (``cv2.solvePnPGeneric``, IPPE for planar points: it returns both
   solutions of the planar ambiguity, a tilt towards or away from the camera), the
   model's palm joints as the object points.  Both solutions, and each turned by 180°
   about the hand's long axis (which side of the hand faces the camera is ambiguous
   when the palm is seen edge-on), are candidates.  Position and distance come with
   it: the model's palm has a known size (the hand length), so its image size fixes
   the depth.  Where the keypoints' noise mirrors the flat arc of knuckles, IPPE's
   poses lie behind the camera (a point reflection through its centre projects
   alike); SQPnP's proper pose (``cv2.SOLVEPNP_SQPNP``) and its turn are taken instead,
   and no fit whose joints lie behind a camera with keypoints is kept.
2. *Everything* by least squares over the 26 parameters (``scipy.optimize.least_squares``,
   joint limits as bounds, the analytic Jacobian ``J_proj · J_G``) from every candidate
   combined with a few named finger postures, minimising over all cameras and present
   points ``Σ c_k ‖π(G_k(x)) − u_k‖² + λ Σ_f (x_f − x_f⁰)²``: pixels weighted by the
   confidence ``c_k``, plus a weak pull of the 20 finger angles towards the starting
   posture (λ = `KeypointFitSettings.prior`², pixels per degree) that settles what 2D
   points leave open (a finger's flexion towards or away from the camera).
3. The candidate with the lowest cost wins.

With ``KeypointFitSettings.tips="pad"`` the detected fingertips are fitted to the
centres of the model's fingertip pads instead of G(x)'s tips (design §14.6).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from handvar.camera import Camera, Rig
from handvar.params import LOWER, N_PARAMS, UPPER, clamp
from handvar.tracking.keypoint_cost import TIPS, keypoint_points
from handvar.validate import as_float, as_instance, one_of
from handvar.vision.keypoints import PALM, as_frame_keypoints

__all__ = [
    "KEYPOINT_FIT_DEFAULTS",
    "KeypointFit",
    "KeypointFitSettings",
    "fit_keypoints",
    "keypoint_error",
    "palm_candidates",
    "palm_seen",
]


@dataclass(frozen=True)
class KeypointFitSettings:
    """Settings of `fit_keypoints` (design §14.1; the paper has no keypoints).

    Attributes
    ----------
    shapes : tuple of str
        Named finger postures (`handvar.hand.kinematics.named_pose`) each candidate
        palm pose starts from.
    prior : float
        Weight of the pull of the finger angles towards the starting posture, pixels of
        residual per degree (0.1: a 10° change costs as much as 1 px of keypoint error).
    min_confidence : float
        Points of lower confidence are ignored.
    max_nfev : int
        Function evaluations per least-squares run.
    tips : {"end", "pad"}
        The model point a detected fingertip is fitted to: G(x)'s tip or the centre
        of the fingertip's pad (`CostSettings.keypoint_tips`, design §14.6).
    """

    shapes: tuple[str, ...] = ("open", "fist", "point")
    prior: float = 0.1
    min_confidence: float = 0.05
    max_nfev: int = 200
    tips: str = "end"

    def __post_init__(self) -> None:
        one_of(self.tips, TIPS, "tips")


KEYPOINT_FIT_DEFAULTS = KeypointFitSettings()


@dataclass(frozen=True, eq=False)
class KeypointFit:
    """The result of `fit_keypoints`.

    Attributes
    ----------
    pose : (26,) ndarray
        mm and degrees.
    error : float
        Mean distance of the projected joints to the present keypoints over cameras,
        pixels (`keypoint_error`).
    cost : float
        The minimised cost (module notes, step 2), pixels².
    n_candidates : int
        Least-squares runs.
    """

    pose: np.ndarray
    error: float
    cost: float
    n_candidates: int


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


def palm_seen(keypoints, settings: KeypointFitSettings = KEYPOINT_FIT_DEFAULTS) -> bool:
    """Whether some camera shows the wrist and the four MCPs, so that `fit_keypoints`
    can start (it returns None otherwise).

    Parameters
    ----------
    keypoints : sequence of (21, 3) array_like or None, or None
        One per camera (None: no keypoints there): x, y, confidence.
    settings : KeypointFitSettings, optional
        Its `min_confidence`: points below it do not count, as in `fit_keypoints`.
    """
    if keypoints is None:
        return False
    palm = list(PALM)
    least = settings.min_confidence
    return any(k is not None and bool((np.asarray(k)[palm, 2] >= least).all()) for k in keypoints)


def palm_candidates(keypoints, camera: Camera, hand) -> np.ndarray:
    """Palm poses (module notes, step 1) from one camera's keypoints.

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


def _residuals(x, hand, rig, frames, x_prior, prior, tips="end"):
    """Weighted pixel residuals and their Jacobian (module notes, step 2)."""
    G, JG = keypoint_points(hand, x, tips, jacobian=True)
    res, jac = [], []
    for cam, k in zip(rig, frames, strict=True):
        if k is None:
            continue
        ok = np.flatnonzero(k[:, 2] > 0)
        px, J = cam.project_jacobian(G[ok])
        w = np.sqrt(k[ok, 2])[:, None]
        res.append(((px - k[ok, :2]) * w).ravel())
        jac.append((np.einsum("nij,njp->nip", J, JG[ok]) * w[:, :, None]).reshape(-1, N_PARAMS))
    res.append(prior * (x[6:] - x_prior[6:]))
    jp = np.zeros((N_PARAMS - 6, N_PARAMS))
    jp[:, 6:] = prior * np.eye(N_PARAMS - 6)
    jac.append(jp)
    return np.concatenate(res), np.concatenate(jac)


def fit_keypoints(
    keypoints,
    rig: Rig,
    hand=None,
    *,
    settings: KeypointFitSettings = KEYPOINT_FIT_DEFAULTS,
) -> KeypointFit | None:
    """Fit the pose to one frame's keypoints (module notes, steps 1–3).

    Parameters
    ----------
    keypoints : sequence of (21, 2|3) array_like or None
        One per camera of `rig` (a single array for one camera), pixels of that
        camera's images, confidence in the third column; NaN where missing.
    rig : Rig
    hand : HandModel, optional
        The hand model (default 185 mm hand).
    settings : KeypointFitSettings, keyword-only

    Returns
    -------
    KeypointFit or None
        None when no camera shows the wrist and all four MCPs, or every fit lies behind
        a camera (a point reflection through its centre projects alike).

    Examples
    --------
    >>> from handvar.hand import HandModel, named_pose
    >>> hand, rig = HandModel(), Rig.default()
    >>> x = named_pose("point")
    >>> kps = [cam.project(hand.joints(x)) for cam in rig]
    >>> fit = fit_keypoints(kps, rig, hand)
    >>> fit.error < 0.5, float(np.abs(fit.pose[:3] - x[:3]).max()) < 1.0
    (True, True)
    """
    from scipy.optimize import least_squares

    from handvar.hand.kinematics import HandModel, named_pose

    as_instance(rig, Rig, "rig")
    as_instance(settings, KeypointFitSettings, "settings")
    as_float(settings.prior, "settings.prior", minimum=0.0)
    hand = HandModel() if hand is None else hand
    tips = settings.tips
    frames = _frames(keypoints, rig)
    for j, k in enumerate(frames):
        if k is not None:
            k = k.copy()
            weak = k[:, 2] < settings.min_confidence
            k[weak] = (np.nan, np.nan, 0.0)
            frames[j] = k if (k[:, 2] > 0).any() else None
    palms = [
        palm_candidates(k, cam, hand) for cam, k in zip(rig, frames, strict=True) if k is not None
    ]
    palms = [p for p in palms if len(p)]
    if not palms:
        return None
    palm = np.concatenate(palms)
    # Bounds: joint limits; least_squares wants the start strictly inside.
    lo, hi = LOWER.copy(), UPPER.copy()
    margin = 1e-6 * (hi - lo)
    best = None
    n = 0
    for name in settings.shapes:
        shape = named_pose(name)
        for p in palm:
            x0 = shape.copy()
            x0[:6] = p
            x0 = np.clip(clamp(x0), lo + margin, hi - margin)
            sol = least_squares(
                lambda x, x0=x0: _residuals(x, hand, rig, frames, x0, settings.prior, tips)[0],
                x0,
                jac=lambda x, x0=x0: _residuals(x, hand, rig, frames, x0, settings.prior, tips)[1],
                bounds=(lo, hi),
                method="trf",
                x_scale="jac",
                max_nfev=settings.max_nfev,
            )
            n += 1
            cost = 2.0 * float(sol.cost)
            if _behind(clamp(sol.x), hand, rig, frames):
                continue  # a point reflection through a camera's centre projects alike
            if best is None or cost < best[0]:
                best = (cost, clamp(sol.x))
    if best is None:
        return None
    cost, pose = best
    return KeypointFit(
        pose=pose,
        error=keypoint_error(pose, hand, rig, frames, tips=tips),
        cost=cost,
        n_candidates=n,
    )
