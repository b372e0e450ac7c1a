"""The convex hull of a tree's mesh, packed after the tree for the distance query.

Two meshes are never closer than their convex hulls, and where the hulls' closest points lie
on the meshes' own triangles the two distances are equal: then a GJK walk over the hulls (a
few microseconds) answers a distance query that a tree descent answers in hundreds
(:mod:`..queries.hull_distance`). What that walk needs per mesh is stored here, as one flat
run of float64 values appended to the packed tree (:mod:`.packed`; its header's ``P[2, 2]``
is 1 when the block is there), so a query kernel reads it without another argument::

    h, m, k                      hull vertices, neighbour entries, vertex-face entries
    extremes                     6: the hull vertices farthest along -x, +x, -y, +y, -z, +z,
                                 where a support search starts
    coordinates                  3 h: the hull vertices, mesh frame
    neighbour_start, neighbours  h + 1 and m: the hull's vertex graph (local indices), which
                                 a support search climbs
    face_start, faces            h + 1 and k: the mesh faces around each hull vertex

Integers are stored as float64 (exact below 2**53). A mesh whose vertices span no volume
(flat, a segment, fewer than four points) has no hull: its block is the single value 0.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from thesis_rbd._numba.jit import njit

__all__ = ["HULL_FIELDS", "hull_block", "hull_fields"]

# Values before the coordinates: h, m, k and the six extreme vertices
HULL_FIELDS = 9


def hull_block(vertices, faces) -> np.ndarray:
    """The flat hull block of a mesh (see the module docstring).

    Parameters
    ----------
    vertices : (nv, 3) float64
    faces : (nf, 3) int
        The mesh, in its frame.

    Returns
    -------
    (r,) float64
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if len(vertices) < 4:
        return np.zeros(1)
    try:
        # Qhull; "QbB" scales the points into a unit box first, so its precision checks do
        # not depend on where the mesh lies
        hull = ConvexHull(vertices, qhull_options="QbB")
    except QhullError:
        return np.zeros(1)
    ids = np.asarray(hull.vertices, dtype=np.int64)
    h = len(ids)
    local = np.full(len(vertices), -1, dtype=np.int64)
    local[ids] = np.arange(h)
    # the vertex graph from the triangulated facets' edges, both ways, without repeats
    # (as keys a h + b, which sort by a then b)
    simplices = local[np.asarray(hull.simplices, dtype=np.int64)]
    a = simplices.reshape(-1)
    b = simplices[:, [1, 2, 0]].reshape(-1)
    keys = np.unique(np.concatenate([a * h + b, b * h + a]))
    neighbour_start = np.searchsorted(keys // h, np.arange(h + 1))
    points = vertices[ids]
    extremes = np.stack([points.argmin(axis=0), points.argmax(axis=0)], axis=1).reshape(-1)
    # the mesh faces around each hull vertex
    corner_local = local[faces.reshape(-1)]
    on_hull = np.flatnonzero(corner_local >= 0)
    order = np.argsort(corner_local[on_hull], kind="stable")
    around = on_hull[order] // 3
    face_start = np.searchsorted(corner_local[on_hull][order], np.arange(h + 1))
    return np.concatenate(
        [
            [h, len(keys), len(around)],
            extremes,
            vertices[ids].reshape(-1),
            neighbour_start,
            keys % h,
            face_start,
            around,
        ]
    ).astype(np.float64)


@njit(allocates=False)
def hull_fields(F, base):
    """Offsets into the flat values ``F`` of the hull block starting at ``F[base]``.

    Returns
    -------
    (h, coordinates, neighbour_start, neighbours, face_start, faces) :
        the hull's vertex count (0: no hull) and the offset of each field.
    """
    h = int(F[base])
    m = int(F[base + 1])
    coordinates = base + HULL_FIELDS
    neighbour_start = coordinates + 3 * h
    neighbours = neighbour_start + h + 1
    face_start = neighbours + m
    faces = face_start + h + 1
    return h, coordinates, neighbour_start, neighbours, face_start, faces
