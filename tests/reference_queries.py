"""Slow, independent oracles for the queries beyond overlap: distance, motions, rays.

Nothing here calls ``thesis_rbd.collision``'s kernels. Triangle distances are plain Python over
feature pairs, with the segment pairs solved from the 2x2 normal equations by NumPy (the
library uses the common-normal form) and intersection decided by the plain-Python
separating-axis oracle of :mod:`reference`; the brute-force mesh distance measures every
triangle pair that a box prefilter cannot rule out. Motions are interpolated with SciPy's
``Slerp``.
"""

from __future__ import annotations

import numpy as np
from reference import point_triangle_distance, tri_tri_sat
from scipy.spatial.transform import Rotation, Slerp

__all__ = [
    "brute_force_distance",
    "interpolated_pose",
    "segment_distance",
    "triangle_distance_reference",
]


def _point_segment(x, p, q) -> float:
    d = q - p
    dd = float(d @ d)
    t = 0.0 if dd == 0.0 else min(max(float((x - p) @ d) / dd, 0.0), 1.0)
    return float(np.linalg.norm(x - (p + t * d)))


def segment_distance(p0, p1, q0, q1) -> float:
    """Distance between segments [p0, p1] and [q0, q1]: end point cases and, when the least
    squares solution of the normal equations lies inside the unit square, the interior one."""
    p0, p1, q0, q1 = (np.asarray(v, dtype=float) for v in (p0, p1, q0, q1))
    best = min(
        _point_segment(p0, q0, q1),
        _point_segment(p1, q0, q1),
        _point_segment(q0, p0, p1),
        _point_segment(q1, p0, p1),
    )
    u = p1 - p0
    v = q1 - q0
    A = np.array([[u @ u, -(u @ v)], [-(u @ v), v @ v]])
    b = np.array([(q0 - p0) @ u, -((q0 - p0) @ v)])
    if np.linalg.matrix_rank(A) == 2:
        s, t = np.linalg.solve(A, b)
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            best = min(best, float(np.linalg.norm(p0 + s * u - (q0 + t * v))))
    return best


def triangle_distance_reference(P, Q) -> float:
    """Distance between triangles P and Q (3, 3): 0 if the SAT oracle says they overlap, else
    the least corner-triangle and edge-edge distance."""
    P = np.asarray(P, dtype=float)
    Q = np.asarray(Q, dtype=float)
    if tri_tri_sat(P, Q)[0]:
        return 0.0
    best = min(
        min(point_triangle_distance(p, Q) for p in P), min(point_triangle_distance(q, P) for q in Q)
    )
    for i in range(3):
        for j in range(3):
            best = min(best, segment_distance(P[i], P[(i + 1) % 3], Q[j], Q[(j + 1) % 3]))
    return best


def _world_triangles(mesh, T) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    return mesh.triangles @ T[:3, :3].T + T[:3, 3]


def brute_force_distance(mesh_a, T_a, mesh_b, T_b) -> float:
    """Least distance between two posed meshes over all triangle pairs.

    An upper bound U (the least corner-to-corner distance) rules out every pair whose
    axis-aligned boxes are farther apart than U; the rest are measured by
    :func:`triangle_distance_reference`.
    """
    ta = _world_triangles(mesh_a, T_a)
    tb = _world_triangles(mesh_b, T_b)
    va = ta.reshape(-1, 3)
    vb = tb.reshape(-1, 3)
    upper = float(np.sqrt(((va[:, None, :] - vb[None, :, :]) ** 2).sum(-1)).min())
    lo_a, hi_a = ta.min(axis=1), ta.max(axis=1)
    lo_b, hi_b = tb.min(axis=1), tb.max(axis=1)
    gap = np.maximum(0.0, np.maximum(lo_a[:, None] - hi_b[None], lo_b[None] - hi_a[:, None]))
    box_distance = np.sqrt((gap**2).sum(-1))
    best = upper
    for i, j in zip(*np.nonzero(box_distance <= upper * (1 + 1e-12)), strict=True):
        if box_distance[i, j] < best:
            best = min(best, triangle_distance_reference(ta[i], tb[j]))
    return best


def interpolated_pose(T0, T1, t: float) -> np.ndarray:
    """Pose at fraction t of the motion T0 -> T1: origin along the segment, rotation by
    SciPy's Slerp (the shorter way)."""
    T0 = np.asarray(T0, dtype=float)
    T1 = np.asarray(T1, dtype=float)
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]])))
    T = np.eye(4)
    T[:3, :3] = slerp([t]).as_matrix()[0]
    T[:3, 3] = (1 - t) * T0[:3, 3] + t * T1[:3, 3]
    return T
