"""Sweep-and-prune broad phase with cached overlap pairs (thesis 4.7, 5.3).

Each frame the three sorted endpoint lists of the last frame get the new coordinates and are
re-sorted by insertion sort, which costs O(n + swaps) on nearly sorted input: under temporal
coherence the expected cost per frame is O(n + k) (thesis 4.7, after Lin 1994). A begin/end
swap is the only event that changes whether two boxes overlap, so the overlap set is kept up
to date by those swaps alone, and the frame reports only what changed (the thesis's cached
overlap list, 5.3). When a frame is incoherent (many boxes teleport) insertion sort degrades
towards O(n^2); past a swap budget priced like a full rebuild, the frame is abandoned and
rebuilt by sorting from scratch and one sort-and-sweep, O(n log n + k_axis).

All the work is in the numba kernels of ``_sap_kernels.py`` over flat arrays; this module
checks input, owns the state and decides which kernel runs.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._validate import as_finite_array
from thesis_rbd.collision import _sap_kernels as kernels
from thesis_rbd.collision.pair_table import keys_to_pairs, new_table, table_from_keys

__all__ = ["SweepAndPrune"]

_EMPTY_PAIRS = np.empty((0, 2), dtype=np.int64)

# Price of a full rebuild in "insertion-sort swaps": one swap costs about as much as COST_SORT
# endpoint-sort steps (m log2 m per axis) and COST_SWEEP overlap checks of the sweep
# (measured at n = 10k: a rebuild took 54 ms, 2.0M swaps of an incoherent frame 49 ms). The
# incremental frame is abandoned once its swaps exceed that price, so a frame that was
# predicted coherent but is not wastes at most about one rebuild.
_COST_SORT = 1.0
_COST_SWEEP = 0.5
# A frame predicted to need more than this times the budget skips the insertion sort.
# Measured (bench_sap.py test_fallback_pricing, 10k boxes): with 4.0, frames with 1 % of the
# boxes teleporting ran to the budget and then rebuilt (72 ms against 37 ms for a plain
# re-sort); with 1.0 "auto" matched the better strategy at 0, 0.1, 1 and 10 % teleports.
_PREDICTION_MARGIN = 1.0
_STRATEGIES = ("auto", "incremental", "full")
# Pair keys pack two ids into 32 bits each.
_MAX_OBJECTS = 2**31 - 1


def _check_boxes(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Validated (n, 3) float64 copies of ``lower``/``upper``, or ValueError; no state change."""
    lo = as_finite_array(lower, "lower", shape=(None, 3))
    hi = as_finite_array(upper, "upper", shape=(None, 3))
    if lo.shape != hi.shape:
        raise ValueError(f"lower and upper must have the same shape, got {lo.shape} and {hi.shape}")
    bad = lo > hi
    if bad.any():
        row, axis = (int(x) for x in np.argwhere(bad)[0])
        raise ValueError(
            f"box {row} has lower > upper on axis {axis}: {lo[row, axis]!r} > {hi[row, axis]!r}"
        )
    if lo.shape[0] > _MAX_OBJECTS:
        raise ValueError(f"at most {_MAX_OBJECTS} boxes are supported, got {lo.shape[0]}")
    # as_finite_array may hand back the caller's own array; the state must not alias it.
    return np.array(lo, copy=True), np.array(hi, copy=True)


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
        self._prediction_margin = _PREDICTION_MARGIN
        self._lower = np.empty((0, 3), dtype=np.float64)
        self._upper = np.empty((0, 3), dtype=np.float64)
        self._val = np.empty((3, 0), dtype=np.float64)
        self._ep = np.empty((3, 0), dtype=np.int64)
        self._keys, self._flags, self._meta = new_table(0)
        self._pair_keys = np.empty(0, dtype=np.int64)
        self._pairs_cache: np.ndarray | None = _EMPTY_PAIRS
        # Overlap checks of the last sort-and-sweep: prices the next fallback decision.
        self._sweep_checks = 0
        self.stats: dict = {
            "swaps": 0,
            "full_resort": False,
            "budget": 0,
            "predicted_swaps": 0,
            "pairs": 0,
            "added": 0,
            "removed": 0,
        }

    # ------------------------------------------------------------------ public API

    def __len__(self) -> int:
        """Number of objects."""
        return self._lower.shape[0]

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
        view = self._lower.view()
        view.flags.writeable = False
        return view

    @property
    def upper(self) -> np.ndarray:
        """(n, 3) float64 upper bounds of the objects as last given (a read-only view)."""
        view = self._upper.view()
        view.flags.writeable = False
        return view

    def update(self, lower, upper) -> tuple[np.ndarray, np.ndarray]:
        """Move every object to new bounds and return the pairs that began and ended overlapping.

        Parameters
        ----------
        lower, upper : (n, 3) array_like of float
            Box bounds, row i = object i; ``lower <= upper`` elementwise, all finite. ``n``
            must equal ``len(self)``, except on an empty broad phase, where any ``n`` is the
            first frame (all its pairs are "added"). Use ``add``/``remove`` to change ``n``.

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
        lo, hi = _check_boxes(lower, upper)
        n = lo.shape[0]
        if len(self) > 0 and n != len(self):
            raise ValueError(
                f"update got {n} boxes but the broad phase holds {len(self)} objects; "
                "call add() or remove() to change the number of objects"
            )
        if len(self) == 0:
            self._lower, self._upper = lo, hi
            added, removed = self._rebuild(budget=0, swaps=0)
            return keys_to_pairs(added), keys_to_pairs(removed)
        old_lo, old_hi = self._lower, self._upper
        self._lower, self._upper = lo, hi
        budget = self._swap_budget()
        predicted = kernels.predict_swaps(lo, hi, old_lo, old_hi)
        if self.strategy == "full" or (
            self.strategy == "auto" and predicted > self._prediction_margin * budget
        ):
            # Clearly incoherent (teleports): do not spend the budget to find out.
            added, removed = self._rebuild(budget=budget, swaps=0)
        else:
            status, swaps, keys, flags, touched = kernels.insertion_sort_frame(
                lo, hi, old_lo, old_hi, self._val, self._ep, self._keys, self._flags, self._meta,
                budget, self._log_capacity,
            )  # fmt: skip
            self._keys, self._flags = keys, flags
            if status == kernels.OVER_BUDGET:
                added, removed = self._rebuild(budget=budget, swaps=swaps)
            else:
                added, removed = kernels.collect_events(keys, flags, self._meta, touched)
                self._set_pair_keys(kernels.merge_pair_keys(self._pair_keys, removed, added))
                self._record(swaps, False, budget, added, removed)
        self.stats["predicted_swaps"] = int(min(predicted, 2.0**62))
        return keys_to_pairs(added), keys_to_pairs(removed)

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
        lo, hi = _check_boxes(lower, upper)
        first = len(self)
        m = lo.shape[0]
        if first + m > _MAX_OBJECTS:
            raise ValueError(f"at most {_MAX_OBJECTS} objects are supported")
        ids = np.arange(first, first + m, dtype=np.int64)
        if m == 0:
            self._record(0, False, 0, np.empty(0, np.int64), np.empty(0, np.int64))
            return ids, _EMPTY_PAIRS.copy()
        all_lo = np.concatenate([self._lower, lo])
        all_hi = np.concatenate([self._upper, hi])
        total = first + m
        # Brute force against every object costs m * total checks; a rebuild costs a sort and
        # a sweep. A few bodies joining a large scene take the first, a bulk load the second.
        if first == 0 or m * total > self._rebuild_price(2 * total):
            self._lower, self._upper = all_lo, all_hi
            added, removed = self._rebuild(budget=0, swaps=0)
            assert removed.shape[0] == 0  # old boxes did not move, so no pair can end
            return ids, keys_to_pairs(added)
        new_keys = kernels.pairs_with_new(all_lo, all_hi, first)
        self._val, self._ep = kernels.merge_endpoints(self._val, self._ep, lo, hi, first)
        self._lower, self._upper = all_lo, all_hi
        self._set_pair_keys(kernels.merge_pair_keys(self._pair_keys, new_keys[:0], new_keys))
        self._keys, self._flags, self._meta = table_from_keys(self._pair_keys)
        self._record(0, False, 0, new_keys, np.empty(0, np.int64))
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
        val, ep, kept, removed = kernels.compact_removed(self._val, self._ep, self._pair_keys, gone)
        self._val, self._ep = val, ep
        self._lower = self._lower[~gone]
        self._upper = self._upper[~gone]
        self._set_pair_keys(kept)
        self._keys, self._flags, self._meta = table_from_keys(kept)
        self._record(0, False, 0, np.empty(0, np.int64), removed)
        return keys_to_pairs(removed)

    # ------------------------------------------------------------------ internals

    def _rebuild_price(self, m: int) -> int:
        """Cost of a full rebuild of ``m`` endpoints per axis, in insertion-sort swaps."""
        sort = 3 * m * math.log2(max(m, 2))
        return int(_COST_SORT * sort + _COST_SWEEP * self._sweep_checks + m)

    def _swap_budget(self) -> int:
        if self.strategy == "incremental":
            return np.iinfo(np.int64).max
        return self._rebuild_price(self._ep.shape[1])

    def _rebuild(self, budget: int, swaps: int) -> tuple[np.ndarray, np.ndarray]:
        """Sort from scratch, sweep the axis with fewest overlaps, diff against the old set."""
        self._val, self._ep = kernels.sort_axes(self._lower, self._upper)
        per_axis = kernels.axis_overlap_counts(self._ep)
        axis = int(np.argmin(per_axis))
        new_keys = kernels.sweep_all_pairs(self._lower, self._upper, self._ep, axis)
        self._sweep_checks = int(per_axis[axis])
        added, removed = kernels.diff_sorted(self._pair_keys, new_keys)
        self._set_pair_keys(new_keys)
        self._keys, self._flags, self._meta = table_from_keys(new_keys)
        self._record(swaps, True, budget, added, removed)
        return added, removed

    def _set_pair_keys(self, keys: np.ndarray) -> None:
        self._pair_keys = keys
        self._pairs_cache = None

    def _record(self, swaps, full, budget, added, removed) -> None:
        self.stats = {
            "swaps": int(swaps),
            "full_resort": bool(full),
            "budget": int(budget),
            "predicted_swaps": 0,
            "pairs": int(self._pair_keys.shape[0]),
            "added": int(added.shape[0]),
            "removed": int(removed.shape[0]),
        }

    def _check_invariants(self) -> None:
        """Assert the internal state is consistent (tests and debugging; O(n log n + k))."""
        n = len(self)
        m = 2 * n
        assert self._val.shape == (3, m) and self._ep.shape == (3, m)
        for a in range(3):
            ep = self._ep[a]
            assert np.array_equal(np.sort(ep), np.arange(m)), "endpoint codes not a permutation"
            ids, is_end = ep >> 1, ep & 1
            expected = np.where(is_end == 1, self._upper[ids, a], self._lower[ids, a])
            assert np.array_equal(self._val[a], expected), "stale endpoint values"
            key_ok = (self._val[a][:-1] < self._val[a][1:]) | (
                (self._val[a][:-1] == self._val[a][1:]) & (is_end[:-1] <= is_end[1:])
            )
            assert key_ok.all(), f"axis {a} not sorted by (value, is_end)"
        keys = self._pair_keys
        assert np.all(keys[:-1] < keys[1:]), "pair keys not strictly increasing"
        in_table = np.sort(self._keys[self._keys >= 0])
        assert np.array_equal(in_table, keys), "hash table differs from the pair list"
        assert self._meta[0] == keys.shape[0]
