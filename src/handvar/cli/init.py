"""`handvar init`: the first frame's pose from real video (or a sequence)."""

from __future__ import annotations

import click

from handvar.cli.common import _FiniteRange, _one_line_errors, _open_recordings, _recording_options
from handvar.cli.track import _option_names


def _open_sources(sources, calib, fov, scale):
    """SOURCES opened: one sequence directory (a `handvar.io.Sequence`, read lazily) or
    the recordings (a `VideoSource`)."""
    import os

    if len(sources) == 1 and os.path.isfile(os.path.join(sources[0], "sequence.json")):
        if calib is not None or fov is not None:
            raise ValueError("--calib, --fov: a sequence directory has its own rig; got one")
        from handvar.io import read_sequence

        return read_sequence(sources[0], lazy=True)
    return _open_recordings(sources, calib, fov, scale)


def _frame_silhouettes(opened, frame, wrist, threshold, allow_empty=False):
    """Rig, BGR images (or None) and masks of frame `frame` of the opened SOURCES
    (`_open_sources`); `allow_empty`: an empty silhouette, or one that is not a hand,
    is taken as empty."""
    import numpy as np

    from handvar.io import Sequence

    if isinstance(opened, Sequence):
        return opened.rig, None, np.asarray(opened.masks[frame])
    for _, images, masks in opened.silhouettes(
        frame, frame + 1, wrist=wrist, threshold=threshold, allow_empty=allow_empty
    ):
        return opened.rig, images, masks
    raise ValueError(
        f"--frame: expected a frame of the recording ({opened.n_frames} frames); got {frame}"
    )


#: Lowest silhouette IoU of the best initial pose that `init` accepts (design §13.4):
#: good initialisations measure 0.70-0.92 on the example video
#: (``studies/keypoint_init.py``), a 3x3 blob 0.001.
INIT_MIN_IOU = 0.3


@click.command("init")
@click.argument("sources", nargs=-1, required=True)
@_recording_options
@click.option("--frame", type=click.IntRange(min=0), default=0, show_default=True,
              help="Frame to fit.")  # fmt: skip
@click.option("--wrist/--no-wrist", default=True, show_default=True,
              help="Cut a visible forearm off the silhouettes at the wrist.")  # fmt: skip
@click.option("--threshold", type=_FiniteRange(min=0.0, min_open=True), default=None,
              help="Skin likelihood-ratio threshold [default: 0.5].")  # fmt: skip
@click.option("--hand-length", type=_FiniteRange(min=50.0, max=400.0), default=185.0,
              show_default=True, help="Hand length (wrist to middle fingertip), mm.")  # fmt: skip
@click.option("--shape", type=click.Path(), default=None,
              help="The hand's proportions from an earlier track (its OUT directory or "
              "track.npz), as `handvar track --shape`: give the same to both.")  # fmt: skip
@click.option("--hand", "side", type=click.Choice(("right", "left", "auto")), default=None,
              help="Which hand is filmed; auto: with two cameras' keypoints the side of "
              "the hand's 3D shape, else of the keypoints' handedness (a .npz of `handvar "
              "keypoints`, MediaPipe's labels read for the person's hand), as `handvar "
              "track --hand auto` [default: the side of --shape, else right].")  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the refinement's random samples.")  # fmt: skip
@click.option("--out", type=click.Path(dir_okay=False), default="init_pose.txt",
              show_default=True,
              help="Pose file to write (26 numbers, for track --init).")  # fmt: skip
@click.option("--overlay", type=click.Path(dir_okay=False), default=None,
              help="Also write a PNG of the fitted model over the frame.")  # fmt: skip
@click.option("--keypoints", "keypoint_files", multiple=True, type=click.Path(dir_okay=False),
              help="2D keypoints (.npy or .csv, see `handvar keypoints`), one file per "
              "source in order: the pose and the wrist cut come from them.")  # fmt: skip
@_one_line_errors
def init_command(
    sources,
    calib,
    fov,
    scale,
    frame,
    wrist,
    threshold,
    hand_length,
    shape,
    side,
    seed,
    out,
    overlay,
    keypoint_files,
) -> None:
    """Find the hand's pose in one frame of SOURCES and write it as a pose file.

    SOURCES are video files or image folders, one per camera of --calib (a single
    video may go without calibration: its depth is then only as good as --fov and
    --hand-length), or one sequence directory. The search tries named hand shapes over
    a grid of palm orientations, places each by the silhouette's centroid and size,
    scores it by silhouette IoU and refines the best with the tracker. With --keypoints
    (pixels of the full-resolution frames) the palm's orientation, the side of the hand
    facing the camera and its position come from the keypoints instead, and the
    forearm is cut at the detected wrist; the search is the fallback for a frame
    without them.
    """
    import os

    import numpy as np

    from handvar.atomic import OutputSet, check_output_file, write_png
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.tracking.init import initial_pose

    check_output_file(out, "--out")  # before any work
    if overlay is not None:
        check_output_file(overlay, "--overlay", suffixes=(".png",))
    shape, side = _shape_and_side(shape, side, hand_length)
    opened = _open_sources(sources, calib, fov, scale)
    if frame >= opened.n_frames:
        raise ValueError(
            f"--frame: expected a frame of SOURCES ({opened.n_frames} frames); got {frame}"
        )
    with _option_names(None):  # hand_side's, check_keypoints's keywords as the options
        kps, side = _frame_keypoints(keypoint_files, opened, frame, scale, side)
    cut_here = wrist and kps is None
    # with keypoints they place the hand: a silhouette that is not a hand (skin colour
    # everywhere) does not stop the fit, which keeps the pose only if it explains them
    rig, images, masks = _frame_silhouettes(opened, frame, cut_here, threshold,
                                            allow_empty=kps is not None)  # fmt: skip
    if kps is not None:
        from handvar.vision.wrist import cut_wrist

        if wrist:
            masks = np.stack([cut_wrist(m, k) if m.any() else m
                              for m, k in zip(masks, kps, strict=True)])  # fmt: skip
    if kps is not None and not any(np.any(k[:, 2] > 0) for k in kps) and not masks.any():
        from handvar.vision.keypoints import read_keypoints

        first = min(int(np.argmax(k.present.any(axis=1)))
                    for k in map(read_keypoints, keypoint_files))  # fmt: skip
        raise ValueError(
            f"--keypoints: expected keypoints or a hand's silhouette in frame {frame}; got "
            f"neither: the keypoints begin at frame {first} (--frame {first}; `handvar "
            "track` without --init starts there); nothing written"
        )
    if shape is not None and shape.side != side:  # --hand auto took the other side
        raise ValueError(f"--hand: expected the keypoints' side to be {shape.side}, the side "
                         f"of --shape; got {side}")  # fmt: skip
    hand = HandModel(shape or HandShape.from_size(hand_length, side=side))
    result = initial_pose(masks, rig, hand, keypoints=kps, rng=np.random.default_rng(seed))
    if not (result.iou >= INIT_MIN_IOU or _explains_keypoints(result, kps)):
        raise ValueError(
            f"SOURCES: expected a silhouette the hand model fits (IoU >= {INIT_MIN_IOU:g}); "
            f"the best fit of frame {frame} has IoU {result.iou:.3f}; nothing written"
        )
    line = " ".join(f"{v:.6f}" for v in result.pose) + "\n"

    def write_text(path):
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(line)

    with OutputSet() as outputs:  # both files, or neither (design §13.1)
        outputs.add(out, write_text)
        if overlay is not None:
            from handvar.render.overlay import overlay_frame

            if images is None:  # a sequence directory: draw over its masks
                images = [
                    np.repeat((np.asarray(m, np.uint8) * 160)[:, :, None], 3, 2) for m in masks
                ]
            picture = overlay_frame(images, rig, hand, result.pose, masks)

            def write_overlay(path):
                write_png(path, picture)

            outputs.add(overlay, write_overlay)
    where = os.path.basename(sources[0].rstrip(os.sep)) + ("" if len(sources) == 1 else ", ...")
    click.echo(
        f"{where} frame {frame}: IoU {result.iou:.3f} (shape {result.shape}, "
        f"{result.n_candidates} candidates"
        + (f", keypoint error {result.keypoint_error:.1f} px" if kps is not None else "")
        + f") -> {out}"
        + (f", {overlay}" if overlay else "")
    )


def _shape_and_side(path, side, hand_length):
    """The `HandShape` of --shape (None without it) and the side: --hand's, else the
    shape's, else right; --hand and --hand-length checked against the shape."""
    if path is None:
        return None, side or "right"
    from handvar.pipeline import load_shape

    try:
        shape = load_shape(path)
    except ValueError as exc:
        raise ValueError(str(exc).replace("shape: ", "--shape: ", 1)) from None
    if side not in (None, "auto", shape.side):
        raise ValueError(f"--hand: expected {shape.side}, the side of --shape, or none; got {side}")
    if hand_length != 185.0:
        raise ValueError(f"--hand-length: expected none with --shape (the hand's length is the "
                         f"shape's); got {hand_length:g}")  # fmt: skip
    return shape, side or shape.side


def _explains_keypoints(result, kps) -> bool:
    """A pose fitted to the frame's keypoints whose mean error is within the lost rule's
    keypoint error (hand sizes of the detector's wrist → middle MCP): with keypoints the
    keypoints judge the first pose, as they judge every frame's fit
    (docs/keypoint-fit.md); a silhouette that takes in a sleeve or a background of skin
    colour does not reject it."""
    import numpy as np

    from handvar.tracking.tracker import QualitySettings

    if kps is None or result.shape != "keypoints" or not np.isfinite(result.keypoint_error):
        return False
    sizes = [np.linalg.norm(k[9, :2] - k[0, :2]) for k in kps if k is not None
             and k[0, 2] > 0 and k[9, 2] > 0]  # fmt: skip
    if not sizes:
        return False
    return result.keypoint_error / max(sizes) <= QualitySettings().lost_keypoint_error


def _frame_keypoints(files, opened, frame, scale, side):
    """Per-camera (21, 3) keypoints of frame `frame` in the pixels of the frames fitted
    (scaled by `scale` on recordings), and the side of the hand; the files checked
    against the opened SOURCES as `handvar track` checks them
    (`handvar.vision.keypoints.check_keypoints`: one per camera, the frame count, the
    pixels, `side` against their handedness or with "auto" taken from the hand's shape
    with two cameras, else from their handedness)."""
    from handvar.io import Sequence
    from handvar.vision.keypoints import check_keypoints, hand_side, read_keypoints

    if not files:
        return None, hand_side([], side)
    if isinstance(opened, Sequence):
        sizes, per, scale = [c.size for c in opened.rig.cameras], "camera of the sequence", 1.0
        short, cameras = None, opened.rig.cameras
    else:
        sizes, per = [reader.size for reader in opened.readers], "source"
        short = [reader.may_end_early for reader in opened.readers]
        cameras = opened.full_rig.cameras
    if len(files) != len(sizes):
        raise ValueError(
            f"--keypoints: expected one file per {per} ({len(sizes)}); got {len(files)}"
        )
    read, side, _ = check_keypoints([read_keypoints(p) for p in files], opened.n_frames,
                                    sizes, side, short, cameras)  # fmt: skip
    return [kp.scaled(scale).frame(frame) if scale != 1.0 else kp.frame(frame)
            for kp in read], side  # fmt: skip
