"""Endpoint records of the sweep-and-prune, one sorted list per grid column, in one array per axis.

The columns of axis ``a`` are cells of the plane across it (``_sap_grid``). Each axis keeps
``count[a]`` records, sorted by the key ``(column, value, is_end)``, so every column's records
are one contiguous sorted run and an insertion sort never moves a record out of its column:

``val : (3, cap) float64``
    Endpoint coordinate on axis ``a`` of each record (row ``a``, first ``count[a]`` entries).
``ep : (3, cap) int64``
    Endpoint code: ``2 * id`` for a begin (lower bound), ``2 * id + 1`` for an end.
``col : (3, cap) int32``
    Column of the record; a box has a begin and an end record in every column it meets.
``rng : (3, n, 4) int32``
    Per axis and box, the cell ranges ``[b0, b1, c0, c1]`` on the two other dimensions
    whose columns hold the box's records.

A box moving across a cell boundary gets records in the columns it enters and loses those in
the columns it leaves (``rebin_axis``), at the place of its previous coordinate, so that the
insertion sort that follows sees every column as it was sorted last frame.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._sorting import stable_argsort

__all__ = ["build_axes", "merge_records", "new_records", "rebin_axis"]


@njit(separate=True)
def _sort_records(rv, re, rc):
    """Records ``(value, code, column)`` sorted by the key (column, value, is_end)."""
    # Three stable passes: begins before ends, then by value, then by column. The integer
    # keys are sorted as int64, the type of the package's other stable sorts, so that one
    # version of the sort serves them all.
    order = stable_argsort((re & 1).astype(np.int64))
    order = order[stable_argsort(rv[order])]
    order = order[stable_argsort(rc[order].astype(np.int64))]
    return rv[order], re[order], rc[order]


@njit
def new_records(box, cells, grid, ids, a):
    """Sorted records on axis ``a`` of boxes ``ids`` in every column they meet.

    Parameters
    ----------
    box : (n, 6) float64
        Bounds; the records take their axis-``a`` coordinates from it.
    cells : (n, 6) int32
        Cells of the bounds that place the boxes in columns.
    grid : (3, 3) float64
    ids : (k,) int64
    a : int

    Returns
    -------
    rv, re, rc : (r,) float64, (r,) int64, (r,) int32
    """
    b = (a + 1) % 3
    c = (a + 2) % 3
    gc = np.int64(grid[c, 2])
    total = 0
    for t in range(ids.shape[0]):
        i = ids[t]
        total += (cells[i, 2 * b + 1] - cells[i, 2 * b] + 1) * (
            cells[i, 2 * c + 1] - cells[i, 2 * c] + 1
        )
    rv = np.empty(2 * total, dtype=np.float64)
    re = np.empty(2 * total, dtype=np.int64)
    rc = np.empty(2 * total, dtype=np.int32)
    r = 0
    for t in range(ids.shape[0]):
        i = ids[t]
        for kb in range(cells[i, 2 * b], cells[i, 2 * b + 1] + 1):
            for kc in range(cells[i, 2 * c], cells[i, 2 * c + 1] + 1):
                for e in range(2):
                    rv[r] = box[i, 2 * a + e]
                    re[r] = 2 * i + e
                    rc[r] = kb * gc + kc
                    r += 1
    return _sort_records(rv, re, rc)


@njit
def _grown(val, ep, col, count, need):
    """The three record arrays with room for ``need`` records per axis (copies)."""
    cap = max(need + need // 4 + 16, 2 * val.shape[1])
    new_val = np.empty((3, cap), dtype=np.float64)
    new_ep = np.empty((3, cap), dtype=np.int64)
    new_col = np.empty((3, cap), dtype=np.int32)
    for a in range(3):
        new_val[a, : count[a]] = val[a, : count[a]]
        new_ep[a, : count[a]] = ep[a, : count[a]]
        new_col[a, : count[a]] = col[a, : count[a]]
    return new_val, new_ep, new_col


@njit
def merge_records(val, ep, col, count, a, rv, re, rc):
    """Merge sorted records into axis ``a`` in place, from the back: O(count + r).

    Returns ``(val, ep, col)``, new arrays when they had to grow.
    """
    r = rv.shape[0]
    if r == 0:
        return val, ep, col
    m = count[a]
    if m + r > val.shape[1]:
        val, ep, col = _grown(val, ep, col, count, m + r)
    p = m - 1
    t = r - 1
    o = m + r - 1
    while t >= 0:
        take_old = False
        if p >= 0:
            kp = col[a, p]
            kt = rc[t]
            vp = val[a, p]
            vt = rv[t]
            take_old = kp > kt or (
                kp == kt and (vp > vt or (vp == vt and (ep[a, p] & 1) > (re[t] & 1)))
            )
        if take_old:
            val[a, o] = val[a, p]
            ep[a, o] = ep[a, p]
            col[a, o] = col[a, p]
            p -= 1
        else:
            val[a, o] = rv[t]
            ep[a, o] = re[t]
            col[a, o] = rc[t]
            t -= 1
        o -= 1
    count[a] = m + r
    return val, ep, col


@njit(separate=True)
def rebin_axis(old_box, cells_b, cells_c, grid, val, ep, col, count, rng, moved, a):
    """Move the records of axis ``a`` into the columns of the current cells, keeping order.

    Records keep the previous frame's coordinates (``old_box``) that the axis is sorted by;
    new ones are inserted at those, so each column stays sorted and the insertion sort that
    follows makes exactly the swaps of that column's boxes.

    Parameters
    ----------
    old_box : (n, 6) float64
        Bounds the axis is sorted by.
    cells_b, cells_c : (n, 6) int32
        Cells of the bounds on dimensions ``b = a + 1`` and ``c = a + 2`` (mod 3) that this
        frame's sort of axis ``a`` sees: new for an axis sorted before ``a``, else previous.
    grid, val, ep, col, count, rng
        See the module docstring; updated in place.
    moved : (n,) uint8
        Zero on entry and on return (scratch).
    a : int

    Returns
    -------
    val, ep, col
        New arrays when they had to grow.
    """
    b = (a + 1) % 3
    c = (a + 2) % 3
    gc = np.int64(grid[c, 2])
    n = rng.shape[1]
    # Boxes entering a column, with the ranges they had: [id, b0, b1, c0, c1].
    pending = np.empty((0, 5), dtype=np.int64)
    npending = 0
    dropped = 0
    for i in range(n):
        b0 = cells_b[i, 2 * b]
        b1 = cells_b[i, 2 * b + 1]
        c0 = cells_c[i, 2 * c]
        c1 = cells_c[i, 2 * c + 1]
        o0 = rng[a, i, 0]
        o1 = rng[a, i, 1]
        o2 = rng[a, i, 2]
        o3 = rng[a, i, 3]
        if b0 == o0 and b1 == o1 and c0 == o2 and c1 == o3:
            continue
        if not (b0 <= o0 and o1 <= b1 and c0 <= o2 and o3 <= c1):
            moved[i] = 1  # leaves a column: its records there go
            dropped += 1
        if not (o0 <= b0 and b1 <= o1 and o2 <= c0 and c1 <= o3):
            if npending == pending.shape[0]:
                grown = np.empty((2 * npending + 16, 5), dtype=np.int64)
                grown[:npending] = pending[:npending]
                pending = grown
            pending[npending, 0] = i
            pending[npending, 1] = o0
            pending[npending, 2] = o1
            pending[npending, 3] = o2
            pending[npending, 4] = o3
            npending += 1
        rng[a, i, 0] = b0
        rng[a, i, 1] = b1
        rng[a, i, 2] = c0
        rng[a, i, 3] = c1
    if dropped:
        o = 0
        for p in range(count[a]):
            code = ep[a, p]
            i = code >> 1
            if moved[i]:
                k = np.int64(col[a, p])
                kb = k // gc
                kc = k - kb * gc
                if kb < rng[a, i, 0] or kb > rng[a, i, 1] or kc < rng[a, i, 2] or kc > rng[a, i, 3]:
                    continue
            val[a, o] = val[a, p]
            ep[a, o] = code
            col[a, o] = col[a, p]
            o += 1
        count[a] = o
        for i in range(n):
            moved[i] = 0
    if npending:
        rv, re, rc = _entered(old_box, rng, gc, pending[:npending], a)
        val, ep, col = merge_records(val, ep, col, count, a, rv, re, rc)
    return val, ep, col


@njit
def _had(pending, t, kb, kc):
    """Whether the old range of ``pending[t]`` holds the column of cells ``(kb, kc)``."""
    return pending[t, 1] <= kb <= pending[t, 2] and pending[t, 3] <= kc <= pending[t, 4]


@njit
def _entered(old_box, rng, gc, pending, a):
    """Sorted records, at the coordinates of ``old_box``, of boxes entering columns.

    ``pending[t] = [id, b0, b1, c0, c1]`` holds the range the box had; ``rng`` the new one.
    """
    total = 0
    for t in range(pending.shape[0]):
        i = pending[t, 0]
        for kb in range(rng[a, i, 0], rng[a, i, 1] + 1):
            for kc in range(rng[a, i, 2], rng[a, i, 3] + 1):
                if not _had(pending, t, kb, kc):
                    total += 1
    rv = np.empty(2 * total, dtype=np.float64)
    re = np.empty(2 * total, dtype=np.int64)
    rc = np.empty(2 * total, dtype=np.int32)
    r = 0
    for t in range(pending.shape[0]):
        i = pending[t, 0]
        for kb in range(rng[a, i, 0], rng[a, i, 1] + 1):
            for kc in range(rng[a, i, 2], rng[a, i, 3] + 1):
                if not _had(pending, t, kb, kc):
                    for e in range(2):
                        rv[r] = old_box[i, 2 * a + e]
                        re[r] = 2 * i + e
                        rc[r] = kb * gc + kc
                        r += 1
    return _sort_records(rv, re, rc)


@njit
def build_axes(gval, gep, cells, grid):
    """Records of every box from the globally sorted endpoints: O(records + columns).

    A stable distribution of each axis's sorted endpoints by column keeps them sorted inside
    every column, so nothing is sorted twice.

    Parameters
    ----------
    gval, gep : (3, 2n) float64, int64
        Every axis's endpoints sorted by (value, is_end), as ``sort_axes`` returns them.
    cells : (n, 6) int32
        Cells of the current bounds.
    grid : (3, 3) float64

    Returns
    -------
    val, ep, col, count, rng
        See the module docstring.
    """
    m = gep.shape[1]
    n = m // 2
    rng = np.empty((3, n, 4), dtype=np.int32)
    count = np.zeros(3, dtype=np.int64)
    for a in range(3):
        b = (a + 1) % 3
        c = (a + 2) % 3
        total = 0
        for i in range(n):
            rng[a, i, 0] = cells[i, 2 * b]
            rng[a, i, 1] = cells[i, 2 * b + 1]
            rng[a, i, 2] = cells[i, 2 * c]
            rng[a, i, 3] = cells[i, 2 * c + 1]
            total += (rng[a, i, 1] - rng[a, i, 0] + 1) * (rng[a, i, 3] - rng[a, i, 2] + 1)
        count[a] = 2 * total
    cap = count.max() + count.max() // 8 + 16
    val = np.empty((3, cap), dtype=np.float64)
    ep = np.empty((3, cap), dtype=np.int64)
    col = np.empty((3, cap), dtype=np.int32)
    for a in range(3):
        c = (a + 2) % 3
        gc = np.int64(grid[c, 2])
        columns = np.int64(grid[(a + 1) % 3, 2]) * gc
        if columns == 1:
            val[a, :m] = gval[a]
            ep[a, :m] = gep[a]
            col[a, :m] = 0
            continue
        start = np.zeros(columns + 1, dtype=np.int64)
        for i in range(n):
            for kb in range(rng[a, i, 0], rng[a, i, 1] + 1):
                for kc in range(rng[a, i, 2], rng[a, i, 3] + 1):
                    start[kb * gc + kc + 1] += 2
        for k in range(columns):
            start[k + 1] += start[k]
        for p in range(m):
            code = gep[a, p]
            i = code >> 1
            for kb in range(rng[a, i, 0], rng[a, i, 1] + 1):
                for kc in range(rng[a, i, 2], rng[a, i, 3] + 1):
                    k = kb * gc + kc
                    o = start[k]
                    val[a, o] = gval[a, p]
                    ep[a, o] = code
                    col[a, o] = k
                    start[k] = o + 1
    return val, ep, col, count, rng
