"""numba kernels that change the sweep-and-prune's membership: objects added and removed.

They work on the flat state described in ``_sap_kernels`` (``box``, ``val``, ``ep`` and the
sorted pair keys): new objects are merged into the sorted axes without a re-sort, removed ones
compacted out with the survivors renumbered in order.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd.collision._sap_kernels import _sort_endpoints
from thesis_rbd.collision.pair_table import pair_key

__all__ = ["compact_removed", "merge_endpoints", "pairs_with_new"]


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
                out[k] = pair_key(j, i)
                k += 1
    return np.sort(out[:k])


@njit
def merge_endpoints(val, ep, new_box, first_id):
    """Insert the endpoints of new boxes (ids ``first_id ...``) into sorted axes.

    O(n + m log m) for m new boxes: the new endpoints are sorted, then merged.

    Returns
    -------
    val, ep : (3, 2(n + m)) float64, int64
    """
    old_m = ep.shape[1]
    add_m = 2 * new_box.shape[0]
    out_val = np.empty((3, old_m + add_m), dtype=np.float64)
    out_ep = np.empty((3, old_m + add_m), dtype=np.int64)
    for a in range(3):
        nv, ne = _sort_endpoints(new_box[:, 2 * a].copy(), new_box[:, 2 * a + 1].copy(), first_id)
        s = 0
        t = 0
        for o in range(old_m + add_m):
            take_old = False
            if t == add_m:
                take_old = True
            elif s < old_m:
                vo = val[a, s]
                vn = nv[t]
                take_old = vo < vn or (vo == vn and (ep[a, s] & 1) <= (ne[t] & 1))
            if take_old:
                out_val[a, o] = val[a, s]
                out_ep[a, o] = ep[a, s]
                s += 1
            else:
                out_val[a, o] = nv[t]
                out_ep[a, o] = ne[t]
                t += 1
    return out_val, out_ep


@njit
def compact_removed(val, ep, pair_keys, gone):
    """Drop objects with ``gone[id]`` and renumber the rest densely, order kept.

    The renumbering ``new_id = id - (number of gone ids below id)`` is increasing, so sorted
    endpoint arrays and sorted pair keys stay sorted: no re-sort.

    Parameters
    ----------
    val, ep : (3, 2n)
    pair_keys : (k,) int64 sorted
    gone : (n,) bool

    Returns
    -------
    val, ep : (3, 2(n - r)) float64, int64
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
    out_val = np.empty((3, 2 * alive), dtype=np.float64)
    out_ep = np.empty((3, 2 * alive), dtype=np.int64)
    for a in range(3):
        o = 0
        for p in range(ep.shape[1]):
            c = ep[a, p]
            i = new_id[c >> 1]
            if i >= 0:
                out_val[a, o] = val[a, p]
                out_ep[a, o] = 2 * i + (c & 1)
                o += 1
    kept = np.empty(pair_keys.shape[0], dtype=np.int64)
    removed = np.empty(pair_keys.shape[0], dtype=np.int64)
    nk = 0
    nr = 0
    for t in range(pair_keys.shape[0]):
        key = pair_keys[t]
        i = new_id[key >> 32]
        j = new_id[key & 0xFFFFFFFF]
        if i < 0 or j < 0:
            removed[nr] = key
            nr += 1
        else:
            kept[nk] = (i << 32) | j
            nk += 1
    return out_val, out_ep, kept[:nk], removed[:nr]
