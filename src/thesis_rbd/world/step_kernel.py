"""The step, written once: every stage of a world step in one kernel, in order, each behind
its guard.

    forces -> contacts -> integrate -> kinematic -> joints -> bounds -> broad_phase
           -> narrow_phase -> tunnelling -> time_of_impact -> impacts -> sleep

``run_steps`` runs steps from a given stage of the current one, as many as asked, and stops
at the first stage whose guard holds but whose work needs Python:

* ``forces`` while an applied force is active (gravity alone is already in the step's force);
* ``broad_phase`` when the fat boxes changed (the sweep-and-prune update);
* ``narrow_phase`` unless every body is convex and none asleep (mesh pairs, waking islands);
* ``tunnelling``, ``time_of_impact``, ``impacts`` and ``sleep`` whenever their guards hold.

The world runs that stage (``world.py``) and calls again from the next one, so the stage
order, every guard and the save at the start of a step exist here only; a stage is skipped,
uncalled, when its guard says it has nothing to do. Parts of the world a scene does not have
are passed as None (no contact response, no joint, no collision, not every body convex), and numba
compiles their stages out: a free-flying body compiles the integrator and nothing else.

Each stage's time is counted in processor cycles (``_numba.cycle_counter``); the world shares
the call's wall time among the stages in proportion to their cycles, so ``World.profile`` keeps
its per-stage figures.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.cycle_counter import cycle_count
from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.broad_phase.bounds import (
    candidate_pairs,
    tight_bounds,
    update_fat_bounds,
)
from thesis_rbd.collision.convex.contacts import find_convex_contacts
from thesis_rbd.dynamics.bodies import copy_state
from thesis_rbd.dynamics.contact_settings import SLOP
from thesis_rbd.dynamics.contact_stats import BAD_BODY
from thesis_rbd.dynamics.impacts import may_have_hit
from thesis_rbd.dynamics.integrators import integrate_bodies
from thesis_rbd.dynamics.joint_solver import step_jointed_bodies
from thesis_rbd.dynamics.kinematic import move_kinematic_bodies, moving_bodies
from thesis_rbd.dynamics.resting_contact import solve_contacts
from thesis_rbd.world.stage_names import STAGE_NAMES

__all__ = ["END_OF_STEP", "FINISHED", "run_steps"]

FORCES = STAGE_NAMES.index("forces")
CONTACTS = STAGE_NAMES.index("contacts")
INTEGRATE = STAGE_NAMES.index("integrate")
KINEMATIC = STAGE_NAMES.index("kinematic")
JOINTS = STAGE_NAMES.index("joints")
BOUNDS = STAGE_NAMES.index("bounds")
BROAD_PHASE = STAGE_NAMES.index("broad_phase")
NARROW_PHASE = STAGE_NAMES.index("narrow_phase")
TUNNELLING = STAGE_NAMES.index("tunnelling")
TIME_OF_IMPACT = STAGE_NAMES.index("time_of_impact")
IMPACTS = STAGE_NAMES.index("impacts")
SLEEP = STAGE_NAMES.index("sleep")
# where a call that resumes after the last stage starts: it only ends the step
END_OF_STEP = len(STAGE_NAMES)
# the stop code of a call that ran every step it was asked for
FINISHED = -1


@njit
def run_steps(
    steps, first, detect_only, time, dt, count, method, planned, gathers,
    frozen, awake, any_asleep, still_any, sleep_tolerance2,
    position, orientation, linear_momentum, angular_momentum,
    inverse_mass, inverse_inertia_body, inertia_body, thickness, restitution, friction,
    kinematic_velocity, kinematic_angular_velocity, external_force, drag, pf_start, pf_arm,
    pf_force,
    saved_position, saved_orientation, saved_linear_momentum, saved_angular_momentum,
    start_position, start_orientation, solved, reach_back,
    contact_group, joint_group, kinematic_group, detection_group, convex_group,
    contacts, acted, warm, cache,
    candidate_count, fast_count, slowest, fat_changed, refit_all, rewound,
    cycles, calls,
):  # fmt: skip
    """Run the stages of up to ``steps`` steps, from stage ``first`` of the current one.

    Parameters
    ----------
    steps : int
        Most steps to finish (the current one counts).
    first : int
        Index in ``STAGE_NAMES`` of the stage to begin with: 0 starts a step (its state is
        saved first); a call after a stage Python ran goes on from the next one
        (``END_OF_STEP`` after the last).
    detect_only : bool
        Run the detection stages of the current state and return (no step is finished): the
        contacts a scene starts with, or has after it changed.
    time : float
        The world's time (s); ``dt`` is added to it once per finished step.
    dt : float
    count : int
        Bodies n.
    method : int
        A value of ``INTEGRATORS``.
    planned : (len(STAGE_NAMES),) bool
        The stages the scene calls for.
    gathers : bool
        Whether applied forces are active (the forces stage is then Python's).
    frozen : (>= n,) bool
        Immovable: static, kinematic or asleep (the dynamics stages move none of them).
    awake, any_asleep, still_any : bool
        Whether any body moves, any sleeps, any awake body has a still-time.
    sleep_tolerance2 : float
        The sleep stage's speed tolerance squared (1/s^2): while every moving body is faster,
        and no body is still or touching, it has nothing to do.
    position ... friction, kinematic_velocity, kinematic_angular_velocity
        The body arrays (n rows or more), as ``integrate_bodies``, ``solve_contacts`` and
        ``move_kinematic_bodies`` take them. The frozen bodies with a kinematic velocity
        move in the kinematic stage, and are not stationary to the detection stages.
    external_force, drag, pf_start, pf_arm, pf_force
        The forces of the step (``AppliedForces.gather``).
    saved_position ... saved_angular_momentum
        Out: the state at the start of the last step begun (``BodyArrays.saved_state``).
    start_position, start_orientation : (>= n, 3), (>= n, 4) float64
        Out: where each body began the step (written when the scene collides).
    solved : (>= n,) bool
        Out: the bodies the contact stage moved this step.
    reach_back : (>= n,) float64
        Out: how far back (s) each body's path over this step goes, for the time of impact:
        ``dt``, less for a body the tunnelling stage caught part way.
    contact_group : tuple or None
        ``(settings, polygon, stats, joints)`` of the contact stage (``joints``: the
        ``JointSet``'s (ints, floats), None without joints); None without a contact response.
    joint_group : tuple or None
        ``(substeps, ints, floats, joint_start, island_joints, body_start, island_bodies,
        island_tree, neighbour_start, neighbour, fixed_base, parents, sides, jointed,
        unintegrated, substep_position, substep_orientation, impulse)`` of the joints stage
        (``World._joint_arguments``); None without joints. The integrator then skips the
        bodies ``unintegrated`` (>= n,) bool marks, the frozen and the jointed, which the
        joints stage moves.
    kinematic_group : tuple or None
        ``(kinematic_velocity, kinematic_angular_velocity)`` where the scene has kinematic
        bodies (the arrays above; the kinematic stage moves them); None without, which
        compiles the stage out.
    detection_group : tuple or None
        ``(size, horizon, fat, fast, fat_pairs, pair_members, box_offset, box_half,
        speculative, reach, tight, candidates)`` of the detection stages
        (``CollisionPipeline.detection_arguments``); None without collision stages.
    convex_group : tuple or None
        ``(hull_of_body, hull_arrays, longest_loop, query_scratch, center_of_mass_local)`` of
        the convex narrow phase; None unless every body is convex.
    contacts : tuple
        (ints, floats, count) of the ``ContactSet`` where the bodies are now.
    acted : tuple
        (ints, floats, count, impulses (c, 3)): what the current step's impulses acted at.
    warm : tuple
        (keys, values) of the warm start.
    cache : tuple
        The convex coherence cache's five arguments (``convex_contacts_for_pairs``).
    candidate_count, fast_count, slowest, fat_changed, refit_all, rewound
        The detection stages' hand-overs: candidate pairs written to the detection group's
        buffer, fast bodies, the smallest (speed / radius)^2, whether the fat boxes changed
        and whether they must all be refitted, whether the time of impact stepped a body back.
    cycles, calls : (len(STAGE_NAMES),) int64
        Out: cycles spent in and calls of each stage during this call.

    Returns
    -------
    tuple
        ``done`` steps finished; the time after them; ``stop``, the stage Python must run
        now (``FINISHED`` if none); ``bad``, the body a stage left non-finite (-1: none; the
        state is then as at the step's start in the saved arrays); the hand-overs
        ``contacts``, ``acted``, ``warm``, ``cache`` now, and as they were at the start of
        the step it stopped in if that step began after the call's first (None otherwise: the
        caller holds those, and boxing them back would cost a small scene's call a tenth of
        its time); then ``candidate_count``, ``fast_count``, ``slowest``,
        ``fat_changed``, ``refit_all`` and ``rewound``.
    """
    cycles[:] = 0
    calls[:] = 0
    no_ints, no_floats, no_impulses = np.empty(0, np.int64), np.empty(0), np.empty((0, 3))
    at_start = (contacts, acted, warm, cache)
    stop, bad = FINISHED, -1
    done = 0
    stage = first
    # the groups unpacked once (numba compiles out what a None group holds)
    if contact_group is not None:
        settings, polygon, stats, contact_joints = contact_group
    if detection_group is not None:
        (
            size, horizon, fat, fast, fat_pairs, pair_members, box_offset, box_half,
            speculative, reach, tight, candidates,
        ) = detection_group  # fmt: skip
    if convex_group is not None:
        hull_of_body, hull_arrays, longest_loop, query_scratch, com_local = convex_group
    # what the detection stages read as staying put this step: the frozen bodies but the
    # moving kinematic ones (``frozen`` itself in a scene without kinematic bodies)
    stationary = frozen
    moving_kinematic = np.zeros(0, np.bool_)
    if kinematic_group is not None:
        moving_kinematic = moving_bodies(count, kinematic_velocity, kinematic_angular_velocity)
        stationary = frozen[:count] & ~moving_kinematic
    if joint_group is not None:
        (
            joint_substeps, joint_ints, joint_floats, joint_start, island_joints, body_start,
            island_bodies, island_tree, neighbour_start, neighbour, fixed_base, tree_parents,
            tree_sides, jointed, unintegrated, substep_position, substep_orientation,
            joint_impulse,
        ) = joint_group  # fmt: skip
    while done < steps:
        start = cycle_count()
        if stage == FORCES:
            copy_state(
                count, position, orientation, linear_momentum, angular_momentum, saved_position,
                saved_orientation, saved_linear_momentum, saved_angular_momentum,
            )  # fmt: skip
            solved[:count] = False
            reach_back[:count] = dt
            at_start = (contacts, acted, warm, cache)
            acted = (no_ints, no_floats, 0, no_impulses)
            rewound = False
            if planned[FORCES]:
                if gathers:  # applied forces: gathered in Python
                    stop = FORCES
                    break
                calls[FORCES] += 1  # gravity alone: already in external_force
        if stage <= CONTACTS and contact_group is not None:
            if planned[CONTACTS] and awake and contacts[2] > 0:
                c = contacts[2]
                impulses = np.empty((c, 3))
                keys, values = np.empty((c, 2), np.int64), np.empty((c, 6))
                solve_contacts(
                    settings, polygon, count, frozen, contacts[0], contacts[1], c, position,
                    orientation, linear_momentum, angular_momentum, inverse_mass,
                    inverse_inertia_body, inertia_body, thickness, restitution, friction,
                    kinematic_velocity, kinematic_angular_velocity, external_force, drag,
                    pf_start, pf_arm, pf_force, warm[0], warm[1], keys, values, impulses,
                    solved, stats, contact_joints,
                )  # fmt: skip
                warm = (keys, values)
                acted = (contacts[0], contacts[1], c, impulses)
                start = _count_stage(CONTACTS, start, cycles, calls)
                if stats[BAD_BODY] >= 0:
                    stop, bad = CONTACTS, stats[BAD_BODY]
                    break
        if stage <= INTEGRATE and planned[INTEGRATE] and awake:
            skipped = frozen
            if joint_group is not None:
                for i in range(count):
                    unintegrated[i] = frozen[i] or jointed[i]
                skipped = unintegrated
            bad = integrate_bodies(
                method, dt, count, skipped, solved, position, orientation, linear_momentum,
                angular_momentum, inverse_mass, inverse_inertia_body, external_force, drag,
                pf_start, pf_arm, pf_force, detection_group is not None, start_position,
                start_orientation,
            )  # fmt: skip
            start = _count_stage(INTEGRATE, start, cycles, calls)
            if bad >= 0:
                stop = INTEGRATE
                break
        if stage <= KINEMATIC and kinematic_group is not None and awake:
            # before the joints stage, which places the bodies jointed to them from where
            # this leaves them
            move_kinematic_bodies(
                moving_kinematic, dt, kinematic_velocity, kinematic_angular_velocity, position,
                orientation, detection_group is not None, start_position, start_orientation,
            )  # fmt: skip
            start = _count_stage(KINEMATIC, start, cycles, calls)
        if stage <= JOINTS and joint_group is not None and awake:
            bad = step_jointed_bodies(
                joint_substeps, dt, count, frozen, solved, joint_ints, joint_floats, joint_start,
                island_joints, body_start, island_bodies, island_tree, neighbour_start, neighbour,
                fixed_base, tree_parents, tree_sides, substep_position, substep_orientation,
                position, orientation, linear_momentum, angular_momentum, inverse_mass,
                inverse_inertia_body, inertia_body, external_force, drag, pf_start, pf_arm,
                pf_force,
                detection_group is not None, start_position, start_orientation, joint_impulse,
                kinematic_velocity, kinematic_angular_velocity,
            )  # fmt: skip
            start = _count_stage(JOINTS, start, cycles, calls)
            if bad >= 0:
                stop = JOINTS
                break
        if detection_group is not None:
            if stage <= BOUNDS and planned[BOUNDS] and awake:
                refit, fast_count, slowest = update_fat_bounds(
                    count, refit_all, stationary, size, thickness, position, start_position,
                    linear_momentum, inverse_mass, horizon, fat, fast,
                )  # fmt: skip
                if refit_all:
                    # static, sleeping and still kinematic bodies do not move: their fat
                    # boxes are their tight boxes
                    tight_bounds(
                        np.flatnonzero(stationary[:count]), box_offset, box_half, size, position,
                        orientation, start_position, fast, thickness, speculative, reach, fat,
                    )  # fmt: skip
                    refit_all = False
                fat_changed = fat_changed or refit
                start = _count_stage(BOUNDS, start, cycles, calls)
            if stage <= BROAD_PHASE and planned[BROAD_PHASE] and awake:
                if fat_changed:  # the sweep-and-prune pairs must be brought up to date
                    stop = BROAD_PHASE
                    break
                if len(fat_pairs) > 0:
                    candidate_count = candidate_pairs(
                        fat_pairs, pair_members, box_offset, box_half, size, position,
                        orientation, start_position, fast, thickness, speculative, reach,
                        tight, stationary, candidates,
                    )  # fmt: skip
                    if candidate_count == 0:  # the narrow phase will not run this step
                        contacts = (no_ints, no_floats, 0)
                    start = _count_stage(BROAD_PHASE, start, cycles, calls)
            if stage <= NARROW_PHASE and planned[NARROW_PHASE] and awake and candidate_count > 0:
                if convex_group is None:
                    stop = NARROW_PHASE
                    break
                else:
                    if any_asleep:  # a touched island wakes: Python's
                        stop = NARROW_PHASE
                        break
                    contacts, cache = find_convex_contacts(
                        candidates[:candidate_count], hull_of_body, hull_arrays, longest_loop,
                        query_scratch, position, orientation, com_local, cache, speculative,
                        reach,
                    )  # fmt: skip
                    start = _count_stage(NARROW_PHASE, start, cycles, calls)
            if detect_only:
                break
            if stage <= TUNNELLING and planned[TUNNELLING] and awake and fast_count > 0:
                stop = TUNNELLING
                break
        if contact_group is not None:  # the time of impact is planned with a response only
            if stage <= TIME_OF_IMPACT and planned[TIME_OF_IMPACT] and awake and contacts[2] > 0:
                hit = may_have_hit(
                    contacts[0], contacts[1], contacts[2], frozen, solved, thickness,
                    settings[SLOP], count, position, start_position,
                )  # fmt: skip
                if hit:
                    stop = TIME_OF_IMPACT
                    break
        if stage <= IMPACTS and planned[IMPACTS] and rewound:
            stop = IMPACTS
            break
        if (
            stage <= SLEEP
            and planned[SLEEP]
            and awake
            and (contacts[2] > 0 or still_any or slowest <= sleep_tolerance2)
        ):
            stop = SLEEP
            break
        done += 1
        time += dt
        stage = FORCES
    if stop == FINISHED or done == 0:
        at_start = None
    return (
        done, time, stop, bad, contacts, acted, warm, cache, at_start, candidate_count,
        fast_count, slowest, fat_changed, refit_all, rewound,
    )  # fmt: skip


@njit(allocates=False)
def _count_stage(stage, start, cycles, calls):
    """Add the cycles since ``start`` and one call to ``stage``; return the cycle count now."""
    now = cycle_count()
    cycles[stage] += now - start
    calls[stage] += 1
    return now
