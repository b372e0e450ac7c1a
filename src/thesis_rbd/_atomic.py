"""Atomic file output: a file is written completely or not at all.

The content goes to a temporary file in the destination's folder (same file system), is
flushed to disk, and only then renamed over the destination with :func:`os.replace`, which is
atomic on POSIX and Windows. If writing fails, the temporary file is removed and the
destination is untouched.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "check_writable_folder"]

_UMASK = os.umask(0o022)
os.umask(_UMASK)


def check_writable_folder(path: str | Path) -> Path:
    """Return ``path`` as a Path after checking that its folder exists and is writable.

    Raises
    ------
    ValueError
        Naming the path when its folder is missing, is not a folder, or cannot be written,
        or when the path itself is a folder.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise ValueError(f"cannot write {path}: it is a folder")
    if not folder.is_dir():
        raise ValueError(f"cannot write {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"cannot write {path}: folder {folder} is not writable")
    return path


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        The destination. Its folder must exist.

    Yields
    ------
    Path
        A fresh, empty temporary file beside ``path``, with the same suffix (writers that
        pick a format by suffix keep working). If the ``with`` body raises, it is deleted and
        ``path`` is left as it was.
    """
    path = check_writable_folder(path)
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
