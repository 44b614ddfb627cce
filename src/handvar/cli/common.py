"""What the commands of `handvar` share: one-line errors, option types and options.

Every command turns a wrong input (a ``ValueError``, a ``TypeError``, an unreadable
file) into one line on standard error naming the argument or the user's path and exit
status 2, never a traceback (design §13.4).
"""

from __future__ import annotations

import functools
import sys
import time
import warnings

import click

#: When the command started (its package imported): the all-in frame rates count from it.
STARTED = time.perf_counter()


def _one_line_errors(func):
    """Report ValueError / TypeError / OSError as one line and exit with status 2.

    The line names the user's paths, never a temporary of `handvar.atomic` (design §13.4). A
    warning shown while the command runs is one line too (``handvar: warning: ...``).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from handvar.atomic import disk_full, user_paths

        try:
            with warnings.catch_warnings():
                warnings.showwarning = _one_line_warning
                return func(*args, **kwargs)
        except (ValueError, TypeError, OSError) as exc:
            if isinstance(exc, OSError) and exc.filename is not None:
                exc = disk_full(exc, exc.filename)  # "PATH: ... the disk is full"
            msg = user_paths(" ".join(str(exc).split()))
            if isinstance(exc, OSError) and exc.filename is not None and not msg:
                msg = f"{exc.filename}: cannot be written"
            click.echo(f"handvar: error: {msg}", err=True)
            sys.exit(2)

    return wrapper


def _locks_out(func):
    """The command writes the directory --out: checked, then locked for the whole run, so
    a second run into it stops before any work ("another run is writing OUT")."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from handvar.atomic import check_output_dir, lock_directory

        check_output_dir(kwargs["out"], "--out")
        with lock_directory(kwargs["out"], "--out"):
            return func(*args, **kwargs)

    return wrapper


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """`warnings.showwarning` of the commands: one line on standard error, no source."""
    from handvar.atomic import user_paths

    click.echo(f"handvar: warning: {user_paths(' '.join(str(message).split()))}", err=True)


class _FiniteRange(click.FloatRange):
    """A float option within a range; NaN and infinities are refused (they pass
    click's comparisons)."""

    def convert(self, value, param, ctx):
        import math

        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return rv


def _recording_options(func):
    """The options of a real recording: --calib, --fov, --scale and --allow-short."""
    options = [
        click.option(
            "--calib", type=click.Path(dir_okay=False), default=None,
            help="Recordings only: calibration file, one camera per recording (OpenCV "
            "YAML/XML/JSON or an anipose .toml) [default: for one video, an assumed "
            "camera, see --fov].",
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
        click.option(
            "--allow-short", is_flag=True,
            help="Recordings only: a video that stops decoding before the frame count of "
            "its container (truncated or damaged) is used to where it stops, with a "
            "warning [default: refused].",
        ),
    ]  # fmt: skip

    @functools.wraps(func)
    def wrapper(*args, allow_short=False, **kwargs):
        # kept for `_open_recordings`, so the commands need no parameter of their own
        click.get_current_context().meta["handvar.allow_short"] = allow_short
        return func(*args, **kwargs)

    for option in reversed(options):
        wrapper = option(wrapper)
    return wrapper


def _open_recordings(sources, calib, fov, scale):
    """A `VideoSource` for the video files / image folders `sources` (one per camera),
    with the command's --allow-short."""
    from handvar.vision.sources import open_source

    ctx = click.get_current_context(silent=True)
    allow_short = bool(ctx is not None and ctx.meta.get("handvar.allow_short"))
    return open_source(list(sources), calib, fov=fov, scale=scale, allow_short=allow_short)
