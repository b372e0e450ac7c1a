"""Ballistic motion: a body moved by time t under a constant acceleration and torque-free spin.

    x(t) = x + v t + a t^2 / 2,   v(t) = v + a t,   q turned freely with L held,

exact for a constant force over the interval; the turn is ``free_rotation.turn_freely``'s, which
keeps the kinetic energy and angular momentum of any spin (turning by w t with w held does not,
off a principal axis). A negative t goes back along the path (the time-of-impact search, then the
impacts stage carrying the bodies forward again).
"""

from __future__ import annotations

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.free_rotation import turn_freely

__all__ = ["move_ballistic"]


@njit
def move_ballistic(
    members, t, v, angular_momentum, inverse_inertia_body, acceleration, position, orientation
):  # fmt: skip
    """Move the bodies ``members`` (m,) by time t (negative: back) along their ballistic paths.

    Velocities ``v`` (n, 3) follow (v + a t); the world angular momenta ``angular_momentum``
    (n, 3) are kept (torque-free spin), with ``inverse_inertia_body`` (n, 3, 3).
    """
    for idx in range(members.shape[0]):
        i = members[idx]
        for a in range(3):
            position[i, a] += v[i, a] * t + 0.5 * acceleration[i, a] * t * t
            v[i, a] += acceleration[i, a] * t
        q = turn_freely(orientation[i], angular_momentum[i], inverse_inertia_body[i], t)
        for k in range(4):
            orientation[i, k] = q[k]
