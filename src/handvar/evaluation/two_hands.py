"""Two hands of one person with ground truth: frames, a detector's labelled hands, calibration.

The two-hand counterpart of the realistic benchmark (`handvar.evaluation.realistic`,
whose scene, look and single-hand detector errors it reuses):

- **the hands**: a LEFT and a RIGHT skinned mesh hand of one person, each of its own
  seeded length (uniform 165–200 mm) and each with its forearm, in one skin tone (drawn
  by the seed from `SKIN_TONES`) with a small albedo difference between them;
- **the motion**: the finger articulation of the one-hand motions (``counting`` for the
  left hand, ``benchmark`` or ``flexion`` by the seed's parity for the right; played back
  and forth when shorter than the case), under the global path of a scenario
  (`SCENARIOS`): minimum-jerk paths of the wrists, the palms roughly towards the camera
  (a yaw of ±10° towards the centre at rest), each hand leaning in the image plane
  towards an elbow below and outside it that follows the hand 60 % of its way, plus a
  slow seeded drift (±8 mm, ±6–8°);
- **the scene**: the realistic benchmark's background, light, colour cast, brightness
  changes, optical blur, sensor noise and motion blur (sub-frame renderings averaged;
  the masks, labels and visibility are the frame time's); both hands, both forearms and
  the optional distractor drawn in one depth buffer per camera, so the nearer surface
  hides the farther;
- **the truth** per hand (0 = left, 1 = right, `TwoHandCase.sides`): poses, the 21 scored
  points (where a detector marks them, as the one-hand benchmark), their
  projections, the hand's visible pixels, which points the OTHER hand (or its forearm)
  hides, and whether the hand is in view;
- **the detector**: per hand the one-hand detector's noise, gross errors and missed frames
  (`detector_keypoints`), then what two hands add (`SwapErrors`): points hidden by the
  other hand marked with a low confidence and displaced, a hand mostly hidden or out of
  view not found, handedness labels flipped in runs of frames, one detection only (the
  front hand's) on some of the frames where the hands overlap, and the detections of a
  frame in random order.

Scenarios (25 fps, 5 s each, 125 frames):

``apart``
    the hands side by side, each moving on its own (the baseline);
``cross``
    the hands swap sides, one 70–95 mm in front of the other, slowing down as they pass,
    so that the front hand hides most of the back one's points for over half a second;
``clap``
    the hands come together at the centre, palm to palm (the pair turned 20–30° from the
    camera's axis, so one hand is partly in front of the other), part halfway, clap once
    more and part; the fingers open as they meet;
``occlude``
    one hand comes 80 mm in front of the other, its arm across it, covering part of it
    (half or more of its points for about a second), and goes back;
``leave``
    one hand leaves the image across its side border (wholly out of view for about 2 s)
    and comes back; the other stays, moving a little.

Everything is seeded: the same arguments give the same frames and detections, bit for bit.

Examples
--------
>>> case = two_hand_case("cross", frames=(40, 42), size=(160, 90))
>>> case.frames.shape, case.truth_2d.shape, case.masks.shape
((1, 2, 90, 160, 3), (1, 2, 2, 21, 2), (1, 2, 2, 90, 160))
>>> [len(found) for found in case.detections[0]] == case.detected[0].sum(0).tolist()
True
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import ClassVar

import numpy as np

from handvar.evaluation.realistic import (
    DISTRACTORS,
    SKIN_TONES,
    DetectorErrors,
    SceneSettings,
    _background,
    _develop,
    _distractor_mesh,
    _HandScene,
    _image_speed,
    _read_frames,
    _render_view,
    _runs,
    _scene_look,
    _sub_frames,
    _write_frames,
    detector_keypoints,
    motion_poses,
    realistic_rig,
)
from handvar.validate import as_float, as_int, one_of
from handvar.vision.keypoints import read_detections, write_detections

__all__ = [
    "SCENARIOS",
    "SCENARIO_FPS",
    "SCENARIO_SECONDS",
    "VISIBLE_POINTS",
    "SwapErrors",
    "TwoHandCase",
    "TwoHandScore",
    "detections_as_tracks",
    "read_two_hand_case",
    "score_two_hands",
    "two_hand_case",
]

#: The scenarios a case may follow (module docstring).
SCENARIOS: tuple[str, ...] = ("apart", "cross", "clap", "occlude", "leave")
#: Frame rate of every scenario (the one-hand motions' whose fingers the hands take).
SCENARIO_FPS = 25.0
#: Length of each scenario, seconds.
SCENARIO_SECONDS = 5.0
#: Points of 21 visible (inside the image, not hidden by the other hand) for a frame to
#: count as one where the hand is visible (`TwoHandScore.lost_visible`): more than half.
VISIBLE_POINTS = 11
#: The two hands, in the order of the truth's hand axis.
SIDES: tuple[str, str] = ("left", "right")

# The resting place of the hands: wrists ±120 mm left and right of the optical axis,
# 90 mm below it (the one-hand motions' height: the hand centred in the image), palms
# turned 10° towards the centre; an elbow 320 mm below each wrist, 170 mm out.
_REST_X, _REST_Y, _REST_YAW = 120.0, 90.0, 10.0
_ELBOW_X, _ELBOW_DROP, _ELBOW_FOLLOWS = 170.0, 320.0, 0.6
# A hand is in view when its visible pixels are at least this fraction of the pixels it
# would cover alone (and its wrist or most of its points are inside the image).
_IN_VIEW_FRACTION = 0.05
# The hands overlap in an image when their silhouettes (each drawn alone) share at least
# this fraction of the smaller one's pixels.
_OVERLAP_FRACTION = 0.1


@dataclasses.dataclass(frozen=True)
class SwapErrors:
    """The errors a detector makes with two hands (`two_hand_case`).

    Attributes
    ----------
    label : float
        Fraction of each hand's frames whose handedness label is the wrong side, in runs
        of 1–5 frames (0.1): MediaPipe's label flips.
    merge : float
        Fraction of the frames where the two hands overlap in the image on which the
        detector gives one hand only, the front one (0.5); in runs of 1–5 frames.
    hidden : float
        A hand whose points the other hand hides for more than this fraction is not
        found (0.6).
    hidden_noise : float
        RMS extra 2D error of a point the other hand hides, hand sizes (0.15), drawn
        afresh each frame: where a detector guesses a point it cannot see.
    hidden_confidence : float
        The confidence given to a point the detector cannot see (hidden by the other hand
        or outside the image) (0.3); seen points have 1.
    """

    label: float = 0.1
    merge: float = 0.5
    hidden: float = 0.6
    hidden_noise: float = 0.15
    hidden_confidence: float = 0.3

    def __post_init__(self) -> None:
        as_float(self.label, "label", minimum=0.0, maximum=0.5)
        as_float(self.merge, "merge", minimum=0.0, maximum=1.0)
        as_float(self.hidden, "hidden", minimum=0.0, maximum=1.0)
        as_float(self.hidden_noise, "hidden_noise", minimum=0.0)
        as_float(self.hidden_confidence, "hidden_confidence", minimum=0.0, maximum=1.0)


# --- the scenarios' global paths -------------------------------------------------------------

# Each scenario gives, per hand, knots (times (K,) s, values (K, 5)) of the wrist position
# x, y, z (mm, world), the yaw (degrees: the palm turned towards +x when positive) and
# the fingers' opening (0: the motion's fingers, 1: the open hand).


def _rest(sigma: float) -> list[float]:
    """The resting knot values of a hand on side `sigma` of the image (+1: right)."""
    return [sigma * _REST_X, _REST_Y, 0.0, -sigma * _REST_YAW, 0.0]


def _knots_apart(rng, sigma, duration):
    out = []
    for s in sigma:  # each hand on its own knots, about one a second
        times = np.cumsum(np.r_[0.0, rng.uniform(0.7, 1.2, 8)])
        times = np.r_[times[times < duration - 0.5], duration]
        values = np.array(
            [[s * _REST_X + rng.uniform(-35, 35), _REST_Y + rng.uniform(-35, 35),
              rng.uniform(-60, 60), -s * _REST_YAW + rng.uniform(-15, 15), 0.0]
             for _ in times]
        )  # fmt: skip
        values[0] = _rest(s)
        out.append((times, values))
    return out


def _knots_cross(rng, sigma, duration):
    front = int(rng.integers(2))
    gap = rng.uniform(70.0, 95.0)
    dy = rng.uniform(-15.0, 15.0, 2)
    times = np.array([0.0, 0.6, 1.4, 2.4, 3.4, duration])
    out = []
    for h, s in enumerate(sigma):
        z = -gap / 2 if h == front else gap / 2
        y = _REST_Y + dy[h]
        values = np.array([
            _rest(s),
            _rest(s),
            [s * 15.0, y, z, 0.0, 0.0],  # about to pass: the front hand over the back one
            [-s * 15.0, y, z, 0.0, 0.0],  # just passed
            [-s * _REST_X, y, z, s * _REST_YAW, 0.0],  # swapped
            [-s * _REST_X, y, z, s * _REST_YAW, 0.0],
        ])  # fmt: skip
        out.append((times, values))
    return out


def _knots_clap(rng, sigma, lengths, duration):
    turn = rng.choice([-1.0, 1.0]) * rng.uniform(20.0, 30.0)  # the pair turned from the axis
    centre = np.array([0.0, _REST_Y + rng.uniform(-20, 20), rng.uniform(-20, 20)])
    yaw_right = 90.0 + turn  # the right hand's palm towards +x, turned
    normal = np.array([math.sin(math.radians(yaw_right)), 0.0,
                       -math.cos(math.radians(yaw_right))])  # fmt: skip
    times = np.array([0.0, 0.6, 1.5, 2.1, 2.7, 3.1, 3.4, 4.3, duration])
    out = []
    for h, s in enumerate(sigma):
        # palms touch: each wrist the palm's thickness (22 mm in a 185 mm hand) from the
        # plane of contact, on its own side
        d = 22.0 * lengths[h] / 185.0
        wrist = centre + s * d * normal  # the left hand (s = +1) on the right hand's palm side
        yaw = yaw_right if s < 0 else yaw_right - 180.0
        touch = [*wrist, yaw, 1.0]
        half = [s * 60.0, _REST_Y, 0.0, 0.5 * yaw, 0.7]
        values = np.array([_rest(s), _rest(s), touch, touch, half, touch, touch,
                           _rest(s), _rest(s)])  # fmt: skip
        out.append((times, values))
    return out


def _knots_occlude(rng, sigma, duration):
    front = int(rng.integers(2))
    back = 1 - front
    sb = sigma[back]
    x_back = sb * 70.0
    cover = rng.uniform(45.0, 65.0)  # the front hand's wrist this far to its own side
    dy = rng.uniform(-30.0, 10.0)
    out = [None, None]
    out[back] = (
        np.array([0.0, 0.6, 1.4, 3.7, 4.4, duration]),
        np.array([_rest(sb), _rest(sb), [x_back, _REST_Y, 40.0, 0.0, 0.0],
                  [x_back, _REST_Y, 40.0, 0.0, 0.0], _rest(sb), _rest(sb)]),
    )  # fmt: skip
    sf = sigma[front]
    over = [x_back + sf * cover, _REST_Y + dy, -40.0, 0.0, 0.0]
    out[front] = (
        np.array([0.0, 0.6, 1.6, 2.7, 3.7, duration]),
        np.array([_rest(sf), _rest(sf), over, over, _rest(sf), _rest(sf)]),
    )
    return out


def _knots_leave(rng, sigma, duration):
    leaving = int(rng.integers(2))
    out = []
    for h, s in enumerate(sigma):
        if h == leaving:
            away = [s * 600.0, _REST_Y + rng.uniform(-30, 30), 0.0, 0.0, 0.0]
            times = np.array([0.0, 0.6, 1.5, 3.0, 3.9, duration])
            values = np.array([_rest(s), _rest(s), away, away, _rest(s), _rest(s)])
        else:  # stays, moving a little
            times = np.array([0.0, 1.2, 2.5, 3.8, duration])
            values = np.array([_rest(s)] + [
                [s * _REST_X + rng.uniform(-25, 25), _REST_Y + rng.uniform(-25, 25),
                 rng.uniform(-30, 30), -s * _REST_YAW, 0.0] for _ in range(3)
            ] + [_rest(s)])  # fmt: skip
        out.append((times, values))
    return out


def _global_paths(scenario: str, rng: np.random.Generator, lengths, t) -> tuple:
    """(2, T, 6) wrist position (mm) and rotation (degrees) of each hand, and (2, T) the
    fingers' opening, at times `t`."""
    from handvar.synth.motion import minimum_jerk_path

    sigma = (1.0, -1.0)  # the left hand on the image's right, the right hand on its left
    duration = SCENARIO_SECONDS
    if scenario == "apart":
        knots = _knots_apart(rng, sigma, duration)
    elif scenario == "cross":
        knots = _knots_cross(rng, sigma, duration)
    elif scenario == "clap":
        knots = _knots_clap(rng, sigma, lengths, duration)
    elif scenario == "occlude":
        knots = _knots_occlude(rng, sigma, duration)
    else:
        knots = _knots_leave(rng, sigma, duration)
    out = np.zeros((2, len(t), 6))
    opening = np.zeros((2, len(t)))
    for h, (times, values) in enumerate(knots):
        path = minimum_jerk_path(t, times, values)
        out[h, :, :3] = path[:, :3]
        # the forearm points to an elbow below the wrist that follows the hand part of its
        # way; the lean is an in-plane roll (rz) while the palm faces the camera, so none
        # as the fingers open towards a clap (the palm then faces sideways)
        elbow = sigma[h] * _ELBOW_X + _ELBOW_FOLLOWS * (path[:, 0] - sigma[h] * _REST_X)
        lean = np.degrees(np.arctan2(path[:, 0] - elbow, _ELBOW_DROP)) * (1.0 - path[:, 4])
        out[h, :, 3] = 180.0  # palm towards the camera, fingers up (`named_pose`)
        out[h, :, 4] = path[:, 3]
        out[h, :, 5] = -lean  # rz > 0 leans the fingers towards −x
        opening[h] = np.clip(path[:, 4], 0.0, 1.0)
    return out, opening


def _fingers(name: str, seed: int, n: int) -> np.ndarray:
    """(n, 20) joint angles of motion `name`, played back and forth to n frames."""
    angles = motion_poses(name, seed)[0][:, 6:]
    m = len(angles)
    k = np.arange(n) % (2 * m - 2) if m > 1 else np.zeros(n, int)
    return angles[np.where(k < m, k, 2 * m - 2 - k)]


def _scenario_poses(scenario: str, seed: int, rng: np.random.Generator, lengths) -> np.ndarray:
    """(2, T, 26) true poses of the whole scenario, mm and degrees."""
    from handvar.params import clamp
    from handvar.synth.sequences import palm_drift

    T = round(SCENARIO_SECONDS * SCENARIO_FPS)
    t = np.arange(T) / SCENARIO_FPS
    glob, opening = _global_paths(scenario, rng, lengths, t)
    right = "benchmark" if seed % 2 == 0 else "flexion"
    poses = np.zeros((2, T, 26))
    for h, motion in enumerate(("counting", right)):
        poses[h, :, :6] = glob[h]
        poses[h, :, 6:] = _fingers(motion, seed, T) * (1.0 - opening[h])[:, None]
        palm_drift(poses[h], t, rng, (("rx", 6.0), ("ry", 8.0), ("rz", 6.0)), 8.0, (1.2, 1.5))
        poses[h] = clamp(poses[h])
    return poses


# --- the case ----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class TwoHandCase:
    """A generated recording of two hands with its ground truth (module docstring).

    Hand h = 0 is the left hand, 1 the right (`sides`); j a camera, T frames.

    Attributes
    ----------
    name : str
    scenario : str
        One of `SCENARIOS`.
    fps : float
    rig : handvar.camera.Rig
    hand_length : (2,) ndarray
        Each hand's length (wrist to middle fingertip), mm.
    skin : str
        Key of `SKIN_TONES` (both hands).
    poses : (2, T, 26) ndarray
        True poses, mm and degrees.
    joints : (2, T, 21, 3) ndarray
        The 21 scored points (a detector's: `keypoint_points` with "pad"), world, mm.
    truth_2d : (n_cams, 2, T, 21, 2) ndarray
        Their projections, pixels.
    visible : (n_cams, 2, T, 21) bool ndarray
        The point is inside the image and the other hand (or its forearm) does not hide
        it: the surface seen at its pixel is not the other hand's nearer than the point.
    in_view : (n_cams, 2, T) bool ndarray
        The hand's visible pixels are at least 5 % of those it covers drawn alone, and
        its wrist or at least 11 of its points are inside the image.
    masks : (n_cams, 2, T, H, W) bool ndarray
        The hand's visible pixels (the mesh hand without the forearm, at the frame time).
    overlap : (n_cams, T) bool ndarray
        The hands' silhouettes (each drawn alone) share at least 10 % of the smaller one.
    keypoints : (n_cams, 2, T, 21, 3) ndarray
        The simulated detector's points of each true hand: x, y (pixels), confidence;
        NaN where the hand was not detected.
    detected : (n_cams, 2, T) bool ndarray
    wrong_label : (n_cams, 2, T) bool ndarray
        The detector labels the hand with the other side (drawn on every frame; it
        matters where `detected`).
    merged : (n_cams, T) bool ndarray
        Frames of overlapping hands on which the detector gives the front hand only.
    gross : (n_cams, 2, T) int ndarray
        The one-hand detector's gross error (`realistic.GROSS_KINDS`, 0 none).
    missed : (n_cams, 2, T) bool ndarray
        The one-hand detector's missed frames.
    detections : list of list of list of Detection
        ``detections[j][t]``: what the detector reports on camera j's frame t, in random
        order (`handvar.vision.keypoints.Detection`: points, side label, score).
    frames : (n_cams, T, H, W, 3) uint8 ndarray
        RGB.
    blurred : (T,) bool ndarray
        Frames rendered with motion blur.
    """

    sides: ClassVar[tuple[str, str]] = SIDES

    name: str
    scenario: str
    fps: float
    rig: object
    hand_length: np.ndarray
    skin: str
    poses: np.ndarray
    joints: np.ndarray
    truth_2d: np.ndarray
    visible: np.ndarray
    in_view: np.ndarray
    masks: np.ndarray
    overlap: np.ndarray
    keypoints: np.ndarray
    detected: np.ndarray
    wrong_label: np.ndarray
    merged: np.ndarray
    gross: np.ndarray
    missed: np.ndarray
    detections: list
    frames: np.ndarray
    blurred: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[1])

    def write(self, directory: str | os.PathLike) -> dict[str, list[Path] | Path]:
        """Write the recording as a user would have it, and its truth.

        ``cam{j}/`` image folders of JPEG frames (``00000.jpg``, …), ``detections{j}.json``
        (the detections per frame, `handvar.vision.keypoints.write_detections`: what
        ``handvar track --hands 2 --keypoints`` reads), ``calib.yml`` (`Rig.save`) and
        ``truth.npz`` (every other attribute).  Returns the paths: ``"frames"``,
        ``"detections"`` (lists, one per camera), ``"calib"``, ``"truth"``.
        """
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        frames, found = [], []
        for j in range(len(self.rig)):
            folder = _write_frames(out / f"cam{j}", self.frames[j])
            path = out / f"detections{j}.json"
            write_detections(path, self.detections[j])
            frames.append(folder)
            found.append(path)
        self.rig.save(out / "calib.yml")
        np.savez_compressed(
            out / "truth.npz", name=self.name, scenario=self.scenario, fps=self.fps,
            hand_length=self.hand_length, skin=self.skin, poses=self.poses,
            joints=self.joints, truth_2d=self.truth_2d, visible=self.visible,
            in_view=self.in_view, masks=np.packbits(self.masks, axis=-1),
            width=self.masks.shape[-1], overlap=self.overlap, keypoints=self.keypoints,
            detected=self.detected, wrong_label=self.wrong_label, merged=self.merged,
            gross=self.gross, missed=self.missed, blurred=self.blurred,
        )  # fmt: skip
        return {"frames": frames, "detections": found, "calib": out / "calib.yml",
                "truth": out / "truth.npz"}  # fmt: skip


def read_two_hand_case(directory: str | os.PathLike, *, frames: bool = False) -> TwoHandCase:
    """A case written by `TwoHandCase.write` (its frames read back only with `frames`)."""
    from handvar.camera import Rig

    d = Path(directory)
    z = np.load(d / "truth.npz")
    rig = Rig.load(d / "calib.yml")
    masks = np.unpackbits(z["masks"], axis=-1, count=int(z["width"])).astype(bool)
    n_cams, _, T = z["detected"].shape
    images = _read_frames(d, n_cams, T, frames)
    detections = [read_detections(d / f"detections{j}.json") for j in range(n_cams)]
    return TwoHandCase(
        name=str(z["name"]), scenario=str(z["scenario"]), fps=float(z["fps"]), rig=rig,
        hand_length=z["hand_length"], skin=str(z["skin"]), poses=z["poses"],
        joints=z["joints"], truth_2d=z["truth_2d"], visible=z["visible"],
        in_view=z["in_view"], masks=masks, overlap=z["overlap"], keypoints=z["keypoints"],
        detected=z["detected"], wrong_label=z["wrong_label"], merged=z["merged"],
        gross=z["gross"], missed=z["missed"], detections=detections, frames=images,
        blurred=z["blurred"],
    )  # fmt: skip


def _point_visibility(uv, depth, part, zbuf, other_parts) -> np.ndarray:
    """(21,) bool: inside the image and not behind the other hand's surface (its parts'
    indices `other_parts` seen nearer than the point at its pixel)."""
    h, w = part.shape
    c = np.rint(uv).astype(np.int64)
    inside = (c[:, 0] >= 0) & (c[:, 0] < w) & (c[:, 1] >= 0) & (c[:, 1] < h)
    out = inside.copy()
    r, q = c[inside, 1], c[inside, 0]
    hidden = np.isin(part[r, q], other_parts) & (zbuf[r, q] < depth[inside])
    out[inside] = ~hidden
    return out


def two_hand_case(
    scenario: str,
    *,
    cameras: int = 1,
    seed: int = 0,
    background: str | np.ndarray = "rectangles",
    skin: str | None = None,
    distractor: str = "none",
    size: tuple[int, int] | None = None,
    frames: tuple[int, int] | None = None,
    # frozen dataclasses: immutable defaults, as `realistic_case`'s
    errors: DetectorErrors = DetectorErrors(),  # noqa: B008
    swaps: SwapErrors = SwapErrors(),
    settings: SceneSettings = SceneSettings(),  # noqa: B008
) -> TwoHandCase:
    """Generate a recording of two hands following `scenario`, with its truth and the
    detections of a simulated detector (module docstring).

    Parameters
    ----------
    scenario : {"apart", "cross", "clap", "occlude", "leave"}
    cameras : {1, 2}, keyword-only
        One camera or a stereo pair (`realistic_rig`).
    seed : int, keyword-only
        Seeds the hands' sizes, the skin (unless given), the path, the scene and the
        detector.
    background : str or (H, W, 3) uint8 ndarray, keyword-only
        One of `realistic.BACKGROUNDS`, or an RGB image resized to the frame size.
    skin : str, keyword-only, optional
        Key of `SKIN_TONES` for both hands; drawn by the seed when omitted.
    distractor : {"none", "arm", "face"}, keyword-only
        The one-hand benchmark's skin-coloured distractor behind the hands (none by
        default: the other hand is the distractor here).
    size : (int, int), keyword-only, optional
        Image size (overrides `settings.size`; the focal length scales with the width).
    frames : (int, int), keyword-only, optional
        The frames [start, stop) of the scenario to render; all by default.
    errors : DetectorErrors, keyword-only
        The detector's errors on each hand.
    swaps : SwapErrors, keyword-only
        The detector's errors with two hands.
    settings : SceneSettings, keyword-only

    Returns
    -------
    TwoHandCase
    """
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.raster import rasterize_triangles
    from handvar.synth.keypoints import hand_size_px
    from handvar.tracking.keypoint_cost import keypoint_points
    from handvar.vision.keypoints import Detection, HandLandmark

    one_of(scenario, SCENARIOS, "scenario")
    one_of(distractor, DISTRACTORS, "distractor")
    seed = as_int(seed, "seed")
    if seed < 0:
        raise ValueError(f"seed: expected a non-negative integer; got {seed}")
    if size is not None:
        settings = dataclasses.replace(settings, size=(int(size[0]), int(size[1])))
    rng = np.random.default_rng([seed, 30, SCENARIOS.index(scenario)])
    lengths = rng.uniform(165.0, 200.0, 2)
    poses = _scenario_poses(scenario, seed, rng, lengths)
    n_all = poses.shape[1]
    if frames is not None:
        start, stop = int(frames[0]), int(frames[1])
        if not 0 <= start < stop <= n_all:
            raise ValueError(f"frames: expected 0 <= start < stop <= {n_all}; got {tuple(frames)}")
    else:
        start, stop = 0, n_all
    prev = poses[:, max(start - 1, 0) : stop - 1]
    poses = poses[:, start:stop].copy()
    if start == 0:
        prev = np.concatenate([poses[:, :1], prev], axis=1)
    T = poses.shape[1]
    fps = SCENARIO_FPS
    rig = realistic_rig(cameras, settings)
    n_cams = len(rig)
    w, h = settings.size
    scenes = [
        _HandScene(HandShape.from_size(float(L), side=s))
        for L, s in zip(lengths, SIDES, strict=True)
    ]
    skin = skin if skin is not None else str(rng.choice(list(SKIN_TONES)))
    one_of(skin, tuple(SKIN_TONES), "skin")
    tone = np.asarray(SKIN_TONES[skin], np.float32) * np.float32(rng.uniform(0.92, 1.05))
    albedo = [tone, tone * rng.uniform(0.95, 1.05, 3).astype(np.float32)]  # a little apart
    other_albedo = np.asarray(SKIN_TONES[str(rng.choice(list(SKIN_TONES)))], np.float32)
    bg = _background(background, (w, h), rng)
    look = _scene_look(rng, T, fps, settings)
    distract = _distractor_mesh(distractor, rng, T, fps)

    joints = np.stack([[keypoint_points(sc.model, x, "pad") for x in p]
                       for sc, p in zip(scenes, poses, strict=True)])  # fmt: skip
    truth_2d = np.stack([cam.project(joints.reshape(-1, 3)).reshape(2, T, 21, 2) for cam in rig])
    depth = np.stack([cam.camera_from_world(joints.reshape(-1, 3))[:, 2].reshape(2, T, 21)
                      for cam in rig])  # fmt: skip
    speed = np.maximum(*(_image_speed(rig, sc.model, p, q, w)
                         for sc, p, q in zip(scenes, poses, prev, strict=True)))  # fmt: skip
    blurred = speed > settings.blur_speed

    # parts: 0 left hand, 1 left forearm, 2 right hand, 3 right forearm, 4 the distractor
    images = np.empty((n_cams, T, h, w, 3), np.uint8)
    masks = np.zeros((n_cams, 2, T, h, w), dtype=bool)
    visible = np.zeros((n_cams, 2, T, 21), dtype=bool)
    alone = np.zeros((n_cams, 2, T), dtype=np.int64)  # pixels of each hand drawn alone
    shared = np.zeros((n_cams, T), dtype=np.int64)  # pixels both silhouettes cover
    for t in range(T):
        subs = _sub_frames(speed[t], blurred[t], settings)
        acc = np.zeros((n_cams, h, w, 3), np.float32)
        for s in subs:
            parts = []
            for k, sc in enumerate(scenes):
                x = prev[k, t] + s * (poses[k, t] - prev[k, t])
                hv = sc.hand_vertices(x)
                parts.append((hv, sc.triangles, albedo[k], True))
                fv, ft = sc.forearm(x, hv, settings.forearm)
                parts.append((fv, ft, albedo[k] * np.float32(0.97), False))
            other = None if distract is None else distract((t - 1 + s) / fps)
            if other is not None:
                parts.append((other[0], other[1], other_albedo, False))
            for j, cam in enumerate(rig):
                args = (cam, parts, bg, look.light, look.ambient, look.diffuse)
                if s != 1.0:
                    acc[j] += _render_view(*args)[0]
                    continue
                img, _, part, zbuf = _render_view(*args, labels=True)
                acc[j] += img
                own = []
                for k in range(2):
                    masks[j, k, t] = part == 2 * k
                    visible[j, k, t] = _point_visibility(
                        truth_2d[j, k, t], depth[j, k, t], part, zbuf, (2 - 2 * k, 3 - 2 * k)
                    )
                    uv = cam.project(parts[2 * k][0])
                    uv[cam.camera_from_world(parts[2 * k][0])[:, 2] <= 1.0] = np.nan
                    own.append(rasterize_triangles(uv, parts[2 * k][1], (w, h), coverage="centre"))
                    alone[j, k, t] = own[k].sum()
                shared[j, t] = (own[0] & own[1]).sum()
        for j in range(n_cams):
            images[j, t] = _develop(acc[j], len(subs), look, t, settings, rng)

    c = truth_2d
    inside = (c[..., 0] > -0.5) & (c[..., 0] < w - 0.5) & (c[..., 1] > -0.5) & (c[..., 1] < h - 0.5)
    placed = inside[..., HandLandmark.WRIST] | (inside.sum(-1) >= 11)
    seen = masks.sum((-2, -1))
    in_view = (alone > 0) & (seen >= _IN_VIEW_FRACTION * alone) & placed
    overlap = shared >= _OVERLAP_FRACTION * np.maximum(np.minimum(alone[:, 0], alone[:, 1]), 1)

    # the detector: one hand's errors for each, then what the other hand does to it
    keypoints = np.full((n_cams, 2, T, 21, 3), np.nan)
    detected = np.zeros((n_cams, 2, T), dtype=bool)
    wrong_label = np.zeros((n_cams, 2, T), dtype=bool)
    merged = np.zeros((n_cams, T), dtype=bool)
    gross = np.zeros((n_cams, 2, T), np.int64)
    missed = np.zeros((n_cams, 2, T), bool)
    detections = []
    for j, cam in enumerate(rig):
        scores = np.empty((2, T))
        for k in range(2):
            size_px = hand_size_px(cam, joints[k])
            xy, gross[j, k], missed[j, k] = detector_keypoints(truth_2d[j, k], size_px, rng,
                                                               errors)  # fmt: skip
            # hidden by the other hand: inside the image yet not visible
            hidden = inside[j, k] & ~visible[j, k]
            extra = rng.standard_normal((T, 21, 2)) * (swaps.hidden_noise / math.sqrt(2.0))
            xy = xy + np.where(hidden[..., None], extra * size_px[:, None, None], 0.0)
            conf = np.where(visible[j, k], 1.0, swaps.hidden_confidence)
            keypoints[j, k] = np.concatenate([xy, conf[..., None]], axis=-1)
            detected[j, k] = (in_view[j, k] & ~missed[j, k]
                              & (hidden.mean(-1) <= swaps.hidden))  # fmt: skip
            wrong_label[j, k] = _runs(T, swaps.label, 5, rng)
            scores[k] = rng.uniform(0.5, 1.0, T)
        both = detected[j].all(0)
        merged[j] = _runs(T, swaps.merge, 5, rng) & overlap[j] & both
        nearer = depth[j].mean(-1)  # (2, T) the hands' mean depth
        back = np.where(nearer[0] <= nearer[1], 1, 0)
        detected[j, back[merged[j]], np.flatnonzero(merged[j])] = False
        keypoints[j][~detected[j]] = np.nan
        per_frame = []
        for t in range(T):
            found = [Detection(points=keypoints[j, k, t],
                               side=SIDES[1 - k] if wrong_label[j, k, t] else SIDES[k],
                               score=float(scores[k, t]))
                     for k in range(2) if detected[j, k, t]]  # fmt: skip
            per_frame.append([found[i] for i in rng.permutation(len(found))])
        detections.append(per_frame)

    return TwoHandCase(
        name=f"{scenario}-{'mono' if n_cams == 1 else 'stereo'}-s{seed}", scenario=scenario,
        fps=fps, rig=rig, hand_length=np.asarray(lengths, float), skin=skin, poses=poses,
        joints=joints, truth_2d=truth_2d, visible=visible, in_view=in_view, masks=masks,
        overlap=overlap, keypoints=keypoints, detected=detected, wrong_label=wrong_label,
        merged=merged, gross=gross, missed=missed, detections=detections, frames=images,
        blurred=blurred,
    )  # fmt: skip


# --- scoring -----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class TwoHandScore:
    """Tracks of two hands against the truth (`score_two_hands`).

    Attributes
    ----------
    ids : tuple
        The tracks' ids, in the order given.
    match : (2, T) int ndarray
        For each true hand and frame, the index into `ids` of the track on it, −1 none.
    track_switches : int
        Times a track's true hand changed from its previous matched frame to its next.
    hand_switches : int
        Times a true hand's track changed from its previous matched frame to its next.
    pck : (2,) ndarray
        Per true hand (left, right), 2D PCK@`threshold` over all 21 points of the frames
        where the hand is in view; a frame without a track on the hand counts as wrong.
    mpjpe : (2,) ndarray
        Absolute 3D error, mm, over the in-view frames with a track on the hand that has
        3D joints (NaN when none).
    mpjpe_relative : (2,) ndarray
        The same, wrist-relative.
    lost : (2,) int ndarray
        In-view frames without a track on the hand.
    lost_visible : (2,) int ndarray
        Of those, the frames where at least `VISIBLE_POINTS` of its 21 points are
        visible (inside the image, not hidden by the other hand).
    frames_in_view : (2,) int ndarray
    drawn_off : int
        Track-frames matched to no true hand: a track present (a finite point) on a frame
        where it is matched to neither (off its hand by more than the gate, or where
        there is none).
    drawn_away : int
        Of those, the track-frames farther than `away` hand sizes from both true hands:
        a hand drawn where there is none.
    """

    ids: tuple
    match: np.ndarray
    track_switches: int
    hand_switches: int
    pck: np.ndarray
    mpjpe: np.ndarray
    mpjpe_relative: np.ndarray
    lost: np.ndarray
    lost_visible: np.ndarray
    frames_in_view: np.ndarray
    drawn_off: int = 0
    drawn_away: int = 0

    @property
    def switches(self) -> int:
        """Identity switches: a track changing hands, plus a hand changing tracks."""
        return self.track_switches + self.hand_switches


def _changes(labels: np.ndarray) -> int:
    """Changes of value between successive non-negative entries (gaps bridged)."""
    seen = labels[labels >= 0]
    return int(np.count_nonzero(seen[1:] != seen[:-1]))


def score_two_hands(case: TwoHandCase, tracks: dict, *, camera: int = 0,
                    threshold: float = 0.2, gate: float = 0.5,
                    away: float = 1.0) -> TwoHandScore:  # fmt: skip
    """Score tracks of two hands against `case`'s truth on one camera.

    Each frame, as CLEAR MOT does, the previous frame's pairs whose track is present (a
    finite point) and still within the gate are kept, and the other tracks present are
    matched one to one to the other true hands by the least total mean 2D distance
    (Hungarian assignment), each distance in the true hand's size (f · L / z,
    `handvar.synth.keypoints.hand_size_px`); a pair more
    than `gate` hand sizes apart is no match.  Every true hand takes part, in view or
    not.  Identity switches count, over the matched frames (gaps bridged, as CLEAR MOT's),
    each change of a track's true hand and each change of a true hand's track.  A true
    hand in view without a matched track is lost on that frame.

    Parameters
    ----------
    case : TwoHandCase
    tracks : dict
        Track id → ``{"points_2d": (T, 21, 2) pixels of camera `camera`, NaN where the
        track has no hand, "joints": (T, 21, 3) world mm or None}``.
    camera : int, keyword-only
    threshold : float, keyword-only
        PCK's threshold, in the true wrist → middle-MCP length in the image
        (`handvar.evaluation.metrics.pck_2d`).
    gate : float, keyword-only
        Largest mean distance of a match, hand sizes.
    away : float, keyword-only
        Least mean distance from both true hands, hand sizes, of a track drawn where
        there is no hand (`TwoHandScore.drawn_away`): one hand size, so that a track
        off its hand but still overlapping it is not counted.

    Returns
    -------
    TwoHandScore
    """
    from scipy.optimize import linear_sum_assignment

    from handvar.evaluation.metrics import joint_errors, pck_2d
    from handvar.synth.keypoints import hand_size_px

    camera = as_int(camera, "camera", minimum=0, maximum=len(case.rig) - 1)
    T = case.n_frames
    ids = tuple(tracks)
    points, joints = [], []
    for key in ids:
        track = tracks[key]
        p = np.asarray(track["points_2d"], dtype=float)
        if p.shape != (T, 21, 2):
            raise ValueError(f"tracks[{key!r}]['points_2d']: expected shape ({T}, 21, 2); "
                             f"got {p.shape}")  # fmt: skip
        points.append(p)
        q = track.get("joints")
        if q is not None:
            q = np.asarray(q, dtype=float)
            if q.shape != (T, 21, 3):
                raise ValueError(f"tracks[{key!r}]['joints']: expected shape ({T}, 21, 3); "
                                 f"got {q.shape}")  # fmt: skip
        joints.append(q)
    truth = case.truth_2d[camera]  # (2, T, 21, 2)
    size = np.stack([hand_size_px(case.rig[camera], case.joints[k]) for k in range(2)])
    match = np.full((2, T), -1, dtype=np.int64)
    drawn = away_count = 0  # track-frames present; of them, away from both hands
    for t in range(T):
        present = [i for i, p in enumerate(points) if np.isfinite(p[t]).any()]
        drawn += len(present)
        if not present:
            continue
        cost = np.empty((len(present), 2))
        for a, i in enumerate(present):
            with np.errstate(invalid="ignore"):
                d = np.linalg.norm(points[i][t][None] - truth[:, t], axis=-1)  # (2, 21)
            cost[a] = np.nanmean(d, axis=1) / size[:, t]
        away_count += int(np.count_nonzero(cost.min(axis=1) > away))
        kept = {}  # CLEAR MOT: last frame's pairs still within the gate are kept
        for k in range(2):
            i = match[k, t - 1] if t else -1
            if i in present and cost[present.index(i), k] <= gate:
                kept[k] = i
        free_rows = [a for a, i in enumerate(present) if i not in kept.values()]
        free_cols = [k for k in range(2) if k not in kept]
        sub = cost[np.ix_(free_rows, free_cols)]
        rows, cols = linear_sum_assignment(np.where(sub <= gate, sub, 1e6))
        for a, k in zip(rows, cols, strict=True):
            if sub[a, k] <= gate:
                kept[free_cols[k]] = present[free_rows[a]]
        for k, i in kept.items():
            match[k, t] = i
    hand_switches = sum(_changes(match[k]) for k in range(2))
    track_of = np.full((len(ids), T), -1, dtype=np.int64)
    for k in range(2):
        on = match[k] >= 0
        track_of[match[k, on], np.flatnonzero(on)] = k
    track_switches = sum(_changes(row) for row in track_of)

    pck, abs_err, rel_err = np.full(2, np.nan), np.full(2, np.nan), np.full(2, np.nan)
    lost, n_view = np.zeros(2, np.int64), np.zeros(2, np.int64)
    lost_visible = np.zeros(2, np.int64)
    for k in range(2):
        view = case.in_view[camera, k]
        n_view[k] = view.sum()
        lost[k] = (view & (match[k] < 0)).sum()
        seen = case.visible[camera, k].sum(axis=1) >= VISIBLE_POINTS
        lost_visible[k] = (view & seen & (match[k] < 0)).sum()
        if not view.any():
            continue
        est2 = np.full((T, 21, 2), np.nan)
        est3 = np.full((T, 21, 3), np.nan)
        for t in np.flatnonzero(match[k] >= 0):
            est2[t] = points[match[k, t]][t]
            if joints[match[k, t]] is not None:
                est3[t] = joints[match[k, t]][t]
        pck[k] = pck_2d(truth[k, view], est2[view], threshold)
        scored = view & np.isfinite(est3).all((1, 2))
        if scored.any():
            abs_err[k] = joint_errors(case.joints[k, scored], est3[scored], alignment="none").mean()
            rel_err[k] = joint_errors(case.joints[k, scored], est3[scored]).mean()
    return TwoHandScore(ids=ids, match=match, track_switches=track_switches,
                        hand_switches=hand_switches, pck=pck, mpjpe=abs_err,
                        mpjpe_relative=rel_err, lost=lost, lost_visible=lost_visible,
                        frames_in_view=n_view,
                        drawn_off=drawn - int(np.count_nonzero(match >= 0)),
                        drawn_away=away_count)  # fmt: skip


def detections_as_tracks(case: TwoHandCase, *, camera: int = 0) -> dict:
    """The detector's hands as a user of its labels would track them: the label is the id.

    Returns
    -------
    dict
        ``{"left": {...}, "right": {...}}`` as `score_two_hands` takes them (no joints);
        of two detections with the same label in a frame, the higher score's.
    """
    camera = as_int(camera, "camera", minimum=0, maximum=len(case.rig) - 1)
    T = case.n_frames
    tracks = {side: {"points_2d": np.full((T, 21, 2), np.nan), "joints": None} for side in SIDES}
    for t, found in enumerate(case.detections[camera]):
        best: dict[str, float] = {}
        for d in found:
            if d.side in tracks and d.score > best.get(d.side, -1.0):
                best[d.side] = d.score
                tracks[d.side]["points_2d"][t] = d.points[:, :2]
    return tracks
