"""Convex hull of a node's vertices and its triangle moments, for Gottschalk's OBB fit.

Thesis 4.5.1 fits a box to the covariance of the *convex hull's* triangles, which makes the
axes independent of how finely the surface is tessellated. This is an incremental 3D hull
(Clarkson-Shor style without conflict lists): start from an extreme tetrahedron, add each
point that lies outside the current hull, replace the faces it sees by a fan over the horizon.
The hull only steers the box *axes*; extents are measured on every corner afterwards, so a
sloppy hull (near-degenerate input, epsilon decisions) can cost tightness, never containment.
Flat or tiny point sets (fewer than 4 points, or no tetrahedron thicker than a relative
1e-9) have no volume hull: the caller then uses the node's own triangles.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["hull_faces", "hull_moments"]


@njit
def _face_plane(P, a, b, c):
    """Unit normal (3,) and offset of the plane through points a, b, c (rows of P)."""
    ux = P[b, 0] - P[a, 0]
    uy = P[b, 1] - P[a, 1]
    uz = P[b, 2] - P[a, 2]
    vx = P[c, 0] - P[a, 0]
    vy = P[c, 1] - P[a, 1]
    vz = P[c, 2] - P[a, 2]
    nx = uy * vz - uz * vy
    ny = uz * vx - ux * vz
    nz = ux * vy - uy * vx
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if length > 0.0:
        nx /= length
        ny /= length
        nz /= length
    return nx, ny, nz, nx * P[a, 0] + ny * P[a, 1] + nz * P[a, 2]


@njit
def hull_faces(P):
    """Triangles of the convex hull of points P (n, 3), by incremental construction from an
    extreme tetrahedron, the farthest points first.

    Returns
    -------
    faces : (f, 3) int64
        Point indices, counter-clockwise seen from outside; empty (0, 3) when the points span
        no volume (fewer than 4, or flat within a relative 1e-9).
    """
    n = P.shape[0]
    empty = np.zeros((0, 3), dtype=np.int64)
    i0, i1, i2, i3, eps = _extreme_tetrahedron(P)
    if i0 < 0:
        return empty
    cap = 8 * n + 16
    fv = np.empty((cap, 3), dtype=np.int64)
    fp = np.empty((cap, 4))
    alive = np.zeros(cap, dtype=np.bool_)
    count = 0
    # Orient the tetrahedron's faces outward (away from the opposite corner).
    tet = np.array([[i0, i1, i2, i3], [i0, i1, i3, i2], [i0, i2, i3, i1], [i1, i2, i3, i0]])
    for f in range(4):
        a, b, c, opp = tet[f, 0], tet[f, 1], tet[f, 2], tet[f, 3]
        nx, ny, nz, off = _face_plane(P, a, b, c)
        if nx * P[opp, 0] + ny * P[opp, 1] + nz * P[opp, 2] - off > 0.0:
            b, c = c, b
        _add_face(P, fv, fp, alive, count, a, b, c)
        count += 1

    n_alive = 4
    # Far points first: they are the likely hull vertices, so the hull grows to nearly its
    # final shape early and the many interior points are rejected against few faces.
    cx = 0.25 * (P[i0, 0] + P[i1, 0] + P[i2, 0] + P[i3, 0])
    cy = 0.25 * (P[i0, 1] + P[i1, 1] + P[i2, 1] + P[i3, 1])
    cz = 0.25 * (P[i0, 2] + P[i1, 2] + P[i2, 2] + P[i3, 2])
    far = np.empty(n)
    for k in range(n):
        far[k] = -((P[k, 0] - cx) ** 2 + (P[k, 1] - cy) ** 2 + (P[k, 2] - cz) ** 2)
    for k in np.argsort(far):
        if k == i0 or k == i1 or k == i2 or k == i3:
            continue
        # Room for the worst case (every live face visible, 3 horizon edges each) before any
        # face is touched.
        if count + 3 * n_alive > cap:
            fv, fp, alive, count, cap = _with_room(fv, fp, alive, count, n_alive)
        added, removed = _add_point(P, k, eps, fv, fp, alive, count, n_alive)
        count += added
        n_alive += added - removed
    out = np.empty((count, 3), dtype=np.int64)
    m = 0
    for f in range(count):
        if alive[f]:
            out[m] = fv[f]
            m += 1
    return out[:m].copy()


@njit
def _extreme_tetrahedron(P):
    """(i0, i1, i2, i3, eps): the min-x point, the farthest from it, the farthest from that
    line, the farthest from that plane, and the flatness tolerance (1e-9 of the first span);
    i0 = -1 when the points span no volume."""
    n = P.shape[0]
    if n < 4:
        return -1, -1, -1, -1, 0.0
    i0 = 0
    for k in range(n):
        if P[k, 0] < P[i0, 0]:
            i0 = k
    i1 = i0
    best = 0.0
    for k in range(n):
        d = (P[k, 0] - P[i0, 0]) ** 2 + (P[k, 1] - P[i0, 1]) ** 2 + (P[k, 2] - P[i0, 2]) ** 2
        if d > best:
            best = d
            i1 = k
    size = math.sqrt(best)
    if size == 0.0:
        return -1, -1, -1, -1, 0.0
    eps = 1e-9 * size
    ex = (P[i1, 0] - P[i0, 0]) / size
    ey = (P[i1, 1] - P[i0, 1]) / size
    ez = (P[i1, 2] - P[i0, 2]) / size
    i2 = i0
    best = 0.0
    for k in range(n):
        wx = P[k, 0] - P[i0, 0]
        wy = P[k, 1] - P[i0, 1]
        wz = P[k, 2] - P[i0, 2]
        cx = wy * ez - wz * ey
        cy = wz * ex - wx * ez
        cz = wx * ey - wy * ex
        d = cx * cx + cy * cy + cz * cz
        if d > best:
            best = d
            i2 = k
    if math.sqrt(best) <= eps:
        return -1, -1, -1, -1, 0.0
    nx, ny, nz, off = _face_plane(P, i0, i1, i2)
    i3 = i0
    best = 0.0
    for k in range(n):
        d = abs(nx * P[k, 0] + ny * P[k, 1] + nz * P[k, 2] - off)
        if d > best:
            best = d
            i3 = k
    if best <= eps:
        return -1, -1, -1, -1, 0.0
    return i0, i1, i2, i3, eps


@njit(allocates=False)
def _add_face(P, fv, fp, alive, row, a, b, c):
    """Face (a, b, c) and its plane into row ``row``, alive."""
    nx, ny, nz, off = _face_plane(P, a, b, c)
    fv[row, 0] = a
    fv[row, 1] = b
    fv[row, 2] = c
    fp[row, 0] = nx
    fp[row, 1] = ny
    fp[row, 2] = nz
    fp[row, 3] = off
    alive[row] = True


@njit
def _with_room(fv, fp, alive, count, n_alive):
    """The face arrays with the dead faces compacted away, grown if that leaves no room for
    every live face to give way to three new ones: (fv, fp, alive, count, capacity)."""
    keep = 0
    for f in range(count):
        if alive[f]:
            fv[keep] = fv[f]
            fp[keep] = fp[f]
            keep += 1
    alive[:] = False
    alive[:keep] = True
    count = keep
    cap = fv.shape[0]
    if count + 3 * n_alive > cap:
        cap = 2 * (count + 3 * n_alive)
        fv2 = np.empty((cap, 3), dtype=np.int64)
        fp2 = np.empty((cap, 4))
        alive2 = np.zeros(cap, dtype=np.bool_)
        fv2[:count] = fv[:count]
        fp2[:count] = fp[:count]
        alive2[:count] = True
        return fv2, fp2, alive2, count, cap
    return fv, fp, alive, count, cap


@njit
def _add_point(P, k, eps, fv, fp, alive, count, n_alive):
    """Add point k to the hull in the first ``count`` rows: the faces it sees (by more than
    ``eps``) die, and each edge of the horizon they leave makes a face with k from row
    ``count`` on. Returns (faces added, faces removed)."""
    visible = np.empty(n_alive, dtype=np.int64)
    nvis = 0
    for f in range(count):
        if alive[f]:
            s = fp[f, 0] * P[k, 0] + fp[f, 1] * P[k, 1] + fp[f, 2] * P[k, 2] - fp[f, 3]
            if s > eps:
                visible[nvis] = f
                nvis += 1
    if nvis == 0:
        return 0, 0
    edges = np.empty((3 * nvis, 2), dtype=np.int64)
    ne = 0
    for i in range(nvis):
        f = visible[i]
        alive[f] = False
        for j in range(3):
            edges[ne, 0] = fv[f, j]
            edges[ne, 1] = fv[f, (j + 1) % 3]
            ne += 1
    # Horizon: edges of visible faces whose reverse is not an edge of a visible face.
    added = 0
    for i in range(ne):
        a = edges[i, 0]
        b = edges[i, 1]
        shared = False
        for j in range(ne):
            if edges[j, 0] == b and edges[j, 1] == a:
                shared = True
                break
        if shared:
            continue
        _add_face(P, fv, fp, alive, count + added, a, b, k)
        added += 1
    return added, nvis


@njit
def hull_moments(P):
    """Area, area-weighted centroid sum and second-moment sum of the hull of P (n, 3).

    Returns (total_area, centroid_sum (3,), moment_sum (3, 3)) in the convention of
    :func:`thesis_rbd.collision.mesh.obb.triangle_moments`; total_area is 0 when P has no volume
    hull (see :func:`hull_faces`).
    """
    faces = hull_faces(P)
    total = 0.0
    cs = np.zeros(3)
    ms = np.zeros((3, 3))
    for f in range(faces.shape[0]):
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        ux = P[b, 0] - P[a, 0]
        uy = P[b, 1] - P[a, 1]
        uz = P[b, 2] - P[a, 2]
        vx = P[c, 0] - P[a, 0]
        vy = P[c, 1] - P[a, 1]
        vz = P[c, 2] - P[a, 2]
        nx = uy * vz - uz * vy
        ny = uz * vx - ux * vz
        nz = ux * vy - uy * vx
        area = 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)
        total += area
        for i in range(3):
            ci = (P[a, i] + P[b, i] + P[c, i]) / 3.0
            cs[i] += area * ci
            for j in range(3):
                cj = (P[a, j] + P[b, j] + P[c, j]) / 3.0
                ms[i, j] += (
                    area
                    / 12.0
                    * (9.0 * ci * cj + P[a, i] * P[a, j] + P[b, i] * P[b, j] + P[c, i] * P[c, j])
                )
    return total, cs, ms
