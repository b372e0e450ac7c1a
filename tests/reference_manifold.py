"""Slow, independent oracle for the contacts dynamics acts on (``collision/mesh/manifold.py``).

Plain NumPy, sharing nothing with the library: for two convex polyhedra given as world-frame
triangle meshes, the least-penetration axis by the separating-axis theorem over every face
normal of either body and every cross product of an edge of A with an edge of B (a superset
of the face normals of the Minkowski difference A - B, so the least overlap over it is the
exact penetration depth), and the signed distance of points to a convex polyhedron.
"""

from __future__ import annotations

import numpy as np

__all__ = ["convex_penetration", "overlap_along", "penetration_axes", "signed_distance_to_convex"]


def _face_normals(V, F):
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    length = np.linalg.norm(n, axis=1)
    keep = length > 1e-12 * np.abs(V).max() ** 2
    return n[keep] / length[keep, None]


def _edges(V, F):
    e = np.concatenate([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 1]], V[F[:, 0]] - V[F[:, 2]]])
    length = np.linalg.norm(e, axis=1)
    return e[length > 0] / length[length > 0, None]


def overlap_along(u, VA, VB):
    """How far A must move along unit ``u`` (rows (k, 3) or one (3,)) to clear B:
    ``max(VB . u) - min(VA . u)``; > 0 where their projections overlap."""
    u = np.atleast_2d(u)
    return (VB @ u.T).max(axis=0) - (VA @ u.T).min(axis=0)


def penetration_axes(VA, FA, VB, FB):
    """Every candidate axis (unit, B towards A) of convex A and B, and the overlap along it.

    Returns
    -------
    axes : (k, 3) float64
        B's outward face normals, A's reversed, and both signs of every edge-pair cross
        product.
    overlaps : (k,) float64
        ``overlap_along`` each axis.
    """
    candidates = [_face_normals(VB, FB), -_face_normals(VA, FA)]
    ea, eb = _edges(VA, FA), _edges(VB, FB)
    cross = np.cross(ea[:, None, :], eb[None, :, :]).reshape(-1, 3)
    length = np.linalg.norm(cross, axis=1)
    cross = cross[length > 1e-9] / length[length > 1e-9, None]
    candidates += [cross, -cross]
    axes = np.concatenate(candidates)
    return axes, overlap_along(axes, VA, VB)


def convex_penetration(VA, FA, VB, FB):
    """Penetration of convex polyhedra A and B (vertices already in the world frame).

    Returns
    -------
    normal : (3,) float64
        Unit axis of least penetration, pointing from B towards A.
    depth : float
        The least overlap over all candidate axes: the penetration depth if > 0; <= 0 means
        the bodies are apart (or touch).
    """
    axes, overlaps = penetration_axes(VA, FA, VB, FB)
    best = int(np.argmin(overlaps))
    return axes[best], float(overlaps[best])


def signed_distance_to_convex(points, V, F):
    """Largest signed distance of each point (p, 3) to the face planes of convex (V, F):
    <= 0 inside; outside, a lower bound of the distance to the surface (exact where the
    nearest feature is a face)."""
    normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    length = np.linalg.norm(normals, axis=1)
    keep = length > 1e-12 * np.abs(V).max() ** 2
    normals = normals[keep] / length[keep, None]
    offsets = np.einsum("ij,ij->i", normals, V[F[keep, 0]])
    return (np.atleast_2d(points) @ normals.T - offsets).max(axis=1)
