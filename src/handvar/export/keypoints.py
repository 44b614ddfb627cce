"""The 21 keypoints of a track per frame: 2D, 3D, visibility and the fit's confidence.

Two layouts (docs/outputs.md):

- handvar's own JSON (:func:`keypoint_frames`, :func:`write_keypoints_json`): one file,
  one record per frame with the world keypoints (mm) and, per camera, the pixels, the
  keypoints in that camera's frame (mm), whether each is visible and whether it falls
  in the image;
- OpenPose's per-frame JSON (:func:`openpose_frames`, :func:`write_openpose`): one file
  per camera and frame with ``people[0].hand_right_keypoints_2d`` (or ``_left_``) as a
  flat ``[x, y, c] * 21`` and ``hand_*_keypoints_3d`` as ``[x, y, z, c] * 21``.

A frame without a hand (its pose NaN as a whole, `handvar.export.absent`) is written
without points: ``world`` null and no ``views`` in the JSON, no ``people`` in OpenPose's.

The keypoints are G(x) (`HandModel.joints`) in the order of `JOINTS`, which is the
21-point order of MediaPipe Hands and OpenPose's hand model.

Visibility: a keypoint is hidden from a camera when the model's own sphere-mesh
surface lies in front of it along the ray from the camera's optical centre by more
than its own flesh can reach (`joint_reach`) plus a tolerance: the
first surface point in front of a keypoint inside the hand is then its own flesh.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from handvar.atomic import OutputSet, check_output_dir, write_atomic
from handvar.export.absent import hand_frames
from handvar.hand.anthropometry import JOINTS
from handvar.validate import as_array

__all__ = [
    "fit_confidence",
    "joint_reach",
    "joint_visibility",
    "keypoint_frames",
    "keypoint_share",
    "openpose_frames",
    "openpose_name",
    "write_keypoints_json",
    "write_openpose",
]

#: mm a keypoint may lie behind the surface of its own joint and still count as seen.
VISIBILITY_TOLERANCE = 1.0
_N_JOINTS = len(JOINTS)


def joint_reach(hand) -> np.ndarray:
    """(21,) how far in front of each keypoint its own flesh can reach, mm.

    A keypoint lies in (or on) some cone-spheres of the sphere-mesh; in one whose
    radius at the keypoint's closest axis point is r and whose axis is e away from the
    keypoint (e ≤ r), a ray reaching the keypoint has entered that cone-sphere at most
    r + e in front of it. The largest such r + e over the cone-spheres holding the
    keypoint, at the rest pose (all 26 parameters 0): a joint on its finger's axis gets
    the finger's radius, a fingertip (on the surface) the tip's diameter, a knuckle
    inside the palm the palm's thickness there.

    Examples
    --------
    >>> from handvar.hand.kinematics import HandModel
    >>> reach = joint_reach(HandModel())
    >>> reach.shape, bool(reach.min() > 0)
    ((21,), True)
    """
    x = np.zeros(26)
    centres, radii = hand.world_spheres(x)  # (P, 2, 3), (P, 2)
    joints = hand.joints(x)
    a, b = centres[:, 0], centres[:, 1]  # (P, 3)
    axis = b - a
    length2 = np.maximum(np.sum(axis * axis, axis=1), 1e-12)
    s = np.clip(np.einsum("jpc,pc->jp", joints[:, None] - a, axis) / length2, 0.0, 1.0)
    closest = a + s[..., None] * axis  # (21, P, 3)
    radius = (1.0 - s) * radii[:, 0] + s * radii[:, 1]
    e = np.linalg.norm(joints[:, None] - closest, axis=2)
    holding = e <= radius + VISIBILITY_TOLERANCE
    return np.where(holding, radius + e, 0.0).max(axis=1)


def joint_visibility(hand, x, camera, *, tolerance: float = VISIBILITY_TOLERANCE):
    """Whether each of the 21 keypoints at pose `x` is seen by `camera`, (21,) bool.

    A keypoint is hidden when the first point of the model's sphere-mesh surface on
    the ray from the camera's optical centre to it lies more than the reach of its own
    flesh (`joint_reach`) plus `tolerance` mm in front of it, or when it is behind the
    camera. Whether it falls inside the image is a separate question (`Camera.in_image`).

    Parameters
    ----------
    hand : HandModel
    x : (26,) array_like
        Pose, mm and degrees.
    camera : Camera
    tolerance : float, keyword-only
        mm.
    """
    joints = hand.joints(x)
    centre = camera.center
    directions = joints - centre  # a hit at ray parameter s lies at centre + s·direction
    depth = hand.intersect_rays(x, np.broadcast_to(centre, joints.shape), directions)
    length = np.linalg.norm(directions, axis=1)
    in_front = np.isfinite(depth) & (depth < 1.0)
    gap = np.where(in_front, (1.0 - depth) * length, 0.0)  # surface in front of it, mm
    ahead = camera.camera_from_world(joints)[:, 2] > 0
    return ahead & (gap <= joint_reach(hand) + tolerance)


def fit_confidence(iou, lost, keypoint_share=None) -> np.ndarray:
    """Per-frame confidence of a fit in [0, 1]: its silhouette IoU, or on a frame fitted to
    keypoints without a silhouette measured, the share of its keypoints the fit honours;
    0 on lost frames.

    Parameters
    ----------
    iou : (T,) or (T, n_cameras) array_like
        Silhouette IoU per frame (and camera; averaged over cameras). NaN: not measured.
    lost : (T,) array_like of bool
        Frames whose fit failed.
    keypoint_share : (T,) array_like, optional
        Per frame the share of its keypoints within the keypoint check's distance of the
        fitted joints, the rejected ones counted out (`keypoint_share`); NaN where the
        frame had none. Used where the IoU is NaN; a frame with neither counts 0.

    Examples
    --------
    >>> fit_confidence([[0.9, 0.7], [0.95, 0.9]], [False, True]).tolist()
    [0.8, 0.0]
    >>> fit_confidence([np.nan, 0.5], [False, False], keypoint_share=[0.95, 1.0]).tolist()
    [0.95, 0.5]
    """
    q = np.asarray(iou, dtype=float)
    if q.ndim == 2:
        n = np.sum(~np.isnan(q), axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            q = np.where(n > 0, np.nansum(q, axis=1) / n, np.nan)
    if q.ndim != 1:
        raise ValueError(f"iou: expected shape (T,) or (T, n_cameras); got shape {q.shape}")
    lost = np.asarray(lost, dtype=bool)
    if lost.shape != q.shape:
        raise ValueError(f"lost: expected shape {q.shape} (one per frame); got {lost.shape}")
    if keypoint_share is not None:
        share = as_array(keypoint_share, "keypoint_share", q.shape, finite=False,
                         what="one value per frame")  # fmt: skip
        q = np.where(np.isnan(q), share, q)
    return np.where(lost | np.isnan(q), 0.0, np.clip(q, 0.0, 1.0))


def keypoint_share(quality, threshold: float = 0.2) -> np.ndarray:
    """(T,) per frame the share of the keypoints within `threshold` hand sizes of the
    fitted joints, rejected keypoints counted as not (the keypoint check's measure,
    `handvar.tracking.frame_fit.honoured`); NaN on frames without keypoints.

    `quality`: a track's `TrackQuality` (its ``distances``, NaN where no keypoint or
    rejected, and ``rejected`` per frame).
    """
    d = np.asarray(quality.distances, dtype=float)  # (T, n_cams, 21)
    kept = np.isfinite(d).sum(axis=(1, 2))  # export sits below tracking (design §12)
    near = (np.nan_to_num(d, nan=np.inf) <= threshold).sum(axis=(1, 2))
    total = kept + np.asarray(quality.rejected, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, near / total, np.nan)


def _check_inputs(poses, hand, rig, confidence):
    """The poses, which frames have a hand, and the confidences, checked."""
    poses, present = hand_frames(poses, "poses", (None, 26))
    if confidence is not None:
        confidence = as_array(confidence, "confidence", (poses.shape[0],), what="confidences")
    return poses, present, confidence


def _views(hand, x, rig):
    """Per camera: pixels (21, 2), camera-frame points (21, 3), visible, in image."""
    joints = hand.joints(x)
    out = []
    for camera in rig.cameras:
        cam = camera.camera_from_world(joints)
        uv = camera.project(joints)
        inside = (cam[:, 2] > 0) & np.all(np.isfinite(uv), axis=1)
        inside[inside] = camera.in_image(uv[inside])
        out.append((uv, cam, joint_visibility(hand, x, camera), inside))
    return joints, out


def _rounded(a: np.ndarray, digits: int) -> list:
    """Nested lists of `a` rounded to `digits` decimals, null for NaN (valid JSON)."""
    r = np.round(np.asarray(a, dtype=float), digits).astype(object)
    r[~np.isfinite(np.asarray(a, dtype=float))] = None
    return r.tolist()


def keypoint_frames(poses, hand, rig=None, *, confidence=None) -> dict:
    """The keypoints of every frame as one JSON-ready document (docs/outputs.md).

    Parameters
    ----------
    poses : (T, 26) array_like
        The track's poses, mm and degrees; NaN as a whole on a frame without a hand.
    hand : HandModel
        The tracked model (its shape gives G(x) and the surface for visibility).
    rig : Rig, optional
        Cameras; without it only the world keypoints are written.
    confidence : (T,) array_like, keyword-only, optional
        Per-frame fit confidence in [0, 1] (`fit_confidence`); null when absent.

    Returns
    -------
    dict
        ``joints`` (the 21 names), ``hand`` (side), ``units``, ``cameras`` (name,
        K, R, t, size) and ``frames``: per frame ``frame``, ``confidence``, ``world``
        (21 × 3 mm) and ``views``, per camera ``camera``, ``keypoints_2d`` (21 × 2
        pixels), ``keypoints_3d`` (21 × 3 mm, camera frame), ``visible`` and
        ``in_image`` (21 booleans). A frame without a hand has ``world`` null and
        ``views`` empty.
    """
    poses, present, confidence = _check_inputs(poses, hand, rig, confidence)
    cameras = [] if rig is None else [
        {"name": name, "K": cam.K.tolist(), "R": cam.R.tolist(), "t": cam.t.tolist(),
         "dist": cam.dist.tolist(), "size": list(cam.size)}
        for name, cam in zip(rig.names, rig.cameras, strict=True)
    ]  # fmt: skip
    frames = []
    for t, x in enumerate(poses):
        record = {
            "frame": t,
            "confidence": None if confidence is None else float(confidence[t]),
            "world": _rounded(hand.joints(x), 4) if present[t] else None,
            "views": [],
        }
        if rig is not None and present[t]:
            _, views = _views(hand, x, rig)
            for name, (uv, cam, visible, inside) in zip(rig.names, views, strict=True):
                record["views"].append({
                    "camera": name,
                    "keypoints_2d": _rounded(uv, 3),
                    "keypoints_3d": _rounded(cam, 4),
                    "visible": visible.tolist(),
                    "in_image": inside.tolist(),
                })  # fmt: skip
        frames.append(record)
    return {
        "format": "handvar-keypoints",
        "version": 1,
        "joints": list(JOINTS),
        "hand": hand.shape.side,
        "units": {"keypoints_2d": "pixels", "keypoints_3d": "mm", "world": "mm"},
        "cameras": cameras,
        "frames": frames,
    }


def write_keypoints_json(path: str | os.PathLike, document: dict) -> Path:
    """Write `document` (`keypoint_frames`) to the JSON file `path`, atomically."""
    write_atomic(path, lambda tmp: Path(tmp).write_text(json.dumps(document), encoding="utf-8"))
    return Path(path)


def openpose_frames(poses, hand, rig, *, confidence=None, with_3d: bool = True) -> list:
    """The track in OpenPose's per-frame JSON layout, one list of frames per camera.

    Each frame is ``{"version": 1.3, "people": [person]}`` with the hand's side in
    ``hand_right_keypoints_2d`` or ``hand_left_keypoints_2d`` as ``[x, y, c] * 21``
    (pixels) and, with `with_3d`, ``hand_*_keypoints_3d`` as ``[x, y, z, c] * 21``
    (mm, world frame); every other keypoint list is empty. The score ``c`` of a keypoint
    is the frame's confidence (1 without one) where it is visible and in the image,
    else 0. A frame without a hand is ``{"version": 1.3, "people": []}``, as OpenPose
    writes a frame where it detected no one.

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without a hand.
    hand : HandModel
    rig : Rig
    confidence : (T,) array_like, keyword-only, optional
    with_3d : bool, keyword-only
        Also the 3D keypoints (for calibrated cameras).

    Returns
    -------
    list of list of dict
        ``[camera][frame]``.
    """
    poses, present, confidence = _check_inputs(poses, hand, rig, confidence)
    if rig is None:
        raise ValueError("rig: expected the cameras to project the keypoints into; got None")
    side = hand.shape.side
    out: list[list[dict]] = [[] for _ in rig.cameras]
    for t, x in enumerate(poses):
        if not present[t]:
            for per_camera in out:
                per_camera.append({"version": 1.3, "people": []})
            continue
        c = 1.0 if confidence is None else float(confidence[t])
        joints, views = _views(hand, x, rig)
        for j, (uv, _, visible, inside) in enumerate(views):
            score = np.where(visible & inside, c, 0.0)
            person = {"person_id": [-1]}
            for part in ("pose", "face", "hand_left", "hand_right"):
                person[f"{part}_keypoints_2d"] = []
            flat2 = np.column_stack([np.nan_to_num(uv), score]).reshape(-1)
            person[f"hand_{side}_keypoints_2d"] = _rounded(flat2, 4)
            if with_3d:
                for part in ("pose", "face", "hand_left", "hand_right"):
                    person[f"{part}_keypoints_3d"] = []
                flat3 = np.column_stack([joints, score]).reshape(-1)
                person[f"hand_{side}_keypoints_3d"] = _rounded(flat3, 4)
            out[j].append({"version": 1.3, "people": [person]})
    return out


def openpose_name(camera: str, frame: int) -> str:
    """File name of one OpenPose frame: ``{camera}_{frame:012d}_keypoints.json``."""
    return f"{camera}_{frame:012d}_keypoints.json"


def write_openpose(directory: str | os.PathLike, frames: list, names) -> Path:
    """Write `frames` (`openpose_frames`) as one JSON file per camera and frame.

    The directory is written aside and swapped into place whole (`handvar.atomic`); an
    existing one is replaced.
    """
    directory = Path(check_output_dir(directory, "directory"))
    names = list(names)
    if len(names) != len(frames):
        raise ValueError(f"names: expected one per camera ({len(frames)}); got {len(names)}")

    def write(tmp: str) -> None:
        for name, per_camera in zip(names, frames, strict=True):
            for t, frame in enumerate(per_camera):
                (Path(tmp) / openpose_name(name, t)).write_text(json.dumps(frame), "utf-8")

    with OutputSet() as out:
        out.add(directory, write, directory=True)
    return directory
