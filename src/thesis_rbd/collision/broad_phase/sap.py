"""Sweep-and-prune broad phase with cached overlap pairs (thesis 4.7, 5.3).

Each frame the three sorted endpoint lists of the last frame get the new coordinates and are
re-sorted by insertion sort, which costs O(n + swaps) on nearly sorted input: under temporal
coherence the expected cost per frame is O(n + k) (thesis 4.7, after Lin 1994). A begin/end
swap is the only event that changes whether two boxes overlap, so the overlap set is kept up
to date by those swaps alone, and the frame reports only what changed (the thesis's cached
overlap list, 5.3). When a frame is incoherent (many boxes teleport) insertion sort degrades
towards O(n^2); past a swap budget priced like a full rebuild, the frame is abandoned and
rebuilt by sorting from scratch and one sort-and-sweep, O(n log n + k_axis).

In a large scene each axis is sorted per column of a coarse grid across it (a multi-SAP,
``_sap_grid.py``), so that an endpoint only passes the endpoints of its own column and a
coherent frame stays O(n) instead of O(n^(5/3)) at constant density; the grid is chosen at
every full rebuild. All the work is in numba kernels over flat arrays (``_sap_kernels.py``,
``_sap_columns.py``, ``_sap_membership.py``); this module checks input, owns the state and
decides which kernel runs.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._pair_keys import keys_to_pairs
from thesis_rbd.collision.broad_phase import _sap_kernels as kernels
from thesis_rbd.collision.broad_phase import _sap_membership as membership
from thesis_rbd.collision.broad_phase._sap_columns import build_axes
from thesis_rbd.collision.broad_phase._sap_grid import choose_grid, compute_cells, single_cell_grid
from thesis_rbd.collision.broad_phase.pair_table import new_table, table_from_keys

__all__ = ["SweepAndPrune"]

_EMPTY_PAIRS = np.empty((0, 2), dtype=np.int64)
_EMPTY_PAIRS.flags.writeable = False
_NO_BOX = np.empty((0, 6), dtype=np.float64)
_ONE_CELL = single_cell_grid()
_NO_KEYS = np.empty(0, dtype=np.int64)
_INT64_MAX = int(np.iinfo(np.int64).max)

# Price of a full rebuild in "insertion-sort swaps": one swap costs about as much as COST_SORT
# endpoint-sort steps (m log2 m per axis) and COST_SWEEP overlap checks of the sweep (the
# ratio of a rebuild's time to an incoherent frame's swaps, timed at n = 10k). The
# incremental frame is abandoned once its swaps exceed that price, so a frame that was
# predicted coherent but is not wastes at most about one rebuild.
_COST_SORT = 1.0
_COST_SWEEP = 0.5
# A frame predicted to need more than this times the budget skips the insertion sort. A
# margin above 1 lets frames with a few teleporting boxes run to the budget and rebuild
# anyway, paying twice; at 1 "auto" picks the cheaper strategy across teleport fractions
# (bench_sap.py test_fallback_pricing).
_PREDICTION_MARGIN = 1.0
_STRATEGIES = ("auto", "incremental", "full")
# Pair keys pack two ids into 32 bits each.
_MAX_OBJECTS = 2**31 - 1


def _as_bounds(value, name: str) -> np.ndarray:
    """``value`` as a C-contiguous (n, 3) float64 array (maybe the caller's own), or ValueError."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(value).__name__}: {exc}") from exc
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {array.shape}")
    return np.ascontiguousarray(array)


def _check_shapes(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Both bound arrays as C-contiguous (n, 3) float64 of one shape; values not checked."""
    lo = _as_bounds(lower, "lower")
    hi = _as_bounds(upper, "upper")
    if lo.shape != hi.shape:
        raise ValueError(f"lower and upper must have the same shape, got {lo.shape} and {hi.shape}")
    if lo.shape[0] > _MAX_OBJECTS:
        raise ValueError(f"at most {_MAX_OBJECTS} boxes are supported, got {lo.shape[0]}")
    return lo, hi


def _bad_bounds(bad: int, row: int, axis: int, lo: np.ndarray, hi: np.ndarray) -> ValueError:
    """The error for ``stage_bounds``'s finding ``bad`` at (row, axis)."""
    if bad == 1:
        return ValueError(f"lower holds a non-finite value {lo[row, axis]} at index {(row, axis)}")
    if bad == 2:
        return ValueError(f"upper holds a non-finite value {hi[row, axis]} at index {(row, axis)}")
    return ValueError(
        f"box {row} has lower > upper on axis {axis}: {lo[row, axis]!r} > {hi[row, axis]!r}"
    )


def _staged(lower, upper, check: bool = True) -> np.ndarray:
    """(n, 6) box table of ``lower``/``upper`` (a new array); validated (or ValueError) if
    ``check``, else the caller vouches for them (see ``update(check=False)``)."""
    if check:
        lower, upper = _check_shapes(lower, upper)
    box = np.empty((lower.shape[0], 6), dtype=np.float64)
    # Cells are not needed here: the grid is chosen afterwards, from these very bounds.
    cells = np.empty((lower.shape[0], 6), dtype=np.int32)
    bad, row, axis, _ = kernels.stage_bounds(lower, upper, box, cells, _NO_BOX, _ONE_CELL, check)
    if bad:
        raise _bad_bounds(bad, row, axis, lower, upper)
    return box


def _to_pairs(keys: np.ndarray) -> np.ndarray:
    return keys_to_pairs(keys) if keys.shape[0] else np.empty((0, 2), dtype=np.int64)


class SweepAndPrune:
    """Incremental sweep-and-prune over axis-aligned boxes with an overlap-pair cache.

    Objects are the rows of the box arrays: object ``i`` is row ``i``, ids are dense
    ``0 .. len(sap) - 1``. Intervals are closed, so boxes that only touch overlap.

    Parameters
    ----------
    strategy : {"auto", "incremental", "full"}
        How a frame is sorted. "auto" (the default) re-sorts from scratch when the frame's
        predicted swap count (from how far the boxes moved) is far above the price of a
        rebuild, else runs insertion sort and still falls back to a full re-sort once the
        frame has cost more swaps than a rebuild would; "incremental"
        never falls back, "full" always re-sorts. All three give identical results; the
        other two exist to measure the choice.

    Attributes
    ----------
    pairs : (k, 2) int64
        Current overlapping pairs ``[i, j]``, ``i < j``, sorted lexicographically.
    stats : dict
        About the last call: ``swaps`` (adjacent swaps of the insertion sort), ``full_resort``
        (True when the frame was rebuilt from scratch), ``budget`` (swap budget of the
        frame), ``predicted_swaps``, ``pairs``, ``added``, ``removed`` (counts).

    Examples
    --------
    >>> sap = SweepAndPrune()
    >>> added, removed = sap.update(lower, upper)      # first frame: every pair is added
    >>> added, removed = sap.update(lower2, upper2)    # later: only what changed
    >>> ids, added = sap.add(new_lower, new_upper)     # ids len(sap) .. len(sap) + m - 1
    >>> removed = sap.remove([3, 7])                   # later rows shift down, like np.delete
    """

    def __init__(self, strategy: str = "auto") -> None:
        if strategy not in _STRATEGIES:
            raise ValueError(f"strategy must be one of {_STRATEGIES}, got {strategy!r}")
        self.strategy = strategy
        # Transitions buffered between pair-table updates inside a frame (tests shrink it).
        self._log_capacity = 4096
        self._log_keys = np.empty(0, dtype=np.int64)
        self._log_start = np.empty(0, dtype=np.uint8)
        self._prediction_margin = _PREDICTION_MARGIN
        # Keyword arguments of choose_grid (tests ask for many columns from a few boxes).
        self._grid_options: dict = {}
        # Bounds and their cells by id (see _sap_kernels): the current tables and spare ones
        # that the next frame is written into, so that no frame allocates.
        self._box = np.empty((0, 6), dtype=np.float64)
        self._spare = np.empty((0, 6), dtype=np.float64)
        self._cells = np.empty((0, 6), dtype=np.int32)
        self._spare_cells = np.empty((0, 6), dtype=np.int32)
        self._moved = np.zeros(0, dtype=np.uint8)
        self._values = np.empty(0, dtype=np.float64)
        self._grid = single_cell_grid()
        # Endpoint records per axis and grid column (see _sap_columns).
        self._val = np.empty((3, 0), dtype=np.float64)
        self._ep = np.empty((3, 0), dtype=np.int64)
        self._col = np.empty((3, 0), dtype=np.int32)
        self._count = np.zeros(3, dtype=np.int64)
        self._rng = np.empty((3, 0, 4), dtype=np.int32)
        self._keys, self._flags, self._meta = new_table(0)
        self._pair_keys = np.empty(0, dtype=np.int64)
        self._pairs_cache: np.ndarray | None = _EMPTY_PAIRS
        # Overlap checks of the last sort-and-sweep: prices the next fallback decision.
        self._sweep_checks = 0
        self._budget_for = (-1, -1)
        self._budget = 0
        # About the last call; `stats` turns them into a dict on demand.
        self._last = (0, False, 0, 0.0, 0, 0)

    # ------------------------------------------------------------------ public API

    def __len__(self) -> int:
        """Number of objects."""
        return self._box.shape[0]

    @property
    def stats(self) -> dict:
        """About the last call (see the class docstring); a new dict on each access."""
        swaps, full, budget, predicted, added, removed = self._last
        return {
            "swaps": int(swaps),
            "full_resort": bool(full),
            "budget": int(budget),
            "predicted_swaps": int(min(predicted, 2.0**62)),
            "pairs": int(self._pair_keys.shape[0]),
            "added": int(added),
            "removed": int(removed),
        }

    @property
    def pairs(self) -> np.ndarray:
        """(k, 2) int64 overlapping pairs ``[i, j]`` with ``i < j``, sorted; read-only."""
        if self._pairs_cache is None:
            pairs = keys_to_pairs(self._pair_keys)
            pairs.flags.writeable = False
            self._pairs_cache = pairs
        return self._pairs_cache

    @property
    def lower(self) -> np.ndarray:
        """(n, 3) float64 lower bounds of the objects as last given (a read-only view)."""
        view = self._box[:, 0::2]
        view.flags.writeable = False
        return view

    @property
    def upper(self) -> np.ndarray:
        """(n, 3) float64 upper bounds of the objects as last given (a read-only view)."""
        view = self._box[:, 1::2]
        view.flags.writeable = False
        return view

    def update(self, lower, upper, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Move every object to new bounds and return the pairs that began and ended overlapping.

        Parameters
        ----------
        lower, upper : (n, 3) array_like of float
            Box bounds, row i = object i; ``lower <= upper`` elementwise, all finite. ``n``
            must equal ``len(self)``, except on an empty broad phase, where any ``n`` is the
            first frame (all its pairs are "added"). Use ``add``/``remove`` to change ``n``.
        check : bool, optional
            ``False`` is the fast path for trusted callers (the World's pipeline, every step):
            ``lower``/``upper`` must then already be C-contiguous (n, 3) float64 arrays with
            finite values and ``lower <= upper``; only the row count is checked. Broken
            bounds give a wrong pair set rather than an error. The bounds are copied, so the
            caller may overwrite its arrays afterwards.

        Returns
        -------
        added, removed : (k_a, 2) int64, (k_r, 2) int64
            Pairs ``[i, j]`` (``i < j``, sorted) that overlap now but did not at the previous
            call, and the reverse; ``pairs == sorted(old pairs + added - removed)``.

        Raises
        ------
        ValueError
            On a wrong shape, a row count other than ``len(self)``, a non-finite value, or
            ``lower > upper``. The state is unchanged then.
        """
        if check:
            lower, upper = _check_shapes(lower, upper)
        n = lower.shape[0]
        box = self._box
        if box.shape[0] == 0:
            self._set_box(_staged(lower, upper, check))
            added, removed = self._rebuild(budget=0, swaps=0)
            return _to_pairs(added), _to_pairs(removed)
        if n != box.shape[0]:
            raise ValueError(
                f"update got {n} boxes but the broad phase holds {box.shape[0]} objects; "
                "call add() or remove() to change the number of objects"
            )
        if self._log_keys.shape[0] != self._log_capacity:
            self._log_keys = np.empty(self._log_capacity, dtype=np.int64)
            self._log_start = np.empty(self._log_capacity, dtype=np.uint8)
        budget = self._swap_budget()
        if self.strategy == "full":
            skip_above = -1.0
        elif self.strategy == "auto":
            skip_above = self._prediction_margin * budget
        else:
            skip_above = math.inf
        spare = self._spare
        cells = self._cells
        spare_cells = self._spare_cells
        (status, bad, row, axis, predicted, swaps, keys, flags, pair_keys, added, removed,
         self._val, self._ep, self._col) = kernels.update_frame(
            lower, upper, spare, box, spare_cells, cells, self._grid, self._val, self._ep,
            self._col, self._count, self._rng, self._moved, self._values, self._keys, self._flags,
            self._meta, self._pair_keys, budget, skip_above, check, self._log_keys,
            self._log_start, _NO_KEYS,
        )  # fmt: skip
        if status == kernels.BAD_BOUNDS:
            raise _bad_bounds(bad, row, axis, lower, upper)
        # The spare tables hold the new bounds now; the old tables become the spares.
        self._box, self._spare = spare, box
        self._cells, self._spare_cells = spare_cells, cells
        self._keys, self._flags = keys, flags
        if status == kernels.DONE:
            if added.shape[0] or removed.shape[0]:
                self._set_pair_keys(pair_keys)
            self._last = (swaps, False, budget, predicted, added.shape[0], removed.shape[0])
        else:
            # PREDICTED_OVER: clearly incoherent (teleports), the insertion sort was skipped;
            # OVER_BUDGET: it was abandoned and its partial state is discarded.
            added, removed = self._rebuild(budget=budget, swaps=swaps)
            self._last = self._last[:3] + (predicted,) + self._last[4:]
        return _to_pairs(added), _to_pairs(removed)

    def add(self, lower, upper) -> tuple[np.ndarray, np.ndarray]:
        """Append objects; their endpoints are merged into the sorted axes (no re-sort).

        Parameters
        ----------
        lower, upper : (m, 3) array_like of float
            Bounds of the new objects.

        Returns
        -------
        ids : (m,) int64
            Their ids, ``len(self) .. len(self) + m - 1`` (the next rows of ``update``).
        added : (k, 2) int64
            The pairs the new objects overlap in, sorted; they are in ``pairs`` at once and
            are not reported again by the next ``update``.
        """
        new_box = _staged(lower, upper)
        first = len(self)
        m = new_box.shape[0]
        if first + m > _MAX_OBJECTS:
            raise ValueError(f"at most {_MAX_OBJECTS} objects are supported")
        ids = np.arange(first, first + m, dtype=np.int64)
        if m == 0:
            self._record(0, False, 0, 0, 0)
            return ids, _EMPTY_PAIRS.copy()
        all_box = np.concatenate([self._box, new_box])
        total = first + m
        # Brute force against every object costs m * total checks; a rebuild costs a sort and
        # a sweep. A few bodies joining a large scene take the first, a bulk load the second.
        if first == 0 or m * total > self._rebuild_price(2 * total):
            self._set_box(all_box)
            added, removed = self._rebuild(budget=0, swaps=0)
            assert removed.shape[0] == 0  # old boxes did not move, so no pair can end
            return ids, keys_to_pairs(added)
        new_keys = membership.pairs_with_new(all_box, first)
        all_cells = np.concatenate([self._cells, compute_cells(new_box, self._grid)])
        self._val, self._ep, self._col, self._rng = membership.merge_new_boxes(
            all_box, all_cells, self._grid, self._val, self._ep, self._col, self._count,
            self._rng, first,
        )  # fmt: skip
        self._set_box(all_box, all_cells)
        self._set_pair_keys(kernels.merge_pair_keys(self._pair_keys, new_keys[:0], new_keys))
        self._keys, self._flags, self._meta = table_from_keys(self._pair_keys)
        self._record(0, False, 0, new_keys.shape[0], 0)
        return ids, keys_to_pairs(new_keys)

    def remove(self, ids) -> np.ndarray:
        """Remove objects; the remaining ones are renumbered densely in their order.

        Like ``np.delete(rows, ids, axis=0)``: after removing ids ``R``, object ``i`` becomes
        ``i - |{r in R : r < i}|``, and ``update`` takes the correspondingly shorter arrays.
        The renumbering keeps order, so the sorted axes and pairs are compacted, not re-sorted.

        Parameters
        ----------
        ids : (r,) array_like of int
            Distinct ids in ``[0, len(self))``.

        Returns
        -------
        removed : (k, 2) int64
            The pairs that involved a removed object, sorted, in the numbering **before**
            the removal.
        """
        idx = np.asarray(ids)
        if idx.ndim == 0:
            idx = idx.reshape(1)
        if idx.ndim != 1 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
            raise ValueError(f"ids must be a 1-D array of integers, got {idx.dtype} {idx.shape}")
        idx = idx.astype(np.int64)
        n = len(self)
        if idx.size and (idx.min() < 0 or idx.max() >= n):
            raise ValueError(f"ids must lie in [0, {n}), got {idx.min()} .. {idx.max()}")
        if np.unique(idx).size != idx.size:
            raise ValueError("ids must be distinct")
        gone = np.zeros(n, dtype=bool)
        gone[idx] = True
        self._rng, kept, removed = membership.compact_removed(
            self._val, self._ep, self._col, self._count, self._rng, self._pair_keys, gone
        )
        self._set_box(self._box[~gone], self._cells[~gone])
        self._set_pair_keys(kept)
        self._keys, self._flags, self._meta = table_from_keys(kept)
        self._record(0, False, 0, 0, removed.shape[0])
        return keys_to_pairs(removed)

    # ------------------------------------------------------------------ internals

    def _rebuild_price(self, m: int) -> int:
        """Cost of a full rebuild of ``m`` endpoints per axis, in insertion-sort swaps."""
        sort = 3 * m * math.log2(max(m, 2))
        return int(_COST_SORT * sort + _COST_SWEEP * self._sweep_checks + m)

    def _swap_budget(self) -> int:
        """Swaps after which a frame is abandoned for a rebuild (cached per object set)."""
        m = 2 * len(self)
        if self._budget_for != (m, self._sweep_checks):
            self._budget_for = (m, self._sweep_checks)
            incremental = self.strategy == "incremental"
            self._budget = _INT64_MAX if incremental else self._rebuild_price(m)
        return self._budget

    def _set_box(self, box: np.ndarray, cells: np.ndarray | None = None) -> None:
        """New object set: its bounds (and cells) tables, spares of the same size, scratch."""
        self._box = np.ascontiguousarray(box)
        self._spare = np.empty_like(self._box)
        if cells is not None:
            self._cells = np.ascontiguousarray(cells)
            # Zeros: stage_bounds leaves the cells of a one-cell dimension untouched.
            self._spare_cells = np.zeros_like(self._cells)
        self._moved = np.zeros(self._box.shape[0], dtype=np.uint8)
        self._values = np.empty(2 * self._box.shape[0], dtype=np.float64)

    def _rebuild(self, budget: int, swaps: int) -> tuple[np.ndarray, np.ndarray]:
        """Choose the grid, sort from scratch, sweep the axis with fewest overlaps, diff."""
        self._grid, cells = choose_grid(self._box, **self._grid_options)
        self._set_box(self._box, cells)
        gval, gep = kernels.sort_axes(self._box)
        per_axis = kernels.axis_overlap_counts(gep)
        axis = int(np.argmin(per_axis))
        new_keys = kernels.sweep_all_pairs(self._box, gep, axis)
        self._val, self._ep, self._col, self._count, self._rng = build_axes(
            gval, gep, cells, self._grid
        )
        self._sweep_checks = int(per_axis[axis])
        added, removed = kernels.diff_sorted(self._pair_keys, new_keys)
        self._set_pair_keys(new_keys)
        self._keys, self._flags, self._meta = table_from_keys(new_keys)
        self._record(swaps, True, budget, added.shape[0], removed.shape[0])
        return added, removed

    def _set_pair_keys(self, keys: np.ndarray) -> None:
        self._pair_keys = keys
        self._pairs_cache = None

    def _record(self, swaps, full, budget, added, removed) -> None:
        self._last = (swaps, full, budget, 0.0, added, removed)

    def _check_invariants(self) -> None:
        """Assert the internal state is consistent (tests and debugging; O(records log))."""
        n = len(self)
        assert self._spare.shape == self._box.shape == (n, 6)
        assert self._spare_cells.shape == self._cells.shape == (n, 6)
        assert np.array_equal(self._cells, compute_cells(self._box, self._grid)), "stale cells"
        assert self._moved.shape == (n,) and not self._moved.any()
        assert self._values.shape == (2 * n,)
        assert self._rng.shape == (3, n, 4)
        for a in range(3):
            m = int(self._count[a])
            ep, col, val = self._ep[a, :m], self._col[a, :m], self._val[a, :m]
            ids, is_end = ep >> 1, ep & 1
            assert np.array_equal(val, self._box[ids, 2 * a + is_end]), "stale endpoint values"
            key_ok = (col[:-1] < col[1:]) | (
                (col[:-1] == col[1:])
                & ((val[:-1] < val[1:]) | ((val[:-1] == val[1:]) & (is_end[:-1] <= is_end[1:])))
            )
            assert key_ok.all(), f"axis {a} not sorted by (column, value, is_end)"
            # Every box has a begin and an end record in each column of its range, no others.
            gc = int(self._grid[(a + 2) % 3, 2])
            want = set()
            for i, (b0, b1, c0, c1) in enumerate(self._rng[a].tolist()):
                for kb in range(b0, b1 + 1):
                    for kc in range(c0, c1 + 1):
                        want |= {(2 * i, kb * gc + kc), (2 * i + 1, kb * gc + kc)}
            got = list(zip(ep.tolist(), col.tolist(), strict=True))
            assert len(got) == len(set(got)) and set(got) == want, f"axis {a} records"
        # The last axis sorted (z) is binned by the current bounds of the other two.
        assert np.array_equal(self._rng[2], self._cells[:, [0, 1, 2, 3]])
        keys = self._pair_keys
        assert np.all(keys[:-1] < keys[1:]), "pair keys not strictly increasing"
        in_table = np.sort(self._keys[self._keys >= 0])
        assert np.array_equal(in_table, keys), "hash table differs from the pair list"
        assert self._meta[0] == keys.shape[0]
