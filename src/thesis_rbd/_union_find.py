"""Union-find over an int array ``parent`` (parent[i] == i at a root), for numba kernels.

Shared by everything that groups: contact islands, contact clusters, contact regions.
"""

from __future__ import annotations

from thesis_rbd._numba.jit import njit

__all__ = ["find_root", "join"]


@njit
def find_root(parent, i):
    """Root of i's set, halving the path on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit
def join(parent, i, j):
    """Merge the sets of i and j; the smaller root index becomes the root."""
    ri, rj = find_root(parent, i), find_root(parent, j)
    if ri != rj:
        parent[max(ri, rj)] = min(ri, rj)
