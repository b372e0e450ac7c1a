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
walking the trees.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from thesis_rbd._jit import njit
from thesis_rbd.collision._query_args import (
    call_normalised,
    pose_at,
    pose_ok,
    relative_pose,
    sealed,
)
from thesis_rbd.collision.collide import (
    faces_intersect,
    roots_disjoint,
    traverse,
    walk,
    walk_stack,
)
from thesis_rbd.collision.distance import pose_stacks, stacked_distances
from thesis_rbd.collision.packed import layout

__all__ = ["collide_batch", "distance_batch"]

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
    """Fill ``colliding[start:stop]``, trying the predecessor's witness before a traversal.

    Poses along a path are close to each other, so the triangle pair found intersecting at
    one pose usually still intersects at the next: where the previous pose collided and the
    root boxes overlap, testing that one pair (a single triangle test) answers most
    colliding poses of a path without a traversal. After a pose that did not collide (and
    on a stack of unrelated poses, which mostly miss at the roots) the witness is not tried.
    The answer is the traversal's either way (:func:`.collide.faces_intersect`).

    Each pose of a stack longer than one is checked here, as it is read (a stack of one is
    checked before the runs). Returns the index of the first pose that is not a finite rigid
    transform, or -1; the run stops there.
    """
    La = layout(P_a)
    Lb = layout(P_b)
    check_a = T_a.shape[0] > 1
    check_b = T_b.shape[0] > 1
    # One stack and one witness row for the whole run (a traversal would allocate both).
    stack = walk_stack(P_a, P_b)
    witness = np.empty((1, 2), dtype=np.int64)
    previous_hit = False
    counts = np.zeros(3, dtype=np.int64)
    for i in range(start, stop):
        ok, M, t = _relative_pose_at(T_a, T_b, i, check_a, check_b)
        if not ok:
            return i
        if roots_disjoint(P_a, La, P_b, Lb, M, t):
            previous_hit = False
            continue
        if previous_hit and faces_intersect(witness[0, 0], witness[0, 1], P_a, La, P_b, Lb, M, t):
            colliding[i] = True
            continue
        stack[0, 0] = La[6]
        stack[0, 1] = Lb[6]
        top, found = walk(True, P_a, La, P_b, Lb, M, t, stack, 1, witness, 0, counts)
        if top > 0 and found == 0:
            # The stack ran out of room, which walk_stack's bound rules out; answer anyway.
            pairs, _, _, _ = traverse(True, P_a, P_b, pose_at(T_a, i), pose_at(T_b, i))
            found = pairs.shape[0]
            if found:
                witness[0, 0] = pairs[0, 0]
                witness[0, 1] = pairs[0, 1]
        colliding[i] = found > 0
        previous_hit = found > 0
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
