"""The `handvar` command.

Every command turns a wrong input (a ``ValueError``, a ``TypeError``, an unreadable
file, a bad option) into one line on standard error naming the argument or the user's
path and exit status 2, never a traceback; its outputs are checked before any work and
written all-or-nothing (design §13).

The command group lives here; each command is a thin module calling the library:
`synth` (synth, show), `predict`, `experiment` (experiment, report), `track`, `init`,
`keypoints` and `export` (export, view); what several of them share is in `common`.
Importing the package loads none of the heavy parts (each command imports them when it runs).
"""

from __future__ import annotations

import sys

import click

from handvar.cli.common import _FiniteRange as _FiniteRange
from handvar.cli.common import _one_line_errors as _one_line_errors
from handvar.cli.common import _recording_options as _recording_options
from handvar.cli.experiment import experiment_command, report_command
from handvar.cli.export import export_command, view_command
from handvar.cli.init import INIT_MIN_IOU, init_command
from handvar.cli.keypoints import keypoints_command
from handvar.cli.predict import predict_command
from handvar.cli.synth import check_limits, load_pose, show_command, synth_command
from handvar.cli.track import make_predictor, track_command

__all__ = [
    "INIT_MIN_IOU",
    "check_limits",
    "experiment_command",
    "export_command",
    "init_command",
    "keypoints_command",
    "load_pose",
    "main",
    "make_predictor",
    "predict_command",
    "report_command",
    "show_command",
    "synth_command",
    "track_command",
    "view_command",
]


class _OneLineGroup(click.Group):
    """A command group whose usage errors (bad options, values) are one line too (design §13.4)."""

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
    """Silence OpenCV's, its FFmpeg backend's and asyncio's logging on standard error
    (design §13.4).

    A damaged video makes FFmpeg print lines such as ``moov atom not found`` before our
    own one-line message; the failure is reported by us instead.  Set before OpenCV
    loads its FFmpeg backend; a value the user set in the environment is kept.  A Zarr
    store's write that fails (a full disk) leaves the store's other writes, running at
    once on its event loop, with their errors unretrieved: asyncio would print each
    with a traceback after our line, when the futures are collected.
    """
    import logging
    import os

    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")
    logging.getLogger("asyncio").setLevel(logging.CRITICAL)


for _command in (
    synth_command,
    show_command,
    predict_command,
    experiment_command,
    report_command,
    track_command,
    init_command,
    keypoints_command,
    export_command,
    view_command,
):
    main.add_command(_command)
del _command
