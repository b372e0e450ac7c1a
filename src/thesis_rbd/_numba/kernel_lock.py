"""One process at a time compiles a kernel for given argument types.

Processes that share numba's on-disk cache (a run and its compile helpers, two runs started
together) would otherwise each compile a kernel that none of them has cached yet, and write
the same index file at once (numba reads, extends and rewrites it, so one of two new entries
can be lost). Under the lock, the second process finds the first one's cache entry and loads
it.

The lock is a POSIX record lock on one byte of a lock file beside the kernel's cache index,
the byte chosen by the argument types, so that two signatures of a kernel compile in
parallel. Record locks belong to the process: a nested compile of the same kernel and types
(never the case in this package, but harmless) holds it again, counted here, and the file
stays open for the life of the process (closing any descriptor of a file releases all of the
process's record locks on it). The kernel refuses a wait that would close a cycle
(``EDEADLK``); the compile then goes ahead unlocked, at worst doing the work twice. Where
record locks are not available (Windows, a read-only cache), nothing is locked.
"""

from __future__ import annotations

import errno
import hashlib
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

from numba.core import event

__all__ = ["WAIT_EVENT", "kernel_lock"]

WAIT_EVENT = "thesis_rbd:compile_wait"
"""numba event kind triggered around a wait for another process's compile; its data holds
the dispatcher and the argument types, as numba's own ``numba:compile`` event does."""

# a lock byte well inside the file's possible offsets, chosen by the argument types
_BYTE_RANGE = 1 << 30
_files: dict[str, int] = {}
_held: dict[tuple[str, int], int] = {}
_guard = threading.Lock()


def _lock_path(dispatcher) -> str | None:
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    if cache_file is None:
        return None
    return cache_file._index_path + ".lock"


def _descriptor(path: str) -> int | None:
    descriptor = _files.get(path)
    if descriptor is None:
        try:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError:
            return None
        _files[path] = descriptor
    return descriptor


def _byte(args: tuple) -> int:
    return int.from_bytes(hashlib.sha256(repr(args).encode()).digest()[:4], "little") % _BYTE_RANGE


@contextmanager
def kernel_lock(dispatcher, args: tuple, wait: bool = True) -> Iterator[bool]:
    """Hold the lock on compiling ``dispatcher`` for ``args`` while the block runs.

    Parameters
    ----------
    dispatcher : numba dispatcher
        A cached kernel of the package.
    args : tuple of numba types
        The argument types it is compiled for.
    wait : bool
        False gives up at once when another process holds the lock.

    Yields
    ------
    bool
        False when ``wait`` is False and another process holds the lock (the block should
        leave the kernel to it); True otherwise, locked or (where locks are not available)
        not.
    """
    path = _lock_path(dispatcher) if fcntl is not None else None
    descriptor = None if path is None else _descriptor(path)
    if descriptor is None:
        yield True
        return
    key = (path, _byte(args))
    with _guard:
        nested = _held.get(key, 0) > 0
    acquired = nested or _acquire(descriptor, key[1], dispatcher, args, wait)
    if not acquired and not wait:
        yield False
        return
    with _guard:
        _held[key] = _held.get(key, 0) + 1
    try:
        yield True
    finally:
        with _guard:
            _held[key] -= 1
            last = _held[key] == 0
            if last:
                del _held[key]
        # a nested hold never brings the count to 0: only the outermost one unlocks
        if last and acquired is True:
            fcntl.lockf(descriptor, fcntl.LOCK_UN, 1, key[1])


def _acquire(descriptor: int, byte: int, dispatcher, args: tuple, wait: bool) -> bool | None:
    """True once locked; False when busy and not waiting; None when locking failed."""
    try:
        fcntl.lockf(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB, 1, byte)
        return True
    except OSError as error:
        if error.errno not in (errno.EACCES, errno.EAGAIN):
            return None
    if not wait:
        return False
    with event.trigger_event(WAIT_EVENT, data={"dispatcher": dispatcher, "args": args}):
        try:
            fcntl.lockf(descriptor, fcntl.LOCK_EX, 1, byte)
            return True
        except OSError:  # EDEADLK, or an interrupted wait: compile unlocked
            return None
