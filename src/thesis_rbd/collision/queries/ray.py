"""Ray casts against a triangle mesh through its OBBTree: :func:`ray_cast`.

Each ray is carried into the mesh frame once and walks the tree nearest box first: a box is
entered only if the slab test (the ray's parameter interval inside each pair of parallel faces,
intersected) meets it before the nearest hit found so far, and a triangle is tested by Möller
and Trumbore's method (barycentric coordinates and distance from one 3x3 determinant). All rays
are answered in one kernel call.

A ray hits a triangle's closed surface from either side; the hit is the first point along the
ray at distance in [0, max_distance]. A ray lying in a triangle's plane does not hit it, nor does
any ray hit a triangle of zero area (a set of zero measure).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision._vec3 import cross, dot, sub
from thesis_rbd.collision.mesh.packed import child, corner, layout, tree_depth
from thesis_rbd.collision.queries._query_args import (
    as_pose,
    call_normalised,
    pose_ok,
    raise_bad_pose,
    sealed,
    tree_array,
)

__all__ = ["RayHits", "ray_cast"]


class RayHits:
    """Outcome of :func:`ray_cast`, one row per ray.

    Attributes
    ----------
    hit : (r,) bool
    distance : (r,) float64
        Distance from the origin to the first hit along the ray (inf where none).
    points : (r, 3) float64
        World hit points (NaN where none).
    normals : (r, 3) float64
        World unit normals of the hit faces, oriented by the faces' winding (counter-clockwise
        seen from the side the normal points to; outward for a closed, consistently wound
        mesh); NaN where none.
    faces : (r,) int64
        Hit face (-1 where none).
    """

    __slots__ = ("distance", "faces", "hit", "normals", "points")

    def __init__(self, hit, distance, points, normals, faces):
        self.hit = hit
        self.distance = distance
        self.points = points
        self.normals = normals
        self.faces = faces

    def __repr__(self) -> str:
        return f"RayHits({int(self.hit.sum())} of {len(self.hit)} rays hit)"


@njit
def _slab(P, L, k, o, d, far):
    """Entry distance of the ray o + s d (mesh frame) into box k, or inf if it misses the box
    or enters it beyond ``far``."""
    c = L[0] + k
    h = L[1] + k
    r = L[2] + 3 * k
    w = (o[0] - P[c, 0], o[1] - P[c, 1], o[2] - P[c, 2])
    near = 0.0
    for j in range(3):
        # Box axis j is column j of the rotation block.
        oj = P[r, j] * w[0] + P[r + 1, j] * w[1] + P[r + 2, j] * w[2]
        dj = P[r, j] * d[0] + P[r + 1, j] * d[1] + P[r + 2, j] * d[2]
        hj = P[h, j]
        if dj == 0.0:
            if abs(oj) > hj:
                return math.inf
            continue
        s0 = (-hj - oj) / dj
        s1 = (hj - oj) / dj
        if s0 > s1:
            s0, s1 = s1, s0
        near = max(near, s0)
        far = min(far, s1)
        if near > far:
            return math.inf
    return near


@njit
def _ray_space(d):
    """The shear that takes the ray direction ``d`` (unit, mesh frame) to +z: the axis of
    its largest component ``kz``, the two others ``kx``, ``ky`` (swapped where d[kz] < 0, so
    that triangles keep their winding), and the shear ``(Sx, Sy, Sz)``."""
    kz = 0
    if abs(d[1]) > abs(d[kz]):
        kz = 1
    if abs(d[2]) > abs(d[kz]):
        kz = 2
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    if d[kz] < 0.0:
        kx, ky = ky, kx
    return kx, ky, kz, d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]


@njit
def _sheared(v, o, shear):
    """Corner ``v`` in ray space: relative to the origin ``o``, sheared along the ray."""
    kx, ky, kz, sx, sy, _ = shear
    a = (v[0] - o[0], v[1] - o[1], v[2] - o[2])
    return a[kx] - sx * a[kz], a[ky] - sy * a[kz], a[kz]


@njit
def _triangle_hit(P, L, t, o, shear):
    """Distance along the ray from ``o`` (mesh frame; its direction unit, given by its ray
    space ``shear``) to triangle t, or inf.

    Watertight (Woop, Benthin and Wald's test): each corner is taken to ray space on its own
    and each edge's function is computed from its two corners alone, so two triangles that
    share an edge compute exactly opposite values for it and a ray through the edge, or
    through a shared corner, cannot slip between them."""
    ax, ay, az = _sheared(corner(P, L, t, 0), o, shear)
    bx, by, bz = _sheared(corner(P, L, t, 1), o, shear)
    cx, cy, cz = _sheared(corner(P, L, t, 2), o, shear)
    u = cx * by - cy * bx
    v = ax * cy - ay * cx
    w = bx * ay - by * ax
    if (u < 0.0 or v < 0.0 or w < 0.0) and (u > 0.0 or v > 0.0 or w > 0.0):
        return math.inf
    det = u + v + w
    # a ray in the triangle's plane, or a triangle of zero area
    if det == 0.0:
        return math.inf
    sz = shear[5]
    s = (u * az + v * bz + w * cz) * sz / det
    return s if s >= 0.0 else math.inf


@njit
def _first_hit(P, L, o, d, max_distance, stack):
    """(distance, face) of the ray's first hit within ``max_distance`` (inf, -1 if none)."""
    shear = _ray_space(d)
    best = max_distance
    face = -1
    root = L[6]
    if root < 0:
        s = _triangle_hit(P, L, -root - 1, o, shear)
        if s < math.inf and s <= best:
            return s, -root - 1
        return math.inf, -1
    if _slab(P, L, root, o, d, best) == math.inf:
        return math.inf, -1
    stack[0, 0] = root
    stack[0, 1] = 0.0
    top = 1
    while top > 0:
        top -= 1
        if stack[top, 1] > best:
            continue
        x = int(stack[top, 0])
        c0 = child(P, L, x, 0)
        c1 = child(P, L, x, 1)
        if c0 == c1:
            # A classic tree's leaf: its one triangle.
            s = _triangle_hit(P, L, -c0 - 1, o, shear)
            if s < math.inf and s <= best:
                best = s
                face = -c0 - 1
            continue
        s0 = math.inf
        s1 = math.inf
        for side in range(2):
            code = c0 if side == 0 else c1
            if code < 0:
                s = _triangle_hit(P, L, -code - 1, o, shear)
                if s < math.inf and s <= best:
                    best = s
                    face = -code - 1
            elif side == 0:
                s0 = _slab(P, L, code, o, d, best)
            else:
                s1 = _slab(P, L, code, o, d, best)
        # Push the farther box first, so the nearer one is walked first (a triangle child or
        # a missed box has entry inf and is not pushed).
        if s0 > s1:
            c0, c1 = c1, c0
            s0, s1 = s1, s0
        if s1 < math.inf and s1 <= best:
            stack[top, 0] = c1
            stack[top, 1] = s1
            top += 1
        if s0 < math.inf and s0 <= best:
            stack[top, 0] = c0
            stack[top, 1] = s0
            top += 1
    if face < 0:
        return math.inf, -1
    return best, face


@sealed
@njit
def _ray_kernel(P, T, origins, directions, max_distance):
    """All rays: (status, hit, distance, points, normals, faces).

    status 0; 1 if T is not rigid; 2 + i if ray i's direction has zero length or a ray has a
    non-finite component (then nothing is computed).
    """
    n = origins.shape[0]
    hit = np.zeros(n, dtype=np.bool_)
    distance = np.full(n, math.inf)
    points = np.full((n, 3), math.nan)
    normals = np.full((n, 3), math.nan)
    faces = np.full(n, -1, dtype=np.int64)
    if not pose_ok(T):
        return 1, hit, distance, points, normals, faces
    for i in range(n):
        largest = 0.0
        for j in range(3):
            if not (np.isfinite(origins[i, j]) and np.isfinite(directions[i, j])):
                return 2 + i, hit, distance, points, normals, faces
            largest = max(largest, abs(directions[i, j]))
        if largest == 0.0:
            return 2 + i, hit, distance, points, normals, faces
    L = layout(P)
    stack = np.empty((2 * tree_depth(P) + 4, 2))
    for i in range(n):
        # scaled by the largest component first: |d|^2 of 1e160 overflows, of 1e-200 is 0
        largest = max(abs(directions[i, 0]), abs(directions[i, 1]), abs(directions[i, 2]))
        scaled = (
            directions[i, 0] / largest,
            directions[i, 1] / largest,
            directions[i, 2] / largest,
        )
        # The ray in the mesh frame: o = R^T (origin - p), d = R^T direction / |direction|.
        w = (origins[i, 0] - T[0, 3], origins[i, 1] - T[1, 3], origins[i, 2] - T[2, 3])
        o = (
            T[0, 0] * w[0] + T[1, 0] * w[1] + T[2, 0] * w[2],
            T[0, 1] * w[0] + T[1, 1] * w[1] + T[2, 1] * w[2],
            T[0, 2] * w[0] + T[1, 2] * w[1] + T[2, 2] * w[2],
        )
        norm = math.sqrt(dot(scaled, scaled))
        u = (scaled[0] / norm, scaled[1] / norm, scaled[2] / norm)
        d = (
            T[0, 0] * u[0] + T[1, 0] * u[1] + T[2, 0] * u[2],
            T[0, 1] * u[0] + T[1, 1] * u[1] + T[2, 1] * u[2],
            T[0, 2] * u[0] + T[1, 2] * u[1] + T[2, 2] * u[2],
        )
        s, f = _first_hit(P, L, o, d, max_distance, stack)
        if f < 0:
            continue
        hit[i] = True
        distance[i] = s
        faces[i] = f
        v0 = corner(P, L, f, 0)
        normal = cross(sub(corner(P, L, f, 1), v0), sub(corner(P, L, f, 2), v0))
        scale = 1.0 / math.sqrt(dot(normal, normal))
        for j in range(3):
            points[i, j] = origins[i, j] + s * u[j]
            normals[i, j] = scale * (
                T[j, 0] * normal[0] + T[j, 1] * normal[1] + T[j, 2] * normal[2]
            )
    return 0, hit, distance, points, normals, faces


def _rays(value, name: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=np.float64, order="C", ndmin=2)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(value).__name__}: {exc}") from exc
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (r, 3) or (3,), got {np.shape(value)}")
    return array


def ray_cast(tree, T, origins, directions, max_distance=np.inf) -> RayHits:
    """First hit of each ray against a mesh.

    Parameters
    ----------
    tree : OBBTree
        The mesh's tree.
    T : (4, 4) array_like of float
        Rigid transform from the mesh frame to the world.
    origins, directions : (r, 3) array_like of float
        World origins and directions of the rays (any non-zero length; distances are
        measured along the unit direction). Either may be a single (3,) row used for every
        ray.
    max_distance : float
        Hits farther than this are ignored (default: no limit).

    Returns
    -------
    RayHits
        ``hit``, ``distance``, ``points``, ``normals`` and ``faces``, one row per ray.

    Raises
    ------
    ValueError
        On a tree that is not an OBBTree, a pose that is not a finite rigid transform, rays
        that are not (r, 3) finite numbers (or a (3,) row), a zero-length direction, or a
        max_distance that is negative or NaN.
    """
    P = tree_array(tree, "tree")
    T = as_pose(T, "T")
    origins = _rays(origins, "origins")
    directions = _rays(directions, "directions")
    if len(origins) != len(directions):
        if len(origins) == 1:
            origins = np.ascontiguousarray(np.broadcast_to(origins, directions.shape))
        elif len(directions) == 1:
            directions = np.ascontiguousarray(np.broadcast_to(directions, origins.shape))
        else:
            raise ValueError(
                f"origins and directions must have the same number of rows (or one), got "
                f"{len(origins)} and {len(directions)}"
            )
    try:
        limit = float(max_distance)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"max_distance must be a number, got {max_distance!r}") from exc
    if not limit >= 0.0:
        raise ValueError(f"max_distance must be >= 0 (inf for no limit), got {max_distance!r}")
    status, hit, distance, points, normals, faces = call_normalised(
        _ray_kernel, P, T, origins, directions, limit
    )
    if status == 1:
        raise_bad_pose(T, "T")
    if status >= 2:
        i = status - 2
        for name, rows in (("origins", origins), ("directions", directions)):
            if not np.all(np.isfinite(rows[i])):
                raise ValueError(f"{name} row {i} holds a non-finite value: {rows[i].tolist()}")
        raise ValueError(f"directions row {i} has zero length")
    return RayHits(hit, distance, points, normals, faces)
