"""Kinematic bodies: immovable bodies that move at the velocity their user set.

A kinematic body is a static body with a velocity (``BodyArrays.kinematic_velocity`` and
``kinematic_angular_velocity``): contacts and joints push against it and never move it, and
they see v and w as its velocity (``contact_kinematics.body_velocities``), so a box on a moving
kinematic platform is carried by friction and a ball leaves a kinematic paddle with the
restitution rule applied to their relative velocity. Its own stage, ``kinematic``, after the
integrator, moves it over each step of dt by the exact screw motion of constant v and w: its
centre of mass goes x + v dt and its orientation turns by w dt about that centre,
q <- exp(w dt) q. The joints stage places the bodies its joints hold to where this motion has
them at the start and end of each substep (``place_partners``), so a body jointed to a moving
kinematic body follows it within the step.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.joint_set import BODY_A, BODY_B
from thesis_rbd.spatial.quaternion import mul, normalize

__all__ = [
    "joint_partners",
    "move_kinematic_bodies",
    "moved_pose",
    "moving_bodies",
    "place_partners",
]


@njit
def moving_bodies(count, velocity, angular_velocity):
    """(count,) bool: the bodies with a kinematic velocity or angular velocity (``velocity``,
    ``angular_velocity`` (>= n, 3), zero but for kinematic bodies): those the kinematic stage
    moves this step."""
    moving = np.zeros(count, np.bool_)
    for i in range(count):
        for k in range(3):
            moving[i] |= velocity[i, k] != 0.0 or angular_velocity[i, k] != 0.0
    return moving


@njit(allocates=False)
def moved_pose(i, tau, velocity, angular_velocity, position, orientation):
    """Body i's pose moved by its kinematic velocity over ``tau`` seconds (negative: back).

    Parameters
    ----------
    i : int
    tau : float
        Seconds (s).
    velocity, angular_velocity : (>= n, 3) float64
        v and w of each body, world frame (w about its centre of mass).
    position, orientation : (>= n, 3), (>= n, 4) float64
        Where each body is now.

    Returns
    -------
    x, q : 3-tuple, 4-tuple
        x + tau v and exp(tau w) q, (x, y, z, w); the pose itself, to the bit, where tau is 0
        or the body does not move (a static body placed by the joints stage).
    """
    x, q, v, w = position[i], orientation[i], velocity[i], angular_velocity[i]
    moved_x = (x[0], x[1], x[2])
    if tau != 0.0 and (v[0] != 0.0 or v[1] != 0.0 or v[2] != 0.0):
        moved_x = (x[0] + tau * v[0], x[1] + tau * v[1], x[2] + tau * v[2])
    turned = (q[0], q[1], q[2], q[3])
    speed = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if tau != 0.0 and speed > 0.0:
        half = 0.5 * speed * tau
        s = math.sin(half) / speed
        turned = normalize(mul((s * w[0], s * w[1], s * w[2], math.cos(half)), turned))
    return moved_x, turned


@njit(allocates=False)
def move_kinematic_bodies(
    bodies, dt, velocity, angular_velocity, position, orientation, save_start, start_position,
    start_orientation,
):  # fmt: skip
    """The ``kinematic`` stage: move each kinematic body over the step by its velocity, in
    place.

    Parameters
    ----------
    bodies : (n,) bool
        The bodies to move: the moving kinematic ones (``moving_bodies``).
    dt : float
        Step (s).
    velocity, angular_velocity : (>= n, 3) float64
        ``BodyArrays.kinematic_velocity`` and ``kinematic_angular_velocity``.
    position, orientation : (>= n, 3), (>= n, 4) float64
        Body poses, moved in place.
    save_start : bool
        Whether to record where each body began the step (the collision stages read it).
    start_position, start_orientation : (>= n, 3), (>= n, 4) float64
        Out (``save_start``): the poses before the move.
    """
    for i in range(bodies.shape[0]):
        if not bodies[i]:
            continue
        if save_start:
            for k in range(3):
                start_position[i, k] = position[i, k]
            for k in range(4):
                start_orientation[i, k] = orientation[i, k]
        x, q = moved_pose(i, dt, velocity, angular_velocity, position, orientation)
        for k in range(3):
            position[i, k] = x[k]
        for k in range(4):
            orientation[i, k] = q[k]


@njit
def joint_partners(joints, ints, frozen, position, orientation):
    """The frozen bodies (static or kinematic) an island's ``joints`` hold to, and their poses.

    Parameters
    ----------
    joints : (j,) int64
        The island's joints.
    ints : (m, 3) int64
        ``JointSet.ints``.
    frozen : (>= n,) bool
    position, orientation : (>= n, 3), (>= n, 4) float64
        Body poses at the end of the step (the kinematic stage has moved its bodies).

    Returns
    -------
    partners : (p,) int64
        The bodies, each once, in the order the joints name them.
    ends : (p, 7) float64
        Each one's position and orientation at the end of the step.
    """
    listed = np.empty(2 * len(joints), np.int64)
    count = 0
    for j in joints:
        for side in (BODY_A, BODY_B):
            body = ints[j, side]
            if body < 0 or not frozen[body]:
                continue
            # an island holds to few frozen bodies: a scan, not a sort (numba's sorts are
            # compiled anew by every process)
            known = False
            for p in range(count):
                known |= listed[p] == body
            if not known:
                listed[count] = body
                count += 1
    partners = listed[:count]
    ends = np.empty((len(partners), 7))
    for p in range(len(partners)):
        ends[p, :3] = position[partners[p]]
        ends[p, 3:] = orientation[partners[p]]
    return partners, ends


@njit(allocates=False)
def place_partners(
    partners, ends, before_start, before_end, velocity, angular_velocity, substep_position,
    substep_orientation, position, orientation,
):  # fmt: skip
    """Place an island's frozen joint partners for one substep: where they are
    ``before_start`` seconds before the end of the step (the substep's start, into
    ``substep_position``, ``substep_orientation``) and ``before_end`` seconds before it (its
    end, into ``position``, ``orientation``), moving back from their poses at the end of the
    step ``ends`` (p, 7) by their kinematic velocities (``joint_partners``). A static partner
    stays where it is; the last substep (``before_end`` 0) leaves every partner at its pose
    at the end of the step, to the bit."""
    for p in range(len(partners)):
        i = partners[p]
        for k in range(3):
            position[i, k] = ends[p, k]
        for k in range(4):
            orientation[i, k] = ends[p, 3 + k]
        x, q = moved_pose(i, -before_start, velocity, angular_velocity, position, orientation)
        for k in range(3):
            substep_position[i, k] = x[k]
        for k in range(4):
            substep_orientation[i, k] = q[k]
        x, q = moved_pose(i, -before_end, velocity, angular_velocity, position, orientation)
        for k in range(3):
            position[i, k] = x[k]
        for k in range(4):
            orientation[i, k] = q[k]
