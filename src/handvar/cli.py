"""The `handvar` command.

Every command turns a wrong input (a ``ValueError``, a ``TypeError``, an unreadable
file, a bad option) into one line on standard error naming the argument or the user's
path and exit status 2, never a traceback; its outputs are checked before any work and
written all-or-nothing (design §13).

One concept, the command line: each command is a thin section calling the library,
which is why the module is about 900 lines.
"""

from __future__ import annotations

import functools
import sys

import click

from handvar.predictors.catalogue import CATALOGUE


def _one_line_errors(func):
    """Report ValueError / TypeError / OSError as one line and exit with status 2.

    The line names the user's paths, never a temporary of `handvar.atomic` (§13.4).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from handvar.atomic import user_paths

        try:
            return func(*args, **kwargs)
        except (ValueError, TypeError, OSError) as exc:
            msg = user_paths(" ".join(str(exc).split()))
            if isinstance(exc, OSError) and exc.filename is not None and not msg:
                msg = f"{exc.filename}: cannot be written"
            click.echo(f"handvar: error: {msg}", err=True)
            sys.exit(2)

    return wrapper


class _FiniteRange(click.FloatRange):
    """A float option within a range; NaN and infinities are refused (they pass
    click's comparisons)."""

    def convert(self, value, param, ctx):
        import math

        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return rv


class _OneLineGroup(click.Group):
    """A command group whose usage errors (bad options, values) are one line too (§13.4)."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            return super().main(args, prog_name, complete_var, False, **extra)
        except click.ClickException as exc:
            msg = " ".join(exc.format_message().split())
            click.echo(f"handvar: error: {msg}", err=True)
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo("handvar: aborted", err=True)
            sys.exit(1)


@click.group(cls=_OneLineGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="handvar")
def main() -> None:
    """Model-based 3D hand tracking with online, adaptive VAR motion prediction."""
    _quiet_native_logs()


def _quiet_native_logs() -> None:
    """Silence OpenCV's and its FFmpeg backend's logging on standard error (§13.4).

    A damaged video makes FFmpeg print lines such as ``moov atom not found`` before our
    own one-line message; the failure is reported by us instead.  Set before OpenCV
    loads its FFmpeg backend; a value the user set in the environment is kept.
    """
    import os

    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")


# --- commands ---------------------------------------------------------------------
# Each command lives in its own section below; keep them independent.


# --- synth: render a synthetic sequence with ground truth ------------------------------


@main.command("synth")
@click.argument("name")
@click.argument("out", type=click.Path())
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Seed of the motion (and of the colour frames).",
)
@click.option("--model", type=click.Choice(("spheres", "mesh")), default="spheres",
              show_default=True, help="Hand surface: sphere-mesh or skinned mesh.")  # fmt: skip
@click.option("--rgb", is_flag=True, help="Also render shaded colour frames.")
@click.option(
    "--frames",
    "n_frames",
    type=click.IntRange(min=1),
    default=None,
    help="Keep only the first N frames (a quick preview).",
)
@click.option("--size", nargs=2, type=float, default=(1.0, 1.0), show_default=True,
              metavar="LENGTH BREADTH",
              help="Hand length and breadth as factors of the default 185 mm hand.")  # fmt: skip
@click.option("--speed", type=click.FloatRange(min=1.0), default=1.0, show_default=True,
              help="Replay the motion this many times faster (fewer frames).")  # fmt: skip
@click.option("--noise", type=click.FloatRange(min=0.0, max=50.0), default=0.0,
              show_default=True, help="Segmentation errors, px.")  # fmt: skip
@_one_line_errors
def synth_command(
    name: str,
    out: str,
    model: str,
    seed: int,
    rgb: bool,
    n_frames: int | None,
    size: tuple[float, float] = (1.0, 1.0),
    speed: float = 1.0,
    noise: float = 0.0,
) -> None:
    """Render the synthetic sequence NAME (benchmark, flexion, flip) into directory OUT.

    OUT receives sequence.json, per-camera PNG masks (and colour frames with --rgb)
    and truth.npz; an existing sequence there is replaced only once the new one is
    complete.
    """
    from tqdm import tqdm

    from handvar.io import check_output_dir, write_sequence
    from handvar.synth.mismatch import generator_hand
    from handvar.synth.sequences import make_sequence

    check_output_dir(out, argument="OUT")  # fail before rendering, not after
    seq = make_sequence(
        name,
        seed=seed,
        rgb=rgb,
        n_frames=n_frames,
        hand=generator_hand(model, *size),
        speed=speed,
        silhouette_noise=noise,
        progress=lambda it: tqdm(it, desc=f"rendering {name}", unit="frame", leave=False),
    )
    path = write_sequence(
        seq, out, progress=lambda it: tqdm(it, desc="writing", unit="frame", leave=False)
    )
    w, h = seq.image_size
    click.echo(
        f"{seq.name}: {seq.n_frames} frames, {seq.n_cameras} cameras {w}x{h}, "
        f"{seq.fps:g} fps -> {path}"
    )


# --- show: draw a pose in the default stereo rig -----------------------------------------


def load_pose(spec: str):
    """A (26,) pose from a named pose (``open``, ``fist``, ...) or a pose file.

    A pose file holds the 26 parameters (mm, degrees): a text file of 26 numbers
    (whitespace or comma separated) or a ``.npy`` array.
    """
    import os

    import numpy as np

    from handvar.hand.kinematics import POSE_NAMES, named_pose
    from handvar.params import check_pose

    if spec in POSE_NAMES:
        return named_pose(spec)
    if not os.path.isfile(spec):
        raise ValueError(
            f"POSE: expected a named pose ({', '.join(POSE_NAMES)}) or a pose file; got {spec!r}"
        )
    try:
        if spec.lower().endswith(".npy"):
            values = np.load(spec, allow_pickle=False)
        else:
            with open(spec) as fh:
                values = np.array(fh.read().replace(",", " ").split(), dtype=float)
    except ValueError as exc:
        raise ValueError(f"{spec}: expected 26 numbers; {exc}") from None
    values = np.asarray(values, dtype=float).ravel()
    return check_limits(check_pose(values, spec), spec)


def check_limits(x, name: str):
    """`x` if every parameter lies within the joint limits of `handvar.params`, else raise."""
    import numpy as np

    from handvar.params import LOWER, NAMES, UPPER

    outside = np.flatnonzero((x < LOWER) | (x > UPPER))
    if outside.size:
        i = int(outside[0])
        raise ValueError(
            f"{name}: expected a pose within the parameter limits; {NAMES[i]} = {x[i]:g} "
            f"is outside [{LOWER[i]:g}, {UPPER[i]:g}]"
        )
    return x


def check_in_front(joints, rig, name: str) -> None:
    """Raise unless every joint (21, 3), mm, lies in front of every camera of `rig`."""
    import numpy as np

    for cam_name, cam in zip(rig.names, rig.cameras, strict=True):
        depth = np.asarray(cam.camera_from_world(joints))[:, 2]
        if not np.all(depth > 1.0):
            raise ValueError(
                f"{name}: expected the hand in front of every camera; it is behind or at "
                f"camera {cam_name!r} (nearest depth {depth.min():.0f} mm)"
            )


@main.command("show")
@click.argument("pose")
@click.option(
    "--out",
    type=click.Path(dir_okay=False),
    default=None,
    help="PNG file to write [default: POSE.png, named after the pose].",
)
@click.option(
    "--hand-length",
    type=_FiniteRange(min=50.0, max=400.0),
    default=185.0,
    show_default=True,
    help="Hand length (wrist crease to middle fingertip), mm (as for `track`).",
)
@click.option(
    "--shaded/--silhouette",
    default=False,
    show_default=True,
    help="Draw a shaded colour rendering instead of the silhouette.",
)
@click.option(
    "--frame",
    type=click.IntRange(min=0),
    default=None,
    help="POSE is a sequence directory: draw the true pose of frame K over its masks.",
)
@click.option("--model", type=click.Choice(("spheres", "mesh")), default="spheres",
              show_default=True, help="Hand surface: sphere-mesh or skinned mesh.")  # fmt: skip
@_one_line_errors
def show_command(
    pose: str,
    out: str | None,
    hand_length: float,
    shaded: bool,
    frame: int | None,
    model: str,
) -> None:
    """Draw POSE (a named pose or a file of 26 numbers) in both default cameras.

    Writes a PNG with the two views side by side: the model's silhouette (or a shaded
    rendering) with the 21 joints and the bones drawn on it.
    """
    import os

    import cv2
    import numpy as np

    from handvar.atomic import OutputSet, check_output_file
    from handvar.camera import Rig
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.render import draw_overlay, render_rgb, side_by_side, silhouettes

    if out is not None:
        check_output_file(out, "--out", suffixes=(".png",))
    x = load_pose(pose) if frame is None else None
    hand = HandModel(HandShape.from_size(hand_length), surface=model)
    rig = Rig.default()
    if frame is not None:  # a frame of a sequence: its true pose, its rig, its masks
        x, rig, masks = _sequence_frame(pose, frame)
        pose = f"{pose.rstrip(os.sep)}-{frame:05d}"
    label = os.path.splitext(os.path.basename(pose))[0]
    if out is None:
        out = check_output_file(f"{label}.png", "--out", suffixes=(".png",))
    joints = hand.joints(x)
    check_in_front(joints, rig, "POSE")
    if frame is None:
        masks = silhouettes(hand, x, rig)
    if shaded:
        base = render_rgb(hand, x, rig, background="plain", rng=np.random.default_rng(0))
    else:
        base = masks
    views = [draw_overlay(b, cam, joints) for b, cam in zip(base, rig, strict=True)]
    titles = [f"{label} - {name} camera" for name in rig.names]
    image = side_by_side(views, titles)

    def write_png(tmp: str) -> None:
        if not cv2.imwrite(tmp, cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
            raise OSError(f"{out}: cannot write the PNG")

    with OutputSet() as outputs:
        outputs.add(out, write_png)
    click.echo(f"{label}: {len(rig)} views -> {out}")


#: Largest magnitude `predict` accepts in a pose series (mm, degrees): far beyond any
#: pose, far below where squares of the values overflow in the predictors' fits.
_MAX_SERIES_VALUE = 1e6


# --- predict: open-loop evaluation of the predictors on a recorded pose series ------
@main.command("predict")
@click.argument("files", nargs=-1, required=True, metavar="FILE[:START:STOP]...")
@click.option(
    "--layout",
    type=click.Choice(["handvar", "htrack", "keypoints", "points", "columns"]),
    default="handvar",
    show_default=True,
    help="Column layout: handvar's 26 parameters (mm, degrees), htrack's (radians), "
    "21 keypoints x, y, z in metres (63 columns, or a (T, 21, 3) .npy), any K points "
    "(K x 3 columns, or a (T, K, 3) .npy; one block per point), or plain columns.",
)
@click.option(
    "--stride", type=click.IntRange(min=1), default=1, show_default=True,
    help="Use every K-th frame (simulates a slower camera).",
)  # fmt: skip
@click.option(
    "--reset-at", "reset_at", type=click.IntRange(min=0), multiple=True,
    help="Row (of each file) where a new recording starts; repeatable.",
)  # fmt: skip
@click.option("--csv", "csv_out", type=click.Path(dir_okay=False), help="Also write a CSV.")
@click.option(
    "--figure", "figure_out", type=click.Path(dir_okay=False),
    help="Write the league figure (RMSE / best baseline) as a PNG.",
)  # fmt: skip
@click.option(
    "--noise", is_flag=True,
    help="Add noisy variants of every recording (Gaussian sigma 0.5, 1, 2 in the columns' "
    "units; 5% outlier frames), scored against the clean next frame.",
)  # fmt: skip
@click.option(
    "--train", "train", metavar="FILE[:START:STOP]",
    help="Fit an offline VAR on this recording (same layout) and add it to the table.",
)  # fmt: skip
@click.option(
    "--predictor", "keys", multiple=True,
    help="Only these predictors besides the baselines (catalogue names); repeatable.",
)  # fmt: skip
@click.option(
    "--fps", type=click.FloatRange(min=0, min_open=True), default=30.0, show_default=True,
    help="Frame rate of the recordings (One Euro and the adaptive bank).",
)  # fmt: skip
@_one_line_errors
def predict_command(
    files, layout, stride, reset_at, csv_out, figure_out, noise, train, keys, fps
) -> None:
    """Score every predictor one step ahead on the recorded poses in FILE(s).

    FILE is whitespace text, CSV or .npy; rows are frames, 26 columns (or 63 for
    keypoints).  FILE:START:STOP takes rows START to STOP - 1.  With one FILE and no
    league option, prints per parameter group RMSE and mean absolute error (mm or
    degrees) and R̃² against no motion (> 0: better than no motion).  With several
    FILEs, --noise, --train, --predictor or --figure, prints the league table: per
    recording every predictor's RMSE, R̃², rank and RMSE / best simple baseline
    (no motion, decelerating 0.2 / 0.4 / 0.6, Kalman CV, One Euro).
    """
    import os

    import numpy as np

    from handvar.atomic import OutputSet, check_output_file
    from handvar.evaluation.openloop import (
        Recording,
        evaluate_open_loop,
        format_league,
        format_table,
        league_table,
        noise_variants,
        read_pose_series,
        write_csv,
        write_league_csv,
        write_league_figure,
    )
    from handvar.predictors.catalogue import catalogue_key

    # The outputs are checked before any work and written together at the end.
    if csv_out is not None:
        check_output_file(csv_out, "--csv", suffixes=(".csv", ".txt"))
    if figure_out is not None:
        check_output_file(figure_out, "--figure", suffixes=(".png", ".pdf", ".svg"))
    keys = [catalogue_key(k, "--predictor") for k in keys] or None
    inner = {"htrack": "handvar"}.get(layout, layout)

    def load(spec: str, option: str):
        """The series of FILE[:START:STOP] in `layout`'s units, and its reset rows."""
        path, rows = spec, None
        if not os.path.isfile(spec) and spec.count(":") >= 2:
            path, start, stop = spec.rsplit(":", 2)
            try:
                rows = (int(start) if start else 0, int(stop) if stop else None)
            except ValueError:
                raise ValueError(
                    f"{option}: expected FILE or FILE:START:STOP with integer rows; got {spec!r}"
                ) from None
        X = read_pose_series(path)
        if layout == "htrack":
            from handvar.synth.motion import htrack_to_handvar

            X = htrack_to_handvar(X)
        elif layout == "keypoints":
            X = 1000.0 * X  # metres -> millimetres
        start, stop = (0, len(X)) if rows is None else (rows[0], rows[1] or len(X))
        if not 0 <= start < stop <= len(X):
            raise ValueError(f"{option}: expected rows within 0..{len(X)}; got {spec!r}")
        if any(r >= len(X) for r in reset_at):
            raise ValueError(f"--reset-at: expected rows below {len(X)}; got {list(reset_at)}")
        biggest = float(np.abs(X).max()) if X.size else 0.0
        if biggest > _MAX_SERIES_VALUE:  # finite, but beyond any pose: the arithmetic overflows
            raise ValueError(
                f"{path}: expected poses in mm and degrees (|value| <= {_MAX_SERIES_VALUE:g}); "
                f"got {biggest:g}"
            )
        X = X[start:stop]
        local = [r - start for r in reset_at if start < r < stop]
        # Reset rows map onto the first kept frame at or after them.
        n = -(-len(X) // stride)
        resets = sorted({-(-r // stride) for r in local if -(-r // stride) < n})
        return X[::stride], tuple(resets)

    league = len(files) > 1 or noise or train or keys or figure_out
    if not league:
        file = files[0]
        X, resets = load(file, "FILE")
        try:
            rows, _ = evaluate_open_loop(X, resets=resets, layout=inner)
        except ValueError as exc:  # the series' shape or values: name the file
            msg = str(exc)
            raise ValueError(msg if msg.startswith(file) else f"{file}: {msg}") from None
        if csv_out:
            write_csv(rows, csv_out)  # first: a failure prints nothing but its one line
        click.echo(f"{file}: {len(X)} frames, {X.shape[1]} parameters, layout {layout}")
        click.echo(format_table(rows))
        if csv_out:
            click.echo(f"wrote {csv_out}")
        return

    recordings = []
    for file in files:
        X, resets = load(file, "FILE")
        rec = Recording(os.path.basename(file), X, inner, resets)
        recordings += [rec, *(noise_variants(rec) if noise else [])]
    extra = None
    if train:
        from handvar.evaluation.openloop import layout_structure
        from handvar.predictors import OfflineVAR

        Xt, rt = load(train, "--train")
        _, blocks = layout_structure(inner, Xt.shape[1])
        model = OfflineVAR(blocks=blocks).fit(Xt, resets=rt)
        click.echo(f"offline VAR: order {model.order_} (BIC), fitted on {train}, {len(Xt)} frames")

        def offline(rec):
            if rec.X.shape[1] != Xt.shape[1]:
                return None
            return OfflineVAR(blocks=blocks).fit(Xt, resets=rt)

        extra = {"offline VAR": offline}
    rows = league_table(recordings, rate=fps, keys=keys, extra=extra)
    with OutputSet() as out:  # both files, or neither
        if csv_out:
            out.add(csv_out, lambda tmp: write_league_csv(rows, tmp))
        if figure_out:
            out.add(figure_out, lambda tmp: write_league_figure(rows, tmp))
    click.echo(format_league(rows))
    if csv_out:
        click.echo(f"wrote {csv_out}")
    if figure_out:
        click.echo(f"wrote {figure_out}")


def _sequence_frame(path: str, frame: int):
    """True pose, rig and masks of frame `frame` of the sequence directory `path`."""
    from handvar.io import read_sequence

    seq = read_sequence(path, lazy=True)
    if frame >= seq.n_frames:
        raise ValueError(f"--frame: expected a frame below {seq.n_frames}; got {frame}")
    if seq.truth is None:
        raise ValueError(f"{path}: expected a sequence with truth.npz for --frame; it has none")
    return seq.truth.poses[frame], seq.rig, seq.masks[frame]


# --- experiment: the paper's tracking experiments on Dask ------------------------------


@main.command("experiment")
@click.option(
    "--out",
    "store",
    type=click.Path(file_okay=False),
    default="experiment.zarr",
    show_default=True,
    help="Zarr store of the results; an existing one is resumed.",
)
@click.option("--scheduler", default=None, help="Address of an existing Dask scheduler.")
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Worker processes of the embedded cluster [default: the number of cores].",
)
@click.option(
    "--set", "assignments", multiple=True, metavar="KEY=VALUE",
    help="Change the protocol: trials=4, frames=40, seed=1, trial=openloop, "
    "rvar.gamma=0.7, tracker.FIELD=V, predictors=none,rvar, extras=true; repeatable.",
)  # fmt: skip
@click.option(
    "--sweep", "sweeps", multiple=True, metavar="PRED.ARG=V1,V2,...",
    help="Add variants of a predictor, e.g. rvar.gamma=0.5,0.6,0.7; repeatable.",
)  # fmt: skip
@click.option("--quick", is_flag=True, help="A reduced protocol: 3 trials of 40 frames.")
@click.option(
    "--extras",
    is_flag=True,
    help="Add ours: relative RVAR, Kalman CV, One Euro and both adaptive banks.",
)
@click.option("--progress/--no-progress", default=True, show_default=True)
@_one_line_errors
def experiment_command(store, scheduler, workers, assignments, sweeps, quick, extras, progress):
    """Run the paper's experiment (5 predictors x 50 trials x 175 frames) into a store.

    Trials run as tasks on Dask: an embedded local cluster (one process per core)
    or --scheduler.  Each finished trial is written at once; running the same
    command again computes only the missing trials.  With an existing store and no
    protocol options, its own configuration is resumed.
    """
    import os

    from handvar.atomic import check_output_dir
    from handvar.evaluation.config import ExperimentConfig, tracker_settings
    from handvar.evaluation.experiment import run_experiment, summary_text
    from handvar.evaluation.store import read_config

    check_output_dir(store, "--out")
    resume = os.path.exists(store)
    if resume and not (assignments or sweeps or quick or extras):
        config = read_config(store)
    else:
        config = ExperimentConfig.quick() if quick else ExperimentConfig()
        if extras:
            config = config.with_extras()
        for text in assignments:
            config = _configure(config.with_overrides, [text], "--set", text)
        for text in sweeps:
            config = _configure(config.with_sweep, text, "--sweep", text)
    # every setting is checked before any work (rendering, a cluster)
    if config.trial_kind == "tracker":
        _configure(tracker_settings, config.tracker, "--set", "tracker")
    for spec in config.predictors:
        _configure(spec.build, None, "--set", spec.key)
    if resume and read_config(store) != config:
        raise ValueError(
            f"--out: {store} holds a different experiment; choose another --out or the "
            "same settings (or none, to resume it)"
        )
    click.echo(
        f"{len(config.predictors)} predictors x {config.trials} trials x {config.frames} "
        f"frames of {config.sequence} ({config.trial_kind}) -> {store}"
    )
    summary = run_experiment(config, store, scheduler=scheduler, workers=workers, progress=progress)
    if summary.repaired:
        click.echo(
            f"{store}: {len(summary.repaired)} damaged trials recomputed: "
            + ", ".join(f"{label} trial {t}" for label, t in summary.repaired)
        )
    click.echo(summary_text(summary))
    if not summary.complete:
        sys.exit(1)


def _configure(apply, arg, option: str, text: str):
    """``apply(arg)`` (or ``apply()``), its ValueError / TypeError naming `option` and `text`."""
    try:
        return apply() if arg is None else apply(arg)
    except (ValueError, TypeError) as exc:
        msg = str(exc)
        if msg.startswith(option):
            raise ValueError(msg) from None
        raise ValueError(f"{option} {text}: {msg}") from None


# --- report: the paper's figures and claims from an experiment store --------------------


@main.command("report")
@click.argument("store", type=click.Path(file_okay=False))
@click.option(
    "--out",
    type=click.Path(file_okay=False),
    default=None,
    help="Output directory [default: STORE's name with -report].",
)
@_one_line_errors
def report_command(store, out):
    """Draw the paper's figures 2-6 and the table of its claims from STORE."""
    import os

    from handvar.atomic import check_output_dir
    from handvar.evaluation.report import write_report

    if out is None:
        base = os.path.splitext(os.path.normpath(store))[0]
        out = f"{base}-report"
    check_output_dir(out, "--out")
    path = write_report(store, out)
    click.echo(f"report -> {path} (and report.html, figures in {out})")


# --- track: fit the hand model to every frame of a sequence ----------------------------


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


def _recording_options(func):
    """The options of a real recording: --calib, --fov and --scale."""
    options = [
        click.option(
            "--calib", type=click.Path(dir_okay=False), default=None,
            help="Recordings only: OpenCV calibration file, one camera per recording "
            "[default: for one video, an assumed camera, see --fov].",
        ),
        click.option(
            "--fov", type=_FiniteRange(1.0, 179.0), default=None,
            help="One uncalibrated video: assumed horizontal field of view, degrees "
            "[default: 60].",
        ),
        click.option(
            "--scale", type=_FiniteRange(0.05, 4.0), default=1.0, show_default=True,
            help="Recordings only: resize the frames by this factor first (0.5 is about "
            "4x faster).",
        ),
    ]  # fmt: skip
    for option in reversed(options):
        func = option(func)
    return func


@main.command("track")
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
    seq, predictor, init, seed, n_frames, out, video, hand_length, model, keypoint_files,
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
    if recover is None:
        recover = spec.kind == "recording" or keypoints is not None
    if spec.kind == "recording":  # video files / image folders: see the init section below
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
    hand = HandModel(HandShape.from_size(hand_length), surface=model)
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
    written = write_track_outputs(
        out, result, sequence, hand, predictor=predictor, seed=seed, video=video,
        backgrounds=None if source is None else recording_backgrounds(source), quality=quality,
    )  # fmt: skip
    if "video_error" in written:
        click.echo(f"handvar: note: no video ({written['video_error']})", err=True)

    fps = T / max(float(result.seconds.sum()), 1e-9)
    click.echo(
        f"{sequence.name}: {T} frames, predictor {predictor}, seed {seed}: "
        f"{result.iterations.mean():.1f} iterations/frame, {fps:.1f} frames/s -> {out}"
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
    if sequence.truth is not None:
        from handvar.evaluation.metrics import mean_joint_error

        err = mean_joint_error(sequence.truth.joints[:T], result.joints)
        click.echo(f"mean joint error: {err.mean():.2f} mm (max {err.max():.2f} mm)")


# --- init: the first frame's pose from real video (or a sequence) ------------------------


def _open_recordings(sources, calib, fov, scale):
    """A `VideoSource` for the video files / image folders `sources` (one per camera)."""
    from handvar.vision.sources import open_source

    return open_source(list(sources), calib, fov=fov, scale=scale)


def _frame_silhouettes(sources, calib, fov, scale, frame, wrist, threshold):
    """Rig, BGR images (or None) and masks of frame `frame` of a sequence or recordings."""
    import os

    if len(sources) == 1 and os.path.isfile(os.path.join(sources[0], "sequence.json")):
        if calib is not None or fov is not None:
            raise ValueError("--calib, --fov: a sequence directory has its own rig; got one")
        rig, masks = _sequence_frame_masks(sources[0], frame)
        return rig, None, masks
    source = _open_recordings(sources, calib, fov, scale)
    for _, images, masks in source.silhouettes(frame, frame + 1, wrist=wrist, threshold=threshold):
        return source.rig, images, masks
    raise ValueError(
        f"--frame: expected a frame of the recording ({source.n_frames} frames); got {frame}"
    )


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


def _sequence_frame_masks(path: str, frame: int):
    """Rig and masks (n_cams, H, W) of frame `frame` of the sequence directory `path`."""
    import numpy as np

    from handvar.io import read_sequence

    seq = read_sequence(path, lazy=True)
    if frame >= seq.n_frames:
        raise ValueError(f"--frame: expected a frame below {seq.n_frames}; got {frame}")
    return seq.rig, np.asarray(seq.masks[frame])


#: Lowest silhouette IoU of the best initial pose that `init` accepts (design §13.4):
#: good initialisations measure 0.70-0.92 on the example video
#: (``benchmarks/keypoint_init.py``), a 3x3 blob 0.001.
INIT_MIN_IOU = 0.3


@main.command("init")
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

    import cv2
    import numpy as np

    from handvar.atomic import OutputSet, check_output_file
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.tracking.init import initial_pose

    check_output_file(out, "--out")  # before any work
    if overlay is not None:
        check_output_file(overlay, "--overlay", suffixes=(".png",))
    kps = _frame_keypoints(keypoint_files, sources, frame, scale)
    cut_here = wrist and kps is None
    rig, images, masks = _frame_silhouettes(sources, calib, fov, scale, frame, cut_here, threshold)
    if kps is not None:
        from handvar.vision.silhouette import cut_wrist

        if wrist:
            masks = np.stack([cut_wrist(m, k) for m, k in zip(masks, kps, strict=True)])
    hand = HandModel(HandShape.from_size(hand_length))
    result = initial_pose(masks, rig, hand, keypoints=kps, rng=np.random.default_rng(seed))
    if not result.iou >= INIT_MIN_IOU:
        raise ValueError(
            f"SOURCES: expected a silhouette the hand model fits (IoU >= {INIT_MIN_IOU:g}); "
            f"the best fit of frame {frame} has IoU {result.iou:.3f}; nothing written"
        )
    line = " ".join(f"{v:.6f}" for v in result.pose) + "\n"

    def write_text(path):
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(line)

    with OutputSet() as outputs:  # both files, or neither (§13.1)
        outputs.add(out, write_text)
        if overlay is not None:
            from handvar.render.overlay import overlay_frame

            if images is None:  # a sequence directory: draw over its masks
                images = [
                    np.repeat((np.asarray(m, np.uint8) * 160)[:, :, None], 3, 2) for m in masks
                ]
            picture = overlay_frame(images, rig, hand, result.pose, masks)

            def write_png(path):
                if not cv2.imwrite(path, picture):
                    raise OSError(f"{overlay}: cannot write the PNG")

            outputs.add(overlay, write_png)
    where = os.path.basename(sources[0].rstrip(os.sep)) + ("" if len(sources) == 1 else ", ...")
    click.echo(
        f"{where} frame {frame}: IoU {result.iou:.3f} (shape {result.shape}, "
        f"{result.n_candidates} candidates"
        + (f", keypoint error {result.keypoint_error:.1f} px" if kps is not None else "")
        + f") -> {out}"
        + (f", {overlay}" if overlay else "")
    )


def _frame_keypoints(files, sources, frame, scale):
    """Per-camera (21, 3) keypoints of frame `frame` in the pixels of the scaled frames."""
    if not files:
        return None
    from handvar.vision.keypoints import read_keypoints

    if len(files) != len(sources):
        raise ValueError(
            f"--keypoints: expected one file per source ({len(sources)}); got {len(files)}"
        )
    out = []
    for path in files:
        kp = read_keypoints(path)
        if frame >= kp.n_frames:
            raise ValueError(
                f"{path}: expected keypoints of frame {frame}; got {kp.n_frames} frames"
            )
        out.append(kp.scaled(scale).frame(frame) if scale != 1.0 else kp.frame(frame))
    return out


# --- keypoints: 2D hand keypoints of a video by MediaPipe Hands (optional extra) ---------


@main.command("keypoints")
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
