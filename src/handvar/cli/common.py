"""What the commands of `handvar` share: one-line errors, option types and options.

Every command turns a wrong input (a ``ValueError``, a ``TypeError``, an unreadable
file) into one line on standard error naming the argument or the user's path and exit
status 2, never a traceback (design §13.4).
"""

from __future__ import annotations

import functools
import sys

import click


def _one_line_errors(func):
    """Report ValueError / TypeError / OSError as one line and exit with status 2.

    The line names the user's paths, never a temporary of `handvar.atomic` (design §13.4).
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


def _open_recordings(sources, calib, fov, scale):
    """A `VideoSource` for the video files / image folders `sources` (one per camera)."""
    from handvar.vision.sources import open_source

    return open_source(list(sources), calib, fov=fov, scale=scale)
