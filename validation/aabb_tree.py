"""A flat AABB tree and cost-measuring traversals: the instrument of the OBB-vs-AABB study.

Thesis 4.2 argues with Gottschalk's cost function ``t = nv*cv + np*cp + nu*cu`` (BV tests
times their cost, primitive tests times theirs, BV updates times theirs) that oriented boxes
win where models are close: an AABB test is cheaper (small ``cv``) but fits worse (large
``nv`` and ``np``). This module measures the terms; it is not library API.

:class:`AABBTree` is built exactly like the classic (leaf) :class:`thesis_rbd.OBBTree`:
top-down, each node split at the mean of its triangles' centroids along the box's longest
axis (the next axes, then a split by count, when one side would be empty), one triangle per
leaf, 2m - 1 nodes as flat arrays. Boxes are axis-aligned in the mesh frame. Under a
relative rotation B's boxes are oriented in A's frame, so the box test is van den Bergen's
"SAT-lite": the 6 face axes of the two boxes (a conservative test: it may report an overlap
that the 9 edge-edge axes would reject, never the other way). The descent rule (split the
box with the longer half-extent) is the OBB tree's.

The tree has two uses, and its leaf test follows the use. As a test oracle of the OBB tree's
pair sets (:func:`aabb_collide`, by default) it decides triangle pairs with its own
separating-axis test (:mod:`validation.triangle_sat`), which shares no code with the
library's, so agreement is a check of both the traversal and the triangle test. As the cost
instrument of the OBB-vs-AABB study (``triangle_test="library"`` and the ``record_*`` and
``time_*`` functions) it uses the library's test (:func:`tri_tri_overlap`), so that the two
trees differ only in their boxes.

The ``record_*`` traversals return the sequence of tested box pairs and triangle pairs of a
query ("all" mode); the ``time_*`` kernels replay such a sequence doing only the box tests
(with the same carried-box reuse as the traversal) or only the triangle tests, which gives
the per-test costs ``cv`` and ``cp`` by timing.
"""

from __future__ import annotations

import time

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.packed import carry_box, half_extent, layout
from thesis_rbd.collision.mesh.triangle import tri_tri_overlap
from thesis_rbd.collision.queries.collide import _boxes_disjoint
from validation.triangle_sat import triangles_overlap

__all__ = [
    "AABBTree",
    "aabb_collide",
    "record_aabb_traversal",
    "record_obb_traversal",
    "relative_pose",
    "time_aabb_tests",
    "time_obb_tests",
    "time_triangle_tests",
]


@njit
def _split(centroids, order, start, end, lower, upper):
    """Partition ``order[start:end]`` at the mean centroid along the longest box axis."""
    count = end - start
    extent = upper - lower
    axes = np.argsort(-extent)
    for attempt in range(3):
        axis = axes[attempt]
        mean = 0.0
        for k in range(start, end):
            mean += centroids[order[k], axis]
        mean /= count
        i = start
        j = end - 1
        while i <= j:
            if centroids[order[i], axis] < mean:
                i += 1
            else:
                order[i], order[j] = order[j], order[i]
                j -= 1
        if start < i < end:
            return i
    return start + count // 2


@njit
def _build_aabb(tris):
    """Top-down build; returns (lower (n, 3), upper (n, 3), children (n, 2) int32, depth)."""
    m = tris.shape[0]
    n_nodes = 2 * m - 1
    lower = np.empty((n_nodes, 3))
    upper = np.empty((n_nodes, 3))
    children = np.zeros((n_nodes, 2), dtype=np.int32)
    centroids = np.empty((m, 3))
    for t in range(m):
        for i in range(3):
            centroids[t, i] = (tris[t, 0, i] + tris[t, 1, i] + tris[t, 2, i]) / 3.0
    order = np.arange(m)
    # Pending nodes: (node, start, end, level).
    stack = np.empty((m + 1, 4), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    stack[0, 2] = m
    stack[0, 3] = 1
    top = 1
    next_node = 1
    depth = 1
    while top > 0:
        top -= 1
        node = stack[top, 0]
        start = stack[top, 1]
        end = stack[top, 2]
        level = stack[top, 3]
        depth = max(depth, level)
        for i in range(3):
            lo = np.inf
            hi = -np.inf
            for k in range(start, end):
                for v in range(3):
                    lo = min(lo, tris[order[k], v, i])
                    hi = max(hi, tris[order[k], v, i])
            lower[node, i] = lo
            upper[node, i] = hi
        if end - start == 1:
            children[node, 0] = -order[start] - 1
            children[node, 1] = -order[start] - 1
            continue
        mid = _split(centroids, order, start, end, lower[node], upper[node])
        for side in range(2):
            children[node, side] = next_node
            stack[top, 0] = next_node
            stack[top, 1] = start if side == 0 else mid
            stack[top, 2] = mid if side == 0 else end
            stack[top, 3] = level + 1
            top += 1
            next_node += 1
    return lower, upper, children, np.int64(depth)


class AABBTree:
    """Bounding-volume hierarchy of axis-aligned boxes over a triangle mesh (2m - 1 nodes).

    Parameters
    ----------
    mesh : thesis_rbd.TriangleMesh
        The geometry in its own frame; the tree keeps a reference.

    Attributes
    ----------
    lower, upper : (n, 3) float64
        Box corners in the mesh frame.
    centers, half_extents : (n, 3) float64
        The same boxes as centre and half-sizes (what the traversal reads).
    children : (n, 2) int32
        ``k >= 0`` node ``k``; a leaf holds ``(-t - 1, -t - 1)`` for its triangle ``t``.
    depth : int
        Number of levels.
    """

    def __init__(self, mesh):
        self.mesh = mesh
        tris = np.ascontiguousarray(mesh.triangles, dtype=np.float64)
        self.lower, self.upper, self.children, depth = _build_aabb(tris)
        self.depth = int(depth)
        self.centers = 0.5 * (self.lower + self.upper)
        self.half_extents = 0.5 * (self.upper - self.lower)

    @property
    def node_count(self) -> int:
        """Number of box nodes, 2m - 1."""
        return int(self.children.shape[0])

    @property
    def nbytes(self) -> int:
        """Bytes of the node arrays as the traversal stores them (centre, half, children)."""
        return int(self.centers.nbytes + self.half_extents.nbytes + self.children.nbytes)


def relative_pose(T_a, T_b) -> tuple[np.ndarray, np.ndarray]:
    """``(R_ab, t_ab)`` of ``T_a^-1 T_b``: B's mesh frame expressed in A's.

    Parameters
    ----------
    T_a, T_b : (4, 4) array_like of float
        Rigid poses of the two meshes.

    Returns
    -------
    R_ab : (3, 3) float64
    t_ab : (3,) float64
    """
    T_a = np.asarray(T_a, dtype=np.float64)
    T_b = np.asarray(T_b, dtype=np.float64)
    R_ab = T_a[:3, :3].T @ T_b[:3, :3]
    t_ab = T_a[:3, :3].T @ (T_b[:3, 3] - T_a[:3, 3])
    return np.ascontiguousarray(R_ab), np.ascontiguousarray(t_ab)


@njit
def _moved_corner(V, F, t, k, R, tr):
    i = F[t, k]
    return (
        R[0, 0] * V[i, 0] + R[0, 1] * V[i, 1] + R[0, 2] * V[i, 2] + tr[0],
        R[1, 0] * V[i, 0] + R[1, 1] * V[i, 1] + R[1, 2] * V[i, 2] + tr[1],
        R[2, 0] * V[i, 0] + R[2, 1] * V[i, 1] + R[2, 2] * V[i, 2] + tr[2],
    )


@njit
def _triangles_intersect(ta, tb, Va, Fa, Vb, Fb, R, tr):
    """The OBB traversal's exact test on triangle ta of A and tb of B (carried into A)."""
    return tri_tri_overlap(
        (Va[Fa[ta, 0], 0], Va[Fa[ta, 0], 1], Va[Fa[ta, 0], 2]),
        (Va[Fa[ta, 1], 0], Va[Fa[ta, 1], 1], Va[Fa[ta, 1], 2]),
        (Va[Fa[ta, 2], 0], Va[Fa[ta, 2], 1], Va[Fa[ta, 2], 2]),
        _moved_corner(Vb, Fb, tb, 0, R, tr),
        _moved_corner(Vb, Fb, tb, 1, R, tr),
        _moved_corner(Vb, Fb, tb, 2, R, tr),
    )


@njit
def _triangles_overlap_sat(ta, tb, Va, Fa, Vb, Fb, R, tr):
    """The oracle's own test (``validation.triangle_sat``) on triangle ta of A and tb of B."""
    P = np.empty((3, 3))
    Q = np.empty((3, 3))
    for k in range(3):
        P[k] = Va[Fa[ta, k]]
        Q[k] = _moved_corner(Vb, Fb, tb, k, R, tr)
    return triangles_overlap(P, Q)


@njit
def _carry_aabb(y, cb, hb, R, tr):
    """B's box y in A's frame: centre ``R c + t`` (its axes are R's columns)."""
    return (
        R[0, 0] * cb[y, 0] + R[0, 1] * cb[y, 1] + R[0, 2] * cb[y, 2] + tr[0],
        R[1, 0] * cb[y, 0] + R[1, 1] * cb[y, 1] + R[1, 2] * cb[y, 2] + tr[1],
        R[2, 0] * cb[y, 0] + R[2, 1] * cb[y, 1] + R[2, 2] * cb[y, 2] + tr[2],
    )


@njit
def _aabbs_disjoint(x, ca, ha, c, y, hb, R, absR):
    """SAT-lite: A's box x against B's box y (centre ``c`` in A's frame, axes R's columns).

    Separating axes tried: A's three face normals, then B's. ``absR`` is ``|R|``.
    """
    d0 = c[0] - ca[x, 0]
    d1 = c[1] - ca[x, 1]
    d2 = c[2] - ca[x, 2]
    b0 = hb[y, 0]
    b1 = hb[y, 1]
    b2 = hb[y, 2]
    if abs(d0) > ha[x, 0] + absR[0, 0] * b0 + absR[0, 1] * b1 + absR[0, 2] * b2:
        return True
    if abs(d1) > ha[x, 1] + absR[1, 0] * b0 + absR[1, 1] * b1 + absR[1, 2] * b2:
        return True
    if abs(d2) > ha[x, 2] + absR[2, 0] * b0 + absR[2, 1] * b1 + absR[2, 2] * b2:
        return True
    a0 = ha[x, 0]
    a1 = ha[x, 1]
    a2 = ha[x, 2]
    for j in range(3):
        s = R[0, j] * d0 + R[1, j] * d1 + R[2, j] * d2
        if abs(s) > hb[y, j] + absR[0, j] * a0 + absR[1, j] * a1 + absR[2, j] * a2:
            return True
    return False


@njit(inline="always")
def _push_children(stack, top, x, y, a_leaf, b_leaf, ha, hb, cha, chb):
    """Push the children of the larger box of node pair (x, y), growing the stack if full.

    The same descent rule as ``collide``'s traversal: split B when A is a leaf or B's
    longest half-extent is larger, else split A. Returns (stack, top).
    """
    if top + 2 > stack.shape[0]:
        bigger = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
        bigger[:top] = stack[:top]
        stack = bigger
    size_a = max(ha[x, 0], ha[x, 1], ha[x, 2])
    size_b = max(hb[y, 0], hb[y, 1], hb[y, 2])
    if a_leaf or (not b_leaf and size_b > size_a):
        stack[top, 0], stack[top, 1] = x, chb[y, 1]
        stack[top + 1, 0], stack[top + 1, 1] = x, chb[y, 0]
    else:
        stack[top, 0], stack[top, 1] = cha[x, 1], y
        stack[top + 1, 0], stack[top + 1, 1] = cha[x, 0], y
    return stack, top + 2


@njit
def _aabb_traverse(first_only, record, own_test, ca, ha, cha, Va, Fa, cb, hb, chb, Vb, Fb, R, tr):
    """Walk two AABB trees; return (pairs, bv_tests, tri_tests, box_log, tri_log).

    With ``record`` the tested box pairs and triangle pairs are logged in order (else the
    logs are empty). ``own_test`` decides triangle pairs with the oracle's own test, else
    with the library's.
    """
    absR = np.abs(R)
    pairs = np.empty((64, 2), dtype=np.int64)
    n_pairs = 0
    box_log = np.empty((1024 if record else 0, 2), dtype=np.int64)
    tri_log = np.empty((1024 if record else 0, 2), dtype=np.int64)
    stack = np.empty((64, 2), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    top = 1
    bv_tests = 0
    tri_tests = 0
    carried = -1
    c = (0.0, 0.0, 0.0)
    while top > 0:
        top -= 1
        x = stack[top, 0]
        y = stack[top, 1]
        if record:
            if bv_tests == box_log.shape[0]:
                bigger = np.empty((2 * bv_tests, 2), dtype=np.int64)
                bigger[:bv_tests] = box_log
                box_log = bigger
            box_log[bv_tests, 0] = x
            box_log[bv_tests, 1] = y
        bv_tests += 1
        if y != carried:
            c = _carry_aabb(y, cb, hb, R, tr)
            carried = y
        if _aabbs_disjoint(x, ca, ha, c, y, hb, R, absR):
            continue
        a_leaf = cha[x, 0] < 0
        b_leaf = chb[y, 0] < 0
        if a_leaf and b_leaf:
            ta = -cha[x, 0] - 1
            tb = -chb[y, 0] - 1
            if record:
                if tri_tests == tri_log.shape[0]:
                    bigger = np.empty((2 * tri_tests, 2), dtype=np.int64)
                    bigger[:tri_tests] = tri_log
                    tri_log = bigger
                tri_log[tri_tests, 0] = ta
                tri_log[tri_tests, 1] = tb
            tri_tests += 1
            if own_test:
                hit = _triangles_overlap_sat(ta, tb, Va, Fa, Vb, Fb, R, tr)
            else:
                hit = _triangles_intersect(ta, tb, Va, Fa, Vb, Fb, R, tr)
            if hit:
                if n_pairs == pairs.shape[0]:
                    bigger = np.empty((2 * n_pairs, 2), dtype=np.int64)
                    bigger[:n_pairs] = pairs
                    pairs = bigger
                pairs[n_pairs, 0] = ta
                pairs[n_pairs, 1] = tb
                n_pairs += 1
                if first_only:
                    break
            continue
        stack, top = _push_children(stack, top, x, y, a_leaf, b_leaf, ha, hb, cha, chb)
    return pairs[:n_pairs].copy(), bv_tests, tri_tests, box_log[:bv_tests], tri_log[:tri_tests]


def _sorted_pairs(pairs: np.ndarray) -> np.ndarray:
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if len(pairs) > 1 else pairs


def aabb_collide(tree_a, T_a, tree_b, T_b, mode: str = "all", triangle_test: str = "own"):
    """Intersect two meshes through their AABB trees.

    Parameters
    ----------
    tree_a, tree_b : AABBTree
    T_a, T_b : (4, 4) array_like of float
        Rigid poses of the meshes.
    mode : {"first", "all"}
        Stop at the first intersecting triangle pair, or find them all.
    triangle_test : {"own", "library"}
        The oracle's own separating-axis test, or the library's (for cost comparisons).

    Returns
    -------
    pairs : (k, 2) int64
        [face of A, face of B], sorted ("all": every intersecting pair once).
    stats : dict
        ``bv_tests`` (box pairs tested, nv) and ``tri_tests`` (triangle pairs tested, np).
    """
    if triangle_test not in ("own", "library"):
        raise ValueError(f"triangle_test must be 'own' or 'library', got {triangle_test!r}")
    R, tr = relative_pose(T_a, T_b)
    mesh_a, mesh_b = tree_a.mesh, tree_b.mesh
    pairs, bv_tests, tri_tests, _, _ = _aabb_traverse(
        mode == "first", False, triangle_test == "own",
        tree_a.centers, tree_a.half_extents, tree_a.children, mesh_a.vertices, mesh_a.faces,
        tree_b.centers, tree_b.half_extents, tree_b.children, mesh_b.vertices, mesh_b.faces,
        R, tr,
    )  # fmt: skip
    return _sorted_pairs(pairs), {"bv_tests": int(bv_tests), "tri_tests": int(tri_tests)}


def record_aabb_traversal(tree_a, T_a, tree_b, T_b):
    """An "all" query's tested box pairs (nv, 2) and triangle pairs (np, 2), in order.

    Parameters
    ----------
    tree_a, tree_b : AABBTree
    T_a, T_b : (4, 4) array_like of float

    Returns
    -------
    box_pairs : (nv, 2) int64
        [node of A, node of B] of every box test.
    triangle_pairs : (np, 2) int64
        [face of A, face of B] of every triangle test.
    """
    R, tr = relative_pose(T_a, T_b)
    mesh_a, mesh_b = tree_a.mesh, tree_b.mesh
    _, _, _, box_log, tri_log = _aabb_traverse(
        False, True, False,
        tree_a.centers, tree_a.half_extents, tree_a.children, mesh_a.vertices, mesh_a.faces,
        tree_b.centers, tree_b.half_extents, tree_b.children, mesh_b.vertices, mesh_b.faces,
        R, tr,
    )  # fmt: skip
    return box_log, tri_log


@njit
def _obb_record(Pa, cha, Pb, hb, chb, M, tr):
    """The classic (leaf) OBB tree's "all" traversal, logging its tests.

    Mirrors :func:`thesis_rbd.collision.queries.collide.traverse` for two leaf trees (no first-mode
    child ordering); trees as their packed query arrays for the box tests, plus the arrays
    the descent reads. Returns (box_log (nv, 2), tri_log (np, 2)).
    """
    La = layout(Pa)
    Lb = layout(Pb)
    ha = Pa[La[1] : La[2]]
    box_log = np.empty((1024, 2), dtype=np.int64)
    tri_log = np.empty((1024, 2), dtype=np.int64)
    stack = np.empty((64, 2), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    top = 1
    nv = 0
    n_tri = 0
    carried = -1
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    c = (0.0, 0.0, 0.0)
    hy = (0.0, 0.0, 0.0)
    while top > 0:
        top -= 1
        x = stack[top, 0]
        y = stack[top, 1]
        if nv == box_log.shape[0]:
            bigger = np.empty((2 * nv, 2), dtype=np.int64)
            bigger[:nv] = box_log
            box_log = bigger
        box_log[nv, 0] = x
        box_log[nv, 1] = y
        nv += 1
        if y != carried:
            g, c = carry_box(y, Pb, Lb, M, tr)
            hy = half_extent(Pb, Lb, y)
            carried = y
        if _boxes_disjoint(x, Pa, La, g, c, hy):
            continue
        a_leaf = cha[x, 0] < 0
        b_leaf = chb[y, 0] < 0
        if a_leaf and b_leaf:
            if n_tri == tri_log.shape[0]:
                bigger = np.empty((2 * n_tri, 2), dtype=np.int64)
                bigger[:n_tri] = tri_log
                tri_log = bigger
            tri_log[n_tri, 0] = -cha[x, 0] - 1
            tri_log[n_tri, 1] = -chb[y, 0] - 1
            n_tri += 1
            continue
        stack, top = _push_children(stack, top, x, y, a_leaf, b_leaf, ha, hb, cha, chb)
    return box_log[:nv].copy(), tri_log[:n_tri].copy()


def _row_major(R) -> tuple:
    return tuple(float(v) for v in np.asarray(R).ravel())


def record_obb_traversal(tree_a, T_a, tree_b, T_b):
    """An "all" query's tested box pairs and triangle pairs for two classic OBB trees.

    Parameters
    ----------
    tree_a, tree_b : thesis_rbd.OBBTree
        Trees built with ``leafless=False`` (float64).
    T_a, T_b : (4, 4) array_like of float

    Returns
    -------
    box_pairs : (nv, 2) int64
    triangle_pairs : (np, 2) int64
    """
    if tree_a.leafless or tree_b.leafless:
        raise ValueError("record_obb_traversal needs classic (leafless=False) OBB trees")
    R, tr = relative_pose(T_a, T_b)
    return _obb_record(
        tree_a.query_array(), tree_a.children,
        tree_b.query_array(), tree_b.half_extents, tree_b.children,
        _row_major(R), (float(tr[0]), float(tr[1]), float(tr[2])),
    )  # fmt: skip


@njit
def _replay_obb_tests(box_pairs, Pa, Pb, M, tr):
    La = layout(Pa)
    Lb = layout(Pb)
    disjoint = 0
    carried = -1
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    c = (0.0, 0.0, 0.0)
    hy = (0.0, 0.0, 0.0)
    for k in range(box_pairs.shape[0]):
        x = box_pairs[k, 0]
        y = box_pairs[k, 1]
        if y != carried:
            g, c = carry_box(y, Pb, Lb, M, tr)
            hy = half_extent(Pb, Lb, y)
            carried = y
        if _boxes_disjoint(x, Pa, La, g, c, hy):
            disjoint += 1
    return disjoint


@njit
def _replay_aabb_tests(box_pairs, ca, ha, cb, hb, R, tr):
    absR = np.abs(R)
    disjoint = 0
    carried = -1
    c = (0.0, 0.0, 0.0)
    for k in range(box_pairs.shape[0]):
        x = box_pairs[k, 0]
        y = box_pairs[k, 1]
        if y != carried:
            c = _carry_aabb(y, cb, hb, R, tr)
            carried = y
        if _aabbs_disjoint(x, ca, ha, c, y, hb, R, absR):
            disjoint += 1
    return disjoint


@njit
def _replay_triangle_tests(triangle_pairs, Va, Fa, Vb, Fb, R, tr):
    hits = 0
    for k in range(triangle_pairs.shape[0]):
        if _triangles_intersect(triangle_pairs[k, 0], triangle_pairs[k, 1], Va, Fa, Vb, Fb, R, tr):
            hits += 1
    return hits


def _best_seconds(call, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return float(best)


def time_obb_tests(tree_a, T_a, tree_b, T_b, box_pairs, repeats: int = 3) -> float:
    """Seconds (best of ``repeats``) to replay the OBB tests ``box_pairs`` of one query.

    Parameters
    ----------
    tree_a, tree_b : thesis_rbd.OBBTree
    T_a, T_b : (4, 4) array_like of float
    box_pairs : (nv, 2) int64
        From :func:`record_obb_traversal`.
    repeats : int

    Returns
    -------
    float
    """
    R, tr = relative_pose(T_a, T_b)
    M, t = _row_major(R), (float(tr[0]), float(tr[1]), float(tr[2]))
    args = (box_pairs, tree_a.query_array(), tree_b.query_array(), M, t)
    return _best_seconds(lambda: _replay_obb_tests(*args), repeats)


def time_aabb_tests(tree_a, T_a, tree_b, T_b, box_pairs, repeats: int = 3) -> float:
    """Seconds (best of ``repeats``) to replay the AABB tests ``box_pairs`` of one query.

    Parameters
    ----------
    tree_a, tree_b : AABBTree
    T_a, T_b : (4, 4) array_like of float
    box_pairs : (nv, 2) int64
        From :func:`record_aabb_traversal`.
    repeats : int

    Returns
    -------
    float
    """
    R, tr = relative_pose(T_a, T_b)
    args = (
        box_pairs, tree_a.centers, tree_a.half_extents,
        tree_b.centers, tree_b.half_extents, R, tr,
    )  # fmt: skip
    return _best_seconds(lambda: _replay_aabb_tests(*args), repeats)


def time_triangle_tests(mesh_a, T_a, mesh_b, T_b, triangle_pairs, repeats: int = 3) -> float:
    """Seconds (best of ``repeats``) to replay the triangle tests ``triangle_pairs``.

    Parameters
    ----------
    mesh_a, mesh_b : thesis_rbd.TriangleMesh
    T_a, T_b : (4, 4) array_like of float
    triangle_pairs : (np, 2) int64
        [face of A, face of B] of the tests, from a recorded traversal.
    repeats : int

    Returns
    -------
    float
    """
    R, tr = relative_pose(T_a, T_b)
    args = (triangle_pairs, mesh_a.vertices, mesh_a.faces, mesh_b.vertices, mesh_b.faces, R, tr)
    return _best_seconds(lambda: _replay_triangle_tests(*args), repeats)
