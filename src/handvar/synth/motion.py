"""Hand motion for synthetic sequences: minimum-jerk key poses and real-motion replay.

Two sources of motion, both returning pose series of shape (T, 26) in the units of
:mod:`handvar.params` (millimetres, degrees) at a chosen frame rate:

- :func:`keyframe_motion` interpolates key poses with the minimum-jerk profile of
  Flash & Hogan (1985), the smooth point-to-point timing of unconstrained human arm
  and finger movements;
- :func:`replay` maps a recording of real hand poses in the 26-parameter layout of
  the htrack tracker (OpenGP/htrack, LGPL-3.0) onto ours (:func:`htrack_to_handvar`)
  and retimes it to the target frame rate.

The functions are pure; nothing here reads files except :func:`load_htrack` (from the
path it is given) and :func:`builtin_recording` (from the package data).
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import itertools
import os
from collections.abc import Sequence

import numpy as np

from handvar.params import LOWER, N_PARAMS, NAMES, UPPER, clamp
from handvar.validate import as_array, as_float

__all__ = [
    "HTRACK_EXCERPT_FIRST_ROW",
    "HtrackMapping",
    "builtin_recording",
    "htrack_to_handvar",
    "keyframe_motion",
    "load_htrack",
    "minimum_jerk",
    "minimum_jerk_path",
    "minimum_jerk_rate",
    "minimum_jerk_transition",
    "poses_from_keys",
    "replay",
    "retime",
    "split_at_jumps",
]


# --- minimum-jerk timing ----------------------------------------------------------


def minimum_jerk(tau) -> np.ndarray:
    """The minimum-jerk position profile s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (Flash & Hogan 1985).

    Parameters
    ----------
    tau : array_like
        Normalised time; values outside [0, 1] are clipped (before the start the
        movement has not begun, after the end it is complete).

    Returns
    -------
    s : ndarray, same shape as `tau`
        Fraction of the movement done, from 0 to 1, with zero velocity and zero
        acceleration at both ends.

    Examples
    --------
    >>> minimum_jerk([0.0, 0.5, 1.0, 2.0]).tolist()
    [0.0, 0.5, 1.0, 1.0]
    """
    t = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    # s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, in Horner form
    return t**3 * (10.0 + t * (-15.0 + 6.0 * t))


def minimum_jerk_rate(tau) -> np.ndarray:
    """Derivative ds/dτ = 30τ² − 60τ³ + 30τ⁴ of :func:`minimum_jerk` (zero outside [0, 1]).

    The peak, at τ = ½, is 15/8: a minimum-jerk movement of amplitude A and duration D
    reaches the speed 1.875·A/D.
    """
    t = np.asarray(tau, dtype=float)
    inside = (t >= 0.0) & (t <= 1.0)
    # ds/dτ = 30τ²(1 − τ)²
    return np.where(inside, 30.0 * t**2 * (1.0 - t) ** 2, 0.0)


def minimum_jerk_transition(times, start: float, duration: float) -> np.ndarray:
    """Minimum-jerk step from 0 to 1 that starts at `start` and lasts `duration` seconds.

    Parameters
    ----------
    times : (T,) array_like
        Sample times in seconds.
    start : float
        Time (s) at which the movement begins.
    duration : float
        Length (s) of the movement, > 0.

    Returns
    -------
    s : (T,) ndarray
        0 before `start`, 1 after `start + duration`, :func:`minimum_jerk` between.
    """
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration: expected a positive number of seconds; got {duration!r}")
    return minimum_jerk((np.asarray(times, dtype=float) - start) / duration)


def minimum_jerk_path(times, key_times, key_values) -> np.ndarray:
    """Values through knots, minimum-jerk between consecutive knots.

    Parameters
    ----------
    times : (T,) array_like
        Sample times, seconds.
    key_times : (K,) array_like
        Knot times, seconds, non-decreasing. Two equal times make a jump: the later
        value holds from that time on.
    key_values : (K,) or (K, D) array_like
        Value at each knot (any unit).

    Returns
    -------
    values : (T,) or (T, D) ndarray
        ``key_values[0]`` before the first knot, ``key_values[-1]`` after the last,
        and between knots k and k+1
        ``v_k + s((t − t_k)/(t_{k+1} − t_k))·(v_{k+1} − v_k)`` with s the
        minimum-jerk profile (:func:`minimum_jerk`).

    Examples
    --------
    >>> minimum_jerk_path([0.0, 0.5, 1.0, 1.5, 3.0], [0.0, 1.0, 2.0], [0.0, 10.0, 4.0]).tolist()
    [0.0, 5.0, 10.0, 7.0, 4.0]
    """
    t = np.asarray(times, dtype=float)
    kt = np.asarray(key_times, dtype=float)
    kv = np.asarray(key_values, dtype=float)
    if kt.ndim != 1 or kt.size == 0 or kv.shape[0] != kt.size:
        raise ValueError(
            f"key_times, key_values: expected K times and K values; got shapes {kt.shape} "
            f"and {kv.shape}"
        )
    if not (np.all(np.isfinite(kt)) and np.all(np.diff(kt) >= 0)):
        raise ValueError(f"key_times: expected non-decreasing finite times; got {kt.tolist()}")
    flat = kv.reshape(kt.size, -1)
    out = np.repeat(flat[:1], t.size, axis=0)
    for j in range(kt.size - 1):
        gap = kt[j + 1] - kt[j]
        if gap == 0:  # a jump: the later value wins from then on
            step = (t >= kt[j]).astype(float)
        else:
            step = minimum_jerk((t - kt[j]) / gap)
        # x(t) = x_k + s(τ)(x_{k+1} − x_k), summed over the transitions already begun
        out += step[:, None] * (flat[j + 1] - flat[j])
    return out.reshape(t.shape + kv.shape[1:])


def _check_key_poses(key_poses) -> np.ndarray:
    arr = np.asarray(key_poses, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != N_PARAMS or arr.shape[0] < 1:
        raise ValueError(f"key_poses: expected an array of shape (K, 26); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("key_poses: expected finite values; got NaN or infinity")
    bad = (arr < LOWER - 1e-9) | (arr > UPPER + 1e-9)
    if np.any(bad):
        k, i = np.argwhere(bad)[0]
        raise ValueError(
            f"key_poses: expected poses within the joint limits; key pose {k} has "
            f"{NAMES[i]} = {arr[k, i]:g}, outside [{LOWER[i]:g}, {UPPER[i]:g}]"
        )
    return arr


def _check_fps(fps: float, name: str = "fps") -> float:
    value = as_float(fps, name)
    if value <= 0:
        raise ValueError(f"{name}: expected a positive frame rate; got {fps!r}")
    return value


def _seconds(values, name: str, length: int) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.ndim == 0:
        arr = np.full(length, float(arr))
    if arr.shape != (length,):
        raise ValueError(f"{name}: expected {length} values (seconds); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name}: expected finite, non-negative seconds; got {arr.tolist()}")
    return arr


def keyframe_motion(
    key_poses,
    durations=None,
    *,
    times=None,
    holds=None,
    fps: float = 25.0,
) -> np.ndarray:
    """Interpolate key poses with minimum-jerk timing and sample them at `fps`.

    Between consecutive key poses every parameter follows
    x(t) = x_k + s(τ)·(x_{k+1} − x_k) with s the minimum-jerk profile
    (:func:`minimum_jerk`), so all parameters of one transition start and stop
    together, with zero velocity and acceleration at the key poses.

    Parameters
    ----------
    key_poses : (K, 26) array_like
        Key poses (mm, degrees), each inside the joint limits.
    durations : (K-1,) array_like or float, optional
        Length (s) of each transition. Give either `durations` or `times`.
    times : (K,) array_like, keyword-only, optional
        Times (s) at which the key poses are reached, non-decreasing, from 0.
        Holds, if given, are inserted after each key time and shift the later ones.
    holds : (K,) array_like or float, keyword-only, optional
        Time (s) spent still at each key pose before moving on (the last hold
        extends the end of the motion). Default no holds.
    fps : float, keyword-only
        Frame rate (frames per second) of the result.

    Returns
    -------
    poses : (T, 26) ndarray
        Frame n is the pose at time n / fps, for all frames up to the end of the
        last hold (T = floor(end · fps) + 1). Clamped to the joint limits (the
        interpolation of poses inside the limits stays inside them; the clamp only
        removes rounding).

    Raises
    ------
    ValueError
        If a key pose has the wrong shape, is not finite or lies outside the joint
        limits, or if the timing is inconsistent.

    Examples
    --------
    >>> import numpy as np
    >>> a, b = np.zeros(26), np.zeros(26)
    >>> b[14] = 90.0                                     # index MCP flexed
    >>> keyframe_motion([a, b], [1.0], fps=4)[:, 14].round(2).tolist()
    [0.0, 9.32, 45.0, 80.68, 90.0]
    """
    keys = _check_key_poses(key_poses)
    fps = _check_fps(fps)
    k = keys.shape[0]
    if (durations is None) == (times is None):
        raise ValueError(
            "durations, times: expected exactly one of them; got "
            + ("both" if durations is not None else "neither")
        )
    if durations is not None:
        moves = _seconds(durations, "durations", k - 1)
        if np.any(moves <= 0):
            raise ValueError(f"durations: expected positive seconds; got {moves.tolist()}")
    else:
        key_times = _seconds(times, "times", k)
        if key_times[0] != 0.0 or np.any(np.diff(key_times) < 0):
            raise ValueError(
                f"times: expected non-decreasing key times starting at 0; got {key_times.tolist()}"
            )
        moves = np.diff(key_times)
    stays = np.zeros(k) if holds is None else _seconds(holds, "holds", k)

    # start of transition k (after the hold at key k), key k reached at arrive[k]
    arrive = np.zeros(k)
    leave = np.zeros(k)
    for j in range(k):
        if j > 0:
            arrive[j] = leave[j - 1] + moves[j - 1]
        leave[j] = arrive[j] + stays[j]
    end = leave[-1]
    n_frames = int(np.floor(end * fps + 1e-9)) + 1
    t = np.arange(n_frames) / fps

    # holds become pairs of equal key poses: reached at arrive[j], left at leave[j]
    key_times = np.stack([arrive, leave], axis=1).ravel()
    key_values = np.repeat(keys, 2, axis=0)
    poses = minimum_jerk_path(t, key_times, key_values)
    return clamp(poses)


# --- the htrack recording ---------------------------------------------------------

# First row, in the original 6000-row file, of the excerpt shipped as package data.
HTRACK_EXCERPT_FIRST_ROW = 560
_EXCERPT_FILE = "htrack-fingerfist-excerpt.txt"


@dataclasses.dataclass(frozen=True)
class HtrackMapping:
    """How a pose of the htrack hand model maps onto ours.

    htrack (OpenGP/htrack, ``tracker/Legacy/geometry/Mapping.cpp``) stores 26 values
    per frame: global translation (3), global rotation as Euler angles about x, y, z
    in radians (3), then per digit (thumb, index, middle, ring, little) one abduction
    (rotation about the digit's local z axis) followed by three flexions (about the
    local x axis). Its joint bounds are −1.5 … 0.1 rad for every flexion: **flexion
    towards the palm is negative**, the opposite of ours. The recording agrees: a
    fist gives flexions near −1.5 to −2 rad.

    Our value for an articulation parameter is ``sign · (degrees(htrack) − rest)``:

    - flexions: sign −1 for every joint of every digit;
    - abductions: htrack turns every finger about the same way (the index finger
      reaches +0.65 rad while the little finger reaches −0.33 rad, i.e. positive is
      towards the thumb side); ours is positive *away from the middle finger*, so
      the index and middle fingers keep the sign and the ring and little fingers
      change it. The thumb's abduction grows while the recorded thumb folds across
      the palm, which is adduction for us: sign −1;
    - `rest_deg`: htrack's open, relaxed hand is not exactly its zero posture
      (fingers rest a few degrees hyperextended, the ring PIP by 16°). We subtract
      that posture — the median of rows 3640–3999 of the recording, where the hand
      is open and still, rounded to whole degrees — so that the open hand maps onto
      our straight zero posture.

    The global pose is copied with a change of units only: translation times
    `translation_scale` (the recording's unit is undocumented; its values of about
    5–20 suggest centimetres, so the default makes millimetres), rotation in
    degrees. htrack's Euler angles and its camera frame are not ours, so the global
    pose of a replay is a plausible trajectory, not the recorded hand's placement in
    our world; synthetic sequences supply their own global motion.
    """

    translation_scale: float = 10.0
    abduction_sign: tuple[float, ...] = (-1.0, 1.0, 1.0, -1.0, -1.0)
    flexion_sign: float = -1.0
    # per digit (thumb, index, middle, ring, little): abduction, three flexions (degrees)
    rest_deg: tuple[tuple[float, float, float, float], ...] = (
        (-2.0, 1.0, 15.0, 9.0),
        (-4.0, 2.0, 1.0, 5.0),
        (-3.0, 7.0, 2.0, 7.0),
        (-8.0, 0.0, 16.0, 5.0),
        (0.0, -5.0, 9.0, 8.0),
    )


def htrack_to_handvar(array, mapping: HtrackMapping = HtrackMapping()) -> np.ndarray:
    """Convert htrack poses (radians, htrack order and signs) to our 26 parameters.

    Parameters
    ----------
    array : (N, 26) array_like
        Rows of an htrack pose file: translation (3), rotation (3, radians), then per
        digit thumb, index, middle, ring, little: abduction and three flexions
        (radians).
    mapping : HtrackMapping
        Signs, rest posture and translation scale; see :class:`HtrackMapping`.

    Returns
    -------
    poses : (N, 26) ndarray
        Our layout (design §2): translation (mm), rotation (degrees), the five
        abductions (degrees), then the fifteen flexions (degrees). Not clamped to
        the joint limits; :func:`replay` does that.

    Examples
    --------
    >>> import numpy as np
    >>> row = np.zeros((1, 26))
    >>> row[0, 12] = -np.pi / 4          # htrack: index PIP-equivalent flexed 45°
    >>> float(htrack_to_handvar(row)[0, 15])   # ours: index_pip, minus its rest
    46.0
    """
    src = as_array(array, "array", (None, N_PARAMS))
    out = np.empty_like(src)
    out[:, 0:3] = mapping.translation_scale * src[:, 0:3]
    out[:, 3:6] = np.degrees(src[:, 3:6])
    digits = np.degrees(src[:, 6:26]).reshape(-1, 5, 4)  # (N, digit, [abd, f1, f2, f3])
    rest = np.asarray(mapping.rest_deg, dtype=float)  # (5, 4)
    centred = digits - rest
    out[:, 6:11] = np.asarray(mapping.abduction_sign) * centred[:, :, 0]
    out[:, 11:26] = mapping.flexion_sign * centred[:, :, 1:].reshape(-1, 15)
    return out


def load_htrack(path: str | os.PathLike) -> np.ndarray:
    """Read an htrack pose file: a whitespace table of N rows and 26 columns (radians).

    Parameters
    ----------
    path : path-like
        The file (for instance ``examples/data/htrack-fingerfist.txt``).

    Returns
    -------
    table : (N, 26) ndarray
        The raw values, unconverted; see :func:`htrack_to_handvar`.

    Raises
    ------
    ValueError
        If the file cannot be parsed, has a number of columns other than 26 or
        contains non-finite values; the message names the file.
    OSError
        If the file cannot be opened.
    """
    path = os.fspath(path)
    try:
        table = np.loadtxt(path, dtype=float, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: expected a whitespace table of numbers; {exc}") from None
    if table.shape[1] != N_PARAMS or table.shape[0] == 0:
        raise ValueError(f"{path}: expected rows of 26 numbers; got a table of shape {table.shape}")
    if not np.all(np.isfinite(table)):
        raise ValueError(f"{path}: expected finite values; got NaN or infinity")
    return table


def builtin_recording() -> np.ndarray:
    """The excerpt of the htrack ``fingerfist`` recording shipped with the package.

    Rows ``HTRACK_EXCERPT_FIRST_ROW`` … +899 of the original file (OpenGP/htrack,
    ``tracker/Legacy/fingerfist.mat``, LGPL-3.0): the index finger flexes fully and
    opens again, then the middle finger flexes, while the other digits follow a
    little. See ``handvar/data/README.md``.

    Returns
    -------
    table : (900, 26) ndarray
        Raw htrack values (radians); convert with :func:`htrack_to_handvar`.
    """
    resource = importlib.resources.files("handvar") / "data" / _EXCERPT_FILE
    with importlib.resources.as_file(resource) as path:
        return load_htrack(path)


def split_at_jumps(poses, max_step) -> list[slice]:
    """Split a pose series where consecutive frames jump (separate recordings).

    Parameters
    ----------
    poses : (N, D) array_like
        A pose series.
    max_step : float or (D,) array_like
        Largest plausible change of each column between consecutive frames.

    Returns
    -------
    segments : list of slice
        Row ranges with no step larger than `max_step`, in order, covering all rows.
    """
    arr = np.asarray(poses, dtype=float)
    if arr.ndim != 2 or arr.shape[0] == 0:
        raise ValueError(f"poses: expected a non-empty (N, D) array; got shape {arr.shape}")
    jumps = np.flatnonzero(np.any(np.abs(np.diff(arr, axis=0)) > max_step, axis=1)) + 1
    edges = [0, *jumps.tolist(), arr.shape[0]]
    return [slice(a, b) for a, b in itertools.pairwise(edges)]


def retime(
    poses,
    source_fps: float,
    fps: float,
    *,
    speed: float = 1.0,
    smooth_sigma: float = 1.0,
) -> np.ndarray:
    """Resample a pose series to another frame rate (and optionally play it faster).

    The series is smoothed with a Gaussian of `smooth_sigma` source frames (scaled
    up by the decimation factor when the result has fewer samples per second of
    motion than the source, as an anti-aliasing filter), then interpolated by a
    cubic spline at the new sample times.

    Parameters
    ----------
    poses : (N, D) array_like
        Samples at `source_fps`.
    source_fps : float
        Frame rate (frames per second) of `poses`.
    fps : float
        Frame rate of the result.
    speed : float, keyword-only
        Playback speed; 2 plays the motion twice as fast (half the frames).
    smooth_sigma : float, keyword-only
        Standard deviation (source frames) of the smoothing; 0 disables it.

    Returns
    -------
    out : (T, D) ndarray
        ``out[n]`` is the motion at source time ``n · speed / fps`` seconds, for all
        n whose time lies inside the recording.
    """
    from scipy.interpolate import CubicSpline  # here: a recording's track needs neither
    from scipy.ndimage import gaussian_filter1d

    arr = np.asarray(poses, dtype=float)
    if arr.ndim != 2 or arr.shape[0] < 2:
        raise ValueError(f"poses: expected an (N, D) array with N >= 2; got shape {arr.shape}")
    source_fps = _check_fps(source_fps, "source_fps")
    fps = _check_fps(fps, "fps")
    if not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"speed: expected a positive playback speed; got {speed!r}")
    if not (np.isfinite(smooth_sigma) and smooth_sigma >= 0):
        raise ValueError(f"smooth_sigma: expected a non-negative number; got {smooth_sigma!r}")
    ratio = source_fps * speed / fps  # source frames per output frame
    sigma = smooth_sigma * max(1.0, ratio)
    if sigma > 0:
        arr = gaussian_filter1d(arr, sigma, axis=0, mode="nearest")
    t_src = np.arange(arr.shape[0]) / source_fps
    n_out = int(np.floor(t_src[-1] * fps / speed + 1e-9)) + 1
    t_out = np.arange(n_out) * speed / fps
    return CubicSpline(t_src, arr, axis=0)(t_out)


# largest change per recorded frame before two rows count as separate recordings
_HTRACK_MAX_STEP = np.array([3.0] * 3 + [0.5] * 3 + [0.5] * 20)


def replay(
    recording,
    *,
    start: int = 0,
    stop: int | None = None,
    source_fps: float = 30.0,
    fps: float = 25.0,
    speed: float = 1.0,
    smooth_sigma: float = 1.0,
    mapping: HtrackMapping = HtrackMapping(),
) -> np.ndarray:
    """Replay rows of an htrack recording as our poses at `fps`.

    Parameters
    ----------
    recording : (N, 26) array_like or path-like
        Raw htrack rows (as from :func:`load_htrack` or :func:`builtin_recording`),
        or the path of such a file.
    start, stop : int, keyword-only
        Row range ``[start, stop)`` to replay (default: all rows). It must not
        cross a discontinuity between two recordings (in the ``fingerfist`` file
        between rows 3999 and 4000).
    source_fps : float, keyword-only
        Assumed frame rate of the recording. htrack does not document it (a depth
        camera at 30–60 fps); 30 is assumed.
    fps : float, keyword-only
        Frame rate of the result (the paper's sequences: 25).
    speed : float, keyword-only
        Playback speed relative to real time.
    smooth_sigma : float, keyword-only
        Gaussian smoothing in source frames (see :func:`retime`). The recording is
        already smooth (about 0.02° of frame-to-frame jitter), so the default is light.
    mapping : HtrackMapping, keyword-only
        Conversion to our parameters.

    Returns
    -------
    poses : (T, 26) ndarray
        Our parameters (mm, degrees), clamped to the joint limits.
    """
    if isinstance(recording, str | os.PathLike):
        table = load_htrack(recording)
    else:
        table = as_array(recording, "recording", (None, N_PARAMS))
    n = table.shape[0]
    stop = n if stop is None else stop
    if not (0 <= start < stop <= n) or stop - start < 2:
        raise ValueError(
            f"start, stop: expected 0 <= start < stop <= {n} with at least 2 rows; "
            f"got start={start}, stop={stop}"
        )
    rows = table[start:stop]
    segments = split_at_jumps(rows, _HTRACK_MAX_STEP)
    if len(segments) > 1:
        cut = start + segments[1].start
        raise ValueError(
            f"start, stop: expected rows of one continuous recording; rows {start}–{stop - 1} "
            f"cross a discontinuity between rows {cut - 1} and {cut}"
        )
    poses = htrack_to_handvar(rows, mapping)
    return clamp(retime(poses, source_fps, fps, speed=speed, smooth_sigma=smooth_sigma))


def poses_from_keys(keys: Sequence[dict[str, float]]) -> np.ndarray:
    """Key poses from dictionaries of named parameters (unnamed ones are 0).

    Parameters
    ----------
    keys : sequence of dict
        One mapping ``name -> value`` (names from :data:`handvar.params.NAMES`)
        per key pose.

    Returns
    -------
    key_poses : (K, 26) ndarray
    """
    out = np.zeros((len(keys), N_PARAMS))
    for k, key in enumerate(keys):
        for name, value in key.items():
            if name not in NAMES:
                raise ValueError(
                    f"keys[{k}]: expected parameter names from {', '.join(NAMES)}; got {name!r}"
                )
            out[k, NAMES.index(name)] = value
    return out
