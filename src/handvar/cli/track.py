"""`handvar track`: the hand model fitted to every frame of a sequence or a recording."""

from __future__ import annotations

import contextlib

import click

from handvar.cli.common import _FiniteRange, _one_line_errors, _recording_options
from handvar.cli.synth import load_pose
from handvar.predictors.catalogue import CATALOGUE


def make_predictor(name: str):
    """The predictor called `name` on the command line, with the paper's settings.

    Any name the catalogue knows (`handvar.predictors.catalogue.make_predictor`).
    """
    from handvar.predictors.catalogue import make_predictor as build

    try:
        return build(name)
    except ValueError as exc:
        raise ValueError(f"--{exc}") from None


def _check_predictor(ctx, param, value: str) -> str:
    """Click callback: `value` must name a predictor of the catalogue."""
    try:
        make_predictor(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc).split(": ", 1)[1]) from None
    return value


@click.command("track")
@click.argument("seq")
@click.option(
    "--predictor", default="rvar", show_default=True, callback=_check_predictor,
    help="Motion predictor giving each frame's starting pose: "
    f"{', '.join(CATALOGUE)}, or a short name (decel, svar, ...).",
)  # fmt: skip
@click.option(
    "--init", "init", default=None,
    help="Pose of the first frame: a named pose or a file of 26 numbers "
    "[default: the sequence's true first pose].",
)  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the optimiser's random samples.")  # fmt: skip
@click.option("--frames", "n_frames", type=click.IntRange(min=1), default=None,
              help="Track only the first K frames.")  # fmt: skip
@click.option("--out", type=click.Path(file_okay=False), required=True,
              help="Output directory.")  # fmt: skip
@click.option("--video/--no-video", default=True, show_default=True,
              help="Also write overlay.mp4.")  # fmt: skip
@click.option("--hand-length", type=_FiniteRange(min=50.0, max=400.0), default=185.0,
              show_default=True, help="Hand length of the model, mm (as for `init`).")  # fmt: skip
@click.option("--hand", "side", type=click.Choice(("right", "left", "auto")),
              default="right", show_default=True,
              help="Which hand is tracked (as for `init`); auto: the side of the keypoints' "
                   "handedness (a .npz of `handvar keypoints`).")  # fmt: skip
@click.option("--model", type=click.Choice(("spheres", "mesh")), default="spheres",
              show_default=True, help="Surface of the tracked hand model.")  # fmt: skip
@click.option("--keypoints", "keypoint_files", multiple=True, type=click.Path(dir_okay=False),
              help="2D keypoints (.npy or .csv, see `handvar keypoints`), one file per "
              "camera in order, pixels of the full-resolution frames.")  # fmt: skip
@click.option("--keypoint-every", type=click.IntRange(min=1), default=1, show_default=True,
              help="Use the keypoints of every K-th frame only (a slower detector).")  # fmt: skip
@click.option("--carry", type=click.Choice(("forward", "both", "none")), default=None,
              help="Carry the detected keypoints by optical flow over the frames without "
              "any: from the last detection (online), also back from the next one (waits "
              "for it), or not [default: forward for recordings with --keypoints].")  # fmt: skip
@click.option("--keypoint-tips", type=click.Choice(("end", "pad")), default=None,
              help="Model point a detected fingertip is compared with: the end of the "
              "finger or the centre of its pad (where MediaPipe marks it; design §14.6) "
              "[default: pad for recordings, end for sequences].")  # fmt: skip
@click.option("--recover/--no-recover", default=None,
              help="Refine poor fits, detect lost frames and search the pose again there "
              "[default: on for recordings and with --keypoints].")  # fmt: skip
@_recording_options
@_one_line_errors
def track_command(
    seq, predictor, init, seed, n_frames, out, video, hand_length, side, model, keypoint_files,
    keypoint_every, carry, keypoint_tips, recover, calib, fov, scale,
) -> None:  # fmt: skip
    """Track the hand through the sequence SEQ (a sequence directory or a synthetic name).

    SEQ may also be a real recording: a video file or an image folder, or several
    separated by commas (one per camera of --calib); its skin-colour silhouettes are
    tracked from the pose given with --init (see `handvar init`), or else from the
    pose searched in its first frame.

    With --keypoints (one file per camera), every K-th frame's keypoints
    (--keypoint-every) place the wrist cut and pull the fit. On a recording the
    detected points are carried by optical flow over the frames between (--carry
    forward, or both ways), and the tracker and the motion predictor carry the rest.
    With recovery (--recover) each frame's fit is checked (silhouette IoU, distance to
    the keypoints), a poor fit is refined, and a lost frame is searched again (from its
    keypoints when it has them); the summary says how many.

    OUT receives poses.csv (T × 26, mm and degrees), joints.csv (T × 63, mm),
    track.npz (the track and its fit quality), overlay.png (a
    strip of frames: the observed masks with the fitted model's outline and joints)
    and, with --video, overlay.mp4 (numbered PNGs in overlay_frames/ when OpenCV has
    no mp4v codec); with recovery also quality.csv (per frame: IoU, keypoint error,
    final cost, lost, re-initialised, empty). Prints the mean joint error when the
    sequence has ground truth.
    """

    from handvar.atomic import check_output_dir
    from handvar.pipeline import track

    check_output_dir(out, "--out")  # before any work
    with _option_names(seq):
        result = track(
            seq, keypoints=list(keypoint_files) or None,
            calib=calib, fov=fov, scale=scale, hand=side, hand_length=hand_length, model=model,
            predictor=predictor, init=None if init is None else load_pose(init),
            keypoint_every=keypoint_every, carry=carry, keypoint_tips=keypoint_tips,
            recover=recover, seed=seed, frames=n_frames, progress=True,
        )  # fmt: skip
    written = result.save(out, video=video)
    if "video_error" in written:
        click.echo(f"handvar: note: no video ({written['video_error']})", err=True)
    if result.options.get("outside_keypoints"):
        click.echo(
            f"handvar: note: {result.options['outside_keypoints']} keypoints more than half "
            f"a frame outside the frames were left out",
            err=True,
        )

    T, fit = result.n_frames, result.result
    # all-in: reading the frames, silhouettes, keypoints, fit, recovery and searches
    fps = T / max(float(sum(result.stage_seconds.values())), 1e-9)
    searches = ""
    if len(result.search_seconds):
        n_search, s_search = len(result.search_seconds), float(result.search_seconds.sum())
        searches = f", {n_search} re-initialisation{'s' * (n_search != 1)} in {s_search:.1f} s"
    click.echo(
        f"{result.name}: {T} frames, predictor {predictor}, seed {seed}: "
        f"{fit.iterations.mean():.1f} iterations/frame, {fps:.1f} frames/s all-in{searches} "
        f"-> {out}" + (f" (with {written['video'].name})" if "video" in written else "")
    )
    if result.quality is not None:
        text = f"fit quality: {result.quality.summary()}"
        if result.detections is not None:
            text += f"; keypoints on {int(result.quality.keypoints.sum())} frames"
        if result.options["carry"] != "none":
            text += f" ({int(result.detections.sum())} with a detection, the others carried)"
        click.echo(text)
        if result.detections is not None:
            ok, worst, n_rejected = result.quality.check(frames=result.detections)
            click.echo(
                f"keypoint check: {'holds' if ok else 'FAILS'} (on every frame with a "
                f"detection the joints lie within 0.2 hand sizes of at least 98 % of the "
                f"keypoints kept; worst frame {100 * worst:.1f} %); {n_rejected} "
                f"keypoints rejected as outliers"
            )
    truth = result.sequence.truth
    if truth is not None:
        from handvar.evaluation.metrics import mean_joint_error

        err = mean_joint_error(truth.joints[:T], result.joints)
        click.echo(f"mean joint error: {err.mean():.2f} mm (max {err.max():.2f} mm)")


#: `handvar.track`'s keyword arguments as `handvar track` names them in its messages (those
#: that the options' own checks leave to `handvar.track`).
OPTION_NAMES = {
    "source": "SEQ", "keypoints": "--keypoints", "keypoint_every": "--keypoint-every",
    "carry": "--carry", "calib": "--calib", "fov": "--fov", "model": "--model",
    "init": "--init", "hand": "--hand",
}  # fmt: skip


@contextlib.contextmanager
def _option_names(seq: str):
    """Errors of `handvar.track` name the command's options instead of its keywords.

    In a message about the keywords (``keypoint_every: expected only with keypoints``)
    or about SEQ, every keyword standing as a word of its own is replaced; other
    messages (a file's) are left as they are.
    """
    import re

    word = re.compile(r"(?<![\w/.\-])(" + "|".join(OPTION_NAMES) + r")(?![\w/.\-])")
    try:
        yield
    except ValueError as exc:
        message = str(exc)
        prefix = message.partition(": ")[0]
        if prefix == seq or all(name in OPTION_NAMES for name in prefix.split(", ")):
            message = word.sub(lambda m: OPTION_NAMES[m.group(1)], message)
        raise ValueError(message) from None
