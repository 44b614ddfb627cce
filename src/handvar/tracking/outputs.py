"""The files of a tracked sequence: poses, joints, the whole track and its overlays.

:func:`write_track_outputs` writes into one folder::

    poses.csv     T × 26 fitted poses, mm and degrees, a header of parameter names
    joints.csv    T × 63 joint positions (j0_x, j0_y, j0_z, …), mm
    track.npz     every field of `TrackResult` (poses, joints, starts, costs,
                  iterations, seconds, iou, cost, keypoint_error, lost, empty),
                  predictor and seed; with a quality also reinit and with_keypoints
    cameras.yml   with a rig: the cameras of the full-resolution frames, in
                  `handvar.camera.Rig.save`'s OpenCV format (what ``--calib`` reads)
    quality.csv   with a quality (design §14.3): per frame its silhouette IoU, keypoint error
                  (hand sizes, empty without keypoints), final cost, the flags lost,
                  reinit, empty, keypoints, no_hand (0/1) and the keypoints rejected
    overlay.png   a strip of up to six evenly spaced frames of the first camera at half
                  size: the fitted model's outline and joints over the frame
    overlay.mp4   every frame, all cameras side by side (`OverlayWriter`, which writes
                  numbered PNGs to ``overlay_frames/`` when the codec is missing); with
                  a quality, a line of it at the foot of each view, red on lost frames

The files are all-or-nothing (design §13.1): each is written under a temporary name
beside its destination, and all are renamed into place only once every one of them was
written (`handvar.atomic.OutputSet`); a failure leaves the folder as it was. The
track owns its folder: the files of an earlier track there that this one does not
write (`TRACK_FILES`: quality.csv of a run with recovery, overlay.mp4 of one with
video, hands.json of a run of both hands) are removed in the same commit; other files
are left alone. The folder is locked
while it is written (`handvar.atomic.lock_directory`): a second run into it at the
same time stops with "another run is writing OUT". The overlays are
drawn over the sequence's masks or, for a real recording, over its colour frames
(:func:`recording_backgrounds`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import cv2
import numpy as np

from handvar.atomic import OutputSet, lock_directory, user_paths, write_png
from handvar.camera import Rig
from handvar.io import Sequence
from handvar.params import NAMES
from handvar.render import overlay_views, side_by_side, write_overlay_video
from handvar.tracking.tracker import TrackResult
from handvar.validate import as_instance

__all__ = [
    "TRACK_FILES",
    "overlay_strip",
    "quality_captions",
    "recording_backgrounds",
    "sequence_backgrounds",
    "write_track_outputs",
]

_N_JOINTS = 21
_STRIP_FRAMES = 6  # frames in overlay.png, at most
_STRIP_SHRINK = 2  # overlay.png tiles are 1/_STRIP_SHRINK of the camera's size

#: The columns of quality.csv after the frame index (`TrackQuality`'s fields).
#: Every file and folder `write_track_outputs` may write: a new track removes those of
#: an earlier one that it does not write itself (a run without video or recovery); and
#: the index of an earlier run of both hands (`handvar.pipeline.HANDS_INDEX`), which
#: `handvar export` and `handvar view` would read instead of the new track.
TRACK_FILES = (
    "poses.csv", "joints.csv", "track.npz", "cameras.yml", "overlay.png", "quality.csv",
    "overlay.mp4", "overlay_frames", "hands.json",
)  # fmt: skip
_QUALITY = (
    "iou", "keypoint_error", "cost", "lost", "reinit", "empty", "keypoints", "no_hand",
    "rejected",
)  # fmt: skip

Backgrounds = Callable[[list[int]], Iterable[tuple[int, list[np.ndarray] | np.ndarray]]]


def sequence_backgrounds(sequence: Sequence) -> Backgrounds:
    """The masks of `sequence` as overlay backgrounds: ``f(frames)`` yields ``(t, masks)``."""

    def backgrounds(frames: list[int]) -> Iterator[tuple[int, np.ndarray]]:
        for t in frames:
            yield t, np.asarray(sequence.masks[t])

    return backgrounds


def recording_backgrounds(source) -> Backgrounds:
    """The colour frames of a recording as overlay backgrounds.

    Parameters
    ----------
    source : VideoSource
        The recording (`handvar.vision.sources.open_source`), BGR frames.

    Returns
    -------
    callable
        ``f(frames)`` yields ``(t, images)`` for the ascending frame indices `frames`,
        one RGB image per camera; a video is read once, up to the last of them, an
        image folder only at those frames.
    """

    def backgrounds(frames: list[int]) -> Iterator[tuple[int, list[np.ndarray]]]:
        wanted = sorted(set(frames))
        if all(r.kind == "folder" for r in source.readers):  # images: only those wanted
            steps = (item for t in wanted for item in source.frames(t, t + 1))
        else:  # a video is decoded in order
            steps = (item for item in source.frames(0, wanted[-1] + 1) if item[0] in wanted)
        for t, images in steps:
            yield t, [cv2.cvtColor(im, cv2.COLOR_BGR2RGB) for im in images]

    return backgrounds


def quality_captions(quality) -> list[str]:
    """One line per frame of a `TrackQuality`: IoU, keypoint error and what happened.

    Examples
    --------
    >>> from types import SimpleNamespace as Q
    >>> q = Q(iou=np.array([0.91, 0.3]), keypoint_error=np.array([np.nan, 0.62]),
    ...       lost=np.array([False, True]), reinit=np.array([False, True]),
    ...       empty=np.array([False, False]))
    >>> quality_captions(q)
    ['IoU 0.91', 'IoU 0.30  kp 0.62  re-init  LOST']
    >>> quality_captions(Q(iou=np.array([np.nan]), keypoint_error=np.array([0.05]),
    ...                    lost=np.array([False]), reinit=np.array([False]),
    ...                    empty=np.array([False])))
    ['kp 0.05']
    """
    lines = []
    for t in range(len(quality.iou)):
        if quality.empty[t]:
            lines.append("empty silhouette")
            continue
        parts = []  # a keypoint frame fitted without its silhouette has no IoU
        if np.isfinite(quality.iou[t]):
            parts.append(f"IoU {quality.iou[t]:.2f}")
        if np.isfinite(quality.keypoint_error[t]):
            parts.append(f"kp {quality.keypoint_error[t]:.2f}")
        if quality.reinit[t]:
            parts.append("re-init")
        if quality.lost[t]:
            parts.append("LOST")
        text = "  ".join(parts)
        lines.append(text)
    return lines


def _check_result(result: TrackResult, sequence: Sequence | None) -> int:
    n_frames = result.poses.shape[0]
    if sequence is None:
        if n_frames < 1:
            raise ValueError(f"result: expected at least one tracked frame; got {n_frames}")
        return n_frames
    if not 1 <= n_frames <= sequence.n_frames:
        raise ValueError(
            f"result: expected 1 to {sequence.n_frames} tracked frames (the sequence's); "
            f"got {n_frames}"
        )
    return n_frames


def overlay_strip(
    result: TrackResult, sequence: Sequence, hand, *, backgrounds: Backgrounds | None = None
) -> np.ndarray:
    """Up to six evenly spaced frames of the first camera, half size, side by side.

    Parameters
    ----------
    result : TrackResult
        The track of the first T frames of `sequence`.
    sequence : Sequence
        The tracked sequence (its rig, and its masks unless `backgrounds` is given).
    hand : HandModel
        The model that was tracked.
    backgrounds : callable, keyword-only, optional
        What the model is drawn over: ``backgrounds(frames)`` yields ``(t, images)``
        for the ascending frame indices `frames` (see :func:`recording_backgrounds`).
        Default: the sequence's masks.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        RGB image, each tile titled with its frame number.
    """
    n_frames = _check_result(result, sequence)
    if backgrounds is None:
        backgrounds = sequence_backgrounds(sequence)
    picks = np.unique(np.linspace(0, n_frames - 1, min(_STRIP_FRAMES, n_frames)).round())
    picks = picks.astype(int).tolist()
    tiles = []
    for t, images in backgrounds(picks):
        view = overlay_views(hand, sequence.rig, images, result.poses[t])[0]
        size = (view.shape[1] // _STRIP_SHRINK, view.shape[0] // _STRIP_SHRINK)
        tiles.append(cv2.resize(view, size, interpolation=cv2.INTER_AREA))
    return side_by_side(tiles, [f"frame {t}" for t in picks])


def write_track_outputs(
    out_dir: str | os.PathLike,
    result: TrackResult,
    sequence: Sequence | None,
    hand,
    *,
    predictor: str,
    seed: int,
    video: bool = True,
    backgrounds: Backgrounds | None = None,
    quality=None,
    overlays: bool = True,
    extra: dict[str, np.ndarray] | None = None,
    rig: Rig | None = None,
) -> dict[str, Path | str]:
    """Write the files of a track (poses, joints, the track, overlays) into `out_dir`.

    Parameters
    ----------
    out_dir : path-like
        Output folder, created if missing.
    result : TrackResult
        The track of the first T frames of `sequence`.
    sequence : Sequence or None
        The tracked sequence; None only without overlays.
    hand : HandModel
        The model that was tracked.
    predictor : str, keyword-only
        Name of the motion predictor, stored in track.npz.
    seed : int, keyword-only
        Seed of the optimiser's samples, stored in track.npz.
    video : bool, keyword-only
        Also write overlay.mp4.
    backgrounds : callable, keyword-only, optional
        What the overlays are drawn over (see :func:`overlay_strip`); default: the
        sequence's masks.
    quality : TrackQuality, keyword-only, optional
        Per-frame fit quality (`handvar.tracking.recovery`): written to quality.csv and
        track.npz and drawn on the overlay video.
    overlays : bool, keyword-only
        Write overlay.png (and, with `video`, the overlay video); without them the
        frames are not needed and `sequence` may be None.
    extra : dict of str to ndarray, keyword-only, optional
        More arrays for track.npz (`handvar.pipeline.Track` keeps its rig, hand shape
        and options there); a name already taken is refused.
    rig : Rig, keyword-only, optional
        The cameras of the full-resolution frames, written to cameras.yml
        (`Rig.save`; `Rig.load` reads them back exactly).

    Returns
    -------
    dict
        ``"poses"``, ``"joints"``, ``"track"``, ``"overlay"`` (and ``"quality"``,
        ``"cameras"``): the files written (Path);
        ``"video"``: overlay.mp4, or the ``overlay_frames`` folder when the codec is
        missing; ``"video_error"``: why no video was written (str), instead of raising.
    """
    if overlays and sequence is None:
        raise ValueError("sequence: expected the tracked sequence for the overlays; got None")
    n_frames = _check_result(result, sequence)
    out = Path(out_dir)
    with lock_directory(out, "out_dir"):  # held already by a command that checked --out
        return _write_track_outputs(
            out, result, sequence, hand, n_frames, predictor, seed, video, backgrounds,
            quality, overlays, extra, rig,
        )  # fmt: skip


def _write_track_outputs(
    out: Path, result, sequence, hand, n_frames, predictor, seed, video, backgrounds,
    quality, overlays, extra, rig,
) -> dict[str, Path | str]:  # fmt: skip
    if backgrounds is None and overlays:
        backgrounds = sequence_backgrounds(sequence)
    written: dict[str, Path | str] = {
        "poses": out / "poses.csv",
        "joints": out / "joints.csv",
        "track": out / "track.npz",
    }
    if overlays:
        written["overlay"] = out / "overlay.png"
    if rig is not None:
        rig = as_instance(rig, Rig, "rig", what="a Rig")
        written["cameras"] = out / "cameras.yml"

    header = ",".join(NAMES)
    jheader = ",".join(f"j{j}_{c}" for j in range(_N_JOINTS) for c in "xyz")

    arrays = {f.name: getattr(result, f.name) for f in dataclasses.fields(result)}
    if quality is not None:
        arrays["reinit"] = np.asarray(quality.reinit)
        arrays["with_keypoints"] = np.asarray(quality.keypoints)
        written["quality"] = out / "quality.csv"
        table = np.column_stack([np.arange(n_frames)] + [
            np.asarray(getattr(quality, name), dtype=float)[:n_frames] for name in _QUALITY
        ])  # fmt: skip

        def write_quality(path: str) -> None:
            fmt = ["%d", "%.4f", "%.4f", "%.6g", "%d", "%d", "%d", "%d", "%d", "%d"]
            qheader = "frame," + ",".join(_QUALITY)
            np.savetxt(path, table, delimiter=",", header=qheader, comments="", fmt=fmt)

    taken = sorted(set(extra or ()) & {*arrays, "predictor", "seed"})
    if taken:
        raise ValueError(f"extra: expected names not already in track.npz; got {taken}")
    arrays.update(extra or {})

    def write_npz(path: str) -> None:
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **arrays, predictor=predictor, seed=seed)

    def write_strip(path: str) -> None:
        strip = overlay_strip(result, sequence, hand, backgrounds=backgrounds)
        write_png(path, cv2.cvtColor(strip, cv2.COLOR_RGB2BGR))

    with OutputSet() as outputs:
        outputs.add(written["poses"], lambda p: np.savetxt(
            p, result.poses, delimiter=",", header=header, comments="",
            fmt="%.6f"))  # fmt: skip
        outputs.add(written["joints"], lambda p: np.savetxt(
            p, result.joints.reshape(n_frames, -1), delimiter=",", header=jheader,
            comments="", fmt="%.4f"))  # fmt: skip
        outputs.add(written["track"], write_npz)
        if rig is not None:
            outputs.add(written["cameras"], rig.save)
        if overlays:
            outputs.add(written["overlay"], write_strip)
        if quality is not None:
            outputs.add(written["quality"], write_quality)
        if video and overlays:
            _add_video(outputs, out, hand, sequence, result, backgrounds, written, quality)
        for name in TRACK_FILES:  # the output set owns its folder: no file of an
            outputs.remove(out / name)  # earlier run stays beside the new ones
    return written


def _add_video(
    outputs: OutputSet, out: Path, hand, sequence, result, backgrounds, written, quality=None
):
    """Write overlay.mp4 (or overlay_frames/) aside into `outputs`; a failure is noted."""
    target = out / "overlay.mp4"
    tmp = Path(outputs.temporary(target))
    frames_tmp = tmp.with_name(tmp.stem + "_frames")  # OverlayWriter's fallback folder
    outputs.track(frames_tmp)
    try:
        got = write_overlay_video(
            tmp, hand, sequence.rig, result.poses, backgrounds, sequence.fps,
            captions=None if quality is None else quality_captions(quality),
            alerts=None if quality is None else quality.lost,
        )  # fmt: skip
    except OSError as exc:
        written["video_error"] = user_paths(str(exc))
        return
    if got == tmp:
        outputs.place(tmp, target)
        written["video"] = target
    elif got is not None:
        outputs.place(got, out / "overlay_frames", directory=True)
        written["video"] = out / "overlay_frames"
