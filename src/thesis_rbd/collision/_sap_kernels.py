"""numba kernels of the sweep-and-prune broad phase (thesis 4.7, 5.3); ``sap.py`` wraps them.

Flat state shared by the kernels, with ``n`` objects and ``m = 2 n`` endpoints per axis:

``box : (n, 6) float64``
    Bounds of each object, row ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]``: the gather of an
    endpoint's coordinates touches one row (48 bytes) instead of one row of each of a lower
    and an upper array. The wrapper keeps two and swaps them each frame (new and previous).
``val : (3, m) float64``
    Endpoint coordinates of each axis in sorted order.
``ep : (3, m) int64``
    Endpoint codes in the same order: ``2 * id`` for a begin (lower bound), ``2 * id + 1`` for
    an end (upper bound).

Sort key of an endpoint is ``(value, is_end)``: on equal coordinates a begin sorts before an
end, so intervals that only touch are seen as overlapping (closed intervals). With that key,
"the intervals of i and j overlap on axis a" is exactly "begin_i precedes end_j and begin_j
precedes end_i in the array of axis a", and the number of axes on which that holds is the
thesis's overlap counter of the pair. Only a swap of a begin with an end changes a term of a
counter, and the pair enters (or leaves) the overlap set exactly when its counter reaches (or
leaves) 3.

The counters are not stored for all pairs: pairs that overlap on one axis alone number
O(n^(5/3)) in a uniform 3-D scene, about 10^8 at n = 10^5. Nor are they read from rank arrays,
which costs a cache miss per swap (measured: 170 ms instead of 12 ms per frame at n = 10^5).
Instead each endpoint record carries a copy of its box's bounds on the two other axes, so the
other two counter terms of a pair are read from the two records being swapped: an axis already
sorted this frame is in the order of the new bounds, an axis not yet sorted still in the order
of the previous frame's bounds, and the copies are taken accordingly (``_refresh_axis``).

Why three sorted axes and not one: a single sorted axis finds the pairs whose intervals
start or stop overlapping on that axis, but a pair that already overlaps on it and starts
overlapping on another axis makes no swap there. Catching it needs either the full sweep of
the sorted axis every frame, O(n + k_axis) with k_axis ~ n^(5/3) pairs overlapping on one
axis in a uniform 3-D scene (about 10^8 at n = 10^5: the NumPy peer of the benchmark), or the
other axes sorted as well.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd.collision.pair_table import (
    IN_SET,
    TOUCHED,
    WAS_IN,
    pair_key,
    table_delete,
    table_find,
    table_insert,
)

# Status codes of `insertion_sort_frame` and `update_frame`.
DONE = 0
OVER_BUDGET = 1
PREDICTED_OVER = 2
BAD_BOUNDS = 3


@njit
def _sort_endpoints(lo, hi, first_id):
    """Sort the endpoints of intervals ``[lo[t], hi[t]]`` (ids ``first_id + t``) by key.

    Returns ``(val, ep)``, both ``(2 len(lo),)``.
    """
    n = lo.shape[0]
    m = 2 * n
    values = np.empty(m, dtype=np.float64)
    codes = np.empty(m, dtype=np.int64)
    for t in range(n):
        values[2 * t] = lo[t]
        values[2 * t + 1] = hi[t]
        codes[2 * t] = 2 * (first_id + t)
        codes[2 * t + 1] = 2 * (first_id + t) + 1
    order = np.argsort(values, kind="quicksort")
    val = values[order]
    ep = codes[order]
    # argsort is not stable and knows nothing of the is_end bit: inside each run of equal
    # values, move the begins in front of the ends.
    start = 0
    while start < m:
        stop = start + 1
        while stop < m and val[stop] == val[start]:
            stop += 1
        if stop - start > 1:
            begins = 0
            for p in range(start, stop):
                if ep[p] & 1 == 0:
                    begins += 1
            if 0 < begins < stop - start:
                run = ep[start:stop].copy()
                b = start
                e = start + begins
                for c in run:
                    if c & 1 == 0:
                        ep[b] = c
                        b += 1
                    else:
                        ep[e] = c
                        e += 1
        start = stop
    return val, ep


@njit
def sort_axes(box):
    """Sort all endpoints from scratch: ``O(n log n)``.

    Parameters
    ----------
    box : (n, 6) float64
        Box bounds ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]``, row = object id.

    Returns
    -------
    val, ep : (3, 2n) float64, (3, 2n) int64
    """
    n = box.shape[0]
    val = np.empty((3, 2 * n), dtype=np.float64)
    ep = np.empty((3, 2 * n), dtype=np.int64)
    for a in range(3):
        v, e = _sort_endpoints(box[:, 2 * a].copy(), box[:, 2 * a + 1].copy(), 0)
        val[a] = v
        ep[a] = e
    return val, ep


@njit
def _touch(keys, flags, slot, touched, ntouched):
    """Remember the frame-start state of ``slot`` the first time a frame changes it."""
    f = flags[slot]
    if f & TOUCHED == 0:
        f |= TOUCHED
        if f & IN_SET:
            f |= WAS_IN
        flags[slot] = f
        if ntouched == touched.shape[0]:
            grown = np.empty(2 * touched.shape[0], dtype=np.int64)
            grown[:ntouched] = touched[:ntouched]
            touched = grown
        touched[ntouched] = keys[slot]
        ntouched += 1
    return touched, ntouched


@njit
def _refresh_axis(box, old_box, val, ep, other, a):
    """Write the new coordinates of axis ``a`` and the other axes' bounds into its records.

    ``other[p] = (lo_b, hi_b, lo_c, hi_c)`` of the box of endpoint ``p`` with ``b = a + 1``,
    ``c = a + 2`` (mod 3): new bounds (``box``) for axes sorted before ``a`` in this frame,
    the previous frame's (``old_box``) for axes sorted after it, so that each matches its
    axis's current order. A pass of its own: its gathers are independent of each other, so
    the processor overlaps their cache misses; gathered inside the sort, each insertion
    waited for its own (measured at n = 10^5: 137 ms per frame instead of 22 ms).
    """
    b = (a + 1) % 3
    c3 = (a + 2) % 3
    src_b = box if b < a else old_box
    src_c = box if c3 < a else old_box
    for p in range(ep.shape[1]):
        code = ep[a, p]
        i = code >> 1
        val[a, p] = box[i, 2 * a + (code & 1)]
        other[p, 0] = src_b[i, 2 * b]
        other[p, 1] = src_b[i, 2 * b + 1]
        other[p, 2] = src_c[i, 2 * c3]
        other[p, 3] = src_c[i, 2 * c3 + 1]


@njit
def _sort_axis(val, ep, other, a, p, log_keys, log_start, swaps, budget):
    """Insertion-sort axis ``a`` from element ``p`` on, logging counter transitions.

    The hot loop of the broad phase. It calls nothing and never reallocates, so numba keeps
    it tight (a hash-table call inside it measured 4x slower); transitions go to a fixed-size
    log that the caller applies to the pair table.

    Returns
    -------
    p : int
        Where to resume: ``m`` when the axis is sorted. Less when the log filled up (the
        element being moved is parked at the hole, which keeps the prefix before it sorted,
        so resuming there is exact) or when ``swaps`` passed ``budget``.
    nlog : int
        Log entries written: ``log_keys[t]`` a pair key, ``log_start[t]`` 1 when the pair's
        counter went 2 -> 3, 0 when 3 -> 2.
    swaps : int
        Running swap count.
    """
    m = ep.shape[1]
    capacity = log_keys.shape[0]
    nlog = 0
    while p < m:
        v = val[a, p]
        code = ep[a, p]
        is_end = code & 1
        lo_b = other[p, 0]
        hi_b = other[p, 1]
        lo_c = other[p, 2]
        hi_c = other[p, 3]
        q = p - 1
        full = False
        # Move `code` left past every endpoint whose key (value, is_end) is larger.
        while q >= 0:
            vq = val[a, q]
            cq = ep[a, q]
            if vq < v or (vq == v and (cq & 1) <= is_end):
                break
            qlo_b = other[q, 0]
            qhi_b = other[q, 1]
            qlo_c = other[q, 2]
            qhi_c = other[q, 3]
            # Bitwise, not short-circuit: one well-predicted branch instead of five
            # data-dependent ones (transitions are rare).
            if (
                ((cq & 1) != is_end)
                & (lo_b <= qhi_b)
                & (qlo_b <= hi_b)
                & (lo_c <= qhi_c)
                & (qlo_c <= hi_c)
            ):
                # The other two counter terms hold, so this swap moves the counter between
                # 2 and 3: a begin passing an end leftwards starts the pair, an end passing
                # a begin ends it.
                if nlog == capacity:
                    full = True
                    break
                log_keys[nlog] = pair_key(code >> 1, cq >> 1)
                log_start[nlog] = 1 - is_end
                nlog += 1
            val[a, q + 1] = vq
            ep[a, q + 1] = cq
            other[q + 1, 0] = qlo_b
            other[q + 1, 1] = qhi_b
            other[q + 1, 2] = qlo_c
            other[q + 1, 3] = qhi_c
            swaps += 1
            q -= 1
        val[a, q + 1] = v
        ep[a, q + 1] = code
        other[q + 1, 0] = lo_b
        other[q + 1, 1] = hi_b
        other[q + 1, 2] = lo_c
        other[q + 1, 3] = hi_c
        if full:
            return q + 1, nlog, swaps
        p += 1
        if swaps > budget:
            return p, nlog, swaps
    return m, nlog, swaps


@njit
def _apply_log(keys, flags, meta, log_keys, log_start, nlog, touched, ntouched):
    """Apply logged transitions in order to the pair table, noting first touches."""
    for t in range(nlog):
        key = log_keys[t]
        if log_start[t]:
            keys, flags, slot = table_insert(keys, flags, meta, key, 0)
            touched, ntouched = _touch(keys, flags, slot, touched, ntouched)
            flags[slot] |= IN_SET
        else:
            slot = table_find(keys, key)
            touched, ntouched = _touch(keys, flags, slot, touched, ntouched)
            flags[slot] &= ~np.uint8(IN_SET)
    return keys, flags, touched, ntouched


@njit
def insertion_sort_frame(box, old_box, val, ep, other, keys, flags, meta, budget, log_keys,
                         log_start):  # fmt: skip
    """One coherent frame: insertion-sort each axis by the new coordinates.

    Every adjacent swap of a begin and an end changes one term of that pair's overlap counter;
    when the other two terms hold, the pair enters or leaves the set. Expected cost
    O(n + swaps), swaps = endpoint crossings since the last frame (thesis 4.7).

    Parameters
    ----------
    box : (n, 6) float64
        New bounds, row ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]`` per id.
    old_box : (n, 6) float64
        Bounds of the previous frame (the ones ``val``/``ep`` are sorted by).
    val, ep : (3, 2n)
        Sorted state of the previous frame, updated in place.
    other : (2n, 4) float64
        Scratch for the other two axes' bounds of each record (no meaning between calls).
    keys, flags, meta : pair table (see ``pair_table``); may be reallocated.
    budget : int
        Stop with ``OVER_BUDGET`` once more swaps than this were made (the caller then
        re-sorts from scratch; the partial state here is discarded).
    log_keys : (L,) int64, log_start : (L,) uint8
        Transition log, applied to the pair table whenever it fills (tests make it tiny to
        exercise the resume path; any ``L >= 1`` gives the same result).

    Returns
    -------
    status : int
        ``DONE`` or ``OVER_BUDGET``.
    swaps : int
        Adjacent swaps made.
    keys, flags : the pair table arrays (new ones if it grew).
    touched : (t,) int64
        Keys of the pairs whose membership changed at least once this frame.
    """
    m = ep.shape[1]
    touched = np.empty(64, dtype=np.int64)
    ntouched = 0
    swaps = 0
    for a in range(3):
        _refresh_axis(box, old_box, val, ep, other, a)
        p = 1
        while p < m:
            p, nlog, swaps = _sort_axis(val, ep, other, a, p, log_keys, log_start, swaps, budget)
            keys, flags, touched, ntouched = _apply_log(
                keys, flags, meta, log_keys, log_start, nlog, touched, ntouched
            )
            if swaps > budget:
                return OVER_BUDGET, swaps, keys, flags, touched[:ntouched]
    return DONE, swaps, keys, flags, touched[:ntouched]


@njit
def stage_bounds(lower, upper, box, old_box, check):
    """Copy ``lower``/``upper`` into ``box`` and predict the coming swaps, in one O(n) pass.

    Parameters
    ----------
    lower, upper : (n, 3) float64
        New bounds as the caller gave them.
    box : (n, 6) float64
        Written: row ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]`` per id.
    old_box : (n, 6) float64 or (0, 6)
        Previous frame's bounds (read only), or empty when there is none (no prediction).
    check : bool
        Stop at the first non-finite value or ``lower > upper``.

    Returns
    -------
    bad : int
        0 when all is well; 1 a non-finite lower bound, 2 a non-finite upper bound, 3 a row
        with ``lower > upper`` (at ``row``, ``axis``).
    row, axis : int
    predicted : float
        Rough swap count of the coming insertion sort, assuming endpoints spread uniformly
        over each axis's extent: an endpoint moving by d passes about d * (2n / extent)
        others, and each swap moves two endpoints relative to each other. It only has to
        tell a coherent frame from one where boxes teleport (orders of magnitude apart); the
        swap budget is the safety net.
    """
    n = lower.shape[0]
    for i in range(n):
        for a in range(3):
            lo = lower[i, a]
            hi = upper[i, a]
            if check:
                if not np.isfinite(lo):
                    return 1, i, a, 0.0
                if not np.isfinite(hi):
                    return 2, i, a, 0.0
                if lo > hi:
                    return 3, i, a, 0.0
            box[i, 2 * a] = lo
            box[i, 2 * a + 1] = hi
    if old_box.shape[0] != n or n == 0:
        return 0, 0, 0, 0.0
    total = 0.0
    for a in range(3):
        lo_min = np.inf
        hi_max = -np.inf
        moved = 0.0
        for i in range(n):
            lo_min = min(lo_min, old_box[i, 2 * a])
            hi_max = max(hi_max, old_box[i, 2 * a + 1])
            moved += abs(box[i, 2 * a] - old_box[i, 2 * a])
            moved += abs(box[i, 2 * a + 1] - old_box[i, 2 * a + 1])
        extent = hi_max - lo_min
        if extent > 0.0:
            total += moved * n / extent
    return 0, 0, 0, total


@njit
def coherent_frame(box, old_box, val, ep, other, keys, flags, meta, pair_keys, budget,
                   log_keys, log_start, no_keys):  # fmt: skip
    """Insertion sort, net events and the new sorted pair list of a frame, in one call.

    One kernel call per coherent frame keeps the dispatch cost of a small scene low (the
    World calls this every step). Arguments as ``insertion_sort_frame``; ``pair_keys`` is the
    sorted pair list of the previous frame; ``no_keys`` an empty int64 array, returned as
    the events of a frame without any.

    Returns
    -------
    status, swaps, keys, flags
        As ``insertion_sort_frame``.
    pair_keys : (k,) int64
        The new sorted pair list (the same array when nothing changed; meaningless when
        ``status`` is ``OVER_BUDGET``).
    added, removed : (k_a,) int64, (k_r,) int64
        Sorted keys of the frame's net events (empty when ``OVER_BUDGET``).
    """
    status, swaps, keys, flags, touched = insertion_sort_frame(
        box, old_box, val, ep, other, keys, flags, meta, budget, log_keys, log_start
    )
    if status != DONE or touched.shape[0] == 0:
        # Nothing to collect. Handing back arrays the caller passed in is cheap: numba
        # returns their Python objects instead of wrapping new ones.
        return status, swaps, keys, flags, pair_keys, no_keys, no_keys
    added, removed = collect_events(keys, flags, meta, touched)
    if added.shape[0] or removed.shape[0]:
        pair_keys = merge_pair_keys(pair_keys, removed, added)
    return status, swaps, keys, flags, pair_keys, added, removed


@njit
def collect_events(keys, flags, meta, touched):
    """Net events of a frame from its touched pairs; clears the marks, drops ended pairs.

    A pair may start and end again within one frame (a box passing another); only the
    difference between frame start and frame end is an event.

    Returns
    -------
    added, removed : (k_a,) int64, (k_r,) int64
        Sorted pair keys.
    """
    added = np.empty(touched.shape[0], dtype=np.int64)
    removed = np.empty(touched.shape[0], dtype=np.int64)
    na = 0
    nr = 0
    for t in range(touched.shape[0]):
        key = touched[t]
        slot = table_find(keys, key)
        f = flags[slot]
        now = f & IN_SET
        before = f & WAS_IN
        if now and not before:
            added[na] = key
            na += 1
        elif before and not now:
            removed[nr] = key
            nr += 1
        if now:
            flags[slot] = IN_SET
        else:
            table_delete(keys, flags, meta, slot)
    return np.sort(added[:na]), np.sort(removed[:nr])


@njit
def merge_pair_keys(old, removed, added):
    """``sorted(old - removed + added)`` in O(len(old) + len(added)).

    ``removed`` is a sorted subset of the sorted ``old``; ``added`` is sorted and disjoint
    from what remains.
    """
    out = np.empty(old.shape[0] - removed.shape[0] + added.shape[0], dtype=np.int64)
    r = 0
    s = 0
    o = 0
    for t in range(old.shape[0]):
        key = old[t]
        if r < removed.shape[0] and removed[r] == key:
            r += 1
            continue
        while s < added.shape[0] and added[s] < key:
            out[o] = added[s]
            o += 1
            s += 1
        out[o] = key
        o += 1
    while s < added.shape[0]:
        out[o] = added[s]
        o += 1
        s += 1
    return out


@njit
def diff_sorted(old, new):
    """``(new - old, old - new)`` of two sorted distinct key arrays, by one merge."""
    added = np.empty(new.shape[0], dtype=np.int64)
    removed = np.empty(old.shape[0], dtype=np.int64)
    na = 0
    nr = 0
    s = 0
    t = 0
    while s < old.shape[0] or t < new.shape[0]:
        if t == new.shape[0] or (s < old.shape[0] and old[s] < new[t]):
            removed[nr] = old[s]
            nr += 1
            s += 1
        elif s == old.shape[0] or new[t] < old[s]:
            added[na] = new[t]
            na += 1
            t += 1
        else:
            s += 1
            t += 1
    return added[:na], removed[:nr]


@njit
def axis_overlap_counts(ep):
    """Number of pairs whose intervals overlap, per axis, from sorted endpoints: (3,) int64.

    Each overlapping pair is counted once, at the later begin: the number of intervals open
    when a begin is met. Used to pick the sweep axis of a full rebuild and to price it.
    """
    counts = np.zeros(3, dtype=np.int64)
    for a in range(3):
        open_intervals = 0
        total = 0
        for p in range(ep.shape[1]):
            if ep[a, p] & 1:
                open_intervals -= 1
            else:
                total += open_intervals
                open_intervals += 1
        counts[a] = total
    return counts


@njit
def sweep_all_pairs(box, ep, axis):
    """All overlapping pairs by one sort-and-sweep along ``axis``: O(n + k_axis).

    Boxes are visited in the order of their begins on ``axis`` and their bounds gathered into
    that order first, so the inner scan over later-starting boxes reads memory sequentially.

    Returns
    -------
    keys : (k,) int64
        Sorted pair keys.
    """
    n = box.shape[0]
    order = np.empty(n, dtype=np.int64)
    t = 0
    for p in range(ep.shape[1]):
        c = ep[axis, p]
        if c & 1 == 0:
            order[t] = c >> 1
            t += 1
    b = (axis + 1) % 3
    c3 = (axis + 2) % 3
    lo_a = np.empty(n)
    hi_a = np.empty(n)
    lo_b = np.empty(n)
    hi_b = np.empty(n)
    lo_c = np.empty(n)
    hi_c = np.empty(n)
    for t in range(n):
        i = order[t]
        lo_a[t] = box[i, 2 * axis]
        hi_a[t] = box[i, 2 * axis + 1]
        lo_b[t] = box[i, 2 * b]
        hi_b[t] = box[i, 2 * b + 1]
        lo_c[t] = box[i, 2 * c3]
        hi_c[t] = box[i, 2 * c3 + 1]
    out = np.empty(max(16, n), dtype=np.int64)
    k = 0
    for s in range(n):
        h = hi_a[s]
        lb = lo_b[s]
        hb = hi_b[s]
        lc = lo_c[s]
        hc = hi_c[s]
        # Later boxes start at or after lo_a[s]; they overlap on `axis` while they start at or
        # before hi_a[s] (closed intervals).
        for t in range(s + 1, n):
            if lo_a[t] > h:
                break
            if lo_b[t] <= hb and lb <= hi_b[t] and lo_c[t] <= hc and lc <= hi_c[t]:
                if k == out.shape[0]:
                    grown = np.empty(2 * k, dtype=np.int64)
                    grown[:k] = out[:k]
                    out = grown
                out[k] = pair_key(order[s], order[t])
                k += 1
    return np.sort(out[:k])


@njit
def update_frame(lower, upper, box, old_box, val, ep, other, keys, flags, meta, pair_keys,
                 budget, skip_above, check, log_keys, log_start, no_keys):  # fmt: skip
    """A whole ``SweepAndPrune.update`` frame in one kernel call (stage, sort, events).

    Parameters
    ----------
    lower, upper : (n, 3) float64
        New bounds as the caller gave them.
    box : (n, 6) float64
        Spare table, written with the new bounds (see ``stage_bounds``).
    old_box : (n, 6) float64
        Current bounds: the ones ``val``/``ep`` are sorted by.
    val, ep, other, keys, flags, meta, budget, log_keys, log_start
        As ``insertion_sort_frame``.
    pair_keys : (k,) int64
        Sorted pair list of the previous frame.
    skip_above : float
        Skip the insertion sort (status ``PREDICTED_OVER``) when the predicted swap count
        exceeds this: the frame is clearly incoherent and the caller rebuilds.
    check : bool
        Validate the bounds (status ``BAD_BOUNDS``, nothing else done).
    no_keys : (0,) int64
        Returned as ``added``/``removed`` when there are none.

    Returns
    -------
    status : int
        ``DONE``, ``OVER_BUDGET``, ``PREDICTED_OVER`` or ``BAD_BOUNDS``.
    bad, row, axis : int
        From ``stage_bounds``.
    predicted : float
    swaps, keys, flags, pair_keys, added, removed
        As ``coherent_frame``.
    """
    bad, row, axis, predicted = stage_bounds(lower, upper, box, old_box, check)
    if bad:
        return BAD_BOUNDS, bad, row, axis, predicted, 0, keys, flags, pair_keys, no_keys, no_keys
    if predicted > skip_above:
        return PREDICTED_OVER, 0, 0, 0, predicted, 0, keys, flags, pair_keys, no_keys, no_keys
    status, swaps, keys, flags, pair_keys, added, removed = coherent_frame(
        box, old_box, val, ep, other, keys, flags, meta, pair_keys, budget, log_keys, log_start,
        no_keys,
    )  # fmt: skip
    return status, 0, 0, 0, predicted, swaps, keys, flags, pair_keys, added, removed
