"""One flat float64 array per OBBTree: everything a query kernel reads, in one argument.

Numba spends about 50 ns unboxing each array argument of a call, and slicing arrays inside a
kernel costs reference counting, so a query that passed a tree as eight arrays and scalars paid
over a microsecond before doing any work. Here a tree is a single (rows, 3) float64 array of
row blocks, and kernels index it at row offsets (:func:`layout`)::

    row 0         n nodes, n vertices, n faces
    row 1         root code, leafless (0/1), depth
    row 2         scale, radius, 1 if the support and hull blocks follow the faces
    centers       n rows
    half_extents  n rows
    rotations     3 n rows: rows 3 k : 3 k + 3 are node k's matrix, box axes as columns
    children      n rows: the two child codes (k >= 0 node, k < 0 triangle -k - 1), 0
    vertices      nv rows
    faces         nf rows: vertex indices
    supports      (this block and the next added by :func:`with_hull` when a distance
                  query first needs them) SUPPORT_ROWS rows per node: its supports along a
                  grid of directions (:mod:`.packed_support`)
    hull          the mesh's convex hull (:mod:`.packed_hull`), its flat values in rows of
                  three

Counts, codes and indices are integers stored as float64, exact below 2**53; kernels convert
them with ``int()`` (one instruction). The scale is the mesh's bounding-box diagonal (relative
tolerances); the radius is the largest distance of a vertex from the mesh-frame origin, which
bounds how fast any point of the mesh moves when the mesh rotates about that origin
(continuous collision).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.packed_hull import hull_block
from thesis_rbd.collision.mesh.packed_support import SUPPORT_ROWS, support_block

__all__ = [
    "HEADER_ROWS",
    "box_frame",
    "carry_box",
    "child",
    "corner",
    "corner_moved",
    "half_extent",
    "hull_row",
    "layout",
    "mesh_vertices",
    "node_size",
    "pack_tree",
    "packed_views",
    "pair_corners",
    "support_values",
    "tree_depth",
    "tree_radius",
    "tree_scale",
    "with_hull",
]

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


def with_hull(packed):
    """The packed tree with the support and hull blocks of its mesh appended (flagged in its
    header), or the array itself if it has them."""
    if packed[2, 2] != 0.0:
        return packed
    n, nv, nf = (int(x) for x in packed[0])
    v = HEADER_ROWS + 6 * n
    vertices = packed[v : v + nv]
    faces = packed[v + nv : v + nv + nf].astype(np.int64)
    centers, _, _ = packed_views(packed)
    children = packed[HEADER_ROWS + 5 * n : HEADER_ROWS + 6 * n, :2].astype(np.int64)
    supports = support_block(centers, children, int(packed[1, 0]), vertices, faces)
    hull = hull_block(vertices, faces)
    hull = np.concatenate([hull, np.zeros(-len(hull) % 3)]).reshape(-1, 3)
    extended = np.concatenate([packed[: v + nv + nf], supports, hull])
    extended[2, 2] = 1.0
    return extended


def packed_views(packed):
    """(centers, rotations, half_extents) of a packed tree, as NumPy views."""
    n = int(packed[0, 0])
    c = HEADER_ROWS
    return (
        packed[c : c + n],
        packed[c + 2 * n : c + 5 * n].reshape(n, 3, 3),
        packed[c + n : c + 2 * n],
    )


@njit(allocates=False)
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


@njit(allocates=False)
def tree_depth(P):
    """Number of levels of a packed tree (sizes traversal stacks)."""
    return int(P[1, 2])


@njit(allocates=False)
def tree_scale(P):
    """The mesh's size (bounding-box diagonal) of a packed tree."""
    return P[2, 0]


@njit(allocates=False)
def tree_radius(P):
    """Largest distance of a vertex from the mesh-frame origin, of a packed tree."""
    return P[2, 1]


@njit(allocates=False)
def hull_row(P, L):
    """First row of the hull block of a packed tree (:mod:`.packed_hull`), or -1 if it has
    none."""
    if P[2, 2] == 0.0:
        return -1
    return L[5] + int(P[0, 2]) + SUPPORT_ROWS * int(P[0, 0])


@njit
def support_values(P, L):
    """A packed tree read as float32 values, and the index there of its support block
    (:mod:`.packed_support`), or -1 if it has none."""
    S = P.reshape(P.size).view(np.float32)
    if P[2, 2] == 0.0:
        return S, -1
    return S, 6 * (L[5] + int(P[0, 2]))


@njit
def mesh_vertices(P):
    """The (nv, 3) vertex block of a packed tree (a slice)."""
    v = HEADER_ROWS + 6 * int(P[0, 0])
    return P[v : v + int(P[0, 1])]


# Accessors of a packed tree (P, L = layout(P)), all in its mesh frame.


@njit(allocates=False)
def node_size(P, L, k):
    """Longest half-extent of box k of tree (P, L)."""
    h = L[1] + k
    return max(P[h, 0], P[h, 1], P[h, 2])


@njit(allocates=False)
def half_extent(P, L, k):
    """Half-extents of box k of tree (P, L) as a tuple."""
    h = L[1] + k
    return (P[h, 0], P[h, 1], P[h, 2])


@njit(allocates=False)
def carry_box(y, P, L, M, tab):
    """Box y of tree (P, L) carried by ``x -> M x + tab``: axes ``G = M R[y]`` (row-major
    9-tuple) and centre."""
    r = L[2] + 3 * y
    g = (
        M[0] * P[r, 0] + M[1] * P[r + 1, 0] + M[2] * P[r + 2, 0],
        M[0] * P[r, 1] + M[1] * P[r + 1, 1] + M[2] * P[r + 2, 1],
        M[0] * P[r, 2] + M[1] * P[r + 1, 2] + M[2] * P[r + 2, 2],
        M[3] * P[r, 0] + M[4] * P[r + 1, 0] + M[5] * P[r + 2, 0],
        M[3] * P[r, 1] + M[4] * P[r + 1, 1] + M[5] * P[r + 2, 1],
        M[3] * P[r, 2] + M[4] * P[r + 1, 2] + M[5] * P[r + 2, 2],
        M[6] * P[r, 0] + M[7] * P[r + 1, 0] + M[8] * P[r + 2, 0],
        M[6] * P[r, 1] + M[7] * P[r + 1, 1] + M[8] * P[r + 2, 1],
        M[6] * P[r, 2] + M[7] * P[r + 1, 2] + M[8] * P[r + 2, 2],
    )
    k = L[0] + y
    c = (
        M[0] * P[k, 0] + M[1] * P[k, 1] + M[2] * P[k, 2] + tab[0],
        M[3] * P[k, 0] + M[4] * P[k, 1] + M[5] * P[k, 2] + tab[1],
        M[6] * P[k, 0] + M[7] * P[k, 1] + M[8] * P[k, 2] + tab[2],
    )
    return g, c


@njit(allocates=False)
def box_frame(x, P, L, g, c):
    """A box (axes ``g``, a row-major 9-tuple, and centre ``c``, in the mesh frame of tree
    (P, L)) seen from that tree's box x: (rotation ``R_x^T g`` as a 9-tuple, centre offset
    ``R_x^T (c - c_x)``), the form the separating-axis tests take."""
    k = L[0] + x
    d0 = c[0] - P[k, 0]
    d1 = c[1] - P[k, 1]
    d2 = c[2] - P[k, 2]
    r = L[2] + 3 * x
    a00 = P[r, 0]
    a01 = P[r, 1]
    a02 = P[r, 2]
    a10 = P[r + 1, 0]
    a11 = P[r + 1, 1]
    a12 = P[r + 1, 2]
    a20 = P[r + 2, 0]
    a21 = P[r + 2, 1]
    a22 = P[r + 2, 2]
    R = (
        a00 * g[0] + a10 * g[3] + a20 * g[6],
        a00 * g[1] + a10 * g[4] + a20 * g[7],
        a00 * g[2] + a10 * g[5] + a20 * g[8],
        a01 * g[0] + a11 * g[3] + a21 * g[6],
        a01 * g[1] + a11 * g[4] + a21 * g[7],
        a01 * g[2] + a11 * g[5] + a21 * g[8],
        a02 * g[0] + a12 * g[3] + a22 * g[6],
        a02 * g[1] + a12 * g[4] + a22 * g[7],
        a02 * g[2] + a12 * g[5] + a22 * g[8],
    )
    T = (
        a00 * d0 + a10 * d1 + a20 * d2,
        a01 * d0 + a11 * d1 + a21 * d2,
        a02 * d0 + a12 * d1 + a22 * d2,
    )
    return R, T


@njit(allocates=False)
def corner(P, L, t, k):
    """Corner k of triangle t of tree (P, L), in its mesh frame."""
    i = L[4] + int(P[L[5] + t, k])
    return (P[i, 0], P[i, 1], P[i, 2])


@njit(allocates=False)
def corner_moved(P, L, t, k, M, tr):
    """Corner k of triangle t of tree (P, L), mapped by ``x -> M x + tr`` (M row-major)."""
    i = L[4] + int(P[L[5] + t, k])
    x = P[i, 0]
    y = P[i, 1]
    z = P[i, 2]
    return (
        M[0] * x + M[1] * y + M[2] * z + tr[0],
        M[3] * x + M[4] * y + M[5] * z + tr[1],
        M[6] * x + M[7] * y + M[8] * z + tr[2],
    )


@njit(allocates=False)
def pair_corners(ta, tb, Pa, La, Pb, Lb, Mab, tab):
    """Corners of triangle ta of tree (Pa, La), in its mesh frame, and of triangle tb of tree
    (Pb, Lb), carried into that frame by ``x -> Mab x + tab``: six 3-tuples."""
    return (
        corner(Pa, La, ta, 0),
        corner(Pa, La, ta, 1),
        corner(Pa, La, ta, 2),
        corner_moved(Pb, Lb, tb, 0, Mab, tab),
        corner_moved(Pb, Lb, tb, 1, Mab, tab),
        corner_moved(Pb, Lb, tb, 2, Mab, tab),
    )


@njit(allocates=False)
def child(P, L, x, side):
    """Child code ``side`` (0 or 1) of node x of tree (P, L)."""
    return int(P[L[3] + x, side])
