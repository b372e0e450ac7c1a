"""Pose batches: one query over a stack of poses in a single kernel call.

A motion planner asks whether (or how far apart) two meshes are at hundreds of poses along a
path; calling :func:`thesis_rbd.collide` or :func:`thesis_rbd.distance` once per pose pays
the Python wrapper each time. :func:`collide_batch` and :func:`distance_batch` take a stack of
poses (k, 4, 4) for either mesh, the other mesh at one pose (4, 4) or at a stack of the same
length, and loop inside numba over the same kernels the single queries use, so each answer
equals the single query's.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd.collision._query_args import call_normalised, sealed
from thesis_rbd.collision.collide import roots_disjoint, traverse
from thesis_rbd.collision.distance import pose_stacks, stacked_distances

__all__ = ["collide_batch", "distance_batch"]


@sealed
@njit
def _collide_stack_kernel(P_a, T_a, P_b, T_b):
    """Colliding (k,) bool over pose stacks checked by ``pose_stacks``, a stack of one
    broadcast against the other."""
    k = max(T_a.shape[0], T_b.shape[0])
    colliding = np.zeros(k, dtype=np.bool_)
    for i in range(k):
        Ta = T_a[0] if T_a.shape[0] == 1 else T_a[i]
        Tb = T_b[0] if T_b.shape[0] == 1 else T_b[i]
        if not roots_disjoint(P_a, P_b, Ta, Tb):
            pairs, _, _, _ = traverse(True, P_a, P_b, Ta, Tb)
            colliding[i] = pairs.shape[0] > 0
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
        ``collide(tree_a, T_a[i], tree_b, T_b[i], mode="first").colliding`` for each i.

    Raises
    ------
    ValueError
        If a tree is not an OBBTree, a pose is not a finite rigid transform (the message
        names the stack and the index), or the two stacks differ in length.
    """
    return call_normalised(_collide_stack_kernel, *pose_stacks(tree_a, T_a, tree_b, T_b))


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
