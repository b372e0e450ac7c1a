"""The exact least penetration of two convex polyhedra, by enumeration (plain NumPy and SciPy).

Every face normal of both hulls and every cross product of an edge of one with an edge of the
other (no Gauss-map pruning), both signs; the penetration along an axis n (B towards A) is
how far A must move along n to clear B, max_B x.n - min_A x.n, and the least of these is the
exact penetration depth of two convex polyhedra. Nothing here comes from thesis_rbd: it is the
oracle of the convex-contact tests (``tests/reference_convex.py``) and of the report's
comparison of the two narrow phases (``validation.studies.narrow_phase_paths``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

__all__ = ["hull_planes", "least_penetration"]


def hull_planes(points):
    """Outward unit normals (f, 3) and offsets (f,) of the hull of points: n.x <= d inside."""
    hull = ConvexHull(points)
    return hull.equations[:, :3], -hull.equations[:, 3]


def _hull_edges(points):
    hull = ConvexHull(points)
    s = hull.simplices
    e = np.concatenate([s[:, [0, 1]], s[:, [1, 2]], s[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    return points[e[:, 1]] - points[e[:, 0]]


def _unit_rows(u):
    length = np.linalg.norm(u, axis=1)
    keep = length > 1e-12 * max(length.max(initial=0.0), 1e-300)
    return u[keep] / length[keep, None]


def least_penetration(points_a, points_b):
    """Exact least penetration of the hulls of points_a (m, 3) and points_b (k, 3).

    Returns
    -------
    depth : float
        min over candidate axes n of (max_B x.n - min_A x.n); negative when apart.
    normal : (3,)
        The axis attaining it (B towards A).
    runner_up : float
        The least penetration over candidate axes more than 1e-6 rad away from ``normal``
        (either sign): the axis is unique when it exceeds ``depth`` clearly.
    face_depth, edge_depth : float
        The least penetration over face normals alone, and over the edge-pair axes more than
        1e-6 rad from the best face normal (an edge lying in a face gives that face's axis).
    """
    na, _ = hull_planes(points_a)
    nb, _ = hull_planes(points_b)
    ea, eb = _hull_edges(points_a), _hull_edges(points_b)
    cross = np.cross(ea[:, None, :], eb[None, :, :]).reshape(-1, 3)
    faces = np.concatenate([na, nb])
    edges = _unit_rows(cross)
    axes = np.concatenate([faces, edges, -faces, -edges])
    is_face = np.tile(np.r_[np.ones(len(faces), bool), np.zeros(len(edges), bool)], 2)
    depth_along = (points_b @ axes.T).max(axis=0) - (points_a @ axes.T).min(axis=0)
    best = int(np.argmin(depth_along))
    normal = axes[best]
    apart = np.arccos(np.clip(axes @ normal, -1.0, 1.0)) > 1e-6
    runner_up = depth_along[apart].min() if apart.any() else np.inf
    best_face = int(np.argmin(np.where(is_face, depth_along, np.inf)))
    other = ~is_face & (np.arccos(np.clip(axes @ axes[best_face], -1.0, 1.0)) > 1e-6)
    edge_depth = depth_along[other].min() if other.any() else np.inf
    return (
        float(depth_along[best]), normal, float(runner_up), float(depth_along[best_face]),
        float(edge_depth),
    )  # fmt: skip
