"""Calls and seconds of each stage of a world's steps (``World.profile``).

The step kernel counts each stage's calls and processor cycles during one call; the call's
wall time is shared among the stages it ran in proportion to their cycles (to their calls
where the target counts no cycles). The sharing is a small kernel over flat arrays: done in
Python, with a dict per stage, it cost a one-body step a tenth of its time.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.world.stage_names import STAGE_NAMES

__all__ = ["StageProfile"]


class StageProfile:
    """Running totals of each stage's calls and seconds, in ``STAGE_NAMES`` order."""

    def __init__(self):
        self.calls = np.zeros(len(STAGE_NAMES), np.int64)
        self.seconds = np.zeros(len(STAGE_NAMES))

    def add_kernel_call(self, seconds: float, cycles: np.ndarray, calls: np.ndarray) -> None:
        """Add one step-kernel call that took ``seconds`` of wall time, with the ``cycles`` and
        ``calls`` (each (len(STAGE_NAMES),) int64) it counted per stage."""
        share_call_time(seconds, cycles, calls, self.seconds, self.calls)

    def add_stage(self, stage: int, seconds: float) -> None:
        """Add one call of ``stage`` (an index in ``STAGE_NAMES``) that took ``seconds``."""
        self.calls[stage] += 1
        self.seconds[stage] += seconds

    def as_dict(self) -> dict[str, dict]:
        """{stage name: {"calls": int, "seconds": float}} for every stage, in order."""
        return {
            name: {"calls": calls, "seconds": seconds}
            for name, calls, seconds in zip(
                STAGE_NAMES, self.calls.tolist(), self.seconds.tolist(), strict=True
            )
        }


@njit(allocates=False)
def share_call_time(seconds, cycles, calls, total_seconds, total_calls):
    """Share ``seconds`` among the stages in proportion to ``cycles`` (to ``calls`` if no
    cycles were counted) into ``total_seconds``; add ``calls`` to ``total_calls``."""
    cycle_sum = 0
    call_sum = 0
    for k in range(cycles.shape[0]):
        cycle_sum += cycles[k]
        call_sum += calls[k]
    for k in range(cycles.shape[0]):
        if calls[k] == 0:
            continue
        total_calls[k] += calls[k]
        if cycle_sum > 0:
            total_seconds[k] += seconds * cycles[k] / cycle_sum
        else:
            total_seconds[k] += seconds * calls[k] / call_sum
