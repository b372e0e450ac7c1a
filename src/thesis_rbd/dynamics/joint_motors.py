"""Joint motors: a hinge or slider driven towards a velocity or a position with a capped
torque or force, or pushed with a set one.

A motor acts along its joint's axis row (``joint_rows.axis_row``: a hinge's relative
rotation about its axis, a slider's relative travel along it) once per substep, after the
forces and before the bodies move, so the projection that holds the joint sees the motion the
motor gave:

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
  reaches the target in one substep, clipped to its most speed, taken with the capped
  impulse of a velocity motor.

Every impulse acts equally and oppositely on the two bodies along the row, so a motor
conserves the mechanism's total momentum as its joint does.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.integrators import angular_velocity
from thesis_rbd.dynamics.joint_rows import (
    axis_row,
    body_pose,
    joint_rows,
    row_coupling,
    row_responses,
    row_written,
    write_row,
)
from thesis_rbd.dynamics.joint_set import (
    BODY_A,
    BODY_B,
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
    TORQUE_MOTOR,
    VELOCITY_MOTOR,
)
from thesis_rbd.dynamics.joint_tree import left_solve, lu_in_place

__all__ = ["MOTOR_SWEEPS", "drive_motors"]

REVOLUTE = JOINT_KINDS["revolute"]

# Gauss-Seidel sweeps over an island's velocity, position and servo motors per substep.
MOTOR_SWEEPS = 4


@njit
def drive_motors(
    h, joints, ints, floats, frozen, position, orientation, linear_momentum, angular_momentum,
    inverse_mass, inverse_inertia_body, impulse,
):  # fmt: skip
    """Apply the motors of an island's ``joints`` for a substep of length h, in place.

    Parameters
    ----------
    h : float
        Substep (s).
    joints : (j,) int64
    ints, floats : ``JointSet`` arrays.
    frozen : (>= n,) bool
    position ... inverse_inertia_body : body arrays (``integrate_bodies``).
    impulse : (m, 7) float64
        Each joint's impulses over the step: the motors' are added to its linear and angular
        impulse on body a (columns 0-5) and, along the axis, to column 6.
    """
    sweeps = 0
    for j in joints:
        code = int(floats[j, MOTOR])
        if code == TORQUE_MOTOR:
            _apply(j, floats[j, MOTOR_TARGET] * h, ints, floats, frozen, position, orientation,
                   linear_momentum, angular_momentum, impulse)  # fmt: skip
        elif code != NO_MOTOR:
            sweeps = MOTOR_SWEEPS
    if sweeps == 0:
        return
    applied = np.zeros(len(joints))  # each motor's impulse this substep
    rows = np.empty((8, 10))  # the motor's row, then its joint's own rows
    moved = np.empty((8, 12))
    for _ in range(sweeps):
        for e in range(len(joints)):
            j = joints[e]
            if int(floats[j, MOTOR]) == NO_MOTOR or int(floats[j, MOTOR]) == TORQUE_MOTOR:
                continue
            count, place = _motor_rows(j, ints, floats, frozen, position, orientation,
                                       inverse_mass, inverse_inertia_body, rows, moved)  # fmt: skip
            velocity, mass, reaction = _held_motion(
                j, ints, frozen, count, rows, moved, linear_momentum, angular_momentum,
                inverse_mass, orientation, inverse_inertia_body,
            )  # fmt: skip
            if not mass > 0.0:
                continue
            wanted = _wanted(h, ints[j, KIND], floats[j], place, velocity, mass, applied[e])
            cap = floats[j, MOTOR_MAX] * h
            total = min(max(applied[e] + wanted, -cap), cap)
            lam = total - applied[e]
            applied[e] = total
            for k in range(count):
                _push(j, (lam if k == 0 else -reaction[k] * lam), rows[k], ints, frozen,
                      linear_momentum, angular_momentum, impulse)  # fmt: skip
            impulse[j, 6] += lam


@njit
def _motor_rows(j, ints, floats, frozen, position, orientation, inverse_mass,
                inverse_inertia_body, rows, moved):  # fmt: skip
    """Joint j's motor row (row 0) and its own rows that act now (rows 1..), with M^-1 J^T
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
                 inverse_inertia_body):  # fmt: skip
    """The motor row's velocity and effective mass with its joint's own rows held, and the
    joint rows' reaction per unit motor impulse: the motor turns a hinged body about the
    hinge (its inertia about the axis through the anchor), not about its own centre."""
    A = np.empty((count, count))
    row_joint = np.full(count, j)
    for i in range(count):
        for k in range(count):
            A[i, k] = row_coupling(ints, row_joint, rows, moved, i, k)
    speeds = np.empty(count)
    for k in range(count):
        speeds[k] = 0.0
        for side in range(2):
            body = ints[j, BODY_A + side]
            if body < 0 or frozen[body]:
                continue
            q = orientation[body]
            w = angular_velocity((q[0], q[1], q[2], q[3]), (L[body, 0], L[body, 1], L[body, 2]),
                                 inverse_inertia_body[body])  # fmt: skip
            sign = 1.0 if side == 0 else -1.0
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
        speed = min(max(error / h, -f[MOTOR_SPEED]), f[MOTOR_SPEED])
        return mass * (speed - velocity)
    # position: lam = h k e - beta v+, v+ = velocity + (lam - applied) / mass
    beta = h * (f[MOTOR_STIFFNESS] * h + f[MOTOR_DAMPING])
    total = (h * f[MOTOR_STIFFNESS] * error - beta * velocity + beta * applied / mass) / (
        1.0 + beta / mass
    )
    return total - applied


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
