"""Joint motors: a hinge or slider driven towards a velocity or a position with a capped
torque or force, or pushed with a set one; and, swept with them, the joints' springs,
dampers and friction (``joint_forces``).

A motor acts along its joint's axis row (``joint_rows.axis_row``: a hinge's relative
rotation about its axis, a slider's relative travel along it, a distance joint's length) once
per substep, after the forces and before the bodies move, so the projection that holds the
joint sees the motion the motor gave:

* a velocity motor takes the impulse that brings the row's velocity J v to its target,
  clipped to the cap times the substep, with every joint row of its island held: the row's
  effective mass is then the mechanism's inertia as the joint feels it (a hinged ball's
  m r^2 + I, not its own I; a shoulder's, the arm beyond it), the velocity the one the
  joints will leave it, and the joints' reactions go with the impulse. The motors of an
  island are swept a few times (Gauss-Seidel) over their coupling with the joints held,
  each accumulating and clipping its own impulse, since they share the mechanism;
* a torque motor gives the set torque (or force) times the substep;
* a position motor is a spring of stiffness k and a damper c towards its target, taken at the
  end of the substep (implicitly, so that no gain is too stiff for the step): the impulse
  lam = h (k e - (k h + c) v+) for the position error e and the row's velocity v+ after it,
  clipped to its cap;
* a servo holds its target as a constraint (pybullet's position control): the velocity that
  reaches the target in one substep, clipped to its most speed and to the speed from which
  half its capped force can still stop what it moves (with the other motors' joints held
  too) at the target, taken with the capped impulse of a velocity motor.

A joint's spring and damper (a distance joint's spring, a hinge's or slider's viscous
damping) and its friction act along the same row in the same sweeps, after its motor and
seeing the motion the motor gave, each accumulating its own impulse: a motor then works
against the friction, and friction holds against a torque motor as against any other force.

Every impulse acts equally and oppositely on the two bodies along the row, so a motor
conserves the mechanism's total momentum as its joint does.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.integrators import angular_velocity
from thesis_rbd.dynamics.joint_forces import friction_impulse, spring_impulse
from thesis_rbd.dynamics.joint_rows import (
    axis_row,
    body_pose,
    coupling_matrix,
    joint_rows,
    row_responses,
    row_written,
    write_row,
)
from thesis_rbd.dynamics.joint_set import (
    BODY_A,
    BODY_B,
    DAMPING,
    FRICTION,
    JOINT_KINDS,
    KIND,
    MOTOR,
    MOTOR_DAMPING,
    MOTOR_MAX,
    MOTOR_SPEED,
    MOTOR_STIFFNESS,
    MOTOR_TARGET,
    NO_MOTOR,
    SERVO_MOTOR,
    SPRING_REST,
    SPRING_STIFFNESS,
    TORQUE_MOTOR,
    VELOCITY_MOTOR,
)
from thesis_rbd.dynamics.joint_tree import left_solve, lu_in_place

__all__ = ["MOTOR_SWEEPS", "drive_joints"]

REVOLUTE = JOINT_KINDS["revolute"]

# Gauss-Seidel sweeps over an island's velocity, position and servo motors, springs, dampers
# and friction per substep.
MOTOR_SWEEPS = 4
# Most turn (rad) a hinge's servo asks for in one substep.
_SERVO_TURN = 0.25


@njit(allocates=False)
def _swept(f):
    """Whether a joint (its ``JointSet.floats`` row) takes part in the sweeps: a velocity,
    position or servo motor, a spring, damping or friction."""
    code = int(f[MOTOR])
    return (
        (code != NO_MOTOR and code != TORQUE_MOTOR)
        or f[SPRING_STIFFNESS] > 0.0
        or f[DAMPING] > 0.0
        or f[FRICTION] > 0.0
    )


@njit
def drive_joints(
    h, joints, ints, floats, frozen, position, orientation, linear_momentum, angular_momentum,
    inverse_mass, inverse_inertia_body, impulse, kinematic_velocity, kinematic_angular_velocity,
):  # fmt: skip
    """Apply the motors, springs, dampers and friction of an island's ``joints`` for a
    substep of length h, in place.

    Parameters
    ----------
    h : float
        Substep (s).
    joints : (j,) int64
    ints, floats : ``JointSet`` arrays.
    frozen : (>= n,) bool
    position ... inverse_inertia_body : body arrays (``integrate_bodies``).
    impulse : (m, 7) float64
        Each joint's impulses over the step: the motors', springs', dampers' and friction's
        are added to its linear and angular impulse on body a (columns 0-5), and the motors'
        along the axis to column 6.
    kinematic_velocity, kinematic_angular_velocity : (>= n, 3) float64
        The frozen bodies' velocities (zero but for a kinematic body's): a joint's motion is
        relative to a moving kinematic body it holds to.
    """
    sweeps = 0
    for j in joints:
        if int(floats[j, MOTOR]) == TORQUE_MOTOR:
            _apply(j, floats[j, MOTOR_TARGET] * h, ints, floats, frozen, position, orientation,
                   linear_momentum, angular_momentum, impulse)  # fmt: skip
        if _swept(floats[j]):
            sweeps = MOTOR_SWEEPS
    if sweeps == 0:
        return
    # Every joint row of the island held, the swept joints' axis rows free: their coupling
    # S (inverse effective masses) and velocities with the joints held.
    swept = np.empty(len(joints), dtype=np.int64)
    count = 0
    for j in joints:
        if _swept(floats[j]):
            swept[count] = j
            count += 1
    swept = swept[:count]
    held, S, free_speed, reaction, places, rows, row_joint = _held_island(
        joints, swept, ints, floats, frozen, position, orientation, linear_momentum,
        angular_momentum, inverse_mass, inverse_inertia_body, kinematic_velocity,
        kinematic_angular_velocity,
    )  # fmt: skip
    braked = _braked_masses(S, swept, floats)
    # each axis row's motor, spring and friction impulse this substep
    applied = np.zeros((count, 3))
    for _ in range(sweeps):
        for e in range(count):
            j = swept[e]
            f = floats[j]
            if not S[e, e] > 0.0:
                continue
            mass = 1.0 / S[e, e]
            velocity = free_speed[e]
            for k in range(count):
                velocity += S[e, k] * (applied[k, 0] + applied[k, 1] + applied[k, 2])
            code = int(f[MOTOR])
            if code != NO_MOTOR and code != TORQUE_MOTOR:
                wanted = _wanted(h, ints[j, KIND], f, places[e], velocity, mass,
                                 max(mass, braked[e]), applied[e, 0])  # fmt: skip
                cap = f[MOTOR_MAX] * h
                total = min(max(applied[e, 0] + wanted, -cap), cap)
                velocity += (total - applied[e, 0]) / mass
                applied[e, 0] = total
            if f[SPRING_STIFFNESS] > 0.0 or f[DAMPING] > 0.0:
                spring = spring_impulse(h, f[SPRING_STIFFNESS], f[DAMPING],
                                        f[SPRING_REST] - places[e], velocity, mass,
                                        applied[e, 1])  # fmt: skip
                applied[e, 1] += spring
                velocity += spring / mass
            if f[FRICTION] > 0.0:
                applied[e, 2] += friction_impulse(h, f[FRICTION], velocity, mass, applied[e, 2])
    # the axis rows' impulses, and the held joint rows' reactions to them
    lam = np.empty(count)
    for e in range(count):
        lam[e] = applied[e, 0] + applied[e, 1] + applied[e, 2]
        _push(swept[e], lam[e], rows[held + e], ints, frozen, linear_momentum,
              angular_momentum, impulse)  # fmt: skip
        impulse[swept[e], 6] += applied[e, 0]
    for r in range(held):
        push = 0.0
        for e in range(count):
            push -= reaction[r, e] * lam[e]
        _push(row_joint[r], push, rows[r], ints, frozen, linear_momentum,
              angular_momentum, impulse)  # fmt: skip


@njit
def _held_island(joints, swept, ints, floats, frozen, position, orientation, P, L,
                 inverse_mass, inverse_inertia_body, kinematic_velocity,
                 kinematic_angular_velocity):  # fmt: skip
    """The swept joints' axis rows with every joint row of the island held.

    With K = J M^-1 J^T over the island's joint rows (e, held) and the axis rows (m), an
    impulse lam along the axis rows, the held rows answering it with -K_ee^-1 K_em lam,
    changes the axis rows' velocities by S lam, S = K_mm - K_me K_ee^-1 K_em: the inverse
    of the mechanism's mass as the motors feel it (a shoulder's servo swings the arm beyond
    it, not its own link alone).

    Returns
    -------
    held : int
        Joint rows held (the first ``held`` of ``rows``; the axis rows follow, one per
        entry of ``swept``).
    S : (m, m) float64
    free_speed : (m,) float64
        The axis rows' velocities once the held rows' own velocities are taken out.
    reaction : (held, m) float64
        K_ee^-1 K_em: the held rows' impulses per unit axis impulse, negated.
    places : (m,) float64
        Each swept joint's position.
    rows, row_joint : (held + m, 10) float64, (held + m,) int64
    """
    count = len(swept)
    rows = np.empty((8 * len(joints) + count, 10))
    row_joint = np.empty(8 * len(joints) + count, dtype=np.int64)
    held = 0
    for j in joints:
        xa, qa = body_pose(ints[j, BODY_A], position, orientation)
        xb, qb = body_pose(ints[j, BODY_B], position, orientation)
        n = joint_rows(ints[j, KIND], floats[j], xa, qa, xb, qb, rows, held, True)
        for k in range(held, held + n):  # rows written as zero (limits not reached) left out
            if row_written(rows, k):
                rows[held] = rows[k]
                row_joint[held] = j
                held += 1
    places = np.empty(count)
    for e in range(count):
        j = swept[e]
        xa, qa = body_pose(ints[j, BODY_A], position, orientation)
        xb, qb = body_pose(ints[j, BODY_B], position, orientation)
        lin, ang_a, ang_b, places[e] = axis_row(ints[j, KIND], floats[j], xa, qa, xb, qb)
        write_row(rows, held + e, lin, ang_a, ang_b, 0.0)
        row_joint[held + e] = j
    total = held + count
    moved = np.empty((total, 12))
    row_responses(rows, row_joint, total, ints, frozen, orientation, inverse_mass,
                  inverse_inertia_body, moved)  # fmt: skip
    K = np.empty((total, total))
    coupling_matrix(ints, row_joint, rows, moved, total, K)
    speeds = _row_speeds(rows, row_joint, total, ints, frozen, orientation, P, L, inverse_mass,
                         inverse_inertia_body, kinematic_velocity,
                         kinematic_angular_velocity)  # fmt: skip
    D = K[:held, :held].copy()
    kept = lu_in_place(D, held)
    reaction = np.empty((held, count))
    column = np.empty(held)
    for e in range(count):
        for r in range(held):
            column[r] = K[r, held + e]
        left_solve(D, kept, held, column, 0)
        reaction[:, e] = column
    S = np.empty((count, count))
    free_speed = np.empty(count)
    for e in range(count):
        free_speed[e] = speeds[held + e]
        for r in range(held):
            free_speed[e] -= reaction[r, e] * speeds[r]
        for k in range(count):
            S[e, k] = K[held + e, held + k]
            for r in range(held):
                S[e, k] -= K[held + e, r] * reaction[r, k]
    return held, S, free_speed, reaction, places, rows, row_joint


@njit
def _row_speeds(rows, row_joint, count, ints, frozen, orientation, P, L, inverse_mass,
                inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity):  # fmt: skip
    """J v of rows[:count]: each row's velocity at the bodies' momenta (a frozen body's the
    velocity set for it: zero, or a kinematic body's)."""
    speeds = np.zeros(count)
    for k in range(count):
        j = row_joint[k]
        for side in range(2):
            body = ints[j, BODY_A + side]
            if body < 0:
                continue
            sign = 1.0 if side == 0 else -1.0
            if frozen[body]:
                for c in range(3):
                    speeds[k] += sign * rows[k, c] * kinematic_velocity[body, c]
                    speeds[k] += rows[k, 3 + 3 * side + c] * kinematic_angular_velocity[body, c]
                continue
            q = orientation[body]
            w = angular_velocity((q[0], q[1], q[2], q[3]), (L[body, 0], L[body, 1], L[body, 2]),
                                 inverse_inertia_body[body])  # fmt: skip
            for c in range(3):
                speeds[k] += sign * rows[k, c] * P[body, c] * inverse_mass[body]
                speeds[k] += rows[k, 3 + 3 * side + c] * w[c]
    return speeds


@njit
def _braked_masses(S, swept, floats):
    """Each axis row's effective mass with the other axis rows held too, (S^-1)_ee: what a
    servo turns when the other joints' servos hold theirs, the most it can meet, which sets
    its braking; 0 where S has no inverse (its own 1 / S_ee then stands), and all 0 where
    no servo is capped (only a capped servo brakes)."""
    count = len(swept)
    out = np.zeros(count)
    capped = False
    for j in swept:
        capped |= int(floats[j, MOTOR]) == SERVO_MOTOR and floats[j, MOTOR_MAX] < math.inf
    if not capped:
        return out
    D = S.copy()
    kept = lu_in_place(D, count)
    unit = np.empty(count)
    for e in range(count):
        if not kept[e]:
            continue
        for k in range(count):
            unit[k] = 1.0 if k == e else 0.0
        left_solve(D, kept, count, unit, 0)
        out[e] = unit[e]
    return out


@njit
def _push(j, lam, row, ints, frozen, linear_momentum, angular_momentum, impulse):
    """An impulse lam along ``row`` of joint j: +row on body a, -row on body b."""
    a, b = ints[j, BODY_A], ints[j, BODY_B]
    for c in range(3):
        if a >= 0 and not frozen[a]:
            linear_momentum[a, c] += row[c] * lam
            angular_momentum[a, c] += row[3 + c] * lam
        if b >= 0 and not frozen[b]:
            linear_momentum[b, c] -= row[c] * lam
            angular_momentum[b, c] += row[6 + c] * lam
        impulse[j, c] += row[c] * lam
        impulse[j, 3 + c] += row[3 + c] * lam


@njit
def _servo_speed(h, kind, f, error, moved):
    """The rate a servo asks for its position ``error``: the one that closes it within the
    substep, but no more than its most speed, no faster than it can still stop from
    (sqrt(2 a |e|) for the deceleration a that half its cap gives what it moves, ``moved``:
    the other half is left for the loads the cap also carries, gravity and the rest of the
    mechanism; a capped servo that only brakes on arriving overshoots and rings), and, for
    a hinge, no more than ``_SERVO_TURN`` per substep (the joint's projection follows a turn
    of that size; a rate that grew as 1 / h would defeat the substeps a failed projection
    takes again)."""
    most = f[MOTOR_SPEED]
    if f[MOTOR_MAX] < math.inf:
        most = min(most, math.sqrt(f[MOTOR_MAX] / moved * abs(error)))
    if kind == REVOLUTE:
        most = min(most, _SERVO_TURN / h)
    return min(max(error / h, -most), most)


@njit
def _wanted(h, kind, f, place, velocity, mass, moved, applied):
    """The impulse a velocity, position or servo motor adds this sweep (before its cap),
    for its row's velocity now and effective mass, having applied ``applied`` this substep;
    ``moved``, the most inertia a servo can meet (``_braked_masses``), sets its braking."""
    code = int(f[MOTOR])
    if code == VELOCITY_MOTOR:
        return mass * (f[MOTOR_TARGET] - velocity)
    error = f[MOTOR_TARGET] - place
    if kind == REVOLUTE:  # the short way round
        error -= 2.0 * math.pi * round(error / (2.0 * math.pi))
    if code == SERVO_MOTOR:
        return mass * (_servo_speed(h, kind, f, error, moved) - velocity)
    return spring_impulse(h, f[MOTOR_STIFFNESS], f[MOTOR_DAMPING], error, velocity, mass,
                          applied)  # fmt: skip


@njit
def _apply(j, lam, ints, floats, frozen, position, orientation, linear_momentum,
           angular_momentum, impulse):  # fmt: skip
    """A set torque's impulse lam along joint j's axis row (its joint's reaction is left to
    the projection, which conserves momentum as the torque pair does)."""
    xa, qa = body_pose(ints[j, BODY_A], position, orientation)
    xb, qb = body_pose(ints[j, BODY_B], position, orientation)
    lin, ang_a, ang_b, _ = axis_row(ints[j, KIND], floats[j], xa, qa, xb, qb)
    row = np.empty((1, 10))
    write_row(row, 0, lin, ang_a, ang_b, 0.0)
    _push(j, lam, row[0], ints, frozen, linear_momentum, angular_momentum, impulse)
    impulse[j, 6] += lam
