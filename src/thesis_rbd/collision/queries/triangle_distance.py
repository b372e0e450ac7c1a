"""Exact distance between two triangles, with the closest points.

Two closed triangles P and Q either intersect (distance 0) or are apart, and then a closest
pair of points is found among two kinds of feature pairs (Larsen, Gottschalk, Lin & Manocha's
case analysis for PQP, here enumerated rather than pruned):

* edge-edge: the 9 pairs of an edge of P and an edge of Q; for each, the closest points of the
  two segments (:func:`segment_segment`);
* vertex-face: a corner of one triangle and the interior of the other, when the corner's
  projection on the other's plane falls inside it (6 pairs).

An edge pair whose closest points are certified by a separating plane ends the search early
(PQP's test); in the worst case all 15 pairs are measured.

Whether they intersect is decided by the package's exact triangle test
(:func:`thesis_rbd.collision.mesh.triangle.tri_tri_overlap`), so a distance of 0 is reported exactly
when :func:`thesis_rbd.collide` reports the pair as intersecting; the point then given for both
triangles is where an edge of one crosses the other (or, for coplanar or touching pairs, the
closest feature pair above, at round-off distance).

A flat triangle (normal at most 1e-12 of its longest edge squared) has no vertex-face case: it
is a segment or a point up to round-off, and its edges already carry every closest point.
Corners are ``(x, y, z)`` tuples; nothing is allocated.
"""

from __future__ import annotations

import math
import sys

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision._vec3 import add, cross, dot, scale, sub
from thesis_rbd.collision.mesh.triangle import tri_tri_overlap

__all__ = ["APART", "point_segment", "segment_segment", "triangle_distance", "triangle_gap"]

# The distance of a pair the exact test calls apart but whose closest points round to one
# point (apart by less than round-off resolves, as triangles on a fine grid can be): the least
# positive normal float, so that 0.0 means intersecting and nothing else.
APART = sys.float_info.min
# A normal shorter than this fraction of the longest edge squared marks a flat triangle (as in
# triangle.py).
_FLAT = 1e-12


@njit
def _dist2(a, b):
    d = sub(a, b)
    return dot(d, d)


@njit
def point_segment(x, p, q):
    """Closest point to ``x`` on segment [p, q] (a point if p == q)."""
    d = sub(q, p)
    dd = dot(d, d)
    if dd <= 0.0:
        return p
    t = dot(sub(x, p), d) / dd
    if t <= 0.0:
        return p
    if t >= 1.0:
        return q
    return add(p, scale(d, t))


@njit
def segment_segment(p0, p1, q0, q1):
    """Closest points (on [p0, p1], on [q0, q1]) of two segments and their squared distance.

    The minimiser of |p(s) - q(t)|^2 over all (s, t) is taken when it falls in the unit
    square; it is computed from the common normal ``n = u x v`` (``s = ((q0 - p0) x v) . n /
    |n|^2``), whose relative error grows like 1 / sin(angle) rather than the 1 / sin(angle)^2
    of the 2x2 normal equations, so nearly parallel segments keep their crossing point.
    Otherwise the minimum lies on the square's boundary: an end point of one segment against
    the other segment (four candidates).
    """
    u = sub(p1, p0)
    v = sub(q1, q0)
    n = cross(u, v)
    nn = dot(n, n)
    if nn > 0.0:
        w = sub(q0, p0)
        s = dot(cross(w, v), n) / nn
        t = dot(cross(w, u), n) / nn
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            x = add(p0, scale(u, s))
            y = add(q0, scale(v, t))
            return x, y, _dist2(x, y)
    bq = point_segment(p0, q0, q1)
    best = _dist2(p0, bq)
    bp = p0
    y = point_segment(p1, q0, q1)
    d2 = _dist2(p1, y)
    if d2 < best:
        best, bp, bq = d2, p1, y
    x = point_segment(q0, p0, p1)
    d2 = _dist2(x, q0)
    if d2 < best:
        best, bp, bq = d2, x, q0
    x = point_segment(q1, p0, p1)
    d2 = _dist2(x, q1)
    if d2 < best:
        best, bp, bq = d2, x, q1
    return bp, bq, best


@njit
def _separates(p, q, x, y):
    """Whether the plane through ``x`` normal to ``y - x`` has P on its near side and the
    parallel plane through ``y`` has Q on its far side: then no pair of points of P and Q is
    closer than (x, y), which is the triangles' closest pair."""
    v = sub(y, x)
    if dot(v, v) == 0.0:
        return False
    xv = dot(x, v)
    yv = dot(y, v)
    return (
        dot(p[0], v) <= xv
        and dot(p[1], v) <= xv
        and dot(p[2], v) <= xv
        and dot(q[0], v) >= yv
        and dot(q[1], v) >= yv
        and dot(q[2], v) >= yv
    )


@njit
def _normal(p0, p1, p2):
    """The triangle's (unnormalised) normal, or (0, 0, 0) if the triangle is flat."""
    n = cross(sub(p1, p0), sub(p2, p0))
    longest = max(_dist2(p0, p1), _dist2(p1, p2), _dist2(p2, p0))
    if dot(n, n) <= (_FLAT * longest) ** 2:
        return (0.0, 0.0, 0.0)
    return n


@njit
def _inside(x, q0, q1, q2, n):
    """Whether ``x`` (in the plane of Q up to round-off) lies in the closed triangle Q."""
    return (
        dot(cross(sub(q1, q0), sub(x, q0)), n) >= 0.0
        and dot(cross(sub(q2, q1), sub(x, q1)), n) >= 0.0
        and dot(cross(sub(q0, q2), sub(x, q2)), n) >= 0.0
    )


@njit
def _vertex_face(x, q0, q1, q2, n):
    """Projection of ``x`` on Q's plane and the squared distance, if it falls inside Q;
    otherwise (x, inf). ``n`` is Q's normal (zero for a flat Q: no face case)."""
    nn = dot(n, n)
    if nn == 0.0:
        return x, math.inf
    h = dot(sub(x, q0), n) / nn
    y = sub(x, scale(n, h))
    if not _inside(y, q0, q1, q2, n):
        return x, math.inf
    return y, h * h * nn


@njit
def _crossing(p0, p1, q0, q1, q2, n):
    """Where segment [p0, p1] crosses triangle Q (normal ``n``); (found, point)."""
    if dot(n, n) == 0.0:
        return False, p0
    s0 = dot(sub(p0, q0), n)
    s1 = dot(sub(p1, q0), n)
    if (s0 > 0.0 and s1 > 0.0) or (s0 < 0.0 and s1 < 0.0) or s0 == s1:
        return False, p0
    x = add(p0, scale(sub(p1, p0), s0 / (s0 - s1)))
    return _inside(x, q0, q1, q2, n), x


@njit
def _closest_features(p, q, n_p, n_q):
    """Least-distance feature pair of two triangles (tuples of corners): (x on P, y on Q, d^2).

    The 9 edge pairs first; as soon as one's closest points are certified by a separating
    plane (:func:`_separates`, as in PQP's triangle distance) they are the answer. Otherwise
    the 6 corner-face projections are tried as well and the least of all is returned.
    """
    best = math.inf
    bx = p[0]
    by = q[0]
    for i in range(3):
        for j in range(3):
            x, y, d2 = segment_segment(p[i], p[(i + 1) % 3], q[j], q[(j + 1) % 3])
            if d2 < best:
                best, bx, by = d2, x, y
                if _separates(p, q, x, y):
                    return bx, by, best
    for i in range(3):
        y, d2 = _vertex_face(p[i], q[0], q[1], q[2], n_q)
        if d2 < best:
            best, bx, by = d2, p[i], y
        x, d2 = _vertex_face(q[i], p[0], p[1], p[2], n_p)
        if d2 < best:
            best, bx, by = d2, x, q[i]
    return bx, by, best


@njit
def triangle_gap(p0, p1, p2, q0, q1, q2):
    """A cheap lower bound on the distance of triangles P and Q (0 when they may touch).

    The largest gap between the triangles' projections on three unit axes: each triangle's
    normal and the line through the centroids. A traversal skips the exact computation of a
    pair whose gap already reaches its best distance.
    """
    g = 0.0
    for axis in range(3):
        if axis == 0:
            n = cross(sub(p1, p0), sub(p2, p0))
        elif axis == 1:
            n = cross(sub(q1, q0), sub(q2, q0))
        else:
            n = sub(add(add(q0, q1), q2), add(add(p0, p1), p2))
        nn = dot(n, n)
        if nn <= 0.0:
            continue
        a0 = dot(n, p0)
        a1 = dot(n, p1)
        a2 = dot(n, p2)
        b0 = dot(n, q0)
        b1 = dot(n, q1)
        b2 = dot(n, q2)
        gap = max(min(b0, b1, b2) - max(a0, a1, a2), min(a0, a1, a2) - max(b0, b1, b2))
        if gap > 0.0:
            g = max(g, gap / math.sqrt(nn))
    return g * (1.0 - 1e-12)


@njit
def triangle_distance(p0, p1, p2, q0, q1, q2):
    """Distance between triangles P and Q and a closest pair of points.

    Parameters
    ----------
    p0, p1, p2, q0, q1, q2 : tuple of 3 float
        Corners, in one frame.

    Returns
    -------
    distance : float
        0.0 when they intersect (touching counts), positive when they do not: at least
        ``APART`` where they are apart by less than round-off resolves.
    x, y : tuple of 3 float
        Points on P and on Q, ``distance`` apart (the same point when they intersect).
    """
    p = (p0, p1, p2)
    q = (q0, q1, q2)
    n_p = _normal(p0, p1, p2)
    n_q = _normal(q0, q1, q2)
    if tri_tri_overlap(p0, p1, p2, q0, q1, q2):
        for i in range(3):
            found, x = _crossing(p[i], p[(i + 1) % 3], q0, q1, q2, n_q)
            if found:
                return 0.0, x, x
            found, x = _crossing(q[i], q[(i + 1) % 3], p0, p1, p2, n_p)
            if found:
                return 0.0, x, x
        x, y, _ = _closest_features(p, q, n_p, n_q)
        return 0.0, x, y
    x, y, d2 = _closest_features(p, q, n_p, n_q)
    return max(math.sqrt(d2), APART), x, y
