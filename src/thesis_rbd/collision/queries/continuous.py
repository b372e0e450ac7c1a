"""Continuous collision: the first time two moving meshes touch, :func:`continuous_collide`.

Each mesh moves from its first pose to its second over the time fraction t in [0, 1]: the
mesh-frame origin along the straight segment, the orientation by spherical interpolation
(constant angular velocity about a fixed axis, through the smaller angle), as python-fcl's
linear motion does.

The search is Mirtich's conservative advancement on the exact distance query
(:func:`.distance.mesh_distance`). Every point of A moves with speed at most ``|v_A| +
theta_A r_A`` (translation per unit t, rotation angle per unit t times the largest distance of
a vertex from the mesh-frame origin), so the relative speed of any point of A against any point
of B is at most ``mu = |v_A - v_B| + theta_A r_A + theta_B r_B`` and the distance ``d(t)`` can
fall by at most ``mu`` per unit t. From a time t with distance d, no contact can occur before
``t + (d - tol / 2) / mu``, so the search steps there, never past a contact, until the distance
is within ``tol`` (contact, reported at that time) or the step passes t = 1 (no contact). The
steps shrink geometrically as the meshes approach, so the number of distance queries grows with
the logarithm of (initial distance / tol) divided by how much of ``mu`` is actual approach.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.packed import tree_radius, tree_scale
from thesis_rbd.collision.queries._query_args import call_normalised, sealed
from thesis_rbd.collision.queries.distance import mesh_distance, pose_stacks
from thesis_rbd.spatial.quaternion import from_matrix

__all__ = ["ContinuousResult", "continuous_collide"]

# Contact distance as a fraction of the larger mesh's size, when none is given.
TOLERANCE_FRACTION = 1e-9
# Distance queries per motion before giving up (only a motion that grazes the other mesh at a
# distance just above the tolerance comes near it).
MAX_STEPS = 1_000_000


class ContinuousResult:
    """Outcome of :func:`continuous_collide`.

    Attributes
    ----------
    colliding : bool, or (k,) bool for pose stacks
        True if the meshes come within the contact tolerance during the motion.
    time : float, or (k,)
        Fraction of the motion in [0, 1] at which they first do (1.0 when they never do).
    poses : (2, 4, 4), or (k, 2, 4, 4)
        The poses of A and of B at ``time``.
    distance : float, or (k,)
        Their distance then (at most the tolerance when colliding).
    steps : int
        Distance queries made (summed over the stack).
    """

    __slots__ = ("colliding", "distance", "poses", "steps", "time")

    def __init__(self, colliding, time, poses, distance, steps):
        self.colliding = colliding
        self.time = time
        self.poses = poses
        self.distance = distance
        self.steps = steps

    def __repr__(self) -> str:
        return f"ContinuousResult(colliding={self.colliding}, time={self.time})"


@njit
def _motion(T0, T1):
    """(R0 row-major 9-tuple, p0, v, axis, angle) of the motion T0 -> T1: translation
    ``p(t) = p0 + t v``, rotation ``R(t) = R0 Rot(axis, t angle)``."""
    rel = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            rel[i, j] = T0[0, i] * T1[0, j] + T0[1, i] * T1[1, j] + T0[2, i] * T1[2, j]
    q = from_matrix(rel)
    s = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
    angle = 2.0 * math.atan2(s, q[3])
    axis = (1.0, 0.0, 0.0) if s == 0.0 else (q[0] / s, q[1] / s, q[2] / s)
    R0 = (T0[0, 0], T0[0, 1], T0[0, 2], T0[1, 0], T0[1, 1], T0[1, 2], T0[2, 0], T0[2, 1], T0[2, 2])
    p0 = (T0[0, 3], T0[1, 3], T0[2, 3])
    v = (T1[0, 3] - T0[0, 3], T1[1, 3] - T0[1, 3], T1[2, 3] - T0[2, 3])
    return R0, p0, v, axis, angle


@njit
def _pose_at(motion, t):
    """(R row-major 9-tuple, p) of a motion at time fraction t."""
    R0, p0, v, k, angle = motion
    c = math.cos(t * angle)
    s = math.sin(t * angle)
    u = 1.0 - c
    # Rodrigues: Rot = c I + s [k]x + u k k^T
    Q = (
        c + u * k[0] * k[0],
        u * k[0] * k[1] - s * k[2],
        u * k[0] * k[2] + s * k[1],
        u * k[1] * k[0] + s * k[2],
        c + u * k[1] * k[1],
        u * k[1] * k[2] - s * k[0],
        u * k[2] * k[0] - s * k[1],
        u * k[2] * k[1] + s * k[0],
        c + u * k[2] * k[2],
    )
    R = (
        R0[0] * Q[0] + R0[1] * Q[3] + R0[2] * Q[6],
        R0[0] * Q[1] + R0[1] * Q[4] + R0[2] * Q[7],
        R0[0] * Q[2] + R0[1] * Q[5] + R0[2] * Q[8],
        R0[3] * Q[0] + R0[4] * Q[3] + R0[5] * Q[6],
        R0[3] * Q[1] + R0[4] * Q[4] + R0[5] * Q[7],
        R0[3] * Q[2] + R0[4] * Q[5] + R0[5] * Q[8],
        R0[6] * Q[0] + R0[7] * Q[3] + R0[8] * Q[6],
        R0[6] * Q[1] + R0[7] * Q[4] + R0[8] * Q[7],
        R0[6] * Q[2] + R0[7] * Q[5] + R0[8] * Q[8],
    )
    p = (p0[0] + t * v[0], p0[1] + t * v[1], p0[2] + t * v[2])
    return R, p


@njit
def _relative(Ra, pa, Rb, pb):
    """B's mesh frame in A's: (Ra^T Rb as a row-major 9-tuple, Ra^T (pb - pa))."""
    M = (
        Ra[0] * Rb[0] + Ra[3] * Rb[3] + Ra[6] * Rb[6],
        Ra[0] * Rb[1] + Ra[3] * Rb[4] + Ra[6] * Rb[7],
        Ra[0] * Rb[2] + Ra[3] * Rb[5] + Ra[6] * Rb[8],
        Ra[1] * Rb[0] + Ra[4] * Rb[3] + Ra[7] * Rb[6],
        Ra[1] * Rb[1] + Ra[4] * Rb[4] + Ra[7] * Rb[7],
        Ra[1] * Rb[2] + Ra[4] * Rb[5] + Ra[7] * Rb[8],
        Ra[2] * Rb[0] + Ra[5] * Rb[3] + Ra[8] * Rb[6],
        Ra[2] * Rb[1] + Ra[5] * Rb[4] + Ra[8] * Rb[7],
        Ra[2] * Rb[2] + Ra[5] * Rb[5] + Ra[8] * Rb[8],
    )
    d = (pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2])
    t = (
        Ra[0] * d[0] + Ra[3] * d[1] + Ra[6] * d[2],
        Ra[1] * d[0] + Ra[4] * d[1] + Ra[7] * d[2],
        Ra[2] * d[0] + Ra[5] * d[1] + Ra[8] * d[2],
    )
    return M, t


@njit
def _write_pose(out, R, p):
    for i in range(3):
        for j in range(3):
            out[i, j] = R[3 * i + j]
        out[i, 3] = p[i]
        out[3, i] = 0.0
    out[3, 3] = 1.0


@njit
def advance(P_a, motion_a, P_b, motion_b, tolerance):
    """Conservative advancement of one motion pair: (status, t, distance, steps).

    status 1: contact at t; 0: none (t = 1); 2: gave up after ``MAX_STEPS`` queries.
    """
    va = motion_a[2]
    vb = motion_b[2]
    dv = (va[0] - vb[0], va[1] - vb[1], va[2] - vb[2])
    mu = (
        math.sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2])
        + motion_a[4] * tree_radius(P_a)
        + motion_b[4] * tree_radius(P_b)
    )
    t = 0.0
    for step in range(1, MAX_STEPS + 1):
        Ra, pa = _pose_at(motion_a, t)
        Rb, pb = _pose_at(motion_b, t)
        M, tr = _relative(Ra, pa, Rb, pb)
        d = mesh_distance(P_a, P_b, M, tr)[0]
        if d <= tolerance:
            return 1, t, d, step
        if t >= 1.0 or mu == 0.0:
            return 0, 1.0, d, step
        t = min(1.0, t + (d - 0.5 * tolerance) / mu)
    return 2, t, math.inf, MAX_STEPS


@sealed
@njit
def _continuous_kernel(P_a, Ta0, Ta1, P_b, Tb0, Tb1, tolerance):
    """Conservative advancement over pose stacks (k_i, 4, 4) checked by ``pose_stacks``, a
    stack of one broadcast; ``tolerance`` < 0 means the default fraction of the size.

    Returns (status (k,) int64, time (k,), distance (k,), poses (k, 2, 4, 4), steps).
    """
    k = max(Ta0.shape[0], Ta1.shape[0], Tb0.shape[0], Tb1.shape[0])
    if tolerance < 0.0:
        tolerance = TOLERANCE_FRACTION * max(tree_scale(P_a), tree_scale(P_b))
    status = np.empty(k, dtype=np.int64)
    times = np.empty(k)
    distances = np.empty(k)
    poses = np.empty((k, 2, 4, 4))
    steps = 0
    for i in range(k):
        motion_a = _motion(Ta0[min(i, Ta0.shape[0] - 1)], Ta1[min(i, Ta1.shape[0] - 1)])
        motion_b = _motion(Tb0[min(i, Tb0.shape[0] - 1)], Tb1[min(i, Tb1.shape[0] - 1)])
        status[i], times[i], distances[i], n = advance(P_a, motion_a, P_b, motion_b, tolerance)
        steps += n
        Ra, pa = _pose_at(motion_a, times[i])
        Rb, pb = _pose_at(motion_b, times[i])
        _write_pose(poses[i, 0], Ra, pa)
        _write_pose(poses[i, 1], Rb, pb)
    return status, times, distances, poses, steps


def continuous_collide(tree_a, T_a0, T_a1, tree_b, T_b0, T_b1, tolerance=None) -> ContinuousResult:
    """First time of contact of two meshes moving from one pose to another.

    Parameters
    ----------
    tree_a, tree_b : OBBTree
        The two meshes' trees.
    T_a0, T_a1, T_b0, T_b1 : (4, 4) or (k, 4, 4) array_like of float
        Start and end poses (rigid transforms from mesh frame to world) of A and of B. Each
        mesh's origin moves along a straight line and its orientation turns at constant
        angular velocity (spherical interpolation) between the two. Any of them may be a
        stack of k motions (a single pose is used with every motion); the result's fields
        then have a leading axis of length k.
    tolerance : float, optional
        Distance at which the meshes count as touching; default ``1e-9`` times the larger
        mesh's size (bounding-box diagonal).

    Returns
    -------
    ContinuousResult
        ``colliding``, ``time`` (fraction of the motion, 1.0 when they never touch),
        ``poses`` (A's and B's poses then), ``distance`` (their distance then).

    Raises
    ------
    ValueError
        On a tree that is not an OBBTree, a pose that is not a finite rigid transform,
        stacks of different lengths, or a tolerance that is not positive and finite.
    RuntimeError
        If a motion needs more than a million distance queries (it grazes the other mesh at
        a distance just above the tolerance); a larger tolerance resolves it.

    Notes
    -----
    The reported time is never later than the first contact: the search only advances by
    steps over which the distance provably stays above half the tolerance.
    """
    if tolerance is None:
        tol = -1.0
    else:
        try:
            tol = float(tolerance)
        except (TypeError, ValueError):
            raise ValueError(f"tolerance must be a number, got {tolerance!r}") from None
        if not (math.isfinite(tol) and tol > 0.0):
            raise ValueError(f"tolerance must be positive and finite, got {tolerance!r}")
    P_a, S_a0, P_b, S_b0 = pose_stacks(tree_a, T_a0, tree_b, T_b0, ("T_a0", "T_b0"), hull=True)
    _, S_a1, _, S_b1 = pose_stacks(tree_a, T_a1, tree_b, T_b1, ("T_a1", "T_b1"))
    lengths = {len(S) for S in (S_a0, S_a1, S_b0, S_b1)} - {1}
    if len(lengths) > 1:
        raise ValueError(f"pose stacks must have one length (or one pose), got {sorted(lengths)}")
    status, times, distances, poses, steps = call_normalised(
        _continuous_kernel, P_a, S_a0, S_a1, P_b, S_b0, S_b1, tol
    )
    if np.any(status == 2):
        raise RuntimeError(
            f"continuous_collide gave up after {MAX_STEPS} distance queries: the motion grazes "
            "the other mesh just above the contact tolerance; pass a larger tolerance"
        )
    if max(np.ndim(T) for T in (T_a0, T_a1, T_b0, T_b1)) < 3:
        return ContinuousResult(
            bool(status[0] == 1), float(times[0]), poses[0], float(distances[0]), int(steps)
        )
    return ContinuousResult(status == 1, times, poses, distances, int(steps))
