"""Impacts: bodies in free flight that ran into something during the step.

After the narrow phase, a contact is a *hit* when one of its bodies flew freely through the
step (the contact stage did not act on it), it penetrates and it approaches: the body met the
other during the step. A penetrating contact that recedes is a hit too if the pair was apart
at the start of the step (the body flew past the middle of a thin one). ``find_hits`` names
the first kind and the candidates of the second; the collision side
(``world/time_of_impact.py``) checks those candidates and steps the bodies back to the
time of impact; ``resolve_impacts`` then resolves each island with a stepped-back body in
two phases:

1. at the time of impact, the collision: Poisson's compression (no approach, with friction)
   and restitution, e times the compression impulse, for contacts approaching faster than
   their bounce threshold; no force acts during the instant of the collision, so a ball
   leaves the floor at exactly e times its impact speed. The answer decides how high and
   where the bodies fly, so PGS must meet a millionth of the impact speed, and a small
   island it cannot bring there is solved exactly. An island where nothing bounces (e = 0,
   or every approach below its bounce threshold) skips this phase: its collision would only
   stop the approach, which the second phase's solve does as well, from the same velocities
   plus the forces' share;
2. the rest of the step, t: the velocities the forces would give over t, and a resting-contact
   solve on them, as the contact stage does at the start of every step. A body that the second
   solve pushed (it came to rest, e = 0) moves with its new velocity; one it did not (it
   bounced away) follows its exact ballistic path over t.

Bodies of those islands that were not stepped back (at rest against a body hit) collide at
the island's time of impact too: they go back along their paths to it (they hardly moved) and
are carried on from there like the others, so a row of touching bodies moves off together.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.contact_set import contact_views
from thesis_rbd.dynamics import contact_settings as cs
from thesis_rbd.dynamics.ballistic import move_ballistic
from thesis_rbd.dynamics.contact_kinematics import (
    body_velocities,
    contact_arms,
    contact_slop,
    contact_tolerances,
    normal_velocity,
    write_momenta,
)
from thesis_rbd.dynamics.contact_solver import contact_basis
from thesis_rbd.dynamics.contact_stats import BAD_BODY, ISLANDS
from thesis_rbd.dynamics.integrators import body_forces
from thesis_rbd.dynamics.island_solver import island_tolerances, solve_islands
from thesis_rbd.dynamics.islands import find_islands, find_linked_islands
from thesis_rbd.dynamics.joint_set import BODY_A, BODY_B
from thesis_rbd.dynamics.jointed_contacts import joined_islands
from thesis_rbd.dynamics.materials import combined_friction, combined_restitution
from thesis_rbd.dynamics.pgs import build_rows

__all__ = ["IMPACT_TOLERANCE", "find_hits", "may_have_hit", "resolve_impacts"]

# PGS velocity tolerance of a collision with a rebound, relative to the fastest approach.
IMPACT_TOLERANCE = 1e-6


@njit(inline="always")
def may_have_hit(
    contact_ints, contact_floats, count, frozen, solved, thickness, slop_fraction, body_count,
    position, start_position,
):  # fmt: skip
    """Whether a contact may be a hit (``find_hits``): one of its bodies flew freely through
    the step (neither frozen nor moved by the contact stage), or one the contact stage moved
    is deeper than the contact's slop, which a resting contact is not (``contact_ints``,
    ``contact_floats``, ``count`` of a ``ContactSet``; the fields read straight from the
    packed layout, every step). A body the contact stage moved by less than half its slop
    (``position`` against ``start_position``, (n, 3)) cannot have run into anything: a
    resting scene answers from its bodies, without reading its contacts' depths."""
    for k in range(count):
        a, b = contact_ints[k], contact_ints[count + k]
        if not (frozen[a] or solved[a]) or not (frozen[b] or solved[b]):
            return True
    for i in range(body_count):
        if solved[i] and not frozen[i]:
            moved2 = 0.0
            for d in range(3):
                moved2 += (position[i, d] - start_position[i, d]) ** 2
            if moved2 > (0.5 * slop_fraction * thickness[i]) ** 2:
                break
    else:
        return False
    for k in range(count):
        a, b = contact_ints[k], contact_ints[count + k]
        if contact_floats[6 * count + k] > contact_slop(a, b, frozen, thickness, slop_fraction):
            return True
    return False


@njit
def find_hits(count, static, movers, solved, contact_ints, contact_floats, contact_count,
              position, orientation, linear_momentum, angular_momentum, inverse_mass,
              inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity, thickness,
              slop_fraction):  # fmt: skip
    """Contacts a moving body ran into during the step: it penetrates (depth > 0) and
    approaches. A body the contact stage moved (``solved``) ran into the other only where the
    contact is deeper than its slop: within it, it is a contact the body rests on.

    A penetrating contact of a body in free flight that does not approach is *receding*: the
    body either touched the other at the start of the step already and is leaving it, or it
    flew past the other's middle within the step (a small fast body through a thin plate),
    so that the least penetration now points out of the far side.
    ``time_of_impact.passed_through`` tells the two apart by the start-of-step poses.

    The contacts come packed (``contact_ints``, ``contact_floats``, ``contact_count`` of a
    ``ContactSet``), as the contact stage takes them: the fields are then sliced here, and
    the kernels both stages call are compiled for one kind of array.

    ``static`` marks the immovable bodies, whose velocities are ``kinematic_velocity`` and
    ``kinematic_angular_velocity`` (``body_velocities``): a body approaches a moving
    kinematic body relative to it.

    Returns ``hits`` (c,) bool, ``receding`` (c,) bool and the body velocities v, w (n, 3)
    at the end of the step.
    """
    body_a, body_b, points, normals, depths, _, _ = contact_views(
        contact_ints, contact_floats, contact_count
    )
    c = contact_count
    v, w, _ = body_velocities(
        count, static, orientation, linear_momentum, angular_momentum, inverse_mass,
        inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity,
    )  # fmt: skip
    hits = np.zeros(c, np.bool_)
    receding = np.zeros(c, np.bool_)
    arm_a = np.empty((c, 3))
    arm_b = np.empty((c, 3))
    for k in range(c):
        for a in range(3):
            arm_a[k, a] = points[k, a] - position[body_a[k], a]
            arm_b[k, a] = points[k, a] - position[body_b[k], a]
    for k in range(c):
        a, b = body_a[k], body_b[k]
        if not (movers[a] or movers[b]) or depths[k] <= 0.0:
            continue
        flew = (movers[a] and not solved[a]) or (movers[b] and not solved[b])
        if not flew and depths[k] <= contact_slop(a, b, static, thickness, slop_fraction):
            continue
        hits[k] = normal_velocity(k, a, b, normals, arm_a, arm_b, v, w) < 0.0
        receding[k] = not hits[k]
    return hits, receding, v, w


@njit
def resolve_impacts(
    settings, polygon, count, static, solved, rewind, contact_ints, contact_floats,
    contact_count,
    position, orientation, linear_momentum, angular_momentum, inverse_mass,
    inverse_inertia_body, inertia_body, thickness, restitution, friction,
    kinematic_velocity, kinematic_angular_velocity, external_force, drag, pf_start, pf_arm,
    pf_force, impulse, joints,
):  # fmt: skip
    """Resolve the islands with a stepped-back body and carry them to the end of the step.

    Parameters
    ----------
    settings, polygon, count, static
        As ``resting_contact.solve_contacts``.
    solved : (>= n,) bool
        Bodies the contact stage moved: their velocities hold the step's forces already, so
        no force acts on them over the rest of the step.
    rewind : (>= n,) float64
        In: how far each body was stepped back (0: not). Out: how long before the end of
        the step each body carried on collided: a body of an island with a stepped-back
        body that was not stepped back itself (one resting on a body hit) collides at the
        island's time of impact too, and is carried on from there with what it was given.
    contact_ints, contact_floats, contact_count
        The contact set after the time-of-impact stage (c rows), packed as a ``ContactSet``.
    position ... friction
        Body state and constants; state of the islands' bodies updated in place.
    kinematic_velocity, kinematic_angular_velocity : (>= n, 3) float64
        The immovable bodies' velocities (``body_velocities``): a body collides with a moving
        kinematic body at their relative velocity.
    external_force, drag, pf_start, pf_arm, pf_force
        The step's forces.
    impulse : (c, 3) float64
        Out: each contact's total impulse in its (n, t1, t2) frame (zero outside the islands).
    joints : tuple or None
        As ``solve_contacts``'s: joints join islands, a whole island goes back to its time
        of impact, and an island with joints is solved with them held.

    Returns
    -------
    stats : (6,) int64
        ``contact_stats.STATS``.
    resolved : (c,) bool
        The contacts of the resolved islands.
    pushed : (n,) bool
        The bodies whose velocities the resting solve of the rest of the step set: like the
        contact stage's, they hold the forces' share of the rest of the step already.
    """
    body_a, body_b, points, normals, depths, _, _ = contact_views(
        contact_ints, contact_floats, contact_count
    )
    dt = settings[cs.DT]
    n = count
    stats = np.zeros(6, np.int64)
    stats[BAD_BODY] = -1
    resolved, sel, sub_start, body_island, island_time, member = _impact_islands(
        n, body_a, body_b, static, rewind, joints
    )
    kept = sel.shape[0]
    if kept == 0:
        return stats, resolved, np.zeros(n, np.bool_)
    stats[ISLANDS] = sub_start.shape[0] - 1
    sa, sb = body_a[sel], body_b[sel]
    arm_a, arm_b = contact_arms(points, position, sel, sa, sb)
    sub_normals = normals[sel]
    basis = contact_basis(sub_normals)
    slop = contact_tolerances(sa, sb, static, thickness, settings[cs.SLOP])
    v, w, inverse_inertia = body_velocities(
        n, static, orientation, linear_momentum, angular_momentum, inverse_mass,
        inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity,
    )  # fmt: skip
    v0 = v.copy()
    acceleration, alpha = _accelerations(
        n, static, orientation, linear_momentum, angular_momentum, inverse_mass,
        inverse_inertia_body, inverse_inertia, external_force, drag, pf_start, pf_arm, pf_force,
    )  # fmt: skip
    for i in range(n):
        if solved[i]:
            for a in range(3):
                acceleration[i, a] = 0.0
                alpha[i, a] = 0.0

    # 1. the collision at the time of impact
    movable_mass = np.where(static[:n], 0.0, inverse_mass[:n])
    rows = build_rows(sa, sb, arm_a, arm_b, basis, movable_mass, inverse_inertia)
    bias, bounce, mu, tolerance = _collision_terms(
        settings, sel, sub_start, sa, sb, depths, sub_normals, arm_a, arm_b, v, w,
        acceleration, slop, restitution, friction,
    )  # fmt: skip
    # the joints of each kept island, numbered as sub_start numbers them
    sub_island = np.full(n, -1)
    kept_index = np.cumsum(island_time > 0.0) - 1
    for i in range(n):
        if member[i]:
            sub_island[i] = kept_index[body_island[i]]
    joined = joined_islands(joints, sub_island, sub_start.shape[0] - 1, position, orientation)
    lam = np.zeros((kept, 3))
    solve_islands(
        settings, polygon, sub_start, sa, sb, arm_a, arm_b, basis, rows, bias, bounce, mu,
        tolerance, movable_mass, inverse_inertia, v, w, lam, stats, joints, joined,
    )  # fmt: skip

    # 2. the rest of the step: forces over it, then resting contact
    v1 = v.copy()
    w1 = w.copy()
    for i in range(n):
        t = rewind[i]
        if t > 0.0:
            for a in range(3):
                v[i, a] += t * acceleration[i, a]
                w[i, a] += t * alpha[i, a]
    for k in range(kept):
        # hold touching contacts; one not touching yet may close its gap
        bias[k] = max(-depths[sel[k]], 0.0) / dt
        bounce[k] = 0.0
        tolerance[k] = settings[cs.TOLERANCE] * slop[k] / dt
    rest = np.zeros((kept, 3))
    # the rest of the step to a fraction of the motion the collision left (contact_settings)
    relaxed = island_tolerances(
        sub_start, sa, sb, arm_a, arm_b, v1, w1, tolerance, settings[cs.RELATIVE_TOLERANCE]
    )
    solve_islands(
        settings, polygon, sub_start, sa, sb, arm_a, arm_b, basis, rows, bias, bounce, mu,
        relaxed, movable_mass, inverse_inertia, v, w, rest, stats, joints, joined,
    )  # fmt: skip

    # 3. the bodies carried to the end of the step
    _back_to_collision(
        n, member, rewind, body_island, island_time, v0, angular_momentum,
        inverse_inertia_body, acceleration, position, orientation,
    )  # fmt: skip
    stats[BAD_BODY], pushed = _carry_to_end_of_step(
        n, static, member, joints is not None, solved, rewind, sa, sb, rest, v, w, v1, w1,
        acceleration, position, orientation,
        linear_momentum, angular_momentum, inverse_mass, inverse_inertia_body, inertia_body,
        external_force, drag, pf_start, pf_arm, pf_force,
    )  # fmt: skip
    for k in range(kept):
        for d in range(3):
            impulse[sel[k], d] = lam[k, d] + rest[k, d]
    return stats, resolved, pushed


@njit(inline="always")
def _back_to_collision(
    n, member, rewind, body_island, island_time, v0, angular_momentum, inverse_inertia_body,
    acceleration, position, orientation,
):  # fmt: skip
    """Step the bodies of the islands (``member`` (n,) bool) that were not stepped back to
    their island's time of impact along their paths before it (velocities ``v0`` (n, 3) at
    the end of the step, scratch), and set their ``rewind``: the collision changed their
    velocities then, so they are carried on from there like the others."""
    for i in range(n):
        if not member[i] or rewind[i] > 0.0:
            continue
        t = island_time[body_island[i]]
        move_ballistic(
            np.array([i]), -t, v0, angular_momentum, inverse_inertia_body, acceleration,
            position, orientation,
        )  # fmt: skip
        rewind[i] = t


@njit(inline="always")
def _impact_islands(n, body_a, body_b, static, rewind, joints):
    """The contacts of the islands that hold a stepped-back body: ``resolved`` (c,) bool,
    their rows ``sel`` (k,) int64 island by island, each island's first row in ``sel``
    (``sub_start`` (islands + 1,) int64), the island of each body (n,) int64 (-1: none)
    with the islands' times of impact (the longest rewind of their bodies, s), and the
    bodies of those islands (``member`` (n,) bool). Joints (``solve_contacts``'s) join
    islands."""
    c = body_a.shape[0]
    if joints is None:
        body_island, order, island_start = find_islands(n, body_a, body_b, static)
    else:
        body_island, order, island_start = find_linked_islands(
            n, body_a, body_b, static, joints[0][:, BODY_A], joints[0][:, BODY_B]
        )
    islands = island_start.shape[0] - 1
    island_time = np.zeros(islands)
    for i in range(n):
        if body_island[i] >= 0:
            island_time[body_island[i]] = max(island_time[body_island[i]], rewind[i])
    member = np.zeros(n, np.bool_)
    for i in range(n):
        member[i] = body_island[i] >= 0 and island_time[body_island[i]] > 0.0
    # keep the contacts of islands with a stepped-back body, island by island
    keep = np.zeros(c, np.bool_)
    starts = [0]
    kept = 0
    for isl in range(islands):
        if island_time[isl] <= 0.0:
            continue
        for idx in range(island_start[isl], island_start[isl + 1]):
            keep[order[idx]] = True
        kept += island_start[isl + 1] - island_start[isl]
        starts.append(kept)
    sel = np.empty(kept, np.int64)
    m = 0
    for isl in range(islands):
        if island_time[isl] > 0.0:
            for idx in range(island_start[isl], island_start[isl + 1]):
                sel[m] = order[idx]
                m += 1
    return keep, sel, np.array(starts, np.int64), body_island, island_time, member


@njit(inline="always")
def _accelerations(
    n, static, orientation, linear_momentum, angular_momentum, inverse_mass,
    inverse_inertia_body, inverse_inertia, external_force, drag, pf_start, pf_arm, pf_force,
):  # fmt: skip
    """Each body's linear and angular acceleration over the step (n, 3), for the bounce
    thresholds and the rest of the step."""
    acceleration = np.zeros((n, 3))
    alpha = np.zeros((n, 3))
    for i in range(n):
        if static[i]:
            continue
        F, T = body_forces(
            i, orientation[i], linear_momentum[i], angular_momentum[i], inverse_mass[i],
            inverse_inertia_body[i], external_force, drag, pf_start, pf_arm, pf_force,
        )  # fmt: skip
        Ii = inverse_inertia[i]
        for a in range(3):
            acceleration[i, a] = F[a] * inverse_mass[i]
            alpha[i, a] = Ii[a, 0] * T[0] + Ii[a, 1] * T[1] + Ii[a, 2] * T[2]
    return acceleration, alpha


@njit(inline="always")
def _collision_terms(
    settings, sel, sub_start, sa, sb, depths, normals, arm_a, arm_b, v, w, acceleration, slop,
    restitution, friction,
):  # fmt: skip
    """The rows' terms of the collision at the time of impact: ``bias``, ``bounce``, ``mu``
    and ``tolerance`` (k,) of the contacts ``sel``. An island rebounds when one of its
    contacts approaches faster than the step's forces could make it, and then every touching
    contact of it rebounds (Poisson); an island without a rebound only stops its approach,
    which the resting solve after it does too, so it is left out (bias inf)."""
    dt = settings[cs.DT]
    kept = sel.shape[0]
    bias = np.empty(kept)
    bounce = np.zeros(kept)
    mu = np.empty(kept)
    tolerance = np.empty(kept)
    fastest = 0.0
    for k in range(kept):
        a, b = sa[k], sb[k]
        u = normal_velocity(k, a, b, normals, arm_a, arm_b, v, w)
        fastest = max(fastest, abs(u))
        du = 0.0
        for i in range(3):
            du += normals[k, i] * dt * (acceleration[a, i] - acceleration[b, i])
        threshold = 2.0 * abs(du) + settings[cs.BOUNCE_SPEED] * slop[k] / dt
        if u < -threshold:
            bounce[k] = combined_restitution(restitution, a, b)
        # a contact not touching yet (beyond round-off: within the slop) takes no part in the
        # collision
        bias[k] = 0.0 if depths[sel[k]] >= -slop[k] else np.inf
        mu[k] = combined_friction(friction, a, b)
    for isl in range(sub_start.shape[0] - 1):
        s, e = sub_start[isl], sub_start[isl + 1]
        rebound = False
        for k in range(s, e):
            rebound |= bounce[k] > 0.0
        for k in range(s, e):
            tolerance[k] = IMPACT_TOLERANCE * fastest
            if not rebound:
                bias[k] = np.inf  # the collision only stops the approach: phase 2 does that
            elif bias[k] == 0.0:
                # Poisson's simultaneous impact: every touching contact of the island gives
                # back e of what it took (a row of touching bodies passes the impact on)
                bounce[k] = combined_restitution(restitution, sa[k], sb[k])
    return bias, bounce, mu, tolerance


@njit(inline="always")
def _carry_to_end_of_step(
    n, static, member, jointed, solved, rewind, sa, sb, rest, v, w, v1, w1, acceleration,
    position, orientation, linear_momentum, angular_momentum, inverse_mass,
    inverse_inertia_body, inertia_body, external_force, drag, pf_start, pf_arm, pf_force,
):  # fmt: skip
    """Write the islands' momenta and move their stepped-back bodies to the end of the step;
    returns the first body whose momenta are not finite (-1: none) and which bodies the
    resting solve pushed (n,) bool.

    Momenta are written where the collision happened: L = I w holds at the orientation of the
    time of impact, and the motion over the rest of the step then keeps L (it turns the body,
    not its angular momentum). A stepped-back body the resting solve did not push (``rest``
    zero) flies on ballistically with the collision's velocities ``v1``, ``w1`` (its forces act
    over the time after the collision); one it pushed moves with the velocities ``v``, ``w``
    of that solve, which hold the forces' share already. With joints (``jointed``), every
    body of the islands (``member`` (n,) bool) moves with the solve's velocities: the joints
    held in it changed them all."""
    pushed = member.copy() if jointed else np.zeros(n, np.bool_)
    touched = member.copy()
    for k in range(sa.shape[0]):
        for i in (sa[k], sb[k]):
            if static[i]:
                continue
            if rest[k, 0] != 0.0 or rest[k, 1] != 0.0 or rest[k, 2] != 0.0:
                pushed[i] = True
    flying = np.zeros(n, np.bool_)
    for i in range(n):
        if rewind[i] > 0.0 and touched[i] and not pushed[i]:
            flying[i] = True
            for a in range(3):
                v[i, a] = v1[i, a]
                w[i, a] = w1[i, a]
    bad = write_momenta(
        np.flatnonzero(touched), orientation, inertia_body, inverse_mass, v, w,
        linear_momentum, angular_momentum,
    )  # fmt: skip
    still = np.zeros((n, 3))
    for i in range(n):
        t = rewind[i]
        if t <= 0.0 or not touched[i]:
            continue
        one = np.array([i])
        if flying[i]:
            move_ballistic(
                one, t, v, angular_momentum, inverse_inertia_body, acceleration, position,
                orientation,
            )  # fmt: skip
            _, T = body_forces(
                i, orientation[i], linear_momentum[i], angular_momentum[i], inverse_mass[i],
                inverse_inertia_body[i], external_force, drag, pf_start, pf_arm, pf_force,
            )  # fmt: skip
            torque_time = 0.0 if solved[i] else t  # a solved body's L holds its torques
            for a in range(3):
                linear_momentum[i, a] = v[i, a] / inverse_mass[i]
                angular_momentum[i, a] += torque_time * T[a]
        else:
            move_ballistic(
                one, t, v, angular_momentum, inverse_inertia_body, still, position, orientation
            )
    return bad, pushed
