"""The contact stage: contact impulses computed before the positions move.

Velocity-level time stepping (Stewart and Trinkle 1996; Anitescu and Potra 1997): the contacts
found at the start of the step act across it. With v the velocities at the start of the step
and v* = v + dt M^-1 F the velocities the forces alone would give at its end, the stage finds
impulses lambda at the contacts such that v+ = v* + M^-1 J^T lambda satisfies, per contact,

    0 <= lambda_n  _|_  u_n+ + bias >= 0,      lambda_t in the friction polygon of mu lambda_n

(maximal dissipation), and the integrator then moves the bodies it touched with v+. A body
resting on a floor therefore never sinks under gravity: its v+ has no approach, so its
positions do not move into the floor (moving first and repairing afterwards sinks it
g dt^2 / 2 every step, 85 um at 240 Hz, most of a 1 mm part).

Per contact (tolerances in ``contact_settings``):

* a contact not touching yet (depth < 0: the narrow phase reports pairs within a small
  margin) may close its gap over the step and no more; one approaching it fast is left to the
  time of impact;
* a contact approaching faster than its bounce threshold (read from v, before the forces)
  bounces: compression of its approach before the step's forces (the forces act on as over
  any step), then e times that compression impulse (Poisson's restitution, which unlike
  Newton's law at simultaneous contacts never adds energy);
* a contact shallower than its slop may approach by ``BAUMGARTE`` of the difference per step,
  so that touching bodies settle to where their contact is found every step;
* penetration beyond the slop is removed at ``BAUMGARTE`` of it per step: by pseudo-velocities
  that move the bodies and leave no velocity behind where that creates no momentum (one body
  static, or the two at rest relative to each other; ``island_solver.correct_positions``),
  else through the velocity, an impulse at the contact point that conserves both momenta.

Everything runs in one kernel call per step, whatever the number of islands and contacts.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._pair_keys import pair_keys
from thesis_rbd._sorting import stable_argsort
from thesis_rbd.collision.contact_set import contact_views
from thesis_rbd.dynamics import contact_settings as cs
from thesis_rbd.dynamics.contact_kinematics import (
    body_velocities,
    contact_arms,
    contact_tolerances,
    normal_velocity,
    write_momenta,
)
from thesis_rbd.dynamics.contact_solver import contact_basis
from thesis_rbd.dynamics.contact_stats import BAD_BODY, ISLANDS, SWEEPS
from thesis_rbd.dynamics.integrators import body_forces
from thesis_rbd.dynamics.island_solver import correct_positions, island_tolerances, solve_islands
from thesis_rbd.dynamics.islands import find_islands, find_linked_islands, order_from_the_top
from thesis_rbd.dynamics.joint_set import BODY_A, BODY_B
from thesis_rbd.dynamics.jointed_contacts import joined_islands
from thesis_rbd.dynamics.materials import combined_friction, combined_restitution
from thesis_rbd.dynamics.pgs import build_rows
from thesis_rbd.dynamics.warm_start import MATCH_FRACTION, find_warm_impulses
from thesis_rbd.spatial.quaternion import to_matrix_into

__all__ = ["solve_contacts"]


@njit(separate=True)
def solve_contacts(
    settings, polygon, count, static, contact_ints, contact_floats, contact_count,
    position, orientation, linear_momentum, angular_momentum,
    inverse_mass, inverse_inertia_body, inertia_body, thickness, restitution, friction,
    kinematic_velocity, kinematic_angular_velocity, external_force, drag, pf_start, pf_arm,
    pf_force, old_keys, old_values, new_keys, new_values, impulse, solved, stats, joints,
):  # fmt: skip
    """Solve every island's contacts for this step and write the momenta of the bodies hit.

    Parameters
    ----------
    settings : (8,) float64
        ``ContactSettings.as_array(dt)``.
    polygon : (sides + 1, 2) float64
        ``pgs.friction_polygon(sides)``.
    count : int
        Number of bodies n.
    static : (>= n,) bool
        Bodies no impulse moves this step (static, kinematic or asleep).
    contact_ints, contact_floats, contact_count
        The c contacts at the start of the step, packed as a ``ContactSet``: bodies, world
        points, unit normals from b towards a, penetration depths (negative: a gap not yet
        closed), feature ids (-1: none).
    position, orientation, linear_momentum, angular_momentum
        Body state (>= n rows). The momenta of bodies hit by an impulse become P = M v+,
        L = I w+ (world); position correction moves bodies.
    inverse_mass, inverse_inertia_body, inertia_body, thickness, restitution, friction
        Body constants.
    kinematic_velocity, kinematic_angular_velocity : (>= n, 3) float64
        The velocities of the immovable bodies, world frame (``body_velocities``): a contact
        with a moving kinematic body sees its motion.
    external_force, drag, pf_start, pf_arm, pf_force
        The step's forces, as the integrator takes them.
    old_keys, old_values
        The previous step's contacts (``warm_start``'s keys and values).
    new_keys, new_values : (c, 2) int64, (c, 6) float64
        Out: the next step's warm start. (Results are written into arrays the
        caller passes, not returned: each array a kernel returns costs about a microsecond
        of boxing, much of a small scene's budget.)
    impulse : (c, 3) float64
        Out: (lambda_n, lambda_t1, lambda_t2) of each contact in its (n, t1, t2) frame.
    solved : (>= n,) bool
        Out: True for the bodies an impulse acted on (they move with v+); others untouched.
    stats : (6,) int64
        Out: the counters of ``contact_stats.STATS``; ``stats[BAD_BODY]`` is the first body
        whose new state is not finite (-1 if none).
    joints : tuple or None
        ``(ints, floats)`` of the world's ``JointSet``, None without joints. Joints join
        islands, and an island with joints is solved with their rows held
        (``jointed_contacts``); each of its bodies takes v+.
    """
    c = contact_count
    body_a, body_b, points, normals, depths, _, features = contact_views(
        contact_ints, contact_floats, c
    )
    n = count
    stats[:] = 0
    stats[BAD_BODY] = -1
    movable_mass = np.where(static[:n], 0.0, inverse_mass[:n])
    # islands; contacts re-ordered so that each island is one slice
    if joints is None:
        body_island, order, island_start = find_islands(n, body_a, body_b, static)
    else:
        joint_ints = joints[0]
        body_island, order, island_start = find_linked_islands(
            n, body_a, body_b, static, joint_ints[:, BODY_A], joint_ints[:, BODY_B]
        )
    order = order_from_the_top(n, body_a, body_b, static, order, island_start)
    stats[ISLANDS] = island_start.shape[0] - 1
    v0, w0, v, w, inverse_inertia = _velocities_before_and_after_forces(
        n, static, body_island, orientation, linear_momentum, angular_momentum, inverse_mass,
        inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity, external_force,
        drag, pf_start, pf_arm, pf_force, settings[cs.DT],
    )  # fmt: skip
    sa = body_a[order]
    sb = body_b[order]
    arm_a, arm_b = contact_arms(points, position, order, sa, sb)
    sorted_normals = normals[order]
    basis = contact_basis(sorted_normals)
    slop = contact_tolerances(sa, sb, static, thickness, settings[cs.SLOP])
    joined = joined_islands(joints, body_island, island_start.shape[0] - 1, position, orientation)
    carried = np.zeros(n, np.bool_)
    jointed = np.zeros(c, np.bool_)
    if joints is not None:
        joint_start = joined[0]
        for isl in range(island_start.shape[0] - 1):
            if joint_start[isl + 1] > joint_start[isl]:
                jointed[island_start[isl] : island_start[isl + 1]] = True
        for i in range(n):
            isl = body_island[i]
            carried[i] = isl >= 0 and joint_start[isl + 1] > joint_start[isl]
    bias, bounce, push, mu, tolerance = _contact_terms(
        settings, static, order, sa, sb, depths, sorted_normals, arm_a, arm_b, v0, w0, v, w,
        slop, restitution, friction, jointed,
    )  # fmt: skip
    keys, sorted_features, local, lam = _warm_start(
        settings, order, sa, sb, features, arm_a, basis, slop, orientation, old_keys, old_values
    )
    rows = build_rows(sa, sb, arm_a, arm_b, basis, movable_mass, inverse_inertia)
    had_impact = _any_positive(bounce)
    impact = np.zeros((c if had_impact else 0, 3))
    if had_impact:
        # an impact: resolved first, on the velocities before the forces, so that only its
        # own impulses rebound (a resting contact's share of the forces must not); then the
        # forces act on the velocities it left, and the contacts are solved as at rest
        impact_bias, impact_bounce = _impact_terms(
            island_start, bounce, depths, order, slop, sa, sb, restitution
        )
        after_v, after_w = v0.copy(), w0.copy()
        solve_islands(
            settings, polygon, island_start, sa, sb, arm_a, arm_b, basis, rows, impact_bias,
            impact_bounce, mu, tolerance, movable_mass, inverse_inertia, after_v, after_w,
            impact, stats, joints, joined,
        )  # fmt: skip
        v += after_v - v0
        w += after_w - w0
        v0, w0 = after_v, after_w
        bias, bounce, push, mu, tolerance = _contact_terms(
            settings, static, order, sa, sb, depths, sorted_normals, arm_a, arm_b, v0, w0, v,
            w, slop, restitution, friction, jointed,
        )  # fmt: skip
    # a moving island is solved to a fraction of its motion before the forces, one at rest to
    # the slop's tolerance (contact_settings)
    relaxed = island_tolerances(
        island_start, sa, sb, arm_a, arm_b, v0, w0, tolerance, settings[cs.RELATIVE_TOLERANCE]
    )
    solve_islands(
        settings, polygon, island_start, sa, sb, arm_a, arm_b, basis, rows, bias, bounce, mu,
        relaxed, movable_mass, inverse_inertia, v, w, lam, stats, joints, joined,
    )  # fmt: skip
    if had_impact:
        lam += impact
    stats[SWEEPS] += correct_positions(
        settings, island_start, sa, sb, basis, rows, push, tolerance, movable_mass, position,
        orientation,
    )  # fmt: skip
    stats[BAD_BODY] = _move_the_bodies_acted_on(
        static, sa, sb, lam, carried, v, w, position, orientation, inertia_body, inverse_mass,
        linear_momentum, angular_momentum, solved,
    )  # fmt: skip
    _remember_impulses(
        order, basis, lam, keys, sorted_features, local, impulse, new_keys, new_values
    )


@njit(inline="always")
def _velocities_before_and_after_forces(
    n, static, body_island, orientation, linear_momentum, angular_momentum, inverse_mass,
    inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity, external_force, drag,
    pf_start, pf_arm, pf_force, dt,
):  # fmt: skip
    """Body velocities before (v0, w0) and after (v, w) the step's forces, each (n, 3) (the
    forces act on the bodies of an island only: ``body_island`` (n,) >= 0), and the world
    inverse inertias (n, 3, 3)."""
    v0, w0, inverse_inertia = body_velocities(
        n, static, orientation, linear_momentum, angular_momentum, inverse_mass,
        inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity,
    )  # fmt: skip
    v = v0.copy()
    w = w0.copy()
    for i in range(n):
        if static[i] or body_island[i] < 0:
            continue
        F, T = body_forces(
            i, orientation[i], linear_momentum[i], angular_momentum[i], inverse_mass[i],
            inverse_inertia_body[i], external_force, drag, pf_start, pf_arm, pf_force,
        )  # fmt: skip
        Ii = inverse_inertia[i]
        for a in range(3):
            v[i, a] += dt * F[a] * inverse_mass[i]
            w[i, a] += dt * (Ii[a, 0] * T[0] + Ii[a, 1] * T[1] + Ii[a, 2] * T[2])
    return v0, w0, v, w, inverse_inertia


@njit(inline="always")
def _contact_terms(
    settings, static, order, sa, sb, depths, normals, arm_a, arm_b, v0, w0, v, w, slop,
    restitution, friction, jointed,
):  # fmt: skip
    """Each contact's row terms, in island order: ``bias`` (the velocity its normal row aims
    for), ``bounce`` (restitution), ``push`` (the pseudo-velocity that removes penetration
    beyond the slop at rest, -inf: none), ``mu`` and ``tolerance``, each (c,).

    The contacts of islands with joints (``jointed`` (c,) bool) differ in two ways. The time
    of impact steps single bodies back, which would pull them off their joints, so a jointed
    body that will close a gap within the step collides now, a step early at most, with its
    restitution (a speculative impact). And their penetration is removed through the
    velocities, as the joints allow, not by moving bodies without their joints (``push``)."""
    dt = settings[cs.DT]
    rate = settings[cs.BIAS_RATE]
    c = order.shape[0]
    bias = np.empty(c)
    bounce = np.zeros(c)
    push = np.full(c, -np.inf)
    mu = np.empty(c)
    tolerance = np.empty(c)
    for k in range(c):
        a, b = sa[k], sb[k]
        depth = depths[order[k]]
        u_before = normal_velocity(k, a, b, normals, arm_a, arm_b, v0, w0)
        u_forced = normal_velocity(k, a, b, normals, arm_a, arm_b, v, w)
        rest_speed = settings[cs.BOUNCE_SPEED] * slop[k] / dt
        relative = 0.0
        for i in range(3):
            relative += (v0[a, i] - v0[b, i]) ** 2
        at_rest = static[a] or static[b] or relative <= rest_speed * rest_speed
        approaching_fast = u_before < -(2.0 * abs(u_forced - u_before) + rest_speed)
        if (
            depth < 0.0 and approaching_fast and jointed[k] and u_before * dt < depth
            and combined_restitution(restitution, a, b) > 0.0
        ):  # fmt: skip
            bounce[k] = combined_restitution(restitution, a, b)
            bias[k] = u_before - u_forced
        elif depth < 0.0:
            # not touching yet (a speculative contact): it may close its gap this step; a
            # body flying at it is left to the time of impact, which catches its bounce
            bias[k] = np.inf if approaching_fast and not jointed[k] else -depth / dt
        elif approaching_fast:
            # compression stops the approach it had before the step's forces (their share
            # acts on as over any step), then e times that impulse pushes it back: the
            # forces' own impulse must not bounce, or their work would be added to the
            # rebound
            bounce[k] = combined_restitution(restitution, a, b)
            bias[k] = u_before - u_forced
        elif depth <= slop[k] or at_rest:
            bias[k] = 0.0
        else:
            bias[k] = -rate * (depth - slop[k]) / dt
        if depth > slop[k] and jointed[k]:
            bias[k] = min(bias[k], -rate * (depth - slop[k]) / dt)
        elif depth > slop[k] and at_rest:
            push[k] = rate * (depth - slop[k]) / dt
        mu[k] = combined_friction(friction, a, b)
        tolerance[k] = settings[cs.TOLERANCE] * slop[k] / dt
    return bias, bounce, push, mu, tolerance


@njit(inline="always")
def _any_positive(values):
    """Whether any of ``values`` (c,) is above zero (without the temporary of np.any)."""
    for k in range(values.shape[0]):
        if values[k] > 0.0:
            return True
    return False


@njit(inline="always")
def _impact_terms(island_start, bounce, depths, order, slop, sa, sb, restitution):
    """The rows' ``bias`` and ``bounce`` (c,) of the impact: in an island where a contact
    approaches fast (``bounce`` > 0), every touching contact takes part with bias 0 and
    rebounds with its pair's restitution (Poisson's simultaneous impact: a row of touching
    bodies passes the impact on and each contact gives back e of what it took); the other
    contacts and islands take no part (bias inf)."""
    c = bounce.shape[0]
    impact_bias = np.full(c, np.inf)
    impact_bounce = np.zeros(c)
    for isl in range(island_start.shape[0] - 1):
        s, e = island_start[isl], island_start[isl + 1]
        if not _any_positive(bounce[s:e]):
            continue
        for k in range(s, e):
            if depths[order[k]] >= -slop[k] or bounce[k] > 0.0:
                impact_bias[k] = 0.0
                impact_bounce[k] = combined_restitution(restitution, sa[k], sb[k])
    return impact_bias, impact_bounce


@njit(inline="always")
def _warm_start(
    settings, order, sa, sb, features, arm_a, basis, slop, orientation, old_keys, old_values
):  # fmt: skip
    """The contacts' pair keys and features (c,), their points in body a's frame (c, 3), and
    the impulses (c, 3) in their (n, t1, t2) frames that their predecessors in ``old_keys``,
    ``old_values`` ended the last step with (zero where none)."""
    c = order.shape[0]
    keys = pair_keys(sa, sb)
    sorted_features = features[order]
    local = np.empty((c, 3))
    radius = np.empty(c)
    R = np.empty((3, 3))
    for k in range(c):
        to_matrix_into(orientation[sa[k]], R)
        for a in range(3):
            local[k, a] = R[0, a] * arm_a[k, 0] + R[1, a] * arm_a[k, 1] + R[2, a] * arm_a[k, 2]
        radius[k] = MATCH_FRACTION * slop[k] / settings[cs.SLOP]
    warm = find_warm_impulses(keys, sorted_features, local, radius, old_keys, old_values)
    lam = np.empty((c, 3))
    for k in range(c):
        for d in range(3):
            lam[k, d] = basis[k, d, 0] * warm[k, 0] + basis[k, d, 1] * warm[k, 1]
            lam[k, d] += basis[k, d, 2] * warm[k, 2]
    return keys, sorted_features, local, lam


@njit(inline="always")
def _move_the_bodies_acted_on(
    static, sa, sb, lam, carried, v, w, position, orientation, inertia_body, inverse_mass,
    linear_momentum, angular_momentum, solved,
):  # fmt: skip
    """The bodies an impulse acted on take v+ (marked in ``solved``), and so do the bodies of
    islands with joints (``carried`` (n,)), whose velocities the joints' rows changed; the
    others keep their state untouched. Returns the first body whose new state is not finite
    (-1: none)."""
    hit = carried.copy()
    for k in range(sa.shape[0]):
        if lam[k, 0] != 0.0 or lam[k, 1] != 0.0 or lam[k, 2] != 0.0:
            hit[sa[k]] = not static[sa[k]]
            hit[sb[k]] = not static[sb[k]]
    moved = np.flatnonzero(hit)
    bad = write_momenta(
        moved, orientation, inertia_body, inverse_mass, v, w, linear_momentum, angular_momentum
    )
    for i in moved:
        solved[i] = True
        if bad < 0 and not math.isfinite(
            position[i, 0] + position[i, 1] + position[i, 2] + orientation[i, 3]
        ):
            bad = i
    return bad


@njit(inline="always")
def _remember_impulses(
    order, basis, lam, keys, sorted_features, local, impulse, new_keys, new_values
):  # fmt: skip
    """The impulses back in the caller's order (``impulse`` (c, 3)), and as world vectors,
    sorted by pair key, the next step's warm start (``new_keys``, ``new_values``)."""
    c = order.shape[0]
    world_impulse = np.empty((c, 3))
    for k in range(c):
        for a in range(3):
            world_impulse[k, a] = (
                lam[k, 0] * basis[k, 0, a] + lam[k, 1] * basis[k, 1, a] + lam[k, 2] * basis[k, 2, a]
            )
        for d in range(3):
            impulse[order[k], d] = lam[k, d]
    by_key = stable_argsort(keys)
    for m in range(c):
        k = by_key[m]
        new_keys[m, 0], new_keys[m, 1] = keys[k], sorted_features[k]
        for a in range(3):
            new_values[m, a] = local[k, a]
            new_values[m, 3 + a] = world_impulse[k, a]
