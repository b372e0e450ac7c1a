"""One flat float64 array per OBBTree: everything a query kernel reads, in one argument.

Numba spends about 50 ns unboxing each array argument of a call, and slicing arrays inside a
kernel costs reference counting, so a query that passed a tree as eight arrays and scalars paid
over a microsecond before doing any work. Here a tree is a single (rows, 3) float64 array of
row blocks, and kernels index it at row offsets (:func:`layout`)::

    row 0         n nodes, n vertices, n faces
    row 1         root code, leafless (0/1), depth
    row 2         scale, radius, 0
    centers       n rows
    half_extents  n rows
    rotations     3 n rows: rows 3 k : 3 k + 3 are node k's matrix, box axes as columns
    children      n rows: the two child codes (k >= 0 node, k < 0 triangle -k - 1), 0
    vertices      nv rows
    faces         nf rows: vertex indices

Counts, codes and indices are integers stored as float64, exact below 2**53; kernels convert
them with ``int()`` (one instruction). The scale is the mesh's bounding-box diagonal (relative
tolerances); the radius is the largest distance of a vertex from the mesh-frame origin, which
bounds how fast any point of the mesh moves when the mesh rotates about that origin
(continuous collision).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit

__all__ = ["HEADER_ROWS", "layout", "pack_tree", "packed_views", "tree_radius", "tree_scale"]

HEADER_ROWS = 3


def pack_tree(centers, rotations, half_extents, children, root, leafless, depth, vertices, faces):
    """The query array of one tree.

    Parameters
    ----------
    centers, rotations, half_extents : (n, 3), (n, 3, 3), (n, 3) float
        Node boxes in the mesh frame (any float dtype; stored as float64).
    children : (n, 2) int
        Child codes (``k >= 0`` node, ``k < 0`` triangle ``-k - 1``).
    root, leafless, depth : int, bool, int
        The tree's root code, variant and number of levels.
    vertices : (nv, 3) float64, faces : (nf, 3) int64
        The mesh, in its frame.

    Returns
    -------
    (3 + 6 n + nv + nf, 3) float64
    """
    n = len(centers)
    vertices = np.asarray(vertices, dtype=np.float64)
    scale = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    radius = float(np.sqrt((vertices * vertices).sum(axis=1).max()))
    codes = np.zeros((n, 3))
    codes[:, :2] = children
    packed = np.concatenate(
        [
            [[n, len(vertices), len(faces)], [root, int(leafless), depth], [scale, radius, 0.0]],
            np.asarray(centers, dtype=np.float64).reshape(n, 3),
            np.asarray(half_extents, dtype=np.float64).reshape(n, 3),
            np.asarray(rotations, dtype=np.float64).reshape(3 * n, 3),
            codes,
            vertices,
            np.asarray(faces, dtype=np.float64),
        ]
    )
    return np.ascontiguousarray(packed, dtype=np.float64)


def packed_views(packed):
    """(centers, rotations, half_extents) of a packed tree, as NumPy views."""
    n = int(packed[0, 0])
    c = HEADER_ROWS
    return (
        packed[c : c + n],
        packed[c + 2 * n : c + 5 * n].reshape(n, 3, 3),
        packed[c + n : c + 2 * n],
    )


@njit
def layout(P):
    """Row offsets of a packed tree's blocks and its root code.

    Returns
    -------
    (centers, half_extents, rotations, children, vertices, faces, root, leafless) :
        int row offsets of each block, the root code (int) and the variant (bool).
    """
    n = int(P[0, 0])
    c = HEADER_ROWS
    v = c + 6 * n
    return c, c + n, c + 2 * n, c + 5 * n, v, v + int(P[0, 1]), int(P[1, 0]), P[1, 1] != 0.0


@njit
def tree_depth(P):
    """Number of levels of a packed tree (sizes traversal stacks)."""
    return int(P[1, 2])


@njit
def tree_scale(P):
    """The mesh's size (bounding-box diagonal) of a packed tree."""
    return P[2, 0]


@njit
def tree_radius(P):
    """Largest distance of a vertex from the mesh-frame origin, of a packed tree."""
    return P[2, 1]


@njit
def mesh_vertices(P):
    """The (nv, 3) vertex block of a packed tree (a slice)."""
    v = HEADER_ROWS + 6 * int(P[0, 0])
    return P[v : v + int(P[0, 1])]
