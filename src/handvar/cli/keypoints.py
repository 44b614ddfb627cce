"""`handvar keypoints`: 2D hand keypoints of a video by MediaPipe Hands (optional extra)."""

from __future__ import annotations

import click

from handvar.cli.common import _one_line_errors


@click.command("keypoints")
@click.argument("video", type=click.Path())
@click.option("--out", type=click.Path(dir_okay=False), required=True,
              help="Keypoint file to write: .npz (the points with the detector's world "
                   "landmarks, depth, presence and handedness), .npy (T, 21, 3) or .csv "
                   "(63 columns); with --hands 2, .json (every hand found).")  # fmt: skip
@click.option("--hands", type=click.IntRange(min=1, max=2), default=1, show_default=True,
              help="2: keep every hand found (up to two) with its side, for "
                   "handvar track --hands 2 --keypoints.")  # fmt: skip
@click.option("--hand", type=click.Choice(["right", "left", "auto"]), default="right",
              show_default=True,
              help="Which hand to keep; auto: the side most of the first 30 frames "
                   "with a hand say, then that side's on every frame, its label "
                   "stored.")  # fmt: skip
@click.option("--mirrored", is_flag=True,
              help="The video is mirrored (a selfie camera).")  # fmt: skip
@click.option("--frames", "n_frames", type=click.IntRange(min=1), default=None,
              help="Only the first K frames.")  # fmt: skip
@click.option("--allow-short", is_flag=True,
              help="A video that stops decoding before the frame count of its container "
                   "(truncated or damaged) is read to where it stops, with a warning "
                   "[default: refused].")  # fmt: skip
@_one_line_errors
def keypoints_command(video, out, hands, hand, mirrored, n_frames, allow_short) -> None:
    """Detect the 21 hand keypoints in every frame of VIDEO with MediaPipe Hands.

    VIDEO is a video file or a folder of images. OUT holds, per frame, x and y in
    pixels of the full-resolution frame and a confidence in [0, 1] (NaN and 0 where no
    hand was found), in the order of the model's joints G(x); `handvar init
    --keypoints OUT` reads it. With --hands 2, OUT (.json) holds every hand found in each
    frame (up to two), each with its side; `handvar track VIDEO --hands 2 --keypoints
    OUT` reads it. Needs the optional extra: pip install 'handvar[mediapipe]'.
    """
    import numpy as np

    try:
        from handvar.vision.mediapipe import MissingExtraError, detect_video
    except ImportError as exc:  # pragma: no cover - the module itself needs only cv2
        raise ValueError(str(exc)) from None
    from handvar.atomic import check_output_file
    from handvar.vision.keypoints import check_output_suffix, write_keypoints

    if hands == 2:
        source = click.get_current_context().get_parameter_source("hand")
        if source is click.core.ParameterSource.COMMANDLINE:
            raise ValueError(f"--hand: expected none with --hands 2 (every hand found is "
                             f"kept, with its side); got {hand}")  # fmt: skip
        return _both_hands(video, out, mirrored, n_frames, allow_short)
    if out.lower().endswith(".json"):
        raise ValueError(f"--out: expected .npz, .npy or .csv for one hand (.json with "
                         f"--hands 2); got {out}")  # fmt: skip
    check_output_suffix(out)  # fail before detecting, not after
    check_output_file(out, "--out", suffixes=(".npy", ".csv", ".npz"))
    progress = _progress(n_frames)
    try:
        kp = detect_video(
            video, hand=hand, mirrored=mirrored, frames=n_frames, progress=progress,
            allow_short=allow_short, details=True,
        )  # fmt: skip
    except MissingExtraError as exc:
        raise ValueError(str(exc)) from None
    # the .npz keeps the handedness and its score: the tracker weighs them by its side
    weighted = kp.for_side(None if hand == "auto" else hand)
    write_keypoints(out, kp if out.lower().endswith(".npz") else weighted)
    c = weighted.confidence[:, 0]
    found = int(np.count_nonzero(c > 0))
    sure = int(np.count_nonzero(c >= 0.5))
    side = hand if hand != "auto" else f"{kp.side() or 'no'} (auto)"
    click.echo(
        f"{video}: {side} hand in {found} of {kp.n_frames} frames "
        f"({sure} with confidence >= 0.5) -> {out}"
    )


def _progress(n_frames):
    from tqdm import tqdm

    def progress(it):
        return tqdm(it, total=n_frames, desc="keypoints", unit="frame", leave=False)

    return progress


def _both_hands(video, out: str, mirrored: bool, n_frames, allow_short: bool) -> None:
    """--hands 2: every hand MediaPipe finds (asked for two), per frame, to a .json."""
    from collections import Counter

    from handvar.atomic import check_output_file
    from handvar.vision.keypoints import write_detections

    try:
        from handvar.vision.mediapipe import MissingExtraError, detect_video_hands
    except ImportError as exc:  # pragma: no cover - the module itself needs only cv2
        raise ValueError(str(exc)) from None
    if not out.lower().endswith(".json"):
        raise ValueError(f"--out: expected a .json file with --hands 2 (every hand found); "
                         f"got {out}")  # fmt: skip
    check_output_file(out, "--out", suffixes=(".json",))
    try:
        found = detect_video_hands(video, mirrored=mirrored, frames=n_frames,
                                   progress=_progress(n_frames),
                                   allow_short=allow_short)  # fmt: skip
    except MissingExtraError as exc:
        raise ValueError(str(exc)) from None
    write_detections(out, found)
    counts = Counter(min(len(f), 2) for f in found)
    click.echo(f"{video}: {len(found)} frames; two hands in {counts[2]}, one in {counts[1]}, "
               f"none in {counts[0]} -> {out}")  # fmt: skip
