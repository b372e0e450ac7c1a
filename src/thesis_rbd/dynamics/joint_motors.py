"""Joint motors: a hinge or slider driven towards a velocity with a capped torque or force,
or pushed with a set one.

A motor acts along its joint's axis row (``joint_rows.axis_row``: a hinge's relative
rotation about its axis, a slider's relative travel along it) once per substep, after the
forces and before the bodies move, so the projection that holds the joint sees the motion the
motor gave:

* a velocity motor takes the impulse that brings the row's velocity J v to its target,
  (target - J v) / (J M^-1 J^T), clipped to the cap times the substep; the motors of an island
  are swept a few times (Gauss-Seidel), each accumulating and clipping its own impulse, since
  they share bodies;
* a torque motor gives the set torque (or force) times the substep.

Every impulse acts equally and oppositely on the two bodies along the row, so a motor
conserves the mechanism's total momentum as its joint does.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.integrators import angular_velocity
from thesis_rbd.dynamics.joint_rows import axis_row, body_pose
from thesis_rbd.dynamics.joint_set import (
    BODY_A,
    BODY_B,
    KIND,
    MOTOR,
    MOTOR_MAX,
    MOTOR_TARGET,
    NO_MOTOR,
    TORQUE_MOTOR,
)

__all__ = ["MOTOR_SWEEPS", "drive_motors"]

# Gauss-Seidel sweeps over an island's velocity motors per substep.
MOTOR_SWEEPS = 4


@njit
def _row_velocity_and_mass(body, sign, lin, ang, frozen, orientation, P, L, inverse_mass,
                           inverse_inertia_body):  # fmt: skip
    """One body's share of the row's velocity J v and of J M^-1 J^T."""
    if body < 0 or frozen[body]:
        return 0.0, 0.0
    q = orientation[body]
    qt = (q[0], q[1], q[2], q[3])
    im = inverse_mass[body]
    Iinv = inverse_inertia_body[body]
    w = angular_velocity(qt, (L[body, 0], L[body, 1], L[body, 2]), Iinv)
    turn = angular_velocity(qt, ang, Iinv)
    velocity = sign * im * (lin[0] * P[body, 0] + lin[1] * P[body, 1] + lin[2] * P[body, 2])
    velocity += ang[0] * w[0] + ang[1] * w[1] + ang[2] * w[2]
    mass = im * (lin[0] ** 2 + lin[1] ** 2 + lin[2] ** 2)
    mass += ang[0] * turn[0] + ang[1] * turn[1] + ang[2] * turn[2]
    return velocity, mass


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
    applied = np.zeros(len(joints))  # each velocity motor's impulse this substep
    for _ in range(sweeps):
        for e in range(len(joints)):
            j = joints[e]
            if int(floats[j, MOTOR]) == NO_MOTOR or int(floats[j, MOTOR]) == TORQUE_MOTOR:
                continue
            a, b = ints[j, BODY_A], ints[j, BODY_B]
            xa, qa = body_pose(a, position, orientation)
            xb, qb = body_pose(b, position, orientation)
            lin, ang_a, ang_b = axis_row(ints[j, KIND], floats[j], xa, qa, xb, qb)
            va, ma = _row_velocity_and_mass(a, 1.0, lin, ang_a, frozen, orientation,
                                            linear_momentum, angular_momentum, inverse_mass,
                                            inverse_inertia_body)  # fmt: skip
            vb, mb = _row_velocity_and_mass(b, -1.0, lin, ang_b, frozen, orientation,
                                            linear_momentum, angular_momentum, inverse_mass,
                                            inverse_inertia_body)  # fmt: skip
            if ma + mb <= 0.0:
                continue
            wanted = (floats[j, MOTOR_TARGET] - (va + vb)) / (ma + mb)
            cap = floats[j, MOTOR_MAX] * h
            total = min(max(applied[e] + wanted, -cap), cap)
            _apply(j, total - applied[e], ints, floats, frozen, position, orientation,
                   linear_momentum, angular_momentum, impulse)  # fmt: skip
            applied[e] = total


@njit
def _apply(j, lam, ints, floats, frozen, position, orientation, linear_momentum,
           angular_momentum, impulse):  # fmt: skip
    """An impulse lam along joint j's axis row: +row on body a, -row on body b."""
    a, b = ints[j, BODY_A], ints[j, BODY_B]
    xa, qa = body_pose(a, position, orientation)
    xb, qb = body_pose(b, position, orientation)
    lin, ang_a, ang_b = axis_row(ints[j, KIND], floats[j], xa, qa, xb, qb)
    for c in range(3):
        if a >= 0 and not frozen[a]:
            linear_momentum[a, c] += lin[c] * lam
            angular_momentum[a, c] += ang_a[c] * lam
        if b >= 0 and not frozen[b]:
            linear_momentum[b, c] -= lin[c] * lam
            angular_momentum[b, c] += ang_b[c] * lam
        impulse[j, c] += lin[c] * lam
        impulse[j, 3 + c] += ang_a[c] * lam
    impulse[j, 6] += lam
