"""A jointed island's Newton matrix solved in time linear in its joints where it is a tree.

The matrix K = J M^-1 J^T couples two joints only through a moving body they share, so its
block pattern is the *line graph* of the island (joints as vertices, linked when they share a
body). Where the bodies and joints form a tree (the world and static bodies counted as one
ground node), that graph is chordal, and eliminating the joints deepest first (farthest from
the ground, or from the island's first body) creates no fill: when a joint is eliminated, the
joints it still touches all share its parent body, and are already linked. Block Gaussian
elimination in that order touches only the blocks of K itself: a chain's K is block
tridiagonal and costs O(links), a ragdoll's no more than its joints' neighbourhoods (Baraff,
"Linear-time dynamics using Lagrange multipliers", SIGGRAPH 1996, eliminates the same tree).

Islands with a closed loop (a four-bar linkage, a body jointed twice to the world) are solved
densely, by the same L U as a diagonal block (``lu_in_place``, ``left_solve``).

Layout per island, in elimination order: joint position e has rows ``row_start[e] ..
row_start[e] + rows[e]`` of the island, and blocks in slots: slot ``self_slot[e]`` is (e, e),
the slots after it up to ``self_slot[e + 1]`` are (e, f) for each later neighbour f
(``neighbour[slot]``, island positions, increasing). A slot holds the upper block K_ef and the
lower block K_fe (6 x 6 storage, the joint's rows used).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import shortest_path

from thesis_rbd._numba.jit import njit

__all__ = [
    "elimination_order",
    "factor_tree",
    "fixed_base_trees",
    "later_neighbours",
    "left_solve",
    "lu_in_place",
    "solve_tree",
]

# A pivot below this fraction of its block's largest entry marks a redundant row.
_REDUNDANT = 1e-10


def elimination_order(a, b, static, joint_island, island_count):
    """Joints ordered for elimination within each island, and which islands are trees.

    Parameters
    ----------
    a, b : (m,) int64
        Each joint's bodies (b = -1: the world).
    static : (n,) bool
    joint_island : (m,) int64
        The island of each joint.
    island_count : int

    Returns
    -------
    depth : (m,) int64
        Each joint's distance from its island's root (eliminated deepest first).
    tree : (island_count,) bool
        Whether the island's joints form a tree (no closed loop through bodies or ground).
    """
    n = len(static)
    ground = n
    # every static body and the world is the ground node
    node_a = np.where(static[a], ground, a)
    node_b = np.where((b < 0) | static[np.maximum(b, 0)], ground, b)
    on_ground = (node_a == ground) | (node_b == ground)
    grounded = np.zeros(island_count, bool)
    grounded[joint_island[on_ground]] = True
    # an island that touches no ground is rooted at its first joint's moving body
    first = np.full(island_count, -1)
    first[joint_island[::-1]] = np.where(node_a != ground, node_a, node_b)[::-1]
    roots = first[~grounded]
    rows = np.concatenate([node_a, roots])
    cols = np.concatenate([node_b, np.full(len(roots), ground)])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n + 1, n + 1)).tocsr()
    node_depth = shortest_path(graph, directed=False, unweighted=True, indices=ground)
    depth = np.maximum(node_depth[node_a], node_depth[node_b]).astype(np.int64)
    # a tree has one joint fewer than it has nodes (the ground counts where it is touched)
    joints = np.bincount(joint_island, minlength=island_count)
    moving = np.concatenate([node_a[node_a != ground], node_b[node_b != ground]])
    moving_island = np.concatenate([joint_island[node_a != ground], joint_island[node_b != ground]])
    _, first_seen = np.unique(moving, return_index=True)
    bodies = np.bincount(moving_island[first_seen], minlength=island_count)
    tree = joints == bodies + grounded - 1
    return depth, tree


def fixed_base_trees(a, b, static, island_joints, joint_start, tree, articulable):
    """Which islands hang from the ground as a tree of joints ``articulable`` marks (the kinds
    ``articulated`` steps in joint coordinates), and each joint's place in its tree.

    Parameters
    ----------
    a, b : (m,) int64
        Each joint's bodies (b = -1: the world).
    static : (n,) bool
    island_joints, joint_start : (m,), (k + 1,) int64
        The islands' joints in elimination order (``elimination_order``: deepest first).
    tree : (k,) bool
        Whether each island is a tree.
    articulable : (m,) bool

    Returns
    -------
    fixed_base : (k,) bool
        Islands that are trees of articulable joints rooted at the ground (the world or a
        static body) by one of them.
    parents : (m,) int64
        For each joint slot, its parent joint's position within its island (-1: the joint
        to the ground, and for every joint of an island that is not a fixed-base tree).
    sides : (m,) int64
        Which of its bodies is the child, farther from the ground: 0 for a, 1 for b.
    """
    ground = len(static)
    node_a = np.where(static[a], ground, a)
    node_b = np.where((b < 0) | static[np.maximum(b, 0)], ground, b)
    parents = np.full(len(island_joints), -1, np.int64)
    sides = np.zeros(len(island_joints), np.int64)
    fixed_base = np.zeros(len(joint_start) - 1, bool)
    for island in np.flatnonzero(tree):
        first, last = joint_start[island], joint_start[island + 1]
        slots = island_joints[first:last]
        if not articulable[slots].all():
            continue
        # from the ground out (the reverse of elimination order): each joint's parent body is
        # the ground or a body an earlier joint reached
        reached = {ground: -1}
        for position in range(last - first - 1, -1, -1):
            j = slots[position]
            if node_b[j] in reached and node_a[j] not in reached:
                child, parent, side = node_a[j], node_b[j], 0
            elif node_a[j] in reached and node_b[j] not in reached:
                child, parent, side = node_b[j], node_a[j], 1
            else:  # a floating island's root joint: neither body is the ground
                break
            parents[first + position] = reached[parent]
            sides[first + position] = side
            reached[child] = position
        else:
            fixed_base[island] = True
    return fixed_base, parents, sides


def later_neighbours(a, b, static, island_joints, joint_start):
    """For each joint (in the order of ``island_joints``), the later joints of its island
    that share a moving body with it.

    Returns
    -------
    neighbour_start : (m + 1,) int64
        Joint slot s (index into ``island_joints``) has later neighbours
        ``neighbour[neighbour_start[s]:neighbour_start[s + 1]]``, as positions within its
        island, increasing.
    neighbour : (p,) int64
    """
    m = len(island_joints)
    n = len(static)
    slot_of = np.empty(m, np.int64)
    slot_of[island_joints] = np.arange(m)
    island_of_slot = np.repeat(np.arange(len(joint_start) - 1), np.diff(joint_start))
    position = np.arange(m) - joint_start[island_of_slot]
    joint = np.concatenate([np.arange(m), np.arange(m)])
    body = np.concatenate([a, b])
    moving = (body >= 0) & ~static[np.maximum(body, 0)]
    incidence = csr_matrix(
        (np.ones(int(moving.sum())), (slot_of[joint[moving]], body[moving])), shape=(m, n)
    )
    shared = (incidence @ incidence.T).tocoo()
    keep = shared.col > shared.row
    rows, cols = shared.row[keep], shared.col[keep]
    order = np.lexsort((cols, rows))
    rows, cols = rows[order], cols[order]
    start = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=m))])
    return start.astype(np.int64), position[cols].astype(np.int64)


@njit(allocates=False)
def lu_in_place(D, r, kept):
    """L U of the r x r leading block of D in place, without pivoting (D is J M^-1 J^T taken
    at two nearby poses, nearly symmetric positive semi-definite). Writes which rows are kept
    into kept[:r] (bool): a row whose pivot vanishes (below ``_REDUNDANT`` of its row's
    largest entry left of and on the diagonal, as the elimination left it) is redundant, its
    constraint held by the others, and is dropped."""
    for j in range(r):
        kept[j] = True
        largest = 0.0
        for k in range(j + 1):
            largest = max(largest, abs(D[j, k]))
        if not abs(D[j, j]) > _REDUNDANT * largest:
            kept[j] = False
            continue
        for i in range(j + 1, r):
            factor = D[i, j] / D[j, j]
            D[i, j] = factor
            for k in range(j + 1, r):
                D[i, k] -= factor * D[j, k]


@njit(allocates=False)
def left_solve(D, kept, r, X, offset):
    """X[offset:offset + r] <- D^-1 X[...] with the factor of ``lu_in_place``, for each
    column of X (n, m) at once (a vector as (n, 1))."""
    m = X.shape[1]
    for i in range(r):
        if not kept[i]:
            X[offset + i, :] = 0.0
            continue
        for k in range(i):
            if kept[k]:
                factor = D[i, k]
                for col in range(m):
                    X[offset + i, col] -= factor * X[offset + k, col]
    for i in range(r - 1, -1, -1):
        if not kept[i]:
            continue
        for k in range(i + 1, r):
            if kept[k]:
                factor = D[i, k]
                for col in range(m):
                    X[offset + i, col] -= factor * X[offset + k, col]
        pivot = D[i, i]
        for col in range(m):
            X[offset + i, col] /= pivot


@njit(allocates=False)
def _right_divide(D, kept, r, B, rows):
    """B[:rows, :r] <- B D^-1 (each row y solves y D = b) with the factor of D."""
    for row in range(rows):
        # y U = b (U upper, dropped columns zero), then y L = z (L unit lower)
        for i in range(r):
            if not kept[i]:
                B[row, i] = 0.0
                continue
            for k in range(i):
                if kept[k]:
                    B[row, i] -= B[row, k] * D[k, i]
            B[row, i] /= D[i, i]
        for i in range(r - 1, -1, -1):
            if not kept[i]:
                continue
            for k in range(i + 1, r):
                if kept[k]:
                    B[row, i] -= B[row, k] * D[k, i]


@njit(allocates=False)
def _slot(self_slot, neighbour, e, f):
    """The slot holding the blocks of island positions e < f (or e == f)."""
    if e == f:
        return self_slot[e]
    for s in range(self_slot[e] + 1, self_slot[e + 1]):
        if neighbour[s] == f:
            return s
    return -1


@njit(allocates=False)
def factor_tree(rows, self_slot, neighbour, upper, lower, kept):
    """Block L U of an island's matrix in elimination order, in place (module docstring).

    Parameters
    ----------
    rows : (p,) int64
        Rows of each joint.
    self_slot, neighbour : (p + 1,), (slots,) int64
        The block layout.
    upper, lower : (slots, 6, 6) float64
        K's blocks; out: U's off-diagonal blocks and the diagonal blocks' factors in
        ``upper``, L's blocks (K_fe D_e^-1) in ``lower``.
    kept : (p, 6) bool
        Out: the rows of each diagonal block that were not dropped as redundant.
    """
    p = len(rows)
    for e in range(p):
        s = self_slot[e]
        lu_in_place(upper[s], rows[e], kept[e])
        for sf in range(s + 1, self_slot[e + 1]):
            f = neighbour[sf]
            _right_divide(upper[s], kept[e], rows[e], lower[sf], rows[f])
        # the later neighbours' blocks lose L_fe U_eg
        for sf in range(s + 1, self_slot[e + 1]):
            f = neighbour[sf]
            for sg in range(s + 1, self_slot[e + 1]):
                g = neighbour[sg]
                if f <= g:
                    target = upper[_slot(self_slot, neighbour, f, g)]
                else:
                    target = lower[_slot(self_slot, neighbour, g, f)]
                for i in range(rows[f]):
                    for k in range(rows[g]):
                        total = 0.0
                        for c in range(rows[e]):
                            total += lower[sf, i, c] * upper[sg, c, k]
                        target[i, k] -= total


@njit(allocates=False)
def solve_tree(rows, row_start, self_slot, neighbour, upper, lower, kept, X):
    """Solve K X = B in place of B (n, m), every column at once, with the factor of
    ``factor_tree``."""
    p = len(rows)
    m = X.shape[1]
    for e in range(p):
        for sf in range(self_slot[e] + 1, self_slot[e + 1]):
            f = neighbour[sf]
            for i in range(rows[f]):
                for c in range(rows[e]):
                    factor = lower[sf, i, c]
                    if factor != 0.0:
                        for col in range(m):
                            X[row_start[f] + i, col] -= factor * X[row_start[e] + c, col]
    for e in range(p - 1, -1, -1):
        for sf in range(self_slot[e] + 1, self_slot[e + 1]):
            f = neighbour[sf]
            for c in range(rows[e]):
                for k in range(rows[f]):
                    factor = upper[sf, c, k]
                    if factor != 0.0:
                        for col in range(m):
                            X[row_start[e] + c, col] -= factor * X[row_start[f] + k, col]
        left_solve(upper[self_slot[e]], kept[e], rows[e], X, row_start[e])
