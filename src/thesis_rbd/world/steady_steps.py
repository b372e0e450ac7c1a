"""The stages of steady steps in one kernel call, for as many steps as they stay steady.

Each stage of a step is a kernel, and each kernel call from Python costs microseconds of
argument checks and unboxing: for one cube resting on a floor, more than the stages' work.
While a world is steady -- every body convex, gravity the only force, every body awake, and
penetration handled by time of impact (the default) -- each stage of its step is one known
kernel, so ``run_steady_steps`` runs them all in one call, step after step, in the world's
order:

    forces -> contacts -> integrate -> bounds -> broad_phase -> narrow_phase -> tunnelling
           -> time_of_impact -> impacts -> sleep

It stops at the first stage of a step that needs Python and says which: the broad phase when a
moving body left its fat box (the sweep-and-prune update), the tunnelling check when a body
moved further than its thickness, the time of impact when a contact has a body in free flight
(it may have run into something), and the sleep stage of a world that lets bodies sleep. The
world finishes that step stage by stage, as it steps any other scene, so the two paths are the
same computation (the tests compare their trajectories to the bit).

Each stage's time is counted in processor cycles (``_numba.cycle_counter``); the world shares the
call's wall time among the stages in proportion to their cycles, so ``World.profile`` keeps
its per-stage figures.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.cycle_counter import cycle_count
from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.broad_phase.bounds import candidate_pairs, update_fat_bounds
from thesis_rbd.collision.contact_set import FLOAT_WIDTH, INT_WIDTH
from thesis_rbd.collision.convex.contacts import (
    OUTPUT_FLOATS,
    OUTPUT_INTS,
    convex_contacts_for_pairs,
)
from thesis_rbd.dynamics.bodies import copy_state
from thesis_rbd.dynamics.contact_stats import BAD_BODY
from thesis_rbd.dynamics.impacts import any_free_body
from thesis_rbd.dynamics.integrators import integrate_bodies
from thesis_rbd.dynamics.resting_contact import solve_contacts
from thesis_rbd.world.stage_names import STAGE_NAMES

__all__ = ["FINISHED", "run_steady_steps"]

FORCES = STAGE_NAMES.index("forces")
CONTACTS = STAGE_NAMES.index("contacts")
INTEGRATE = STAGE_NAMES.index("integrate")
BOUNDS = STAGE_NAMES.index("bounds")
BROAD_PHASE = STAGE_NAMES.index("broad_phase")
NARROW_PHASE = STAGE_NAMES.index("narrow_phase")
TUNNELLING = STAGE_NAMES.index("tunnelling")
TIME_OF_IMPACT = STAGE_NAMES.index("time_of_impact")
SLEEP = STAGE_NAMES.index("sleep")
# the stop code of a call that ran every step it was asked for
FINISHED = -1


@njit
def run_steady_steps(
    steps, frozen, has_forces, sleeps,
    settings, polygon, method, dt, count, solved,
    position, orientation, linear_momentum, angular_momentum,
    inverse_mass, inverse_inertia_body, inertia_body, thickness, restitution, friction,
    external_force, drag, pf_start, pf_arm, pf_force,
    saved_position, saved_orientation, saved_linear_momentum, saved_angular_momentum,
    start_position, start_orientation, stats,
    size, horizon, fat, fast, fat_pairs, pair_members, box_offset, box_half, speculative,
    reach, tight, candidates, hull_of_body, hull_arrays, longest_loop, query_scratch,
    center_of_mass_local,
    contact_ints, contact_floats, contact_count, warm_keys, warm_values,
    acted_ints, acted_floats, acted_count, acted_impulses,
    cache_ints, cache_floats, cache_int_offset, cache_float_offset, cache_count,
    time, cycles, calls,
):  # fmt: skip
    """Run up to ``steps`` steady steps of a world whose bodies are all convex and awake.

    Parameters
    ----------
    steps : int
        Most steps to run.
    frozen : (>= n,) bool
        The static bodies (none may be asleep), as ``solve_contacts`` takes them.
    has_forces : bool
        Whether the world plans a forces stage (gravity, already in ``external_force``).
    sleeps : bool
        Whether the world plans a sleep stage: every step then stops there.
    settings ... pf_force
        As ``solve_contacts`` and ``integrate_bodies`` take them (``method`` a value of
        ``INTEGRATORS``; ``count`` bodies n).
    saved_position, saved_orientation, saved_linear_momentum, saved_angular_momentum
        Out: the state at the start of the last step begun (``BodyArrays.saved_state``).
    start_position, start_orientation, stats
        As ``integrate_bodies`` and ``solve_contacts`` write them.
    size ... center_of_mass_local
        The collision pipeline's (``CollisionPipeline.steady_arguments``): bounding radii,
        the fat-box horizon (s), fat boxes, fast flags, fat pairs and their bodies, mesh-frame
        boxes, the speculative fraction and reach, tight boxes, the candidate buffer (f, 2),
        and the hull set and its query scratch, as ``candidate_pairs`` and
        ``convex_contacts_for_pairs`` take them.
    contact_ints, contact_floats, contact_count
        The contacts where the bodies are now (a ``ContactSet``'s arrays and count).
    warm_keys, warm_values
        The warm start of the last contact stage (``WarmStart``).
    acted_ints, acted_floats, acted_count, acted_impulses
        What the last step's impulses acted at: its contacts and impulses (c, 3).
    cache_ints ... cache_count
        The convex pairs' coherence cache (see ``convex_contacts_for_pairs``).
    time : float
        The world's time (s); ``dt`` is added to it once per finished step, as the world
        adds it after a step run stage by stage.
    cycles, calls : (len(STAGE_NAMES),) int64
        Out: cycles spent in and calls of each stage during this call.

    Returns
    -------
    tuple
        ``done`` steps finished; the time after them; ``stop``, the stage at which the next
        step stopped for Python to finish it (``FINISHED`` if none did); ``bad_body``, the
        body a failed stage left non-finite (the state is then as at that step's start in
        the saved arrays), or -1; the contacts where the bodies are now (ints, floats,
        count); what the stopped or last step's impulses acted at (ints, floats, count,
        impulses) and what the step before's did (the same four); the warm start (keys,
        values); the coherence cache (its five arguments); the candidate count in
        ``candidates``; the fast-body count; the smallest (speed / radius)^2 of a moving
        body; whether a body left its fat box.
    """
    cycles[:] = 0
    calls[:] = 0
    previous = (acted_ints, acted_floats, acted_count, acted_impulses)
    acted = previous
    candidate_count, fast_count, slowest, refit = 0, 0, np.inf, False
    stop, bad = FINISHED, -1
    done = 0
    while done < steps:
        copy_state(
            count, position, orientation, linear_momentum, angular_momentum, saved_position,
            saved_orientation, saved_linear_momentum, saved_angular_momentum,
        )  # fmt: skip
        solved[:count] = False
        previous = acted
        acted = (np.empty(0, np.int64), np.empty(0), 0, np.empty((0, 3)))
        start = cycle_count()
        if has_forces:  # gravity alone: already in external_force
            calls[FORCES] += 1
        if contact_count > 0:
            impulses = np.empty((contact_count, 3))
            keys, values = np.empty((contact_count, 2), np.int64), np.empty((contact_count, 6))
            solve_contacts(
                settings, polygon, count, frozen, contact_ints, contact_floats, contact_count,
                position, orientation, linear_momentum, angular_momentum, inverse_mass,
                inverse_inertia_body, inertia_body, thickness, restitution, friction,
                external_force, drag, pf_start, pf_arm, pf_force, warm_keys, warm_values, keys,
                values, impulses, solved, stats,
            )  # fmt: skip
            warm_keys, warm_values = keys, values
            acted = (contact_ints, contact_floats, contact_count, impulses)
            start = _count_stage(CONTACTS, start, cycles, calls)
            if stats[BAD_BODY] >= 0:
                stop, bad = CONTACTS, stats[BAD_BODY]
                break
        bad = integrate_bodies(
            method, dt, count, frozen, solved, position, orientation, linear_momentum,
            angular_momentum, inverse_mass, inverse_inertia_body, external_force, drag,
            pf_start, pf_arm, pf_force, True, start_position, start_orientation,
        )  # fmt: skip
        start = _count_stage(INTEGRATE, start, cycles, calls)
        if bad >= 0:
            stop = INTEGRATE
            break
        refit, fast_count, slowest = update_fat_bounds(
            count, False, frozen, size, thickness, position, start_position, linear_momentum,
            inverse_mass, horizon, fat, fast,
        )  # fmt: skip
        start = _count_stage(BOUNDS, start, cycles, calls)
        if refit:  # the sweep-and-prune pairs must be brought up to date
            stop = BROAD_PHASE
            break
        candidate_count = 0
        if len(fat_pairs) > 0:
            candidate_count = candidate_pairs(
                fat_pairs, pair_members, box_offset, box_half, size, position, orientation,
                start_position, fast, thickness, speculative, reach, tight, frozen, candidates,
            )  # fmt: skip
            start = _count_stage(BROAD_PHASE, start, cycles, calls)
        contact_ints, contact_floats, contact_count = np.empty(0, np.int64), np.empty(0), 0
        if candidate_count > 0:
            pairs = candidates[:candidate_count]
            contact_ints = np.empty(OUTPUT_INTS * candidate_count, np.int64)
            contact_floats = np.empty(OUTPUT_FLOATS * candidate_count)
            contact_count = convex_contacts_for_pairs(
                pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position,
                orientation, center_of_mass_local, cache_ints, cache_floats, cache_int_offset,
                cache_float_offset, cache_count, speculative, reach, contact_ints,
                contact_floats,
            )  # fmt: skip
            cache_ints, cache_floats = contact_ints, contact_floats
            cache_int_offset, cache_float_offset = (
                INT_WIDTH * contact_count, FLOAT_WIDTH * contact_count
            )  # fmt: skip
            cache_count = candidate_count
            start = _count_stage(NARROW_PHASE, start, cycles, calls)
        if fast_count > 0:
            stop = TUNNELLING
            break
        if contact_count > 0 and any_free_body(contact_ints, contact_count, frozen, solved):
            stop = TIME_OF_IMPACT
            break
        if sleeps:
            stop = SLEEP
            break
        done += 1
        time += dt
    if stop == FINISHED:
        previous = acted  # the step before the last is of no use to the caller
    acted_ints, acted_floats, acted_count, acted_impulses = acted
    previous_ints, previous_floats, previous_count, previous_impulses = previous
    return (
        done, time, stop, bad, contact_ints, contact_floats, contact_count,
        acted_ints, acted_floats, acted_count, acted_impulses,
        previous_ints, previous_floats, previous_count, previous_impulses,
        warm_keys, warm_values, cache_ints, cache_floats, cache_int_offset, cache_float_offset,
        cache_count, candidate_count, fast_count, slowest, refit,
    )  # fmt: skip


@njit(allocates=False)
def _count_stage(stage, start, cycles, calls):
    """Add the cycles since ``start`` and one call to ``stage``; return the cycle count now."""
    now = cycle_count()
    cycles[stage] += now - start
    calls[stage] += 1
    return now
