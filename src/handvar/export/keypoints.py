"""The 21 keypoints of a track per frame: 2D, 3D, visibility and confidences.

Two layouts (docs/outputs.md):

- handvar's own JSON (:func:`keypoint_frames`, :func:`write_keypoints_json`): one file,
  one record per frame with the world keypoints (mm) and, per camera, the pixels, the
  keypoints in that camera's frame (mm), whether each is visible and whether it falls
  in the image, and each point's confidence;
- OpenPose's per-frame JSON (:func:`openpose_frames`, :func:`write_openpose`), as
  OpenPose's ``--write_json`` writes it: one file per camera and frame, one person
  with every keypoint list at its full length (BODY_25 body, 70 face points, 21 per
  hand; zeros where nothing was found), the tracked hand in ``hand_right_*`` or
  ``hand_left_*`` by its side.

Both hands (`hands_keypoint_frames`, `hands_openpose_frames`; `handvar.export.hands`):
the JSON lists each hand's frames under ``hands``, OpenPose's person holds both.

A frame without a hand (its pose NaN as a whole, `handvar.export.absent`) is written
without points: ``world`` null, confidence 0 and no ``views`` in the JSON, no
``people`` in OpenPose's.

The keypoints are the hand's reported points (`HandModel.landmarks`: on a recording's
track the fingertips and the thumb's base where a detector marks them, otherwise G(x))
in the order of `JOINTS`, which is the 21-point order of MediaPipe Hands and OpenPose's
hand model.

A point's confidence in a camera is its frame's fit confidence (`fit_confidence`)
times what the point's own evidence leaves of it (`point_support`, `PointScores`:
lower where its keypoint was rejected or missing, far from the fit, or carried by
optical flow) and, where the hand itself hides it, `PointScores.hidden`; 0 outside
the image.

Visibility: a keypoint is hidden from a camera when the model's own sphere-mesh
surface lies in front of it along the ray from the camera's optical centre by more
than its own flesh can reach (`joint_reach`) plus a tolerance: the
first surface point in front of a keypoint inside the hand is then its own flesh.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handvar.atomic import OutputSet, check_output_dir, write_atomic
from handvar.export.absent import hand_frames
from handvar.export.hands import checked_hands
from handvar.hand.anthropometry import JOINTS
from handvar.validate import as_array

__all__ = [
    "OPENPOSE_LENGTHS",
    "PointScores",
    "fit_confidence",
    "hands_keypoint_frames",
    "hands_openpose_frames",
    "joint_reach",
    "joint_visibility",
    "keypoint_frames",
    "keypoint_share",
    "openpose_frames",
    "openpose_name",
    "point_support",
    "write_keypoints_json",
    "write_openpose",
]

#: mm a keypoint may lie behind the surface of its own joint and still count as seen.
VISIBILITY_TOLERANCE = 1.0
_N_JOINTS = len(JOINTS)
#: Points per part in OpenPose's JSON: BODY_25 body, the 70-point face, 21 per hand.
OPENPOSE_LENGTHS = {"pose": 25, "face": 70, "hand_left": 21, "hand_right": 21}
_OPENPOSE_VERSION = 1.3


@dataclass(frozen=True)
class PointScores:
    """What lowers a keypoint's confidence below its frame's (docs/outputs.md).

    Each is the factor a point's confidence is multiplied by when it holds: an ordering
    for a reader to rank or threshold points by (1 > far, carried, hidden > missing),
    not a probability fitted to data.

    Attributes
    ----------
    far : float
        The point's kept keypoint lies farther than `threshold` from the fitted joint in
        every camera: the fit does not follow it.
    missing : float
        The frame had keypoints but none was kept for this point in any camera: the fit
        rejected it as an outlier, or the detector gave none.
    carried : float
        The frame's keypoints were carried by optical flow from a detection on another
        frame, not detected on this one.
    hidden : float
        The hand itself hides the point from the camera (`joint_visibility`).
    threshold : float
        Hand sizes: the keypoint check's distance (`handvar.tracking.frame_fit.
        CHECK_THRESHOLD`; export sits below tracking, design §12).
    """

    far: float = 0.5
    missing: float = 0.25
    carried: float = 0.5
    hidden: float = 0.5
    threshold: float = 0.2


def joint_reach(hand) -> np.ndarray:
    """(21,) how far in front of each keypoint its own flesh can reach, mm.

    A keypoint lies in (or on) some cone-spheres of the sphere-mesh; in one whose
    radius at the keypoint's closest axis point is r and whose axis is e away from the
    keypoint (e ≤ r), a ray reaching the keypoint has entered that cone-sphere at most
    r + e in front of it. The largest such r + e over the cone-spheres holding the
    keypoint (`HandModel.landmarks`), at the rest pose (all 26 parameters 0): a joint on
    its finger's axis gets the finger's radius, a fingertip at the finger's end (on the
    surface) the tip's diameter, at its pad's centre its radius, a knuckle inside the palm
    the palm's thickness there.

    Examples
    --------
    >>> from handvar.hand.kinematics import HandModel
    >>> reach = joint_reach(HandModel())
    >>> reach.shape, bool(reach.min() > 0)
    ((21,), True)
    """
    x = np.zeros(26)
    centres, radii = hand.world_spheres(x)  # (P, 2, 3), (P, 2)
    joints = hand.landmarks(x)
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
    joints = hand.landmarks(x)
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


def point_support(quality, detections=None, *, scores: PointScores = PointScores()):
    """(T, 21) what each keypoint's own evidence leaves of its frame's confidence, in
    [0, 1] (`PointScores`): 1 on a frame fitted without keypoints and for a point whose
    kept keypoint the fit follows (within ``scores.threshold`` in some camera),
    ``scores.far`` for one it does not, ``scores.missing`` for a point with no kept
    keypoint on a frame with keypoints, all times ``scores.carried`` on a frame whose
    keypoints were carried.

    Parameters
    ----------
    quality : TrackQuality
        The track's quality: ``keypoints`` (T,), the frames with keypoints, and
        ``distances`` (T, n_cams, 21), hand sizes, NaN where no keypoint or rejected
        (all NaN when the track did not record them: then no point is told missing).
    detections : (T,) array_like of bool, optional
        Frames with a detection (`handvar.Track.detections`); the others with
        keypoints had them carried. None: none known to be carried.
    scores : PointScores, keyword-only

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> d = np.full((2, 1, 21), np.nan); d[0, 0, :3] = [0.1, 0.5, np.nan]
    >>> q = SimpleNamespace(keypoints=np.array([True, False]), distances=d)
    >>> point_support(q)[:, :3].tolist()
    [[1.0, 0.5, 0.25], [1.0, 1.0, 1.0]]
    >>> point_support(q, detections=[False, False])[0, :3].tolist()
    [0.5, 0.25, 0.125]
    """
    d = np.asarray(quality.distances, dtype=float)  # (T, n_cams, 21)
    with_keypoints = np.asarray(quality.keypoints, dtype=bool)[:, None]
    nearest = np.where(np.isnan(d), np.inf, d).min(axis=1)  # (T, 21), inf: none kept
    out = np.ones(nearest.shape)
    if np.isfinite(d).any():  # distances recorded: a point without one was not kept
        out = np.where(with_keypoints & np.isinf(nearest), scores.missing, out)
    out = np.where(np.isfinite(nearest) & (nearest > scores.threshold), scores.far, out)
    if detections is not None:
        detected = as_array(detections, "detections", (len(out),), what="one flag per frame")
        out = np.where(with_keypoints & (detected[:, None] == 0), out * scores.carried, out)
    return out


def _check_inputs(poses, hand, rig, confidence, support=None):
    """The poses, which frames have a hand, the confidences and the points' support,
    checked."""
    poses, present = hand_frames(poses, "poses", (None, 26))
    n = poses.shape[0]
    if confidence is not None:
        confidence = as_array(confidence, "confidence", (n,), what="confidences")
    if support is not None:
        support = as_array(support, "support", (n, _N_JOINTS), what="values in [0, 1]")
    return poses, present, confidence, support


def _point_scores(t, confidence, support, visible, inside, scores: PointScores):
    """(21,) confidence of each point of frame t in one camera (module docstring)."""
    c = 1.0 if confidence is None else float(confidence[t])
    c = c * (np.ones(_N_JOINTS) if support is None else support[t])
    return np.where(inside, np.where(visible, c, c * scores.hidden), 0.0)


def _views(hand, x, rig):
    """Per camera: pixels (21, 2), camera-frame points (21, 3), visible, in image."""
    joints = hand.landmarks(x)
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


def keypoint_frames(poses, hand, rig=None, *, confidence=None, support=None,
                    scores: PointScores = PointScores()) -> dict:  # fmt: skip
    """The keypoints of every frame as one JSON-ready document (docs/outputs.md).

    Parameters
    ----------
    poses : (T, 26) array_like
        The track's poses, mm and degrees; NaN as a whole on a frame without a hand.
    hand : HandModel
        The tracked model (its shape and ``tips`` give the points, `HandModel.landmarks`;
        its surface the visibility).
    rig : Rig, optional
        Cameras; without it only the world keypoints are written.
    confidence : (T,) array_like, keyword-only, optional
        Per-frame fit confidence in [0, 1] (`fit_confidence`); null when absent (0 on a
        frame without a hand all the same).
    support : (T, 21) array_like, keyword-only, optional
        What each point's evidence leaves of its frame's confidence (`point_support`);
        1 when absent.
    scores : PointScores, keyword-only
        The factor of a point hidden by the hand (``hidden``).

    Returns
    -------
    dict
        ``joints`` (the 21 names), ``hand`` (side), ``units``, ``cameras`` (name,
        K, R, t, size) and ``frames``: per frame ``frame``, ``confidence``, ``world``
        (21 × 3 mm) and ``views``, per camera ``camera``, ``keypoints_2d`` (21 × 2
        pixels), ``keypoints_3d`` (21 × 3 mm, camera frame), ``visible`` and
        ``in_image`` (21 booleans) and ``scores`` (21 confidences, as OpenPose's). A
        frame without a hand has ``confidence`` 0, ``world`` null and ``views`` empty.
    """
    poses, present, confidence, support = _check_inputs(poses, hand, rig, confidence, support)
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
            "world": _rounded(hand.landmarks(x), 4) if present[t] else None,
            "views": [],
        }
        if not present[t]:
            record["confidence"] = 0.0  # known: no hand
        if rig is not None and present[t]:
            _, views = _views(hand, x, rig)
            for name, (uv, cam, visible, inside) in zip(rig.names, views, strict=True):
                score = _point_scores(t, confidence, support, visible, inside, scores)
                record["views"].append({
                    "camera": name,
                    "keypoints_2d": _rounded(uv, 3),
                    "keypoints_3d": _rounded(cam, 4),
                    "visible": visible.tolist(),
                    "in_image": inside.tolist(),
                    "scores": _rounded(score, 4),
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


def hands_keypoint_frames(hands, rig=None, *, scores: PointScores = PointScores()) -> dict:
    """The keypoints of several hands as one JSON-ready document (docs/outputs.md).

    Each hand's part is `keypoint_frames`' document without what the hands share: the
    ``joints`` names, ``units`` and ``cameras`` are at the top, each hand under
    ``hands`` with its ``id``, ``side`` and ``frames`` (as `keypoint_frames` writes
    them: a frame without that hand has ``world`` null, ``confidence`` 0, no ``views``).

    Parameters
    ----------
    hands : sequence of TrackedHand
        At most one of each side, over the same frames (`checked_hands`).
    rig : Rig, optional
        Cameras; without it only the world keypoints are written.
    scores : PointScores, keyword-only

    Returns
    -------
    dict
        ``{"format": "handvar-keypoints-hands", "version": 1, "joints", "units",
        "cameras", "hands": [{"id", "side", "frames"}, ...]}``.
    """
    parts = [
        (h, keypoint_frames(h.poses, h.hand, rig, confidence=h.confidence, support=h.support,
                            scores=scores))
        for h in checked_hands(hands)
    ]  # fmt: skip
    first = parts[0][1]
    return {
        "format": "handvar-keypoints-hands",
        "version": 1,
        "joints": first["joints"],
        "units": first["units"],
        "cameras": first["cameras"],
        "hands": [{"id": int(h.id), "side": h.side, "frames": doc["frames"]} for h, doc in parts],
    }


def write_keypoints_json(path: str | os.PathLike, document: dict) -> Path:
    """Write `document` (`keypoint_frames`) to the JSON file `path`, atomically."""
    write_atomic(path, lambda tmp: Path(tmp).write_text(json.dumps(document), encoding="utf-8"))
    return Path(path)


def openpose_frames(poses, hand, rig, *, confidence=None, support=None, with_3d: bool = True,
                    scores: PointScores = PointScores()) -> list:  # fmt: skip
    """The track in OpenPose's per-frame JSON layout, one list of frames per camera.

    Each frame is ``{"version": 1.3, "people": [person]}``, the person with every list
    OpenPose's ``--write_json`` writes, at full length (`OPENPOSE_LENGTHS`):
    ``pose_keypoints_2d`` (75 values), ``face_keypoints_2d`` (210),
    ``hand_left_keypoints_2d`` and ``hand_right_keypoints_2d`` (63 each) as ``x, y, c``
    per point, and with `with_3d` the ``*_keypoints_3d`` lists as ``x, y, z, c`` (100,
    280, 84, 84; OpenPose's ``--3d`` output; without it they are empty, as OpenPose
    writes them then). The tracked hand fills the lists of its side, everything else
    is zeros (OpenPose's "not found"). In 2D, ``x, y`` are pixels and ``c`` the point's
    confidence (module docstring), a point with ``c`` 0 (outside the image, or on a
    lost frame) written as zeros; in 3D, ``x, y, z`` are mm in the world frame and
    ``c`` is 1, or 0 on a lost frame (confidence 0), as OpenPose marks whether its
    reconstruction succeeded. A frame without a hand is ``{"version": 1.3,
    "people": []}``, as OpenPose writes a frame where it found no one.

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without a hand.
    hand : HandModel
    rig : Rig
    confidence : (T,) array_like, keyword-only, optional
        Per-frame fit confidence (`fit_confidence`); 1 when absent.
    support : (T, 21) array_like, keyword-only, optional
        Per point what its evidence leaves of that (`point_support`); 1 when absent.
    with_3d : bool, keyword-only
        Also the 3D keypoints (for calibrated cameras).
    scores : PointScores, keyword-only
        The factor of a point hidden by the hand (``hidden``).

    Returns
    -------
    list of list of dict
        ``[camera][frame]``.
    """
    poses, present, confidence, support = _check_inputs(poses, hand, rig, confidence, support)
    return _openpose([(poses, present, hand, confidence, support)], rig, with_3d, scores)


def _openpose(hands, rig, with_3d: bool, scores: PointScores) -> list:
    """`openpose_frames` of several hands, each ``(poses, present, hand, confidence,
    support)`` checked, of different sides: one person holding every hand in the frame."""
    if rig is None:
        raise ValueError("rig: expected the cameras to project the keypoints into; got None")
    n = hands[0][0].shape[0]
    out: list[list[dict]] = [[] for _ in rig.cameras]
    for t in range(n):
        here = [h for h in hands if h[1][t]]
        if not here:
            for per_camera in out:
                per_camera.append({"version": _OPENPOSE_VERSION, "people": []})
            continue
        lists2: list[dict[str, np.ndarray]] = [{} for _ in rig.cameras]  # per camera
        lists3: dict[str, np.ndarray] = {}
        for poses, _, hand, confidence, support in here:
            side = f"hand_{hand.shape.side}"
            joints, views = _views(hand, poses[t], rig)
            found = 1.0 if confidence is None or confidence[t] > 0 else 0.0
            lists3[side] = np.column_stack([joints, np.ones(_N_JOINTS)]) * found
            for j, (uv, _, visible, inside) in enumerate(views):
                score = _point_scores(t, confidence, support, visible, inside, scores)
                lists2[j][side] = np.where((score > 0)[:, None], np.column_stack([uv, score]),
                                           0.0)  # fmt: skip
        for j in range(len(rig.cameras)):
            person: dict = {"person_id": [-1]}
            for part, k in OPENPOSE_LENGTHS.items():
                points = lists2[j].get(part, np.zeros((k, 3)))
                person[f"{part}_keypoints_2d"] = _rounded(points.reshape(-1), 4)
            for part, k in OPENPOSE_LENGTHS.items():
                points = lists3.get(part, np.zeros((k, 4)))
                person[f"{part}_keypoints_3d"] = _rounded(points.reshape(-1), 4) if with_3d else []
            out[j].append({"version": _OPENPOSE_VERSION, "people": [person]})
    return out


def hands_openpose_frames(hands, rig, *, with_3d: bool = True,
                          scores: PointScores = PointScores()) -> list:  # fmt: skip
    """Several hands in OpenPose's per-frame JSON layout, one list of frames per camera.

    As `openpose_frames`, with one person per frame holding every hand in the frame, each
    in the lists of its side (``hand_right_*``, ``hand_left_*``), zeros for a hand not in
    the frame; ``"people": []`` on a frame with none of them, as OpenPose writes it.

    Parameters
    ----------
    hands : sequence of TrackedHand
        At most one of each side, over the same frames (`checked_hands`).
    rig : Rig
    with_3d, scores : keyword-only
        As `openpose_frames`.

    Returns
    -------
    list of list of dict
        ``[camera][frame]``.
    """
    checked = []
    for h in checked_hands(hands):
        poses, present, confidence, support = _check_inputs(h.poses, h.hand, rig,
                                                            h.confidence, h.support)  # fmt: skip
        checked.append((poses, present, h.hand, confidence, support))
    return _openpose(checked, rig, with_3d, scores)


def openpose_name(camera: str, frame: int) -> str:
    """File name of one OpenPose frame: ``{camera}_{frame:012d}_keypoints.json``."""
    return f"{camera}_{frame:012d}_keypoints.json"


def write_openpose(directory: str | os.PathLike, frames: list, names) -> Path:
    """Write `frames` (`openpose_frames`) as one JSON file per camera and frame.

    With one camera the files go into `directory`; with several, into one folder per
    camera (``directory/<camera>/``), so that each folder is one camera's OpenPose
    output, as a reader of OpenPose folders expects. The directory is written aside
    and swapped into place whole (`handvar.atomic`); an existing one is replaced.
    """
    directory = Path(check_output_dir(directory, "directory"))
    names = list(names)
    if len(names) != len(frames):
        raise ValueError(f"names: expected one per camera ({len(frames)}); got {len(names)}")

    def write(tmp: str) -> None:
        for name, per_camera in zip(names, frames, strict=True):
            folder = Path(tmp) if len(names) == 1 else Path(tmp) / name
            folder.mkdir(exist_ok=True)
            for t, frame in enumerate(per_camera):
                (folder / openpose_name(name, t)).write_text(json.dumps(frame), "utf-8")

    with OutputSet() as out:
        out.add(directory, write, directory=True)
    return directory
