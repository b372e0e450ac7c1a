"""Naive oracles for convex-polyhedron contact (plain NumPy and SciPy, nothing from thesis_rbd).

* ``least_penetration`` (:mod:`validation.convex_oracle`, shared with the report): every
  face normal of both hulls and every edge-pair cross product, both signs.
* ``face_separation``: the greatest separation over the hulls' own outward face normals.
* ``contact_polygon``: the part of the incident face (the other body's face most opposed to
  the reference face) that lies over the reference face and below its plane, computed as
  a 2D half-plane intersection (``scipy.spatial.HalfspaceIntersection``) in the reference
  plane; ``best_four_area``: the largest area of four of its corners, by trying them all.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

from validation.convex_oracle import hull_planes, least_penetration

__all__ = [
    "best_four_area",
    "contact_polygon",
    "face_separation",
    "hull_planes",
    "least_penetration",
    "polygon_area",
]


def face_separation(points_a, points_b):
    """Greatest separation of the hulls over their own outward face normals: how far B lies
    beyond a face of A, or A beyond a face of B (negative when every face is crossed)."""
    na, da = hull_planes(points_a)
    nb, db = hull_planes(points_b)
    beyond_a = (points_b @ na.T).min(axis=0) - da
    beyond_b = (points_a @ nb.T).min(axis=0) - db
    return float(max(beyond_a.max(), beyond_b.max()))


def overlap_lp(points_a, points_b) -> bool:
    """Whether the two hulls share a point: feasibility of a convex-combination LP."""
    m, k = len(points_a), len(points_b)
    # sum la_i a_i - sum lb_j b_j = 0, sum la = 1, sum lb = 1, l >= 0
    A_eq = np.zeros((5, m + k))
    A_eq[:3, :m] = points_a.T
    A_eq[:3, m:] = -points_b.T
    A_eq[3, :m] = 1.0
    A_eq[4, m:] = 1.0
    b_eq = np.array([0.0, 0.0, 0.0, 1.0, 1.0])
    res = linprog(np.zeros(m + k), A_eq=A_eq, b_eq=b_eq, bounds=(0, None), method="highs")
    return res.status == 0


def _faces_of(points):
    """Hull faces as (normal, offset, corner points) with coplanar triangles merged."""
    normals, offsets = hull_planes(points)
    scale = np.ptp(points, axis=0).max()
    faces = []
    used = np.zeros(len(normals), bool)
    for f in range(len(normals)):
        if used[f]:
            continue
        same = (normals @ normals[f] > 1 - 1e-12) & (np.abs(offsets - offsets[f]) <= 1e-12 * scale)
        used |= same
        on = np.abs(points @ normals[f] - offsets[f]) <= 1e-10 * scale
        faces.append((normals[f], offsets[f], points[on]))
    return faces


def _plane_basis(n):
    helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _polygon_halfplanes(corners_2d):
    """Half-planes [a, b, c] with a x + b y + c <= 0 inside the convex hull of corners."""
    hull = ConvexHull(corners_2d)
    return hull.equations


def contact_polygon(points_a, points_b, normal):
    """The contact polygon for contact normal ``normal`` (B towards A), world frame.

    The reference face is B's face with outward normal ``normal`` or A's with ``-normal``
    (whichever exists, B's first); the incident face is the other body's face whose outward
    normal is most opposed to the reference normal. Returns (corners (k, 3), incident
    ambiguous: bool, depths (k,) of the corners below the reference plane, the cosine
    between the incident face's normal and the reversed reference normal), corners empty
    when the region is degenerate.
    """
    faces_a, faces_b = _faces_of(points_a), _faces_of(points_b)
    reference = None
    for n, d, pts in faces_b:
        if n @ normal > 1 - 1e-9:
            reference, incident_faces = (n, d, pts), faces_a
            break
    if reference is None:
        for n, d, pts in faces_a:
            if n @ -normal > 1 - 1e-9:
                reference, incident_faces = (n, d, pts), faces_b
                break
    if reference is None:
        return np.zeros((0, 3)), True, np.zeros(0), 0.0
    n, d, ref_pts = reference
    opposed = np.array([m @ n for m, _, _ in incident_faces])
    order = np.argsort(opposed)
    ambiguous = len(order) > 1 and opposed[order[1]] - opposed[order[0]] < 1e-9
    inc_pts = incident_faces[order[0]][2]
    u, v = _plane_basis(n)
    origin = ref_pts.mean(axis=0)
    to2 = lambda p: np.stack([(p - origin) @ u, (p - origin) @ v], axis=1)  # noqa: E731
    ref2, inc2 = to2(ref_pts), to2(inc_pts)
    # the incident face's plane over the reference plane: depth below the reference plane
    # is linear in the 2D coordinates, fitted through the incident corners
    depth_inc = d - inc_pts @ n
    fit = np.linalg.lstsq(np.column_stack([inc2, np.ones(len(inc2))]), depth_inc, rcond=None)[0]
    halfplanes = [_polygon_halfplanes(ref2), _polygon_halfplanes(inc2)]
    # depth >= 0:  -(g . x + c) <= 0
    halfplanes.append(np.array([[-fit[0], -fit[1], -fit[2]]]))
    halfplanes = np.concatenate(halfplanes)
    # a row whose normal vanishes (the depth of faces exactly parallel) bounds nothing: it
    # holds everywhere or nowhere
    norms = np.linalg.norm(halfplanes[:, :2], axis=1)
    vanishing = norms <= 1e-12 * norms.max()
    if (halfplanes[vanishing, 2] > 0).any():
        return np.zeros((0, 3)), ambiguous, np.zeros(0), -opposed[order[0]]
    halfplanes, norms = halfplanes[~vanishing], norms[~vanishing]
    # unit normals: qhull judges a feasible point by its distance, which a short normal hides
    halfplanes = halfplanes / norms[:, None]
    norms = np.ones(len(halfplanes))
    # an interior point: Chebyshev centre by LP
    res = linprog(
        [0, 0, -1],
        A_ub=np.column_stack([halfplanes[:, :2], norms]),
        b_ub=-halfplanes[:, 2],
        bounds=[(None, None), (None, None), (0, None)],
        method="highs",
    )
    scale = np.abs(ref2).max() + np.abs(inc2).max()
    if res.status != 0 or res.x[2] <= 1e-9 * scale:
        return np.zeros((0, 3)), ambiguous, np.zeros(0), -opposed[order[0]]
    corners = HalfspaceIntersection(halfplanes, res.x[:2]).intersections
    corners = corners[ConvexHull(corners).vertices]
    depth = corners @ fit[:2] + fit[2]
    world = origin + corners[:, :1] * u + corners[:, 1:] * v - depth[:, None] * n
    return world, ambiguous, depth, -opposed[order[0]]


def polygon_area(points, normal):
    """Area of the convex hull of points (k, 3) projected on the plane normal to ``normal``."""
    if len(points) < 3:
        return 0.0
    u, v = _plane_basis(normal / np.linalg.norm(normal))
    p2 = np.stack([points @ u, points @ v], axis=1)
    try:
        return float(ConvexHull(p2).volume)
    except QhullError:  # collinear: no area
        return 0.0


def best_four_area(points, normal, include=None):
    """Largest projected area spanned by four of the points (every subset tried), of those
    that include one of the indices ``include`` if given."""
    if len(points) <= 4:
        return polygon_area(points, normal)
    u, v = _plane_basis(normal / np.linalg.norm(normal))
    p2 = np.stack([points @ u, points @ v], axis=1)
    order = ConvexHull(p2).vertices  # corners in loop order: a subset in order is convex
    subsets = np.array(list(combinations(order.tolist(), 4)))
    # four corners taken in loop order form a convex quadrilateral: shoelace area
    position = {int(c): k for k, c in enumerate(order)}
    ranks = np.vectorize(position.get)(subsets)
    subsets = np.take_along_axis(subsets, np.argsort(ranks, axis=1), axis=1)
    x, y = p2[subsets, 0], p2[subsets, 1]
    area = 0.5 * np.abs((x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1))
    if include is not None:
        area = area[np.isin(subsets, list(include)).any(axis=1)]
    return float(area.max())
