"""Exact primitive tests: triangle-triangle overlap, and the triangle-box culling test.

Triangles and boxes are *closed* sets: two that merely touch overlap (python-fcl does the same).

Triangle-triangle (:func:`tri_tri_overlap`) is exact for the float64 corners it is given: every
branch is the sign of an orientation determinant evaluated exactly (:mod:`.predicates`), so
triangles that share a corner or an edge bitwise, that lie flush or coplanar, or that touch in
any other way are decided as exact rational arithmetic would decide them. The method:

* the two plane-side rejections of Guigue & Devillers (2003): the corners of each triangle
  against the other's plane, which settle most pairs a bounding-volume traversal hands over;
* for proper triangles straddling each other's planes, Guigue-Devillers' canonical relabelling
  and two more orientation signs that tell whether the two triangles' segments on the planes'
  common line overlap (zero signs, i.e. touching, fall through the same case analysis);
* coplanar triangles: a 2D separating-line test in the coordinate plane onto which the common
  plane projects one to one (dropping a coordinate is exact, and so are the 2D signs);
* flat triangles (exactly collinear corners: a segment or a point) are the union of their
  edges, each decided exactly as a segment against the other triangle, or against the other's
  edges when both are flat.

Triangle-box (:func:`tri_box_overlap`) culls a traversal: it must never separate a triangle
from a box that holds a triangle it meets, and a false overlap only costs time. It is
Akenine-Möller's (2001) separating-axis test (the box's face normals, the triangle normal and
the 9 box axis x triangle edge products), made *conservative*: an axis separates only when its
gap exceeds a bound on the rounding of the projections, so the answer is never "apart" for a
triangle that meets the box.

Corners are passed as ``(x, y, z)`` tuples so the common path allocates nothing (only the
predicates' exact fallback does).
"""

from __future__ import annotations

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision._vec3 import cross, dot, sub, vec
from thesis_rbd.collision.mesh.predicates import orient2d, orient3d, plane_sides

__all__ = ["tri_box_overlap", "tri_tri_overlap", "triangle_box_overlap", "triangles_overlap"]

# Relative slack of the triangle-box test: 64 units of rounding of the magnitudes involved,
# above the error of a projection (3 roundings per dot product plus the radius's own) and of
# a rigid transform of the corners (under 20 units; see tri_box_overlap).
_BOX_SLACK = 2.0**-46


@njit
def tri_tri_overlap(p0, p1, p2, q0, q1, q2):
    """Exact closed triangle-triangle overlap test.

    Parameters
    ----------
    p0, p1, p2, q0, q1, q2 : tuple of 3 float
        Corners of triangles P and Q in one common frame.

    Returns
    -------
    bool
        True if the triangles share at least one point (touching counts), exactly for these
        float64 corners (within the predicates' range: no product of coordinate differences
        under- or overflows). Degenerate triangles (segments, points) are allowed.
    """
    # Sides of P's corners against Q's plane (all 0 if Q is flat), and of Q's against P's.
    s0, s1, s2 = plane_sides(q0, q1, q2, p0, p1, p2)
    if (s0 > 0 and s1 > 0 and s2 > 0) or (s0 < 0 and s1 < 0 and s2 < 0):
        return False
    t0, t1, t2 = plane_sides(p0, p1, p2, q0, q1, q2)
    if (t0 > 0 and t1 > 0 and t2 > 0) or (t0 < 0 and t1 < 0 and t2 < 0):
        return False
    if (s0 == 0 and s1 == 0 and s2 == 0) or (t0 == 0 and t1 == 0 and t2 == 0):
        return _coplanar_or_flat(p0, p1, p2, q0, q1, q2, s0, s1, s2, t0, t1, t2)
    # Both triangles are proper (a flat one would give all-zero signs) and not coplanar.
    # Guigue-Devillers: relabel P so that its first corner is alone on its side of Q's plane
    # (flipping Q's orientation if that side is the negative one), then the same for Q.
    a0, a1, a2, flip = _gd_relabel(p0, p1, p2, s0, s1, s2)
    if flip:
        q1, q2 = q2, q1
        t1, t2 = t2, t1
    b0, b1, b2, flip = _gd_relabel(q0, q1, q2, t0, t1, t2)
    if flip:
        a1, a2 = a2, a1
    # Now a0 is alone on the positive side of B's plane and b0 alone on the positive side of
    # A's: the triangles' segments on the planes' common line overlap iff both orientations
    # are <= 0.
    return orient3d(b1, b0, a0, a1) <= 0 and orient3d(b2, b0, a2, a0) <= 0


@njit
def _gd_relabel(c0, c1, c2, s0, s1, s2):
    """Guigue-Devillers' relabelling of a triangle by the sides s of its corners against the
    other's plane: its corners rotated to start at the one alone on its side, and whether the
    other triangle's orientation must flip (the lone corner is on the negative side; zeros
    as in their case table)."""
    r = 2
    flip = True
    if s0 > 0:
        r, flip = (2, True) if s1 > 0 else ((1, True) if s2 > 0 else (0, False))
    elif s0 < 0:
        r, flip = (2, False) if s1 < 0 else ((1, False) if s2 < 0 else (0, True))
    elif s1 < 0:
        r, flip = (1, True) if s2 >= 0 else (0, False)
    elif s1 > 0:
        r, flip = (0, True) if s2 > 0 else (1, False)
    elif s2 > 0:
        r, flip = 2, False
    if r == 0:
        return c0, c1, c2, flip
    if r == 1:
        return c1, c2, c0, flip
    return c2, c0, c1, flip


@njit
def _drop(p, k):
    """Point p projected on the coordinate plane without coordinate k (exact)."""
    return (p[(k + 1) % 3], p[(k + 2) % 3])


@njit
def _projection(a, b, c):
    """Coordinate plane onto which the plane of triangle abc projects one to one.

    Returns ``(k, o)``: drop coordinate k (keeping ``(k + 1) % 3, (k + 2) % 3``, which
    preserves orientation), and the exact orientation o (+1/-1) of the projected triangle,
    i.e. the sign of component k of its normal. ``(-1, 0)`` if the triangle is flat.
    The axis of the largest normal component (in floating point) is tried first.
    """
    n = cross(sub(b, a), sub(c, a))
    k = 0
    if abs(n[1]) > abs(n[k]):
        k = 1
    if abs(n[2]) > abs(n[k]):
        k = 2
    for attempt in range(3):
        axis = (k + attempt) % 3
        o = orient2d(_drop(b, axis), _drop(c, axis), _drop(a, axis))
        if o != 0:
            return axis, o
    return -1, 0


@njit
def _segment_meets_triangle(a, b, sa, sb, q0, q1, q2, k, o):
    """Closed segment ab (a point if a == b) against proper triangle Q.

    ``sa``, ``sb`` are the exact sides of a and b against Q's plane; ``k``, ``o`` Q's
    projection (see :func:`_projection`).
    """
    if sa * sb > 0:
        return False
    if sa != 0 and sb != 0:
        # a and b strictly on either side: the segment crosses the plane at one point,
        # inside the closed triangle iff the line ab passes no edge of Q on the outer side.
        o1 = orient3d(a, b, q0, q1)
        o2 = orient3d(a, b, q1, q2)
        o3 = orient3d(a, b, q2, q0)
        return not ((o1 > 0 or o2 > 0 or o3 > 0) and (o1 < 0 or o2 < 0 or o3 < 0))
    # The part of the segment in Q's plane (both ends, or the one end on it), projected:
    # apart iff both ends lie strictly outside one edge of Q, or Q lies strictly on one
    # side of the segment's line.
    x = _drop(a if sa == 0 else b, k)
    y = _drop(b if sb == 0 else a, k)
    T = (_drop(q0, k), _drop(q1, k), _drop(q2, k))
    for i in range(3):
        u = T[i]
        v = T[(i + 1) % 3]
        if orient2d(u, v, x) * o < 0 and orient2d(u, v, y) * o < 0:
            return False
    if x[0] == y[0] and x[1] == y[1]:
        return True
    u0 = orient2d(x, y, T[0])
    u1 = orient2d(x, y, T[1])
    u2 = orient2d(x, y, T[2])
    return not ((u0 > 0 and u1 > 0 and u2 > 0) or (u0 < 0 and u1 < 0 and u2 < 0))


@njit
def _segments_meet(a, b, c, d):
    """Closed 3D segments ab and cd (either may be a point) share a point.

    They must be coplanar; then every coordinate projection of them meets, and at least one
    projection is one to one on their common plane (or line), so all three meeting is also
    sufficient. In a projection, the segments meet iff each separates the other's ends
    strictly, or an end lies on the other segment (on its line and in its bounding box).
    """
    if orient3d(a, b, c, d) != 0:
        return False
    for k in range(3):
        a2, b2, c2, d2 = _drop(a, k), _drop(b, k), _drop(c, k), _drop(d, k)
        o1 = orient2d(a2, b2, c2)
        o2 = orient2d(a2, b2, d2)
        o3 = orient2d(c2, d2, a2)
        o4 = orient2d(c2, d2, b2)
        meet = o1 * o2 < 0 and o3 * o4 < 0
        for u, v, x, o in ((a2, b2, c2, o1), (a2, b2, d2, o2), (c2, d2, a2, o3), (c2, d2, b2, o4)):
            meet = meet or (
                o == 0
                and min(u[0], v[0]) <= x[0] <= max(u[0], v[0])
                and min(u[1], v[1]) <= x[1] <= max(u[1], v[1])
            )
        if not meet:
            return False
    return True


@njit
def _coplanar_or_flat(p0, p1, p2, q0, q1, q2, s0, s1, s2, t0, t1, t2):
    """Pairs with all-zero plane sides: coplanar proper triangles, or a flat triangle (the
    union of its three edges)."""
    kp, op = _projection(p0, p1, p2)
    kq, oq = _projection(q0, q1, q2)
    P = (p0, p1, p2)
    Q = (q0, q1, q2)
    if kp >= 0 and kq >= 0:
        # Coplanar, projected one to one along kq: apart iff some edge of one triangle has
        # the other strictly outside (the separating-axis theorem in the plane).
        for side in range(2):
            T, o, X = (P, op, Q) if side == 0 else (Q, oq, P)
            if side == 0 and kp != kq:
                o = orient2d(_drop(p1, kq), _drop(p2, kq), _drop(p0, kq))
            x0, x1, x2 = _drop(X[0], kq), _drop(X[1], kq), _drop(X[2], kq)
            for i in range(3):
                u = _drop(T[i], kq)
                v = _drop(T[(i + 1) % 3], kq)
                if (
                    orient2d(u, v, x0) * o < 0
                    and orient2d(u, v, x1) * o < 0
                    and orient2d(u, v, x2) * o < 0
                ):
                    return False
        return True
    if kp < 0 and kq < 0:
        for i in range(3):
            for j in range(3):
                if _segments_meet(P[i], P[(i + 1) % 3], Q[j], Q[(j + 1) % 3]):
                    return True
        return False
    # One flat triangle F, with the sides of its corners against the proper one, T.
    if kq >= 0:
        F, sides, T, k, o = P, (s0, s1, s2), Q, kq, oq
    else:
        F, sides, T, k, o = Q, (t0, t1, t2), P, kp, op
    for i in range(3):
        j = (i + 1) % 3
        if _segment_meets_triangle(F[i], F[j], sides[i], sides[j], T[0], T[1], T[2], k, o):
            return True
    return False


@njit
def _box_separated(axis, v0, v1, v2, h):
    """True if the triangle's projection on ``axis`` misses the box's (centred) interval."""
    a = dot(axis, v0)
    b = dot(axis, v1)
    c = dot(axis, v2)
    r = h[0] * abs(axis[0]) + h[1] * abs(axis[1]) + h[2] * abs(axis[2])
    return min(a, b, c) > r or max(a, b, c) < -r


@njit
def tri_box_overlap(v0, v1, v2, h, reach):
    """Conservative closed triangle / axis-aligned box overlap test (Akenine-Möller 2001).

    Parameters
    ----------
    v0, v1, v2 : tuple of 3 float
        Triangle corners in the box frame (box centred at the origin, axes = coordinate axes).
    h : tuple of 3 float
        Box half-extents (>= 0).
    reach : float
        Magnitude of what the corners were computed from, if they carry rounding (0 for
        exact corners): the box grows by a bound on that rounding too (see ``_tri_in_box``
        in :mod:`..queries.collide`).

    Returns
    -------
    bool
        True if the triangle and the box share a point, and possibly (a false overlap) if
        they are within about 1e-14 of ``3 max(|corner|, h) + reach`` of each other; never
        False for a triangle that meets the box.
    """
    lo0 = min(v0[0], v1[0], v2[0])
    hi0 = max(v0[0], v1[0], v2[0])
    lo1 = min(v0[1], v1[1], v2[1])
    hi1 = max(v0[1], v1[1], v2[1])
    lo2 = min(v0[2], v1[2], v2[2])
    hi2 = max(v0[2], v1[2], v2[2])
    size = max(max(h[0], h[1], h[2]), max(-lo0, hi0), max(-lo1, hi1), max(-lo2, hi2))
    # The box grown by the slack: any axis's computed gap then exceeds its rounding error.
    slack = _BOX_SLACK * (3.0 * size + reach)
    g = (h[0] + slack, h[1] + slack, h[2] + slack)
    # Box face normals: the triangle's own bounding box against the box.
    if lo0 > g[0] or hi0 < -g[0] or lo1 > g[1] or hi1 < -g[1] or lo2 > g[2] or hi2 < -g[2]:
        return False
    e0 = sub(v1, v0)
    e1 = sub(v2, v1)
    e2 = sub(v0, v2)
    # The triangle's normal, as computed: any axis is a valid candidate, so a flat
    # triangle's round-off normal cannot separate falsely either (all three corners are
    # projected).
    if _box_separated(cross(e0, e1), v0, v1, v2, g):
        return False
    # Box axis x triangle edge. cross(unit_k, e) written out to save the multiplications.
    for e in (e0, e1, e2):
        if _box_separated((0.0, -e[2], e[1]), v0, v1, v2, g):
            return False
        if _box_separated((e[2], 0.0, -e[0]), v0, v1, v2, g):
            return False
        if _box_separated((-e[1], e[0], 0.0), v0, v1, v2, g):
            return False
    return True


@njit
def triangles_overlap(P, Q):
    """Array form of :func:`tri_tri_overlap`: ``P``, ``Q`` are (3, 3) corner rows."""
    return tri_tri_overlap(vec(P, 0), vec(P, 1), vec(P, 2), vec(Q, 0), vec(Q, 1), vec(Q, 2))


@njit
def triangle_box_overlap(V, h):
    """Array form of :func:`tri_box_overlap`: ``V`` (3, 3) corners in the box frame, ``h`` (3,)."""
    return tri_box_overlap(
        vec(V, 0), vec(V, 1), vec(V, 2), (float(h[0]), float(h[1]), float(h[2])), 0.0
    )
