"""`handvar track`: the hand model fitted to every frame of a sequence or a recording."""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import click

from handvar.cli.common import _FiniteRange, _locks_out, _one_line_errors, _recording_options
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
@click.argument("seq", nargs=-1)
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
@click.option("--shape", type=click.Path(), default=None,
              help="The hand's proportions from an earlier track (its OUT directory or "
              "track.npz: the person's hand, fitted to its keypoints), held for this "
              "track instead of the default hand of --hand-length; its side is the hand "
              "tracked.")  # fmt: skip
@click.option("--hand", "side", type=click.Choice(("right", "left", "auto")), default=None,
              help="Which hand is tracked (as for `init`); auto: with two cameras the side "
                   "of the hand's 3D shape, else of the detector's handedness or of a .npz "
                   "of `handvar keypoints` [default: auto with the detector or such a .npz, "
                   "else right].")  # fmt: skip
@click.option("--detector", type=click.Choice(("auto", "mediapipe", "none")), default="auto",
              show_default=True,
              help="The keypoint detector run inside the pipeline on a recording or a "
                   "camera given without --keypoints; auto: MediaPipe Hands when installed "
                   "(pip install 'handvar[mediapipe]'), else none (skin-colour silhouettes "
                   "alone, for plain backgrounds). Its points are kept in OUT/keypoints.npz "
                   "and reused by a rerun into OUT.")  # fmt: skip
@click.option("--hands", type=click.IntRange(min=1, max=2), default=1, show_default=True,
              help="Hands tracked: 2 tracks both, each under an identity kept by tracking "
                   "(OUT/left/, OUT/right/, OUT/hands.json; a recording, also --realtime, "
                   "or --camera, with the detector inside).")  # fmt: skip
@click.option("--model", type=click.Choice(("spheres", "mesh")), default="spheres",
              show_default=True, help="Surface of the tracked hand model.")  # fmt: skip
@click.option("--keypoints", "keypoint_files", multiple=True, type=click.Path(dir_okay=False),
              help="2D keypoints (.npz, .npy or .csv, see `handvar keypoints`), one file "
              "per camera in order, pixels of the full-resolution frames; with --hands 2 "
              "every hand found, a .json (handvar keypoints --hands 2).")  # fmt: skip
@click.option("--keypoint-every", type=click.IntRange(min=1), default=1, show_default=True,
              help="Run the detector (or use the keypoints) on every K-th frame only.")  # fmt: skip
@click.option("--carry", type=click.Choice(("forward", "both", "none")), default=None,
              help="Carry the detected keypoints by optical flow over the frames without "
              "any: from the last detection (online), also back from the next one (waits "
              "for it, at most 30 frames), or not [default: both for recordings with "
              "--keypoints, forward with --realtime or --camera].")  # fmt: skip
@click.option("--keypoint-tips", type=click.Choice(("end", "pad")), default=None,
              help="Model point a detected fingertip is compared with: the end of the "
              "finger or the centre of its pad (where MediaPipe marks it; design §14.6) "
              "[default: pad for recordings, end for sequences].")  # fmt: skip
@click.option("--silhouette-term", type=_FiniteRange(min=0.0), default=0.0, show_default=True,
              help="σ of the silhouette as a secondary cue in the keypoint fit, hand sizes "
              "(docs/keypoint-fit.md); 0: off. Needs recovery.")  # fmt: skip
@click.option("--recover/--no-recover", default=None,
              help="Refine poor fits, detect lost frames and search the pose again there "
              "[default: on for recordings and with --keypoints].")  # fmt: skip
@click.option("--camera", type=click.IntRange(min=0), default=None,
              help="Track a live camera (OpenCV's index N) instead of SEQ, the newest "
              "frame each time the tracker is free, until --frames or Ctrl-C.")  # fmt: skip
@click.option("--realtime", is_flag=True,
              help="Play the recording at its own frame rate, skipping the frames the "
              "tracker has no time for; report the latency and the frames dropped.")  # fmt: skip
@click.option("--show", is_flag=True,
              help="With --camera or --realtime: show the model over the silhouettes in a "
              "window while tracking (needs a display and OpenCV with a GUI).")  # fmt: skip
@click.option("--scheduler", default=None,
              help="Several SEQ: address of an existing Dask scheduler [default: an "
              "embedded cluster].")  # fmt: skip
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Several SEQ: worker processes of the embedded cluster [default: one "
              "per core].")  # fmt: skip
@_recording_options
@_one_line_errors
@_locks_out
def track_command(
    seq, predictor, init, seed, n_frames, out, video, hand_length, shape, side, detector, hands,
    model, keypoint_files, keypoint_every, carry, keypoint_tips, silhouette_term, recover, camera,
    realtime, show, scheduler, workers, calib, fov, scale,
) -> None:  # fmt: skip
    """Track the hand through the sequence SEQ (a sequence directory or a synthetic name).

    SEQ may also be a real recording: a video file or an image folder, or several
    separated by commas (one per camera of --calib); its skin-colour silhouettes are
    tracked from the pose given with --init (see `handvar init`), or else from the
    pose searched in its first frame.

    With --keypoints (one file per camera), every K-th frame's keypoints
    (--keypoint-every) place the wrist cut and pull the fit. On a recording the
    detected points are carried by optical flow over the frames between (both ways
    by default, --carry forward online), and the tracker and the motion predictor carry
    the rest.
    With recovery (--recover) each frame's fit is checked (silhouette IoU, distance to
    the keypoints), a poor fit is refined, and a lost frame is searched again (from its
    keypoints when it has them); the summary says how many.

    OUT receives poses.csv (T × 26, mm and degrees), joints.csv (T × 63, mm),
    cameras.yml (the cameras, as --calib reads them), track.npz (the track, its fit
    quality, hand shape, frame rate and name: what `handvar export` and `handvar
    view` read), overlay.png (a
    strip of frames: the observed masks with the fitted model's outline and joints)
    and, with --video, overlay.mp4 (numbered PNGs in overlay_frames/ when OpenCV has
    no mp4v codec); with recovery also quality.csv (per frame: IoU, keypoint error,
    final cost, lost, re-initialised, empty, keypoints, no hand, keypoints rejected).
    Prints the mean joint error when the
    sequence has ground truth. The files of an earlier track in OUT that this run does
    not write go; other files stay. One run at a time writes OUT.

    Live and real time: --camera N tracks a webcam; --realtime plays a recording at its
    frame rate. Each frame is tracked as it comes; the frames that arrive while the
    tracker is busy are dropped (marked in track.npz, holding the last pose), and a
    line gives the frames dropped and the latency from capture to pose.

    Several SEQ (each a recording, or a comma-separated rig): one task per recording
    on a Dask cluster, each written to OUT/<file stem>/ whole or not at all; the
    recordings already in OUT are skipped, so a run stopped half-way is resumed by
    running it again. --keypoints then gives one file per recording, in order. A
    recording that fails gets its one-line error and the others go on; the exit
    status is 2 when any failed.
    """

    from handvar.atomic import check_output_dir

    check_output_dir(out, "--out")  # before any work
    recovery = None  # handvar.track refuses one without recovery, naming the option
    if silhouette_term > 0:
        from handvar.tracking.recovery import RECOVERY_DEFAULTS

        recovery = RECOVERY_DEFAULTS.with_silhouette_term(silhouette_term)
    allow_short = click.get_current_context().meta.get("handvar.allow_short", False)
    _check_sources(seq, camera, realtime, show, scheduler, workers)
    if hands == 2:
        one_hands = {"--keypoint-tips": keypoint_tips is not None, "--shape": shape is not None,
                     "--recover" if recover else "--no-recover": recover is not None}  # fmt: skip
        _track_hands(seq, out, video, keypoint_files=keypoint_files, camera=camera,
                     realtime=realtime, show=show, side=side, init=init,
                     keypoint_every=keypoint_every, one_hands=one_hands,
                     carry=carry, predictor=predictor, seed=seed, frames=n_frames,
                     hand_length=hand_length, model=model, detector=detector, calib=calib,
                     fov=fov, scale=scale, allow_short=allow_short,
                     recovery=recovery)  # fmt: skip
        return
    if len(seq) > 1:
        _track_batch(
            seq, out, keypoint_files, video, scheduler, workers, calib=calib, fov=fov,
            scale=scale, hand=side, hand_length=hand_length, model=model,
            predictor=predictor, init=None if init is None else load_pose(init),
            keypoint_every=keypoint_every, carry=carry, keypoint_tips=keypoint_tips,
            recover=recover, recovery=recovery, seed=seed, frames=n_frames, allow_short=allow_short,
            detector=detector, shape=shape,
        )  # fmt: skip
        return
    source, options = (seq[0] if seq else None), {"calib": calib, "fov": fov, "scale": scale}
    if camera is not None:
        if keypoint_files:
            raise ValueError("--keypoints: expected none with --camera")
        source, options = _open_camera(camera, calib, fov, scale), {}
    reused, keypoints = (), list(keypoint_files) or None
    if camera is None and not keypoint_files and detector != "none":
        reused, keypoints, side = _detected_before(out, seq[0], side)
    with _option_names(seq[0] if seq else "--camera"), _stop_on_interrupt(source):
        result = _track_one(
            source, keypoints=keypoints, hand=side, hand_length=hand_length,
            model=model, predictor=predictor, init=None if init is None else load_pose(init),
            keypoint_every=keypoint_every, carry=carry, keypoint_tips=keypoint_tips,
            recover=recover, seed=seed, frames=n_frames, progress=not show,
            realtime=realtime and camera is None, show=show, allow_short=allow_short,
            recovery=recovery, detector=detector if keypoints is None else "auto", shape=shape,
            **options,
        )  # fmt: skip
    written = _save_track(result, out, video, reused)
    _print_summary(result, written, out, predictor, seed)


def _track_hands(seq, out, video: bool, *, keypoint_files, camera, realtime, show, side, init,
                 keypoint_every, carry, detector, one_hands, **options) -> None:  # fmt: skip
    """--hands 2: both hands of one recording (`handvar.pipeline.track_hands`);
    `one_hands`: more of one hand's options, by whether each was given."""
    from handvar.cli.common import STARTED
    from handvar.pipeline import track

    alone = {"--show": show, "--hand": side is not None, "--init": init is not None,
             "--carry": carry is not None, **one_hands, "SEQ": len(seq) > 1}  # fmt: skip
    given = [name for name, on in alone.items() if on]
    if given:
        raise ValueError(f"{', '.join(given)}: expected none with --hands 2 (one recording "
                         f"or --camera; one hand's options); got {', '.join(given)}")  # fmt: skip
    if detector == "none" and not keypoint_files:
        raise ValueError("--detector: expected auto or mediapipe with --hands 2; got none")
    source = seq[0] if seq else None
    if camera is not None:
        source = _open_camera(camera, options.pop("calib"), options.pop("fov"),
                              options.pop("scale"))  # fmt: skip
    with _option_names(seq[0] if seq else "--camera"), _stop_on_interrupt(source):
        result = track(source, hands=2, progress=camera is None and not realtime,
                       detector=detector, keypoint_every=keypoint_every,
                       realtime=realtime and camera is None,
                       keypoints=list(keypoint_files) or None, **options)  # fmt: skip
    written = result.save(out, video=video)
    outside = max((t.options.get("outside_keypoints", 0) for t in result.tracks.values()),
                  default=0)  # fmt: skip
    if outside:
        click.echo(f"handvar: note: {outside} keypoints more than half a frame outside the "
                   f"frames were left out", err=True)  # fmt: skip
    fps = result.n_frames / max(time.perf_counter() - STARTED, 1e-9)
    video_note = " (with overlay.mp4)" if "video" in written else ""
    click.echo(f"{result.name}: {result.n_frames} frames, both hands, {fps:.1f} frames/s "
               f"all-in -> {out}{video_note}")  # fmt: skip
    timed = next((t for t in result.tracks.values() if t.latency is not None), None)
    if timed is not None:
        click.echo(timed.realtime_summary())
    for k, t in sorted(result.tracks.items()):
        q = t.quality
        seen = int((~q.no_hand).sum())
        fitted = int(q.keypoints.sum())
        failing = q.failing(frames=q.keypoints)
        click.echo(f"hand {k} ({t.shape.side}): on {seen} frames, {int(q.empty.sum())} of them "
                   f"carried by the prediction; {int(q.lost.sum())} lost; the joints within "
                   f"0.2 hand sizes of ≥ 98 % of the keypoints on {fitted - failing} of the "
                   f"{fitted} frames fitted to them")  # fmt: skip
    if not result.tracks:
        click.echo("no hand found in any frame", err=True)


def _check_sources(seq, camera, realtime: bool, show: bool, scheduler, workers) -> None:
    """SEQ or --camera, and the options that need one recording, a camera or a batch."""
    if camera is not None and seq:
        raise ValueError(f"--camera: expected no SEQ with a camera; got {' '.join(seq)}")
    if camera is None and not seq:
        raise ValueError("SEQ: expected a sequence or a recording (or --camera N); got none")
    if len(seq) > 1:
        for name, given in (("--realtime", realtime), ("--show", show)):
            if given:
                raise ValueError(f"{name}: expected one recording; got {len(seq)}")
        return
    if scheduler is not None or workers is not None:
        raise ValueError("--scheduler, --workers: expected several SEQ (a batch); got one")
    if show and not (realtime or camera is not None):
        raise ValueError("--show: expected --camera or --realtime")
    if show:
        _check_display()


def _save_track(result, out, video: bool, reused) -> dict:
    """The track written into OUT with the detector's points (`_save_detected`); the
    notes on standard error.  `reused`: the keypoint files of an earlier run used."""
    if result.options.get("notice"):
        click.echo(f"handvar: note: {result.options['notice']}", err=True)
    if reused:  # the detector's points of an earlier run: its name kept for the next
        result.options["detector"] = "reused from " + ", ".join(Path(f).name for f in reused)
    written = result.save(out, video=video)
    if result.detected is not None:
        _save_detected(out, result)
    if "video_error" in written:
        click.echo(f"handvar: note: no video ({written['video_error']})", err=True)
    if result.options.get("outside_keypoints"):
        click.echo(
            f"handvar: note: {result.options['outside_keypoints']} keypoints more than half "
            f"a frame outside the frames were left out",
            err=True,
        )
    return written


def _print_summary(result, written: dict, out, predictor: str, seed: int) -> None:
    """The lines `handvar track` prints of a track: what ran and the all-in rate, the fit
    quality (`_print_quality`), the mean joint error against the ground truth, the
    real-time line."""
    from handvar.cli.common import STARTED

    T = result.n_frames
    tracked = T if result.dropped is None else int(T - result.dropped.sum())
    # all-in: the whole command, from its start to the files written
    fps = tracked / max(time.perf_counter() - STARTED, 1e-9)
    searches = ""
    if len(result.search_seconds):
        n_search, s_search = len(result.search_seconds), float(result.search_seconds.sum())
        searches = f", {n_search} re-initialisation{'s' * (n_search != 1)} in {s_search:.1f} s"
    click.echo(
        f"{result.name}: {T} frames, predictor {predictor}, seed {seed}: {_lanes(result)}, "
        f"{fps:.1f} frames/s all-in{searches} "
        f"-> {out}" + (f" (with {written['video'].name})" if "video" in written else "")
    )
    if result.quality is not None:
        _print_quality(result)
    truth = result.sequence.truth
    if truth is not None:
        from handvar.evaluation.metrics import mean_joint_error

        err = mean_joint_error(truth.joints[:T], result.joints)
        click.echo(f"mean joint error: {err.mean():.2f} mm (max {err.max():.2f} mm)")
    if result.latency is not None:
        click.echo(result.realtime_summary())


def _print_quality(result) -> None:
    """The fit quality of a track with recovery, the frames with keypoints (detected or
    carried) and, with keypoints, the keypoint check."""
    text = f"fit quality: {result.quality.summary()}"
    if result.detections is not None:
        with_kp = int(result.quality.keypoints.sum())
        text += f"; keypoints on {with_kp} frames"
    if result.options["carry"] != "none":
        seen = (
            result.detections if result.dropped is None else (result.detections & ~result.dropped)
        )  # the frames tracked
        if int(seen.sum()) < with_kp:
            text += f" ({int(seen.sum())} with a detection, the others carried)"
    click.echo(text)
    if result.detections is not None:
        ok, worst, n_rejected = result.quality.check(frames=result.detections)
        verdict = "holds"
        if not ok:
            failing = result.quality.failing(frames=result.detections)
            verdict = f"FAILS on {failing} of {int(result.detections.sum())} frames"
        click.echo(
            f"keypoint check: {verdict} (on every frame with a detection the joints lie "
            f"within 0.2 hand sizes of at least 98 % of the keypoints kept; worst frame "
            f"{100 * worst:.1f} %); {n_rejected} keypoints rejected as outliers"
        )


def _lanes(result) -> str:
    """What ran, per frame: the frames fitted to keypoints, to silhouettes, without a hand."""
    q, fit = result.quality, result.result
    if q is None:
        return f"{fit.iterations.sum() / max(result.n_frames, 1):.1f} iterations/frame"
    keypoints = int(q.keypoints.sum())
    no_hand = int(q.no_hand.sum())
    dropped = 0 if result.dropped is None else int(result.dropped.sum())
    silhouettes = result.n_frames - keypoints - no_hand - dropped
    parts = [f"{keypoints} fitted to keypoints"]
    if silhouettes:
        sil = ~q.keypoints & ~q.no_hand
        rate = fit.iterations[sil].sum() / silhouettes
        parts.append(f"{silhouettes} to silhouettes ({rate:.1f} iterations/frame)")
    parts.append(f"{no_hand} without a hand")
    detector = result.options.get("detector", "none")
    return ", ".join(parts) + (f" (detector {detector})" if detector != "none" else "")


def _keypoint_files(out, n_cameras: int) -> list:
    """Where `handvar track` keeps what the detector found, one file per camera (in the
    order of SEQ)."""
    from pathlib import Path

    if n_cameras == 1:
        return [Path(out) / "keypoints.npz"]
    return [Path(out) / f"keypoints-{j}.npz" for j in range(n_cameras)]


def _save_detected(out, result) -> None:
    """OUT/keypoints.npz (keypoints-<j>.npz with several cameras): the detector's points,
    world landmarks and handedness, as `handvar keypoints` writes them."""
    from handvar.vision.keypoints import write_keypoints

    for path, k in zip(_keypoint_files(out, len(result.detected)), result.detected,
                       strict=True):  # fmt: skip
        write_keypoints(path, k)


def _detected_before(out, seq: str, side: str | None) -> tuple[tuple, list | None, str | None]:
    """The keypoint files an earlier run into OUT detected on the same whole recording,
    to use again (a rerun with other settings), their keypoints, and the side to track,
    the earlier run's: the side it decided, not the detector's handedness in the files
    (which may differ between cameras, or from that side).  The files hold the hands
    chosen for that side, so a rerun for the other side (--hand) detects again.
    Without such files ``((), None, side)``."""
    import dataclasses
    import json
    from pathlib import Path

    import numpy as np

    from handvar.vision.keypoints import read_keypoints

    track_file = Path(out) / "track.npz"
    if not track_file.is_file():
        return (), None, side
    try:
        with np.load(track_file, allow_pickle=False) as z:
            options = json.loads(str(z["meta"])).get("options", {})
    except (OSError, ValueError, KeyError, EOFError):
        return (), None, side
    paths = seq.split(",")
    same = options.get("source") == paths and options.get("detector") not in (None, "none")
    whole = options.get("frames") is None
    files = _keypoint_files(out, len(paths))
    earlier = options.get("hand")
    if not (same and whole and earlier in ("right", "left") and side in (None, "auto", earlier)
            and all(f.is_file() for f in files)):  # fmt: skip
        return (), None, side
    keypoints = [dataclasses.replace(read_keypoints(f), handedness=None) for f in files]
    return tuple(str(f) for f in files), keypoints, earlier


def _open_camera(index: int, calib, fov, scale):
    """`open_camera`, its errors naming --camera."""
    from handvar.vision.sources import open_camera

    try:
        return open_camera(index, calib, fov=fov, scale=scale)
    except ValueError as exc:
        message = str(exc)
        if message.startswith("camera: "):
            message = "--" + message
        raise ValueError(message) from None


def _check_display() -> None:
    """--show needs a display and an OpenCV built with a GUI (not the headless wheel)."""
    import os
    import re
    import sys

    import cv2

    gui = re.search(r"GUI:\s*(\S+)", cv2.getBuildInformation())
    if gui is None or gui.group(1).upper() == "NONE":
        raise ValueError(
            "--show: expected OpenCV with a GUI (opencv-python); got one without "
            "(opencv-python-headless)"
        )
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise ValueError("--show: expected a display; DISPLAY and WAYLAND_DISPLAY are not set")


def _track_one(source, *, show: bool, **options):
    """`handvar.track`, with a window showing each frame's fit when `show`."""
    from handvar.pipeline import track

    if not show:
        return track(source, **options)
    import cv2

    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.render import overlay_views, side_by_side

    # the points the track reports: on a recording where a detector marks them (design §14.6)
    tips = options.get("keypoint_tips") or "pad"
    # before the first hand (no pose to draw): a hand of the given length and side
    given = HandShape.from_size(
        options["hand_length"], side="left" if options.get("hand") == "left" else "right"
    )
    drawn = {}  # the rig, and the model drawn for the tracked hand's shape

    def model(tracked):
        """The model drawn: the tracked hand's shape (as fitted so far, its side as
        decided) with the reported points."""
        shape = given if tracked is None else tracked.shape
        if drawn.get("shape") is not shape:
            drawn["shape"] = shape
            drawn["hand"] = HandModel(shape, surface=options["model"], tips=tips)
        return drawn["hand"]

    def draw(i, pose, quality, masks, images=None, hand=None):
        if "rig" not in drawn:  # the tracked frames' cameras: the camera's, or the recording's
            drawn["rig"] = _tracked_rig(source, options, masks)
        # the model and its skeleton over the camera's image (over the silhouettes for a
        # frame read ahead without it); a frame without a hand shows the image alone
        backgrounds = masks if images is None else [
            cv2.cvtColor(im, cv2.COLOR_BGR2RGB) for im in images]  # fmt: skip
        views = overlay_views(model(hand), drawn["rig"], backgrounds, pose)
        image = side_by_side(views, [f"frame {i}"] * len(views))
        cv2.imshow("handvar", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        if cv2.waitKey(1) & 0xFF == ord("q") and hasattr(source, "stop"):
            source.stop()

    try:
        return track(source, on_frame=draw, **options)
    finally:
        cv2.destroyAllWindows()


def _tracked_rig(source, options, masks):
    """The rig of the frames being tracked (for --show)."""
    if hasattr(source, "rig"):
        return source.rig
    from handvar.vision.sources import open_source

    paths = source.split(",")
    return open_source(paths, options.get("calib"), fov=options.get("fov"),
                       scale=options.get("scale", 1.0)).rig  # fmt: skip


@contextlib.contextmanager
def _stop_on_interrupt(source):
    """On a live camera the first Ctrl-C ends the tracking (the frames so far are kept)."""
    import signal

    if not hasattr(source, "stop"):
        yield
        return
    previous = signal.signal(signal.SIGINT, lambda *_: source.stop())
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        source.close()


def _track_batch(seq, out, keypoint_files, video, scheduler, workers, **options) -> None:
    """Several SEQ: `handvar.batch.track_many`, a line per recording, exit 2 on failures."""
    import sys

    from handvar.batch import track_many

    if keypoint_files and len(keypoint_files) != len(seq):
        raise ValueError(
            f"--keypoints: expected one file per recording ({len(seq)}), in order; "
            f"got {len(keypoint_files)}"
        )

    def done(name: str, error: str | None, line: str) -> None:
        if error is None:
            click.echo(f"{name}: {line}")
            return
        recording, _, message = error.partition(": ")  # `track_many` names the recording
        click.echo(f"handvar: error: {recording}: {_cli_message(message, None)}", err=True)

    with _option_names(",".join(seq)):
        summary = track_many(
            list(seq), out, keypoints=list(keypoint_files) or None, video=video,
            scheduler=scheduler, workers=workers, progress=True, on_done=done, **options,
        )  # fmt: skip
    click.echo(summary.text())
    if summary.failed:
        n = len(summary.failed)
        click.echo(
            f"handvar: error: {n} of {len(summary.names)} recordings failed",
            err=True,
        )
        sys.exit(2)


#: `handvar.track`'s keyword arguments as `handvar track` names them in its messages (those
#: that the options' own checks leave to `handvar.track`), where a keyword names the
#: argument at fault: before the message's first colon.
OPTION_NAMES = {
    "source": "SEQ", "keypoints": "--keypoints", "keypoint_every": "--keypoint-every",
    "carry": "--carry", "calib": "--calib", "fov": "--fov", "model": "--model",
    "init": "--init", "realtime": "--realtime", "recordings": "SEQ", "out": "--out",
    "hand": "--hand", "recovery": "--silhouette-term", "recover": "--recover",
    "on_frame": "--show", "detector": "--detector", "shape": "--shape",
    "hand_length": "--hand-length",
}  # fmt: skip
#: The keywords renamed in the rest of such a message too: those that are no plain words
#: there ("hand", "model", "source", "recordings" and "out" are: "a hand in some frame"),
#: and "recovery", which there means the recovery itself, switched by --recover (its
#: settings, before the colon, are --silhouette-term's).
TEXT_NAMES = {
    **{name: OPTION_NAMES[name] for name in (
        "keypoints", "keypoint_every", "carry", "calib", "fov", "init", "realtime", "recover",
        "on_frame",
    )},
    "recovery": "--recover",
}  # fmt: skip


@contextlib.contextmanager
def _option_names(seq: str | None):
    """Errors of `handvar.track` name the command's options instead of its keywords.

    In a message about the keywords (``keypoint_every: expected only with keypoints``)
    or about SEQ, the keywords are replaced (`_cli_message`); other messages (a file's)
    are left as they are.
    """
    try:
        yield
    except ValueError as exc:
        raise ValueError(_cli_message(str(exc), seq)) from None


def _cli_message(message: str, seq: str | None) -> str:
    """`message` with `handvar.track`'s keywords named as the options (`_option_names`).

    The keywords before the first colon by `OPTION_NAMES`; after it, a keyword standing
    as a word of its own by `TEXT_NAMES` (never the command ``handvar keypoints``), and
    a setting ``recover=False``, ``carry=both`` as the option given (``--no-recover``,
    ``--carry both``).
    """
    import re

    prefix, colon, text = message.partition(": ")
    names = prefix.split(", ")
    if prefix != seq and not all(name in OPTION_NAMES for name in names):
        return message
    if prefix != seq:
        prefix = ", ".join(OPTION_NAMES[name] for name in names)
    keyword = "|".join(TEXT_NAMES)

    def setting(m: re.Match) -> str:
        option, value = TEXT_NAMES[m.group(1)], m.group(2)
        if value in ("True", "False"):  # a flag: --recover / --no-recover
            return option if value == "True" else "--no-" + option.removeprefix("--")
        return f"{option} {value}"

    text = re.sub(rf"(?<![\w/.\-])({keyword})=(\w+)", setting, text)
    text = re.sub(rf"(?<![\w/.\-])(?<!handvar )({keyword})(?![\w/.\-])",
                  lambda m: TEXT_NAMES[m.group(1)], text)  # fmt: skip
    return prefix + colon + text
