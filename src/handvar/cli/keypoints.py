"""`handvar keypoints`: 2D hand keypoints of a video by MediaPipe Hands (optional extra)."""

from __future__ import annotations

import click

from handvar.cli.common import _one_line_errors


@click.command("keypoints")
@click.argument("video", type=click.Path())
@click.option("--out", type=click.Path(dir_okay=False), required=True,
              help="Keypoint file to write: .npy (T, 21, 3) or .csv (63 columns).")  # fmt: skip
@click.option("--hand", type=click.Choice(["right", "left"]), default="right",
              show_default=True, help="Which hand to keep.")  # fmt: skip
@click.option("--mirrored", is_flag=True,
              help="The video is mirrored (a selfie camera).")  # fmt: skip
@click.option("--frames", "n_frames", type=click.IntRange(min=1), default=None,
              help="Only the first K frames.")  # fmt: skip
@_one_line_errors
def keypoints_command(video, out, hand, mirrored, n_frames) -> None:
    """Detect the 21 hand keypoints in every frame of VIDEO with MediaPipe Hands.

    VIDEO is a video file or a folder of images. OUT holds, per frame, x and y in
    pixels of the full-resolution frame and a confidence in [0, 1] (NaN and 0 where no
    hand was found), in the order of the model's joints G(x); `handvar init
    --keypoints OUT` reads it. Needs the optional extra: pip install 'handvar[mediapipe]'.
    """
    import numpy as np

    try:
        from handvar.vision.mediapipe import MissingExtraError, detect_video
    except ImportError as exc:  # pragma: no cover - the module itself needs only cv2
        raise ValueError(str(exc)) from None
    from handvar.atomic import check_output_file
    from handvar.vision.keypoints import check_output_suffix, write_keypoints

    check_output_suffix(out)  # fail before detecting, not after
    check_output_file(out, "--out", suffixes=(".npy", ".csv"))
    try:
        from tqdm import tqdm

        def progress(it):
            return tqdm(it, total=n_frames, desc="keypoints", unit="frame", leave=False)
    except ImportError:  # pragma: no cover - tqdm is a core dependency
        progress = None
    try:
        array = detect_video(
            video, hand=hand, mirrored=mirrored, frames=n_frames, progress=progress
        )
    except MissingExtraError as exc:
        raise ValueError(str(exc)) from None
    write_keypoints(out, array)
    found = int(np.count_nonzero(array[:, 0, 2] > 0))
    sure = int(np.count_nonzero(array[:, 0, 2] >= 0.5))
    click.echo(
        f"{video}: {hand} hand in {found} of {len(array)} frames "
        f"({sure} with confidence >= 0.5) -> {out}"
    )
