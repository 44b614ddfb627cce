"""The `handvar` command.

Every command turns a wrong input (a ``ValueError`` or an unreadable file) into one
line on standard error and a non-zero exit status, never a traceback.
"""

from __future__ import annotations

import functools
import sys

import click


def _one_line_errors(func):
    """Report ValueError / OSError as one line and exit with status 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except (ValueError, OSError) as exc:
            msg = " ".join(str(exc).split())
            click.echo(f"handvar: error: {msg}", err=True)
            sys.exit(2)

    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="handvar")
def main() -> None:
    """Model-based 3D hand tracking with online, adaptive VAR motion prediction."""


# --- commands ---------------------------------------------------------------------
# Each command lives in its own section below; keep them independent.
