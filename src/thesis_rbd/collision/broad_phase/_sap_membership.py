"""numba kernels that change the sweep-and-prune's membership: objects added and removed.

They work on the flat state described in ``_sap_kernels`` and ``_sap_columns`` (bounds, the
records of each axis and the sorted pair keys): new objects are merged into the sorted columns
without a re-sort, removed ones compacted out with the survivors renumbered in order.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._pair_keys import first_of, pair_key, second_of, unordered_pair_key
from thesis_rbd._sorting import sorted_copy
from thesis_rbd.collision.broad_phase._sap_columns import merge_records, new_records

__all__ = ["compact_removed", "merge_new_boxes", "pairs_with_new"]


@njit
def pairs_with_new(box, first_new):
    """Sorted keys of overlapping pairs with at least one id >= ``first_new``: O(n * new).

    ``box`` is (n, 6) ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]`` per id.
    """
    n = box.shape[0]
    out = np.empty(16, dtype=np.int64)
    k = 0
    for i in range(first_new, n):
        for j in range(i):
            if (
                box[j, 0] <= box[i, 1]
                and box[i, 0] <= box[j, 1]
                and box[j, 2] <= box[i, 3]
                and box[i, 2] <= box[j, 3]
                and box[j, 4] <= box[i, 5]
                and box[i, 4] <= box[j, 5]
            ):
                if k == out.shape[0]:
                    grown = np.empty(2 * k, dtype=np.int64)
                    grown[:k] = out[:k]
                    out = grown
                out[k] = unordered_pair_key(j, i)
                k += 1
    return sorted_copy(out[:k])


@njit
def merge_new_boxes(box, cells, grid, val, ep, col, count, rng, first_id):
    """Insert the records of new boxes (ids ``first_id ...``) into every axis, no re-sort.

    O(records + r log r) for r new records: they are sorted, then merged.

    Parameters
    ----------
    box, cells : (n, 6) float64, (n, 6) int32
        Bounds and cells of all objects, the new ones last.
    grid, val, ep, col, count, rng
        As ``_sap_columns`` describes, of the first ``first_id`` objects.

    Returns
    -------
    val, ep, col : the record arrays (new ones if they grew)
    rng : (3, n, 4) int32, a new array
    """
    n = box.shape[0]
    ids = np.arange(first_id, n)
    out = np.empty((3, n, 4), dtype=np.int32)
    out[:, :first_id] = rng
    for a in range(3):
        b = (a + 1) % 3
        c = (a + 2) % 3
        for i in range(first_id, n):
            out[a, i, 0] = cells[i, 2 * b]
            out[a, i, 1] = cells[i, 2 * b + 1]
            out[a, i, 2] = cells[i, 2 * c]
            out[a, i, 3] = cells[i, 2 * c + 1]
        rv, re, rc = new_records(box, cells, grid, ids, a)
        val, ep, col = merge_records(val, ep, col, count, a, rv, re, rc)
    return val, ep, col, out


@njit
def compact_removed(val, ep, col, count, rng, pair_keys, gone):
    """Drop objects with ``gone[id]`` and renumber the rest densely, order kept.

    The renumbering ``new_id = id - (number of gone ids below id)`` is increasing, so sorted
    records and sorted pair keys stay sorted: no re-sort. The records are compacted in place
    (``count`` updated).

    Parameters
    ----------
    val, ep, col, count, rng
        As ``_sap_columns`` describes.
    pair_keys : (k,) int64 sorted
    gone : (n,) bool

    Returns
    -------
    rng : (3, n - r, 4) int32, a new array
    kept_keys : sorted keys of the surviving pairs, renumbered
    removed_keys : sorted keys (old numbering) of the pairs that involved a gone object
    """
    n = gone.shape[0]
    new_id = np.empty(n, dtype=np.int64)
    alive = 0
    for i in range(n):
        if gone[i]:
            new_id[i] = -1
        else:
            new_id[i] = alive
            alive += 1
    out_rng = np.empty((3, alive, 4), dtype=np.int32)
    for a in range(3):
        for i in range(n):
            if new_id[i] >= 0:
                out_rng[a, new_id[i]] = rng[a, i]
        o = 0
        for p in range(count[a]):
            code = ep[a, p]
            i = new_id[code >> 1]
            if i >= 0:
                val[a, o] = val[a, p]
                ep[a, o] = 2 * i + (code & 1)
                col[a, o] = col[a, p]
                o += 1
        count[a] = o
    kept = np.empty(pair_keys.shape[0], dtype=np.int64)
    removed = np.empty(pair_keys.shape[0], dtype=np.int64)
    nk = 0
    nr = 0
    for t in range(pair_keys.shape[0]):
        key = pair_keys[t]
        i = new_id[first_of(key)]
        j = new_id[second_of(key)]
        if i < 0 or j < 0:
            removed[nr] = key
            nr += 1
        else:
            kept[nk] = pair_key(i, j)
            nk += 1
    return out_rng, kept[:nk], removed[:nr]
