"""Atomic writing: the one helper below everything that writes a file (design §11).

A file is written whole under a temporary name beside its destination and renamed into
place, so a failed or interrupted write never leaves a half-written file nor destroys
the previous one. Temporaries carry a recognisable name (``.NAME.handvar-*.tmp``), so
:func:`remove_stale_temporaries` can clear what a killed run left behind without ever
touching a file it did not make.

This module is a leaf: it imports nothing from handvar.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["TMP_MARK", "file_mode", "remove_stale_temporaries", "temporary_name", "write_atomic"]

#: Part of the name of every temporary this package makes (files and directories).
TMP_MARK = ".handvar-"


def file_mode(directory: bool = False) -> int:
    """Permissions a new file (0o666) or directory (0o777) gets under the current umask."""
    mask = os.umask(0)
    os.umask(mask)
    return (0o777 if directory else 0o666) & ~mask


def temporary_name(path: str | os.PathLike, *, directory: bool = False) -> str:
    """Create and return a fresh temporary file (or directory) beside `path`.

    Its name starts with ``.NAME.handvar-`` and ends with ``.tmp`` plus the suffix of
    `path`, so writers that choose a format by suffix pick the right one. It is created
    with the permissions the umask allows (not mkstemp's private 0600).
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    name = os.path.basename(path)
    prefix = f".{name}{TMP_MARK}"
    if directory:
        tmp = tempfile.mkdtemp(prefix=prefix, suffix=".tmp", dir=folder)
        os.chmod(tmp, file_mode(directory=True))
        return tmp
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=".tmp" + os.path.splitext(path)[1], dir=folder)
    os.close(fd)
    os.chmod(tmp, file_mode())
    return tmp


def write_atomic(path: str | os.PathLike, write: Callable[[str], Any]) -> None:
    """Write one file under a temporary name beside `path`, then rename it to `path`.

    A failed write never leaves a half-written file nor destroys the previous one.

    Parameters
    ----------
    path : path-like
        File to write; its folder must exist.
    write : callable
        ``write(tmp)`` writes the whole file to the path ``tmp`` (a str with the
        suffix of `path`, so writers that go by the suffix pick the right format).

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> write_atomic(os.path.join(folder, "x.txt"), lambda tmp: Path(tmp).write_text("1"))
    >>> sorted(os.listdir(folder))
    ['x.txt']
    """
    path = os.fspath(path)
    tmp = temporary_name(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries this package left beside `path` (a killed earlier run).

    Only names of the form ``.NAME.handvar-*.tmp*`` for ``NAME`` = the base name of
    `path` are touched. Returns what was removed.
    """
    import shutil

    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        return []
    removed = []
    for entry in folder.glob(f".{path.name}{TMP_MARK}*.tmp*"):
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed
