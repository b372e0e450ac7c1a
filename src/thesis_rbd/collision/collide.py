"""Narrow phase: simultaneous traversal of two OBBTrees, and the public :func:`collide`.

The traversal (Gottschalk's, thesis 4.8) keeps an explicit stack of *code pairs*, one code per
tree (``k >= 0`` node, ``k < 0`` triangle ``-k - 1``, see :mod:`.obbtree`), and pops:

* node/node: the 15-axis OBB test; on overlap, if both are leaves of a classic tree their
  triangles are tested, otherwise the larger box (by its longest half-extent) is split;
* triangle/node (leafless trees): the triangle-box test, then the node is split; a triangle
  against a classic leaf is tested against the leaf's triangle directly (thesis 5.4.2);
* triangle/triangle: the exact triangle test, recording the pair.

Every triangle pair is reached at most once, because the children of a node partition its
triangles; so "all" reports each intersecting pair exactly once without deduplication.

All geometry is evaluated in the mesh frame of A: B's boxes and triangles are carried over by
the relative transform ``(R_ab, t_ab) = T_a^-1 T_b`` (a carried box is reused while the same B
node is tested against A's children). In "first" mode the nearer child (by box centre) is
visited first, which finds an intersecting pair after about a quarter of the tests on the
tori demo; "all" visits everything anyway and skips that bookkeeping.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd._validate import as_rigid_transform
from thesis_rbd.collision._vec3 import sub
from thesis_rbd.collision.contacts import Contacts, compute_contacts, merge_contacts
from thesis_rbd.collision.obb import obb_disjoint
from thesis_rbd.collision.obbtree import OBBTree
from thesis_rbd.collision.triangle import tri_box_overlap, tri_tri_overlap

__all__ = ["CollisionResult", "collide"]

_MODES = ("first", "all", "contacts")

# Contacts closer than this fraction of the larger mesh's size are merged into one (the
# intersection polyline's corners are shared by neighbouring triangle pairs; see contacts.py).
MERGE_FRACTION = 1e-6


class CollisionResult:
    """Outcome of :func:`collide`.

    Attributes
    ----------
    colliding : bool
        True if at least one triangle of A intersects one of B (touching counts).
    pairs : (k, 2) int64
        [face of A, face of B]. "first": at most one pair. "all" and "contacts": every
        intersecting pair exactly once, sorted lexicographically.
    contacts : Contacts or None
        World-frame contact points, normals (from B towards A), depths and faces; only in
        "contacts" mode, None otherwise.
    stats : dict
        ``bv_tests`` (box-box tests), ``tri_box_tests``, ``tri_tests`` (triangle-triangle
        tests); in "contacts" mode also ``contacts_before_merge``.
    """

    # A plain slotted class, not a dataclass: "first" queries take microseconds and a frozen
    # dataclass's __init__ alone would add one.
    __slots__ = ("colliding", "contacts", "pairs", "stats")

    def __init__(self, colliding: bool, pairs: np.ndarray, contacts, stats: dict):
        self.colliding = colliding
        self.pairs = pairs
        self.contacts = contacts
        self.stats = stats

    def __repr__(self) -> str:
        extra = "" if self.contacts is None else f", contacts={len(self.contacts)}"
        return f"CollisionResult(colliding={self.colliding}, pairs={len(self.pairs)}{extra})"


@njit
def _node_size(h, k):
    return max(h[k, 0], h[k, 1], h[k, 2])


@njit
def _carry_box(y, cb, rb, M, tab):
    """B's box y in A's mesh frame: axes ``G = R_ab R_b[y]`` (row-major 9-tuple), centre."""
    g = (
        M[0] * rb[y, 0, 0] + M[1] * rb[y, 1, 0] + M[2] * rb[y, 2, 0],
        M[0] * rb[y, 0, 1] + M[1] * rb[y, 1, 1] + M[2] * rb[y, 2, 1],
        M[0] * rb[y, 0, 2] + M[1] * rb[y, 1, 2] + M[2] * rb[y, 2, 2],
        M[3] * rb[y, 0, 0] + M[4] * rb[y, 1, 0] + M[5] * rb[y, 2, 0],
        M[3] * rb[y, 0, 1] + M[4] * rb[y, 1, 1] + M[5] * rb[y, 2, 1],
        M[3] * rb[y, 0, 2] + M[4] * rb[y, 1, 2] + M[5] * rb[y, 2, 2],
        M[6] * rb[y, 0, 0] + M[7] * rb[y, 1, 0] + M[8] * rb[y, 2, 0],
        M[6] * rb[y, 0, 1] + M[7] * rb[y, 1, 1] + M[8] * rb[y, 2, 1],
        M[6] * rb[y, 0, 2] + M[7] * rb[y, 1, 2] + M[8] * rb[y, 2, 2],
    )
    c = (
        M[0] * cb[y, 0] + M[1] * cb[y, 1] + M[2] * cb[y, 2] + tab[0],
        M[3] * cb[y, 0] + M[4] * cb[y, 1] + M[5] * cb[y, 2] + tab[1],
        M[6] * cb[y, 0] + M[7] * cb[y, 1] + M[8] * cb[y, 2] + tab[2],
    )
    return g, c


@njit
def _boxes_disjoint(x, ca, ra, ha, g, c, b):
    """OBB test of A's box x against a box already carried into A's mesh frame.

    ``g`` (row-major 9-tuple) and ``c`` are that box's axes and centre in A's mesh frame (see
    :func:`_carry_box`), ``b`` its half-extents. Arrays are indexed element by element (no
    row views), which keeps the kernel free of reference counting.
    """
    d0 = c[0] - ca[x, 0]
    d1 = c[1] - ca[x, 1]
    d2 = c[2] - ca[x, 2]
    a00 = ra[x, 0, 0]
    a01 = ra[x, 0, 1]
    a02 = ra[x, 0, 2]
    a10 = ra[x, 1, 0]
    a11 = ra[x, 1, 1]
    a12 = ra[x, 1, 2]
    a20 = ra[x, 2, 0]
    a21 = ra[x, 2, 1]
    a22 = ra[x, 2, 2]
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
    a = (float(ha[x, 0]), float(ha[x, 1]), float(ha[x, 2]))
    return obb_disjoint(R, T, a, b)


@njit
def _closer(c1, c0, centers, other, other_centers, M, tr, b_side):
    """Whether child c1 lies nearer than child c0 to node ``other`` of the other tree.

    Used only by "first" queries: visiting the nearer child first finds an intersecting pair
    sooner on average. Children that are triangles (< 0) have no centre: keep the order.
    """
    if c0 < 0 or c1 < 0:
        return False
    if b_side:
        # Children are B's nodes: compare in B's frame against A's centre carried there.
        p = (
            other_centers[other, 0] - tr[0],
            other_centers[other, 1] - tr[1],
            other_centers[other, 2] - tr[2],
        )
        o = (
            M[0] * p[0] + M[3] * p[1] + M[6] * p[2],
            M[1] * p[0] + M[4] * p[1] + M[7] * p[2],
            M[2] * p[0] + M[5] * p[1] + M[8] * p[2],
        )
    else:
        q = (other_centers[other, 0], other_centers[other, 1], other_centers[other, 2])
        o = (
            M[0] * q[0] + M[1] * q[1] + M[2] * q[2] + tr[0],
            M[3] * q[0] + M[4] * q[1] + M[5] * q[2] + tr[1],
            M[6] * q[0] + M[7] * q[1] + M[8] * q[2] + tr[2],
        )
    d1 = 0.0
    d0 = 0.0
    for i in range(3):
        d1 += (centers[c1, i] - o[i]) ** 2
        d0 += (centers[c0, i] - o[i]) ** 2
    return d1 < d0


@njit
def _corner(V, F, t, k):
    i = F[t, k]
    return (V[i, 0], V[i, 1], V[i, 2])


@njit
def _corner_moved(V, F, t, k, M, tr):
    """Corner k of triangle t, mapped by ``x -> M x + tr`` (M a row-major 9-tuple)."""
    i = F[t, k]
    x = V[i, 0]
    y = V[i, 1]
    z = V[i, 2]
    return (
        M[0] * x + M[1] * y + M[2] * z + tr[0],
        M[3] * x + M[4] * y + M[5] * z + tr[1],
        M[6] * x + M[7] * y + M[8] * z + tr[2],
    )


@njit
def _tri_pair(ta, tb, Va, Fa, Vb, Fb, Rab, tab):
    return tri_tri_overlap(
        _corner(Va, Fa, ta, 0),
        _corner(Va, Fa, ta, 1),
        _corner(Va, Fa, ta, 2),
        _corner_moved(Vb, Fb, tb, 0, Rab, tab),
        _corner_moved(Vb, Fb, tb, 1, Rab, tab),
        _corner_moved(Vb, Fb, tb, 2, Rab, tab),
    )


@njit
def _tri_in_box(V, F, t, R, tr, c, rot, h, k):
    """Triangle t (mapped by ``x -> R x + tr``) against box k (centre c, axes rot, half h)."""
    ck = (float(c[k, 0]), float(c[k, 1]), float(c[k, 2]))
    # Box frame = rot[k].T (x - c): fold it into the mapping, one 9-tuple product.
    Q = (
        rot[k, 0, 0] * R[0] + rot[k, 1, 0] * R[3] + rot[k, 2, 0] * R[6],
        rot[k, 0, 0] * R[1] + rot[k, 1, 0] * R[4] + rot[k, 2, 0] * R[7],
        rot[k, 0, 0] * R[2] + rot[k, 1, 0] * R[5] + rot[k, 2, 0] * R[8],
        rot[k, 0, 1] * R[0] + rot[k, 1, 1] * R[3] + rot[k, 2, 1] * R[6],
        rot[k, 0, 1] * R[1] + rot[k, 1, 1] * R[4] + rot[k, 2, 1] * R[7],
        rot[k, 0, 1] * R[2] + rot[k, 1, 1] * R[5] + rot[k, 2, 1] * R[8],
        rot[k, 0, 2] * R[0] + rot[k, 1, 2] * R[3] + rot[k, 2, 2] * R[6],
        rot[k, 0, 2] * R[1] + rot[k, 1, 2] * R[4] + rot[k, 2, 2] * R[7],
        rot[k, 0, 2] * R[2] + rot[k, 1, 2] * R[5] + rot[k, 2, 2] * R[8],
    )
    w = sub(tr, ck)
    qt = (
        rot[k, 0, 0] * w[0] + rot[k, 1, 0] * w[1] + rot[k, 2, 0] * w[2],
        rot[k, 0, 1] * w[0] + rot[k, 1, 1] * w[1] + rot[k, 2, 1] * w[2],
        rot[k, 0, 2] * w[0] + rot[k, 1, 2] * w[1] + rot[k, 2, 2] * w[2],
    )
    v0 = _corner_moved(V, F, t, 0, Q, qt)
    v1 = _corner_moved(V, F, t, 1, Q, qt)
    v2 = _corner_moved(V, F, t, 2, Q, qt)
    # The triangle test sees the corners mapped by (R, tr) alone; mapped into the box frame
    # in one step they differ from those by rounding, at most a few units of the magnitudes
    # involved: the corner (whose length is about that of v - qt), tr and the box centre.
    reach = (
        2.0 * (abs(qt[0]) + abs(qt[1]) + abs(qt[2]))
        + (abs(tr[0]) + abs(tr[1]) + abs(tr[2]))
        + (abs(ck[0]) + abs(ck[1]) + abs(ck[2]))
    )
    return tri_box_overlap(v0, v1, v2, (float(h[k, 0]), float(h[k, 1]), float(h[k, 2])), reach)


@njit
def traverse(
    first_only,
    ca,
    ra,
    ha,
    cha,
    root_a,
    leafless_a,
    Va,
    Fa,
    cb,
    rb,
    hb,
    chb,
    root_b,
    leafless_b,
    Vb,
    Fb,
    T_a,
    T_b,
    stack_capacity,
):
    """Walk two trees; return (pairs (k, 2) int64, bv_tests, tri_box_tests, tri_tests).

    Trees are given as their flat arrays (see :class:`OBBTree`), vertices ``V`` (n, 3) and
    faces ``F`` (m, 3) in their mesh frames; ``T_a``, ``T_b`` (4, 4) are the poses (the
    relative one is formed here, saving a kernel call per query). ``first_only`` stops at
    the first intersecting pair. Pairs come unsorted.
    """
    Rab, tab = _relative_pose(T_a, T_b)
    # Transforms as tuples (registers, no aliasing with the tree arrays); the inverse one
    # carries A's triangles into B's frame for B's boxes.
    Mab = (
        Rab[0, 0],
        Rab[0, 1],
        Rab[0, 2],
        Rab[1, 0],
        Rab[1, 1],
        Rab[1, 2],
        Rab[2, 0],
        Rab[2, 1],
        Rab[2, 2],
    )
    Mba = (
        Rab[0, 0],
        Rab[1, 0],
        Rab[2, 0],
        Rab[0, 1],
        Rab[1, 1],
        Rab[2, 1],
        Rab[0, 2],
        Rab[1, 2],
        Rab[2, 2],
    )
    tab_t = (tab[0], tab[1], tab[2])
    tba_t = (
        -(Mba[0] * tab[0] + Mba[1] * tab[1] + Mba[2] * tab[2]),
        -(Mba[3] * tab[0] + Mba[4] * tab[1] + Mba[5] * tab[2]),
        -(Mba[6] * tab[0] + Mba[7] * tab[1] + Mba[8] * tab[2]),
    )
    pairs = np.empty((64, 2), dtype=np.int64)
    n_pairs = 0
    stack = np.empty((stack_capacity, 2), dtype=np.int64)
    stack[0, 0] = root_a
    stack[0, 1] = root_b
    top = 1
    bv_tests = 0
    box_tests = 0
    tri_tests = 0
    carried = -1
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    c = (0.0, 0.0, 0.0)
    hy = (0.0, 0.0, 0.0)
    while top > 0:
        top -= 1
        x = stack[top, 0]
        y = stack[top, 1]
        ta = -1
        tb = -1
        if x >= 0 and y >= 0:
            bv_tests += 1
            # B's box carried into A's frame is reused while y stays the same (A's children
            # are tested against it one after the other).
            if y != carried:
                g, c = _carry_box(y, cb, rb, Mab, tab_t)
                hy = (float(hb[y, 0]), float(hb[y, 1]), float(hb[y, 2]))
                carried = y
            if _boxes_disjoint(x, ca, ra, ha, g, c, hy):
                continue
            a_leaf = (not leafless_a) and cha[x, 0] < 0
            b_leaf = (not leafless_b) and chb[y, 0] < 0
            if a_leaf and b_leaf:
                ta = -cha[x, 0] - 1
                tb = -chb[y, 0] - 1
            else:
                if top + 2 > stack.shape[0]:
                    bigger = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
                    bigger[:top] = stack[:top]
                    stack = bigger
                if a_leaf or (not b_leaf and _node_size(hb, y) > _node_size(ha, x)):
                    c0 = chb[y, 0]
                    c1 = chb[y, 1]
                    if first_only and _closer(c1, c0, cb, x, ca, Mab, tab_t, True):
                        c0, c1 = c1, c0
                    stack[top, 0] = x
                    stack[top, 1] = c1
                    stack[top + 1, 0] = x
                    stack[top + 1, 1] = c0
                else:
                    c0 = cha[x, 0]
                    c1 = cha[x, 1]
                    if first_only and _closer(c1, c0, ca, y, cb, Mab, tab_t, False):
                        c0, c1 = c1, c0
                    stack[top, 0] = c1
                    stack[top, 1] = y
                    stack[top + 1, 0] = c0
                    stack[top + 1, 1] = y
                top += 2
                continue
        elif x < 0 and y < 0:
            ta = -x - 1
            tb = -y - 1
        elif x < 0:
            # A's triangle against B's node.
            if (not leafless_b) and chb[y, 0] < 0:
                ta = -x - 1
                tb = -chb[y, 0] - 1
            else:
                box_tests += 1
                if not _tri_in_box(Va, Fa, -x - 1, Mba, tba_t, cb, rb, hb, y):
                    continue
                if top + 2 > stack.shape[0]:
                    bigger = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
                    bigger[:top] = stack[:top]
                    stack = bigger
                stack[top, 0] = x
                stack[top, 1] = chb[y, 1]
                stack[top + 1, 0] = x
                stack[top + 1, 1] = chb[y, 0]
                top += 2
                continue
        else:
            # A's node against B's triangle.
            if (not leafless_a) and cha[x, 0] < 0:
                ta = -cha[x, 0] - 1
                tb = -y - 1
            else:
                box_tests += 1
                if not _tri_in_box(Vb, Fb, -y - 1, Mab, tab_t, ca, ra, ha, x):
                    continue
                if top + 2 > stack.shape[0]:
                    bigger = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
                    bigger[:top] = stack[:top]
                    stack = bigger
                stack[top, 0] = cha[x, 1]
                stack[top, 1] = y
                stack[top + 1, 0] = cha[x, 0]
                stack[top + 1, 1] = y
                top += 2
                continue
        # A triangle pair.
        tri_tests += 1
        if _tri_pair(ta, tb, Va, Fa, Vb, Fb, Mab, tab_t):
            if n_pairs == pairs.shape[0]:
                bigger = np.empty((2 * pairs.shape[0], 2), dtype=np.int64)
                bigger[:n_pairs] = pairs[:n_pairs]
                pairs = bigger
            pairs[n_pairs, 0] = ta
            pairs[n_pairs, 1] = tb
            n_pairs += 1
            if first_only:
                break
    return pairs[:n_pairs].copy(), bv_tests, box_tests, tri_tests


def _as_tree(tree, name: str) -> OBBTree:
    if not isinstance(tree, OBBTree):
        raise ValueError(f"{name} must be a thesis_rbd.OBBTree, got {type(tree).__name__}")
    return tree


@njit
def _rigid_ok(T, tol):
    """Fast acceptance check equivalent to (and no looser than) ``as_rigid_transform``."""
    for i in range(4):
        for j in range(4):
            if not np.isfinite(T[i, j]):
                return False
    if abs(T[3, 0]) > tol or abs(T[3, 1]) > tol or abs(T[3, 2]) > tol or abs(T[3, 3] - 1) > tol:
        return False
    for i in range(3):
        for j in range(3):
            s = T[0, i] * T[0, j] + T[1, i] * T[1, j] + T[2, i] * T[2, j]
            if abs(s - (1.0 if i == j else 0.0)) > tol:
                return False
    det = (
        T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1])
        - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
        + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0])
    )
    return det > 0.0


@njit
def _relative_pose(T_a, T_b):
    """``(R_ab, t_ab)`` of ``T_a^-1 T_b``: B's mesh frame expressed in A's."""
    Rab = np.empty((3, 3))
    tab = np.empty(3)
    for i in range(3):
        for j in range(3):
            Rab[i, j] = T_a[0, i] * T_b[0, j] + T_a[1, i] * T_b[1, j] + T_a[2, i] * T_b[2, j]
        tab[i] = (
            T_a[0, i] * (T_b[0, 3] - T_a[0, 3])
            + T_a[1, i] * (T_b[1, 3] - T_a[1, 3])
            + T_a[2, i] * (T_b[2, 3] - T_a[2, 3])
        )
    return Rab, tab


@njit
def _to_world(points, normals, T):
    """Map (c, 3) points and directions from a mesh frame to the world by ``T`` (4, 4)."""
    P = np.empty_like(points)
    N = np.empty_like(normals)
    for k in range(points.shape[0]):
        for i in range(3):
            P[k, i] = T[i, 0] * points[k, 0] + T[i, 1] * points[k, 1] + T[i, 2] * points[k, 2]
            P[k, i] += T[i, 3]
            N[k, i] = T[i, 0] * normals[k, 0] + T[i, 1] * normals[k, 1] + T[i, 2] * normals[k, 2]
    return P, N


def _is_matrix(T) -> bool:
    return (
        type(T) is np.ndarray
        and T.shape == (4, 4)
        and T.dtype == np.float64
        and T.flags.c_contiguous
    )


@njit
def _checked_traverse(
    first_only, ca, ra, ha, cha, root_a, leafless_a, Va, Fa,
    cb, rb, hb, chb, root_b, leafless_b, Vb, Fb, T_a, T_b, stack_capacity,
):  # fmt: skip
    """:func:`traverse` after checking both poses; bv_tests = -1 if either is not rigid."""
    if not (_rigid_ok(T_a, 1e-6) and _rigid_ok(T_b, 1e-6)):
        return np.empty((0, 2), dtype=np.int64), -1, 0, 0
    return traverse(
        first_only, ca, ra, ha, cha, root_a, leafless_a, Va, Fa,
        cb, rb, hb, chb, root_b, leafless_b, Vb, Fb, T_a, T_b, stack_capacity,
    )  # fmt: skip


def collide(tree_a, T_a, tree_b, T_b, mode: str = "first", merge_tolerance=None):
    """Intersect two triangle meshes through their OBBTrees.

    Parameters
    ----------
    tree_a, tree_b : OBBTree
        The two meshes' trees.
    T_a, T_b : (4, 4) array_like of float
        Rigid transforms from each mesh frame to the world (trimesh convention).
    mode : {"first", "all", "contacts"}
        "first" stops at the first intersecting triangle pair; "all" finds every one;
        "contacts" also computes contact points, normals and depths (see
        :mod:`thesis_rbd.collision.contacts`).
    merge_tolerance : float, optional
        "contacts" only: contacts closer than this (world units) are merged, keeping the one
        of least depth. Default ``1e-6 * max(mesh_a.scale, mesh_b.scale)``, which merges the
        duplicates that neighbouring triangle pairs produce and nothing else; pass a larger
        value to thin the contact set.

    Returns
    -------
    CollisionResult

    Raises
    ------
    ValueError
        On an unknown mode, a tree that is not an OBBTree, or a transform that is not a
        finite (4, 4) rigid transform.
    """
    if mode not in _MODES:
        raise ValueError(f"mode must be one of {_MODES}, got {mode!r}")
    tree_a = _as_tree(tree_a, "tree_a")
    tree_b = _as_tree(tree_b, "tree_b")
    mesh_a = tree_a.mesh
    mesh_b = tree_b.mesh
    args = (
        mode == "first",
        tree_a.centers,
        tree_a.rotations,
        tree_a.half_extents,
        tree_a.children,
        tree_a.root,
        tree_a.leafless,
        mesh_a.vertices,
        mesh_a.faces,
        tree_b.centers,
        tree_b.rotations,
        tree_b.half_extents,
        tree_b.children,
        tree_b.root,
        tree_b.leafless,
        mesh_b.vertices,
        mesh_b.faces,
    )
    capacity = 2 * (tree_a.depth + tree_b.depth) + 8
    # Fast path: float64 C-contiguous (4, 4) arrays are checked inside the query kernel (one
    # kernel call per query: dispatch costs about a microsecond, a "first" query ten). If
    # the check fails, or the poses are anything else, the package validator converts them
    # or raises its precise message, and the query runs on its result.
    bv_tests = -1
    if _is_matrix(T_a) and _is_matrix(T_b):
        pairs, bv_tests, box_tests, tri_tests = _checked_traverse(*args, T_a, T_b, capacity)
    if bv_tests < 0:
        T_a = as_rigid_transform(T_a, "T_a")
        T_b = as_rigid_transform(T_b, "T_b")
        pairs, bv_tests, box_tests, tri_tests = traverse(*args, T_a, T_b, capacity)
    stats = {
        "bv_tests": int(bv_tests),
        "tri_box_tests": int(box_tests),
        "tri_tests": int(tri_tests),
    }
    if mode != "first" and len(pairs) > 1:
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    contacts = None
    if mode == "contacts":
        if merge_tolerance is None:
            merge_tolerance = MERGE_FRACTION * max(tree_a.scale, tree_b.scale)
        else:
            merge_tolerance = float(merge_tolerance)
            if not np.isfinite(merge_tolerance) or merge_tolerance < 0:
                raise ValueError(f"merge_tolerance must be finite and >= 0, got {merge_tolerance}")
        Rab, tab = _relative_pose(T_a, T_b)
        points, normals, depths, faces = compute_contacts(
            pairs, mesh_a.vertices, mesh_a.faces, mesh_b.vertices, mesh_b.faces, Rab, tab
        )
        stats["contacts_before_merge"] = len(points)
        keep = merge_contacts(points, depths, merge_tolerance)
        points, normals = _to_world(points[keep], normals[keep], T_a)
        contacts = Contacts(points=points, normals=normals, depths=depths[keep], faces=faces[keep])
    return CollisionResult(colliding=len(pairs) > 0, pairs=pairs, contacts=contacts, stats=stats)
