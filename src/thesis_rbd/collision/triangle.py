"""Exact primitive tests: triangle-triangle and triangle-box overlap.

Both tests treat triangles and boxes as *closed* sets: two that merely touch are
reported as overlapping (python-fcl does the same), and a separation is only reported when a
sign or an axis shows a strictly positive gap. In the separating-axis parts any axis, of any
length, is a valid candidate, so a near-zero axis (nearly parallel edges) can only fail to
separate, never separate falsely; no epsilon is needed.

Triangle-triangle (:func:`tri_tri_overlap`) is Guigue & Devillers (2003), a reformulation of
Möller (1997) that decides everything with signs of 3x3 determinants (no divisions, no
interval end points): the two plane-side rejections first, which settle most pairs a
bounding-volume traversal hands over; then, for triangles straddling each other's plane, a
canonical relabelling and two more orientation signs that tell whether the two segments on
the planes' common line overlap. Touching cases (a zero sign) fall through the same case
analysis. Coplanar pairs and flat triangles (a segment or a point: a normal at most 1e-12 of
the longest edge squared, so round-off when the corners are collinear) go to a
separating-axis test instead, which leaves out a flat triangle's normal: its direction is
round-off, and a projection on it can show a gap that is not there. The test uses both
normals, the 9 edge-edge cross products, the 12 in-plane edge normals, and for flat triangles
the edges themselves and the corner-to-corner directions (and their components perpendicular
to each edge), which decides point/point, point/segment and segment/segment pairs as well.

Triangle-box (:func:`tri_box_overlap`) is Akenine-Möller's (2001) 13-axis test: the box's face
normals, the triangle normal (not for a flat triangle), and the 9 cross products of box axes
with triangle edges.

Corners are passed as ``(x, y, z)`` tuples so the kernels allocate nothing.
"""

from __future__ import annotations

from thesis_rbd._jit import njit
from thesis_rbd.collision._vec3 import cross, dot, sub, vec

__all__ = ["tri_box_overlap", "tri_tri_overlap", "triangle_box_overlap", "triangles_overlap"]


@njit
def _separated(axis, p0, p1, p2, q0, q1, q2):
    """True if the projections of triangles P and Q on ``axis`` are disjoint (strict gap)."""
    a = dot(axis, p0)
    b = dot(axis, p1)
    c = dot(axis, p2)
    pmin = min(a, b, c)
    pmax = max(a, b, c)
    a = dot(axis, q0)
    b = dot(axis, q1)
    c = dot(axis, q2)
    qmin = min(a, b, c)
    qmax = max(a, b, c)
    return pmax < qmin or qmax < pmin


@njit(inline="always")
def _flat(n, e0, e1, e2):
    """Whether a triangle with edges e0, e1, e2 and normal n = e0 x e1 has no plane: |n| is
    at most 1e-12 times its longest edge squared (corners collinear up to round-off)."""
    longest = max(dot(e0, e0), dot(e1, e1), dot(e2, e2))
    return dot(n, n) <= 1e-24 * longest * longest


@njit
def tri_tri_overlap(p0, p1, p2, q0, q1, q2):
    """Closed triangle-triangle overlap test.

    Parameters
    ----------
    p0, p1, p2, q0, q1, q2 : tuple of 3 float
        Corners of triangles P and Q in one common frame.

    Returns
    -------
    bool
        True if the triangles share at least one point (touching counts).
    """
    # Orientation of each corner against the other triangle's plane (Guigue-Devillers
    # convention: the plane's normal is taken at its third corner).
    # A flat triangle has no plane to reject against: separating axes decide.
    flat_p = _flat(cross(sub(p1, p0), sub(p2, p1)), sub(p1, p0), sub(p2, p1), sub(p0, p2))
    flat_q = _flat(cross(sub(q1, q0), sub(q2, q1)), sub(q1, q0), sub(q2, q1), sub(q0, q2))
    if flat_p or flat_q:
        return _sat_overlap(p0, p1, p2, q0, q1, q2, flat_p, flat_q)
    n2 = cross(sub(q0, q2), sub(q1, q2))
    s0 = dot(sub(p0, q2), n2)
    s1 = dot(sub(p1, q2), n2)
    s2 = dot(sub(p2, q2), n2)
    if (s0 > 0.0 and s1 > 0.0 and s2 > 0.0) or (s0 < 0.0 and s1 < 0.0 and s2 < 0.0):
        return False
    n1 = cross(sub(p0, p2), sub(p1, p2))
    t0 = dot(sub(q0, p2), n1)
    t1 = dot(sub(q1, p2), n1)
    t2 = dot(sub(q2, p2), n1)
    if (t0 > 0.0 and t1 > 0.0 and t2 > 0.0) or (t0 < 0.0 and t1 < 0.0 and t2 < 0.0):
        return False
    if (s0 == 0.0 and s1 == 0.0 and s2 == 0.0) or (t0 == 0.0 and t1 == 0.0 and t2 == 0.0):
        return _sat_overlap(p0, p1, p2, q0, q1, q2, False, False)  # coplanar
    # Guigue-Devillers: rotate P so that its first corner is alone on its side of Q's plane
    # (flipping Q's orientation if that side is the negative one), then the same for Q.
    if s0 > 0.0:
        if s1 > 0.0:
            return _gd_second(p2, p0, p1, q0, q2, q1, t0, t2, t1)
        if s2 > 0.0:
            return _gd_second(p1, p2, p0, q0, q2, q1, t0, t2, t1)
        return _gd_second(p0, p1, p2, q0, q1, q2, t0, t1, t2)
    if s0 < 0.0:
        if s1 < 0.0:
            return _gd_second(p2, p0, p1, q0, q1, q2, t0, t1, t2)
        if s2 < 0.0:
            return _gd_second(p1, p2, p0, q0, q1, q2, t0, t1, t2)
        return _gd_second(p0, p1, p2, q0, q2, q1, t0, t2, t1)
    if s1 < 0.0:
        if s2 >= 0.0:
            return _gd_second(p1, p2, p0, q0, q2, q1, t0, t2, t1)
        return _gd_second(p0, p1, p2, q0, q1, q2, t0, t1, t2)
    if s1 > 0.0:
        if s2 > 0.0:
            return _gd_second(p0, p1, p2, q0, q2, q1, t0, t2, t1)
        return _gd_second(p1, p2, p0, q0, q1, q2, t0, t1, t2)
    if s2 > 0.0:
        return _gd_second(p2, p0, p1, q0, q1, q2, t0, t1, t2)
    return _gd_second(p2, p0, p1, q0, q2, q1, t0, t2, t1)


@njit
def _gd_second(p0, p1, p2, q0, q1, q2, t0, t1, t2):
    """Second half of Guigue-Devillers: the same normalisation for Q against P's plane."""
    if t0 > 0.0:
        if t1 > 0.0:
            return _gd_intervals(p0, p2, p1, q2, q0, q1)
        if t2 > 0.0:
            return _gd_intervals(p0, p2, p1, q1, q2, q0)
        return _gd_intervals(p0, p1, p2, q0, q1, q2)
    if t0 < 0.0:
        if t1 < 0.0:
            return _gd_intervals(p0, p1, p2, q2, q0, q1)
        if t2 < 0.0:
            return _gd_intervals(p0, p1, p2, q1, q2, q0)
        return _gd_intervals(p0, p2, p1, q0, q1, q2)
    if t1 < 0.0:
        if t2 >= 0.0:
            return _gd_intervals(p0, p2, p1, q1, q2, q0)
        return _gd_intervals(p0, p1, p2, q0, q1, q2)
    if t1 > 0.0:
        if t2 > 0.0:
            return _gd_intervals(p0, p2, p1, q0, q1, q2)
        return _gd_intervals(p0, p1, p2, q1, q2, q0)
    if t2 > 0.0:
        return _gd_intervals(p0, p1, p2, q2, q0, q1)
    return _gd_intervals(p0, p2, p1, q2, q0, q1)


@njit
def _gd_intervals(p0, p1, p2, q0, q1, q2):
    """Overlap of the two triangles' segments on the planes' common line, by two signs.

    With p0 alone on the positive side of Q's plane and q0 alone on the positive side of
    P's plane, the segments overlap iff both orientation determinants below are <= 0.
    """
    if dot(sub(q1, p1), cross(sub(q0, p1), sub(p0, p1))) > 0.0:
        return False
    if dot(sub(q2, p0), cross(sub(q0, p0), sub(p2, p0))) > 0.0:
        return False
    return True


@njit
def _sat_overlap(p0, p1, p2, q0, q1, q2, flat_p, flat_q):
    """Separating-axis decision for coplanar pairs and flat triangles (``flat_p``,
    ``flat_q``: that triangle's normal is round-off and is not used as an axis)."""
    e0 = sub(p1, p0)
    e1 = sub(p2, p1)
    e2 = sub(p0, p2)
    f0 = sub(q1, q0)
    f1 = sub(q2, q1)
    f2 = sub(q0, q2)
    n1 = (0.0, 0.0, 0.0) if flat_p else cross(e0, e1)
    n2 = (0.0, 0.0, 0.0) if flat_q else cross(f0, f1)
    if _separated(n1, p0, p1, p2, q0, q1, q2) or _separated(n2, p0, p1, p2, q0, q1, q2):
        return False
    # Edge-edge axes: complete, together with the normals, for non-coplanar triangles.
    if _separated(cross(e0, f0), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e0, f1), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e0, f2), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e1, f0), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e1, f1), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e1, f2), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e2, f0), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e2, f1), p0, p1, p2, q0, q1, q2):
        return False
    if _separated(cross(e2, f2), p0, p1, p2, q0, q1, q2):
        return False
    # In-plane edge normals: decide coplanar pairs. Each triangle's edges are crossed with
    # both normals, so that a flat triangle (zero normal here) still gets the in-plane
    # normals of its edges from the other triangle's plane.
    for n in (n1, n2):
        if _separated(cross(n, e0), p0, p1, p2, q0, q1, q2):
            return False
        if _separated(cross(n, e1), p0, p1, p2, q0, q1, q2):
            return False
        if _separated(cross(n, e2), p0, p1, p2, q0, q1, q2):
            return False
        if _separated(cross(n, f0), p0, p1, p2, q0, q1, q2):
            return False
        if _separated(cross(n, f1), p0, p1, p2, q0, q1, q2):
            return False
        if _separated(cross(n, f2), p0, p1, p2, q0, q1, q2):
            return False
    if flat_p or flat_q:
        return not _degenerate_separated(p0, p1, p2, q0, q1, q2, e0, e1, e2, f0, f1, f2)
    return True


@njit
def _degenerate_separated(p0, p1, p2, q0, q1, q2, e0, e1, e2, f0, f1, f2):
    """Extra axes for a flat triangle: a segment or a point.

    The axes above lose their meaning when a normal vanishes: a point against a segment, or
    two parallel segments, has no face normal or edge cross product to separate on. The
    missing axes are the edges themselves (a point beyond a segment's end) and, for every
    corner-to-corner vector w, its component perpendicular to each edge,
    ``e x (w x e)`` (a point beside a segment's line), and w itself (two points).
    """
    for e in (e0, e1, e2, f0, f1, f2):
        if _separated(e, p0, p1, p2, q0, q1, q2):
            return True
    for p in (p0, p1, p2):
        for q in (q0, q1, q2):
            w = sub(q, p)
            if _separated(w, p0, p1, p2, q0, q1, q2):
                return True
            for e in (e0, e1, e2, f0, f1, f2):
                if _separated(cross(e, cross(w, e)), p0, p1, p2, q0, q1, q2):
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
def tri_box_overlap(v0, v1, v2, h):
    """Closed triangle / axis-aligned box overlap test (Akenine-Möller 2001).

    Parameters
    ----------
    v0, v1, v2 : tuple of 3 float
        Triangle corners in the box frame (box centred at the origin, axes = coordinate axes).
    h : tuple of 3 float
        Box half-extents (>= 0).

    Returns
    -------
    bool
        True if the triangle and the box share a point.
    """
    # Box face normals: the triangle's own bounding box against the box.
    for k in range(3):
        lo = min(v0[k], v1[k], v2[k])
        hi = max(v0[k], v1[k], v2[k])
        if lo > h[k] or hi < -h[k]:
            return False
    e0 = sub(v1, v0)
    e1 = sub(v2, v1)
    e2 = sub(v0, v2)
    # Triangle plane against the box (a flat triangle has none: its edges' axes decide).
    n = cross(e0, e1)
    if not _flat(n, e0, e1, e2):
        d = dot(n, v0)
        r = h[0] * abs(n[0]) + h[1] * abs(n[1]) + h[2] * abs(n[2])
        if d > r or d < -r:
            return False
    # Box axis x triangle edge. cross(unit_k, e) written out to save the multiplications.
    for e in (e0, e1, e2):
        if _box_separated((0.0, -e[2], e[1]), v0, v1, v2, h):
            return False
        if _box_separated((e[2], 0.0, -e[0]), v0, v1, v2, h):
            return False
        if _box_separated((-e[1], e[0], 0.0), v0, v1, v2, h):
            return False
    return True


@njit
def triangles_overlap(P, Q):
    """Array form of :func:`tri_tri_overlap`: ``P``, ``Q`` are (3, 3) corner rows."""
    return tri_tri_overlap(vec(P, 0), vec(P, 1), vec(P, 2), vec(Q, 0), vec(Q, 1), vec(Q, 2))


@njit
def triangle_box_overlap(V, h):
    """Array form of :func:`tri_box_overlap`: ``V`` (3, 3) corners in the box frame, ``h`` (3,)."""
    return tri_box_overlap(vec(V, 0), vec(V, 1), vec(V, 2), (float(h[0]), float(h[1]), float(h[2])))
