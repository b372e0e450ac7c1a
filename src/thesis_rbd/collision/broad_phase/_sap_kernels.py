"""numba kernels of the sweep-and-prune broad phase (thesis 4.7, 5.3); ``sap.py`` wraps them.

Flat state shared by the kernels, with ``n`` objects:

``box : (n, 6) float64``
    Bounds of each object, row ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]``. The wrapper keeps two
    and swaps them each frame (new and previous), and likewise two ``cells``.
``cells : (n, 6) int32``
    The grid cells of those bounds (``_sap_grid``).
``val, ep, col, count, rng``
    The endpoint records of each axis, one sorted run per grid column (``_sap_columns``).
``values : (2n,) float64``
    Scratch: the new coordinates of one axis by endpoint code, that the records read.

Sort key of an endpoint is ``(column, value, is_end)``: on equal coordinates a begin sorts
before an end, so intervals that only touch are seen as overlapping (closed intervals). With
that key, inside a column that lists both boxes, "the intervals of i and j overlap on axis a"
is exactly "begin_i precedes end_j and begin_j precedes end_i". A frame moves the axes one
after the other, x then y then z; while axis ``a`` moves, the other two hold their new bounds
if sorted already this frame, else their previous ones, and the columns of ``a`` are those of
exactly these bounds (``rebin_axis``). A pair's overlap changes while axis ``a`` moves only
when a begin of one passes an end of the other while the other two axes overlap, and that
swap happens in every column that lists both boxes; it is counted in one of them only, the
column of the pair's canonical point ``(max lo_b, max lo_c)``, which lies in both boxes (they
overlap on b and c) and whose cells are ``max`` of the two boxes' cells (the cell map is
monotone). So each overlap transition is logged exactly once, as with a single list.

The other two axes' bounds are read from the bounds tables by id at a begin/end swap only:
with columns, swaps are few (a few per box per frame), and the per-record copies that a
single list needed to avoid a cache miss per swap (1.8M swaps per frame at n = 10^5) would
cost a gather of four values for every record of every frame.

Why three sorted axes and not one: a single sorted axis finds the pairs whose intervals
start or stop overlapping on that axis, but a pair that already overlaps on it and starts
overlapping on another axis makes no swap there. Catching it needs either the full sweep of
the sorted axis every frame, O(n + k_axis) with k_axis ~ n^(5/3) pairs overlapping on one
axis in a uniform 3-D scene (about 10^8 at n = 10^5: the NumPy peer of the benchmark), or the
other axes sorted as well.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._pair_keys import unordered_pair_key
from thesis_rbd._sorting import sorted_copy
from thesis_rbd.collision.broad_phase._sap_columns import rebin_axis
from thesis_rbd.collision.broad_phase._sap_grid import cell_of
from thesis_rbd.collision.broad_phase.pair_table import (
    IN_SET,
    TOUCHED,
    WAS_IN,
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
def _endpoint_values(box, a, out):
    """``out[code]`` = coordinate on axis ``a`` of endpoint ``code``: a sequential copy.

    The records' refresh then gathers from 16 bytes per box instead of a 48-byte row: a table
    a third of the size, which at large n mostly stays in cache.
    """
    for i in range(box.shape[0]):
        out[2 * i] = box[i, 2 * a]
        out[2 * i + 1] = box[i, 2 * a + 1]


@njit
def _refresh_values(values, val, ep, col, count, a):
    """Give every record of axis ``a`` its new coordinate ``values[code]``: one gather each.

    Returns the first record whose key is below its predecessor's (``count[a]`` when none):
    the insertion sort starts there. The gather and the order check are separate loops
    without branches, so that the compiler vectorises them; the first out-of-order record is
    looked for only when there is one.
    """
    va = val[a]
    ea = ep[a]
    ca = col[a]
    m = count[a]
    for p in range(m):
        va[p] = values[ea[p]]
    # Branch-free, so that the compiler vectorises it: is any record below its predecessor?
    bad = False
    for p in range(1, m):
        bad |= (ca[p] == ca[p - 1]) & (
            (va[p] < va[p - 1]) | ((va[p] == va[p - 1]) & ((ea[p - 1] & 1) > (ea[p] & 1)))
        )
    if not bad:
        return m
    for p in range(1, m):
        if (ca[p] == ca[p - 1]) and (
            va[p] < va[p - 1] or (va[p] == va[p - 1] and (ea[p - 1] & 1) > (ea[p] & 1))
        ):
            return p
    return m


@njit
def _sort_axis(val, ep, col, box_b, box_c, cells_b, cells_c, gc, a, p, m, log_keys, log_start,
               swaps, budget):  # fmt: skip
    """Insertion-sort the records of axis ``a`` from element ``p`` on, logging transitions.

    The hot loop of the broad phase. It calls nothing (not even the pair table) and never
    reallocates, so that numba compiles it to a tight loop; transitions go to a fixed-size
    log that the caller applies to the pair table. A record never leaves its column: the
    column is the first part of the key, so the column array is not touched.

    Parameters
    ----------
    box_b, box_c : (n, 6) float64
        The bounds tables that hold axis ``b``'s and axis ``c``'s bounds as this axis sees
        them (``b = a + 1``, ``c = a + 2`` mod 3); ``cells_b``, ``cells_c`` their cells.
    gc : int
        Cells of the grid along ``c`` (``column = cell_b * gc + cell_c``).
    p : int
        First record to insert, at least 1.
    m : int
        Records of the axis.

    Returns
    -------
    p : int
        Where to resume: ``m`` when the axis is sorted. Less when the log filled up (the
        element being moved is parked at the hole, which keeps the prefix before it sorted,
        so resuming there is exact) or when ``swaps`` passed ``budget``.
    nlog : int
        Log entries written: ``log_keys[t]`` a pair key, ``log_start[t]`` 1 when the pair
        began to overlap, 0 when it stopped.
    swaps : int
        Running swap count.
    """
    b = (a + 1) % 3
    c = (a + 2) % 3
    # Rows as 1-D views: the inner loop indexes one array per quantity.
    va = val[a]
    ea = ep[a]
    ca = col[a]
    capacity = log_keys.shape[0]
    nlog = 0
    while p < m:
        v = va[p]
        code = ea[p]
        is_end = code & 1
        k = ca[p]
        vq = va[p - 1]
        if vq < v or (vq == v and (ea[p - 1] & 1) <= is_end) or ca[p - 1] != k:
            # Already in place (a record of an earlier column is below it in any case).
            p += 1
            continue
        q = p - 1
        full = False
        # Move `code` left past every endpoint of its column whose key is larger.
        while q >= 0:
            vq = va[q]
            cq = ea[q]
            if ca[q] != k or vq < v or (vq == v and (cq & 1) <= is_end):
                break
            if (cq & 1) != is_end:
                i = code >> 1
                j = cq >> 1
                # Bitwise, not short-circuit: one well-predicted branch instead of four
                # data-dependent ones (transitions are rare).
                if (
                    (box_b[i, 2 * b] <= box_b[j, 2 * b + 1])
                    & (box_b[j, 2 * b] <= box_b[i, 2 * b + 1])
                    & (box_c[i, 2 * c] <= box_c[j, 2 * c + 1])
                    & (box_c[j, 2 * c] <= box_c[i, 2 * c + 1])
                ):
                    canonical = max(cells_b[i, 2 * b], cells_b[j, 2 * b]) * gc + max(
                        cells_c[i, 2 * c], cells_c[j, 2 * c]
                    )
                    if canonical == k:
                        # A begin passing an end leftwards starts the pair, an end passing
                        # a begin ends it.
                        if nlog == capacity:
                            full = True
                            break
                        log_keys[nlog] = unordered_pair_key(i, j)
                        log_start[nlog] = 1 - is_end
                        nlog += 1
            va[q + 1] = vq
            ea[q + 1] = cq
            swaps += 1
            q -= 1
        va[q + 1] = v
        ea[q + 1] = code
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


@njit(separate=True)
def insertion_sort_frame(box, old_box, cells, old_cells, grid, val, ep, col, count, rng, moved,
                         values, keys, flags, meta, budget, log_keys, log_start):  # fmt: skip
    """One coherent frame: move each axis's records into their columns and insertion-sort them.

    Expected cost O(n + records + swaps), swaps = endpoint crossings inside columns since the
    last frame (thesis 4.7).

    Parameters
    ----------
    box, cells : (n, 6) float64, (n, 6) int32
        New bounds and their cells.
    old_box, old_cells : (n, 6) float64, (n, 6) int32
        Bounds of the previous frame (the ones the records are sorted by) and their cells.
    grid : (3, 3) float64
    val, ep, col, count, rng : the records (``_sap_columns``); updated, may be reallocated.
    moved : (n,) uint8
        Zero scratch.
    values : (2n,) float64
        Scratch.
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
    val, ep, col : the record arrays (new ones if they grew).
    """
    touched = np.empty(64, dtype=np.int64)
    ntouched = 0
    swaps = 0
    for a in range(3):
        b = (a + 1) % 3
        c = (a + 2) % 3
        # The other axes as this one sees them: new when sorted earlier this frame.
        box_b = box if b < a else old_box
        box_c = box if c < a else old_box
        cells_b = cells if b < a else old_cells
        cells_c = cells if c < a else old_cells
        gc = np.int64(grid[c, 2])
        if np.int64(grid[b, 2]) * gc > 1:
            val, ep, col = rebin_axis(
                old_box, cells_b, cells_c, grid, val, ep, col, count, rng, moved, a
            )
        _endpoint_values(box, a, values)
        p = max(_refresh_values(values, val, ep, col, count, a), 1)
        m = count[a]
        while p < m:
            p, nlog, swaps = _sort_axis(
                val, ep, col, box_b, box_c, cells_b, cells_c, gc, a, p, m, log_keys, log_start,
                swaps, budget,
            )  # fmt: skip
            keys, flags, touched, ntouched = _apply_log(
                keys, flags, meta, log_keys, log_start, nlog, touched, ntouched
            )
            if swaps > budget:
                return OVER_BUDGET, swaps, keys, flags, touched[:ntouched], val, ep, col
    return DONE, swaps, keys, flags, touched[:ntouched], val, ep, col


@njit
def stage_bounds(lower, upper, box, cells, old_box, grid, check):
    """Copy ``lower``/``upper`` into ``box``, their cells into ``cells``, predict the swaps.

    O(n).

    Parameters
    ----------
    lower, upper : (n, 3) float64
        New bounds as the caller gave them.
    box : (n, 6) float64
        Written: row ``[lo_x, hi_x, lo_y, hi_y, lo_z, hi_z]`` per id.
    cells : (n, 6) int32
        Written: the grid cells of those bounds, on the dimensions with more than one cell
        (left as they are on the others, where every cell is 0).
    old_box : (n, 6) float64 or (0, 6)
        Previous frame's bounds (read only), or empty when there is none (no prediction).
    grid : (3, 3) float64
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
        over each axis's extent and its columns: an endpoint moving by d passes about
        d * (2n / extent / columns) others, and each swap moves two endpoints relative to
        each other. It only has to tell a coherent frame from one where boxes teleport
        (orders of magnitude apart); the swap budget is the safety net.
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
            if grid[a, 2] > 1.0:
                cells[i, 2 * a] = cell_of(lo, grid[a, 0], grid[a, 1], grid[a, 2])
                cells[i, 2 * a + 1] = cell_of(hi, grid[a, 0], grid[a, 1], grid[a, 2])
    if old_box.shape[0] != n or n == 0:
        return 0, 0, 0, 0.0
    total = 0.0
    for a in range(3):
        lo_min = np.inf
        hi_max = -np.inf
        moved = 0.0
        for i in range(n):
            lo = box[i, 2 * a]
            hi = box[i, 2 * a + 1]
            if lo < lo_min:
                lo_min = lo
            if hi > hi_max:
                hi_max = hi
            moved += abs(lo - old_box[i, 2 * a]) + abs(hi - old_box[i, 2 * a + 1])
        if hi_max > lo_min:
            columns = grid[(a + 1) % 3, 2] * grid[(a + 2) % 3, 2]
            total += moved * n / (hi_max - lo_min) / columns
    return 0, 0, 0, total


@njit(separate=True)
def coherent_frame(box, old_box, cells, old_cells, grid, val, ep, col, count, rng, moved, values,
                   keys, flags, meta, pair_keys, budget, log_keys, log_start, no_keys):  # fmt: skip
    """Insertion sort, net events and the new sorted pair list of a frame, in one call.

    Arguments as ``insertion_sort_frame``; ``pair_keys`` is the sorted pair list of the
    previous frame; ``no_keys`` an empty int64 array, returned as the events of a frame
    without any.

    Returns
    -------
    status, swaps, keys, flags
        As ``insertion_sort_frame``.
    pair_keys : (k,) int64
        The new sorted pair list (the same array when nothing changed; meaningless when
        ``status`` is ``OVER_BUDGET``).
    added, removed : (k_a,) int64, (k_r,) int64
        Sorted keys of the frame's net events (empty when ``OVER_BUDGET``).
    val, ep, col
        The record arrays (new ones if they grew).
    """
    status, swaps, keys, flags, touched, val, ep, col = insertion_sort_frame(
        box, old_box, cells, old_cells, grid, val, ep, col, count, rng, moved, values, keys,
        flags, meta, budget, log_keys, log_start,
    )  # fmt: skip
    if status != DONE or touched.shape[0] == 0:
        # Nothing to collect. Handing back arrays the caller passed in is cheap: numba
        # returns their Python objects instead of wrapping new ones.
        return status, swaps, keys, flags, pair_keys, no_keys, no_keys, val, ep, col
    added, removed = collect_events(keys, flags, meta, touched)
    if added.shape[0] or removed.shape[0]:
        pair_keys = merge_pair_keys(pair_keys, removed, added)
    return status, swaps, keys, flags, pair_keys, added, removed, val, ep, col


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
    return sorted_copy(added[:na]), sorted_copy(removed[:nr])


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
                out[k] = unordered_pair_key(order[s], order[t])
                k += 1
    return sorted_copy(out[:k])


@njit
def update_frame(lower, upper, box, old_box, cells, old_cells, grid, val, ep, col, count, rng,
                 moved, values, keys, flags, meta, pair_keys, budget, skip_above, check, log_keys,
                 log_start, no_keys):  # fmt: skip
    """A whole ``SweepAndPrune.update`` frame in one kernel call (stage, sort, events).

    Parameters
    ----------
    lower, upper : (n, 3) float64
        New bounds as the caller gave them.
    box, cells : (n, 6) float64, (n, 6) int32
        Spare tables, written with the new bounds and their cells (see ``stage_bounds``).
    old_box, old_cells : (n, 6) float64, (n, 6) int32
        Current bounds (the ones the records are sorted by) and their cells.
    grid, val, ep, col, count, rng, moved, values, keys, flags, meta, budget, log_keys, log_start
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
    swaps, keys, flags, pair_keys, added, removed, val, ep, col
        As ``coherent_frame``.
    """
    bad, row, axis, predicted = stage_bounds(lower, upper, box, cells, old_box, grid, check)
    if bad or predicted > skip_above:
        status = BAD_BOUNDS if bad else PREDICTED_OVER
        return (status, bad, row, axis, predicted, 0, keys, flags, pair_keys, no_keys, no_keys,
                val, ep, col)  # fmt: skip
    status, swaps, keys, flags, pair_keys, added, removed, val, ep, col = coherent_frame(
        box, old_box, cells, old_cells, grid, val, ep, col, count, rng, moved, values, keys,
        flags, meta, pair_keys, budget, log_keys, log_start, no_keys,
    )  # fmt: skip
    return status, 0, 0, 0, predicted, swaps, keys, flags, pair_keys, added, removed, val, ep, col
