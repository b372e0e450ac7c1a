"""Atomic file output: a file is written completely or not at all.

The content goes to a temporary file in the destination's folder (same file system), is
flushed to disk, and only then renamed over the destination with :func:`os.replace`, which is
atomic on POSIX and Windows. If writing fails, the temporary file is removed and the
destination is untouched.

Outputs are regular files only. A destination that is a symbolic link is written through to
the file it points at (the link stays, as a shell's ``>`` would leave it), atomically in that
file's folder; a destination (or a link's target) that is a folder, a device, a FIFO or a
socket is refused before anything is written: replacing it would destroy it (a device node
such as ``/dev/null``) or hand the output to whatever reads it.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "check_writable_folder", "output_target"]

_UMASK = os.umask(0o022)
os.umask(_UMASK)


def _kind(mode: int) -> str | None:
    """What a non-regular file is, from its ``st_mode`` (None for a regular file)."""
    for test, kind in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return None if stat.S_ISREG(mode) else "not a regular file"


def output_target(path: str | Path) -> Path:
    """The regular file an output named ``path`` is written to: ``path`` itself, or the file
    a symbolic link there points at.

    Raises
    ------
    ValueError
        Naming the path when it (or the file its link points at) exists and is not a
        regular file, or when its folder is missing, is not a folder, or cannot be written.
    """
    path = Path(path)
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:
        raise ValueError(f"cannot write {path}: {exc.strerror}") from None
    if mode is not None and (kind := _kind(mode)) is not None:
        via = f" (its link points at {target})" if target != path else ""
        raise ValueError(f"cannot write {path}: it is {kind}{via}; outputs are regular files")
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"cannot write {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"cannot write {path}: folder {folder} is not writable")
    return target


def check_writable_folder(path: str | Path) -> Path:
    """Return ``path`` as a Path after checking that it can be written as an output.

    Raises
    ------
    ValueError
        As :func:`output_target`.
    """
    output_target(path)
    return Path(path)


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        The destination: a regular file or none yet, or a symbolic link to one (written
        through). Its folder must exist.

    Yields
    ------
    Path
        A fresh, empty temporary file beside ``path``, with the same suffix (writers that
        pick a format by suffix keep working). If the ``with`` body raises, it is deleted and
        ``path`` is left as it was.
    """
    path = output_target(path)
    handle, temporary = tempfile.mkstemp(
        prefix=f".{path.stem}.",
        suffix=f".partial{path.suffix}",
        dir=path.parent if str(path.parent) else ".",
    )
    os.close(handle)
    temporary = Path(temporary)
    os.chmod(temporary, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the usual permissions
    try:
        yield temporary
        with open(temporary, "rb+") as written:
            os.fsync(written.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
