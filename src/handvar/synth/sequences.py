"""The paper's three synthetic sequences, with ground truth (design §8).

- :func:`benchmark` — the 175-frame, 25 fps stereo test sequence of paper §4:
  finger articulation replayed from a real recording (htrack ``fingerfist``, see
  :mod:`handvar.synth.motion`), palm rotations, a fast little-finger movement near
  frame 73, a global rotation near frame 100 and the thumb crossing the palm near
  frame 150 — the three error peaks of the paper's figure 4.
- :func:`flexion` — 280 frames like the first real sequence of paper §6: each digit
  flexes alone, then the fingers flex together, some of them fast.
- :func:`flip` — 80 frames like the second real sequence of paper §6: the palm turns
  fully away from the cameras (its normal more than 150° from the direction to
  them) and back.

Each function returns the true poses (T, 26) (mm, degrees, within the joint limits)
and is deterministic for a given seed; the seed varies amplitudes, durations, the
placement of the replayed excerpt and the slow drift of the palm, never the frame
count nor the frames of the named events. :func:`render_sequence` turns poses into a
:class:`handvar.io.Sequence` (silhouettes, optional colour frames, ground-truth
joints); :func:`make_sequence` does both by name.

All motion is human-like: every parameter moves along minimum-jerk profiles or a
replayed real recording, and no joint angle changes faster than 1000°/s.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable

import numpy as np

from handvar.hand.kinematics import named_pose
from handvar.params import N_PARAMS, clamp, index
from handvar.synth.motion import (
    HTRACK_EXCERPT_FIRST_ROW,
    builtin_recording,
    minimum_jerk_path,
    replay,
)
from handvar.validate import as_float, as_int

__all__ = [
    "SEQUENCE_FPS",
    "SEQUENCE_NAMES",
    "BenchmarkSettings",
    "FlexionSettings",
    "FlipSettings",
    "benchmark",
    "flexion",
    "flip",
    "make_sequence",
    "palm_drift",
    "render_sequence",
    "sequence_poses",
]

_FINGERS = ("index", "middle", "ring", "little")


@dataclasses.dataclass(frozen=True)
class BenchmarkSettings:
    """The synthetic benchmark sequence of paper §4 (figure 4: error peaks).

    Attributes
    ----------
    n_frames, fps : int, float
        175 frames at 25 fps (paper §4: "175 frames, 640×480 pixels").
    little_frame, rotation_frame, thumb_frame : int
        Frames of the fastest moment of the three events behind the error peaks of
        figure 4: a misfit of the little finger (73), a global rotation (100), the
        thumb crossing the palm (150).
    source_fps : float
        Assumed frame rate of the htrack recording (undocumented; 30 assumed).
    replay_speed : float
        Playback speed of the recording: it is slow (a finger closes in about five
        seconds at 30 fps), so it is played twice as fast.
    excerpt_start : int
        First row of the package's excerpt to replay (before the seed's offset of
        up to ±`excerpt_jitter` rows).
    excerpt_jitter : int
        Largest seed-dependent shift of the replayed rows.
    """

    n_frames: int = 175
    fps: float = 25.0
    little_frame: int = 73
    rotation_frame: int = 100
    thumb_frame: int = 150
    source_fps: float = 30.0
    replay_speed: float = 2.0
    excerpt_start: int = 60
    excerpt_jitter: int = 40


@dataclasses.dataclass(frozen=True)
class FlexionSettings:
    """The finger-flexion sequence of paper §6 (first real sequence, figure 7).

    280 frames at 25 fps: individual flexions of the five digits, then simultaneous
    ones, some fast (the paper's tracker lost accuracy in the fast flexions near
    frames 86 and 111).
    """

    n_frames: int = 280
    fps: float = 25.0


@dataclasses.dataclass(frozen=True)
class FlipSettings:
    """The palm-flip sequence of paper §6 (second real sequence, figure 8).

    80 frames at 25 fps in which the palm turns completely away from the cameras
    and back: a rotation of `turn_deg` (drawn from the range by the seed) about the
    hand's long axis.
    """

    n_frames: int = 80
    fps: float = 25.0
    turn_deg: tuple[float, float] = (168.0, 176.0)


def _base(n_frames: int) -> np.ndarray:
    """The open right hand in front of the default cameras, palm towards them."""
    return np.repeat(named_pose("open")[None, :], n_frames, axis=0)


def _add_path(poses, t, name: str, key_times, key_values) -> None:
    """poses[:, name] += minimum-jerk path through the knots (in place)."""
    poses[:, index(name)] += minimum_jerk_path(t, key_times, key_values)


def _bump(t, start: float, rise: float, hold: float, fall: float) -> np.ndarray:
    """0 → 1 in `rise` s from `start`, held `hold` s, back to 0 in `fall` s (minimum jerk)."""
    times = [start, start + rise, start + rise + hold, start + rise + hold + fall]
    return minimum_jerk_path(t, times, [0.0, 1.0, 1.0, 0.0])


def _drift(rng, t, amplitude: float, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Knots of a slow random drift: one uniform value in ±amplitude every `period` s."""
    times = np.arange(0.0, t[-1] + period, period)
    values = rng.uniform(-amplitude, amplitude, times.size)
    values[0] = 0.0
    return times, values


def palm_drift(poses, t, rng, rotation, translation: float, periods) -> None:
    """Add slow random drifts of the palm: `rotation` ((name, degrees), ...) with knots
    every ``periods[0]`` s, then ±`translation` mm on each axis every ``periods[1]`` s."""
    for name, amplitude in rotation:
        _add_path(poses, t, name, *_drift(rng, t, amplitude, periods[0]))
    for name in ("tx", "ty", "tz"):
        _add_path(poses, t, name, *_drift(rng, t, translation, periods[1]))


def _check_seed(seed) -> int:
    if as_int(seed, "seed") < 0:
        raise ValueError(f"seed: expected a non-negative integer; got {seed!r}")
    return int(seed)


def benchmark(seed: int = 0, settings: BenchmarkSettings = BenchmarkSettings()) -> np.ndarray:
    """True poses of the benchmark sequence (paper §4).

    Finger articulation and part of the palm's rotation come from the real htrack
    recording (package excerpt, :func:`handvar.synth.motion.builtin_recording`,
    replayed at `settings.replay_speed` times real time); on top of it, minimum-jerk
    movements add slow palm rotations and the three events of figure 4:

    - a fast flexion and extension of the little finger, fastest at
      `little_frame` (about 600°/s at the PIP joint);
    - a global rotation of the hand (≈40° in the image plane, ≈30° about its long
      axis, ≈30° tilting the fingers towards the cameras), fastest at
      `rotation_frame`;
    - the thumb flexing and adducting across the palm, fastest at `thumb_frame`.

    Parameters
    ----------
    seed : int
        Varies the replayed rows, amplitudes and the slow palm drift.
    settings : BenchmarkSettings

    Returns
    -------
    poses : (175, 26) ndarray
        mm and degrees, within the joint limits.
    """
    rng = np.random.default_rng([_check_seed(seed), 0])
    s = settings
    n = s.n_frames
    t = np.arange(n) / s.fps
    poses = _base(n)

    # finger articulation and palm wobble replayed from the real recording
    recording = builtin_recording()
    shift = int(rng.integers(-s.excerpt_jitter, s.excerpt_jitter + 1))
    start = s.excerpt_start + shift
    rows = int(np.ceil((n - 1) / s.fps * s.source_fps * s.replay_speed)) + 2
    real = replay(
        recording,
        start=start,
        stop=start + rows,
        source_fps=s.source_fps,
        fps=s.fps,
        speed=s.replay_speed,
    )[:n]
    poses[:, 6:] += real[:, 6:]
    poses[:, 3:6] += real[:, 3:6] - real[0, 3:6]  # the recorded palm rotation, from zero

    # slow palm rotations and translation (keyframed drift)
    palm_drift(poses, t, rng, (("rx", 15.0), ("ry", 20.0), ("rz", 12.0)), 20.0, (1.2, 1.5))

    def centred(frame: int, rise: float) -> float:
        return frame / s.fps - rise / 2.0  # start so that the rise is fastest at `frame`

    # event 1: fast little-finger flexion (fastest at little_frame), ring follows a bit
    rise = 0.24
    bump = _bump(t, centred(s.little_frame, rise), rise, 0.16, 0.4)
    gain = rng.uniform(0.9, 1.1)
    for joint, amplitude in (("mcp", 60.0), ("pip", 75.0), ("dip", 45.0)):
        poses[:, index(f"little_{joint}")] += gain * amplitude * bump
        poses[:, index(f"ring_{joint}")] += 0.2 * gain * amplitude * bump

    # event 2: global rotation (fastest at rotation_frame), undone slowly afterwards
    rise = 0.56
    turn = _bump(t, centred(s.rotation_frame, rise), rise, 0.3, 1.0)
    poses[:, index("rx")] += rng.uniform(25.0, 35.0) * turn
    poses[:, index("ry")] += rng.uniform(25.0, 35.0) * turn
    poses[:, index("rz")] += rng.uniform(35.0, 45.0) * turn

    # event 3: the thumb crosses the palm (fastest at thumb_frame) and comes back
    rise = 0.32
    cross = _bump(t, centred(s.thumb_frame, rise), rise, 0.3, 0.4)
    gain = rng.uniform(0.9, 1.1)
    for name, amplitude in (
        ("abd_thumb", -12.0),
        ("thumb_cmc", 40.0),
        ("thumb_mcp", 40.0),
        ("thumb_ip", 25.0),
    ):
        poses[:, index(name)] += gain * amplitude * cross
    return clamp(poses)


def _digit_flexion(digit: str, scale: float) -> dict[str, float]:
    """Joint angles (degrees) of a flexed digit, `scale` = 1 for a full flexion."""
    if digit == "thumb":
        full = {"abd_thumb": -15.0, "thumb_cmc": 35.0, "thumb_mcp": 45.0, "thumb_ip": 50.0}
    else:
        full = {f"{digit}_mcp": 80.0, f"{digit}_pip": 95.0, f"{digit}_dip": 60.0}
    return {k: scale * v for k, v in full.items()}


def _add_flexion(poses, t, digits, start, rise, hold, fall, scale, enslave=0.15) -> float:
    """Flex `digits` from `start` (s) and back; neighbours follow by `enslave`."""
    bump = _bump(t, start, rise, hold, fall)
    moved = dict.fromkeys(digits, 1.0)
    for d in digits:  # finger enslaving: adjacent fingers move a little too
        if d in _FINGERS:
            k = _FINGERS.index(d)
            for j in (k - 1, k + 1):
                if 0 <= j < 4 and _FINGERS[j] not in moved:
                    moved[_FINGERS[j]] = enslave
    for d, share in moved.items():
        for name, value in _digit_flexion(d, scale * share).items():
            poses[:, index(name)] += value * bump
    return start + rise + hold + fall


def flexion(seed: int = 0, settings: FlexionSettings = FlexionSettings()) -> np.ndarray:
    """True poses of the flexion sequence (paper §6, first real sequence).

    Each digit in turn (thumb, index, middle, ring, little) flexes and extends
    alone, then the four fingers and the thumb close into a fist and open, the four
    fingers flex fast together (a quarter of a second to close), and the hand closes
    once more slowly. Adjacent fingers follow a flexing finger by 15% (finger
    enslaving); the palm drifts slowly.

    Parameters
    ----------
    seed : int
        Varies amplitudes, durations and the palm drift.
    settings : FlexionSettings

    Returns
    -------
    poses : (280, 26) ndarray
        mm and degrees, within the joint limits.
    """
    rng = np.random.default_rng([_check_seed(seed), 1])
    n = settings.n_frames
    t = np.arange(n) / settings.fps
    poses = _base(n)
    palm_drift(poses, t, rng, (("rx", 8.0), ("ry", 10.0), ("rz", 6.0)), 10.0, (2.0, 2.0))

    # the script: (digits, rise, hold, fall, amplitude, pause after), in seconds
    everything = ("thumb", *_FINGERS)
    script = [
        (
            (digit,),
            rng.uniform(0.3, 0.45),
            rng.uniform(0.1, 0.2),
            rng.uniform(0.3, 0.45),
            rng.uniform(0.85, 1.0),
            rng.uniform(0.1, 0.2),
        )
        for digit in everything
    ]
    script += [
        (everything, 0.45, 0.25, 0.45, rng.uniform(0.85, 1.0), 0.25),
        (_FINGERS, 0.25, 0.15, 0.3, rng.uniform(0.8, 0.95), 0.3),
        (everything, 0.6, 0.3, 0.6, rng.uniform(0.85, 1.0), 0.0),
    ]
    lead, tail = 0.3, 0.25
    length = sum(rise + hold + fall + pause for _, rise, hold, fall, _, pause in script)
    stretch = (t[-1] - lead - tail) / length  # fill the sequence (≥ 1: never faster)
    clock = lead
    for digits, rise, hold, fall, amplitude, pause in script:
        clock = _add_flexion(
            poses, t, digits, clock, rise * stretch, hold * stretch, fall * stretch, amplitude
        )
        clock += pause * stretch
    return clamp(poses)


def flip(seed: int = 0, settings: FlipSettings = FlipSettings()) -> np.ndarray:
    """True poses of the flip sequence (paper §6, second real sequence).

    The hand, fingers relaxed and slightly curled, turns about its long axis until
    the back of the hand faces the cameras (palm normal 168–176° from its start)
    and turns back; the fingers curl a little more while it turns.

    Parameters
    ----------
    seed : int
        Varies the turn angle, its timing and a slow drift of the palm.
    settings : FlipSettings

    Returns
    -------
    poses : (80, 26) ndarray
        mm and degrees, within the joint limits.
    """
    rng = np.random.default_rng([_check_seed(seed), 2])
    n = settings.n_frames
    t = np.arange(n) / settings.fps
    poses = _base(n)
    relaxed = {"mcp": 10.0, "pip": 15.0, "dip": 5.0}
    for finger in _FINGERS:
        for joint, value in relaxed.items():
            poses[:, index(f"{finger}_{joint}")] += value
    poses[:, index("thumb_cmc")] += 10.0
    palm_drift(poses, t, rng, (("rx", 6.0), ("rz", 6.0)), 8.0, (1.0, 1.0))

    lo, hi = settings.turn_deg
    angle = rng.uniform(lo, hi)
    start = rng.uniform(0.25, 0.35)
    turn_time = rng.uniform(0.95, 1.05)
    hold = rng.uniform(0.25, 0.35)
    turn = _bump(t, start, turn_time, hold, turn_time)
    poses[:, index("ry")] += angle * turn
    for finger in _FINGERS:
        poses[:, index(f"{finger}_pip")] += 15.0 * turn
    return clamp(poses)


#: Generators of the named sequences.
_GENERATORS: dict[str, Callable[[int], np.ndarray]] = {
    "benchmark": benchmark,
    "flexion": flexion,
    "flip": flip,
}
#: Frame rate of each named sequence.
SEQUENCE_FPS = {
    "benchmark": BenchmarkSettings().fps,
    "flexion": FlexionSettings().fps,
    "flip": FlipSettings().fps,
}
SEQUENCE_NAMES: tuple[str, ...] = tuple(_GENERATORS)


def sequence_poses(name: str, seed: int = 0) -> np.ndarray:
    """True poses of the named sequence (``benchmark``, ``flexion`` or ``flip``)."""
    if name not in _GENERATORS:
        raise ValueError(f"name: expected one of {', '.join(SEQUENCE_NAMES)}; got {name!r}")
    return _GENERATORS[name](seed)


def render_sequence(
    poses,
    *,
    name: str,
    fps: float = 25.0,
    rig=None,
    hand=None,
    rgb: bool = False,
    seed: int = 0,
    background: str = "clutter",
    progress: Callable[[Iterable[int]], Iterable[int]] | None = None,
    provenance: dict | None = None,
):
    """Render silhouettes (and optionally colour frames) of poses into a Sequence.

    Parameters
    ----------
    poses : (T, 26) array_like
        True poses, mm and degrees, within the joint limits.
    name : str, keyword-only
        Name of the sequence.
    fps : float, keyword-only
        Frame rate.
    rig : handvar.camera.Rig, keyword-only, optional
        Cameras; the paper's stereo pair (``Rig.default()``) by default.
    hand : handvar.hand.kinematics.HandModel, keyword-only, optional
        The hand; the default 185 mm hand by default.
    rgb : bool, keyword-only
        Also render shaded colour frames over a synthetic background.
    seed : int, keyword-only
        Seeds the colour frames' background and noise (silhouettes are exact and
        need no randomness). The background of each camera is the same in every
        frame, as for fixed cameras.
    background : {"clutter", "texture", "plain"}, keyword-only
        Background of the colour frames.
    progress : callable, keyword-only, optional
        Wraps the frame iterator (for instance ``tqdm.tqdm``).
    provenance : dict, keyword-only, optional
        Stored with the sequence.

    Returns
    -------
    seq : handvar.io.Sequence
        Masks (T, n_cams, H, W), optional RGB, and the truth: `poses` and the joints
        ``G(poses[t])`` (T, 21, 3).
    """
    from handvar.camera import Rig
    from handvar.hand.kinematics import HandModel
    from handvar.io import Sequence, Truth
    from handvar.render import render_rgb, silhouettes

    arr = np.asarray(poses, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != N_PARAMS or arr.shape[0] == 0:
        raise ValueError(f"poses: expected an array of shape (T, 26); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("poses: expected finite values; got NaN or infinity")
    seed = _check_seed(seed)
    rig = Rig.default() if rig is None else rig
    hand = HandModel() if hand is None else hand
    w, h = rig.cameras[0].size
    n = arr.shape[0]
    masks = np.empty((n, len(rig), h, w), dtype=bool)
    colour = np.empty((n, len(rig), h, w, 3), dtype=np.uint8) if rgb else None
    joints = np.empty((n, 21, 3))
    frames: Iterable[int] = range(n)
    if progress is not None:
        frames = progress(frames)
    for f in frames:
        joints[f] = hand.joints(arr[f])
        masks[f] = silhouettes(hand, arr[f], rig)
        if colour is not None:
            # the same generator state every frame: a static background per camera, as
            # seen by fixed cameras (the sensor-noise pattern repeats with it)
            rng = np.random.default_rng([seed, 3])
            colour[f] = render_rgb(hand, arr[f], rig, background=background, rng=rng)
    return Sequence(
        name=name,
        fps=fps,
        rig=rig,
        masks=masks,
        rgb=colour,
        truth=Truth(arr.copy(), joints),
        provenance=dict(provenance or {}),
    )


def make_sequence(
    name: str,
    *,
    seed: int = 0,
    rgb: bool = False,
    n_frames: int | None = None,
    progress: Callable[[Iterable[int]], Iterable[int]] | None = None,
    hand=None,
    speed: float = 1.0,
    silhouette_noise: float = 0.0,
):
    """Generate and render a named synthetic sequence.

    Parameters
    ----------
    name : {"benchmark", "flexion", "flip"}
    seed : int, keyword-only
        Seeds the motion (and the colour frames).
    rgb : bool, keyword-only
        Also render colour frames.
    n_frames : int, keyword-only, optional
        Keep only the first `n_frames` frames (a quick preview); all by default.
    progress : callable, keyword-only, optional
        Wraps the frame iterator (for instance ``tqdm.tqdm``).
    hand : handvar.hand.kinematics.HandModel, keyword-only, optional
        The hand that renders the frames (default 185 mm sphere-mesh); a
        ``HandModel(surface="mesh")`` renders the skinned mesh, a hand of another
        shape (:func:`handvar.synth.mismatch.generator_hand`) renders another size;
        the truth's joints are this hand's.
    speed : float, keyword-only
        Replay the motion this many times faster at the same frame rate
        (:func:`handvar.synth.mismatch.faster`; the sequence has fewer frames).
    silhouette_noise : float, keyword-only
        Corrupt the silhouettes with the errors of a real segmentation of this
        strength in pixels (:func:`handvar.synth.mismatch.corrupt_silhouettes`,
        seeded by `seed`); 0: exact silhouettes.

    Returns
    -------
    seq : handvar.io.Sequence
        With provenance: generator, seed, settings and the source of the replayed
        motion.
    """
    from handvar.synth.mismatch import corrupt_silhouettes, faster

    poses = sequence_poses(name, seed)
    speed = as_float(speed, "speed", minimum=1.0)
    silhouette_noise = as_float(silhouette_noise, "silhouette_noise", minimum=0.0, maximum=50.0)
    if speed != 1.0:
        poses = faster(poses, speed)
    n_generated = int(poses.shape[0])
    if n_frames is not None:
        if as_int(n_frames, "n_frames") < 1:
            raise ValueError(f"n_frames: expected a positive integer; got {n_frames!r}")
        poses = poses[: int(n_frames)]
    provenance = {
        "generator": f"handvar.synth.sequences.{name}",
        "seed": seed,
        "frames_of_full_sequence": n_generated,
        "rgb": bool(rgb),
    }
    if hand is not None:
        provenance["model"] = getattr(hand, "surface", "spheres")
    if speed != 1.0:
        provenance["speed"] = speed
    if silhouette_noise:
        provenance["silhouette_noise_px"] = silhouette_noise
    if name == "benchmark":
        provenance["motion_source"] = (
            "finger articulation replayed from rows "
            f"{HTRACK_EXCERPT_FIRST_ROW}–{HTRACK_EXCERPT_FIRST_ROW + 899} of htrack "
            "fingerfist (OpenGP/htrack, tracker/Legacy/fingerfist.mat, LGPL-3.0)"
        )
    seq = render_sequence(
        poses,
        name=name,
        fps=SEQUENCE_FPS[name],
        rgb=rgb,
        seed=seed,
        progress=progress,
        provenance=provenance,
        hand=hand,
    )
    if silhouette_noise:
        masks = corrupt_silhouettes(
            seq.masks, seq.truth.joints, seq.rig, silhouette_noise, seed=seed
        )
        seq = dataclasses.replace(seq, masks=masks)
    return seq
