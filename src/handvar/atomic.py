"""Atomic writing: the one helper below everything that writes a file (design §11, §13).

A file is written whole under a temporary name beside its destination and renamed into
place, so a failed or interrupted write never leaves a half-written file nor destroys
the previous one. Temporaries carry a recognisable name (``.NAME.handvar-*.tmp``), so
:func:`remove_stale_temporaries` can clear what a killed run left behind without ever
touching a file it did not make.

A command with several outputs writes them through one :class:`OutputSet`: each is
checked before any work (:func:`check_output_file`, :func:`check_output_dir`), written
aside, and all are renamed into place only once every one of them was written
(design §13.1). A directory is replaced by :func:`replace_directory`, which leaves a
marked copy of the old one that :func:`recover_directory` restores should the swap be
killed half-way (design §13.2).

This module is a leaf: it imports nothing from handvar.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

__all__ = [
    "OLD_MARK",
    "TMP_MARK",
    "OutputSet",
    "check_output_dir",
    "check_output_file",
    "file_mode",
    "recover_directory",
    "remove_stale_temporaries",
    "replace_directory",
    "temporary_name",
    "user_paths",
    "write_atomic",
]

#: Part of the name of every temporary this package makes (files and directories).
TMP_MARK = ".handvar-"
#: Suffix of the old copy of a directory while :func:`replace_directory` swaps it.
OLD_MARK = ".handvar-old"

# .NAME.handvar-XXXXXXXX.tmp[.ext | _frames] -> NAME (the user's own file name)
_TMP_RE = re.compile(
    r"(?<![^/\\\s'\"(\[=])\.([^/\\\s'\"]+?)\.handvar-[A-Za-z0-9_]+\.tmp(?:_frames|\.[A-Za-z0-9]+)?"
)


def user_paths(text: str) -> str:
    """`text` with every temporary name of this package replaced by the user's own name.

    Examples
    --------
    >>> user_paths("out/.x.txt.handvar-ab12_c3d.tmp.txt: Permission denied")
    'out/x.txt: Permission denied'
    """
    return _TMP_RE.sub(r"\1", text)


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


def _remove(path: str | os.PathLike) -> None:
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)


def _translated(exc: BaseException) -> BaseException:
    """`exc` again, its message naming the user's paths instead of our temporaries."""
    text = str(exc)
    fixed = user_paths(text)
    if fixed == text:
        return exc
    kind = type(exc)
    if isinstance(exc, OSError):
        kind = OSError
    elif not isinstance(exc, ValueError | TypeError):
        return exc
    try:
        return kind(fixed)
    except Exception:  # an exception type with another signature
        return ValueError(fixed)


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
    with OutputSet() as out:
        out.add(path, write)


# --- checking outputs before any work -------------------------------------------------


def _check_parent(path: str, argument: str, parents: bool = False) -> None:
    parent = os.path.dirname(os.path.abspath(path))
    if parents:  # the missing folders will be made: the nearest existing one must do
        while not os.path.lexists(parent) and os.path.dirname(parent) != parent:
            parent = os.path.dirname(parent)
    if not os.path.exists(parent):
        raise ValueError(f"{argument}: expected a path in an existing folder; got {path}")
    if not os.path.isdir(parent):
        raise ValueError(f"{argument}: expected a path in a folder; got {path}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{argument}: expected a writable folder; cannot write into {parent}")


def check_output_file(
    path: str | os.PathLike,
    argument: str,
    *,
    suffixes: Iterable[str] | None = None,
) -> str:
    """Check, before any work, that the file `path` can be written; return it as str.

    Parameters
    ----------
    path : path-like
        The file to write.
    argument : str
        The option it came from (``--out``), named in the message.
    suffixes : iterable of str, keyword-only, optional
        Allowed endings (``".png"``), case-insensitive.

    Raises
    ------
    ValueError
        Empty name, a directory, a missing or unwritable folder, or a wrong suffix.
    """
    path = os.fspath(path)
    if not path.strip():
        raise ValueError(f"{argument}: expected a file name; got {path!r}")
    if os.path.isdir(path) or path.endswith(("/", os.sep)):
        raise ValueError(f"{argument}: expected a file; {path} is a directory")
    if suffixes is not None:
        suffixes = tuple(s.lower() for s in suffixes)
        if os.path.splitext(path)[1].lower() not in suffixes:
            raise ValueError(
                f"{argument}: expected a file ending in {' or '.join(suffixes)}; got {path}"
            )
    _check_parent(path, argument)
    if os.path.exists(path) and not os.path.isfile(path):
        raise ValueError(f"{argument}: expected a regular file; {path} is something else")
    return path


def check_output_dir(path: str | os.PathLike, argument: str, *, parents: bool = True) -> str:
    """Check, before any work, that the directory `path` can be written into or made.

    With `parents` (default) missing folders above `path` are allowed (they will be
    made); the nearest existing one must be a writable folder.

    Raises
    ------
    ValueError
        Empty name, an existing non-directory, a missing or unwritable folder.
    """
    path = os.fspath(path)
    if not path.strip():
        raise ValueError(f"{argument}: expected a directory name; got {path!r}")
    if os.path.exists(path):
        if not os.path.isdir(path):
            raise ValueError(f"{argument}: expected a directory; {path} is a file")
        if not os.access(path, os.W_OK | os.X_OK):
            raise ValueError(f"{argument}: expected a writable directory; got {path}")
    _check_parent(os.path.normpath(path), argument, parents)
    return path


# --- a set of outputs, committed together ----------------------------------------------


class OutputSet:
    """Outputs written aside and moved into place together, only if all succeeded.

    Use as a context manager: on a normal exit :meth:`commit` renames every temporary
    to its destination; on an exception :meth:`abort` removes the temporaries and
    every destination is left as it was.  While committing, each file about to be
    replaced is first hard-linked aside, so a failed rename puts the earlier ones back.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> try:
    ...     with OutputSet() as out:
    ...         _ = out.add(folder / "a.txt", lambda tmp: Path(tmp).write_text("a"))
    ...         _ = out.add(folder / "b.txt", lambda tmp: 1 / 0)
    ... except ZeroDivisionError:
    ...     pass
    >>> sorted(os.listdir(folder))
    []
    >>> with OutputSet() as out:
    ...     _ = out.add(folder / "a.txt", lambda tmp: Path(tmp).write_text("a"))
    >>> sorted(os.listdir(folder))
    ['a.txt']
    """

    def __init__(self) -> None:
        self._temporaries: list[str] = []
        self._moves: list[tuple[str, str, bool]] = []  # (tmp, destination, is_dir)
        self.committed = False

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.abort()

    def temporary(self, path: str | os.PathLike, *, directory: bool = False) -> str:
        """A fresh temporary beside `path`, removed by :meth:`abort` unless placed.

        Temporaries of `path` that a killed earlier run left are removed first.
        """
        remove_stale_temporaries(path)
        tmp = temporary_name(path, directory=directory)
        self._temporaries.append(tmp)
        return tmp

    def track(self, path: str | os.PathLike) -> None:
        """Remove `path` (a temporary made by someone else) on :meth:`abort`."""
        self._temporaries.append(os.fspath(path))

    def place(self, tmp: str | os.PathLike, path: str | os.PathLike, *, directory=False) -> None:
        """Rename the written temporary `tmp` to `path` on :meth:`commit`."""
        tmp = os.fspath(tmp)
        if tmp not in self._temporaries:
            self._temporaries.append(tmp)
        self._moves.append((tmp, os.fspath(path), directory))

    def add(
        self, path: str | os.PathLike, write: Callable[[str], Any], *, directory: bool = False
    ) -> str:
        """Write `path` aside now: ``write(tmp)`` fills a temporary, renamed on commit.

        An error of `write` that names the temporary is raised naming `path` instead.
        """
        tmp = self.temporary(path, directory=directory)
        try:
            write(tmp)
        except Exception as exc:
            new = _translated(exc)
            if new is exc:
                raise
            raise new from None
        self.place(tmp, path, directory=directory)
        return tmp

    def commit(self) -> None:
        """Rename every written temporary into place (all of them, or none on failure)."""
        backups: list[tuple[str, str]] = []  # (backup, destination) of replaced files
        done: list[str] = []  # destinations that were new
        try:
            for tmp, path, is_dir in self._moves:
                if is_dir:
                    replace_directory(tmp, path)
                    continue
                if os.path.isfile(path):
                    backup = temporary_name(path)
                    os.unlink(backup)
                    try:
                        os.link(path, backup)
                        backups.append((backup, path))
                    except OSError:  # no hard links here: the file cannot be put back
                        pass
                else:
                    done.append(path)
                os.replace(tmp, path)
        except BaseException:
            for backup, path in backups:
                with contextlib.suppress(OSError):
                    os.replace(backup, path)  # a no-op where path is still the same file
                with contextlib.suppress(OSError):
                    os.unlink(backup)
            for path in done:
                with contextlib.suppress(OSError):
                    os.unlink(path)
            self.abort()
            raise
        for backup, _ in backups:
            with contextlib.suppress(OSError):
                os.unlink(backup)
        self._temporaries.clear()
        self._moves.clear()
        self.committed = True

    def abort(self) -> None:
        """Remove every temporary; no destination is touched."""
        for tmp in self._temporaries:
            _remove(tmp)
        self._temporaries.clear()
        self._moves.clear()


# --- replacing a directory ---------------------------------------------------------------


def _old_name(target: Path) -> Path:
    return target.with_name(f".{target.name}{OLD_MARK}")


def recover_directory(path: str | os.PathLike) -> bool:
    """Finish or undo a directory swap that was killed half-way; True if one was found.

    If `path` is missing and its marked old copy (``.NAME.handvar-old``) exists, the
    copy is renamed back to `path`; if both exist, the swap had finished and the old
    copy is removed.
    """
    target = Path(path)
    old = _old_name(target)
    if not os.path.lexists(old):
        return False
    if os.path.lexists(target):
        _remove(old)
    else:
        os.replace(old, target)
    return True


def replace_directory(new: str | os.PathLike, path: str | os.PathLike) -> None:
    """Rename the directory `new` to `path`, replacing an existing `path`.

    The old `path` is first renamed to ``.NAME.handvar-old`` beside it, `new` is
    renamed to `path`, then the old copy is removed.  A failure puts the old one back;
    a kill between the two renames leaves the marked copy, which
    :func:`recover_directory` (called here first, and by the readers of sequences)
    restores.
    """
    target = Path(path)
    recover_directory(target)
    old = _old_name(target)
    had_old = os.path.lexists(target)
    if had_old:
        os.replace(target, old)
    try:
        os.replace(new, target)
    except BaseException:
        if had_old:
            os.replace(old, target)
        raise
    if had_old:
        _remove(old)


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries this package left beside `path` (a killed earlier run).

    Only names of the form ``.NAME.handvar-*.tmp*`` for ``NAME`` = the base name of
    `path` are touched. Returns what was removed.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        return []
    removed = []
    for entry in folder.glob(f".{_glob_escape(path.name)}{TMP_MARK}*.tmp*"):
        _remove(entry)
        removed.append(entry)
    return removed


def _glob_escape(name: str) -> str:
    """`name` with the glob's special characters escaped."""
    import glob

    return glob.escape(name)
