"""The initial pose of the first frame: coarse global search, then local refinement.

The paper fitted its first pose by eye (section 6).  Here it is found automatically from
the first frame's silhouettes:

1. *Candidates*: every combination of a few named hand shapes (`named_pose`: open,
   spread, fist, …) and a grid of palm orientations relative to the first camera —
   roll about its optical axis, pitch and yaw away from it, palm or back of the hand
   towards it (`candidate_rotations`).
2. *Placement*: the translation of each candidate is solved, not searched.  The
   model's silhouette is rendered and moved until its centroid matches the observed
   one in every camera: with two or more cameras the centroids are triangulated (the
   model is shifted by the difference of the triangulated observed and rendered
   centroids); with one camera the centroid fixes the direction and the silhouette's
   area the distance (an image's area falls with the square of the depth, so
   ``d ← d · sqrt(A_model / A_observed)``).  Two updates suffice.
3. *Score*: the intersection over union of the rendered and observed silhouettes,
   averaged over the cameras (`silhouette_iou`).  The search renders at a reduced
   resolution, in a crop around each silhouette (`InitSettings.search_size`).
4. *Refinement*: the best few candidates are tracked for a few passes on the same frame
   with the tracker (`handvar.tracking.tracker.Tracker`, no motion model) at full
   resolution, and the one with the highest IoU is returned.

With 2D keypoints (``keypoints``, design §14.1) the palm's orientation, the side of the hand
that faces the camera, the position and the depth come from them instead, by the fit
the tracker re-initialises with (`handvar.tracking.frame_fit.reinitialise`: the
perspective-n-point poses of the palm, then the keypoint-first fit of all 21 projected
joints from each, with the fingers in each posture of `InitSettings.keypoint_shapes`);
steps 1–3 are skipped, and the search runs only when no camera shows the wrist and the
four MCPs.  Step 4 then refines the keypoint fit
too, and the refined pose is kept only if its keypoint error stays within
`InitSettings.keypoint_slack` pixels of the fit's (the silhouette cannot see inside
itself and may pull the model down a forearm).

Monocular silhouettes are ambiguous: a hand farther away and larger looks the same, and
finger flexion towards or away from the camera changes the silhouette little.  The
search returns the best-fitting candidate; the depth of a monocular fit rests on the
model's hand size and the camera's focal length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from handvar.camera import Camera, Rig
from handvar.hand.kinematics import euler_from_matrix
from handvar.params import N_PARAMS, clamp
from handvar.validate import as_float, as_instance, as_int

__all__ = [
    "INIT_SETTINGS",
    "InitResult",
    "InitSettings",
    "candidate_rotations",
    "initial_pose",
    "silhouette_iou",
]


@dataclass(frozen=True)
class InitSettings:
    """Grid and effort of the initial-pose search (the paper fitted by eye, paper §6).

    Attributes
    ----------
    shapes : tuple of str
        Named hand shapes tried (`handvar.hand.kinematics.POSE_NAMES`); their finger
        angles (parameters 6–25) are used, the global pose is searched.
    roll : tuple of float
        Rotations of the hand about the first camera's optical axis, degrees (0: fingers
        up in the image).  30° steps: the refinement recovers ±15° easily.
    pitch, yaw : tuple of float
        Tilts of the palm away from the camera about its x (image right) and y (image
        down) axes, degrees.
    back : bool
        Also try the back of the hand towards the camera (a right hand then shows its
        thumb on the image's left).
    search_size : int
        Pixels across the larger side of each observed silhouette's bounding box at the
        search resolution (the images are scaled down to it, never up).
    placements : int
        Translation updates per candidate (step 2 of the module notes); the kept
        candidates get two more before the refinement.
    search_tol : float
        Outline accuracy of the search's renderings, pixels at search resolution
        (`handvar.render.silhouette`'s ``tol``; coarser is faster).
    keep : int
        Candidates refined by the tracker: the best-scoring ones whose palm
        orientations differ pairwise by at least `distinct` degrees (the refinement
        settles the finger angles; distinct orientations make it explore).
    distinct : float
        Minimum angle between the orientations of refined candidates, degrees.
    refine_passes : int
        Tracker passes over the first frame per refined candidate (each up to the
        optimiser's `SMDSettings.max_iterations` iterations); 0 skips the refinement.
    keypoint_slack : float
        With keypoints: the silhouette refinement is kept only if it raises the mean
        keypoint error by at most this many pixels (of the masks' resolution).
    keypoint_shapes : tuple of str
        With keypoints: the finger postures each palm pose is fitted from.
    """

    shapes: tuple[str, ...] = ("open", "spread", "fist", "point", "pinch", "thumb_across")
    roll: tuple[float, ...] = tuple(float(a) for a in range(-180, 180, 30))
    pitch: tuple[float, ...] = (-30.0, 0.0, 30.0)
    yaw: tuple[float, ...] = (-30.0, 0.0, 30.0)
    back: bool = True
    search_size: int = 64
    placements: int = 1
    search_tol: float = 0.25
    keep: int = 5
    distinct: float = 25.0
    refine_passes: int = 10
    keypoint_slack: float = 2.0
    keypoint_shapes: tuple[str, ...] = ("open", "fist", "point")

    def __post_init__(self) -> None:
        from handvar.hand.kinematics import POSE_NAMES

        for name in ("shapes", "keypoint_shapes"):
            shapes = getattr(self, name)
            if not shapes or any(s not in POSE_NAMES for s in shapes):
                raise ValueError(
                    f"{name}: expected names among {', '.join(POSE_NAMES)}; got {shapes!r}"
                )
        for name in ("roll", "pitch", "yaw"):
            values = np.asarray(getattr(self, name), dtype=float)
            if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
                raise ValueError(f"{name}: expected a non-empty tuple of angles; got {values}")
        for name, low in (("search_size", 8), ("placements", 1), ("keep", 1), ("refine_passes", 0)):
            as_int(getattr(self, name), name, minimum=low)
        as_float(self.distinct, "distinct", minimum=0, maximum=180)
        as_float(self.search_tol, "search_tol", minimum=0, exclusive_minimum=True)
        as_float(self.keypoint_slack, "keypoint_slack", minimum=0)


INIT_SETTINGS = InitSettings()


@dataclass(frozen=True, eq=False)
class InitResult:
    """The initial pose and how well it fits.

    Attributes
    ----------
    pose : (26,) ndarray
        The pose, mm and degrees.
    iou : float
        Mean IoU over cameras of its silhouette with the observed one, full resolution.
    search_iou : float
        The same for the best candidate of the coarse search, at search resolution
        (with keypoints: the keypoint fit's, at full resolution).
    shape : str
        Named hand shape of the candidate the pose was refined from; ``"keypoints"``
        when it came from keypoints.
    n_candidates : int
        Candidates scored by the search (with keypoints: the fits started,
        `FrameFit.starts`).
    keypoint_error : float
        Mean distance of the projected joints to the keypoints, pixels; NaN without
        keypoints.
    """

    pose: np.ndarray
    iou: float
    search_iou: float
    shape: str
    n_candidates: int
    keypoint_error: float = math.nan


# --- rotations -------------------------------------------------------------------------


def _axis_rotation(axis: int, deg: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotations by `deg` degrees about coordinate axis 0, 1 or 2."""
    t = np.radians(np.asarray(deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    out = np.zeros((*t.shape, 3, 3))
    i, j = [k for k in range(3) if k != axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def candidate_rotations(camera: Camera, settings: InitSettings = INIT_SETTINGS) -> np.ndarray:
    """The palm orientations of the search grid, as Euler angles in the world frame.

    In the camera's frame (x image right, y image down, z along the view), the base
    orientation shows the palm of a right hand with the fingers up and the thumb on
    the image's right: hand x (thumb side) = camera x, hand y (towards the fingers) =
    camera −y, hand z (out of the palm) = camera −z, i.e. ``R_cam_hand0 = Rx(180°)``,
    the orientation of `named_pose` in front of the default rig.  A candidate is::

        R_world_hand = R_camᵀ · Rz(roll) · Ry(yaw) · Rx(pitch) · [Ry(180°)] · R_cam_hand0

    (rotations about the camera's axes; the bracketed factor turns the back of the hand
    to the camera when `InitSettings.back`).

    Parameters
    ----------
    camera : Camera
        The reference camera (its rotation R is world → camera).
    settings : InitSettings

    Returns
    -------
    (K, 3) ndarray
        ``(rx, ry, rz)`` per candidate, degrees, with
        ``K = len(roll) · len(yaw) · len(pitch) · (2 if back else 1)``.
    """
    roll, yaw, pitch = np.meshgrid(
        np.asarray(settings.roll, dtype=float),
        np.asarray(settings.yaw, dtype=float),
        np.asarray(settings.pitch, dtype=float),
        indexing="ij",
    )
    view = (
        _axis_rotation(2, roll.ravel())
        @ _axis_rotation(1, yaw.ravel())
        @ _axis_rotation(0, pitch.ravel())
    )
    base = _axis_rotation(0, np.array(180.0))
    sides = [base] + ([_axis_rotation(1, np.array(180.0)) @ base] if settings.back else [])
    R_cam = np.concatenate([view @ s for s in sides])
    return euler_from_matrix(camera.R.T @ R_cam)


# --- silhouettes -----------------------------------------------------------------------


def silhouette_iou(rendered, observed) -> float:
    """Intersection over union of two stacks of silhouettes, averaged over cameras.

    Parameters
    ----------
    rendered, observed : (n_cams, H, W) bool array_like
        Silhouettes of equal shapes (a single (H, W) mask is one camera).

    Returns
    -------
    float
        Mean over cameras of ``|A ∩ B| / |A ∪ B|`` (a camera where both are empty
        counts as 1).
    """
    a = np.asarray(rendered, dtype=bool)
    b = np.asarray(observed, dtype=bool)
    if a.shape != b.shape or a.ndim not in (2, 3):
        raise ValueError(
            f"rendered, observed: expected silhouettes of one shape (n_cams, H, W); "
            f"got {a.shape} and {b.shape}"
        )
    if a.ndim == 2:
        a, b = a[None], b[None]
    inter = np.logical_and(a, b).sum(axis=(1, 2))
    union = np.logical_or(a, b).sum(axis=(1, 2))
    return float(np.mean(np.where(union > 0, inter / np.maximum(union, 1), 1.0)))


def _check_masks(masks, rig: Rig, *, allow_empty: bool = False) -> np.ndarray:
    m = np.asarray(masks)
    if m.ndim == 2:
        m = m[None]
    if m.ndim != 3 or m.shape[0] != len(rig):
        raise ValueError(
            f"masks: expected (n_cams, H, W) silhouettes for {len(rig)} camera(s); got {m.shape}"
        )
    for j, cam in enumerate(rig):
        if (m.shape[2], m.shape[1]) != tuple(cam.size):
            raise ValueError(
                f"masks: camera {rig.names[j]!r} is calibrated for {cam.size[0]}x{cam.size[1]} "
                f"images; got masks of {m.shape[2]}x{m.shape[1]}"
            )
        if not allow_empty and not m[j].any():
            raise ValueError(f"masks: expected a non-empty silhouette in camera {rig.names[j]!r}")
    return m.astype(bool, copy=False)


@dataclass(frozen=True, eq=False)
class _SearchView:
    """One camera at search resolution, cropped around the observed silhouette."""

    camera: Camera
    mask: np.ndarray  # (h, w) bool, the observed silhouette in the crop
    centroid: np.ndarray  # (2,) pixels
    area: float  # pixels


def _moments(mask: np.ndarray) -> tuple[float, np.ndarray]:
    """Area (pixels) and centroid (u, v) of a mask; area 0 and NaN for an empty mask."""
    m = cv2.moments(mask.view(np.uint8), binaryImage=True)
    if m["m00"] == 0:
        return 0.0, np.full(2, np.nan)
    return float(m["m00"]), np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])


def _search_view(mask: np.ndarray, camera: Camera, size: int) -> _SearchView:
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    extent = max(rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1)
    factor = min(1.0, size / extent)
    cam = camera.scaled(factor)
    small = mask
    if cam.size != camera.size:
        small = cv2.resize(mask.astype(np.float32), cam.size, interpolation=cv2.INTER_AREA) > 0.5
        if not small.any():  # a sliver thinner than a search pixel
            small = cv2.resize(mask.view(np.uint8), cam.size, interpolation=cv2.INTER_NEAREST) > 0
    # Crop: the silhouette's box grown by half its extent on every side.
    r = np.flatnonzero(small.any(axis=1))
    c = np.flatnonzero(small.any(axis=0))
    pad = max(r[-1] - r[0], c[-1] - c[0]) // 2 + 2
    v0, v1 = max(r[0] - pad, 0), min(r[-1] + pad + 1, small.shape[0])
    u0, u1 = max(c[0] - pad, 0), min(c[-1] + pad + 1, small.shape[1])
    crop = Camera(
        cam.fx, cam.fy, cam.cx - u0, cam.cy - v0, dist=cam.dist, R=cam.R, t=cam.t,
        size=(int(u1 - u0), int(v1 - v0)),
    )  # fmt: skip
    sub = np.ascontiguousarray(small[v0:v1, u0:u1])
    area, centroid = _moments(sub)
    return _SearchView(crop, sub, centroid, area)


def _backproject(camera: Camera, pixel: np.ndarray, depth: float) -> np.ndarray:
    """World point at camera depth `depth` (mm) on the ray through `pixel`."""
    origin, direction = camera.rays(pixel[None])
    d = direction[0]
    z = d @ camera.R[2]  # depth per unit length along the ray
    return origin[0] + d * (depth / z)


def _triangulate(cameras: list[Camera], pixels: list[np.ndarray]) -> np.ndarray:
    """Least-squares point nearest to the rays through `pixels` (midpoint method).

    Minimises ``Σ_j ‖(I − d_j d_jᵀ)(P − o_j)‖²`` over P.
    """
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for cam, px in zip(cameras, pixels, strict=True):
        o, d = cam.rays(px[None])
        M = np.eye(3) - np.outer(d[0], d[0])
        A += M
        b += M @ o[0]
    return np.linalg.solve(A, b)


def _render(hand, x: np.ndarray, views: list[_SearchView], tol: float) -> list[np.ndarray]:
    from handvar.render import silhouette_of_spheres

    centres, radii = hand.world_spheres(x)
    return [silhouette_of_spheres(centres, radii, v.camera, tol=tol) for v in views]


def _place(hand, x: np.ndarray, views: list[_SearchView], placements: int, tol: float):
    """Solve the translation of pose `x` (step 2 of the module notes).

    Returns the placed pose and its search-resolution IoU.
    """
    x = x.copy()
    cams = [v.camera for v in views]
    # Start: model centre on the observed centroid's ray (triangulated with several
    # cameras, at a nominal 500 mm depth with one).
    centre = hand.world_spheres(x)[0].reshape(-1, 3).mean(axis=0)
    if len(views) > 1:
        target = _triangulate(cams, [v.centroid for v in views])
    else:
        target = _backproject(cams[0], views[0].centroid, 500.0)
    x[:3] += target - centre
    for _ in range(placements):
        rendered = _render(hand, x, views, tol)
        moments = [_moments(m) for m in rendered]
        seen = [k for k, (area, _) in enumerate(moments) if area > 0]
        if not seen:
            return x, 0.0
        if len(views) > 1 and len(seen) > 1:
            observed = _triangulate([cams[k] for k in seen], [views[k].centroid for k in seen])
            model = _triangulate([cams[k] for k in seen], [moments[k][1] for k in seen])
            x[:3] += observed - model
        else:
            k = seen[0]
            area, centroid = moments[k]
            centre = hand.world_spheres(x)[0].reshape(-1, 3).mean(axis=0)
            d0 = float(cams[k].camera_from_world(centre[None])[0, 2])
            # image area ∝ 1 / depth²: d1 = d0 · sqrt(A_model / A_observed)
            d1 = d0 * math.sqrt(area / views[k].area)
            x[:3] += _backproject(cams[k], views[k].centroid, d1) - _backproject(
                cams[k], centroid, d0
            )
    rendered = _render(hand, x, views, tol)
    # the crops differ in size between cameras: IoU per camera, then the mean
    return x, float(
        np.mean([silhouette_iou(r, v.mask) for r, v in zip(rendered, views, strict=True)])
    )


# --- the search ------------------------------------------------------------------------


def _distinct(order: np.ndarray, poses: np.ndarray, keep: int, min_angle: float) -> list[int]:
    """The first `keep` of `order` whose palm orientations differ by ≥ `min_angle` degrees.

    Greedy in score order; the angle between two orientations is that of the relative
    rotation, ``arccos((tr(R_aᵀ R_b) − 1) / 2)``.
    """
    from handvar.hand.kinematics import world_from_hand_rotation

    chosen: list[int] = []
    rotations: list[np.ndarray] = []
    cos_min = math.cos(math.radians(min_angle))
    for i in order:
        R = world_from_hand_rotation(poses[i, 3:6])[0]
        if all((np.trace(Q.T @ R) - 1.0) / 2.0 < cos_min for Q in rotations):
            chosen.append(int(i))
            rotations.append(R)
            if len(chosen) == keep:
                break
    return chosen


def initial_pose(
    masks,
    rig: Rig,
    hand=None,
    *,
    keypoints=None,
    settings: InitSettings = INIT_SETTINGS,
    rng: np.random.Generator | None = None,
    tracker_settings=None,
) -> InitResult:
    """Find the pose of the hand in one frame's silhouettes (module notes, steps 1–4).

    Parameters
    ----------
    masks : (n_cams, H, W) bool array_like
        The first frame's silhouettes, one per camera of `rig` (a single (H, W) mask
        for a monocular rig).
    rig : Rig
        The cameras; the orientation grid is relative to the first.
    hand : HandModel, optional
        The hand model (default 185 mm hand).
    keypoints : sequence of (21, 2|3) array_like or None, keyword-only, optional
        The frame's 2D keypoints per camera (None for a camera without), in the pixels
        of the masks, confidence in the third column, NaN where missing (module notes;
        `handvar.vision.keypoints`).  The silhouette search is the fallback when no
        camera shows the wrist and the four MCPs.  With keypoints a silhouette may be
        empty (skin colour nowhere, or everywhere): the keypoints place the hand and the
        silhouette refinement is skipped.
    settings : InitSettings, keyword-only
        Search grid and effort.
    rng : numpy.random.Generator, keyword-only, optional
        The refinement's random samples (``default_rng(0)`` by default).
    tracker_settings : TrackerSettings, keyword-only, optional
        Settings of the refining tracker (the paper's by default).

    Returns
    -------
    InitResult

    Raises
    ------
    ValueError
        If the masks do not match the rig (count, size) or a silhouette the pose is
        searched in is empty.

    Examples
    --------
    >>> from handvar.hand import HandModel, named_pose
    >>> from handvar.render import silhouettes
    >>> hand, rig = HandModel(), Rig.default()
    >>> masks = silhouettes(hand, named_pose("spread"), rig)
    >>> result = initial_pose(masks, rig, hand)
    >>> result.iou > 0.9
    True
    """
    from handvar.hand.kinematics import HandModel, named_pose
    from handvar.render import silhouettes

    as_instance(rig, Rig, "rig", what="a handvar.camera.Rig")
    as_instance(settings, InitSettings, "settings")
    hand = HandModel() if hand is None else hand
    m = _check_masks(masks, rig, allow_empty=keypoints is not None)
    rng = np.random.default_rng(0) if rng is None else rng
    as_instance(rng, np.random.Generator, "rng", what="a numpy.random.Generator")

    if keypoints is not None:
        result = _keypoint_pose(m, rig, hand, keypoints, settings, rng, tracker_settings)
        if result is not None:
            return result
        _check_masks(m, rig)  # the silhouette search needs a silhouette in every camera
    views = [_search_view(m[j], cam, settings.search_size) for j, cam in enumerate(rig)]
    rotations = candidate_rotations(rig.cameras[0], settings)
    poses, scores, shapes = [], [], []
    for name in settings.shapes:
        x = named_pose(name)
        for angles in rotations:
            x[3:6] = angles
            placed, score = _place(hand, x, views, settings.placements, settings.search_tol)
            poses.append(placed)
            scores.append(score)
            shapes.append(name)
    scores_arr = np.asarray(scores)
    order = np.argsort(-scores_arr, kind="stable")
    best = _distinct(order, np.asarray(poses), settings.keep, settings.distinct)

    def full_iou(x: np.ndarray) -> float:
        return silhouette_iou(silhouettes(hand, x, rig), m)

    results = []
    for i in best:
        x = clamp(_place(hand, poses[i], views, 2, settings.search_tol)[0])
        results.append((full_iou(x), x, shapes[i]))
        if settings.refine_passes:
            from handvar.predictors import NoMotion
            from handvar.tracking.tracker import Tracker

            tracker = Tracker(rig, hand, NoMotion(), rng, tracker_settings)
            tracker.reset(x)
            for _ in range(settings.refine_passes):
                refined = tracker.step(m).pose
            results.append((full_iou(refined), refined, shapes[i]))
    iou, pose, shape = max(results, key=lambda r: r[0])
    return InitResult(
        pose=np.asarray(pose, dtype=float).reshape(N_PARAMS),
        iou=float(iou),
        search_iou=float(scores_arr[order[0]]),
        shape=shape,
        n_candidates=len(poses),
    )


def _keypoint_pose(m, rig, hand, keypoints, settings, rng, tracker_settings):
    """The pose from keypoints, refined on the silhouettes (module notes); None if none."""
    from handvar.predictors import NoMotion
    from handvar.render import silhouettes
    from handvar.tracking.frame_fit import FrameFitSettings, reinitialise
    from handvar.tracking.keypoint_fit import _frames, keypoint_error
    from handvar.tracking.tracker import Tracker

    tips = "end" if tracker_settings is None else tracker_settings.cost.keypoint_tips
    keypoints = _frames(keypoints, rig)
    fit = reinitialise(keypoints, rig, hand, settings=FrameFitSettings(tips=tips),
                       shapes=settings.keypoint_shapes)  # fmt: skip
    if fit is None:
        return None
    pose = fit.pose
    error = keypoint_error(pose, hand, rig, keypoints, tips=tips)
    iou = silhouette_iou(silhouettes(hand, pose, rig), m)
    fit_iou = iou
    if settings.refine_passes and m.any(axis=(1, 2)).all():  # refined where there is one
        tracker = Tracker(rig, hand, NoMotion(), rng, tracker_settings)
        tracker.reset(pose)
        for _ in range(settings.refine_passes):
            refined = tracker.step(m).pose
        refined_error = keypoint_error(refined, hand, rig, keypoints, tips=tips)
        refined_iou = silhouette_iou(silhouettes(hand, refined, rig), m)
        if refined_error <= error + settings.keypoint_slack and refined_iou > iou:
            pose, error, iou = refined, refined_error, refined_iou
    return InitResult(
        pose=np.asarray(pose, dtype=float).reshape(N_PARAMS),
        iou=float(iou),
        search_iou=float(fit_iou),
        shape="keypoints",
        n_candidates=fit.starts,
        keypoint_error=float(error),
    )
