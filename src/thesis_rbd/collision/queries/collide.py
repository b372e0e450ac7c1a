"""Narrow phase: simultaneous traversal of two OBBTrees, and the public :func:`collide`.

The traversal (Gottschalk's, thesis 4.8) keeps an explicit stack of *code pairs*, one code per
tree (``k >= 0`` node, ``k < 0`` triangle ``-k - 1``, see :mod:`..mesh.obbtree`), and pops:

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

Trees reach the kernels as their packed arrays (:mod:`..mesh.packed`, one argument per tree) and
poses as given, checked inside a sealed kernel (:mod:`._query_args`); a "first" query whose
root boxes are disjoint returns before the traversal allocates its stack. These keep the cost
of a query that misses at the root near python-fcl's.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision._vec3 import sub
from thesis_rbd.collision.mesh.contact_report import Contacts, compute_contacts, merge_contacts
from thesis_rbd.collision.mesh.obb import obb_disjoint
from thesis_rbd.collision.mesh.packed import (
    box_frame,
    carry_box,
    child,
    corner_moved,
    half_extent,
    layout,
    node_size,
    pair_corners,
    tree_depth,
)
from thesis_rbd.collision.mesh.triangle import tri_box_overlap, tri_tri_overlap
from thesis_rbd.collision.queries._query_args import (
    as_pose,
    call_normalised,
    inverse_pose,
    pose_ok,
    raise_bad_pose,
    relative_pose,
    sealed,
    tree_array,
)

__all__ = ["CollisionResult", "collide"]

_MODES = ("first", "all", "contacts")
_STATS = ("bv_tests", "tri_box_tests", "tri_tests", "contacts_before_merge")
# The pairs of every "first" query that finds none (read-only, so sharing it is safe).
_NO_PAIRS = np.empty((0, 2), dtype=np.int64)
_NO_PAIRS.flags.writeable = False

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

    # A plain slotted class, not a dataclass, and the stats dict built only when read:
    # "first" queries that miss at the root take about a microsecond in all.
    __slots__ = ("_counts", "colliding", "contacts", "pairs")

    def __init__(self, colliding: bool, pairs: np.ndarray, contacts, counts: tuple):
        self.colliding = colliding
        self.pairs = pairs
        self.contacts = contacts
        self._counts = counts

    @property
    def stats(self) -> dict:
        return dict(zip(_STATS, (int(c) for c in self._counts), strict=False))

    def __repr__(self) -> str:
        extra = "" if self.contacts is None else f", contacts={len(self.contacts)}"
        return f"CollisionResult(colliding={self.colliding}, pairs={len(self.pairs)}{extra})"


@njit(allocates=False)
def _boxes_disjoint(x, P, L, g, c, b):
    """OBB test of box x of tree (P, L) against a box already carried into its mesh frame.

    ``g`` (row-major 9-tuple) and ``c`` are that box's axes and centre in the mesh frame (see
    :func:`.packed.carry_box`), ``b`` its half-extents. Arrays are indexed element by element (no
    row views), which keeps the kernel free of reference counting.
    """
    R, T = box_frame(x, P, L, g, c)
    return obb_disjoint(R, T, half_extent(P, L, x), b)


@njit(allocates=False)
def _carried_centre(P, L, k, M, tr):
    """Centre of box k of tree (P, L) mapped by ``x -> M x + tr`` (M row-major)."""
    c = L[0] + k
    return (
        M[0] * P[c, 0] + M[1] * P[c, 1] + M[2] * P[c, 2] + tr[0],
        M[3] * P[c, 0] + M[4] * P[c, 1] + M[5] * P[c, 2] + tr[1],
        M[6] * P[c, 0] + M[7] * P[c, 1] + M[8] * P[c, 2] + tr[2],
    )


@njit(allocates=False)
def _centre_distance2(P, L, k, o):
    """Squared distance from the centre of box k of tree (P, L) to the point ``o``."""
    c = L[0] + k
    return (P[c, 0] - o[0]) ** 2 + (P[c, 1] - o[1]) ** 2 + (P[c, 2] - o[2]) ** 2


@njit
def faces_intersect(face_a, face_b, Pa, La, Pb, Lb, Mab, tab):
    """Whether face ``face_a`` of A and ``face_b`` of B intersect, B's mesh frame mapped
    into A's by ``x -> Mab x + tab`` (:func:`._query_args.relative_pose` of the poses).

    The triangle test :func:`walk` makes: a pair that the walk reports at a pose passes here
    at that pose, and a pair that passes here is one the walk would reach (its boxes overlap,
    so it is never pruned). The test may allocate (exact predicates); the corners are read
    without reference counting the trees.
    """
    p0, p1, p2, q0, q1, q2 = pair_corners(face_a, face_b, Pa, La, Pb, Lb, Mab, tab)
    return tri_tri_overlap(p0, p1, p2, q0, q1, q2)


@njit(allocates=False)
def _tri_in_box(P, L, t, R, tr, Pk, Lk, k):
    """Triangle t of tree (P, L) (mapped by ``x -> R x + tr``) against box k of (Pk, Lk)."""
    ck = (Pk[Lk[0] + k, 0], Pk[Lk[0] + k, 1], Pk[Lk[0] + k, 2])
    r = Lk[2] + 3 * k
    # Box frame = rot[k].T (x - c): fold it into the mapping, one 9-tuple product.
    Q = (
        Pk[r, 0] * R[0] + Pk[r + 1, 0] * R[3] + Pk[r + 2, 0] * R[6],
        Pk[r, 0] * R[1] + Pk[r + 1, 0] * R[4] + Pk[r + 2, 0] * R[7],
        Pk[r, 0] * R[2] + Pk[r + 1, 0] * R[5] + Pk[r + 2, 0] * R[8],
        Pk[r, 1] * R[0] + Pk[r + 1, 1] * R[3] + Pk[r + 2, 1] * R[6],
        Pk[r, 1] * R[1] + Pk[r + 1, 1] * R[4] + Pk[r + 2, 1] * R[7],
        Pk[r, 1] * R[2] + Pk[r + 1, 1] * R[5] + Pk[r + 2, 1] * R[8],
        Pk[r, 2] * R[0] + Pk[r + 1, 2] * R[3] + Pk[r + 2, 2] * R[6],
        Pk[r, 2] * R[1] + Pk[r + 1, 2] * R[4] + Pk[r + 2, 2] * R[7],
        Pk[r, 2] * R[2] + Pk[r + 1, 2] * R[5] + Pk[r + 2, 2] * R[8],
    )
    w = sub(tr, ck)
    qt = (
        Pk[r, 0] * w[0] + Pk[r + 1, 0] * w[1] + Pk[r + 2, 0] * w[2],
        Pk[r, 1] * w[0] + Pk[r + 1, 1] * w[1] + Pk[r + 2, 1] * w[2],
        Pk[r, 2] * w[0] + Pk[r + 1, 2] * w[1] + Pk[r + 2, 2] * w[2],
    )
    v0 = corner_moved(P, L, t, 0, Q, qt)
    v1 = corner_moved(P, L, t, 1, Q, qt)
    v2 = corner_moved(P, L, t, 2, Q, qt)
    # The triangle test sees the corners mapped by (R, tr) alone; mapped into the box frame
    # in one step they differ from those by rounding, at most a few units of the magnitudes
    # involved: the corner (whose length is about that of v - qt), tr and the box centre.
    reach = (
        2.0 * (abs(qt[0]) + abs(qt[1]) + abs(qt[2]))
        + (abs(tr[0]) + abs(tr[1]) + abs(tr[2]))
        + (abs(ck[0]) + abs(ck[1]) + abs(ck[2]))
    )
    return tri_box_overlap(v0, v1, v2, half_extent(Pk, Lk, k), reach)


@njit(allocates=False)
def _record_disjoint(front, n_front, x, y):
    """Write the code pair (x, y) to ``front[n_front]``; return the new count."""
    front[n_front, 0] = x
    front[n_front, 1] = y
    return n_front + 1


@njit
def walk(first_only, Pa, La, Pb, Lb, Mab, tab, stack, top, pairs, n_pairs, counts, front, n_front):
    """Walk two trees from the code pairs ``stack[:top]``; return ``(top, n_pairs, n_front)``.

    The traversal itself, over arrays the caller owns and never replaces: numba increfs and
    decrefs an array variable that a loop may reassign on every pass (atomic operations that
    cost about as much as the box test itself), so the stack and the pair list are not grown
    here.

    Trees are given as their packed arrays and layouts (:mod:`..mesh.packed`), B's mesh frame
    mapped into A's by ``x -> Mab x + tab``. Found pairs are written to ``pairs[n_pairs:]``
    (unsorted); ``counts`` (3,) int64 accumulates the box-box, triangle-box and triangle
    tests. ``first_only`` stops at the first intersecting pair.

    ``front`` (m, 2) int64, or None to keep none: every code pair found disjoint (boxes,
    triangle and box, or two triangles) is written to ``front[n_front:]``. The pairs proved
    disjoint by a walk that ends without finding one cover every triangle pair exactly once
    (children partition their parent's triangles), so a walk from them at a nearby pose is
    as complete as one from the roots, and skips the boxes above them (front tracking,
    Ehmann and Lin 2001).

    The walk is done when the returned ``top`` is 0, or when ``first_only`` and a pair was
    found. Otherwise it stopped, with its state intact, because ``pairs`` or ``front`` is full
    or the stack has no room for the next split; the caller gives it a larger copy of that
    array and calls again with the returned ``top``, ``n_pairs`` and ``n_front``.
    """
    leafless_a = La[7]
    leafless_b = Lb[7]
    # The inverse transform carries A's triangles into B's frame for B's boxes.
    Mba, tba = inverse_pose(Mab, tab)
    bv_tests = 0
    box_tests = 0
    tri_tests = 0
    carried = -1
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    c = (0.0, 0.0, 0.0)
    hy = (0.0, 0.0, 0.0)
    front_rows = 0
    if front is not None:
        front_rows = front.shape[0]
    # A pop frees one row and a split fills two: a split needs room for one more.
    while top > 0 and top < stack.shape[0] and n_pairs < pairs.shape[0]:
        if front is not None and n_front == front_rows:
            break
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
                g, c = carry_box(y, Pb, Lb, Mab, tab)
                hy = half_extent(Pb, Lb, y)
                carried = y
            if _boxes_disjoint(x, Pa, La, g, c, hy):
                if front is not None:
                    n_front = _record_disjoint(front, n_front, x, y)
                continue
            a_leaf = (not leafless_a) and child(Pa, La, x, 0) < 0
            b_leaf = (not leafless_b) and child(Pb, Lb, y, 0) < 0
            if a_leaf and b_leaf:
                ta = -child(Pa, La, x, 0) - 1
                tb = -child(Pb, Lb, y, 0) - 1
            else:
                if a_leaf or (not b_leaf and node_size(Pb, Lb, y) > node_size(Pa, La, x)):
                    c0 = child(Pb, Lb, y, 0)
                    c1 = child(Pb, Lb, y, 1)
                    # "first": visit the child nearer the other box first (in B's frame).
                    if first_only and c0 >= 0 and c1 >= 0:
                        o = _carried_centre(Pa, La, x, Mba, tba)
                        if _centre_distance2(Pb, Lb, c1, o) < _centre_distance2(Pb, Lb, c0, o):
                            c0, c1 = c1, c0
                    stack[top, 0] = x
                    stack[top, 1] = c1
                    stack[top + 1, 0] = x
                    stack[top + 1, 1] = c0
                else:
                    c0 = child(Pa, La, x, 0)
                    c1 = child(Pa, La, x, 1)
                    if first_only and c0 >= 0 and c1 >= 0:
                        o = _carried_centre(Pb, Lb, y, Mab, tab)
                        if _centre_distance2(Pa, La, c1, o) < _centre_distance2(Pa, La, c0, o):
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
            if (not leafless_b) and child(Pb, Lb, y, 0) < 0:
                ta = -x - 1
                tb = -child(Pb, Lb, y, 0) - 1
            else:
                box_tests += 1
                if not _tri_in_box(Pa, La, -x - 1, Mba, tba, Pb, Lb, y):
                    if front is not None:
                        n_front = _record_disjoint(front, n_front, x, y)
                    continue
                stack[top, 0] = x
                stack[top, 1] = child(Pb, Lb, y, 1)
                stack[top + 1, 0] = x
                stack[top + 1, 1] = child(Pb, Lb, y, 0)
                top += 2
                continue
        else:
            # A's node against B's triangle.
            if (not leafless_a) and child(Pa, La, x, 0) < 0:
                ta = -child(Pa, La, x, 0) - 1
                tb = -y - 1
            else:
                box_tests += 1
                if not _tri_in_box(Pb, Lb, -y - 1, Mab, tab, Pa, La, x):
                    if front is not None:
                        n_front = _record_disjoint(front, n_front, x, y)
                    continue
                stack[top, 0] = child(Pa, La, x, 1)
                stack[top, 1] = y
                stack[top + 1, 0] = child(Pa, La, x, 0)
                stack[top + 1, 1] = y
                top += 2
                continue
        # A triangle pair.
        tri_tests += 1
        if faces_intersect(ta, tb, Pa, La, Pb, Lb, Mab, tab):
            pairs[n_pairs, 0] = ta
            pairs[n_pairs, 1] = tb
            n_pairs += 1
            if first_only:
                break
        elif front is not None:
            n_front = _record_disjoint(front, n_front, x, y)
    counts[0] += bv_tests
    counts[1] += box_tests
    counts[2] += tri_tests
    return top, n_pairs, n_front


@njit
def walk_stack(Pa, Pb):
    """A stack for :func:`walk` over trees (Pa, Pb), with room for the deepest descent: a
    split moves one tree a level down, so a descent adds at most one row per level."""
    return np.empty((tree_depth(Pa) + tree_depth(Pb) + 8, 2), dtype=np.int64)


@njit
def with_room(rows):
    """A copy of ``rows`` (k, 2) int64 with room for 2 k."""
    bigger = np.empty((2 * rows.shape[0], 2), dtype=np.int64)
    bigger[: rows.shape[0]] = rows
    return bigger


@njit(separate=True)
def traverse(first_only, Pa, Pb, T_a, T_b):
    """Walk two trees; return (pairs (k, 2) int64, bv_tests, tri_box_tests, tri_tests).

    Trees are given as their packed arrays (see :mod:`..mesh.packed`), which hold the boxes and the
    mesh in its frame; ``T_a``, ``T_b`` (4, 4) are the poses (the relative one is formed
    here, saving a kernel call per query). ``first_only`` stops at the first intersecting
    pair. Pairs come unsorted.
    """
    La = layout(Pa)
    Lb = layout(Pb)
    Mab, tab = relative_pose(T_a, T_b)
    stack = walk_stack(Pa, Pb)
    stack[0, 0] = La[6]
    stack[0, 1] = Lb[6]
    pairs = np.empty((1 if first_only else 64, 2), dtype=np.int64)
    counts = np.zeros(3, dtype=np.int64)
    top, n_pairs, _ = walk(
        first_only, Pa, La, Pb, Lb, Mab, tab, stack, 1, pairs, 0, counts, None, 0
    )
    while top > 0 and not (first_only and n_pairs > 0):
        if n_pairs == pairs.shape[0]:
            pairs = with_room(pairs)
        else:
            stack = with_room(stack)
        top, n_pairs, _ = walk(
            first_only, Pa, La, Pb, Lb, Mab, tab, stack, top, pairs, n_pairs, counts, None, 0
        )
    return pairs[:n_pairs], counts[0], counts[1], counts[2]


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


@njit(allocates=False)
def roots_disjoint(Pa, La, Pb, Lb, Mab, tab):
    """Whether the root boxes of two trees (both nodes) are disjoint, B's mesh frame mapped
    into A's by ``x -> Mab x + tab``.

    The test :func:`traverse` makes first, done without allocating anything: queries that
    miss at the root (most of a motion planner's) end here.
    """
    if La[6] < 0 or Lb[6] < 0:
        return False
    g, c = carry_box(Lb[6], Pb, Lb, Mab, tab)
    return _boxes_disjoint(La[6], Pa, La, g, c, half_extent(Pb, Lb, Lb[6]))


@sealed
@njit
def _first_kernel(P_a, T_a, P_b, T_b):
    """ "first" query: (status, face of A, face of B, bv, tri_box, tri tests).

    status 0: done (faces -1 when nothing intersects); 1 or 2: T_a or T_b is not a finite
    rigid (4, 4) transform. Scalars only, so nothing is allocated for the answer.
    """
    if not pose_ok(T_a):
        return 1, -1, -1, 0, 0, 0
    if not pose_ok(T_b):
        return 2, -1, -1, 0, 0, 0
    Mab, tab = relative_pose(T_a, T_b)
    if roots_disjoint(P_a, layout(P_a), P_b, layout(P_b), Mab, tab):
        return 0, -1, -1, 1, 0, 0
    pairs, bv, box, tri = traverse(True, P_a, P_b, T_a, T_b)
    if pairs.shape[0] == 0:
        return 0, -1, -1, bv, box, tri
    return 0, pairs[0, 0], pairs[0, 1], bv, box, tri


@sealed
@njit
def _all_kernel(P_a, T_a, P_b, T_b):
    """ "all" query: (status, pairs (k, 2) unsorted, bv, tri_box, tri tests)."""
    if not pose_ok(T_a):
        return 1, np.empty((0, 2), dtype=np.int64), 0, 0, 0
    if not pose_ok(T_b):
        return 2, np.empty((0, 2), dtype=np.int64), 0, 0, 0
    pairs, bv, box, tri = traverse(False, P_a, P_b, T_a, T_b)
    return 0, pairs, bv, box, tri


def _normalised(tree_a, T_a, tree_b, T_b):
    """The arguments of a query kernel from any accepted input (ValueError otherwise)."""
    P_a = tree_array(tree_a, "tree_a")
    P_b = tree_array(tree_b, "tree_b")
    return P_a, as_pose(T_a, "T_a"), P_b, as_pose(T_b, "T_b")


def _check_status(status, T_a, T_b):
    if status == 1:
        raise_bad_pose(T_a, "T_a")
    if status == 2:
        raise_bad_pose(T_b, "T_b")


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
        :mod:`thesis_rbd.collision.mesh.contact_report`).
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
    # Fast path (see _query_args): packed trees and poses go to a sealed kernel as they are;
    # anything it was not compiled for raises TypeError (or AttributeError for a tree that is
    # not an OBBTree or not packed yet) and is normalised, or refused, by _normalised.
    if mode == "first":
        try:
            status, face_a, face_b, bv, box, tri = _first_kernel(
                tree_a._packed, T_a, tree_b._packed, T_b
            )
        except (TypeError, AttributeError):
            args = _normalised(tree_a, T_a, tree_b, T_b)
            status, face_a, face_b, bv, box, tri = call_normalised(_first_kernel, *args)
        if status:
            _check_status(status, T_a, T_b)
        if face_a < 0:
            return CollisionResult(False, _NO_PAIRS, None, (bv, box, tri))
        pairs = np.array([[face_a, face_b]], dtype=np.int64)
        return CollisionResult(True, pairs, None, (bv, box, tri))
    if mode not in _MODES:
        raise ValueError(f"mode must be one of {_MODES}, got {mode!r}")
    args = _normalised(tree_a, T_a, tree_b, T_b)
    status, pairs, bv, box, tri = call_normalised(_all_kernel, *args)
    if status:
        _check_status(status, T_a, T_b)
    T_a = args[1]
    if len(pairs) > 1:
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    if mode == "all":
        return CollisionResult(len(pairs) > 0, pairs, None, (bv, box, tri))
    mesh_a = tree_a.mesh
    mesh_b = tree_b.mesh
    if merge_tolerance is None:
        merge_tolerance = MERGE_FRACTION * max(tree_a.scale, tree_b.scale)
    else:
        try:
            merge_tolerance = float(merge_tolerance)
        except (TypeError, ValueError):
            raise ValueError(f"merge_tolerance must be a number, got {merge_tolerance!r}") from None
        if not np.isfinite(merge_tolerance) or merge_tolerance < 0:
            raise ValueError(f"merge_tolerance must be finite and >= 0, got {merge_tolerance}")
    Rab, tab = _relative_pose(T_a, args[3])
    points, normals, depths, faces = compute_contacts(
        pairs, mesh_a.vertices, mesh_a.faces, mesh_b.vertices, mesh_b.faces, Rab, tab
    )
    before_merge = len(points)
    keep = merge_contacts(points, depths, merge_tolerance)
    points, normals = _to_world(points[keep], normals[keep], T_a)
    contacts = Contacts(points=points, normals=normals, depths=depths[keep], faces=faces[keep])
    return CollisionResult(len(pairs) > 0, pairs, contacts, (bv, box, tri, before_merge))
