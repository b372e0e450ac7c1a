"""How a world hands its steady steps to one kernel call (``steady_steps.run_steady_steps``)
and takes back what the call did: the contacts, the warm start, the coherence cache, the
detection state, the time and each stage's share of the call's wall time. ``World``
inherits these; the kernel, and when a world is steady, are described in
``world/steady_steps.py``."""

from __future__ import annotations

from time import perf_counter

import numpy as np

from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.dynamics.integrators import INTEGRATORS
from thesis_rbd.world.stage_names import STAGE_NAMES
from thesis_rbd.world.steady_steps import CONTACTS, FINISHED, run_steady_steps

__all__ = ["WorldSteadySteps"]


class WorldSteadySteps:
    """The steady-step path of ``World``: it reads the world's planned stage arguments and
    writes the stage hand-overs, as the stages of ``world/world.py`` do."""

    def _gather_steady_arguments(self) -> None:
        """What ``run_steady_steps`` takes of the world, from ``has_forces`` to ``stats``,
        gathered once per plan; and the arrays it counts each stage's cycles and calls in."""
        b, pf = self.bodies, self._point_forces
        self._stage_cycles = np.zeros(len(STAGE_NAMES), np.int64)
        self._stage_calls = np.zeros(len(STAGE_NAMES), np.int64)
        self._steady_arguments = (
            self._pipeline[0][0] == "forces", self._pipeline[-1][0] == "sleep",
            self._settings, self._polygon, INTEGRATORS[self.integrator], self.dt, b.count,
            self._solved, *self._state, *self._constants,
            self._external_force, self._drag_array, pf.start, pf.arm, pf.force,
            *b.saved_state(), self._start_position, self._start_orientation,
            self._contact_stats,
        )  # fmt: skip

    def _steady_now(self) -> bool:
        """Whether the next steps may run in ``run_steady_steps``: a steady plan, every body
        awake, the contacts found and the detection ready for it."""
        return (
            self._steady
            and self._awake
            and not self._any_asleep
            and not self._contacts_stale
            and self._collision.steady_ready
        )

    def _run_steady_steps(self, steps: int) -> tuple[int, int, int]:
        """Run up to ``steps`` steps in one ``run_steady_steps`` call and take what it
        hands over. Returns the steps done, the stage at which the step after them stopped
        for Python to finish it (``FINISHED``: none did), and the body that stage left
        non-finite (-1: none; the state is then saved as at that step's start)."""
        c, warm = self._contacts, self._warm_start
        acted, acted_impulses = self._acted
        cycles, calls = self._stage_cycles, self._stage_calls
        start = perf_counter()
        (
            done, self.time, stop, bad, ints, floats, count, acted_ints, acted_floats,
            acted_count, impulses, previous_ints, previous_floats, previous_count,
            previous_impulses, warm.keys, warm.values, *cache, candidate_count,
            self._fast_count, self._slowest, refit,
        ) = run_steady_steps(
            steps, self._frozen, *self._steady_arguments,
            *self._collision.steady_arguments(self.dt),
            c.ints, c.floats, c.count, warm.keys, warm.values, acted.ints, acted.floats,
            acted.count, acted_impulses, *self._collision.convex_cache, self.time, cycles,
            calls,
        )  # fmt: skip
        self._share_profile(perf_counter() - start, cycles, calls)
        self._contacts = ContactSet(ints, floats, count)
        self._acted = (ContactSet(acted_ints, acted_floats, acted_count), impulses)
        self._candidates = self._collision.take_steady(refit, candidate_count, tuple(cache))
        if calls[CONTACTS]:
            self._impact_count = 0
        self.steps_taken += done
        if stop != FINISHED:
            # what a failure in the rest of the stopped step puts back: the contacts it began
            # with (those its impulses act at) and what the step before's impulses acted at
            previous = ContactSet(previous_ints, previous_floats, previous_count)
            self._saved = (self._acted[0], (previous, previous_impulses), self.applied_forces)
            self._rewound = False
        return done, stop, bad

    def _share_profile(self, seconds: float, cycles: np.ndarray, calls: np.ndarray) -> None:
        """Share a ``run_steady_steps`` call's wall time among the stages it ran, in
        proportion to their cycles (to their calls where the target counts no cycles)."""
        cycles, calls = cycles.tolist(), calls.tolist()
        total = sum(cycles)
        weights = cycles if total > 0 else calls
        scale = seconds / (total if total > 0 else max(sum(calls), 1))
        for name, count, weight in zip(STAGE_NAMES, calls, weights, strict=True):
            if count:
                entry = self.profile[name]
                entry["calls"] += count
                entry["seconds"] += scale * weight
