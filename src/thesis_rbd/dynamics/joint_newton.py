"""An island's Newton matrix for one substep: its joint rows where the substep begins, their
responses M^-1 J^T, and K = J M^-1 J^T factorised once, for both of the substep's solves.

The motors (``joint_motors``) solve with every joint row of the island held, and the
projection (``joint_solver.project_island``) puts the joints back together by Newton's
method; both need K at the island's pose. It is made where the substep begins, after the
forces and before the bodies move: the motors' solve is exact there, and the projection's
iterations, whose rows are taken where the bodies have moved to, converge with it as a
quasi-Newton matrix (it differs from theirs by the substep's turn, h w, a few hundredths),
as they already did from their first iterate on. A limit reached or left on the way changes
which rows act, and the projection makes the matrix again (``factor``).

Factorisation (``joint_tree``): block by block in linear time where the island is a tree,
dense L U where it has a closed loop; rows of a vanishing pivot (a limit not reached, a
redundant row of a loop) are dropped.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.joint_rows import (
    body_pose,
    coupling_block,
    coupling_matrix,
    joint_row_count,
    joint_rows,
    row_responses,
    row_written,
)
from thesis_rbd.dynamics.joint_set import BODY_A, BODY_B, KIND
from thesis_rbd.dynamics.joint_tree import factor_tree, left_solve, lu_in_place, solve_tree

__all__ = ["factor", "factor_at_start", "island_rows", "newton_scratch", "newton_solve"]


@njit
def newton_scratch(joints, bodies, ints, floats, neighbour_start, neighbour, tree):
    """The arrays an island's substeps work in, made once per step: the rows at the
    substep's start and now (r, 10), each row's joint (r,) and its bodies' places among
    ``bodies`` (r, 2) (-1: the world or frozen), M^-1 J^T (r, 12), the block layout of a
    tree or the dense matrix of a loop, the Newton step (r,), the per-body turns (b, 3), the
    rows a dense factor kept (r,) and the rows written when the factor was made (r,).

    Parameters
    ----------
    joints : (j,) int64
        The island's joints, in elimination order.
    bodies : (b,) int64
        The island's moving bodies, increasing.
    ints, floats : ``JointSet`` arrays.
    neighbour_start, neighbour : (j + 1,), (p,) int64
        The island's joints' later neighbours: its slice of ``joint_tree.later_neighbours``'s
        starts, which index the whole ``neighbour`` of every island.
    tree : bool
        Whether the island is a tree.
    """
    size = 0
    for j in joints:
        size += joint_row_count(ints[j, KIND], floats[j])
    row_joint = np.empty(size, np.int64)
    row_body = np.empty((size, 2), np.int64)
    r = 0
    for j in joints:
        for _ in range(joint_row_count(ints[j, KIND], floats[j])):
            row_joint[r] = j
            for side in range(2):
                body = ints[j, BODY_A + side]
                row_body[r, side] = -1 if body < 0 else np.searchsorted(bodies, body)
            r += 1
    layout = _tree_layout(joints, ints, floats, neighbour_start, neighbour, tree)
    K = np.empty((0, 0)) if tree else np.empty((size, size))
    return (
        np.empty((size, 10)), np.empty((size, 10)), row_joint, row_body,
        np.empty((size, 12)), layout, K, np.empty(size), np.empty((len(bodies), 3)),
        np.ones(size, np.bool_), np.zeros(size, np.bool_),
    )  # fmt: skip


@njit(allocates=False)
def factor_at_start(joints, tree, ints, floats, frozen, position, orientation, inverse_mass,
                    inverse_inertia_body, scratch):  # fmt: skip
    """Where the substep begins (the bodies at ``position``, ``orientation``): the island's
    rows with every limit row written (their directions, which the projection moves the
    bodies along), their responses, the rows as they act (limits not reached written as
    zero), and K of the two factorised (``factor``). Body arrays as ``integrate_bodies``'s."""
    rows, current, row_joint = scratch[0], scratch[1], scratch[2]
    moved = scratch[4]
    island_rows(joints, ints, floats, position, orientation, rows, row_joint, False)
    row_responses(rows, row_joint, rows.shape[0], ints, frozen, orientation, inverse_mass,
                  inverse_inertia_body, moved)  # fmt: skip
    island_rows(joints, ints, floats, position, orientation, current, row_joint, True)
    factor(tree, ints, scratch)


@njit(allocates=False)
def factor(tree, ints, scratch):
    """K = current M^-1 rows^T of the scratch, factorised in place, and which rows of
    ``current`` were written (acting) when it was made."""
    rows, current, row_joint, _, moved, layout, K, _, _, kept, factored_rows = scratch
    size = rows.shape[0]
    for k in range(size):
        factored_rows[k] = row_written(current, k)
    if tree:
        _tree_factor(layout, ints, row_joint, current, moved)
    else:
        coupling_matrix(ints, row_joint, current, moved, size, K)
        lu_in_place(K, size, kept)


@njit(allocates=False)
def newton_solve(tree, scratch, X):
    """X (r, m) <- K^-1 X, each column, with the factor ``factor`` made (dropped rows get
    zero)."""
    layout, K, kept = scratch[5], scratch[6], scratch[9]
    if tree:
        rows_of, row_start, self_slot, slot_neighbour, upper, lower, kept_blocks = layout
        solve_tree(rows_of, row_start, self_slot, slot_neighbour, upper, lower, kept_blocks, X)
    else:
        left_solve(K, kept, X.shape[0], X, 0)


@njit(allocates=False)
def island_rows(joints, ints, floats, position, orientation, rows, row_joint, active_only):
    """The rows of the island's ``joints`` at the given poses into ``rows``, and the joint of
    each row (``active_only``: limit rows as ``joint_rows``'s ``active_limits_only``)."""
    r = 0
    for j in joints:
        xa, qa = body_pose(ints[j, BODY_A], position, orientation)
        xb, qb = body_pose(ints[j, BODY_B], position, orientation)
        n = joint_rows(ints[j, KIND], floats[j], xa, qa, xb, qb, rows, r, active_only)
        for k in range(r, r + n):
            row_joint[k] = j
        r += n


@njit
def _tree_layout(joints, ints, floats, neighbour_start, neighbour, tree):
    """The block layout of ``joint_tree`` for an island (empty unless ``tree``): rows and
    row starts per joint, slots, each slot's neighbour, and the block and mask storage."""
    p = len(joints) if tree else 0
    rows = np.empty(p, np.int64)
    row_start = np.empty(p + 1, np.int64)
    self_slot = np.empty(p + 1, np.int64)
    slots = p + (neighbour_start[p] - neighbour_start[0] if tree else 0)
    slot_neighbour = np.full(slots, -1, np.int64)
    row_start[0] = 0
    self_slot[0] = 0
    for e in range(p):
        rows[e] = joint_row_count(ints[joints[e], KIND], floats[joints[e]])
        row_start[e + 1] = row_start[e] + rows[e]
        later = neighbour_start[e + 1] - neighbour_start[e]
        for k in range(later):  # neighbour_start holds offsets into the whole neighbour
            slot_neighbour[self_slot[e] + 1 + k] = neighbour[neighbour_start[e] + k]
        self_slot[e + 1] = self_slot[e] + 1 + later
    upper = np.zeros((slots, 6, 6))
    lower = np.zeros((slots, 6, 6))
    kept = np.zeros((p, 6), np.bool_)
    return rows, row_start, self_slot, slot_neighbour, upper, lower, kept


@njit(allocates=False)
def _tree_factor(layout, ints, row_joint, current, moved):
    """The blocks of current M^-1 rows^T in the layout, factorised by ``joint_tree``."""
    rows, row_start, self_slot, slot_neighbour, upper, lower, kept = layout
    for e in range(len(rows)):
        for s in range(self_slot[e], self_slot[e + 1]):
            f = e if s == self_slot[e] else slot_neighbour[s]
            coupling_block(ints, row_joint, current, moved, row_start[e], rows[e],
                           row_start[f], rows[f], upper[s])  # fmt: skip
            if f != e:
                coupling_block(ints, row_joint, current, moved, row_start[f], rows[f],
                               row_start[e], rows[e], lower[s])  # fmt: skip
    factor_tree(rows, self_slot, slot_neighbour, upper, lower, kept)
