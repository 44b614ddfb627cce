"""Realistic recordings with ground truth: colour frames, detector-like keypoints, calibration.

A test for the real-video path that a user's recording would be, with the truth known
(docs/realistic-benchmark.md):

- **the hand**: the skinned mesh hand (`handvar.hand.mesh`, a right hand; a left hand is
  its mirror image in the hand frame's y–z plane, as `HandShape.mirrored`) of a seeded
  size, with a forearm (an elliptic tube continuing from the wrist along the hand's −y
  axis past the image border), shaded by Lambert's law in one of several skin tones
  (`SKIN_TONES`, light to dark);
- **the scene**: a background image (a real frame given by the caller, or a generated
  one: `textured_background`), skin-coloured distractors (a second arm or a face-like
  ellipsoid that enter and leave), slow and sudden brightness changes, a colour cast,
  a slight optical blur, sensor noise, and motion blur (the average of sub-frame
  renderings) on frames where the hand moves fast;
- **the motion**: the paper's sequences (``benchmark``, ``flip``, ``flexion``,
  `handvar.synth.sequences`), ``counting`` (fist, one to four fingers, spread hand,
  from the named hand shapes of `handvar.hand.kinematics`) and ``fast`` (the same
  gestures three times as fast, twice over, the palm moving with them);
- **the keypoints** of a detector (`detector_keypoints`): the true points with an AR(1)
  noise of `DetectorErrors.noise` hand sizes, gross errors on `DetectorErrors.gross` of
  the frames (a finger's points swapped with its neighbour's, a fingertip snapped to its
  knuckle, the whole hand shifted) and missed frames (NaN);
- **the truth**: poses (mm, degrees), the 21 points in the world frame (the camera frame
  of camera 0 for one camera), their projections, and the hand's mask per camera.

The 21 points everything is scored on are the detector's: G(x) with each fingertip at the
centre of its pad, one tip radius short of G(x)'s tip, and the thumb's base up its
metacarpal (design §14.6, `handvar.tracking.keypoint_cost.keypoint_points` with
``tips="pad"``); the simulated detector marks them there, as MediaPipe does.

Everything is seeded: the same arguments give the same frames, bit for bit.

Examples
--------
>>> case = realistic_case("flip", seed=0, frames=(0, 2), size=(160, 90))
>>> case.frames.shape, case.keypoints.shape, case.truth_2d.shape
((1, 2, 90, 160, 3), (1, 2, 21, 2), (1, 2, 21, 2))
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import cv2
import numpy as np

from handvar.validate import as_float, as_int, one_of

__all__ = [
    "BACKGROUNDS",
    "DISTRACTORS",
    "FAST_PACE",
    "GROSS_KINDS",
    "MOTIONS",
    "SKIN_TONES",
    "DetectorErrors",
    "RealisticCase",
    "SceneSettings",
    "counting_poses",
    "detector_keypoints",
    "motion_poses",
    "read_case",
    "realistic_case",
    "realistic_rig",
    "textured_background",
]

#: Skin albedos, RGB, light to dark (sRGB values of lit skin patches, rounded).
SKIN_TONES: dict[str, tuple[int, int, int]] = {
    "light": (236, 196, 170),
    "medium": (212, 160, 124),
    "olive": (184, 134, 96),
    "brown": (140, 94, 66),
    "dark": (92, 62, 46),
}
#: Motions a case may follow.
MOTIONS: tuple[str, ...] = ("benchmark", "flip", "flexion", "counting", "fast", "faster")
#: The ``fast`` motion's pace: the counting gestures this many times as fast (the
#: ``faster`` motion: twice that).
FAST_PACE = 3.0
#: Generated backgrounds (`textured_background`).
BACKGROUNDS: tuple[str, ...] = ("gradient", "rectangles", "fridge")
#: Skin-coloured distractors.
DISTRACTORS: tuple[str, ...] = ("none", "arm", "face")
#: Kinds of gross keypoint errors, coded 1, 2, 3 in `RealisticCase.gross` (0: none).
GROSS_KINDS: tuple[str, ...] = ("swap", "tip", "shift")


@dataclasses.dataclass(frozen=True)
class DetectorErrors:
    """The errors of the simulated keypoint detector (`detector_keypoints`).

    Hand size: ``f · L / z`` pixels, L the true wrist → middle-MCP length and z the depth
    of the palm point ½(G_0 + G_9) (as `handvar.synth.keypoints.synthetic_keypoints`).

    Attributes
    ----------
    noise : float
        RMS 2D error of a point, hand sizes (0.05): each coordinate an AR(1) series of
        standard deviation ``noise / √2``.
    correlation : float
        The AR(1) coefficient from one frame to the next (0.8): the error of a point
        drifts over a few frames, as a detector's does.
    gross : float
        Fraction of the frames with a gross error (0.05), in runs of 1–3 frames, the
        kind drawn uniformly from `GROSS_KINDS`.
    shift : (float, float)
        Range of the whole hand's shift of a ``"shift"`` error, hand sizes.
    missed : float
        Fraction of the frames the detector misses (all 21 points NaN), in runs of 1–4
        frames (0.03).
    """

    noise: float = 0.05
    correlation: float = 0.8
    gross: float = 0.05
    shift: tuple[float, float] = (0.3, 0.8)
    missed: float = 0.03

    def __post_init__(self) -> None:
        as_float(self.noise, "noise", minimum=0.0)
        as_float(self.correlation, "correlation", minimum=0.0, maximum=0.999)
        as_float(self.gross, "gross", minimum=0.0, maximum=0.5)
        as_float(self.missed, "missed", minimum=0.0, maximum=0.5)


@dataclasses.dataclass(frozen=True)
class SceneSettings:
    """Cameras, lighting and the blur of a realistic case.

    Attributes
    ----------
    size : (int, int)
        Image (width, height), pixels (640 × 360).
    focal : float
        Focal length at 640 pixels wide, pixels (scaled with the width).
    distance : float
        Camera to the world origin (where the motions place the hand), mm.
    baseline : float
        Distance between the two cameras of a stereo rig, mm.
    forearm : float
        Length of the forearm tube from the wrist, mm (it leaves the image).
    exposure : float
        Fraction of the frame interval the shutter is open (motion blur).
    blur_speed : float
        Fastest point's image speed (pixels per frame at 640 wide) above which a frame
        is rendered with motion blur.
    brightness : float
        Amplitude of the slow brightness change (a gain of 1 ± this).
    noise_sigma : float
        Sensor noise, grey levels.
    """

    size: tuple[int, int] = (640, 360)
    focal: float = 480.0
    distance: float = 560.0
    baseline: float = 200.0
    forearm: float = 450.0
    exposure: float = 0.5
    blur_speed: float = 6.0
    brightness: float = 0.2
    noise_sigma: float = 2.5


def realistic_rig(cameras: int = 1, settings: SceneSettings = SceneSettings()):
    """One camera facing the world origin from −z, or a convergent stereo pair.

    Returns
    -------
    handvar.camera.Rig
        Image up = world −y (the motions' hands point their fingers up); a stereo pair
        is `baseline` apart along world x, both optical axes through the origin.
    """
    from handvar.camera import Camera, Rig

    cameras = as_int(cameras, "cameras")
    if cameras not in (1, 2):
        raise ValueError(f"cameras: expected 1 or 2; got {cameras}")
    w, h = settings.size
    f = settings.focal * w / 640.0
    if cameras == 1:
        return Rig([Camera.look_at((0.0, 0.0, -settings.distance), fx=f, size=(w, h))])
    half = settings.baseline / 2.0
    z = -math.sqrt(settings.distance**2 - half**2)
    cams = [Camera.look_at((s * half, 0.0, z), fx=f, size=(w, h)) for s in (-1.0, 1.0)]
    return Rig(cams, ("left", "right"))


# --- motions -----------------------------------------------------------------------------


def counting_poses(
    seed: int = 0, fps: float = 25.0, *, pace: float = 1.0, rounds: int = 1
) -> np.ndarray:
    """Counting and spread gestures: fist, then one to four fingers, the spread hand, fist.

    Key poses from the named hand shapes (`handvar.hand.kinematics.named_pose`): the
    fist; "one" the pointing hand; two to four extend the middle, ring and little
    fingers in turn (their angles from the open hand); then the spread hand; each held
    briefly, with minimum-jerk transitions of seeded durations (0.35–0.6 s, holds
    0.15–0.35 s, each divided by `pace`) and a drift of the palm (as the paper's
    sequences, `handvar.synth.sequences`: ±10–15° and ±15 mm, knots every 1.2 and
    1.5 s divided by `pace`); the gestures `rounds` times over.

    Returns
    -------
    (T, 26) ndarray
        mm and degrees, within the joint limits.
    """
    from handvar.hand.kinematics import named_pose
    from handvar.params import clamp, digit_angles
    from handvar.synth.motion import keyframe_motion
    from handvar.synth.sequences import palm_drift

    pace = as_float(pace, "pace", minimum=0.0, exclusive_minimum=True)
    rng = np.random.default_rng([int(seed), 10])
    fist, point, spread = named_pose("fist"), named_pose("point"), named_pose("spread")
    keys = [fist, point]
    current = point.copy()
    for digit in (2, 3, 4):  # middle, ring, little join the index
        current = current.copy()
        current[digit_angles(digit)] = 0.0  # the open hand's angles
        keys.append(current)
    keys += [spread]
    keys = keys * as_int(rounds, "rounds", minimum=1) + [fist]
    durations = rng.uniform(0.35, 0.6, len(keys) - 1) / pace
    holds = rng.uniform(0.15, 0.35, len(keys)) / pace
    poses = keyframe_motion(np.array(keys), durations, holds=holds, fps=fps)
    t = np.arange(len(poses)) / fps
    palm_drift(poses, t, rng, (("rx", 10.0), ("ry", 15.0), ("rz", 10.0)), 15.0,
               (1.2 / pace, 1.5 / pace))  # fmt: skip
    return clamp(poses)


def motion_poses(name: str, seed: int = 0) -> tuple[np.ndarray, float]:
    """True poses (T, 26) and frame rate of the motion called `name` (`MOTIONS`)."""
    from handvar.synth.sequences import SEQUENCE_FPS, sequence_poses

    one_of(name, MOTIONS, "motion")
    if name == "counting":
        return counting_poses(seed), 25.0
    if name == "fast":  # FAST_PACE times the pace, twice over
        return counting_poses(seed, pace=FAST_PACE, rounds=2), 25.0
    if name == "faster":  # twice that, four times over (as many frames)
        return counting_poses(seed, pace=2 * FAST_PACE, rounds=4), 25.0
    return sequence_poses(name, seed), SEQUENCE_FPS[name]


# --- backgrounds -------------------------------------------------------------------------


def textured_background(kind: str, size: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A generated background, (H, W, 3) uint8 RGB.

    ``gradient``: a smooth two-colour gradient with low-frequency shading;
    ``rectangles``: clutter of coloured rectangles and bars, some of them in warm,
    skin-like hues (wood, cardboard); ``fridge``: a white or metal door of vertical panels
    with strong vertical edges, handles and a wood-grain strip.
    """
    one_of(kind, BACKGROUNDS, "kind")
    w, h = int(size[0]), int(size[1])
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    if kind == "gradient":
        a, b = rng.uniform(40, 230, (2, 3)).astype(np.float32)
        angle = rng.uniform(0, 2 * np.pi)
        s = (np.cos(angle) * xx / w + np.sin(angle) * yy / h + 1.0) / 2.0
        img = a + (b - a) * np.clip(s, 0, 1)[..., None]
    elif kind == "rectangles":
        img = np.empty((h, w, 3), np.float32)
        img[:] = rng.uniform(60, 200, 3)
        for _ in range(int(rng.integers(25, 45))):
            if rng.random() < 0.25:  # warm: wood, cardboard, beige
                col = np.array([rng.uniform(150, 230), rng.uniform(100, 170), rng.uniform(50, 120)])
            else:
                col = rng.uniform(0, 255, 3)
            x0, y0 = rng.uniform(-0.1, 1.0) * w, rng.uniform(-0.1, 1.0) * h
            x1, y1 = x0 + rng.uniform(0.03, 0.35) * w, y0 + rng.uniform(0.03, 0.35) * h
            cv2.rectangle(img, (int(x0), int(y0)), (int(x1), int(y1)), col.tolist(), -1)
    else:  # fridge
        base = rng.uniform(170, 235) if rng.random() < 0.6 else rng.uniform(120, 170)
        img = np.empty((h, w, 3), np.float32)
        img[:] = base * np.array([1.0, 1.0, rng.uniform(0.97, 1.05)])
        img *= (0.85 + 0.15 * xx / w)[..., None]  # light falling off across the door
        edges = np.sort(rng.uniform(0.05, 0.95, int(rng.integers(2, 5)))) * w
        for x in edges:  # panel gaps: dark vertical lines with a highlight beside
            cv2.line(img, (int(x), 0), (int(x), h), (30, 30, 30), int(rng.integers(2, 5)))
            cv2.line(img, (int(x) + 3, 0), (int(x) + 3, h), (250, 250, 250), 1)
        for x in rng.choice(edges, 2):  # handles
            y0 = rng.uniform(0.1, 0.5) * h
            cv2.rectangle(img, (int(x) - 12, int(y0)), (int(x) - 6, int(y0 + 0.3 * h)),
                          (90, 90, 95), -1)  # fmt: skip
        x0 = rng.uniform(0, 0.85) * w  # a wooden shelf (skin-like hue), part of the height
        y0 = int(rng.uniform(0.0, 0.6) * h)
        y1 = int(y0 + rng.uniform(0.15, 0.4) * h)
        grain = 20 * np.sin(yy[y0:y1, :1] / rng.uniform(3, 8) + rng.uniform(0, 6))
        wood = np.array([176, 120, 74], np.float32) + grain[..., None].astype(np.float32)
        x1 = int(x0 + rng.uniform(0.06, 0.15) * w)
        img[y0:y1, int(x0) : x1] = wood
    field = rng.standard_normal((h // 40 + 2, w // 40 + 2)).astype(np.float32)
    img = img * (1.0 + 0.06 * cv2.resize(field, (w, h), interpolation=cv2.INTER_CUBIC))[..., None]
    return np.clip(img, 0, 255).astype(np.uint8)


# --- geometry of the scene -----------------------------------------------------------------


def _tube(start, direction, u, v, radii0, radii1, length, rings: int = 8, sides: int = 24):
    """Vertices (rings·sides, 3) and triangles of an elliptic tube, tapering linearly.

    Ring k is centred at ``start + s_k · direction`` with half-axes along u and v
    interpolated from `radii0` to `radii1`; triangles wind outward.
    """
    s = np.linspace(0.0, length, rings)
    a = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    frac = (s / length)[:, None]
    ru = radii0[0] + (radii1[0] - radii0[0]) * frac
    rv = radii0[1] + (radii1[1] - radii0[1]) * frac
    verts = (
        start[None, None, :]
        + s[:, None, None] * direction[None, None, :]
        + (ru * np.cos(a))[..., None] * u[None, None, :]
        + (rv * np.sin(a))[..., None] * v[None, None, :]
    ).reshape(-1, 3)
    k, j = np.meshgrid(np.arange(rings - 1), np.arange(sides), indexing="ij")
    p0 = (k * sides + j).ravel()
    p1 = (k * sides + (j + 1) % sides).ravel()
    p2 = p0 + sides
    p3 = p1 + sides
    tris = np.concatenate([np.stack([p0, p2, p1], 1), np.stack([p1, p2, p3], 1)])
    return verts, tris


def _ellipsoid(centre, radii, n_lat: int = 16, n_lon: int = 24):
    """Vertices and outward triangles of an axis-aligned ellipsoid."""
    lat = np.linspace(0.0, np.pi, n_lat)
    lon = np.linspace(0.0, 2 * np.pi, n_lon, endpoint=False)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    unit = np.stack([np.sin(la) * np.cos(lo), np.cos(la), np.sin(la) * np.sin(lo)], -1)
    verts = (centre + unit * radii).reshape(-1, 3)
    k, j = np.meshgrid(np.arange(n_lat - 1), np.arange(n_lon), indexing="ij")
    p0 = (k * n_lon + j).ravel()
    p1 = (k * n_lon + (j + 1) % n_lon).ravel()
    tris = np.concatenate([np.stack([p0, p1, p0 + n_lon], 1),
                           np.stack([p1, p1 + n_lon, p0 + n_lon], 1)])  # fmt: skip
    return verts, _outward(verts, tris, centre)


def _outward(verts, tris, centre):
    a, b, c = (verts[tris[:, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", n, (a + b + c) / 3.0 - centre) < 0
    out = tris.copy()
    out[flip] = out[flip][:, ::-1]
    return out


def _tube_outward(verts, tris, start, direction):
    """Wind a tube's triangles outward from its axis (start + s · direction)."""
    a, b, c = (verts[tris[:, i]] for i in range(3))
    centre = (a + b + c) / 3.0
    rel = centre - start
    radial = rel - np.outer(rel @ direction, direction)
    n = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", n, radial) < 0
    out = tris.copy()
    out[flip] = out[flip][:, ::-1]
    return out


class _HandScene:
    """The hand (mesh, mirrored for a left hand) and its forearm at a pose."""

    def __init__(self, shape) -> None:
        from handvar.hand.kinematics import HandModel

        self.shape = shape
        self.side = shape.side
        right = shape if shape.side == "right" else shape.mirrored()
        self.right = HandModel(right, surface="mesh")
        self.model = HandModel(shape) if shape.side != "right" else self.right
        tris = self.right.mesh.triangles
        self.triangles = tris if self.side == "right" else tris[:, ::-1].copy()

    def hand_vertices(self, x) -> np.ndarray:
        from handvar.hand.kinematics import world_from_hand_rotation

        v = self.right.mesh.vertices(x)
        if self.side == "right":
            return v
        R, _ = world_from_hand_rotation(x[3:6])
        mirror = np.diag([-1.0, 1.0, 1.0])
        return (v - x[:3]) @ R @ mirror @ R.T + x[:3]

    def forearm(self, x, hand_vertices, length: float):
        """The forearm tube: from inside the palm along the hand's −y axis."""
        from handvar.hand.kinematics import world_from_hand_rotation

        R, _ = world_from_hand_rotation(x[3:6])
        wrist = x[:3]
        local = (hand_vertices - wrist) @ R  # hand frame
        near = np.abs(local[:, 1]) < 8.0  # the mesh's cross-section at the wrist
        if near.sum() >= 8:
            half_w = 0.5 * np.ptp(local[near, 0])
            half_t = 0.5 * np.ptp(local[near, 2])
            mid = np.array([local[near, 0].mean(), 0.0, local[near, 2].mean()])
        else:
            half_w, half_t, mid = 28.0, 18.0, np.zeros(3)
        start = wrist + R @ (mid + np.array([0.0, 12.0, 0.0]))
        d = -R[:, 1]
        r0 = np.array([half_w * 0.95, half_t * 0.95])
        verts, tris = _tube(start, d, R[:, 0], R[:, 2], r0, r0 * 1.3, length + 12.0)
        return verts, _tube_outward(verts, tris, start, d)


def _distractor_mesh(kind: str, rng: np.random.Generator, n_frames: int, fps: float):
    """A function frame-time → (vertices, triangles) or None, for a distractor entering and
    leaving the view behind the hand."""
    from handvar.synth.motion import minimum_jerk_path

    if kind == "none":
        return None
    duration = n_frames / fps
    t_in = rng.uniform(0.05, 0.3) * duration
    t_out = t_in + rng.uniform(0.35, 0.6) * duration
    ramp = 0.25 * duration
    side = rng.choice([-1.0, 1.0])
    if kind == "arm":
        # a second forearm reaching in from a side border, 120–250 mm behind the hand
        depth = rng.uniform(120.0, 250.0)
        y = rng.uniform(-60.0, 120.0)
        tilt = rng.uniform(-0.4, 0.4)
        reach = rng.uniform(140.0, 260.0)  # how far towards the centre its end comes

        def at(t):
            s = float(minimum_jerk_path([t], [t_in, t_in + ramp, t_out, t_out + ramp],
                                        [0.0, 1.0, 1.0, 0.0])[0])  # fmt: skip
            if s <= 0.0:
                return None
            end = np.array([side * (700.0 - s * (700.0 - reach)), y, depth])
            d = np.array([side, tilt, 0.0])
            d /= np.linalg.norm(d)
            verts, tris = _tube(end, d, np.array([0.0, 0.0, 1.0]), np.cross(d, [0.0, 0.0, 1.0]),
                                np.array([30.0, 24.0]), np.array([42.0, 34.0]), 700.0)  # fmt: skip
            return verts, _tube_outward(verts, tris, end, d)

        return at
    # a face-like ellipsoid passing behind, partly in view at a side
    depth = rng.uniform(250.0, 450.0)
    y = rng.uniform(-150.0, 50.0)
    radii = np.array([75.0, 100.0, 80.0]) * rng.uniform(0.9, 1.1)

    def at_face(t):
        s = float(minimum_jerk_path([t], [t_in, t_in + ramp, t_out, t_out + ramp],
                                    [0.0, 1.0, 1.0, 0.0])[0])  # fmt: skip
        if s <= 0.0:
            return None
        centre = np.array([side * (650.0 - s * 330.0), y, depth])
        return _ellipsoid(centre, radii)

    return at_face


# --- rendering -----------------------------------------------------------------------------


def _render_view(camera, parts, background, light, ambient, diffuse, *, labels: bool = False):
    """One camera's shaded image (float32 RGB, H × W × 3) and the hand's mask.

    `parts`: (vertices, triangles, albedo RGB, is_hand) in drawing order; one depth
    buffer for all (the nearest surface wins).  With `labels`, also the index into
    `parts` of the surface seen at each pixel ((H, W) int, −1 for the background) and its
    camera depth ((H, W), mm, inf for the background): ``img, mask, part, depth``.
    """
    from handvar.geometry.normals import vertex_normals
    from handvar.hand.raster import rasterize_triangles
    from handvar.render.mesh import pixel_normals

    verts, tris, albedo, hand_tri, normals, part_tri = [], [], [], [], [], []
    offset = 0
    for k, (v, t, colour, is_hand) in enumerate(parts):
        part_tri.append(np.full(len(t), k))
        verts.append(v)
        tris.append(t + offset)
        normals.append(vertex_normals(v, t))
        albedo.append(np.repeat(np.asarray(colour, np.float32)[None], len(t), 0))
        hand_tri.append(np.full(len(t), is_hand))
        offset += len(v)
    V, Tr, N = np.concatenate(verts), np.concatenate(tris), np.concatenate(normals)
    A, H = np.concatenate(albedo), np.concatenate(hand_tri)
    z = camera.camera_from_world(V)[:, 2]
    uv = camera.project(V)
    uv[z <= 1.0] = np.nan
    _, tri_id, zbuf = rasterize_triangles(uv, Tr, camera.size, coverage="centre", depth=z)
    img = background.astype(np.float32).copy()
    rows, cols = np.nonzero(tri_id >= 0)
    mask = np.zeros(tri_id.shape, dtype=bool)
    if rows.size:
        t = tri_id[rows, cols]
        n = pixel_normals(uv, Tr, N, rows, cols, t)
        lambert = np.maximum(n @ light, 0.0)
        img[rows, cols] = A[t] * (ambient + diffuse * lambert)[:, None]
        mask[rows, cols] = H[t]
    if not labels:
        return img, mask
    part = np.full(tri_id.shape, -1, dtype=np.int64)
    part[rows, cols] = np.concatenate(part_tri)[tri_id[rows, cols]]
    return img, mask, part, zbuf


def _background(background, size: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """The case's background, (H, W, 3) uint8: generated (`textured_background`) for a name,
    else the caller's RGB image resized to `size`."""
    if isinstance(background, str):
        return textured_background(background, size, rng)
    bg = np.asarray(background)
    if bg.ndim != 3 or bg.shape[2] != 3:
        raise ValueError(f"background: expected an (H, W, 3) image; got shape {bg.shape}")
    return cv2.resize(bg.astype(np.uint8), size, interpolation=cv2.INTER_AREA)


@dataclasses.dataclass(frozen=True)
class _Look:
    """The light and the camera's response of a case (drawn by `_scene_look`)."""

    light: np.ndarray  # (3,) unit vector towards the light
    ambient: float
    diffuse: float
    cast: np.ndarray  # (3,) float32 white balance
    gain: np.ndarray  # (T,) brightness of each frame


def _scene_look(rng: np.random.Generator, T: int, fps: float, settings: SceneSettings) -> _Look:
    """Draw the light, the colour cast and the brightness of each frame (a slow sine and
    one exposure step)."""
    light = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.9, -0.3), -1.0])
    light /= np.linalg.norm(light)
    ambient, diffuse = float(rng.uniform(0.35, 0.5)), float(rng.uniform(0.5, 0.7))
    cast = rng.uniform(0.9, 1.1, 3).astype(np.float32)  # white balance
    tt = np.arange(T) / fps
    gain = 1.0 + settings.brightness * np.sin(2 * np.pi * tt / rng.uniform(2.0, 5.0)
                                              + rng.uniform(0, 2 * np.pi))  # fmt: skip
    jump = int(rng.integers(T // 3, max(T // 3 + 1, 2 * T // 3)))
    gain[jump:] *= rng.choice([0.8, 1.2])  # an exposure step
    return _Look(light, ambient, diffuse, cast, gain)


def _image_speed(rig, model, poses, prev, width: int) -> np.ndarray:
    """(T,) the fastest joint's image speed from `prev` to `poses`, pixels per frame at
    640 wide, the fastest camera's."""
    T = len(poses)
    ends = np.stack([model.joints(x) for x in prev])
    speed = np.zeros(T)
    for cam in rig:
        now = cam.project(np.stack([model.joints(x) for x in poses]).reshape(-1, 3))
        before = cam.project(ends.reshape(-1, 3))
        v = np.linalg.norm(now - before, axis=1).reshape(T, 21).max(1) * 640.0 / width
        speed = np.maximum(speed, v)
    return speed


def _sub_frames(speed: float, blurred: bool, settings: SceneSettings):
    """The fractions s of the frame interval rendered and averaged for motion blur
    (``[1.0]``: the frame time only)."""
    n_sub = int(min(6, math.ceil(speed * settings.exposure / 2.0))) if blurred else 1
    return np.linspace(1.0 - settings.exposure, 1.0, n_sub) if n_sub > 1 else [1.0]


def _develop(acc, n_sub: int, look: _Look, t: int, settings: SceneSettings,
             rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """The camera's frame t from the sum `acc` of `n_sub` shaded renderings: colour cast,
    gain, optical blur, sensor noise; (H, W, 3) uint8."""
    img = acc / np.float32(n_sub) * look.cast * np.float32(look.gain[t])
    img = cv2.GaussianBlur(img, (0, 0), 0.7)
    img += np.float32(settings.noise_sigma) * rng.standard_normal(img.shape, dtype=np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


@dataclasses.dataclass(frozen=True, eq=False)
class RealisticCase:
    """A generated recording with its ground truth (module docstring).

    Attributes
    ----------
    name : str
    fps : float
    rig : handvar.camera.Rig
    side : {"right", "left"}
    hand_length : float
        The true hand's length (wrist to middle fingertip), mm.
    skin : str
        Key of `SKIN_TONES`.
    poses : (T, 26) ndarray
        True poses, mm and degrees, of a hand of `hand_length` and `side`.
    joints : (T, 21, 3) ndarray
        The 21 scored points (a detector's: `keypoint_points` with "pad"), world, mm.
    truth_2d : (n_cams, T, 21, 2) ndarray
        Their projections, pixels.
    keypoints : (n_cams, T, 21, 2) ndarray
        The simulated detector's, pixels; NaN on missed frames.
    gross : (n_cams, T) int ndarray
        Gross error of each frame's keypoints: 0 none, 1 + index into `GROSS_KINDS`.
    missed : (n_cams, T) bool ndarray
    frames : (n_cams, T, H, W, 3) uint8 ndarray
        RGB.
    masks : (n_cams, T, H, W) bool ndarray
        The hand's pixels (the mesh hand without forearm, unblurred frame time).
    blurred : (T,) bool ndarray
        Frames rendered with motion blur.
    """

    name: str
    fps: float
    rig: object
    side: str
    hand_length: float
    skin: str
    poses: np.ndarray
    joints: np.ndarray
    truth_2d: np.ndarray
    keypoints: np.ndarray
    gross: np.ndarray
    missed: np.ndarray
    frames: np.ndarray
    masks: np.ndarray
    blurred: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[0])

    def write(self, directory: str | os.PathLike) -> dict[str, list[Path] | Path]:
        """Write the recording as a user would have it, and its truth.

        ``cam{j}/`` image folders of JPEG frames (``00000.jpg``, …), ``keypoints{j}.npy``
        ((T, 21, 2), pixels, NaN where missed: what `handvar track --keypoints` reads),
        ``calib.yml`` (`Rig.save`, what ``--calib`` reads) and ``truth.npz`` (every other
        attribute).  Returns the paths: ``"frames"``, ``"keypoints"`` (lists, one per
        camera), ``"calib"``, ``"truth"``.
        """
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        frames, kps = [], []
        for j in range(len(self.rig)):
            folder = _write_frames(out / f"cam{j}", self.frames[j])
            np.save(out / f"keypoints{j}.npy", self.keypoints[j])
            frames.append(folder)
            kps.append(out / f"keypoints{j}.npy")
        self.rig.save(out / "calib.yml")
        np.savez_compressed(
            out / "truth.npz", name=self.name, fps=self.fps, side=self.side,
            hand_length=self.hand_length, skin=self.skin, poses=self.poses,
            joints=self.joints, truth_2d=self.truth_2d, keypoints=self.keypoints,
            gross=self.gross, missed=self.missed, masks=np.packbits(self.masks, axis=-1),
            width=self.masks.shape[-1], blurred=self.blurred,
        )  # fmt: skip
        return {"frames": frames, "keypoints": kps, "calib": out / "calib.yml",
                "truth": out / "truth.npz"}  # fmt: skip


def _write_frames(folder: Path, frames: np.ndarray) -> Path:
    """RGB `frames` (T, H, W, 3) as the JPEG image folder ``folder/00000.jpg``, …"""
    folder.mkdir(exist_ok=True)
    for t, rgb in enumerate(frames):
        if not cv2.imwrite(str(folder / f"{t:05d}.jpg"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR),
                           [cv2.IMWRITE_JPEG_QUALITY, 92]):  # fmt: skip
            raise OSError(f"{folder}: cannot write the frames")
    return folder


def _read_frames(directory: Path, n_cams: int, T: int, read: bool) -> np.ndarray:
    """The RGB frames (n_cams, T, H, W, 3) of ``directory/cam{j}/`` (`_write_frames`);
    empty ones when not `read`."""
    if not read:
        return np.zeros((n_cams, T, 0, 0, 3), np.uint8)
    return np.stack([
        np.stack([cv2.cvtColor(cv2.imread(str(directory / f"cam{j}" / f"{t:05d}.jpg")),
                               cv2.COLOR_BGR2RGB) for t in range(T)])
        for j in range(n_cams)
    ])  # fmt: skip


def read_case(directory: str | os.PathLike, *, frames: bool = False) -> RealisticCase:
    """A case written by `RealisticCase.write` (its frames read back only with `frames`)."""
    from handvar.camera import Rig

    d = Path(directory)
    z = np.load(d / "truth.npz")
    rig = Rig.load(d / "calib.yml")
    masks = np.unpackbits(z["masks"], axis=-1, count=int(z["width"])).astype(bool)
    n_cams, T = z["keypoints"].shape[:2]
    images = _read_frames(d, n_cams, T, frames)
    return RealisticCase(
        name=str(z["name"]), fps=float(z["fps"]), rig=rig, side=str(z["side"]),
        hand_length=float(z["hand_length"]), skin=str(z["skin"]), poses=z["poses"],
        joints=z["joints"], truth_2d=z["truth_2d"], keypoints=z["keypoints"],
        gross=z["gross"], missed=z["missed"], frames=images, masks=masks,
        blurred=z["blurred"],
    )  # fmt: skip


# --- keypoints -----------------------------------------------------------------------------


def _runs(n: int, rate: float, longest: int, rng: np.random.Generator) -> np.ndarray:
    """(n,) bool: runs of 1…`longest` frames (uniform) covering a fraction `rate` on average.

    A run starts at a free frame with probability p = f / (f + D̄(1 − f)) (f = `rate`,
    D̄ the mean run length): the renewal cycle of a geometric gap of mean (1 − p)/p and a
    run of mean D̄ then covers f of the frames.
    """
    out = np.zeros(n, dtype=bool)
    if rate <= 0:
        return out
    mean = (1 + longest) / 2.0
    p = rate / (rate + mean * (1.0 - rate))
    t = 0
    while t < n:
        if rng.random() < p:
            d = int(rng.integers(1, longest + 1))
            out[t : t + d] = True
            t += d
        else:
            t += 1
    return out


def detector_keypoints(truth_2d, hand_size, rng: np.random.Generator,
                       errors: DetectorErrors = DetectorErrors()):  # fmt: skip
    """Keypoints with a detector's kinds of error, from the true points of one camera.

    Parameters
    ----------
    truth_2d : (T, 21, 2) array_like
        True points, pixels.
    hand_size : (T,) array_like
        Hand size per frame, pixels (`DetectorErrors`).
    rng : numpy.random.Generator
    errors : DetectorErrors

    Returns
    -------
    keypoints : (T, 21, 2) ndarray
        Pixels; NaN on missed frames.
    gross : (T,) int ndarray
        0, or 1 + index into `GROSS_KINDS` of the frame's gross error.
    missed : (T,) bool ndarray

    Notes
    -----
    The first frame is detected and free of gross errors (a user starts where the
    detector sees the hand).
    """
    from handvar.vision.keypoints import MCP

    P = np.asarray(truth_2d, dtype=float)
    size = np.asarray(hand_size, dtype=float)
    if P.ndim != 3 or P.shape[1:] != (21, 2):
        raise ValueError(f"truth_2d: expected shape (T, 21, 2); got shape {P.shape}")
    if size.shape != (P.shape[0],):
        raise ValueError(f"hand_size: expected shape ({P.shape[0]},); got shape {size.shape}")
    T = P.shape[0]
    rho = errors.correlation
    sigma = errors.noise / math.sqrt(2.0)
    e = np.empty((T, 21, 2))
    e[0] = rng.standard_normal((21, 2)) * sigma
    for t in range(1, T):  # AR(1): e_t = ρ e_{t-1} + √(1 − ρ²) σ ε_t
        e[t] = rho * e[t - 1] + math.sqrt(1.0 - rho**2) * sigma * rng.standard_normal((21, 2))
    out = P + e * size[:, None, None]
    gross_on = _runs(T, errors.gross, 3, rng)
    missed = _runs(T, errors.missed, 4, rng)
    gross_on[0] = missed[0] = False
    kind = np.where(gross_on, rng.integers(1, len(GROSS_KINDS) + 1, T), 0)
    # a run keeps one error: the kind and its parameters of the run's first frame
    finger = rng.integers(1, 4, T)  # swap digit d (index, middle, ring) with d + 1
    digit = rng.integers(0, 5, T)  # snap the tip of this digit
    angle = rng.uniform(0.0, 2 * np.pi, T)
    amount = rng.uniform(*errors.shift, T)
    for t in range(1, T):
        if gross_on[t] and gross_on[t - 1]:
            kind[t], finger[t], digit[t] = kind[t - 1], finger[t - 1], digit[t - 1]
            angle[t], amount[t] = angle[t - 1], amount[t - 1]
    for t in np.flatnonzero(kind):
        name = GROSS_KINDS[kind[t] - 1]
        if name == "swap":
            a = slice(1 + 4 * finger[t], 5 + 4 * finger[t])
            b = slice(5 + 4 * finger[t], 9 + 4 * finger[t])
            out[t, a], out[t, b] = out[t, b].copy(), out[t, a].copy()
        elif name == "tip":
            knuckle = 2 if digit[t] == 0 else MCP[digit[t] - 1]
            out[t, 4 + 4 * digit[t]] = out[t, knuckle]
        else:
            out[t] += amount[t] * size[t] * np.array([np.cos(angle[t]), np.sin(angle[t])])
    out[missed] = np.nan
    kind[missed] = 0
    return out, kind.astype(np.int64), missed


# --- the case ------------------------------------------------------------------------------


def personal_shape(shape, spread: float, rng: np.random.Generator):
    """`shape` as one person's hand: the palm's length and breadth each scaled by
    exp(N(0, spread²)), each digit's three bones by another such factor, and each digit
    base's position and each bone's length by one of half that spread on top (a
    person's knuckles keep their arch, a digit's bones their ratios only roughly); the
    radii kept.  The wrist → middle-tip length changes with them."""
    spread = as_float(spread, "proportions", minimum=0.0)
    z = rng.standard_normal
    bones = np.exp(spread * z((5, 1)) + 0.5 * spread * z((5, 3)))
    across = np.exp(spread * z() + 0.5 * spread * z(5))
    along = np.exp(spread * z() + 0.5 * spread * z(5))
    scale = np.stack([across, along, across], axis=1)
    tip = (shape.bases[2, 1] * along[2] + (shape.segments[2] * bones[2]).sum()) / (
        shape.bases[2, 1] + shape.segments[2].sum())  # fmt: skip
    return dataclasses.replace(shape, segments=shape.segments * bones,
                               bases=shape.bases * scale, length=shape.length * tip)  # fmt: skip


def realistic_case(
    motion: str,
    *,
    cameras: int = 1,
    side: str = "right",
    seed: int = 0,
    background: str | np.ndarray = "rectangles",
    skin: str | None = None,
    distractor: str = "arm",
    frames: tuple[int, int] | None = None,
    size: tuple[int, int] | None = None,
    errors: DetectorErrors = DetectorErrors(),
    settings: SceneSettings = SceneSettings(),
    proportions: float = 0.0,
) -> RealisticCase:
    """Generate a realistic recording of `motion` with its ground truth (module docstring).

    Parameters
    ----------
    motion : {"benchmark", "flip", "flexion", "counting", "fast", "faster"}
    cameras : {1, 2}, keyword-only
        One camera or a stereo pair (`realistic_rig`).
    side : {"right", "left"}, keyword-only
    seed : int, keyword-only
        Seeds the motion, the hand's size, the skin (unless given), the scene and the
        detector.
    background : str or (H, W, 3) uint8 ndarray, keyword-only
        One of `BACKGROUNDS`, or an RGB image (e.g. a frame of a real video without a
        hand), resized to the frame size; the same for every camera and frame (fixed
        cameras).
    skin : str, keyword-only, optional
        Key of `SKIN_TONES`; drawn by the seed when omitted.
    distractor : {"none", "arm", "face"}, keyword-only
    frames : (int, int), keyword-only, optional
        The frames [start, stop) of the motion to render; all by default.
    size : (int, int), keyword-only, optional
        Image size (overrides `settings.size`; the focal length scales with the width).
    errors : DetectorErrors, keyword-only
    settings : SceneSettings, keyword-only
    proportions : float, keyword-only
        σ of the person's departure from the published average proportions (0: the
        average hand): each bone's length and each digit base's position along and
        across the palm scaled by exp(N(0, σ²)), drawn by the seed (`personal_shape`).

    Returns
    -------
    RealisticCase
    """
    from handvar.hand.anthropometry import HandShape
    from handvar.synth.keypoints import hand_size_px
    from handvar.tracking.keypoint_cost import keypoint_points

    one_of(side, ("right", "left"), "side")
    one_of(distractor, DISTRACTORS, "distractor")
    seed = as_int(seed, "seed")
    if seed < 0:
        raise ValueError(f"seed: expected a non-negative integer; got {seed}")
    if size is not None:
        settings = dataclasses.replace(settings, size=(int(size[0]), int(size[1])))
    rng = np.random.default_rng([seed, 20, MOTIONS.index(motion) if motion in MOTIONS else 0])
    poses, fps = motion_poses(motion, seed)
    if frames is not None:
        start, stop = int(frames[0]), int(frames[1])
        if not 0 <= start < stop <= len(poses):
            raise ValueError(
                f"frames: expected 0 <= start < stop <= {len(poses)}; got {tuple(frames)}"
            )
    else:
        start, stop = 0, len(poses)
    prev = poses[max(start - 1, 0) : stop - 1]
    poses = poses[start:stop].copy()
    if start == 0:
        prev = np.concatenate([poses[:1], prev])
    T = len(poses)
    rig = realistic_rig(cameras, settings)
    w, h = settings.size
    length = float(rng.uniform(172.0, 198.0))
    shape = HandShape.from_size(length, side=side)
    if proportions > 0:
        shape = personal_shape(shape, proportions, np.random.default_rng([seed, 21]))
        length = float(shape.bases[2, 1] + shape.segments[2].sum())
    scene = _HandScene(shape)
    skin = skin if skin is not None else str(rng.choice(list(SKIN_TONES)))
    one_of(skin, tuple(SKIN_TONES), "skin")
    albedo = np.asarray(SKIN_TONES[skin], np.float32) * np.float32(rng.uniform(0.92, 1.05))
    other_albedo = np.asarray(SKIN_TONES[str(rng.choice(list(SKIN_TONES)))], np.float32)
    bg = _background(background, (w, h), rng)
    look = _scene_look(rng, T, fps, settings)
    distract = _distractor_mesh(distractor, rng, T, fps)

    joints = np.stack([keypoint_points(scene.model, x, "pad") for x in poses])
    n_cams = len(rig)
    truth_2d = np.stack([cam.project(joints.reshape(-1, 3)).reshape(T, 21, 2) for cam in rig])
    speed = _image_speed(rig, scene.model, poses, prev, w)
    blurred = speed > settings.blur_speed

    images = np.empty((n_cams, T, h, w, 3), np.uint8)
    masks = np.zeros((n_cams, T, h, w), dtype=bool)
    for t in range(T):
        subs = _sub_frames(speed[t], blurred[t], settings)
        acc = np.zeros((n_cams, h, w, 3), np.float32)
        for s in subs:
            x = prev[t] + s * (poses[t] - prev[t])
            hv = scene.hand_vertices(x)
            parts = [(hv, scene.triangles, albedo, True)]
            fv, ft = scene.forearm(x, hv, settings.forearm)
            parts.append((fv, ft, albedo * np.float32(0.97), False))
            other = None if distract is None else distract((t - 1 + s) / fps)
            if other is not None:
                parts.append((other[0], other[1], other_albedo, False))
            for j, cam in enumerate(rig):
                img, mask = _render_view(cam, parts, bg, look.light, look.ambient,
                                         look.diffuse)  # fmt: skip
                acc[j] += img
                if s == 1.0:
                    masks[j, t] = mask
        for j in range(n_cams):
            images[j, t] = _develop(acc[j], len(subs), look, t, settings, rng)

    kps = np.empty((n_cams, T, 21, 2))
    gross = np.zeros((n_cams, T), np.int64)
    missed = np.zeros((n_cams, T), bool)
    for j, cam in enumerate(rig):
        size_px = hand_size_px(cam, joints)
        kps[j], gross[j], missed[j] = detector_keypoints(truth_2d[j], size_px, rng, errors)
    return RealisticCase(
        name=f"{motion}-{'mono' if n_cams == 1 else 'stereo'}-{side}-s{seed}", fps=fps,
        rig=rig, side=side, hand_length=length, skin=skin, poses=poses, joints=joints,
        truth_2d=truth_2d, keypoints=kps, gross=gross, missed=missed, frames=images,
        masks=masks, blurred=blurred,
    )  # fmt: skip
