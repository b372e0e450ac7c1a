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
from thesis_rbd.dynamics.joint_newton import newton_solve
from thesis_rbd.dynamics.joint_rows import axis_row, body_pose, row_responses, write_row
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
    SERVO_VELOCITY,
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
    h, joints, tree, ints, floats, frozen, position, orientation, linear_momentum,
    angular_momentum, inverse_mass, inverse_inertia_body, impulse, kinematic_velocity,
    kinematic_angular_velocity, scratch,
):  # fmt: skip
    """Apply the motors, springs, dampers and friction of an island's ``joints`` for a
    substep of length h, in place.

    Parameters
    ----------
    h : float
        Substep (s).
    joints : (j,) int64
    tree : bool
        Whether the island is a tree.
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
    S, free_speed, reaction, places, axis = _held_island(
        swept, tree, ints, floats, frozen, position, orientation, linear_momentum,
        angular_momentum, inverse_mass, inverse_inertia_body, kinematic_velocity,
        kinematic_angular_velocity, scratch,
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
    # a servo's target moves on at its velocity
    for j in swept:
        if int(floats[j, MOTOR]) == SERVO_MOTOR and floats[j, SERVO_VELOCITY] != 0.0:
            target = floats[j, MOTOR_TARGET] + h * floats[j, SERVO_VELOCITY]
            if ints[j, KIND] == REVOLUTE:  # kept in (-pi, pi], as set
                target -= 2.0 * math.pi * math.ceil((target - math.pi) / (2.0 * math.pi))
            floats[j, MOTOR_TARGET] = target
    # the axis rows' impulses, and the held joint rows' reactions to them
    lam = np.empty(count)
    for e in range(count):
        lam[e] = applied[e, 0] + applied[e, 1] + applied[e, 2]
        _push(swept[e], lam[e], axis[e], ints, frozen, linear_momentum, angular_momentum,
              impulse)  # fmt: skip
        impulse[swept[e], 6] += applied[e, 0]
    held, row_joint = scratch[1], scratch[2]
    for r in range(len(row_joint)):
        push = 0.0
        for e in range(count):
            push -= reaction[r, e] * lam[e]
        if push != 0.0:
            _push(row_joint[r], push, held[r], ints, frozen, linear_momentum, angular_momentum,
                  impulse)  # fmt: skip


@njit
def _held_island(swept, tree, ints, floats, frozen, position, orientation, P, L, inverse_mass,
                 inverse_inertia_body, kinematic_velocity, kinematic_angular_velocity,
                 scratch):  # fmt: skip
    """The swept joints' axis rows with every joint row of the island held.

    With K = J M^-1 J^T over the island's joint rows (e, held) and the axis rows (m), an
    impulse lam along the axis rows, the held rows answering it with -K_ee^-1 K_em lam,
    changes the axis rows' velocities by S lam, S = K_mm - K_me K_ee^-1 K_em: the inverse
    of the mechanism's mass as the motors feel it (a shoulder's servo swings the arm beyond
    it, not its own link alone). K_ee is the island's Newton matrix of the substep
    (``joint_newton``, factorised already: each column of K_em costs one solve in time
    linear in a tree's joints); the held rows are its rows as they act (``scratch``'s
    ``current``, a limit not reached written as zero and dropped).

    Returns
    -------
    S : (m, m) float64
    free_speed : (m,) float64
        The axis rows' velocities once the held rows' own velocities are taken out.
    reaction : (r, m) float64
        K_ee^-1 K_em: the held rows' impulses per unit axis impulse, negated.
    places : (m,) float64
        Each swept joint's position.
    axis : (m, 10) float64
        The axis rows.
    """
    held, row_joint, moved = scratch[1], scratch[2], scratch[4]
    size = len(row_joint)
    count = len(swept)
    axis = np.empty((count, 10))
    places = np.empty(count)
    for e in range(count):
        j = swept[e]
        xa, qa = body_pose(ints[j, BODY_A], position, orientation)
        xb, qb = body_pose(ints[j, BODY_B], position, orientation)
        lin, ang_a, ang_b, places[e] = axis_row(ints[j, KIND], floats[j], xa, qa, xb, qb)
        write_row(axis, e, lin, ang_a, ang_b, 0.0)
    axis_moved = np.empty((count, 12))
    row_responses(axis, swept, count, ints, frozen, orientation, inverse_mass,
                  inverse_inertia_body, axis_moved)  # fmt: skip
    # K_me (the axis rows against the held rows' responses) and K_ee^-1 K_em
    K_me = np.zeros((count, size))
    reaction = np.zeros((size, count))
    for e in range(count):
        for r in range(size):
            if _share_a_body(ints, row_joint[r], swept[e]):
                reaction[r, e] = _coupling(ints, row_joint[r], held, r, swept[e], axis_moved, e)
                K_me[e, r] = _coupling(ints, swept[e], axis, e, row_joint[r], moved, r)
    newton_solve(tree, scratch, reaction)
    held_speed = _row_speeds(held, row_joint, size, ints, frozen, orientation, P, L,
                             inverse_mass, inverse_inertia_body, kinematic_velocity,
                             kinematic_angular_velocity)  # fmt: skip
    axis_speed = _row_speeds(axis, swept, count, ints, frozen, orientation, P, L, inverse_mass,
                             inverse_inertia_body, kinematic_velocity,
                             kinematic_angular_velocity)  # fmt: skip
    S = np.empty((count, count))
    free_speed = np.empty(count)
    for e in range(count):
        free_speed[e] = axis_speed[e]
        for r in range(size):
            free_speed[e] -= reaction[r, e] * held_speed[r]
        for k in range(count):
            S[e, k] = _coupling(ints, swept[e], axis, e, swept[k], axis_moved, k)
            for r in range(size):
                S[e, k] -= K_me[e, r] * reaction[r, k]
    return S, free_speed, reaction, places, axis


@njit(allocates=False)
def _share_a_body(ints, joint_i, joint_k):
    """Whether two joints share a body (the world aside): only then are they coupled."""
    a, b = ints[joint_i, BODY_A], ints[joint_i, BODY_B]
    c, d = ints[joint_k, BODY_A], ints[joint_k, BODY_B]
    return (a >= 0 and (a == c or a == d)) or (b >= 0 and (b == c or b == d))


@njit(allocates=False)
def _coupling(ints, joint_i, rows, i, joint_k, moved, k):
    """J_i M^-1 J_k^T of row i of ``rows`` (a row of joint_i) against row k of ``moved``
    (the response of a row of joint_k, ``row_responses``), over the bodies they share."""
    total = 0.0
    for side_i in range(2):
        body = ints[joint_i, BODY_A + side_i]
        if body < 0:
            continue
        sign = 1.0 if side_i == 0 else -1.0
        for side_k in range(2):
            if ints[joint_k, BODY_A + side_k] != body:
                continue
            for c in range(3):
                total += sign * rows[i, c] * moved[k, 6 * side_k + c]
                total += rows[i, 3 + 3 * side_i + c] * moved[k, 6 * side_k + 3 + c]
    return total


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
    kept = np.empty(count, np.bool_)
    lu_in_place(D, count, kept)
    unit = np.empty(count)
    for e in range(count):
        if not kept[e]:
            continue
        for k in range(count):
            unit[k] = 1.0 if k == e else 0.0
        left_solve(D, kept, count, unit.reshape((count, 1)), 0)
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
    takes again). A target moving at the servo's velocity is met where it will be at the
    substep's end: that rate is added to the closing one (the braking bounds the closing
    rate, relative to the target)."""
    most = f[MOTOR_SPEED]
    closing = most
    if f[MOTOR_MAX] < math.inf:
        closing = min(closing, math.sqrt(f[MOTOR_MAX] / moved * abs(error)))
    if kind == REVOLUTE:
        most = min(most, _SERVO_TURN / h)
    rate = min(max(error / h, -closing), closing) + f[SERVO_VELOCITY]
    return min(max(rate, -most), most)


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
