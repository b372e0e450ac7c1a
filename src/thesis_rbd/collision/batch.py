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
from thesis_rbd.collision._query_args import call_normalised, pose_at, sealed
from thesis_rbd.collision.collide import faces_intersect, roots_disjoint, traverse
from thesis_rbd.collision.distance import pose_stacks, stacked_distances

__all__ = ["collide_batch", "distance_batch"]

# Runs of consecutive poses per thread: more runs even out the threads' work on a stack whose
# costly poses cluster, fewer keep more of a path's witnesses (one is lost per run).
RUNS_PER_THREAD = 4


@njit
def _collide_run(P_a, T_a, P_b, T_b, start, stop, colliding):
    """Fill ``colliding[start:stop]``, trying each pose's predecessor's witness first.

    Poses along a path are close to each other, so the triangle pair found intersecting at
    one pose usually still intersects at the next: testing that one pair first (a single
    triangle test) answers most colliding poses of a path without a traversal. The answer is
    the traversal's either way (:func:`.collide.faces_intersect`).
    """
    witness_a = -1
    witness_b = -1
    for i in range(start, stop):
        Ta = pose_at(T_a, i)
        Tb = pose_at(T_b, i)
        if witness_a >= 0 and faces_intersect(P_a, P_b, Ta, Tb, witness_a, witness_b):
            colliding[i] = True
            continue
        if roots_disjoint(P_a, P_b, Ta, Tb):
            continue
        pairs, _, _, _ = traverse(True, P_a, P_b, Ta, Tb)
        if pairs.shape[0] > 0:
            colliding[i] = True
            witness_a = pairs[0, 0]
            witness_b = pairs[0, 1]


@sealed
@njit(parallel=True)
def _collide_stack_kernel(P_a, T_a, P_b, T_b, runs):
    """Colliding (k,) bool over pose stacks checked by ``pose_stacks``, a stack of one
    broadcast against the other.

    The stack is cut into ``runs`` runs of consecutive poses, shared out among numba's
    threads; each run keeps its own witness.
    """
    k = max(T_a.shape[0], T_b.shape[0])
    colliding = np.zeros(k, dtype=np.bool_)
    runs = min(k, runs)
    if runs <= 1:
        # One run needs no threads (waking them costs microseconds).
        _collide_run(P_a, T_a, P_b, T_b, 0, k, colliding)
        return colliding
    for r in prange(runs):
        _collide_run(P_a, T_a, P_b, T_b, r * k // runs, (r + 1) * k // runs, colliding)
    return colliding


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
    return call_normalised(_collide_stack_kernel, *pose_stacks(tree_a, T_a, tree_b, T_b), runs)


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
