"""Which numba kernels compiled while a piece of code ran, and for how long.

numba compiles a kernel the first time it is called with a new signature, unless its on-disk
cache (``cache=True``, see :mod:`thesis_rbd._numba.jit`) already holds the machine code; a cache hit
costs milliseconds, a compile seconds. numba announces each compile with a ``"numba:compile"``
event (:mod:`numba.core.event`) at its start and its end. Compiling a kernel compiles the
kernels it calls on the way, inside its own event, so the events nest: a record's ``seconds``
include the callees compiled within it, its ``own_seconds`` do not, and the time spent
compiling is the sum of the outermost records' ``seconds``.

Where helper processes compile a first run's kernels beside it (:mod:`.compile_helpers`), the
run may wait for a kernel that a helper is compiling (:mod:`.kernel_lock` announces the wait
with an event of its own); those waits are recorded apart, in ``waits``, and count as time
spent compiling.

>>> with CompileLog() as log:
...     world.step()
>>> log.seconds, [record.name for record in log.slowest(5)]
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from time import perf_counter, process_time

from numba.core import event

from thesis_rbd._numba.kernel_lock import WAIT_EVENT

__all__ = ["CompileLog", "KernelCompile"]

_COMPILE_EVENT = "numba:compile"


@dataclass(frozen=True)
class KernelCompile:
    """One compile of one kernel for one signature.

    Attributes
    ----------
    name : str
        ``module.qualname`` of the kernel's Python function.
    signature : str
        The argument types it was compiled for.
    seconds : float
        Wall time of the compile, callees compiled within it included.
    own_seconds : float
        ``seconds`` less the callees' compiles.
    cpu_seconds, own_cpu_seconds : float
        The same in processor time of this process: on a busy machine, the part of the wall
        time that was compiling rather than waiting for a core.
    depth : int
        0 for a compile that no other compile started (its ``seconds`` are wall time spent
        compiling), 1 for a callee of such a compile, and so on.
    """

    name: str
    signature: str
    seconds: float
    own_seconds: float
    cpu_seconds: float
    own_cpu_seconds: float
    depth: int

    def to_json(self) -> dict:
        """The record as a JSON-able dict."""
        return {
            "name": self.name,
            "signature": self.signature,
            "seconds": self.seconds,
            "own_seconds": self.own_seconds,
            "cpu_seconds": self.cpu_seconds,
            "own_cpu_seconds": self.own_cpu_seconds,
            "depth": self.depth,
        }


@dataclass
class _OpenCompile:
    name: str
    signature: str
    start: float
    cpu_start: float
    callee_seconds: float = 0.0
    callee_cpu_seconds: float = 0.0
    waiting: bool = False


class CompileLog(event.Listener):
    """Record numba's kernel compiles while the ``with`` block runs.

    Parameters
    ----------
    on_start : callable(name), optional
        Called when a kernel starts compiling (outermost compiles and waits only), with its
        name; the command line shows a spinner from here.
    on_end : callable(record), optional
        Called with the :class:`KernelCompile` of each outermost compile (or wait) once it
        has ended.

    Attributes
    ----------
    records : list of KernelCompile
        Every compile so far, in the order they ended (callees before their callers).
    waits : list of KernelCompile
        Every wait for a kernel that another process was compiling, as records of their own
        (their ``own_seconds`` are the wait).
    """

    def __init__(
        self,
        on_start: Callable[[str], None] | None = None,
        on_end: Callable[[KernelCompile], None] | None = None,
    ):
        self.records: list[KernelCompile] = []
        self.waits: list[KernelCompile] = []
        self._on_start, self._on_end = on_start, on_end
        # numba compiles under one global lock, so events arrive one compile at a time; the
        # stack of open compiles is still guarded, as callbacks run on the compiling thread
        self._open: list[_OpenCompile] = []
        self._lock = threading.Lock()

    def __enter__(self) -> CompileLog:
        event.register(_COMPILE_EVENT, self)
        event.register(WAIT_EVENT, self)
        return self

    def __exit__(self, *exc_info) -> None:
        event.unregister(_COMPILE_EVENT, self)
        event.unregister(WAIT_EVENT, self)

    # numba's Listener interface
    def on_start(self, evt: event.Event) -> None:
        data = evt.data
        function = data["dispatcher"].py_func
        name = f"{function.__module__}.{function.__qualname__}"
        signature = "(" + ", ".join(str(arg) for arg in data["args"]) + ")"
        with self._lock:
            outermost = not self._open
            self._open.append(
                _OpenCompile(
                    name, signature, perf_counter(), process_time(), waiting=evt.kind == WAIT_EVENT
                )
            )
        if outermost and self._on_start is not None:
            self._on_start(name)

    def on_end(self, evt: event.Event) -> None:
        now, cpu_now = perf_counter(), process_time()
        with self._lock:
            opened = self._open.pop()
            seconds, cpu_seconds = now - opened.start, cpu_now - opened.cpu_start
            record = KernelCompile(
                opened.name,
                opened.signature,
                seconds,
                max(seconds - opened.callee_seconds, 0.0),
                cpu_seconds,
                max(cpu_seconds - opened.callee_cpu_seconds, 0.0),
                len(self._open),
            )
            if self._open:
                self._open[-1].callee_seconds += seconds
                self._open[-1].callee_cpu_seconds += cpu_seconds
            (self.waits if opened.waiting else self.records).append(record)
        if record.depth == 0 and self._on_end is not None:
            self._on_end(record)

    # ------------------------------------------------------------------ reading
    @property
    def compiling(self) -> bool:
        """Whether a compile is under way now."""
        return bool(self._open)

    @property
    def seconds(self) -> float:
        """Wall time spent compiling: the sum of the outermost compiles and waits for them."""
        return sum(record.seconds for record in self.records + self.waits if record.depth == 0)

    @property
    def cpu_seconds(self) -> float:
        """Processor time spent compiling: the sum of the outermost compiles' (and waits')."""
        return sum(record.cpu_seconds for record in self.records + self.waits if record.depth == 0)

    @property
    def wait_seconds(self) -> float:
        """Wall time spent waiting, outside any compile of this process, for kernels that
        other processes were compiling."""
        return sum(record.seconds for record in self.waits if record.depth == 0)

    @property
    def kernel_count(self) -> int:
        """Distinct kernels compiled (one compiled for two signatures counts once)."""
        return len({record.name for record in self.records})

    def slowest(self, count: int | None = None) -> list[KernelCompile]:
        """The records by decreasing ``own_seconds``, the first ``count`` of them (all: None)."""
        ranked = sorted(self.records, key=lambda record: record.own_seconds, reverse=True)
        return ranked if count is None else ranked[:count]
