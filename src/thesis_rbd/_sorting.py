"""Stable sorting inside kernels: one merge sort for every kernel that sorts integer keys, or
float keys stably.

``np.argsort``, ``np.sort`` and ``np.unique`` inside a kernel compile numba's own sorts: a
family of about six functions per algorithm (quicksort, mergesort), key type and variant
(sort or argsort). numba keeps them in no on-disk cache, so every first run compiles them
again, and so does each process compiling kernels beside it (:mod:`._numba.compile_helpers`). The
kernels here are the package's own: compiled once per key type, and cached like every other
kernel.

Kernels that sort floats for speed alone, where equal keys may come in any order (the
convex hull's insertion order, the box axes by extent), keep ``np.argsort``: changing the
order of their ties would change which of equally good answers they give.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["sort_with_order", "sorted_copy", "stable_argsort", "unique_sorted"]

# Runs this short are sorted by insertion before merging: fewer passes over the scratch array.
_RUN = 16


@njit(allocates=False)
def _before(x, y):
    """Whether key x sorts strictly before key y: ascending, NaN last (numpy's order)."""
    return x < y or (x == x and y != y)


@njit
def stable_argsort(keys):
    """The order that sorts ``keys`` (n,) int64 or float64 ascending, equal keys in their
    input order: ``np.argsort(keys, kind="stable")``, as an (n,) int64 array."""
    return sort_with_order(keys)[1]


@njit
def sorted_copy(keys):
    """``np.sort(keys)`` for (n,) int64 or float64 keys: a sorted copy."""
    return sort_with_order(keys)[0]


@njit
def sort_with_order(keys):
    """(sorted copy of ``keys`` (n,) int64 or float64, the stable order that sorts them): both
    of what ``np.sort`` and ``np.argsort(kind="stable")`` give, from one bottom-up merge sort,
    after insertion sorts of short runs. The keys travel with their indices, so that each
    comparison reads two neighbouring keys rather than two keys scattered by an index."""
    n = keys.shape[0]
    values = keys.copy()
    order = np.empty(n, np.int64)
    for i in range(n):
        order[i] = i
    for lo in range(0, n, _RUN):
        hi = min(lo + _RUN, n)
        for i in range(lo + 1, hi):
            key = values[i]
            index = order[i]
            j = i - 1
            while j >= lo and _before(key, values[j]):
                values[j + 1] = values[j]
                order[j + 1] = order[j]
                j -= 1
            values[j + 1] = key
            order[j + 1] = index
    if n <= _RUN:
        return values, order
    other_values = np.empty_like(values)
    other_order = np.empty(n, np.int64)
    width = _RUN
    passes = 0
    while width < n:
        # Passes alternate between the two pairs of arrays instead of swapping the variables:
        # an array variable a loop reassigns is reference-counted on every pass.
        if passes % 2 == 0:
            _merge_pass(values, order, other_values, other_order, width)
        else:
            _merge_pass(other_values, other_order, values, order, width)
        passes += 1
        width *= 2
    if passes % 2 == 1:
        return other_values, other_order
    return values, order


@njit(allocates=False)
def _merge_pass(values, order, to_values, to_order, width):
    """Merge each pair of neighbouring sorted runs of ``width`` keys (and their indices) into
    the ``to_`` arrays; on ties the left run's key first (stability)."""
    n = values.shape[0]
    for lo in range(0, n, 2 * width):
        mid = min(lo + width, n)
        hi = min(lo + 2 * width, n)
        i = lo
        j = mid
        k = lo
        while i < mid and j < hi:
            if _before(values[j], values[i]):
                to_values[k] = values[j]
                to_order[k] = order[j]
                j += 1
            else:
                to_values[k] = values[i]
                to_order[k] = order[i]
                i += 1
            k += 1
        while i < mid:
            to_values[k] = values[i]
            to_order[k] = order[i]
            i += 1
            k += 1
        while j < hi:
            to_values[k] = values[j]
            to_order[k] = order[j]
            j += 1
            k += 1


@njit
def unique_sorted(keys):
    """``np.unique(keys)`` for (n,) int64 keys: the distinct keys, ascending."""
    ordered = sorted_copy(keys)
    m = 0
    for i in range(ordered.shape[0]):
        if m == 0 or ordered[i] != ordered[m - 1]:
            ordered[m] = ordered[i]
            m += 1
    return ordered[:m]
