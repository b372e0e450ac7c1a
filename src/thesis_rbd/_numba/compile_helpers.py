"""A first run's kernels compiled by several processes at once, one per core.

numba compiles under one lock per process, so a first run compiles its kernels one after the
other on one core. When a run starts on a cache that lacks its scene's kernels,
:class:`CompileHelpers` starts helper processes on the spare cores, and the run and its
helpers all walk the scene's compile plan (:mod:`.compile_plan`: every kernel the scene's
first run compiles, callees before their callers). Each process takes the next kernel that
no other process has taken and compiles it into numba's on-disk cache (:mod:`.kernel_lock`
makes a kernel one process's at a time): a kernel another process holds is passed over, a
callee another process is still compiling is waited for, and a kernel another process has
finished is loaded. The run then starts, and loads what it needs.

The run never depends on its helpers: it compiles whatever it needs that the cache lacks,
and when it ends, helpers still at work are stopped (what they finished stays cached).
"""

from __future__ import annotations

import argparse
import subprocess
import sys

from thesis_rbd._cores import usable_cores
from thesis_rbd._numba.compile_plan import PlannedCompile, load_plan
from thesis_rbd._numba.kernel_lock import kernel_lock

__all__ = ["CompileHelpers", "compile_ahead", "compile_planned", "spare_cores"]


def spare_cores() -> int:
    """Cores this process may use, less the one it runs on."""
    return max(usable_cores() - 1, 0)


def _is_cached(entry: PlannedCompile) -> bool:
    """Whether the kernel is compiled in this process or listed in numba's cache index (a
    stale entry counts as cached: there is nothing to compile ahead for it). Read from the
    index, not loaded: the run loads it when it calls it."""
    try:
        dispatcher = entry.dispatcher()
    except LookupError:
        return True
    return entry.args in dispatcher.overloads or entry.args in dispatcher.cached_signatures()


def compile_planned(entries: list[PlannedCompile]) -> int:
    """Compile (or load) each planned kernel that no other process is compiling, in order.

    Returns how many it compiled or loaded. A planned kernel that the package no longer has,
    or that no longer compiles for the planned types, is passed over: the plan is a guess at
    what a run needs.
    """
    done = 0
    for entry in entries:
        try:
            dispatcher = entry.dispatcher()
        except LookupError:
            continue
        if entry.args in dispatcher.overloads:
            continue
        with kernel_lock(dispatcher, entry.args, wait=False) as ours:
            if not ours:
                continue
            try:
                dispatcher.compile(entry.args)
                done += 1
            except Exception:  # numba's typing errors share no base class: a stale entry is
                continue  # passed over, and the run compiles what it needs
    return done


def compile_ahead(scenes: list[str] | None) -> bool:
    """Compile (or load) the named scenes' planned kernels, taking turns with any other
    process doing the same, unless the cache already holds them. Returns whether it did.

    The plan's last kernel is the outermost the scenes compile: cached, they are warm.
    """
    entries = load_plan().for_scenes(scenes)
    if not entries or _is_cached(entries[-1]):
        return False
    compile_planned(entries)
    return True


class CompileHelpers:
    """On entry, if the cache lacks the scenes' kernels: start helpers and compile the plan
    with them; on exit, stop helpers still at work.

    Parameters
    ----------
    scenes : list of str, optional
        The built-in scenes whose plans to compile (every scene's: None).
    helpers : int, optional
        How many helper processes; one per spare core (:func:`spare_cores`) by default, 0
        for none (the run then compiles as it goes, alone).

    Attributes
    ----------
    started : int
        How many helpers were started.
    """

    def __init__(self, scenes: list[str] | None = None, helpers: int | None = None):
        if helpers is not None and helpers < 0:
            raise ValueError(f"helpers must be 0 or more, got {helpers}")
        self.scenes = scenes
        self.helpers = spare_cores() if helpers is None else helpers
        self.started = 0
        self._processes: list[subprocess.Popen] = []

    def __enter__(self) -> CompileHelpers:
        self.start()
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()

    def start(self) -> None:
        """Compile the scenes' plan with the helpers, if the cache lacks it."""
        entries = load_plan().for_scenes(self.scenes)
        if self.helpers == 0 or not entries or _is_cached(entries[-1]):
            return  # no helpers wanted, or the scenes are warm (see compile_ahead)
        scenes = [] if self.scenes is None else ["--scene", *self.scenes]
        for _ in range(self.helpers):
            self._processes.append(
                subprocess.Popen(
                    [sys.executable, "-m", __name__, *scenes],
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        self.started = len(self._processes)
        try:
            compile_planned(entries)
        except BaseException:
            # interrupted while entering (Ctrl-C, SIGTERM): the context will not be exited
            self.stop()
            raise

    def stop(self) -> None:
        """Stop the helpers still at work."""
        for process in self._processes:
            process.terminate()
        for process in self._processes:
            process.wait()
        self._processes.clear()


def _main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", nargs="*", default=None)
    options = parser.parse_args(argv)
    compile_planned(load_plan().for_scenes(options.scene))


if __name__ == "__main__":
    _main()
