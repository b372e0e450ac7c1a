"""Contacts of jointed bodies: the contact rows solved with the joint rows of their island.

Two boxes welded together, one of them on a floor: solved body by body, the floor holds up
the lower box's own weight and the weld pulls it down by the upper box's, every step, and the
pair never rests. So a contact island that holds jointed bodies (islands are joined through
joints as well as contacts, ``islands.find_islands``'s links) is solved on the velocities the
joints allow. With M the island's mass matrix, J_j its joint rows and K = J_j M^-1 J_j^T,

    P = M^-1 - M^-1 J_j^T K^-1 J_j M^-1

maps an impulse to the velocity change it makes with every joint row held, so the contact
problem of the island is the ordinary one (``contact_solver``) with the Delassus matrix
A = J_c P J_c^T of its contact rows J_c, on the velocities v_p = v - M^-1 J_j^T K^-1 J_j v
(the step's velocities with the joints' relative motion taken out). A contact's impulse then
moves every body jointed to it, as the joints would pass it on, and the weld's floor carries
both boxes.

A is dense in the island's contacts: it is solved by projected Gauss-Seidel on A (the same
steps, friction polygon and tolerances as ``pgs``), and exactly by Lemke's method where PGS
has not converged and the settings allow (``contact_solver.exact_contact_impulses``).
Restitution is Poisson's, as ``island_solver.solve_islands`` gives it. K is factorised by
``joint_tree.lu_in_place``, which drops the redundant rows of closed loops.

A joint's equality rows are held through P; its limits take part as one-sided rows beside
the contacts, speculative as contacts are (a knee pressed on its limit by a body resting on
it stays there, instead of the contacts letting it through and the joints stage pushing it
back every step). Motors act in the joints stage, which also removes what is left of the
joints' error at position level after the step (``joint_solver``).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics import contact_settings as cs
from thesis_rbd.dynamics.contact_solver import (
    FALLBACK_SWEEPS,
    REBOUND_EXACT_CONTACTS,
    exact_contact_impulses,
)
from thesis_rbd.dynamics.contact_stats import EXACT_ISLANDS, MAX_SWEEPS, SWEEPS, UNCONVERGED
from thesis_rbd.dynamics.joint_rows import (
    LIMITED,
    axis_row,
    axis_state,
    body_pose,
    cone_angle,
    equality_row_count,
    frame_axis_row,
    has_axes,
    joint_rows,
)
from thesis_rbd.dynamics.joint_set import (
    AXIS_LOWER,
    AXIS_UPPER,
    BODY_A,
    BODY_B,
    CONE,
    JOINT_KINDS,
    KIND,
    LOWER,
    SCALE,
    UPPER,
)
from thesis_rbd.dynamics.joint_tree import left_solve, lu_in_place
from thesis_rbd.dynamics.pgs import project_onto_polygon

__all__ = ["island_joints", "joined_islands", "solve_jointed_island"]

# Most rows a joint has (a fixed joint's six, and a limit's).
_MOST_ROWS = 7
# A contact row whose effective inverse mass with the joints held is below this fraction of
# its value without them cannot move (a body welded to the world): it takes no impulse.
_IMMOVABLE = 1e-9
REVOLUTE = JOINT_KINDS["revolute"]
SPHERICAL = JOINT_KINDS["spherical"]


@njit
def island_joints(ints, body_island, islands):
    """The joints of each contact island, as a CSR.

    Parameters
    ----------
    ints : (m, 3) int64
        ``JointSet.ints``.
    body_island : (n,) int64
        Each body's contact island (-1: none), from ``find_islands`` with the joints as
        links, so that a joint's two bodies share their island.
    islands : int

    Returns
    -------
    joint_start : (islands + 1,) int64
    joints : (k,) int64
        The joints of island i are ``joints[joint_start[i]:joint_start[i + 1]]``.
    """
    counts = np.zeros(islands + 1, np.int64)
    for j in range(ints.shape[0]):
        isl = body_island[ints[j, BODY_A]]
        if isl >= 0:
            counts[isl + 1] += 1
    joint_start = np.cumsum(counts)
    fill = joint_start[:-1].copy()
    joints = np.empty(joint_start[-1], np.int64)
    for j in range(ints.shape[0]):
        isl = body_island[ints[j, BODY_A]]
        if isl >= 0:
            joints[fill[isl]] = j
            fill[isl] += 1
    return joint_start, joints


@njit(inline="always")
def joined_islands(joints, body_island, islands, position, orientation):
    """What ``island_solver.solve_islands`` takes of the joints beside the ``JointSet``'s
    (ints, floats) ``joints`` (None: no joints): the joints of each island
    (``island_joints``; none anywhere without joints) and the poses. Always the same tuple
    type, so that no kernel takes a value that may be None or not; inlined, so that a scene
    without joints compiles nothing for it."""
    joint_start = np.zeros(islands + 1, np.int64)
    island_joint_list = np.empty(0, np.int64)
    if joints is not None:
        joint_start, island_joint_list = island_joints(joints[0], body_island, islands)
    return joint_start, island_joint_list, position, orientation


@njit
def solve_jointed_island(
    s, e, settings, polygon, body_a, body_b, arm_a, arm_b, basis, bias, bounce, friction,
    tolerance, inverse_mass, inverse_inertia, v, w, impulse, stats, joints, ints, floats,
    position, orientation,
):  # fmt: skip
    """Solve the contacts ``s:e`` of one island with its joints' rows held, in place.

    Parameters
    ----------
    s, e : int
        The island's slice of the island-sorted contacts.
    settings, polygon, body_a ... impulse, stats
        As ``island_solver.solve_islands``; ``impulse`` rows ``s:e`` are the warm start in
        and the answer out, and ``v``, ``w`` of every body of the island (jointed ones that
        touch nothing included) become the velocities after the impulses.
    joints : (k,) int64
        The island's joints (``island_joints``).
    ints, floats
        ``JointSet`` arrays.
    position, orientation : (>= n, 3), (>= n, 4) float64
        Where the bodies are (the joint rows' directions).
    """
    local, bodies = _island_bodies(s, e, body_a, body_b, joints, ints, inverse_mass)
    size = 6 * bodies.shape[0]
    joint_jacobian = _joint_jacobian(joints, ints, floats, local, position, orientation, size)
    joint_response = _times_inverse_mass(joint_jacobian, bodies, inverse_mass, inverse_inertia)
    r = joint_jacobian.shape[0]
    K = joint_jacobian @ joint_response.T
    kept = np.empty(r, np.bool_)
    lu_in_place(K, r, kept)
    c = e - s
    # the contacts' rows, then each limit's as a frictionless contact of its own
    limit_jacobian, limit_bias, limit_scale = _limit_rows(
        joints, ints, floats, local, position, orientation, size, settings[cs.DT]
    )
    rows = np.vstack(
        (_contact_jacobian(s, e, body_a, body_b, arm_a, arm_b, basis, local, size), limit_jacobian)
    )
    l = limit_bias.shape[0]
    row_bias = np.concatenate((bias[s:e], limit_bias))
    row_friction = np.concatenate((friction[s:e], np.zeros(l)))
    row_tolerance = np.concatenate((tolerance[s:e], tolerance[s:e].min() / limit_scale))
    free_response = _times_inverse_mass(rows, bodies, inverse_mass, inverse_inertia)
    # D = P J^T, one row per row of ``rows``: the velocity change (6 per body) of a unit
    # impulse along it with the joints held
    D = free_response.copy()
    for row in range(D.shape[0]):
        _hold_joints(D[row], joint_jacobian, joint_response, K, kept)
    A = rows @ D.T
    free_diagonal = np.empty(A.shape[0])
    for row in range(A.shape[0]):
        free_diagonal[row] = rows[row] @ free_response[row]
    velocity = _gather(bodies, v, w)
    _hold_joints(velocity, joint_jacobian, joint_response, K, kept)
    answer = np.zeros((c + l, 3))
    answer[:c] = impulse[s:e]
    rebounds = False
    for k in range(s, e):
        rebounds |= bounce[k] > 0.0
    exact_limit = REBOUND_EXACT_CONTACTS if rebounds else int(settings[cs.EXACT_LIMIT])
    _solve(
        settings, polygon, A, free_diagonal, rows @ velocity, row_bias, row_friction,
        row_tolerance, exact_limit, answer, stats,
    )  # fmt: skip
    velocity += D.T @ answer.ravel()
    if rebounds:
        # Poisson: e times each compression impulse back, then an inelastic pass from the
        # velocities it left, so that no contact approaches after it
        extra = np.zeros_like(answer)
        for k in range(c):
            extra[k, 0] = bounce[s + k] * answer[k, 0]
        velocity += D.T @ extra.ravel()
        answer += extra
        second = np.zeros_like(answer)
        _solve(
            settings, polygon, A, free_diagonal, rows @ velocity,
            np.where(np.isfinite(row_bias), 0.0, np.inf), row_friction, row_tolerance,
            exact_limit, second, stats,
        )  # fmt: skip
        velocity += D.T @ second.ravel()
        answer += second
    impulse[s:e] = answer[:c]
    _scatter(bodies, velocity, v, w)


@njit
def _limit_rows(joints, ints, floats, local, position, orientation, size, dt):
    """The one-sided rows of the island's limits (a hinge's angle, a slider's travel, a
    rope's length, a spherical joint's cone and twist, a universal or generic joint's limited
    axes), three per limit as a contact's (its direction, then two zero rows).

    A lower limit's row is the joint's axis row (``joint_rows.axis_row``, or
    ``frame_axis_row`` of a limited axis), an upper limit's
    (and a cone's) its negative, so that a positive impulse pushes the joint back within its
    limits; the bias lets it close the gap to its limit over the step and no more (a
    speculative limit: it stops on the limit as a contact stops on a floor), and a limit
    passed already takes no further approach (the joints stage puts it back on the limit).
    Returns the rows (3 l, 6 k), their biases (l,) and their scales (l,): the joint's length
    for an angle (m per rad: the contact tolerances are speeds), else 1.
    """
    count = 0
    for j in joints:
        count += (floats[j, LOWER] > -np.inf) + (floats[j, UPPER] < np.inf)
        count += floats[j, CONE] < np.inf
        if has_axes(ints[j, KIND]):
            for axis in range(6):
                if axis_state(floats[j], axis) == LIMITED:
                    count += (floats[j, AXIS_LOWER + axis] > -np.inf) + (
                        floats[j, AXIS_UPPER + axis] < np.inf
                    )
    J = np.zeros((3 * count, size))
    bias = np.empty(count)
    scale = np.ones(count)
    row = 0
    for j in joints:
        f = floats[j]
        kind = ints[j, KIND]
        a, b = ints[j, BODY_A], ints[j, BODY_B]
        xa, qa = body_pose(a, position, orientation)
        xb, qb = body_pose(b, position, orientation)
        angular = kind == REVOLUTE or kind == SPHERICAL
        if f[CONE] < np.inf:
            n, angle = cone_angle(f, qa, qb)
            bias[row] = max(f[CONE] - angle, 0.0) / dt
            scale[row] = f[SCALE]
            _write_limit(J, row, a, b, local, -1.0, (0.0, 0.0, 0.0), n, (-n[0], -n[1], -n[2]))
            row += 1
        if has_axes(kind):
            for axis in range(6):
                if axis_state(f, axis) == LIMITED:
                    lin, ang_a, ang_b, where = frame_axis_row(f, axis, xa, qa, xb, qb)
                    row = _write_limits(J, bias, scale, row, a, b, local, dt,
                                        f[AXIS_LOWER + axis], f[AXIS_UPPER + axis], lin, ang_a,
                                        ang_b, where, f[SCALE] if axis >= 3 else 1.0)  # fmt: skip
        elif f[LOWER] > -np.inf or f[UPPER] < np.inf:
            lin, ang_a, ang_b, where = axis_row(kind, f, xa, qa, xb, qb)
            row = _write_limits(J, bias, scale, row, a, b, local, dt, f[LOWER], f[UPPER], lin,
                                ang_a, ang_b, where, f[SCALE] if angular else 1.0)  # fmt: skip
    return J, bias, scale


@njit
def _write_limits(J, bias, scale, row, a, b, local, dt, lower, upper, lin, ang_a, ang_b, where,
                  length):  # fmt: skip
    """The rows of a lower and an upper limit (each where finite) on a joint's row at
    ``where`` from row ``row`` on (``_limit_rows``); ``length`` scales an angle's. Returns
    the next row."""
    for side in range(2):
        limit = lower if side == 0 else upper
        if not math.isfinite(limit):
            continue
        sign = 1.0 if side == 0 else -1.0
        bias[row] = max(sign * (where - limit), 0.0) / dt
        scale[row] = length
        _write_limit(J, row, a, b, local, sign, lin, ang_a, ang_b)
        row += 1
    return row


@njit
def _write_limit(J, row, a, b, local, sign, lin, ang_a, ang_b):
    """Row 3 ``row`` of J: ``sign`` times a joint row (lin on a, -lin on b, its angular
    parts) in the island's columns."""
    for end in range(2):
        body = a if end == 0 else b
        if body < 0 or local[body] < 0:
            continue
        column = 6 * local[body]
        for i in range(3):
            J[3 * row, column + i] = sign * (lin[i] if end == 0 else -lin[i])
            J[3 * row, column + 3 + i] = sign * (ang_a[i] if end == 0 else ang_b[i])


@njit
def _island_bodies(s, e, body_a, body_b, joints, ints, inverse_mass):
    """The island's movable bodies (k,) and each body's index among them (-1: not one)."""
    n = inverse_mass.shape[0]
    local = np.full(n, -1)
    bodies = np.empty(2 * (e - s + joints.shape[0]), np.int64)
    count = 0
    for k in range(s, e):
        for body in (body_a[k], body_b[k]):
            if inverse_mass[body] > 0.0 and local[body] < 0:
                local[body] = count
                bodies[count] = body
                count += 1
    for j in joints:
        for body in (ints[j, BODY_A], ints[j, BODY_B]):
            if body >= 0 and inverse_mass[body] > 0.0 and local[body] < 0:
                local[body] = count
                bodies[count] = body
                count += 1
    return local, bodies[:count]


@njit
def _joint_jacobian(joints, ints, floats, local, position, orientation, size):
    """The equality rows of the joints (r, 6 k), columns (v, w) per island body."""
    total = 0
    for j in joints:
        total += equality_row_count(ints[j, KIND], floats[j])
    J = np.zeros((total, size))
    scratch = np.empty((_MOST_ROWS, 10))
    first = 0
    for j in joints:
        a, b = ints[j, BODY_A], ints[j, BODY_B]
        xa, qa = body_pose(a, position, orientation)
        xb, qb = body_pose(b, position, orientation)
        joint_rows(ints[j, KIND], floats[j], xa, qa, xb, qb, scratch, 0, True)
        equalities = equality_row_count(ints[j, KIND], floats[j])
        for row in range(equalities):
            for side in range(2):
                body = a if side == 0 else b
                if body < 0 or local[body] < 0:
                    continue
                column = 6 * local[body]
                sign = 1.0 if side == 0 else -1.0
                for i in range(3):
                    J[first + row, column + i] = sign * scratch[row, i]
                    J[first + row, column + 3 + i] = scratch[row, 3 + 3 * side + i]
        first += equalities
    return J


@njit
def _contact_jacobian(s, e, body_a, body_b, arm_a, arm_b, basis, local, size):
    """The contact rows (3 c, 6 k), (n, t1, t2) per contact, columns as ``_joint_jacobian``."""
    J = np.zeros((3 * (e - s), size))
    for k in range(s, e):
        for side in range(2):
            body = body_a[k] if side == 0 else body_b[k]
            if local[body] < 0:
                continue
            column = 6 * local[body]
            sign = 1.0 if side == 0 else -1.0
            arm = arm_a[k] if side == 0 else arm_b[k]
            for d in range(3):
                row = 3 * (k - s) + d
                direction = basis[k, d]
                for i in range(3):
                    J[row, column + i] = sign * direction[i]
                J[row, column + 3] = sign * (arm[1] * direction[2] - arm[2] * direction[1])
                J[row, column + 4] = sign * (arm[2] * direction[0] - arm[0] * direction[2])
                J[row, column + 5] = sign * (arm[0] * direction[1] - arm[1] * direction[0])
    return J


@njit
def _times_inverse_mass(J, bodies, inverse_mass, inverse_inertia):
    """(M^-1 J^T)^T: each row of J (r, 6 k) with its body blocks taken through M^-1."""
    out = np.empty_like(J)
    for row in range(J.shape[0]):
        for local in range(bodies.shape[0]):
            body = bodies[local]
            c = 6 * local
            I = inverse_inertia[body]
            for i in range(3):
                out[row, c + i] = inverse_mass[body] * J[row, c + i]
                out[row, c + 3 + i] = (
                    I[i, 0] * J[row, c + 3] + I[i, 1] * J[row, c + 4] + I[i, 2] * J[row, c + 5]
                )
    return out


@njit
def _hold_joints(velocity, joint_jacobian, joint_response, K, kept):
    """velocity (6 k,) <- velocity - M^-1 J_j^T K^-1 J_j velocity: the joints' relative
    motion taken out."""
    r = joint_jacobian.shape[0]
    if r == 0:
        return
    t = joint_jacobian @ velocity
    left_solve(K, kept, r, t.reshape((r, 1)), 0)
    velocity -= joint_response.T @ t


@njit
def _gather(bodies, v, w):
    """The island's velocities (6 k,): (v, w) per body."""
    out = np.empty(6 * bodies.shape[0])
    for local in range(bodies.shape[0]):
        for i in range(3):
            out[6 * local + i] = v[bodies[local], i]
            out[6 * local + 3 + i] = w[bodies[local], i]
    return out


@njit
def _scatter(bodies, velocity, v, w):
    """``_gather``'s inverse."""
    for local in range(bodies.shape[0]):
        for i in range(3):
            v[bodies[local], i] = velocity[6 * local + i]
            w[bodies[local], i] = velocity[6 * local + 3 + i]


@njit
def _solve(
    settings, polygon, A, free_diagonal, u, bias, friction, tolerance, exact_limit, answer,
    stats,
):  # fmt: skip
    """The contact problem on A (3 c, 3 c) from the contact velocities ``u`` (3 c,) before
    any impulse: PGS from the warm start ``answer`` (c, 3), Lemke where it has not converged
    and the settings allow; the answer in ``answer``."""
    solver = int(settings[cs.SOLVER])
    c = answer.shape[0]
    exact = solver == 2
    if not exact:
        sweeps, converged = _sweeps(
            A, free_diagonal, u.copy(), bias, friction, tolerance, polygon,
            int(settings[cs.ITERATIONS]), answer,
        )  # fmt: skip
        stats[SWEEPS] += sweeps
        stats[MAX_SWEEPS] = max(stats[MAX_SWEEPS], sweeps)
        if not converged:
            if solver == 0 and c <= exact_limit:
                exact = True
            else:
                stats[UNCONVERGED] += 1
    if not exact:
        return
    taking_part = np.flatnonzero(np.isfinite(bias))
    rows = np.empty(3 * taking_part.shape[0], np.int64)
    for idx in range(taking_part.shape[0]):
        for d in range(3):
            rows[3 * idx + d] = 3 * taking_part[idx] + d
    velocity_scale = 0.0
    for k in taking_part:
        velocity_scale = max(velocity_scale, tolerance[k] / settings[cs.TOLERANCE])
    part_A = A[rows][:, rows]
    best, residual, _ = exact_contact_impulses(
        polygon.shape[0] - 1, part_A, u[rows], bias[taking_part], friction[taking_part],
        velocity_scale,
    )  # fmt: skip
    stats[EXACT_ISLANDS] += 1
    # as contact_solver.solve_exact: Lemke's answer where it holds; PGS from it where it is
    # nearly right, from where the sweeps stopped where it is off
    if residual <= 1e-2:
        answer[:] = 0.0
        for idx in range(taking_part.shape[0]):
            for d in range(3):
                answer[taking_part[idx], d] = best[3 * idx + d]
    if residual > 1e-6:
        stats[UNCONVERGED] += 1
        _sweeps(
            A, free_diagonal, u.copy(), bias, friction, 1e-3 * tolerance, polygon,
            FALLBACK_SWEEPS, answer,
        )  # fmt: skip


@njit
def _sweeps(A, free_diagonal, u, bias, friction, tolerance, polygon, iterations, answer):
    """Projected Gauss-Seidel on the Delassus matrix A from the warm start ``answer``.

    ``u`` (3 c,) is the contact velocities before any impulse (overwritten: kept current as
    the impulses change). Steps as ``pgs.run_sweeps``: the normal row by 1 / A_nn, the
    tangent pair by 1 / lambda_max of its 2 x 2 block, projected onto the friction polygon
    of radius mu lambda_n. Returns (sweeps run, converged).
    """
    c = answer.shape[0]
    normal_step = np.zeros(c)
    tangent_step = np.zeros(c)
    for k in range(c):
        n = 3 * k
        if bias[k] == np.inf or not A[n, n] > _IMMOVABLE * free_diagonal[n]:
            answer[k, :] = 0.0  # takes no part, or cannot move: no impulse
            continue
        normal_step[k] = 1.0 / A[n, n]
        a11, a22 = A[n + 1, n + 1], A[n + 2, n + 2]
        a12 = 0.5 * (A[n + 1, n + 2] + A[n + 2, n + 1])
        largest = 0.5 * (a11 + a22) + math.sqrt(0.25 * (a11 - a22) ** 2 + a12 * a12)
        if largest > 0.0:
            tangent_step[k] = 1.0 / largest
    u += A @ answer.reshape(3 * c)
    for sweep in range(iterations):
        converged = True
        for k in range(c):
            if normal_step[k] == 0.0:
                continue
            n = 3 * k
            old_n = answer[k, 0]
            new_n = max(old_n - (u[n] + bias[k]) * normal_step[k], 0.0)
            dn = new_n - old_n
            answer[k, 0] = new_n
            _add_column(A, n, dn, u)
            converged &= abs(dn) <= tolerance[k] * normal_step[k]
            if friction[k] > 0.0 and tangent_step[k] > 0.0:
                h = tangent_step[k]
                old_1, old_2 = answer[k, 1], answer[k, 2]
                t1, t2 = project_onto_polygon(
                    old_1 - h * u[n + 1], old_2 - h * u[n + 2], friction[k] * new_n, polygon
                )
                d1, d2 = t1 - old_1, t2 - old_2
                answer[k, 1], answer[k, 2] = t1, t2
                _add_column(A, n + 1, d1, u)
                _add_column(A, n + 2, d2, u)
                converged &= max(abs(d1), abs(d2)) <= tolerance[k] * h
        if converged:
            return sweep + 1, True
    return iterations, False


@njit(inline="always")
def _add_column(A, column, amount, u):
    """u += A[:, column] amount, in place (no temporary)."""
    if amount != 0.0:
        for i in range(u.shape[0]):
            u[i] += A[i, column] * amount
