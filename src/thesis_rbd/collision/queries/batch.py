"""Pose batches: one query over a stack of poses in a single kernel call.

A motion planner asks whether (or how far apart) two meshes are at hundreds of poses along a
path; calling :func:`thesis_rbd.collide` or :func:`thesis_rbd.distance` once per pose pays
the Python wrapper each time. :func:`collide_batch` and :func:`distance_batch` take a stack of
poses (k, 4, 4) for either mesh, the other mesh at one pose (4, 4) or at a stack of the same
length, and loop inside numba over the same kernels the single queries use, so each answer
equals the single query's.

:func:`collide_batch` shares its poses out among numba's threads (``numba.set_num_threads``
or ``NUMBA_NUM_THREADS``; by default one per core) and, along each thread's runs of
consecutive poses, tries the triangle pair that intersected at the previous pose before
walking the trees, and starts a walk after an apart pose from the pairs found disjoint there.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.packed import layout
from thesis_rbd.collision.queries._query_args import (
    call_normalised,
    pose_ok,
    relative_pose,
    sealed,
)
from thesis_rbd.collision.queries.collide import (
    faces_intersect,
    roots_disjoint,
    walk,
    walk_stack,
    with_room,
)
from thesis_rbd.collision.queries.distance import pose_stacks, stacked_distances

__all__ = ["collide_batch", "distance_batch"]

# How many poses after an apart one start their walks from its front (the pairs its walk from
# the roots found disjoint); the pose after them walks from the roots again.
FRONT_POSES = 2
# Rows of a run's first front (it grows as needed).
FRONT_ROWS = 256

# Runs of consecutive poses per thread: more runs even out the threads' work on a stack whose
# costly poses cluster, fewer keep more of a path's witnesses (one is lost per run).
RUNS_PER_THREAD = 4


@njit(allocates=False)
def _relative_pose_at(T_a, T_b, i, check_a, check_b):
    """(ok, M, t): pose i of each stack checked (where its ``check`` is set) and B's mesh frame
    in A's (:func:`._query_args.relative_pose`); ok is False if a checked pose is not a
    finite rigid transform.

    Compiled without reference counting: the pose views taken here would otherwise cost four
    atomic operations per pose on the stacks every thread shares.
    """
    # pose_at's choice, inline: a kernel without reference counting cannot return a view.
    Ta = T_a[0 if T_a.shape[0] == 1 else i]
    Tb = T_b[0 if T_b.shape[0] == 1 else i]
    ok = (not check_a or pose_ok(Ta)) and (not check_b or pose_ok(Tb))
    M, t = relative_pose(Ta, Tb)
    return ok, M, t


@njit
def _collide_run(P_a, T_a, P_b, T_b, start, stop, colliding):
    """Fill ``colliding[start:stop]``, each pose's walk starting from what an earlier pose's
    walk learnt.

    Poses along a path are close to each other. Where the previous pose collided and the
    root boxes overlap, the triangle pair found intersecting then is tested first: it
    usually still intersects, which answers most colliding poses of a path with a single
    triangle test. Where the previous pose was apart, the pairs that its walk from the roots
    found disjoint (its front, :func:`.collide.walk`) start the walks of the next
    ``FRONT_POSES`` poses: they mostly stay disjoint, and the boxes above them are not
    tested again. Those walks' own fronts are not kept: a front only deepens (a pair found
    disjoint is never merged back into its parent), and where the meshes part, a deepened
    front keeps testing small boxes that a walk from the roots settles with a few large
    ones. The answer is the traversal's either way.

    Each pose of a stack longer than one is checked here, as it is read (a stack of one is
    checked before the runs). Returns the index of the first pose that is not a finite rigid
    transform, or -1; the run stops there.
    """
    La = layout(P_a)
    Lb = layout(P_b)
    check_a = T_a.shape[0] > 1
    check_b = T_b.shape[0] > 1
    # One stack, witness row and pair of fronts for the whole run (a traversal would
    # allocate them).
    stack = walk_stack(P_a, P_b)
    descent_rows = stack.shape[0]
    witness = np.empty((1, 2), dtype=np.int64)
    anchor = np.empty((FRONT_ROWS, 2), dtype=np.int64)  # front of the last walk from the roots
    front = np.empty((FRONT_ROWS, 2), dtype=np.int64)  # the current walk's
    n_anchor = 0  # 0 where the previous pose leaves none to start from
    anchor_age = 0
    previous_hit = False
    counts = np.zeros(3, dtype=np.int64)
    for i in range(start, stop):
        ok, M, t = _relative_pose_at(T_a, T_b, i, check_a, check_b)
        if not ok:
            return i
        if roots_disjoint(P_a, La, P_b, Lb, M, t):
            previous_hit = False
            n_anchor = 0
            continue
        if previous_hit and faces_intersect(witness[0, 0], witness[0, 1], P_a, La, P_b, Lb, M, t):
            colliding[i] = True
            continue
        from_anchor = n_anchor > 0 and anchor_age < FRONT_POSES
        if from_anchor:
            if stack.shape[0] < n_anchor + descent_rows:
                stack = np.empty((n_anchor + descent_rows, 2), dtype=np.int64)
            for row in range(n_anchor):
                stack[row, 0] = anchor[row, 0]
                stack[row, 1] = anchor[row, 1]
            top = n_anchor
            anchor_age += 1
        else:
            stack[0, 0] = La[6]
            stack[0, 1] = Lb[6]
            top = 1
        n_front = 0
        while True:
            top, found, n_front = walk(
                True, P_a, La, P_b, Lb, M, t, stack, top, witness, 0, counts, front, n_front
            )
            if top == 0 or found > 0:
                break
            if n_front == front.shape[0]:
                front = with_room(front)
            else:
                stack = with_room(stack)
        colliding[i] = found > 0
        previous_hit = found > 0
        if previous_hit:
            n_anchor = 0
        elif not from_anchor:
            anchor, front = front, anchor
            n_anchor = n_front
            anchor_age = 0
    return -1


@sealed
@njit(parallel=True)
def _collide_stack_kernel(P_a, T_a, P_b, T_b, runs):
    """(colliding (k,) bool, index of the first pose that is not a rigid transform or -1)
    over pose stacks, a stack of one broadcast against the other.

    The stack is cut into ``runs`` runs of consecutive poses, shared out among numba's
    threads; each run keeps its own witness.
    """
    k = max(T_a.shape[0], T_b.shape[0])
    colliding = np.zeros(k, dtype=np.bool_)
    if (T_a.shape[0] == 1 and not pose_ok(T_a[0])) or (T_b.shape[0] == 1 and not pose_ok(T_b[0])):
        return colliding, 0
    runs = min(k, runs)
    if runs <= 1:
        # One run needs no threads (waking them costs microseconds).
        return colliding, _collide_run(P_a, T_a, P_b, T_b, 0, k, colliding)
    bad = np.empty(runs, dtype=np.int64)
    for r in prange(runs):
        bad[r] = _collide_run(P_a, T_a, P_b, T_b, r * k // runs, (r + 1) * k // runs, colliding)
    for r in range(runs):
        if bad[r] >= 0:
            return colliding, bad[r]
    return colliding, -1


def collide_batch(tree_a, T_a, tree_b, T_b) -> np.ndarray:
    """Whether two meshes intersect, at each pose of a stack.

    Parameters
    ----------
    tree_a, tree_b : OBBTree
        The two meshes' trees.
    T_a, T_b : (k, 4, 4) or (4, 4) array_like of float
        Rigid transforms from each mesh frame to the world; a single pose is used with every
        pose of the other stack (two single poses give k = 1).

    Returns
    -------
    (k,) bool
        ``collide(tree_a, T_a[i], tree_b, T_b[i], mode="first").colliding`` for each i,
        whatever the number of threads.

    Raises
    ------
    ValueError
        If a tree is not an OBBTree, a pose is not a finite rigid transform (the message
        names the stack and the index), or the two stacks differ in length.
    """
    runs = RUNS_PER_THREAD * numba.get_num_threads()
    # The kernel checks the poses as it reads them; the checked conversion names the fault.
    stacks = pose_stacks(tree_a, T_a, tree_b, T_b, checked=False)
    colliding, bad = call_normalised(_collide_stack_kernel, *stacks, runs)
    if bad >= 0:
        pose_stacks(tree_a, T_a, tree_b, T_b)
    return colliding


def distance_batch(tree_a, T_a, tree_b, T_b) -> np.ndarray:
    """Least distance between two meshes at each pose of a stack (0.0 where they intersect).

    Parameters and errors as :func:`collide_batch`.

    Returns
    -------
    (k,) float64
        ``distance(tree_a, T_a[i], tree_b, T_b[i]).distance`` for each i.
    """
    distances, _, _, _, _ = stacked_distances(tree_a, T_a, tree_b, T_b)
    return distances
