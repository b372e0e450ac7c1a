"""Support values of every tree node along a fixed grid of directions, for distance bounds.

A distance descent prunes a pair of nodes when a lower bound on the distance of their
triangles reaches the best distance found. Projected on the unit line ``u`` from one node's
centre to the other's, the two contents are at least ``|c_B - c_A| - h_A(u) - h_B(-u)``
apart, where ``h(u) = max u . (v - c)`` over the node's vertices is its support function.
With exact supports, that bound on the centre line is nearly the true distance of two
curved patches; a box's support overshoots it by the box's empty corners, which is what
leaves thousands of node pairs open around the closest pair of two curved meshes.

Exact supports would need every vertex of a node; this block stores each node's support at
the grid points ``p`` of a cube's surface (each face cut into ``GRID x GRID`` squares), so a
node costs ``DIRECTIONS`` values. Any direction ``u`` meets the cube at a point inside one
grid triangle, a non-negative combination of that triangle's three corners, and a support
function is sublinear (``h(a + b) <= h(a) + h(b)``, ``h(s a) = s h(a)`` for ``s >= 0``),
so the same combination of the three stored values bounds ``h(u)`` from above
(:func:`support_along`). The bound is exact wherever the three corners share a support
vertex and overshoots by about the node's size times the squared angular width of a grid
cell elsewhere: far tighter than a box near its corners.

Values are taken about the node's own box centre, so they are of the node's size wherever
the mesh lies (a mesh far from its frame's origin loses no precision), and they are built
bottom up, a parent's from its children's (the support of a union is the larger support).
The values are stored as float32, each rounded up (a bound that is a little high is still a
bound; the rounding is a few parts in 1e8 of a node's size), which halves the block. It
follows the faces in the packed tree (:mod:`.packed`): read as float32, node k's values
start at index ``6 * row + SUPPORT_STRIDE * k`` (:func:`.packed.support_values`).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "DIRECTIONS",
    "GRID",
    "SUPPORT_ROWS",
    "SUPPORT_STRIDE",
    "grid_points",
    "support_along",
    "support_at",
    "support_block",
    "support_weights",
]

# Squares per cube-face side; the measured choice is in reports/ (the query-cost study).
GRID = 4
# Distinct grid points over the cube's surface: 6 GRID^2 + 2.
DIRECTIONS = 6 * GRID * GRID + 2
# float32 values per node (whole packed rows: six float32 to a row of three float64), and
# packed rows per node
SUPPORT_STRIDE = 6 * ((DIRECTIONS + 5) // 6)
SUPPORT_ROWS = SUPPORT_STRIDE // 6


def _grid() -> tuple[np.ndarray, np.ndarray]:
    """(DIRECTIONS, 3) grid points and the (6, GRID + 1, GRID + 1) index of each face's.

    Face ``f`` lies on axis ``f // 2`` at sign ``+`` for even ``f``; its grid runs over the
    two following axes (x: y, z; y: z, x; z: x, y) from -1 to 1.
    """
    ticks = np.linspace(-1.0, 1.0, GRID + 1)
    index = np.empty((6, GRID + 1, GRID + 1), dtype=np.int64)
    seen: dict[tuple[float, float, float], int] = {}
    points = []
    for f in range(6):
        axis, sign = f // 2, 1.0 if f % 2 == 0 else -1.0
        for i, s in enumerate(ticks):
            for j, t in enumerate(ticks):
                p = [0.0, 0.0, 0.0]
                p[axis] = sign
                p[(axis + 1) % 3] = s
                p[(axis + 2) % 3] = t
                key = tuple(p)
                if key not in seen:
                    seen[key] = len(points)
                    points.append(p)
                index[f, i, j] = seen[key]
    return np.array(points), index


_POINTS, _INDEX = _grid()
# the same index, flat: face f, grid point (i, j) at f (GRID + 1)^2 + i (GRID + 1) + j
_FLAT_INDEX = _INDEX.reshape(-1).copy()


def grid_points() -> np.ndarray:
    """(DIRECTIONS, 3) float64: the cube-surface points whose supports each node stores."""
    return _POINTS.copy()


@njit
def _build(centers, children, root, vertices, faces, points):
    """(n, DIRECTIONS) supports of each node about its centre, children before parents."""
    n = centers.shape[0]
    k = points.shape[0]
    order = np.empty(n, dtype=np.int64)
    order[0] = root
    filled = 1
    for head in range(n):
        if head >= filled:
            break
        for side in range(2):
            c = children[order[head], side]
            if c >= 0 and (side == 0 or c != children[order[head], 0]):
                order[filled] = c
                filled += 1
    h = np.empty((n, k))
    for position in range(filled - 1, -1, -1):
        node = order[position]
        cx, cy, cz = centers[node, 0], centers[node, 1], centers[node, 2]
        for d in range(k):
            h[node, d] = -np.inf
        for side in range(2):
            c = children[node, side]
            if side == 1 and c == children[node, 0]:
                break
            if c >= 0:
                # the child's supports moved to this node's centre
                ox = centers[c, 0] - cx
                oy = centers[c, 1] - cy
                oz = centers[c, 2] - cz
                for d in range(k):
                    s = h[c, d] + points[d, 0] * ox + points[d, 1] * oy + points[d, 2] * oz
                    h[node, d] = max(h[node, d], s)
            else:
                for corner in range(3):
                    v = faces[-c - 1, corner]
                    vx = vertices[v, 0] - cx
                    vy = vertices[v, 1] - cy
                    vz = vertices[v, 2] - cz
                    for d in range(k):
                        s = points[d, 0] * vx + points[d, 1] * vy + points[d, 2] * vz
                        h[node, d] = max(h[node, d], s)
    return h


def support_block(centers, children, root, vertices, faces) -> np.ndarray:
    """The packed support block of a tree: (n SUPPORT_ROWS, 3) float64 rows holding each
    node's ``SUPPORT_STRIDE`` float32 values (the first ``DIRECTIONS`` of them its supports).

    Parameters
    ----------
    centers : (n, 3) float64
        Node box centres in the mesh frame, as the packed tree stores them.
    children : (n, 2) int64
        Child codes (``k >= 0`` node, ``k < 0`` triangle ``-k - 1``).
    root : int
        The root code (a node: a one-triangle tree has no block to build).
    vertices : (nv, 3) float64, faces : (nf, 3) int64
        The mesh, in its frame.
    """
    n = len(centers)
    if n == 0:
        return np.zeros((0, 3))
    h = _build(
        np.ascontiguousarray(centers, dtype=np.float64),
        np.ascontiguousarray(children, dtype=np.int64),
        int(root),
        np.ascontiguousarray(vertices, dtype=np.float64),
        np.ascontiguousarray(faces, dtype=np.int64),
        _POINTS,
    )
    # float32 halves the block; each value is rounded up, so it still bounds the support
    rounded = h.astype(np.float32)
    low = rounded < h
    rounded[low] = np.nextafter(rounded[low], np.float32(np.inf))
    block = np.zeros((n, SUPPORT_STRIDE), dtype=np.float32)
    block[:, :DIRECTIONS] = rounded
    return block.view(np.float64).reshape(n * SUPPORT_ROWS, 3)


@njit(inline="always")
def support_weights(x, y, z):
    """Where a direction's support is read: three value indices and their weights.

    Parameters
    ----------
    x, y, z : float
        The direction, in the mesh frame; any length (the weights scale with it).

    Returns
    -------
    (k0, k1, k2, w0, w1, w2) :
        ``w0 h[k0] + w1 h[k1] + w2 h[k2]`` bounds the support along (x, y, z) of any node
        whose stored values are ``h`` (:func:`support_at`); all weights 0 for a zero
        direction.
    """
    ax = abs(x)
    ay = abs(y)
    az = abs(z)
    if ax >= ay and ax >= az:
        m, f, s, t = ax, 0 if x > 0.0 else 1, y, z
    elif ay >= az:
        m, f, s, t = ay, 2 if y > 0.0 else 3, z, x
    else:
        m, f, s, t = az, 4 if z > 0.0 else 5, x, y
    if m == 0.0:
        return 0, 0, 0, 0.0, 0.0, 0.0
    # where the direction meets the cube face, in grid units from the face's corner
    scale = (0.5 * GRID) / m
    fs = s * scale + 0.5 * GRID
    ft = t * scale + 0.5 * GRID
    i = min(int(fs), GRID - 1)
    j = min(int(ft), GRID - 1)
    fs -= i
    ft -= j
    row = f * (GRID + 1) * (GRID + 1) + i * (GRID + 1) + j
    if fs + ft <= 1.0:
        return (
            _FLAT_INDEX[row], _FLAT_INDEX[row + GRID + 1], _FLAT_INDEX[row + 1],
            m * (1.0 - fs - ft), m * fs, m * ft,
        )  # fmt: skip
    return (
        _FLAT_INDEX[row + GRID + 2], _FLAT_INDEX[row + GRID + 1], _FLAT_INDEX[row + 1],
        m * (fs + ft - 1.0), m * (1.0 - ft), m * (1.0 - fs),
    )  # fmt: skip


@njit(inline="always")
def support_at(S, start, k, weights):
    """Upper bound on node k's support about its centre along the direction of ``weights``
    (:func:`support_weights`).

    Parameters
    ----------
    S : (2 m,) float32
        The packed tree, flat, read as float32 (:func:`.packed.support_values`); ``start``
        the index of its support block there.
    k : int
        The node.
    """
    k0, k1, k2, w0, w1, w2 = weights
    base = start + SUPPORT_STRIDE * k
    return w0 * S[base + k0] + w1 * S[base + k1] + w2 * S[base + k2]


@njit(inline="always")
def support_along(S, start, k, x, y, z):
    """Upper bound on node k's support ``max (x, y, z) . (v - c_k)`` over its vertices.

    Parameters
    ----------
    S : (2 m,) float32
        The packed tree, flat, read as float32; ``start`` the index of its support block.
    k : int
        The node.
    x, y, z : float
        The direction, in the mesh frame; any length (the bound scales with it).
    """
    return support_at(S, start, k, support_weights(x, y, z))
