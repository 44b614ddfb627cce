"""Sequences on disk: silhouette masks, optional colour frames, the rig and ground truth.

A sequence directory (design §8) holds::

    sequence.json          name, fps, frame count, the cameras (intrinsics, distortion,
                           extrinsics, image size, as Rig.to_dict()), provenance
    cam0/mask_00000.png    one 1-bit PNG per frame and camera (white = hand)
    cam0/rgb_00000.png     optional colour frames (8-bit RGB PNG)
    cam1/...
    truth.npz              optional ground truth: poses (T, 26), joints (T, 21, 3)

Camera ``j`` of the rig has the folder ``cam{j}``. :func:`write_sequence` builds the
directory under a temporary name beside the target and swaps it into place
(`handvar.atomic.replace_directory`, design §13.2), so a failed write never leaves a
half-written directory nor destroys the previous one, and a swap killed half-way is
undone by the next reader or writer.
:func:`read_sequence` checks every file before returning and names the file at fault.

What a sequence argument names -- a recording (video files or image folders), a
sequence directory or a synthetic sequence -- is decided by :func:`resolve_sequence`.

One concept, sequences on disk (the format, its reader and writer), which is why the
module is over 600 lines.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import struct
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from handvar.atomic import (
    OutputSet,
    recover_directory,
    remove_stale_temporaries,
    write_atomic,
)
from handvar.atomic import check_output_dir as _check_writable_dir
from handvar.camera import Rig
from handvar.validate import as_float, as_instance

__all__ = [
    "FORMAT",
    "IMAGE_SUFFIXES",
    "FrameStack",
    "Sequence",
    "SequenceError",
    "SequenceSpec",
    "Truth",
    "check_output_dir",
    "read_sequence",
    "resolve_sequence",
    "write_atomic",
    "write_sequence",
]

#: File name endings of the images an image folder may hold (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm")

FORMAT = "handvar-sequence"
FORMAT_VERSION = 1
_JSON = "sequence.json"
_TRUTH = "truth.npz"
_N_JOINTS = 21
_N_PARAMS = 26
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"


class SequenceError(ValueError):
    """A sequence directory or one of its files is missing, unreadable or inconsistent."""


def _frame_name(kind: str, t: int) -> str:
    return f"{kind}_{t:05d}.png"


def _camera_dir(j: int) -> str:
    return f"cam{j}"


# --- in-memory sequence --------------------------------------------------------------


class FrameStack:
    """Frames of a sequence on disk, decoded when indexed.

    Behaves like a read-only array of shape ``(T, n_cams, H, W)`` (masks, bool) or
    ``(T, n_cams, H, W, 3)`` (colour, uint8, RGB order): ``stack[t]`` decodes frame
    ``t`` of every camera, ``stack[a:b]`` a range, ``np.asarray(stack)`` all of them.

    Parameters
    ----------
    paths : (T, n_cams) array_like of str
        PNG file of each frame and camera.
    kind : {"mask", "rgb"}
        What the files hold.
    size : (int, int)
        Image (width, height) every file was checked to have.
    """

    def __init__(self, paths, kind: str, size: tuple[int, int]) -> None:
        if kind not in ("mask", "rgb"):
            raise ValueError(f"kind: expected 'mask' or 'rgb'; got {kind!r}")
        self._paths = np.asarray(paths, dtype=object)
        if self._paths.ndim != 2:
            raise ValueError(f"paths: expected a (T, n_cams) table; got shape {self._paths.shape}")
        self.kind = kind
        w, h = size
        t, n = self._paths.shape
        self.shape: tuple[int, ...] = (t, n, h, w) if kind == "mask" else (t, n, h, w, 3)
        self.dtype = np.dtype(bool) if kind == "mask" else np.dtype(np.uint8)

    def __len__(self) -> int:
        return self.shape[0]

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def _load(self, path: str) -> np.ndarray:
        if self.kind == "mask":
            img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        else:
            img = cv2.imread(path, cv2.IMREAD_COLOR)
        if img is None:
            raise SequenceError(f"{path}: expected a readable PNG image; could not decode it")
        if img.shape[:2] != self.shape[2:4]:
            raise SequenceError(
                f"{path}: expected an image of {self.shape[3]}x{self.shape[2]} pixels; "
                f"got {img.shape[1]}x{img.shape[0]}"
            )
        if self.kind == "mask":
            return img > 127
        return img[:, :, ::-1]  # OpenCV decodes BGR

    def frame(self, t: int) -> np.ndarray:
        """Frame `t` of every camera: (n_cams, H, W) bool or (n_cams, H, W, 3) uint8."""
        n_frames = self.shape[0]
        if not -n_frames <= t < n_frames:
            raise IndexError(f"t: expected a frame index in [0, {n_frames}); got {t}")
        return np.stack([self._load(p) for p in self._paths[t]])

    def __getitem__(self, key):
        if isinstance(key, tuple):
            head, rest = key[0], key[1:]
            return self[head][(slice(None), *rest) if not _is_int(head) else rest]
        if _is_int(key):
            return self.frame(int(key))
        frames = range(self.shape[0])[key]
        out = np.empty((len(frames), *self.shape[1:]), dtype=self.dtype)
        for i, t in enumerate(frames):
            out[i] = self.frame(t)
        return out

    def __array__(self, dtype=None, copy=None):
        arr = self[:]
        return arr if dtype is None else arr.astype(dtype)

    def __repr__(self) -> str:
        return f"FrameStack(kind={self.kind!r}, shape={self.shape})"


def _is_int(key) -> bool:
    return isinstance(key, int | np.integer)


@dataclasses.dataclass(frozen=True, eq=False)
class Truth:
    """Ground truth of a synthetic sequence.

    Parameters
    ----------
    poses : (T, 26) ndarray
        True pose parameters per frame (mm, degrees).
    joints : (T, 21, 3) ndarray
        True joint and fingertip positions per frame (mm, world frame), ``G(poses[t])``.
    """

    poses: np.ndarray
    joints: np.ndarray

    def __post_init__(self) -> None:
        poses = np.asarray(self.poses, dtype=float)
        joints = np.asarray(self.joints, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != _N_PARAMS:
            raise ValueError(f"poses: expected shape (T, 26); got shape {poses.shape}")
        if joints.shape != (poses.shape[0], _N_JOINTS, 3):
            raise ValueError(
                f"joints: expected shape ({poses.shape[0]}, 21, 3) to match poses; "
                f"got shape {joints.shape}"
            )
        if not (np.all(np.isfinite(poses)) and np.all(np.isfinite(joints))):
            raise ValueError("poses, joints: expected finite values; got NaN or infinity")
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "joints", joints)


@dataclasses.dataclass(eq=False)
class Sequence:
    """Frames from several calibrated cameras, with optional ground truth.

    Parameters
    ----------
    name : str
        Short name (``"benchmark"``, a recording's name).
    fps : float
        Frame rate, frames per second.
    rig : Rig
        The calibrated cameras; camera ``j`` saw ``masks[:, j]``.
    masks : (T, n_cams, H, W) bool ndarray or FrameStack
        Silhouettes (True = hand). Every camera of the rig must have size (W, H).
    rgb : (T, n_cams, H, W, 3) uint8 ndarray or FrameStack, optional
        Colour frames in RGB order.
    truth : Truth, optional
        Ground-truth poses and joints (synthetic sequences).
    provenance : dict, optional
        JSON-friendly description of where the sequence came from (generator,
        seed, source files, licences).
    """

    name: str
    fps: float
    rig: Rig
    masks: np.ndarray | FrameStack
    rgb: np.ndarray | FrameStack | None = None
    truth: Truth | None = None
    provenance: dict[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if not as_instance(self.name, str, "name", what="a non-empty string"):
            raise ValueError(f"name: expected a non-empty string; got {self.name!r}")
        if as_float(self.fps, "fps") <= 0:
            raise ValueError(f"fps: expected a positive frame rate; got {self.fps!r}")
        self.fps = float(self.fps)
        as_instance(self.rig, Rig, "rig", what="a handvar.camera.Rig")
        if not isinstance(self.masks, FrameStack):
            masks = np.asarray(self.masks)
            if masks.dtype != bool:
                raise ValueError(f"masks: expected a bool array; got dtype {masks.dtype}")
            self.masks = masks
        shape = tuple(self.masks.shape)
        n_cams = len(self.rig)
        if len(shape) != 4 or shape[1] != n_cams or shape[0] == 0:
            raise ValueError(
                f"masks: expected shape (T, {n_cams}, H, W) with T >= 1 for a rig of "
                f"{n_cams} cameras; got shape {shape}"
            )
        h, w = shape[2:]
        for cam_name, cam in zip(self.rig.names, self.rig.cameras, strict=True):
            if tuple(cam.size) != (w, h):
                raise ValueError(
                    f"rig: expected every camera to have the image size of the masks "
                    f"({w}x{h}); camera {cam_name!r} has {cam.size[0]}x{cam.size[1]}"
                )
        if self.rgb is not None:
            if not isinstance(self.rgb, FrameStack):
                rgb = np.asarray(self.rgb)
                if rgb.dtype != np.uint8:
                    raise ValueError(f"rgb: expected a uint8 array; got dtype {rgb.dtype}")
                self.rgb = rgb
            if tuple(self.rgb.shape) != (*shape, 3):
                raise ValueError(
                    f"rgb: expected shape {(*shape, 3)} to match the masks; "
                    f"got shape {tuple(self.rgb.shape)}"
                )
        if self.truth is not None:
            as_instance(self.truth, Truth, "truth")
            if self.truth.poses.shape[0] != shape[0]:
                raise ValueError(
                    f"truth: expected {shape[0]} frames to match the masks; "
                    f"got {self.truth.poses.shape[0]}"
                )
        as_instance(self.provenance, dict, "provenance")
        try:
            json.dumps(self.provenance)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"provenance: expected JSON-friendly values; {exc}") from None

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return int(self.masks.shape[0])

    @property
    def n_cameras(self) -> int:
        """Number of cameras."""
        return len(self.rig)

    @property
    def image_size(self) -> tuple[int, int]:
        """Image (width, height), pixels."""
        return int(self.masks.shape[3]), int(self.masks.shape[2])

    def __len__(self) -> int:
        return self.n_frames

    def __repr__(self) -> str:
        w, h = self.image_size
        extras = [k for k in ("rgb", "truth") if getattr(self, k) is not None]
        return (
            f"Sequence({self.name!r}, {self.n_frames} frames at {self.fps:g} fps, "
            f"{self.n_cameras} cameras {w}x{h}" + "".join(f", {k}" for k in extras) + ")"
        )


# --- writing -------------------------------------------------------------------------


def _write_png(path: Path, image: np.ndarray, params: list[int]) -> None:
    if not cv2.imwrite(str(path), image, params):
        raise OSError(f"{path}: could not write the PNG image")


def _is_sequence_dir(path: Path) -> bool:
    return (path / _JSON).is_file()


def check_output_dir(path: str | os.PathLike, *, argument: str = "path") -> Path:
    """Check that :func:`write_sequence` may write to `path`, before any work is done.

    A directory swap that was killed half-way is first undone and temporaries a killed
    run left beside `path` are removed (design §13.2).

    Parameters
    ----------
    path : path-like
        Intended sequence directory.
    argument : str, keyword-only
        The argument's name in the message of the error.

    Returns
    -------
    path : Path

    Raises
    ------
    ValueError
        If `path` is empty, its folder is missing or not writable, or it exists and is
        neither an empty directory nor a sequence directory.
    """
    if not os.fspath(path).strip():
        raise ValueError(f"{argument}: expected a directory name; got {os.fspath(path)!r}")
    target = Path(path)
    if target.parent.is_dir():
        recover_directory(target)
        remove_stale_temporaries(target)
    if target.exists() and not (
        target.is_dir() and (not any(target.iterdir()) or _is_sequence_dir(target))
    ):
        raise ValueError(
            f"{argument}: expected a new directory, an empty one or a sequence directory; "
            f"{target} exists and holds something else"
        )
    _check_writable_dir(path, argument)
    return target


def write_sequence(
    seq: Sequence,
    path: str | os.PathLike,
    *,
    progress: Callable[[Iterable[int]], Iterable[int]] | None = None,
) -> Path:
    """Write a sequence directory atomically.

    The directory is built under a temporary name next to `path` and renamed into
    place. If `path` already holds a sequence it is replaced only once the new one
    is complete; on any failure the old one is left as it was.

    Parameters
    ----------
    seq : Sequence
        What to write.
    path : path-like
        Target directory. It may not exist, be empty, or hold a sequence (which is
        replaced); anything else is refused.
    progress : callable, keyword-only, optional
        Wraps the frame iterator (for instance ``tqdm.tqdm``).

    Returns
    -------
    path : Path
        The written directory.

    Raises
    ------
    ValueError
        If `path` holds something other than a sequence.
    TypeError
        If `seq` is not a Sequence.
    OSError
        If a file cannot be written.
    """
    as_instance(seq, Sequence, "seq", what="a handvar.io.Sequence")
    target = check_output_dir(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    with OutputSet() as out:
        out.add(target, lambda tmp: _write_contents(seq, Path(tmp), progress), directory=True)
    return target


def _write_contents(seq: Sequence, out: Path, progress) -> None:
    mask_params = [cv2.IMWRITE_PNG_BILEVEL, 1]
    rgb_params = [cv2.IMWRITE_PNG_COMPRESSION, 3]
    for j in range(seq.n_cameras):
        (out / _camera_dir(j)).mkdir()
    frames: Iterable[int] = range(seq.n_frames)
    if progress is not None:
        frames = progress(frames)
    for t in frames:
        masks = np.asarray(seq.masks[t])
        rgb = None if seq.rgb is None else np.asarray(seq.rgb[t])
        for j in range(seq.n_cameras):
            cam_dir = out / _camera_dir(j)
            _write_png(
                cam_dir / _frame_name("mask", t), masks[j].astype(np.uint8) * 255, mask_params
            )
            if rgb is not None:
                _write_png(cam_dir / _frame_name("rgb", t), rgb[j][:, :, ::-1], rgb_params)
    if seq.truth is not None:
        np.savez_compressed(out / _TRUTH, poses=seq.truth.poses, joints=seq.truth.joints)
    w, h = seq.image_size
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "name": seq.name,
        "fps": seq.fps,
        "n_frames": seq.n_frames,
        "n_cameras": seq.n_cameras,
        "image_size": [w, h],
        "has_rgb": seq.rgb is not None,
        "has_truth": seq.truth is not None,
        "rig": seq.rig.to_dict(),
        "provenance": seq.provenance,
    }
    with open(out / _JSON, "w", encoding="utf-8") as fh:
        json.dump(meta, fh, indent=2)
        fh.write("\n")


# --- reading -------------------------------------------------------------------------


def _png_size(path: Path, kind: str) -> tuple[int, int]:
    """(width, height) from a PNG's header, checking signature, type and end marker."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(26)
            fh.seek(0, os.SEEK_END)
            length = fh.tell()
            fh.seek(max(0, length - len(_PNG_END)))
            tail = fh.read()
    except FileNotFoundError:
        raise SequenceError(f"{path}: missing frame") from None
    except OSError as exc:
        raise SequenceError(f"{path}: could not read the frame ({exc.strerror})") from None
    if len(head) < 26 or head[:8] != _PNG_SIGNATURE or head[12:16] != b"IHDR":
        raise SequenceError(f"{path}: expected a PNG image; the file is not one")
    if tail != _PNG_END:
        raise SequenceError(f"{path}: expected a complete PNG image; the file is truncated")
    width, height = struct.unpack(">II", head[16:24])
    colour_type = head[25]
    want = (0,) if kind == "mask" else (2, 6)
    if colour_type not in want:
        what = "a grey-level mask" if kind == "mask" else "an RGB image"
        raise SequenceError(f"{path}: expected {what}; got PNG colour type {colour_type}")
    return int(width), int(height)


def _require(meta: dict, key: str, types, where: str, check=None, expected: str = ""):
    if key not in meta:
        raise SequenceError(f"{where}: missing key {key!r}")
    value = meta[key]
    if isinstance(value, bool) and bool not in (types if isinstance(types, tuple) else (types,)):
        ok = False
    else:
        ok = isinstance(value, types) and (check is None or check(value))
    if not ok:
        raise SequenceError(f"{where}: expected {key!r} to be {expected}; got {value!r}")
    return value


def _read_meta(json_path: Path) -> dict:
    try:
        with open(json_path, encoding="utf-8") as fh:
            meta = json.load(fh)
    except FileNotFoundError:
        raise SequenceError(f"{json_path}: missing; not a sequence directory") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SequenceError(f"{json_path}: could not read the file ({exc})") from None
    except json.JSONDecodeError as exc:
        raise SequenceError(f"{json_path}: expected JSON; {exc}") from None
    if not isinstance(meta, dict):
        raise SequenceError(f"{json_path}: expected a JSON object; got {type(meta).__name__}")
    where = str(json_path)
    fmt = meta.get("format")
    if fmt != FORMAT:
        raise SequenceError(f"{where}: expected 'format' to be {FORMAT!r}; got {fmt!r}")
    _require(meta, "version", int, where, lambda v: v == FORMAT_VERSION, str(FORMAT_VERSION))
    _require(meta, "name", str, where, bool, "a non-empty string")
    _require(
        meta, "fps", (int, float), where, lambda v: math.isfinite(v) and v > 0, "a positive number"
    )
    _require(meta, "n_frames", int, where, lambda v: v > 0, "a positive integer")
    _require(meta, "n_cameras", int, where, lambda v: v > 0, "a positive integer")
    _require(
        meta,
        "image_size",
        list,
        where,
        lambda v: len(v) == 2 and all(isinstance(x, int) and x > 0 for x in v),
        "[width, height]",
    )
    _require(meta, "has_rgb", bool, where, None, "true or false")
    _require(meta, "has_truth", bool, where, None, "true or false")
    _require(meta, "rig", dict, where, None, "an object")
    _require(meta, "provenance", dict, where, None, "an object")
    return meta


def _read_truth(path: Path, n_frames: int) -> Truth:
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in ("poses", "joints") if k not in data.files]
            if missing:
                raise SequenceError(f"{path}: missing array {missing[0]!r}")
            poses = data["poses"]
            joints = data["joints"]
    except FileNotFoundError:
        raise SequenceError(
            f"{path}: missing (sequence.json says the sequence has truth)"
        ) from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        if isinstance(exc, SequenceError):
            raise
        raise SequenceError(f"{path}: could not read the arrays ({exc})") from None
    if poses.shape != (n_frames, _N_PARAMS):
        raise SequenceError(
            f"{path}: expected 'poses' of shape ({n_frames}, 26); got shape {poses.shape}"
        )
    if joints.shape != (n_frames, _N_JOINTS, 3):
        raise SequenceError(
            f"{path}: expected 'joints' of shape ({n_frames}, 21, 3); got shape {joints.shape}"
        )
    try:
        return Truth(poses, joints)
    except ValueError as exc:
        raise SequenceError(f"{path}: {exc}") from None


def read_sequence(path: str | os.PathLike, *, lazy: bool = False) -> Sequence:
    """Read and check a sequence directory written by :func:`write_sequence`.

    Every file is checked before anything is returned: ``sequence.json`` (all keys,
    types, the rig), that every frame of every camera exists and is a complete PNG
    of the size of its camera, that no frame beyond the stated count is present,
    and that ``truth.npz`` holds arrays of the right shapes.

    Parameters
    ----------
    path : path-like
        The sequence directory.
    lazy : bool, keyword-only
        If False (default) the masks are decoded into one bool array. If True they
        stay on disk and are decoded when indexed (:class:`FrameStack`). Colour
        frames are always lazy.

    Returns
    -------
    seq : Sequence

    Raises
    ------
    SequenceError
        (a ValueError) naming the file that is missing, unreadable or inconsistent.
    """
    root = Path(path)
    try:
        recover_directory(root)  # a swap killed half-way (design §13.2)
    except OSError:
        pass
    if not root.is_dir():
        raise SequenceError(f"{root}: expected a sequence directory; it does not exist")
    json_path = root / _JSON
    meta = _read_meta(json_path)
    try:
        rig = Rig.from_dict(meta["rig"])
    except ValueError as exc:
        raise SequenceError(f"{json_path}: {exc}") from None
    n_frames, n_cams = meta["n_frames"], meta["n_cameras"]
    width, height = meta["image_size"]
    if len(rig) != n_cams:
        raise SequenceError(
            f"{json_path}: expected {n_cams} cameras in 'rig' ('n_cameras'); got {len(rig)}"
        )
    for j, (cam_name, cam) in enumerate(zip(rig.names, rig.cameras, strict=True)):
        if tuple(cam.size) != (width, height):
            raise SequenceError(
                f"{json_path}: camera {j} ({cam_name!r}) is calibrated for "
                f"{cam.size[0]}x{cam.size[1]} images; the frames are {width}x{height}"
            )

    kinds = ["mask", "rgb"] if meta["has_rgb"] else ["mask"]
    paths = {k: np.empty((n_frames, n_cams), dtype=object) for k in kinds}
    for j in range(n_cams):
        cam_dir = root / _camera_dir(j)
        if not cam_dir.is_dir():
            raise SequenceError(f"{cam_dir}: missing folder of camera {j}")
        for kind in kinds:
            for t in range(n_frames):
                file = cam_dir / _frame_name(kind, t)
                size = _png_size(file, kind)
                if size != (width, height):
                    raise SequenceError(
                        f"{file}: expected {width}x{height} pixels (the calibration of "
                        f"camera {j} in {json_path.name}); got {size[0]}x{size[1]}"
                    )
                paths[kind][t, j] = str(file)
            extra = cam_dir / _frame_name(kind, n_frames)
            if extra.exists():
                raise SequenceError(
                    f"{extra}: unexpected frame; {json_path.name} says the sequence has "
                    f"{n_frames} frames"
                )
    truth = _read_truth(root / _TRUTH, n_frames) if meta["has_truth"] else None

    masks: np.ndarray | FrameStack = FrameStack(paths["mask"], "mask", (width, height))
    if not lazy:
        masks = masks[:]
    rgb = FrameStack(paths["rgb"], "rgb", (width, height)) if meta["has_rgb"] else None
    try:
        return Sequence(
            name=meta["name"],
            fps=meta["fps"],
            rig=rig,
            masks=masks,
            rgb=rgb,
            truth=truth,
            provenance=meta["provenance"],
        )
    except ValueError as exc:
        raise SequenceError(f"{json_path}: {exc}") from None


# --- what a sequence argument names -----------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SequenceSpec:
    """What a sequence argument names (:func:`resolve_sequence`).

    Attributes
    ----------
    kind : {"recording", "directory", "synthetic"}
        Real recordings (one video file or image folder per camera), a sequence
        directory (:func:`read_sequence`), or a synthetic sequence by name.
    paths : tuple of str
        The recordings, one per camera; the directory; empty for a synthetic name.
    name : str
        The synthetic sequence's name; empty otherwise.
    """

    kind: str
    paths: tuple[str, ...] = ()
    name: str = ""


def _is_image_folder(path: str) -> bool:
    return any(os.path.splitext(f)[1].lower() in IMAGE_SUFFIXES for f in os.listdir(path))


def resolve_sequence(
    spec: str, *, names: Iterable[str] = (), argument: str = "sequence"
) -> SequenceSpec:
    """Decide what `spec` names: recordings, a sequence directory or a synthetic name.

    In this order: several paths separated by commas, a file, or a folder of images
    without ``sequence.json`` are recordings; any other folder is a sequence directory;
    one of `names` is a synthetic sequence.  Nothing is opened or read beyond a folder
    listing.

    Parameters
    ----------
    spec : str
        The argument as given (``handvar track SEQ``).
    names : iterable of str, keyword-only
        The synthetic sequences' names (``handvar.synth.SEQUENCE_NAMES``).
    argument : str, keyword-only
        The argument's name in the message of the error.

    Returns
    -------
    SequenceSpec

    Raises
    ------
    ValueError
        If `spec` is none of these.

    Examples
    --------
    >>> resolve_sequence("benchmark", names=("benchmark", "flip"))
    SequenceSpec(kind='synthetic', paths=(), name='benchmark')
    >>> resolve_sequence("left.mp4,right.mp4").paths
    ('left.mp4', 'right.mp4')
    """
    spec = as_instance(spec, str, argument)
    names = tuple(names)
    if "," in spec or os.path.isfile(spec):
        return SequenceSpec("recording", tuple(spec.split(",")))
    if os.path.isdir(spec):
        if not os.path.exists(os.path.join(spec, _JSON)) and _is_image_folder(spec):
            return SequenceSpec("recording", (spec,))
        return SequenceSpec("directory", (spec,))
    if spec in names:
        return SequenceSpec("synthetic", name=spec)
    raise ValueError(
        f"{argument}: expected a sequence directory or one of {', '.join(names)}; got {spec!r}"
    )
