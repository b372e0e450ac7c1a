"""Exact contact report for intersecting triangle pairs (thesis 4.9 and 5.2), and merging.

Definition (what :func:`collide` returns in "contacts" mode)
------------------------------------------------------------
For every intersecting triangle pair (a of mesh A, b of mesh B):

* **Points**: the end points of the pair's intersection segment. In the generic case (the
  triangles cross, neither is degenerate) this is Möller's construction: the segment where each
  triangle meets the other's plane, both on the line of the two planes, overlapped; each end
  point is an edge of one mesh crossing a face of the other, or a corner lying on the other's
  plane (touching triangles: a face resting on an edge gives that edge's part on the face).
  Coplanar pairs (flush faces) give the corners of their overlap polygon, at most six. Pairs
  with a degenerate triangle (zero area, or a height below 1e-9 of its size, where its plane is
  rounding noise) give one point: the midpoint of the closest pair of features (edge-edge,
  corner-face, edge through face), which for touching triangles lies on both. Which case
  applies, and which corners lie on the other's plane, is decided by the exact predicates of
  :mod:`.predicates`, so touching and flush pairs are never taken for crossing ones; the points
  themselves are placed in floating point and lie on both triangles up to rounding.
* **Normal and depth**: the feature pair of least penetration, as in the thesis (5.2): the
  candidates are the face of b (vertex-face, normal = b's outward normal), the face of a
  (normal = minus a's normal), each unless its triangle is flat, and the 9 edge-edge directions
  ``e_a x e_b`` (oriented to point out of b, into a); the depth along a candidate unit
  direction ``u`` is how far A's triangle must move along ``u`` to clear B's,
  ``max_B(u.x) - min_A(u.x) >= 0``, and the candidate with the smallest depth wins. The normal
  is a unit vector from B towards A (the impulse ``+j n`` acts on A). For closed,
  outward-oriented meshes this is the vertex-face or edge-edge contact of the thesis; for open
  or inconsistently wound meshes the face normals still define the side.
* The depth is *local to the triangle pair*: how deeply these two triangles interpenetrate,
  not how deep one mesh is inside the other. For the shallow penetrations of a simulation
  (less than a triangle's size) the two agree; for deep overlaps (the tori demo) it is at
  most about a triangle's size, as with fcl's mesh-mesh contacts.

Merging
-------
The intersection of two meshes is a closed polyline; each corner of it is shared by the two
triangle pairs on either side of the crossing edge, so every point would be reported twice
(the duplicate contacts complained of in the thesis and fcl issue #106). The crossing points
are computed from the edge's vertices in a canonical order, so such duplicates are bitwise
equal. :func:`merge_contacts` clusters points that lie within ``tolerance`` of each other
(transitively) and keeps, per cluster, the contact of least depth; the survivors are pairwise
more than ``tolerance`` apart. No contact is produced without an intersecting triangle pair,
so there are no ghost contacts from box overlaps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._sorting import sorted_copy, stable_argsort
from thesis_rbd._union_find import find_root, join
from thesis_rbd.collision._vec3 import add, cross, dot, lerp, matvec, norm, scale, sub
from thesis_rbd.collision.mesh.predicates import orient2d, plane_sides
from thesis_rbd.collision.mesh.triangle import _drop, _projection

__all__ = ["Contacts", "cluster_points", "compute_contacts", "merge_contacts"]


@dataclass(frozen=True)
class Contacts:
    """Contact set of one mesh pair, world frame.

    Attributes
    ----------
    points : (c, 3) float64
        Contact points (on both triangles of the pair).
    normals : (c, 3) float64
        Unit normals pointing from B towards A.
    depths : (c,) float64
        Penetration depth along the normal, >= 0.
    faces : (c, 2) int64
        [face of A, face of B] of the triangle pair each contact comes from.
    """

    points: np.ndarray
    normals: np.ndarray
    depths: np.ndarray
    faces: np.ndarray

    def __len__(self) -> int:
        return len(self.depths)


@njit
def _depth_along(u, p0, p1, p2, q0, q1, q2):
    """How far A (p) must move along unit ``u`` to clear B (q): max_B(u.x) - min_A(u.x)."""
    return max(dot(u, q0), dot(u, q1), dot(u, q2)) - min(dot(u, p0), dot(u, p1), dot(u, p2))


@njit
def least_penetration(p0, p1, p2, q0, q1, q2):
    """Normal (unit, B -> A) and depth (>= 0) of the feature pair of least penetration."""
    ea = (sub(p1, p0), sub(p2, p1), sub(p0, p2))
    eb = (sub(q1, q0), sub(q2, q1), sub(q0, q2))
    na = cross(ea[0], ea[1])
    nb = cross(eb[0], eb[1])
    la = norm(na)
    lb = norm(nb)
    best = np.inf
    best_u = (0.0, 0.0, 1.0)
    # Outward side: the direction from B towards A, used to orient the edge-edge axes.
    side = (0.0, 0.0, 0.0)
    # a flat triangle (_is_flat) has no face normal: its cross product's direction is noise
    if lb > 0.0 and not _is_flat((q0, q1, q2), nb):
        u = scale(nb, 1.0 / lb)
        side = add(side, u)
        d = _depth_along(u, p0, p1, p2, q0, q1, q2)
        if d < best:
            best = d
            best_u = u
    if la > 0.0 and not _is_flat((p0, p1, p2), na):
        u = scale(na, -1.0 / la)
        side = add(side, u)
        d = _depth_along(u, p0, p1, p2, q0, q1, q2)
        if d < best:
            best = d
            best_u = u
    ca = scale(add(add(p0, p1), p2), 1.0 / 3.0)
    cb = scale(add(add(q0, q1), q2), 1.0 / 3.0)
    apart = sub(ca, cb)
    for i in range(3):
        for j in range(3):
            c = cross(ea[i], eb[j])
            lc = norm(c)
            # Skip (nearly) parallel edges: their cross product's direction is noise.
            if lc <= 1e-9 * norm(ea[i]) * norm(eb[j]) or lc == 0.0:
                continue
            u = scale(c, 1.0 / lc)
            s = dot(u, side)
            if s < 0.0 or (s == 0.0 and dot(u, apart) < 0.0):
                u = scale(u, -1.0)
            d = _depth_along(u, p0, p1, p2, q0, q1, q2)
            if d < best:
                best = d
                best_u = u
    if best == np.inf:
        # Both triangles degenerate and parallel: only their relative position is left.
        la = norm(apart)
        if la > 0.0:
            best_u = scale(apart, 1.0 / la)
        best = _depth_along(best_u, p0, p1, p2, q0, q1, q2)
    return best_u, max(best, 0.0)


@njit
def closest_on_segment_pair(p, q, r, s):
    """Closest points of segments pq and rs (Ericson 5.1.9; degenerate segments allowed)."""
    d1 = sub(q, p)
    d2 = sub(s, r)
    w = sub(p, r)
    a = dot(d1, d1)
    e = dot(d2, d2)
    f = dot(d2, w)
    if a <= 0.0 and e <= 0.0:
        return p, r
    if a <= 0.0:
        return p, lerp(r, s, min(max(f / e, 0.0), 1.0))
    c = dot(d1, w)
    if e <= 0.0:
        return lerp(p, q, min(max(-c / a, 0.0), 1.0)), r
    b = dot(d1, d2)
    den = a * e - b * b
    t1 = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 0.0 else 0.0
    t2 = (b * t1 + f) / e
    if t2 < 0.0:
        t2 = 0.0
        t1 = min(max(-c / a, 0.0), 1.0)
    elif t2 > 1.0:
        t2 = 1.0
        t1 = min(max((b - c) / a, 0.0), 1.0)
    return lerp(p, q, t1), lerp(r, s, t2)


@njit
def _inside_projection(x, a, b, c, n):
    """Projection of x on the plane of proper triangle abc (normal n), and whether inside."""
    n2 = dot(n, n)
    y = sub(x, scale(n, dot(n, sub(x, a)) / n2))
    inside = (
        dot(cross(sub(b, a), sub(y, a)), n) >= 0.0
        and dot(cross(sub(c, b), sub(y, b)), n) >= 0.0
        and dot(cross(sub(a, c), sub(y, c)), n) >= 0.0
    )
    return y, inside


@njit
def _dist2(a, b):
    d = sub(a, b)
    return dot(d, d)


@njit
def _is_flat(t, n):
    """Whether triangle t (normal n = an edge cross product) is (nearly) a segment or point.

    Relative test: |n| <= 1e-9 * (longest edge)^2, i.e. the triangle's height is below 1e-9
    of its size; such a plane is rounding noise and must not be used for clipping.
    """
    longest = 0.0
    for i in range(3):
        d = sub(t[(i + 1) % 3], t[i])
        longest = max(longest, dot(d, d))
    return dot(n, n) <= 1e-18 * longest * longest


@njit
def _closest_features_midpoint(p, q):
    """Midpoint of the closest feature pair of two triangles (tuples of 3 corners)."""
    best = np.inf
    point = p[0]
    for i in range(3):
        for j in range(3):
            x, y = closest_on_segment_pair(p[i], p[(i + 1) % 3], q[j], q[(j + 1) % 3])
            d = _dist2(x, y)
            if d < best:
                best = d
                point = scale(add(x, y), 0.5)
    for side in range(2):
        s = p if side == 0 else q
        t = q if side == 0 else p
        n = cross(sub(t[1], t[0]), sub(t[2], t[0]))
        if _is_flat(t, n):
            continue
        # Corners of s on the face of t.
        for i in range(3):
            y, inside = _inside_projection(s[i], t[0], t[1], t[2], n)
            if inside:
                d = _dist2(s[i], y)
                if d < best:
                    best = d
                    point = scale(add(s[i], y), 0.5)
        # Edges of s through the face of t.
        for i in range(3):
            a = s[i]
            b = s[(i + 1) % 3]
            da = dot(n, sub(a, t[0]))
            db = dot(n, sub(b, t[0]))
            if (da > 0.0 and db < 0.0) or (da < 0.0 and db > 0.0):
                x = lerp(a, b, da / (da - db))
                y, inside = _inside_projection(x, t[0], t[1], t[2], n)
                if inside:
                    d = _dist2(x, y)
                    if d < best:
                        best = d
                        point = scale(add(x, y), 0.5)
    return point


@njit
def _plane_section(p, ids, n, o, sides):
    """Where triangle p meets the plane (n, through o): up to 2 points and their count.

    ``sides`` are the exact sides of p's corners (:func:`.predicates.plane_sides`): they
    decide which corners lie on the plane and which edges cross it; the float distances
    along n only place the crossing points. These are computed from the edge's end points
    in increasing vertex-id order, so a neighbouring triangle sharing the edge gets the
    bitwise-same point.
    """
    d = (dot(n, sub(p[0], o)), dot(n, sub(p[1], o)), dot(n, sub(p[2], o)))
    out0 = p[0]
    out1 = p[0]
    count = 0
    for i in range(3):
        if sides[i] == 0:
            if count == 0:
                out0 = p[i]
            else:
                out1 = p[i]
            count += 1
    for i in range(3):
        j = (i + 1) % 3
        if sides[i] * sides[j] < 0:
            lo = i if ids[i] < ids[j] else j
            hi = j if lo == i else i
            x = lerp(p[lo], p[hi], _crossing(d[lo], d[hi]))
            if count == 0:
                out0 = x
            else:
                out1 = x
            count += 1
    return out0, out1, min(count, 2)


@njit
def _crossing(da, db):
    """Parameter in [0, 1] where a linear function with end values da, db (of opposite exact
    signs) vanishes; rounding of the values near touching is clamped."""
    if da == db:
        return 0.5
    return min(max(da / (da - db), 0.0), 1.0)


@njit
def _coplanar_polygon(p, q, k, out, spare):
    """Corners of the overlap of coplanar proper triangles p and q: q clipped by each edge
    line of p (Sutherland-Hodgman), the inside tests decided exactly in the projection
    along coordinate k (:func:`.triangle._projection`), the new corners placed by float
    interpolation in 3D. Writes at most 6 corners into ``out`` (9, 3); returns the count.
    """
    a = (_drop(p[0], k), _drop(p[1], k), _drop(p[2], k))
    o = orient2d(a[0], a[1], a[2])
    for i in range(3):
        for c in range(3):
            out[i, c] = q[i][c]
    n = 3
    poly = out
    other = spare
    swapped = False
    for e in range(3):
        u = a[e]
        v = a[(e + 1) % 3]
        m = 0
        for i in range(n):
            x = (poly[i, 0], poly[i, 1], poly[i, 2])
            j = (i + 1) % n
            y = (poly[j, 0], poly[j, 1], poly[j, 2])
            x2 = _drop(x, k)
            y2 = _drop(y, k)
            sx = orient2d(u, v, x2) * o
            sy = orient2d(u, v, y2) * o
            if sx >= 0:
                other[m, 0], other[m, 1], other[m, 2] = x
                m += 1
            if sx * sy < 0:
                fx = (v[0] - u[0]) * (x2[1] - u[1]) - (v[1] - u[1]) * (x2[0] - u[0])
                fy = (v[0] - u[0]) * (y2[1] - u[1]) - (v[1] - u[1]) * (y2[0] - u[0])
                other[m, 0], other[m, 1], other[m, 2] = lerp(x, y, _crossing(fx, fy))
                m += 1
        poly, other = other, poly
        swapped = not swapped
        n = m
        if n == 0:
            break
    if swapped:
        for i in range(n):
            for c in range(3):
                out[i, c] = poly[i, c]
    return n


@njit
def _pair_points(p, q, ida, idb, out, spare):
    """Intersection points of two intersecting triangles, written into ``out``; their count.

    Crossing triangles give the two end points of their intersection segment (one if it
    is a point), coplanar ones the corners of their overlap polygon (at most 6), and pairs
    with a flat triangle (zero area, or ``_is_flat``) the midpoint of their closest
    features. Which case applies, and which corners lie on the other's plane, is decided
    exactly.
    """
    kp, _ = _projection(p[0], p[1], p[2])
    kq, _ = _projection(q[0], q[1], q[2])
    na = cross(sub(p[1], p[0]), sub(p[2], p[1]))
    nb = cross(sub(q[1], q[0]), sub(q[2], q[1]))
    # A flat triangle's plane is rounding noise (collinear corners, once rounded or moved
    # into the other mesh's frame, are no longer exactly collinear): sections with it would
    # land anywhere along that plane.
    if kp < 0 or kq < 0 or _is_flat(p, na) or _is_flat(q, nb):
        return _one_point(_closest_features_midpoint(p, q), out)
    sp = plane_sides(q[0], q[1], q[2], p[0], p[1], p[2])
    if sp[0] == 0 and sp[1] == 0 and sp[2] == 0:
        count = _coplanar_polygon(p, q, kq, out, spare)
        if count == 0:
            return _one_point(_closest_features_midpoint(p, q), out)
        return count
    sq = plane_sides(p[0], p[1], p[2], q[0], q[1], q[2])
    a0, a1, ka = _plane_section(p, ida, nb, q[0], sp)
    b0, b1, kb = _plane_section(q, idb, na, p[0], sq)
    if ka == 0 or kb == 0:
        return _one_point(_closest_features_midpoint(p, q), out)
    if ka == 1:
        a1 = a0
    if kb == 1:
        b1 = b0
    line = cross(na, nb)
    sa0 = dot(line, a0)
    sa1 = dot(line, a1)
    if sa1 < sa0:
        a0, a1 = a1, a0
        sa0, sa1 = sa1, sa0
    sb0 = dot(line, b0)
    sb1 = dot(line, b1)
    if sb1 < sb0:
        b0, b1 = b1, b0
        sb0, sb1 = sb1, sb0
    lo = a0 if sa0 >= sb0 else b0
    slo = max(sa0, sb0)
    hi = a1 if sa1 <= sb1 else b1
    shi = min(sa1, sb1)
    if slo > shi:
        # Rounding made the two sections miss by a hair: report the point between them.
        return _one_point(scale(add(lo, hi), 0.5), out)
    if lo == hi:
        return _one_point(lo, out)
    out[0, 0], out[0, 1], out[0, 2] = lo
    out[1, 0], out[1, 1], out[1, 2] = hi
    return 2


@njit
def _one_point(x, out):
    out[0, 0], out[0, 1], out[0, 2] = x
    return 1


@njit
def compute_contacts(pairs, Va, Fa, Vb, Fb, Rab, tab):
    """Contacts of intersecting triangle pairs, in A's mesh frame.

    Parameters
    ----------
    pairs : (k, 2) int64
        Intersecting [face of A, face of B] pairs.
    Va, Vb : (n, 3) float64
        Vertices of each mesh in its own frame.
    Fa, Fb : (m, 3) int64
        Faces of each mesh.
    Rab : (3, 3) float64
    tab : (3,) float64
        Transform carrying B's mesh frame into A's.

    Returns
    -------
    points : (c, 3) float64
    normals : (c, 3) float64
        Unit, from B towards A.
    depths : (c,) float64
    faces : (c, 2) int64
        Before merging; up to two contacts per pair, six for a coplanar pair (see module
        docstring).
    """
    k = pairs.shape[0]
    points = np.empty((6 * k, 3))
    normals = np.empty((6 * k, 3))
    depths = np.empty(6 * k)
    faces = np.empty((6 * k, 2), dtype=np.int64)
    corners = np.empty((9, 3))
    spare = np.empty((9, 3))
    tr = (tab[0], tab[1], tab[2])
    c = 0
    for r in range(k):
        fa = pairs[r, 0]
        fb = pairs[r, 1]
        p = (
            (Va[Fa[fa, 0], 0], Va[Fa[fa, 0], 1], Va[Fa[fa, 0], 2]),
            (Va[Fa[fa, 1], 0], Va[Fa[fa, 1], 1], Va[Fa[fa, 1], 2]),
            (Va[Fa[fa, 2], 0], Va[Fa[fa, 2], 1], Va[Fa[fa, 2], 2]),
        )
        q = (
            add(matvec(Rab, (Vb[Fb[fb, 0], 0], Vb[Fb[fb, 0], 1], Vb[Fb[fb, 0], 2])), tr),
            add(matvec(Rab, (Vb[Fb[fb, 1], 0], Vb[Fb[fb, 1], 1], Vb[Fb[fb, 1], 2])), tr),
            add(matvec(Rab, (Vb[Fb[fb, 2], 0], Vb[Fb[fb, 2], 1], Vb[Fb[fb, 2], 2])), tr),
        )
        ida = (Fa[fa, 0], Fa[fa, 1], Fa[fa, 2])
        idb = (Fb[fb, 0], Fb[fb, 1], Fb[fb, 2])
        u, depth = least_penetration(p[0], p[1], p[2], q[0], q[1], q[2])
        count = _pair_points(p, q, ida, idb, corners, spare)
        for i in range(count):
            points[c, 0] = corners[i, 0]
            points[c, 1] = corners[i, 1]
            points[c, 2] = corners[i, 2]
            normals[c, 0] = u[0]
            normals[c, 1] = u[1]
            normals[c, 2] = u[2]
            depths[c] = depth
            faces[c, 0] = fa
            faces[c, 1] = fb
            c += 1
    return points[:c].copy(), normals[:c].copy(), depths[:c].copy(), faces[:c].copy()


@njit
def cluster_points(points, tolerance):
    """Union-find ``parent`` (c,) grouping points closer than ``tolerance``, transitively.

    A sweep along x bounds the pairs compared; roots are found with ``find_root``.
    """
    c = points.shape[0]
    parent = np.arange(c)
    order = stable_argsort(points[:, 0].copy())  # contiguous, as the other sorts' keys
    tol2 = tolerance * tolerance
    for ii in range(c):
        i = order[ii]
        jj = ii + 1
        while jj < c and points[order[jj], 0] - points[i, 0] <= tolerance:
            j = order[jj]
            dx = points[i, 0] - points[j, 0]
            dy = points[i, 1] - points[j, 1]
            dz = points[i, 2] - points[j, 2]
            if dx * dx + dy * dy + dz * dz <= tol2:
                join(parent, i, j)
            jj += 1
    return parent


@njit
def merge_contacts(points, depths, tolerance):
    """Indices (increasing) of the contacts kept after merging near-duplicates.

    Contacts within ``tolerance`` of each other are clustered transitively (union-find over a
    sweep along x); each cluster keeps its contact of least depth (ties: lowest index). Kept
    contacts are pairwise more than ``tolerance`` apart.
    """
    c = points.shape[0]
    parent = cluster_points(points, tolerance)
    best = np.full(c, -1, dtype=np.int64)
    for i in range(c):
        r = find_root(parent, i)
        if best[r] < 0 or depths[i] < depths[best[r]]:
            best[r] = i
    keep = np.empty(c, dtype=np.int64)
    n = 0
    for i in range(c):
        if parent[i] == i:
            keep[n] = best[i]
            n += 1
    out = sorted_copy(keep[:n])
    return out
