"""GJK and EPA for convex hulls with many vertices, finished on exact features.

The separating-axis test costs (faces x vertices + edges x edges) per pair, which for an
icosphere is thousands of candidates. GJK (Gilbert, Johnson, Keerthi; van den Bergen's
formulation, Ericson "Real-Time Collision Detection" 9.5) instead walks the Minkowski
difference M = A - B through support points, a handful per pair, and the support of a hull
is found by climbing its vertex graph from the last support vertex (a convex polyhedron's
support function has no local maximum on that graph but the global one), so each costs a
few dot products, not one per vertex.

If GJK finds the origin inside M, the hulls overlap, and EPA (the expanding polytope
algorithm) grows a polytope inside M from GJK's tetrahedron towards M's boundary face nearest
the origin: the axis of least penetration. EPA stops when a support point adds nothing along
the nearest face's normal, so that face lies on M's boundary. Its corners are differences of
hull vertices: the faces and edges around those vertices hold the features of the face of M
it lies on, and the axis and depth are finally taken from those features exactly (the
largest separation over their face normals and Gauss-pruned edge pairs), which is what
the separating-axis test would have found. Touching or degenerate configurations, where GJK
ends on a flat simplex or EPA would divide by nothing, go to the separating-axis test.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.convex.sat import EDGES, FACE_A, FACE_B, place_hull, sat_query

__all__ = ["CACHE_AXIS", "closest_on_simplex", "gjk_epa_query", "mapped_support", "support_vertex"]

# Cache kind of a GJK separating direction (a direction, no feature)
CACHE_AXIS = 4
_GJK_ITERATIONS = 64
_EPA_ITERATIONS = 128
_EPA_FACES = 512
_EPA_VERTICES = _EPA_ITERATIONS + 4
# EPA stops when a support point lies no further than this fraction of the hulls' sizes
# beyond the nearest face: the face is on M's boundary to round-off.
_EPA_TOLERANCE = 1e-11
# The exact axis is sought among features within this angle (rad) of EPA's normal
_AXIS_ANGLE = 1e-2
_AXIS_COSINE = math.cos(_AXIS_ANGLE)


@njit(allocates=False)
def support_vertex(vertices, neighbor_start, neighbors, dx, dy, dz, start):
    """Vertex of a hull farthest along (dx, dy, dz), by climbing from vertex ``start``.

    Parameters
    ----------
    vertices : (v, 3) float64
    neighbor_start : (v + 1,) int64
        Offsets into ``neighbors`` (global offsets, local vertex indices).
    """
    v = start
    best = dx * vertices[v, 0] + dy * vertices[v, 1] + dz * vertices[v, 2]
    moved = True
    while moved:
        moved = False
        for k in range(neighbor_start[v], neighbor_start[v + 1]):
            u = neighbors[k]
            s = dx * vertices[u, 0] + dy * vertices[u, 1] + dz * vertices[u, 2]
            if s > best:
                best, v, moved = s, u, True
    return v


@njit(allocates=False)
def mapped_support(H, h, M, c, dx, dy, dz, start):
    """Vertex of hull ``h`` farthest along (dx, dy, dz), a direction in a frame the hull is
    mapped into by x -> M x + c, climbing from its vertex ``start`` (any index outside the
    hull starts at its first vertex): (x, y, z, vertex), the point in that frame and the
    vertex's index in its hull."""
    vertex_start, vertices, neighbor_start, neighbors = (
        H.vertex_start,
        H.vertices,
        H.neighbor_start,
        H.neighbors,
    )
    # the support along d in the mapped frame is the support along M^T d in the hull's own
    ex = M[0, 0] * dx + M[1, 0] * dy + M[2, 0] * dz
    ey = M[0, 1] * dx + M[1, 1] * dy + M[2, 1] * dz
    ez = M[0, 2] * dx + M[1, 2] * dy + M[2, 2] * dz
    v0, v1 = vertex_start[h], vertex_start[h + 1]
    local = support_vertex(
        vertices[v0:v1], neighbor_start[v0 : v1 + 1], neighbors, ex, ey, ez,
        start if 0 <= start < v1 - v0 else 0,
    )  # fmt: skip
    v = v0 + local
    x = M[0, 0] * vertices[v, 0] + M[0, 1] * vertices[v, 1] + M[0, 2] * vertices[v, 2] + c[0]
    y = M[1, 0] * vertices[v, 0] + M[1, 1] * vertices[v, 1] + M[1, 2] * vertices[v, 2] + c[1]
    z = M[2, 0] * vertices[v, 0] + M[2, 1] * vertices[v, 1] + M[2, 2] * vertices[v, 2] + c[2]
    return x, y, z, local


@njit
def _support(H, ha, hb, R, t, dx, dy, dz, start_a, start_b, out, row, index_a, index_b):
    """Support point of M = A - B along d (A's frame) into ``out[row]``; its vertex indices
    into ``index_a[row]``, ``index_b[row]``."""
    vertex_start, vertices, neighbor_start, neighbors = (
        H.vertex_start,
        H.vertices,
        H.neighbor_start,
        H.neighbors,
    )
    a0, a1 = vertex_start[ha], vertex_start[ha + 1]
    b0, b1 = vertex_start[hb], vertex_start[hb + 1]
    ia = support_vertex(vertices[a0:a1], neighbor_start[a0 : a1 + 1], neighbors,
                        dx, dy, dz, start_a)  # fmt: skip
    # B's support along -d, searched in B's frame along -R^T d
    ex = -(R[0, 0] * dx + R[1, 0] * dy + R[2, 0] * dz)
    ey = -(R[0, 1] * dx + R[1, 1] * dy + R[2, 1] * dz)
    ez = -(R[0, 2] * dx + R[1, 2] * dy + R[2, 2] * dz)
    ib = support_vertex(vertices[b0:b1], neighbor_start[b0 : b1 + 1], neighbors,
                        ex, ey, ez, start_b)  # fmt: skip
    vb = vertices[b0 + ib]
    for a in range(3):
        out[row, a] = vertices[a0 + ia, a] - (
            R[a, 0] * vb[0] + R[a, 1] * vb[1] + R[a, 2] * vb[2] + t[a]
        )
    index_a[row] = ia
    index_b[row] = ib


@njit
def _dot(P, i, x, y, z):
    return P[i, 0] * x + P[i, 1] * y + P[i, 2] * z


@njit
def _keep(P, ia, ib, rows, count):
    """Compact simplex rows ``rows[:count]`` to the front."""
    for k in range(count):
        r = rows[k]
        if r != k:
            P[k, 0], P[k, 1], P[k, 2] = P[r, 0], P[r, 1], P[r, 2]
            ia[k] = ia[r]
            ib[k] = ib[r]
    return count


@njit
def _others(face):
    """The tetrahedron corners other than ``face``, increasing, then ``face``."""
    if face == 0:
        return 1, 2, 3, 0
    if face == 1:
        return 0, 2, 3, 1
    if face == 2:
        return 0, 1, 3, 2
    return 0, 1, 2, 3


@njit
def closest_on_simplex(P, ia, ib, n, rows):
    """Point of the simplex P[:n] (n = 1..4) nearest the origin; shrinks the simplex to the
    smallest face holding it (Ericson 5.1.5 / 9.5.2). Returns (count, vx, vy, vz); count 4
    means the origin is inside the tetrahedron."""
    if n == 1:
        return 1, P[0, 0], P[0, 1], P[0, 2]
    if n == 2:
        abx, aby, abz = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1], P[1, 2] - P[0, 2]
        s = -_dot(P, 0, abx, aby, abz)
        length2 = abx * abx + aby * aby + abz * abz
        if s <= 0.0 or length2 == 0.0:
            return 1, P[0, 0], P[0, 1], P[0, 2]
        if s >= length2:
            rows[0] = 1
            _keep(P, ia, ib, rows, 1)
            return 1, P[0, 0], P[0, 1], P[0, 2]
        s /= length2
        return 2, P[0, 0] + s * abx, P[0, 1] + s * aby, P[0, 2] + s * abz
    if n == 3:
        return _closest_on_triangle(P, ia, ib, 0, 1, 2, rows, True)
    # tetrahedron: the origin is inside unless it lies beyond one of its faces
    best = np.inf
    best_face = -1
    for face in range(4):
        # the other three corners in increasing order, so shrinking copies rows forwards only
        i0, i1, i2, i3 = _others(face)
        ux, uy, uz = P[i1, 0] - P[i0, 0], P[i1, 1] - P[i0, 1], P[i1, 2] - P[i0, 2]
        wx, wy, wz = P[i2, 0] - P[i0, 0], P[i2, 1] - P[i0, 1], P[i2, 2] - P[i0, 2]
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        origin_side = -_dot(P, i0, nx, ny, nz)
        opposite_side = _dot(P, i3, nx, ny, nz) - _dot(P, i0, nx, ny, nz)
        if origin_side * opposite_side < 0.0:
            _, x, y, z = _closest_on_triangle(P, ia, ib, i0, i1, i2, rows, False)
            d2 = x * x + y * y + z * z
            if d2 < best:
                best, best_face = d2, face
    if best_face < 0:
        return 4, 0.0, 0.0, 0.0
    i0, i1, i2, _ = _others(best_face)
    return _closest_on_triangle(P, ia, ib, i0, i1, i2, rows, True)


@njit
def _closest_on_triangle(P, ia, ib, i0, i1, i2, rows, shrink):
    """Point of triangle (P[i0], P[i1], P[i2]) nearest the origin (Ericson 5.1.5); with
    ``shrink`` the simplex becomes the triangle's feature holding it."""
    ax, ay, az = P[i0, 0], P[i0, 1], P[i0, 2]
    abx, aby, abz = P[i1, 0] - ax, P[i1, 1] - ay, P[i1, 2] - az
    acx, acy, acz = P[i2, 0] - ax, P[i2, 1] - ay, P[i2, 2] - az
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    count = 3
    if d1 <= 0.0 and d2 <= 0.0:
        rows[0], count, x, y, z = i0, 1, ax, ay, az
    else:
        bx, by, bz = P[i1, 0], P[i1, 1], P[i1, 2]
        d3 = -(abx * bx + aby * by + abz * bz)
        d4 = -(acx * bx + acy * by + acz * bz)
        cx, cy, cz = P[i2, 0], P[i2, 1], P[i2, 2]
        d5 = -(abx * cx + aby * cy + abz * cz)
        d6 = -(acx * cx + acy * cy + acz * cz)
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            rows[0], count, x, y, z = i1, 1, bx, by, bz
        elif d6 >= 0.0 and d5 <= d6:
            rows[0], count, x, y, z = i2, 1, cx, cy, cz
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            s = d1 / (d1 - d3)
            rows[0], rows[1], count = i0, i1, 2
            x, y, z = ax + s * abx, ay + s * aby, az + s * abz
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            s = d2 / (d2 - d6)
            rows[0], rows[1], count = i0, i2, 2
            x, y, z = ax + s * acx, ay + s * acy, az + s * acz
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            rows[0], rows[1], count = i1, i2, 2
            x = bx + s * (cx - bx)
            y = by + s * (cy - by)
            z = bz + s * (cz - bz)
        else:
            total = va + vb + vc
            if total == 0.0:
                rows[0], count, x, y, z = i0, 1, ax, ay, az
            else:
                v = vb / total
                w = vc / total
                rows[0], rows[1], rows[2] = i0, i1, i2
                x = ax + v * abx + w * acx
                y = ay + v * aby + w * acy
                z = az + v * abz + w * acz
    if shrink:
        _keep(P, ia, ib, rows, count)
    return count, x, y, z


@njit
def epa_scratch():
    """Scratch arrays of one EPA run, reused over the pairs of a kernel call."""
    return (
        np.empty((_EPA_VERTICES, 3)),
        np.empty(_EPA_VERTICES, np.int64),
        np.empty(_EPA_VERTICES, np.int64),
        np.empty((_EPA_FACES, 3), np.int64),
        np.empty((_EPA_FACES, 4)),
        np.empty(_EPA_FACES, np.bool_),
        np.empty((3 * _EPA_FACES, 2), np.int64),
        np.empty(4, np.int64),
        np.empty((4, 3)),
        np.empty(4, np.int64),
        np.empty(4, np.int64),
    )


@njit
def _thickness(P):
    """Least height of the tetrahedron P[:4] over its faces: 6 volume / largest face area
    (doubled)."""
    ux, uy, uz = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1], P[1, 2] - P[0, 2]
    vx, vy, vz = P[2, 0] - P[0, 0], P[2, 1] - P[0, 1], P[2, 2] - P[0, 2]
    wx, wy, wz = P[3, 0] - P[0, 0], P[3, 1] - P[0, 1], P[3, 2] - P[0, 2]
    volume = abs(ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx))
    largest = 0.0
    for i, j, k in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        ax, ay, az = P[j, 0] - P[i, 0], P[j, 1] - P[i, 1], P[j, 2] - P[i, 2]
        bx, by, bz = P[k, 0] - P[i, 0], P[k, 1] - P[i, 1], P[k, 2] - P[i, 2]
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        largest = max(largest, math.sqrt(nx * nx + ny * ny + nz * nz))
    return volume / largest if largest > 0.0 else 0.0


@njit(separate=True)
def _gjk(H, ha, hb, R, t, vx, vy, vz, P, ia, ib, rows, tolerance, margin):
    """GJK from the direction -v: (status, vx, vy, vz, bound).

    status 1: separated by more than ``margin``, every point x of M has x.v >= bound >
    margin |v|; 0: the origin is inside the tetrahedron P[:4]; -1: within the margin,
    touching or degenerate (the origin on M's boundary to round-off).
    """
    n = 0
    start_a, start_b = 0, 0
    tolerance2 = tolerance * tolerance
    for _ in range(_GJK_ITERATIONS):
        _support(H, ha, hb, R, t, -vx, -vy, -vz, start_a, start_b, P, n, ia, ib)
        start_a, start_b = ia[n], ib[n]
        vw = _dot(P, n, vx, vy, vz)
        v2 = vx * vx + vy * vy + vz * vz
        if vw > 0.0 and vw * vw > margin * margin * v2:
            return 1, vx, vy, vz, vw
        if n > 0:
            for k in range(n):
                if ia[k] == ia[n] and ib[k] == ib[n]:
                    return -1, vx, vy, vz, 0.0  # no new support point: converged onto the origin
            if v2 - vw <= 1e-12 * v2:
                return -1, vx, vy, vz, 0.0
        n, vx, vy, vz = closest_on_simplex(P, ia, ib, n + 1, rows)
        if n == 4:
            # a flat tetrahedron decides nothing: the signs that put the origin inside it
            # are round-off (the origin may lie off its plane, outside M)
            return (0 if _thickness(P) > tolerance else -1), vx, vy, vz, 0.0
        if vx * vx + vy * vy + vz * vz <= tolerance2:
            return -1, vx, vy, vz, 0.0
    return -1, vx, vy, vz, 0.0


@njit
def _face_plane(V, a, b, c, out, f):
    """Plane of triangle (a, b, c) of V into out[f] = (n, d), n = (b - a) x (c - a) / |..|;
    returns False if degenerate."""
    ux, uy, uz = V[b, 0] - V[a, 0], V[b, 1] - V[a, 1], V[b, 2] - V[a, 2]
    wx, wy, wz = V[c, 0] - V[a, 0], V[c, 1] - V[a, 1], V[c, 2] - V[a, 2]
    nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if length == 0.0:
        return False
    nx, ny, nz = nx / length, ny / length, nz / length
    out[f, 0], out[f, 1], out[f, 2] = nx, ny, nz
    out[f, 3] = nx * V[a, 0] + ny * V[a, 1] + nz * V[a, 2]
    return True


@njit(separate=True)
def _epa(H, ha, hb, R, t, P, ia, ib, scratch, tolerance):
    """EPA from the tetrahedron P[:4] around the origin.

    Returns (ok, face): the polytope face (row of the scratch faces) nearest the origin once
    no support point lies beyond it by more than ``tolerance``; ok False on degeneracy.
    """
    V, va, vb, faces, planes, alive, horizon = scratch[:7]
    for k in range(4):
        V[k, 0], V[k, 1], V[k, 2] = P[k, 0], P[k, 1], P[k, 2]
        va[k] = ia[k]
        vb[k] = ib[k]
    cx = 0.25 * (V[0, 0] + V[1, 0] + V[2, 0] + V[3, 0])
    cy = 0.25 * (V[0, 1] + V[1, 1] + V[2, 1] + V[3, 1])
    cz = 0.25 * (V[0, 2] + V[1, 2] + V[2, 2] + V[3, 2])
    face_count = 0
    for a, b, c in ((0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)):
        if not _face_plane(V, a, b, c, planes, face_count):
            return False, 0
        if planes[face_count, 0] * cx + planes[face_count, 1] * cy + planes[face_count, 2] * cz \
                > planes[face_count, 3]:  # fmt: skip
            b, c = c, b
            _face_plane(V, a, b, c, planes, face_count)
        faces[face_count, 0], faces[face_count, 1], faces[face_count, 2] = a, b, c
        alive[face_count] = True
        face_count += 1
    vertex_count = 4
    for _ in range(_EPA_ITERATIONS):
        nearest, nearest_d = -1, np.inf
        for f in range(face_count):
            if alive[f] and planes[f, 3] < nearest_d:
                nearest, nearest_d = f, planes[f, 3]
        if nearest < 0 or nearest_d < -tolerance:
            return False, 0
        if vertex_count == _EPA_VERTICES:
            return False, 0
        w = vertex_count
        nx, ny, nz = planes[nearest, 0], planes[nearest, 1], planes[nearest, 2]
        _support(H, ha, hb, R, t, nx, ny, nz, va[faces[nearest, 0]], vb[faces[nearest, 0]],
                 V, w, va, vb)  # fmt: skip
        if _dot(V, w, nx, ny, nz) - nearest_d <= tolerance:
            return True, nearest
        vertex_count += 1
        # remove the faces the new point sees; their unshared edges form the horizon
        edge_count = 0
        for f in range(face_count):
            if not alive[f]:
                continue
            if _dot(V, w, planes[f, 0], planes[f, 1], planes[f, 2]) - planes[f, 3] <= 0.0:
                continue
            alive[f] = False
            for k in range(3):
                u, v = faces[f, k], faces[f, (k + 1) % 3]
                shared = -1
                for e in range(edge_count):
                    if horizon[e, 0] == v and horizon[e, 1] == u:
                        shared = e
                        break
                if shared >= 0:
                    edge_count -= 1
                    horizon[shared] = horizon[edge_count]
                else:
                    horizon[edge_count, 0], horizon[edge_count, 1] = u, v
                    edge_count += 1
        if face_count + edge_count > _EPA_FACES:
            return False, 0
        for e in range(edge_count):
            u, v = horizon[e, 0], horizon[e, 1]
            if not _face_plane(V, u, v, w, planes, face_count):
                return False, 0
            faces[face_count, 0], faces[face_count, 1], faces[face_count, 2] = u, v, w
            alive[face_count] = True
            face_count += 1
    return False, 0


@njit
def _support_b_along(H, hb, R, t, dx, dy, dz, start):
    """B's support point along d (A's frame), in A's frame: (x, y, z, vertex)."""
    vertex_start, vertices, neighbor_start, neighbors = (
        H.vertex_start,
        H.vertices,
        H.neighbor_start,
        H.neighbors,
    )
    b0, b1 = vertex_start[hb], vertex_start[hb + 1]
    ex = R[0, 0] * dx + R[1, 0] * dy + R[2, 0] * dz
    ey = R[0, 1] * dx + R[1, 1] * dy + R[2, 1] * dz
    ez = R[0, 2] * dx + R[1, 2] * dy + R[2, 2] * dz
    v = support_vertex(vertices[b0:b1], neighbor_start[b0 : b1 + 1], neighbors, ex, ey, ez,
                       start)  # fmt: skip
    p = vertices[b0 + v]
    return (
        R[0, 0] * p[0] + R[0, 1] * p[1] + R[0, 2] * p[2] + t[0],
        R[1, 0] * p[0] + R[1, 1] * p[1] + R[1, 2] * p[2] + t[1],
        R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2] + t[2],
        v,
    )


@njit
def _rotate(R, x, y, z):
    return (
        R[0, 0] * x + R[0, 1] * y + R[0, 2] * z,
        R[1, 0] * x + R[1, 1] * y + R[1, 2] * z,
        R[2, 0] * x + R[2, 1] * y + R[2, 2] * z,
    )


@njit(separate=True)
def _exact_axis(H, ha, hb, R, t, corners_a, corners_b, tie, px, py, pz):
    """Largest separation over the features around the given vertices of A and of B.

    Candidates: faces of A around ``corners_a``, faces of B around ``corners_b``, and the
    pairs of their edges that build a Minkowski face, each only if its axis is within
    ``_AXIS_ANGLE`` of EPA's normal (px, py, pz): the face of M that EPA stopped on lies
    in the plane of the true one, so the axis sought is EPA's to round-off. Returns (kind,
    i, j, separation, ux, uy, uz) as ``sat_query``.
    """
    (vertex_start, vertices, neighbor_start, neighbors, neighbor_edges, vertex_face_start,
     vertex_faces, face_start, planes, _, _, edge_start, edges, edge_faces, edge_arcs,
     centroids, _, _, _, _) = H  # fmt: skip
    a0, b0 = vertex_start[ha], vertex_start[hb]
    fa0, fb0 = face_start[ha], face_start[hb]
    ea0, eb0 = edge_start[ha], edge_start[hb]
    sep_a, face_a = -np.inf, -1
    for ca in corners_a:
        for k in range(vertex_face_start[a0 + ca], vertex_face_start[a0 + ca + 1]):
            f = fa0 + vertex_faces[k]
            nx, ny, nz = planes[f, 0], planes[f, 1], planes[f, 2]
            if nx * px + ny * py + nz * pz < _AXIS_COSINE:
                continue
            x, y, z, _ = _support_b_along(H, hb, R, t, -nx, -ny, -nz, corners_b[0])
            s = nx * x + ny * y + nz * z - planes[f, 3]
            if s > sep_a:
                sep_a, face_a = s, vertex_faces[k]
    sep_b, face_b = -np.inf, -1
    A = vertices[a0 : vertex_start[ha + 1]]
    for cb in corners_b:
        for k in range(vertex_face_start[b0 + cb], vertex_face_start[b0 + cb + 1]):
            g = fb0 + vertex_faces[k]
            nx, ny, nz = _rotate(R, planes[g, 0], planes[g, 1], planes[g, 2])
            if -(nx * px + ny * py + nz * pz) < _AXIS_COSINE:
                continue
            d = planes[g, 3] + nx * t[0] + ny * t[1] + nz * t[2]
            v = support_vertex(A, neighbor_start[a0 : vertex_start[ha + 1] + 1], neighbors,
                               -nx, -ny, -nz, corners_a[0])  # fmt: skip
            s = nx * A[v, 0] + ny * A[v, 1] + nz * A[v, 2] - d
            if s > sep_b:
                sep_b, face_b = s, vertex_faces[k]
    sep_e, edge_a, edge_b = -np.inf, -1, -1
    ex = ey = ez = 0.0
    cax, cay, caz = centroids[ha, 0], centroids[ha, 1], centroids[ha, 2]
    for ca in corners_a:
        for ka in range(neighbor_start[a0 + ca], neighbor_start[a0 + ca + 1]):
            i = neighbor_edges[ka]
            fa, fb = fa0 + edge_faces[ea0 + i, 0], fa0 + edge_faces[ea0 + i, 1]
            arc_ax, arc_ay, arc_az = edge_arcs[ea0 + i, 0], edge_arcs[ea0 + i, 1], \
                edge_arcs[ea0 + i, 2]  # fmt: skip
            pa = A[edges[ea0 + i, 0]]
            qa = A[edges[ea0 + i, 1]]
            dax, day, daz = qa[0] - pa[0], qa[1] - pa[1], qa[2] - pa[2]
            for cb in corners_b:
                for kb in range(neighbor_start[b0 + cb], neighbor_start[b0 + cb + 1]):
                    j = neighbor_edges[kb]
                    pb = vertices[b0 + edges[eb0 + j, 0]]
                    qb = vertices[b0 + edges[eb0 + j, 1]]
                    dbx, dby, dbz = _rotate(R, qb[0] - pb[0], qb[1] - pb[1], qb[2] - pb[2])
                    ux = day * dbz - daz * dby
                    uy = daz * dbx - dax * dbz
                    uz = dax * dby - day * dbx
                    along = ux * px + uy * py + uz * pz
                    length2 = ux * ux + uy * uy + uz * uz
                    if along * along < _AXIS_COSINE**2 * length2 or length2 == 0.0:
                        continue
                    fc, fd = fb0 + edge_faces[eb0 + j, 0], fb0 + edge_faces[eb0 + j, 1]
                    cx, cy, cz = _rotate(R, planes[fc, 0], planes[fc, 1], planes[fc, 2])
                    dx, dy, dz = _rotate(R, planes[fd, 0], planes[fd, 1], planes[fd, 2])
                    s1 = cx * arc_ax + cy * arc_ay + cz * arc_az
                    s2 = dx * arc_ax + dy * arc_ay + dz * arc_az
                    if s1 * s2 >= 0.0:
                        continue
                    bx, by, bz = _rotate(R, edge_arcs[eb0 + j, 0], edge_arcs[eb0 + j, 1],
                                         edge_arcs[eb0 + j, 2])  # fmt: skip
                    s3 = planes[fa, 0] * bx + planes[fa, 1] * by + planes[fa, 2] * bz
                    s4 = planes[fb, 0] * bx + planes[fb, 1] * by + planes[fb, 2] * bz
                    if s3 * s4 >= 0.0 or s1 * s4 >= 0.0:
                        continue
                    pbx, pby, pbz = _rotate(R, pb[0], pb[1], pb[2])
                    pbx, pby, pbz = pbx + t[0], pby + t[1], pbz + t[2]
                    length = math.sqrt(length2)
                    ux, uy, uz = ux / length, uy / length, uz / length
                    if ux * (pa[0] - cax) + uy * (pa[1] - cay) + uz * (pa[2] - caz) < 0.0:
                        ux, uy, uz = -ux, -uy, -uz
                    s = ux * (pbx - pa[0]) + uy * (pby - pa[1]) + uz * (pbz - pa[2])
                    if s > sep_e:
                        sep_e, edge_a, edge_b, ex, ey, ez = s, i, j, ux, uy, uz
    if sep_b > sep_a + tie:
        f = fb0 + face_b
        fx, fy, fz = _rotate(R, -planes[f, 0], -planes[f, 1], -planes[f, 2])
        kind, index, face_sep = FACE_B, face_b, sep_b
    else:
        f = fa0 + face_a
        fx, fy, fz = planes[f, 0], planes[f, 1], planes[f, 2]
        kind, index, face_sep = FACE_A, face_a, sep_a
    if sep_e > face_sep + tie:
        return EDGES, edge_a, edge_b, sep_e, ex, ey, ez
    return kind, index, 0, face_sep, fx, fy, fz


@njit
def _distinct(a, b, c):
    """The distinct values among a, b, c, as an array."""
    if a == b:
        return np.array([a, c]) if c != a else np.array([a])
    if c == a or c == b:
        return np.array([a, b])
    return np.array([a, b, c])


@njit
def _sat_fallback(H, ha, hb, R, t, tie, margin):
    """The separating-axis test on a pair GJK or EPA could not settle (touching, flat)."""
    (vertex_start, vertices, _, _, _, _, _, face_start, planes, _, _, edge_start, edges,
     edge_faces, edge_arcs, centroids, _, _, _, _) = H  # fmt: skip
    va0, va1 = vertex_start[ha], vertex_start[ha + 1]
    vb0, vb1 = vertex_start[hb], vertex_start[hb + 1]
    fa0, fa1 = face_start[ha], face_start[ha + 1]
    fb0, fb1 = face_start[hb], face_start[hb + 1]
    ea0, ea1 = edge_start[ha], edge_start[ha + 1]
    eb0, eb1 = edge_start[hb], edge_start[hb + 1]
    placed_vertices = np.empty((vb1 - vb0, 3))
    placed_planes = np.empty((fb1 - fb0, 4))
    placed_arcs = np.empty((eb1 - eb0, 3))
    place_hull(vertices[vb0:vb1], planes[fb0:fb1], edge_arcs[eb0:eb1], R, t,
               placed_vertices, placed_planes, placed_arcs)  # fmt: skip
    return sat_query(
        vertices[va0:va1], planes[fa0:fa1], edges[ea0:ea1], edge_faces[ea0:ea1],
        edge_arcs[ea0:ea1], centroids[ha],
        placed_vertices, placed_planes, edges[eb0:eb1], edge_faces[eb0:eb1], placed_arcs,
        0, 0, 0, tie, margin, np.empty((fa1 - fa0, eb1 - eb0)),
        np.empty((ea1 - ea0, fb1 - fb0)),
    )  # fmt: skip


@njit(separate=True)
def gjk_epa_query(H, ha, hb, R, t, ax, ay, az, tie, margin, scratch):
    """Axis of least penetration or a separating axis of hulls A and B, by GJK and EPA.

    Parameters
    ----------
    H : tuple
        ``HullSet.arrays()``.
    ha, hb : int
        The hulls; (R, t) maps B's frame into A's.
    ax, ay, az : float
        A guess of the separating axis from A towards B (A's frame), e.g. last step's;
        zero for none.
    tie : float
        Separations closer than this count as equal (see ``sat_query``).
    margin : float
        Separations up to this are wanted exactly (see ``sat_query``): a pair that GJK does
        not separate by more goes to the separating-axis test.
    scratch : tuple
        ``epa_scratch()``.

    Returns
    -------
    kind, i, j, separation, ux, uy, uz
        As ``sat_query``; a separating direction found by GJK has kind ``CACHE_AXIS`` and a
        lower bound of the separation above ``margin``.
    """
    centroids, sizes = H.centroids, H.sizes
    va, vb, faces, planes = scratch[1], scratch[2], scratch[3], scratch[4]
    rows, P, ia, ib = scratch[7], scratch[8], scratch[9], scratch[10]
    if ax * ax + ay * ay + az * az > 0.0:
        vx, vy, vz = -ax, -ay, -az
    else:
        cx, cy, cz = _rotate(R, centroids[hb, 0], centroids[hb, 1], centroids[hb, 2])
        vx = centroids[ha, 0] - cx - t[0]
        vy = centroids[ha, 1] - cy - t[1]
        vz = centroids[ha, 2] - cz - t[2]
        if vx * vx + vy * vy + vz * vz == 0.0:
            vx = 1.0
    tolerance = _EPA_TOLERANCE * (sizes[ha] + sizes[hb])
    status, vx, vy, vz, bound = _gjk(
        H, ha, hb, R, t, vx, vy, vz, P, ia, ib, rows, tolerance, margin
    )
    if status == 1:
        length = math.sqrt(vx * vx + vy * vy + vz * vz)
        return CACHE_AXIS, 0, 0, bound / length, -vx / length, -vy / length, -vz / length
    if status == 0:
        ok, face = _epa(H, ha, hb, R, t, P, ia, ib, scratch, tolerance)
        if ok:
            corners_a = _distinct(va[faces[face, 0]], va[faces[face, 1]], va[faces[face, 2]])
            corners_b = _distinct(vb[faces[face, 0]], vb[faces[face, 1]], vb[faces[face, 2]])
            result = _exact_axis(H, ha, hb, R, t, corners_a, corners_b, tie,
                                 planes[face, 0], planes[face, 1], planes[face, 2])  # fmt: skip
            # EPA bounds the depth from both sides: the features must reach that depth
            if -result[3] <= planes[face, 3] + 2.0 * tolerance + tie:
                return result
    return _sat_fallback(H, ha, hb, R, t, tie, margin)
