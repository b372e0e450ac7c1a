"""Compile every kernel ahead of use: what ``thesis-rbd warmup`` runs.

numba compiles a kernel on its first call and keeps the machine code in its on-disk cache, so
whatever the warm-up calls, later runs load instead of compiling. The warm-up runs every
built-in scene for a simulated second (between them they reach every stage of the pipeline:
free flight, bounds, the broad and narrow phases, contacts with and without friction,
tunnelling, sleep) and the public collision queries once in each mode. On a warm cache it
compiles nothing and takes a few seconds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from time import perf_counter

import numpy as np

from thesis_rbd._numba.compile_log import CompileLog, KernelCompile

__all__ = ["WarmupResult", "WarmupTask", "slowest_kernels", "warm_up", "warmup_tasks"]

SCENE_SECONDS = 1.0


@dataclass(frozen=True)
class WarmupTask:
    """One piece of the warm-up: a name and the work that calls kernels."""

    name: str
    work: Callable[[], None]


@dataclass(frozen=True)
class WarmupResult:
    """What one task took: its wall time and the compiles it caused."""

    name: str
    seconds: float
    compiles: list[KernelCompile]

    @property
    def compile_seconds(self) -> float:
        return sum(record.seconds for record in self.compiles if record.depth == 0)


def _run_scene(name: str) -> None:
    from thesis_rbd import scenes
    from thesis_rbd.trajectory import simulate

    simulate(scenes.get(name).build(), SCENE_SECONDS, record_contacts=True)


def _collision_queries() -> None:
    from thesis_rbd.collision import OBBTree, SweepAndPrune, collide
    from thesis_rbd.geometry import shapes

    tree_a = OBBTree(shapes.torus(1.0, 0.3, 24, 12))
    tree_b = OBBTree(shapes.box((0.5, 0.5, 0.5)))
    pose_a, pose_b = np.eye(4), np.eye(4)
    pose_b[:3, 3] = (1.0, 0.0, 0.0)  # the box sits on the torus's ring: they intersect
    for mode in ("first", "all", "contacts"):
        collide(tree_a, pose_a, tree_b, pose_b, mode=mode)
    sweep = SweepAndPrune()
    lower = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5], [3.0, 3.0, 3.0]])
    sweep.update(lower, lower + 1.0)
    sweep.update(lower + 0.25, lower + 1.25)


def warmup_tasks() -> list[WarmupTask]:
    """The warm-up's work: each built-in scene, then the collision queries."""
    from thesis_rbd import scenes

    tasks = [
        WarmupTask(f"scene {name}", lambda name=name: _run_scene(name)) for name in scenes.names()
    ]
    tasks.append(WarmupTask("collision queries", _collision_queries))
    return tasks


def warm_up(
    tasks: list[WarmupTask] | None = None,
    on_start: Callable[[WarmupTask], None] | None = None,
    on_compile: Callable[[str | None], None] | None = None,
    on_end: Callable[[WarmupResult], None] | None = None,
) -> list[WarmupResult]:
    """Run the warm-up tasks one after the other, recording the compiles of each.

    Parameters
    ----------
    tasks : list of WarmupTask, optional
        :func:`warmup_tasks` by default.
    on_start, on_end : callable, optional
        Told of each task before it runs and of its result after (a progress bar).
    on_compile : callable(name or None), optional
        Told the kernel numba starts compiling, and None when it is done.

    Returns
    -------
    list of WarmupResult
        One per task, in order.
    """
    results = []

    def compile_started(name: str) -> None:
        if on_compile is not None:
            on_compile(name)

    def compile_ended(_record: KernelCompile) -> None:
        if on_compile is not None:
            on_compile(None)

    for task in warmup_tasks() if tasks is None else tasks:
        if on_start is not None:
            on_start(task)
        start = perf_counter()
        with CompileLog(on_start=compile_started, on_end=compile_ended) as log:
            task.work()
        result = WarmupResult(task.name, perf_counter() - start, list(log.records))
        results.append(result)
        if on_end is not None:
            on_end(result)
    return results


def slowest_kernels(records: list[KernelCompile]) -> list[tuple[str, int, float]]:
    """Kernels by decreasing own compile time, summed over their signatures.

    Returns
    -------
    list of (name, signatures, seconds)
    """
    own: dict[str, list[float]] = {}
    for record in records:
        own.setdefault(record.name, []).append(record.own_seconds)
    ranked = sorted(own.items(), key=lambda item: sum(item[1]), reverse=True)
    return [(name, len(seconds), sum(seconds)) for name, seconds in ranked]
