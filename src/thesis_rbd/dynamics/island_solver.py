"""Solving the contacts of every island: impulses, restitution, and position correction.

The contacts arrive sorted by island (island i is the slice ``island_start[i]:island_start[i+1]``)
with their frames and the rows of ``pgs.build_rows``. Three operations, each one loop over the
islands inside numba:

* ``solve_islands``: the velocity problem of each island by projected Gauss-Seidel warm
  started from the previous step, or exactly by Lemke's method when the settings ask for it, or
  ("auto") when PGS has not converged on an island of at most ``EXACT_LIMIT`` contacts, which
  is what holds a heavy body on a light one; then Poisson's restitution, e times each bouncing
  contact's compression impulse. A big island (a heap) gets conjugate-gradient steps on its
  active rows between its sweeps (:mod:`.subspace`), which carry a load across the heap in
  a few steps where sweeps move it one contact at a time.
* ``correct_positions``: removes penetration beyond the slop at contacts where that creates no
  momentum (Bullet's split impulse, restricted): a normal-only solve on pseudo-velocities
  that move the bodies over the step and are then forgotten, so no velocity is left behind and
  a resting stack does not jitter. Moving two bodies apart by J / m while they slide past each
  other would change the angular momentum by dt J x v_rel, so it is done only where one body is
  static or the two are at rest relative to each other; elsewhere the contact stage corrects
  through the velocities instead (an impulse at the contact point, which conserves both
  momenta exactly).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics import contact_settings as cs
from thesis_rbd.dynamics.contact_kinematics import relative_velocity
from thesis_rbd.dynamics.contact_solver import REBOUND_EXACT_CONTACTS, solve_exact
from thesis_rbd.dynamics.contact_stats import EXACT_ISLANDS, MAX_SWEEPS, SWEEPS, UNCONVERGED
from thesis_rbd.dynamics.jointed_contacts import solve_jointed_island
from thesis_rbd.dynamics.pgs import sweep_island
from thesis_rbd.dynamics.subspace import SUBSPACE_CONTACTS, sweep_with_subspace_steps
from thesis_rbd.spatial.quaternion import mul, normalize

__all__ = ["correct_positions", "island_tolerances", "solve_islands"]


@njit
def island_tolerances(island_start, body_a, body_b, arm_a, arm_b, v, w, tolerance, relative):
    """Each contact's PGS tolerance, raised to a fraction of its island's fastest motion.

    Parameters
    ----------
    island_start : (m + 1,) int64
        Island i is the contacts ``island_start[i]:island_start[i + 1]``.
    body_a, body_b : (c,) int64
    arm_a, arm_b : (c, 3) float64
        Each contact's bodies and arms from their centres of mass (world frame).
    v, w : (n, 3) float64
        Body velocities to measure the motion with (world frame): those before the step's
        forces, so that a resting island, whose only motion is the g dt the forces add, keeps
        its own tolerances.
    tolerance : (c,) float64
        Each contact's own velocity tolerance (m/s).
    relative : float
        The fraction of the island's fastest contact-point speed |u_a - u_b| allowed.

    Returns
    -------
    (c,) float64
        max(tolerance, relative x the island's fastest contact-point speed), a fresh array.
    """
    out = tolerance.copy()
    for isl in range(island_start.shape[0] - 1):
        s, e = island_start[isl], island_start[isl + 1]
        fastest = 0.0
        for k in range(s, e):
            u = relative_velocity(k, body_a[k], body_b[k], arm_a, arm_b, v, w)
            fastest = max(fastest, u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        floor = relative * np.sqrt(fastest)
        for k in range(s, e):
            out[k] = max(out[k], floor)
    return out


@njit(separate=True)
def solve_islands(
    settings, polygon, island_start, body_a, body_b, arm_a, arm_b, basis, rows, bias, bounce,
    friction, tolerance, inverse_mass, inverse_inertia, v, w, impulse, stats, joints, joined,
):  # fmt: skip
    """Solve each island's contacts, then add Poisson's restitution, in place.

    Restitution (an island with a ``bounce``): each contact's compression impulse times its
    ``bounce`` is added, then the island is solved again with every taking part contact's
    bias zero, from zero impulses: where the rebound of one contact drives two bodies into
    each other (a row of touching bodies hit at one end), that contact stops approaching.
    With one restitution for the island this is Poisson's simultaneous impact, which conserves
    momentum and never adds kinetic energy (the second solve is inelastic: it only takes
    energy out).

    Parameters
    ----------
    settings, polygon
        ``ContactSettings.as_array(dt)`` and ``pgs.friction_polygon(sides)``.
    island_start : (m + 1,) int64
    body_a, body_b, arm_a, arm_b, basis
        The island-sorted contacts (c rows): bodies, arms from each centre of mass (world),
        frames (rows n, t1, t2).
    rows : tuple
        ``pgs.build_rows`` of those contacts.
    bias, bounce, friction, tolerance : (c,) float64
        Normal bias (u_n + bias >= 0; +inf for a contact that takes no part, and an island
        none of whose contacts take part is skipped), restitution of each contact (0: none),
        friction coefficient, velocity tolerance of PGS (m/s).
    inverse_mass : (n,) float64
        Zero for bodies that must not move.
    inverse_inertia : (n, 3, 3) float64
        World frame.
    v, w : (n, 3) float64
        Body velocities, updated with every impulse.
    impulse : (c, 3) float64
        Warm start in, answer out, in each contact's (n, t1, t2) frame.
    stats : (6,) int64
        ``contact_stats.STATS`` counters, updated.
    joints : tuple or None
        The ``JointSet``'s (ints, floats); None: no joints.
    joined : tuple
        ``jointed_contacts.joined_islands``: the joints of each island and the poses. An
        island with joints is solved with them held (``jointed_contacts``).
    """
    angular_a, angular_b, response_a, response_b, normal_step, tangent_step, coupling = rows
    solver = int(settings[cs.SOLVER])
    iterations = int(settings[cs.ITERATIONS])
    sides = polygon.shape[0] - 1
    v_start = v.copy()
    w_start = w.copy()
    for isl in range(island_start.shape[0] - 1):
        s, e = island_start[isl], island_start[isl + 1]
        taking_part = False
        rebounds = False
        for k in range(s, e):
            taking_part |= bias[k] != np.inf
            rebounds |= bounce[k] > 0.0
        if not taking_part:
            continue
        if joints is not None:
            joint_start, joint_list, position, orientation = joined
            if joint_start[isl + 1] > joint_start[isl]:
                solve_jointed_island(
                    s, e, settings, polygon, body_a, body_b, arm_a, arm_b, basis, bias, bounce,
                    friction, tolerance, inverse_mass, inverse_inertia, v, w, impulse, stats,
                    joint_list[joint_start[isl] : joint_start[isl + 1]], joints[0], joints[1],
                    position, orientation,
                )  # fmt: skip
                continue
        # an impact's rebound gives back e of the compression impulses, and keeps the energy
        # only if they are the compression's answer: an island that rebounds is solved
        # exactly, when PGS has not converged, up to REBOUND_EXACT_CONTACTS contacts
        exact_limit = REBOUND_EXACT_CONTACTS if rebounds else int(settings[cs.EXACT_LIMIT])
        # pass 0 solves the island; after a rebound, pass 1 solves it again inelastically
        # from the velocities the rebound left, so that no contact approaches after it
        row_bias, answer = bias, impulse
        for rebound_pass in range(2 if rebounds else 1):
            if rebound_pass == 1:
                _add_restitution(
                    s, e, bounce, body_a, body_b, basis, response_a, response_b, inverse_mass,
                    v, w, impulse, v_start, w_start,
                )  # fmt: skip
                row_bias = np.where(np.isfinite(bias), 0.0, np.inf)
                answer = np.zeros_like(impulse)
            exact = solver == 2
            if not exact:
                if e - s >= SUBSPACE_CONTACTS:
                    sweeps, converged = sweep_with_subspace_steps(
                        s, e, iterations, tolerance, polygon, body_a, body_b, basis, rows,
                        inverse_mass, row_bias, friction, v, w, answer,
                    )  # fmt: skip
                else:
                    sweeps, converged = sweep_island(
                        s, e, iterations, tolerance, polygon, body_a, body_b, basis,
                        angular_a, angular_b, response_a, response_b, normal_step,
                        tangent_step, coupling, inverse_mass, row_bias, friction, v, w, answer,
                    )  # fmt: skip
                stats[SWEEPS] += sweeps
                stats[MAX_SWEEPS] = max(stats[MAX_SWEEPS], sweeps)
                if not converged:
                    if solver == 0 and e - s <= exact_limit:
                        exact = True
                    else:
                        stats[UNCONVERGED] += 1
            if exact:
                _solve_island_exactly(
                    s, e, settings, sides, body_a, body_b, arm_a, arm_b, basis, row_bias,
                    friction, tolerance, inverse_mass, inverse_inertia, v, w, v_start,
                    w_start, answer, stats,
                )  # fmt: skip
            if rebound_pass == 1:
                for k in range(s, e):
                    for d in range(3):
                        impulse[k, d] += answer[k, d]


@njit(inline="always")
def _add_restitution(
    s, e, bounce, body_a, body_b, basis, response_a, response_b, inverse_mass, v, w, impulse,
    v_start, w_start,
):  # fmt: skip
    """Add e times each contact's compression impulse of the island ``s:e`` to its impulse
    and to the velocities; the island's velocities after it become its ``v_start``,
    ``w_start`` (where an exact solve of the next pass starts)."""
    for k in range(s, e):
        extra = bounce[k] * impulse[k, 0]
        if extra > 0.0:
            a, b = body_a[k], body_b[k]
            for i in range(3):
                v[a, i] += inverse_mass[a] * extra * basis[k, 0, i]
                v[b, i] -= inverse_mass[b] * extra * basis[k, 0, i]
                w[a, i] += extra * response_a[k, 0, i]
                w[b, i] -= extra * response_b[k, 0, i]
            impulse[k, 0] += extra
    for k in range(s, e):
        for i in (body_a[k], body_b[k]):
            for a in range(3):
                v_start[i, a] = v[i, a]
                w_start[i, a] = w[i, a]


@njit
def _solve_island_exactly(
    s, e, settings, sides, body_a, body_b, arm_a, arm_b, basis, bias, friction, tolerance,
    inverse_mass, inverse_inertia, v, w, v_start, w_start, impulse, stats,
):  # fmt: skip
    """The island ``s:e`` by Lemke's method, from the velocities before its impulses
    (``v_start``, ``w_start``); its impulses replaced by the answer."""
    velocity_scale = 0.0
    for k in range(s, e):  # back to the velocities before this island's impulses
        velocity_scale = max(velocity_scale, tolerance[k] / settings[cs.TOLERANCE])
        for i in (body_a[k], body_b[k]):
            for a in range(3):
                v[i, a] = v_start[i, a]
                w[i, a] = w_start[i, a]
    # contacts with an infinite bias can never bind: they stay out of the LCP
    taking_part = np.arange(s, e)[np.isfinite(bias[s:e])]
    for k in range(s, e):
        for d in range(3):
            impulse[k, d] = 0.0
    frame = (
        body_a[taking_part], body_b[taking_part], arm_a[taking_part], arm_b[taking_part],
        basis[taking_part],
    )  # fmt: skip
    answer = np.zeros((taking_part.shape[0], 3))
    status = solve_exact(
        sides, frame, bias[taking_part], friction[taking_part],
        (v, w, inverse_mass, inverse_inertia), answer, velocity_scale,
    )  # fmt: skip
    for idx in range(taking_part.shape[0]):
        for d in range(3):
            impulse[taking_part[idx], d] = answer[idx, d]
    stats[EXACT_ISLANDS] += 1
    stats[UNCONVERGED] += status != 0


@njit(separate=True)
def correct_positions(
    settings, island_start, body_a, body_b, basis, rows, push, tolerance, inverse_mass,
    position, orientation,
):  # fmt: skip
    """Move bodies out of the penetration ``push`` asks for, without touching their momenta.

    Parameters
    ----------
    settings, island_start, body_a, body_b, basis, rows, tolerance, inverse_mass
        As ``solve_islands``.
    push : (c,) float64
        Separation speed each contact must reach in the pseudo-velocities (the penetration to
        remove this step over dt); -np.inf where the contact takes no part (it can then
        never bind).
    position, orientation : (>= n, 3), (>= n, 4) float64
        Moved in place by dt times the pseudo-velocities.

    Returns
    -------
    sweeps : int
    """
    c = body_a.shape[0]
    if c == 0 or push.max() == -np.inf:
        return 0  # nothing to push out: the common case of resting contact
    dt = settings[cs.DT]
    n = inverse_mass.shape[0]
    angular_a, angular_b, response_a, response_b, normal_step, tangent_step, coupling = rows
    pseudo_v = np.zeros((n, 3))
    pseudo_w = np.zeros((n, 3))
    lam = np.zeros((c, 3))
    frictionless = np.zeros(c)
    bias = -push
    sweeps = 0
    no_polygon = np.zeros((4, 2))
    for isl in range(island_start.shape[0] - 1):
        s, e = island_start[isl], island_start[isl + 1]
        active = False
        for k in range(s, e):
            active |= push[k] != -np.inf
        if not active:
            continue
        done, _ = sweep_island(
            s, e, int(settings[cs.ITERATIONS]), tolerance, no_polygon, body_a, body_b, basis,
            angular_a, angular_b, response_a, response_b, normal_step, tangent_step, coupling,
            inverse_mass, bias, frictionless, pseudo_v, pseudo_w, lam,
        )  # fmt: skip
        sweeps += done
    for i in range(n):
        rx, ry, rz = dt * pseudo_w[i, 0], dt * pseudo_w[i, 1], dt * pseudo_w[i, 2]
        for a in range(3):
            position[i, a] += dt * pseudo_v[i, a]
        angle = np.sqrt(rx * rx + ry * ry + rz * rz)
        if angle > 0.0:
            s_half = np.sin(0.5 * angle) / angle
            turn = (rx * s_half, ry * s_half, rz * s_half, np.cos(0.5 * angle))
            q = (orientation[i, 0], orientation[i, 1], orientation[i, 2], orientation[i, 3])
            q = normalize(mul(turn, q))
            for a in range(4):
                orientation[i, a] = q[a]
    return sweeps
