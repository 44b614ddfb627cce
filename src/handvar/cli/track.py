"""`handvar track`: the hand model fitted to every frame of a sequence or a recording."""

from __future__ import annotations

import click

from handvar.cli.common import _FiniteRange, _one_line_errors, _open_recordings, _recording_options
from handvar.cli.synth import check_in_front, load_pose
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
@click.option("--hand", "side", type=click.Choice(("right", "left")), default="right",
              show_default=True, help="Which hand is tracked (as for `init`).")  # fmt: skip
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

    import numpy as np
    from tqdm import tqdm

    from handvar.atomic import check_output_dir
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.io import read_sequence, resolve_sequence
    from handvar.synth.sequences import SEQUENCE_NAMES, make_sequence
    from handvar.tracking import CostSettings, Tracker, TrackerSettings
    from handvar.tracking.outputs import recording_backgrounds, write_track_outputs

    check_output_dir(out, "--out")  # before any work
    spec = resolve_sequence(seq, names=SEQUENCE_NAMES, argument="SEQ")
    source = None  # a real recording: its colour frames go under the overlays
    keypoints = _track_keypoints(keypoint_files, spec, keypoint_every)
    if carry not in (None, "none") and (keypoints is None or spec.kind != "recording"):
        got = "no --keypoints" if spec.kind == "recording" else f"the {spec.kind} sequence {seq!r}"
        raise ValueError(
            f"--carry: expected a recording (a video file or an image folder) with "
            f"--keypoints for {carry}; got {got}"
        )
    if carry is None:
        carry = "forward" if keypoints is not None and spec.kind == "recording" else "none"
    detected = keypoints
    import time

    t_read = time.perf_counter()  # the all-in time: silhouettes, carrying, fit, rules
    if recover is None:
        recover = spec.kind == "recording" or keypoints is not None
    if spec.kind == "recording":  # video files / image folders: see _recording_sequence
        # With keypoints and recovery the wrist is cut while tracking (at the detected
        # wrist, else at the tracked model's); otherwise here.
        source, sequence = _recording_sequence(
            spec.paths, calib, fov, scale, n_frames, allow_empty=recover,
            **({"wrist": False} if recover and keypoints is not None else {"keypoints": keypoints}),
        )  # fmt: skip
        if carry != "none":
            keypoints = source.carried_keypoints(keypoints, stop=n_frames, both=carry == "both")
        elif keypoints is not None:
            keypoints = source.scaled_keypoints(keypoints)
    elif calib is not None or fov is not None:
        raise ValueError("--calib, --fov: expected only with a video or an image folder")
    elif spec.kind == "directory":
        sequence = read_sequence(spec.paths[0], lazy=True)
    else:
        sequence = make_sequence(spec.name, n_frames=n_frames)
    if keypoints is not None and len(keypoints) != len(sequence.rig):
        raise ValueError(
            f"--keypoints: expected one file per camera ({len(sequence.rig)}); got {len(keypoints)}"
        )
    if init is not None:
        x0 = load_pose(init)
    elif sequence.truth is not None:
        x0 = sequence.truth.poses[0]
    elif recover:
        x0 = None  # searched in the first frame
    else:
        raise ValueError(
            f"{seq}: the sequence has no ground truth; give the first pose with --init"
        )
    if side == "left" and model == "mesh":
        raise ValueError(
            "--model: expected spheres for a left hand (the skinned mesh is a right hand); got mesh"
        )
    hand = HandModel(HandShape.from_size(hand_length, side=side), surface=model)
    if x0 is not None:
        check_in_front(hand.joints(x0), sequence.rig, "--init" if init is not None else seq)
    if keypoint_tips is None:  # a detector's keypoints on a recording, else G(x) projected
        keypoint_tips = "pad" if spec.kind == "recording" else "end"
    settings = TrackerSettings(cost=CostSettings(keypoint_tips=keypoint_tips))
    tracker = Tracker(
        sequence.rig, hand, make_predictor(predictor), np.random.default_rng(seed), settings
    )
    quality = None
    if recover:
        from handvar.tracking.recovery import track_with_recovery

        n = sequence.n_frames if n_frames is None else min(n_frames, sequence.n_frames)
        frames = tqdm(
            (np.asarray(sequence.masks[t]) for t in range(n)), total=n,
            desc=f"tracking {sequence.name}", unit="frame", leave=False,
        )  # fmt: skip
        recovered = track_with_recovery(
            tracker, frames, x0, keypoints=None if keypoints is None else _keypoints_at(keypoints),
            cut_wrist=source is not None and keypoints is not None,
        )  # fmt: skip
        result, quality = recovered.track, recovered.quality
    else:
        result = tracker.track(
            sequence, x0, frames=n_frames, keypoints=keypoints,
            progress=lambda it: tqdm(it, desc=f"tracking {sequence.name}", unit="frame",
                                     leave=False),
        )  # fmt: skip
    T = result.poses.shape[0]
    all_in = time.perf_counter() - t_read
    written = write_track_outputs(
        out, result, sequence, hand, predictor=predictor, seed=seed, video=video,
        backgrounds=None if source is None else recording_backgrounds(source), quality=quality,
    )  # fmt: skip
    if "video_error" in written:
        click.echo(f"handvar: note: no video ({written['video_error']})", err=True)

    fps = T / max(all_in, 1e-9)
    searches = ""
    if recover and len(recovered.init_seconds):
        n_search, s_search = len(recovered.init_seconds), float(recovered.init_seconds.sum())
        searches = (
            f", {n_search} re-initialisation{'s' * (n_search != 1)} in {s_search:.1f} s"
        )
    click.echo(
        f"{sequence.name}: {T} frames, predictor {predictor}, seed {seed}: "
        f"{result.iterations.mean():.1f} iterations/frame, {fps:.1f} frames/s all-in "
        f"(silhouettes, keypoints, fit and recovery){searches} -> {out}"
        + (f" (with {written['video'].name})" if "video" in written else "")
    )
    if quality is not None:
        with_kp = int(quality.keypoints.sum())
        text = f"fit quality: {quality.summary()}"
        if keypoints is not None:
            text += f"; keypoints on {with_kp} frames"
        if carry != "none":
            seen = np.zeros(T, dtype=bool)
            for k in detected:
                seen[: min(T, k.n_frames)] |= k.present[:T].any(axis=1)
            text += f" ({int(seen.sum())} with a detection, the others carried)"
        click.echo(text)
        if keypoints is not None:
            ok, worst, n_rejected = quality.check()
            click.echo(
                f"keypoint check: {'holds' if ok else 'FAILS'} (on every frame with "
                f"keypoints the joints lie within 0.2 hand sizes of at least 98 % of the "
                f"keypoints kept; worst frame {100 * worst:.1f} %); {n_rejected} "
                f"keypoints rejected as outliers"
            )
    if sequence.truth is not None:
        from handvar.evaluation.metrics import mean_joint_error

        err = mean_joint_error(sequence.truth.joints[:T], result.joints)
        click.echo(f"mean joint error: {err.mean():.2f} mm (max {err.max():.2f} mm)")


def _recording_sequence(paths, calib, fov, scale, n_frames, **kwargs):
    """`handvar track` on a recording: the source and its skin-colour silhouettes.

    `kwargs` go to `VideoSource.silhouettes` (keypoints, allow_empty).
    """
    from tqdm import tqdm

    source = _open_recordings(paths, calib, fov, scale)
    total = source.n_frames if n_frames is None else min(n_frames, source.n_frames)
    return source, source.to_sequence(
        stop=n_frames,
        progress=lambda it: tqdm(it, total=total, desc="silhouettes", unit="frame", leave=False),
        **kwargs,
    )


def _track_keypoints(files, spec, every):
    """`handvar track --keypoints`: per camera a `Keypoints2D` (every `every`-th frame)."""
    if not files:
        if every != 1:
            raise ValueError("--keypoint-every: expected only with --keypoints")
        return None
    from handvar.vision.keypoints import read_keypoints

    if spec.kind == "recording" and len(files) != len(spec.paths):
        raise ValueError(
            f"--keypoints: expected one file per recording ({len(spec.paths)}); got {len(files)}"
        )
    return [read_keypoints(path).every(every) for path in files]


def _keypoints_at(keypoints):
    """Frame i's keypoints of every camera, for `track_with_recovery`."""

    def at(i):
        return [None if k is None or i >= k.n_frames else k.frame(i) for k in keypoints]

    return at
