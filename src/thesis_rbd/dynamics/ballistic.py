"""Ballistic motion: a body moved by time t under a constant acceleration and torque-free spin.

    x(t) = x + v t + a t^2 / 2,   v(t) = v + a t,   q turned by w t,

exact for a constant force over the interval and torque-free spin about a fixed axis; a
negative t retraces the path (the time-of-impact search, then the impacts stage carrying the
bodies forward again).
"""

from __future__ import annotations

import math

from thesis_rbd._numba.jit import njit
from thesis_rbd.spatial.quaternion import mul, normalize

__all__ = ["move_ballistic"]


@njit
def move_ballistic(members, t, v, w, acceleration, position, orientation):
    """Move the bodies ``members`` (m,) by time t (negative: back) along their ballistic paths.

    Velocities ``v`` (n, 3) follow (v + a t); ``w`` (n, 3) is kept (torque-free spin).
    """
    for idx in range(members.shape[0]):
        i = members[idx]
        for a in range(3):
            position[i, a] += v[i, a] * t + 0.5 * acceleration[i, a] * t * t
            v[i, a] += acceleration[i, a] * t
        rx, ry, rz = w[i, 0] * t, w[i, 1] * t, w[i, 2] * t
        angle = math.sqrt(rx * rx + ry * ry + rz * rz)
        if angle == 0.0:
            continue
        s = math.sin(0.5 * angle) / angle
        turn = (rx * s, ry * s, rz * s, math.cos(0.5 * angle))
        q = (orientation[i, 0], orientation[i, 1], orientation[i, 2], orientation[i, 3])
        q = normalize(mul(turn, q))
        for k in range(4):
            orientation[i, k] = q[k]
