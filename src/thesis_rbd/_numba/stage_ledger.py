"""Stage times of a run with numba's compiling kept apart.

numba compiles a kernel inside the first stage call that needs it, so on a first run
``World.profile`` counts seconds of compiling as seconds of that stage. The ledger looks at
the profile after every recorded frame of :func:`thesis_rbd.simulate`: the frames during
which a :class:`~thesis_rbd._numba.compile_log.CompileLog` saw a compile are set aside whole
(they are a few steps of a run), and the stage times of the others are what the stages cost.
"""

from __future__ import annotations

from time import perf_counter

from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd.world import World

__all__ = ["StageLedger"]


class StageLedger:
    """Split a run's profile into the frames that compiled kernels and the rest.

    Parameters
    ----------
    world : World
        The world being run, before the run starts.
    log : CompileLog
        Active over the run.

    Attributes
    ----------
    compiling_steps : int
        Steps of the frames during which kernels compiled.
    compiling_wall : float
        Wall time of those frames (s).
    compiling_profile : dict
        Their share of the profile, {stage: {"calls", "seconds"}}.
    """

    def __init__(self, world: World, log: CompileLog):
        self.world, self.log = world, log
        self.compiling_steps = 0
        self.compiling_wall = 0.0
        self.compiling_profile = {stage: {"calls": 0, "seconds": 0.0} for stage in world.profile}
        self._done = 0
        self._mark()

    def _mark(self) -> None:
        self._profile = {stage: dict(entry) for stage, entry in self.world.profile.items()}
        self._compile_seconds = self.log.seconds
        self._wall = perf_counter()

    def __call__(self, done: int, total: int) -> None:
        """After a recorded frame: set the frame aside if kernels compiled during it."""
        if self.log.seconds > self._compile_seconds:
            self.compiling_steps += done - self._done
            self.compiling_wall += perf_counter() - self._wall
            for stage, entry in self.world.profile.items():
                aside = self.compiling_profile.setdefault(stage, {"calls": 0, "seconds": 0.0})
                before = self._profile.get(stage, {"calls": 0, "seconds": 0.0})
                aside["calls"] += entry["calls"] - before["calls"]
                aside["seconds"] += entry["seconds"] - before["seconds"]
        self._done = done
        self._mark()

    def without_compiling(self, profile: dict) -> dict:
        """``profile`` (a run's, as :func:`thesis_rbd.simulate` reports it) less the frames that
        compiled kernels."""
        return {
            stage: {
                "calls": entry["calls"] - self.compiling_profile.get(stage, {"calls": 0})["calls"],
                "seconds": entry["seconds"]
                - self.compiling_profile.get(stage, {"seconds": 0.0})["seconds"],
            }
            for stage, entry in profile.items()
        }
