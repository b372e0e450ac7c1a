"""Joint motors: a hinge or slider driven towards a velocity or a position with a capped
torque or force, or pushed with a set one; and, swept with them, the joints' springs,
dampers and friction (``joint_forces``).

A motor acts along its joint's axis row (``joint_rows.axis_row``: a hinge's relative
rotation about its axis, a slider's relative travel along it, a distance joint's length) once
per substep, after the forces and before the bodies move, so the projection that holds the
joint sees the motion the motor gave:

* a velocity motor takes the impulse that brings the row's velocity J v to its target,
  clipped to the cap times the substep, with its own joint's rows held: the row's effective
  mass is then the bodies' inertia about the joint's axis (a hinged ball's m r^2 + I, not its
  own I), the velocity the one its joint will leave it, and the joint's reaction goes with
  the impulse. The motors of an island are swept a few times (Gauss-Seidel), each
  accumulating and clipping its own impulse, since they share bodies;
* a torque motor gives the set torque (or force) times the substep;
* a position motor is a spring of stiffness k and a damper c towards its target, taken at the
  end of the substep (implicitly, so that no gain is too stiff for the step): the impulse
  lam = h (k e - (k h + c) v+) for the position error e and the row's velocity v+ after it,
  clipped to its cap;
* a servo holds its target as a constraint (pybullet's position control): the velocity that
  reaches the target in one substep, clipped to its most speed and to the speed from which
  its capped force can still stop it at the target, taken with the capped impulse of a
  velocity motor.

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
    coupling_block,
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
    # each motor's, spring's and friction's impulse this substep
    applied = np.zeros((len(joints), 3))
    rows = np.empty((8, 10))  # the axis row, then its joint's own rows
    moved = np.empty((8, 12))
    for _ in range(sweeps):
        for e in range(len(joints)):
            j = joints[e]
            f = floats[j]
            if not _swept(f):
                continue
            count, place = _motor_rows(j, ints, floats, frozen, position, orientation,
                                       inverse_mass, inverse_inertia_body, rows, moved)  # fmt: skip
            velocity, mass, reaction = _held_motion(
                j, ints, frozen, count, rows, moved, linear_momentum, angular_momentum,
                inverse_mass, orientation, inverse_inertia_body, kinematic_velocity,
                kinematic_angular_velocity,
            )  # fmt: skip
            if not mass > 0.0:
                continue
            motor = 0.0
            code = int(f[MOTOR])
            if code != NO_MOTOR and code != TORQUE_MOTOR:
                wanted = _wanted(h, ints[j, KIND], f, place, velocity, mass, applied[e, 0])
                cap = f[MOTOR_MAX] * h
                total = min(max(applied[e, 0] + wanted, -cap), cap)
                motor = total - applied[e, 0]
                applied[e, 0] = total
                velocity += motor / mass
            spring = 0.0
            if f[SPRING_STIFFNESS] > 0.0 or f[DAMPING] > 0.0:
                spring = spring_impulse(h, f[SPRING_STIFFNESS], f[DAMPING],
                                        f[SPRING_REST] - place, velocity, mass,
                                        applied[e, 1])  # fmt: skip
                applied[e, 1] += spring
                velocity += spring / mass
            friction = 0.0
            if f[FRICTION] > 0.0:
                friction = friction_impulse(h, f[FRICTION], velocity, mass, applied[e, 2])
                applied[e, 2] += friction
            lam = motor + spring + friction
            for k in range(count):
                _push(j, (lam if k == 0 else -reaction[k] * lam), rows[k], ints, frozen,
                      linear_momentum, angular_momentum, impulse)  # fmt: skip
            impulse[j, 6] += motor


@njit
def _motor_rows(j, ints, floats, frozen, position, orientation, inverse_mass,
                inverse_inertia_body, rows, moved):  # fmt: skip
    """Joint j's axis row (row 0) and its own rows that act now (rows 1..), with M^-1 J^T
    of each; returns how many, and the joint's position."""
    a, b = ints[j, BODY_A], ints[j, BODY_B]
    xa, qa = body_pose(a, position, orientation)
    xb, qb = body_pose(b, position, orientation)
    lin, ang_a, ang_b, place = axis_row(ints[j, KIND], floats[j], xa, qa, xb, qb)
    write_row(rows, 0, lin, ang_a, ang_b, 0.0)
    n = joint_rows(ints[j, KIND], floats[j], xa, qa, xb, qb, rows, 1, True)
    count = 0
    for k in range(n + 1):  # rows written as zero (limits not reached) are left out
        if row_written(rows, k):
            rows[count] = rows[k]
            count += 1
    row_responses(rows, np.full(count, j), count, ints, frozen, orientation, inverse_mass,
                  inverse_inertia_body, moved)  # fmt: skip
    return count, place


@njit
def _held_motion(j, ints, frozen, count, rows, moved, P, L, inverse_mass, orientation,
                 inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity):  # fmt: skip
    """The motor row's velocity and effective mass with its joint's own rows held, and the
    joint rows' reaction per unit motor impulse: the motor turns a hinged body about the
    hinge (its inertia about the axis through the anchor), not about its own centre."""
    A = np.empty((count, count))
    coupling_block(ints, np.full(count, j), rows, moved, 0, count, 0, count, A)
    speeds = np.empty(count)
    for k in range(count):
        speeds[k] = 0.0
        for side in range(2):
            body = ints[j, BODY_A + side]
            if body < 0:
                continue
            sign = 1.0 if side == 0 else -1.0
            if frozen[body]:
                # a kinematic body moves at its set velocity (a static one's is zero)
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
    held = count - 1
    reaction = np.zeros(count)
    velocity, mass_inverse = speeds[0], A[0, 0]
    if held > 0:
        Acc = A[1:, 1:].copy()
        kept = lu_in_place(Acc, held)
        x = A[1:, 0].copy()
        left_solve(Acc, kept, held, x, 0)
        y = speeds[1:].copy()
        left_solve(Acc, kept, held, y, 0)
        for k in range(held):
            reaction[k + 1] = x[k]
            mass_inverse -= A[0, k + 1] * x[k]
            velocity -= A[0, k + 1] * y[k]
    if not mass_inverse > 0.0:
        return velocity, 0.0, reaction
    return velocity, 1.0 / mass_inverse, reaction


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
def _servo_speed(h, kind, f, error, mass):
    """The rate a servo asks for its position ``error``: the one that closes it within the
    substep, but no more than its most speed, no faster than it can still stop from with
    its capped force (sqrt(2 a |e|) for the deceleration a = cap / effective mass: a capped
    servo that only brakes on arriving overshoots and rings), and, for a hinge, no more
    than ``_SERVO_TURN`` per substep (the joint's projection follows a turn of that size;
    a rate that grew as 1 / h would defeat the substeps a failed projection takes again)."""
    most = f[MOTOR_SPEED]
    if f[MOTOR_MAX] < math.inf:
        most = min(most, math.sqrt(2.0 * f[MOTOR_MAX] / mass * abs(error)))
    if kind == REVOLUTE:
        most = min(most, _SERVO_TURN / h)
    return min(max(error / h, -most), most)


@njit
def _wanted(h, kind, f, place, velocity, mass, applied):
    """The impulse a velocity, position or servo motor adds this sweep (before its cap),
    for its row's velocity now and effective mass, having applied ``applied`` this substep."""
    code = int(f[MOTOR])
    if code == VELOCITY_MOTOR:
        return mass * (f[MOTOR_TARGET] - velocity)
    error = f[MOTOR_TARGET] - place
    if kind == REVOLUTE:  # the short way round
        error -= 2.0 * math.pi * round(error / (2.0 * math.pi))
    if code == SERVO_MOTOR:
        return mass * (_servo_speed(h, kind, f, error, mass) - velocity)
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
