"""Slow, obviously correct oracle for the broad phase: all-pairs box tests and set bookkeeping.

Nothing here is shared with ``thesis_rbd.collision.broad_phase.sap``: pairs come from an
O(n^2) test of every pair with plain comparisons, events from Python set differences.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BroadPhaseOracle", "brute_force_pairs", "sorted_pairs"]


def sorted_pairs(pairs) -> np.ndarray:
    """Iterable of (i, j) with i < j -> (k, 2) int64 sorted lexicographically."""
    rows = sorted((int(i), int(j)) for i, j in pairs)
    return np.array(rows, dtype=np.int64).reshape(-1, 2)


def brute_force_pairs(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """All (i, j), i < j, whose closed boxes intersect: (k, 2) int64 sorted. O(n^2) memory.

    Parameters
    ----------
    lower, upper : (n, 3) float
    """
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    # overlap[i, j] on every axis: lower_i <= upper_j and lower_j <= upper_i (closed).
    overlap = np.ones((lower.shape[0], lower.shape[0]), dtype=bool)
    for axis in range(3):
        lo = lower[:, axis]
        hi = upper[:, axis]
        overlap &= (lo[:, None] <= hi[None, :]) & (lo[None, :] <= hi[:, None])
    i, j = np.nonzero(np.triu(overlap, k=1))
    return sorted_pairs(zip(i.tolist(), j.tolist(), strict=True))


class BroadPhaseOracle:
    """Mirror of ``SweepAndPrune``'s contract built from sets of tuples.

    Objects are dense rows; ``remove`` renumbers like ``np.delete``.
    """

    def __init__(self) -> None:
        self.lower = np.empty((0, 3))
        self.upper = np.empty((0, 3))
        self.pairs: set[tuple[int, int]] = set()

    def _current(self) -> set[tuple[int, int]]:
        return {(int(i), int(j)) for i, j in brute_force_pairs(self.lower, self.upper)}

    def update(self, lower, upper) -> tuple[np.ndarray, np.ndarray]:
        self.lower = np.array(lower, dtype=np.float64)
        self.upper = np.array(upper, dtype=np.float64)
        new = self._current()
        added, removed = new - self.pairs, self.pairs - new
        self.pairs = new
        return sorted_pairs(added), sorted_pairs(removed)

    def add(self, lower, upper) -> tuple[np.ndarray, np.ndarray]:
        first = self.lower.shape[0]
        self.lower = np.concatenate([self.lower, np.asarray(lower, dtype=np.float64)])
        self.upper = np.concatenate([self.upper, np.asarray(upper, dtype=np.float64)])
        new = self._current()
        added = new - self.pairs
        self.pairs = new
        return np.arange(first, self.lower.shape[0]), sorted_pairs(added)

    def remove(self, ids) -> np.ndarray:
        gone = {int(i) for i in np.atleast_1d(ids)}
        removed = {p for p in self.pairs if p[0] in gone or p[1] in gone}
        survivors = [i for i in range(self.lower.shape[0]) if i not in gone]
        renumber = {old: new for new, old in enumerate(survivors)}
        self.pairs = {(renumber[i], renumber[j]) for i, j in self.pairs - removed}
        self.lower = self.lower[survivors]
        self.upper = self.upper[survivors]
        return sorted_pairs(removed)

    def sorted(self) -> np.ndarray:
        return sorted_pairs(self.pairs)
