"""Per-body and per-contact quantities the contact kernels share.

Body velocities from momenta (v = P / M, w = I^-1 L with the world inverse inertia
I^-1 = R I_body^-1 R^T), the normal velocity of a contact, each contact's slop, and writing
momenta back from velocities. Immovable bodies (static, kinematic or asleep) have zero inverse
inertia and the velocity their user set: zero but for a kinematic body's.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.spatial.quaternion import to_matrix_into

__all__ = [
    "body_velocities",
    "contact_arms",
    "contact_slop",
    "contact_tolerances",
    "normal_velocity",
    "write_momenta",
]


@njit
def contact_tolerances(body_a, body_b, static, thickness, slop_fraction):
    """(c,) slop of each contact: ``slop_fraction`` of its thinner dynamic body."""
    c = body_a.shape[0]
    slop = np.empty(c)
    for k in range(c):
        slop[k] = contact_slop(body_a[k], body_b[k], static, thickness, slop_fraction)
    return slop


@njit(inline="always")
def contact_slop(a, b, static, thickness, slop_fraction):
    """The slop of one contact between bodies a and b: ``slop_fraction`` of its thinner
    dynamic body (inf between two static bodies)."""
    thinnest = np.inf
    if not static[a]:
        thinnest = thickness[a]
    if not static[b]:
        thinnest = min(thinnest, thickness[b])
    return slop_fraction * thinnest


@njit
def contact_arms(points, position, rows, body_a, body_b):
    """Lever arms (k, 3) of the contacts ``rows`` (k,) of ``points`` (c, 3), world frame:
    each point minus the centre of mass of its body in ``body_a`` / ``body_b`` (k,), which
    are already the bodies of those rows."""
    k = rows.shape[0]
    arm_a = np.empty((k, 3))
    arm_b = np.empty((k, 3))
    for r in range(k):
        for a in range(3):
            arm_a[r, a] = points[rows[r], a] - position[body_a[r], a]
            arm_b[r, a] = points[rows[r], a] - position[body_b[r], a]
    return arm_a, arm_b


@njit
def world_tensor(q, tensor_body, R, out):
    """out[:3, :3] = R X R^T: a body-frame tensor X (3, 3), such as I_body or its inverse,
    in the world frame, for the unit quaternion q (``R`` (3, 3) is scratch)."""
    to_matrix_into(q, R)
    for a in range(3):
        for b in range(3):
            total = 0.0
            for c in range(3):
                total += (
                    R[a, 0] * tensor_body[0, c]
                    + R[a, 1] * tensor_body[1, c]
                    + R[a, 2] * tensor_body[2, c]
                ) * R[b, c]
            out[a, b] = total


@njit
def body_velocities(count, static, orientation, linear_momentum, angular_momentum,
                    inverse_mass, inverse_inertia_body, kinematic_velocity,
                    kinematic_angular_velocity):  # fmt: skip
    """v = P / M, w = I^-1 L and the world inverse inertia I^-1 = R I_body^-1 R^T.

    ``static`` (>= n,) bool marks the immovable bodies (static, kinematic or asleep): their
    inverse inertia is zero and their velocities are ``kinematic_velocity`` and
    ``kinematic_angular_velocity`` (>= n, 3), world frame, zero but for a kinematic body's.

    Returns v, w (n, 3) and I^-1 (n, 3, 3).
    """
    v = np.zeros((count, 3))
    w = np.zeros((count, 3))
    inverse_inertia = np.zeros((count, 3, 3))
    R = np.empty((3, 3))
    for i in range(count):
        if static[i]:
            for a in range(3):
                v[i, a] = kinematic_velocity[i, a]
                w[i, a] = kinematic_angular_velocity[i, a]
            continue
        world_tensor(orientation[i], inverse_inertia_body[i], R, inverse_inertia[i])
        Ii = inverse_inertia[i]
        for a in range(3):
            v[i, a] = linear_momentum[i, a] * inverse_mass[i]
            w[i, a] = (
                Ii[a, 0] * angular_momentum[i, 0]
                + Ii[a, 1] * angular_momentum[i, 1]
                + Ii[a, 2] * angular_momentum[i, 2]
            )
    return v, w, inverse_inertia


@njit
def _relative_component(i, k, a, b, arm_a, arm_b, v, w):
    j, l = (i + 1) % 3, (i + 2) % 3
    ua = v[a, i] + w[a, j] * arm_a[k, l] - w[a, l] * arm_a[k, j]
    ub = v[b, i] + w[b, j] * arm_b[k, l] - w[b, l] * arm_b[k, j]
    return ua - ub


@njit
def relative_velocity(k, a, b, arm_a, arm_b, v, w):
    """u = (v + w x r)_a - (v + w x r)_b at contact k (3 floats, world frame)."""
    return (
        _relative_component(0, k, a, b, arm_a, arm_b, v, w),
        _relative_component(1, k, a, b, arm_a, arm_b, v, w),
        _relative_component(2, k, a, b, arm_a, arm_b, v, w),
    )


@njit
def normal_velocity(k, a, b, normal, arm_a, arm_b, v, w):
    """u . n at contact k for body velocities v, w."""
    u = relative_velocity(k, a, b, arm_a, arm_b, v, w)
    return normal[k, 0] * u[0] + normal[k, 1] * u[1] + normal[k, 2] * u[2]


@njit
def write_momenta(bodies, orientation, inertia_body, inverse_mass, v, w,
                  linear_momentum, angular_momentum):  # fmt: skip
    """P = M v and L = R I_body R^T w for the listed bodies; returns the first body whose
    new state is not finite, or -1."""
    R = np.empty((3, 3))
    bad = -1
    for idx in range(bodies.shape[0]):
        i = bodies[idx]
        to_matrix_into(orientation[i], R)
        I = inertia_body[i]
        for a in range(3):
            linear_momentum[i, a] = v[i, a] / inverse_mass[i]
            total = 0.0
            for b in range(3):
                row = R[a, 0] * I[0, b] + R[a, 1] * I[1, b] + R[a, 2] * I[2, b]
                total += row * (R[0, b] * w[i, 0] + R[1, b] * w[i, 1] + R[2, b] * w[i, 2])
            angular_momentum[i, a] = total
        for a in range(3):
            if not (math.isfinite(linear_momentum[i, a]) and math.isfinite(angular_momentum[i, a])):
                if bad < 0:
                    bad = i
    return bad
