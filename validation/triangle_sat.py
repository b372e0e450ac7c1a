"""Triangle-triangle overlap by the separating-axis theorem: the AABB tree's own leaf test.

Written apart from the library's triangle tests (``thesis_rbd.collision.mesh.triangle``: Guigue
and Devillers with a fallback) so that the AABB tree of :mod:`validation.aabb_tree` is an
independent oracle of the OBB tree's pair sets, not the same test reached by another
traversal.

Two closed triangles are disjoint exactly when some axis separates their projections. For two
proper triangles the candidates are both normals, the nine cross products of an edge of one
with an edge of the other, and each edge crossed with either normal (the in-plane axes that a
coplanar pair needs). A segment- or point-shaped triangle has no normal; for those, the edges
themselves, the corner-to-corner directions and their parts perpendicular to each edge are
tried as well. Any axis that separates is a proof of disjointness, so extra candidates cannot
make the answer wrong, only slower. Projections are compared exactly as computed: touching
triangles (a zero gap) overlap, and only a gap within round-off can be decided either way.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["triangles_overlap"]


@njit
def _put_cross(axes, k, a, b) -> int:
    """Row k of ``axes`` = a x b; returns k + 1."""
    axes[k, 0] = a[1] * b[2] - a[2] * b[1]
    axes[k, 1] = a[2] * b[0] - a[0] * b[2]
    axes[k, 2] = a[0] * b[1] - a[1] * b[0]
    return k + 1


@njit
def _separates(axis, P, Q) -> bool:
    """Whether ``axis`` (3,) separates the projections of P and Q (3, 3) by a positive gap."""
    if axis[0] == 0.0 and axis[1] == 0.0 and axis[2] == 0.0:
        return False
    p_lo = q_lo = np.inf
    p_hi = q_hi = -np.inf
    for k in range(3):
        p = P[k, 0] * axis[0] + P[k, 1] * axis[1] + P[k, 2] * axis[2]
        q = Q[k, 0] * axis[0] + Q[k, 1] * axis[1] + Q[k, 2] * axis[2]
        p_lo, p_hi = min(p_lo, p), max(p_hi, p)
        q_lo, q_hi = min(q_lo, q), max(q_hi, q)
    return p_hi < q_lo or q_hi < p_lo


@njit
def triangles_overlap(P, Q) -> bool:
    """Do the closed triangles P and Q, (3, 3) corners each, share a point?

    Parameters
    ----------
    P, Q : (3, 3) float64
        Corners (rows) of the two triangles, in one frame.

    Returns
    -------
    bool
        False when some candidate axis separates them (see the module docstring).
    """
    # edges: rows 0-2 of P, rows 3-5 of Q
    edges = np.empty((6, 3))
    for k in range(3):
        edges[k] = P[(k + 1) % 3] - P[k]
        edges[3 + k] = Q[(k + 1) % 3] - Q[k]
    normals = np.empty((2, 3))
    _put_cross(normals, 0, edges[0], edges[1])
    _put_cross(normals, 1, edges[3], edges[4])
    flat = not (normals[0].any() and normals[1].any())
    axes = np.empty((92 if flat else 23, 3))
    axes[0], axes[1] = normals[0], normals[1]
    count = 2
    for i in range(3):
        for j in range(3, 6):
            count = _put_cross(axes, count, edges[i], edges[j])
    for n in range(2):
        for k in range(6):
            count = _put_cross(axes, count, normals[n], edges[k])
    if flat:
        # a segment or a point: its edges, corner-to-corner directions, and their parts
        # perpendicular to each edge, w - (w.d) d / |d|^2 up to scale: d x (w x d)
        for k in range(6):
            axes[count] = edges[k]
            count += 1
        w_cross_d = np.empty((1, 3))
        for a in range(3):
            for b in range(3):
                w = Q[b] - P[a]
                axes[count] = w
                count += 1
                for k in range(6):
                    _put_cross(w_cross_d, 0, w, edges[k])
                    count = _put_cross(axes, count, edges[k], w_cross_d[0])
    for k in range(count):
        if _separates(axes[k], P, Q):
            return False
    return True
