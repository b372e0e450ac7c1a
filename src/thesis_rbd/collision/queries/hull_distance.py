"""The distance of two meshes from their convex hulls, where the hulls prove it.

Every point of a mesh lies in its convex hull, so two meshes are never closer than their
hulls: GJK (Gilbert, Johnson, Keerthi; Ericson, Real-Time Collision Detection 9.5) over the
two hulls gives a lower bound on the mesh distance, the gap of a separating plane, in a few
support searches that each climb the hull's vertex graph from the last one. GJK ends on the
hulls' closest features, spanned by a few hull vertices on each side; and the
mesh triangles around those vertices are measured exactly
(:mod:`.triangle_distance`), and the least of those distances is an upper bound. Where the
two bounds meet (to 1e-12 of the meshes' sizes) that triangle pair is the answer: the
closest points lie on the meshes' own surfaces, as they do wherever two meshes face each
other with convex sides, whatever their size.

Where they do not meet (a closest point in a concavity the hull spans, hulls that overlap,
a flat mesh without a hull), the caller descends the trees, starting from the upper bound.
The answer is exact either way; only its cost differs.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.convex.gjk import closest_on_simplex
from thesis_rbd.collision.mesh.packed import corner, corner_moved, hull_row, tree_scale
from thesis_rbd.collision.mesh.packed_hull import hull_fields
from thesis_rbd.collision.queries.triangle_distance import triangle_distance, triangle_gap

__all__ = ["hull_distance"]

_GJK_ITERATIONS = 64
# The bounds meet when they differ by at most this fraction of the two meshes' sizes and
# the distance: far above the round-off of a support point, far below any answer's error
# budget
_MEET = 1e-12


@njit(allocates=False)
def _climb(F, xyz, start, neighbours, dx, dy, dz, v):
    """Hull vertex farthest along (dx, dy, dz), climbing the vertex graph from vertex v."""
    best = dx * F[xyz + 3 * v] + dy * F[xyz + 3 * v + 1] + dz * F[xyz + 3 * v + 2]
    moved = True
    while moved:
        moved = False
        for k in range(int(F[start + v]), int(F[start + v + 1])):
            u = int(F[neighbours + k])
            s = dx * F[xyz + 3 * u] + dy * F[xyz + 3 * u + 1] + dz * F[xyz + 3 * u + 2]
            if s > best:
                best, v, moved = s, u, True
    return v


@njit(allocates=False)
def _extreme(F, base, dx, dy, dz):
    """The hull's extreme vertex (block at ``F[base]``) along the axis nearest (dx, dy, dz)."""
    ax, ay, az = abs(dx), abs(dy), abs(dz)
    if ax >= ay and ax >= az:
        return int(F[base + 3 + (1 if dx > 0.0 else 0)])
    if ay >= az:
        return int(F[base + 5 + (1 if dy > 0.0 else 0)])
    return int(F[base + 7 + (1 if dz > 0.0 else 0)])


@njit
def _around(F, face_start, faces, hull_vertices, n):
    """Mesh faces at the hull feature spanned by hull vertices ``hull_vertices[:n]``
    (repeats allowed): the faces holding all its distinct vertices (the feature itself,
    where it is a mesh edge or face), or else every face around any of them.
    Returns (count,) int64."""
    first = hull_vertices[0]
    lo, hi = int(F[face_start + first]), int(F[face_start + first + 1])
    out = np.empty(hi - lo, dtype=np.int64)
    count = 0
    for q in range(lo, hi):
        f = int(F[faces + q])
        # f holds every other vertex of the feature if it is among each one's faces
        holds = True
        for k in range(1, n):
            v = hull_vertices[k]
            if v == first:
                continue
            found = False
            for r in range(int(F[face_start + v]), int(F[face_start + v + 1])):
                found |= int(F[faces + r]) == f
            holds &= found
        if holds:
            out[count] = f
            count += 1
    if count > 0:
        return out[:count]
    total = 0
    for k in range(n):
        v = hull_vertices[k]
        total += int(F[face_start + v + 1]) - int(F[face_start + v])
    out = np.empty(total, dtype=np.int64)
    count = 0
    for k in range(n):
        v = hull_vertices[k]
        for q in range(int(F[face_start + v]), int(F[face_start + v + 1])):
            out[count] = int(F[faces + q])
            count += 1
    return out


@njit
def hull_distance(Pa, La, Pb, Lb, M, t):
    """GJK over the hulls of two packed trees, B placed in A's mesh frame by (M, t).

    Parameters
    ----------
    Pa, La, Pb, Lb : packed trees and their layouts (:mod:`..mesh.packed`)
    M, t : tuple of 9 float, tuple of 3 float
        B's mesh frame in A's (row-major rotation and translation).

    Returns
    -------
    proved, distance, point_a, point_b, face_a, face_b, triangle_tests
        ``proved``: the hulls are apart and their lower bound meets the least distance of
        the triangles around their closest features, which is then the meshes' distance.
        Otherwise ``distance`` (with its points, A's mesh frame, and faces) is the least
        triangle distance measured, an upper bound (inf, faces -1, if none was measured).
    """
    no = (0.0, 0.0, 0.0)
    row_a = hull_row(Pa, La)
    row_b = hull_row(Pb, Lb)
    if row_a < 0 or row_b < 0:
        return False, math.inf, no, no, -1, -1, 0
    Fa = Pa.reshape(Pa.size)
    Fb = Pb.reshape(Pb.size)
    ha, xa, sa, na, fsa, fa = hull_fields(Fa, 3 * row_a)
    hb, xb, sb, nb, fsb, fb = hull_fields(Fb, 3 * row_b)
    if ha == 0 or hb == 0:
        return False, math.inf, no, no, -1, -1, 0
    # GJK on M = A - B (B carried into A's frame): the simplex P[:n], its hull vertices
    P = np.empty((4, 3))
    ia = np.empty(4, dtype=np.int64)
    ib = np.empty(4, dtype=np.int64)
    rows = np.empty(4, dtype=np.int64)
    # from the line between the hulls' first vertices, each climb starting at the hull's
    # extreme vertex along the axis nearest its direction
    bx, by, bz = Fb[xb], Fb[xb + 1], Fb[xb + 2]
    vx = Fa[xa] - (M[0] * bx + M[1] * by + M[2] * bz + t[0])
    vy = Fa[xa + 1] - (M[3] * bx + M[4] * by + M[5] * bz + t[1])
    vz = Fa[xa + 2] - (M[6] * bx + M[7] * by + M[8] * bz + t[2])
    va = _extreme(Fa, 3 * row_a, -vx, -vy, -vz)
    vb = _extreme(
        Fb, 3 * row_b, M[0] * vx + M[3] * vy + M[6] * vz, M[1] * vx + M[4] * vy + M[7] * vz,
        M[2] * vx + M[5] * vy + M[8] * vz,
    )  # fmt: skip
    n = 0
    lower = 0.0
    for _ in range(_GJK_ITERATIONS):
        v2 = vx * vx + vy * vy + vz * vz
        if v2 == 0.0:
            break
        # support of M along -v: A's along -v, B's along +v (in B's frame, M^T v)
        va = _climb(Fa, xa, sa, na, -vx, -vy, -vz, va)
        ex = M[0] * vx + M[3] * vy + M[6] * vz
        ey = M[1] * vx + M[4] * vy + M[7] * vz
        ez = M[2] * vx + M[5] * vy + M[8] * vz
        vb = _climb(Fb, xb, sb, nb, ex, ey, ez, vb)
        bx, by, bz = Fb[xb + 3 * vb], Fb[xb + 3 * vb + 1], Fb[xb + 3 * vb + 2]
        wx = Fa[xa + 3 * va] - (M[0] * bx + M[1] * by + M[2] * bz + t[0])
        wy = Fa[xa + 3 * va + 1] - (M[3] * bx + M[4] * by + M[5] * bz + t[1])
        wz = Fa[xa + 3 * va + 2] - (M[6] * bx + M[7] * by + M[8] * bz + t[2])
        vw = vx * wx + vy * wy + vz * wz
        if vw > 0.0:
            lower = max(lower, vw / math.sqrt(v2))
        repeated = False
        for k in range(n):
            repeated |= ia[k] == va and ib[k] == vb
        if repeated or v2 - vw <= 1e-14 * v2:
            if n == 0:
                # the first support already meets v (the starting vertices are the closest):
                # that vertex pair is the closest feature
                ia[0] = va
                ib[0] = vb
                n = 1
            break
        P[n, 0], P[n, 1], P[n, 2] = wx, wy, wz
        ia[n] = va
        ib[n] = vb
        n, vx, vy, vz = closest_on_simplex(P, ia, ib, n + 1, rows)
        if n == 4:
            break
    # a simplex that ends as a tetrahedron is round-off where the hulls touch flat on flat
    # (coplanar hull vertices): if a support plane separated them, its gap is still a lower
    # bound, and the triangles around all four vertices are measured against it
    if lower <= 0.0 or n == 0:
        return False, math.inf, no, no, -1, -1, 0
    return _measure(Pa, La, Pb, Lb, M, t, Fa, fsa, fa, Fb, fsb, fb, ia, ib, n, lower)


@njit
def _measure(Pa, La, Pb, Lb, M, t, Fa, fsa, fa, Fb, fsb, fb, ia, ib, n, lower):
    """Least distance of the triangles around the closest features (hull vertices ia[:n] of
    A, ib[:n] of B), and whether it meets the lower bound (see :func:`hull_distance`)."""
    faces_a = _around(Fa, fsa, fa, ia, n)
    faces_b = _around(Fb, fsb, fb, ib, n)
    best = math.inf
    best_a = (0.0, 0.0, 0.0)
    best_b = (0.0, 0.0, 0.0)
    face_a = -1
    face_b = -1
    tests = 0
    for i in range(faces_a.shape[0]):
        p0 = corner(Pa, La, faces_a[i], 0)
        p1 = corner(Pa, La, faces_a[i], 1)
        p2 = corner(Pa, La, faces_a[i], 2)
        for j in range(faces_b.shape[0]):
            q0 = corner_moved(Pb, Lb, faces_b[j], 0, M, t)
            q1 = corner_moved(Pb, Lb, faces_b[j], 1, M, t)
            q2 = corner_moved(Pb, Lb, faces_b[j], 2, M, t)
            if best < math.inf and triangle_gap(p0, p1, p2, q0, q1, q2) >= best:
                continue
            tests += 1
            d, x, y = triangle_distance(p0, p1, p2, q0, q1, q2)
            if d < best:
                best, best_a, best_b, face_a, face_b = d, x, y, faces_a[i], faces_b[j]
    meet = _MEET * (tree_scale(Pa) + tree_scale(Pb) + best)
    return best - lower <= meet, best, best_a, best_b, face_a, face_b, tests
