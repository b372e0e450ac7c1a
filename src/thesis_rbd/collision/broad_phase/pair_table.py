"""Open-addressing hash set of object pairs in flat arrays, for numba kernels.

The sweep-and-prune broad phase (``sap.py``) must answer "is pair (i, j) in the overlap set?"
and insert or delete a pair in O(1) while its insertion sort runs inside a kernel. A sorted key
array would cost O(k) per insertion; a Python set cannot be touched from numba. So the set is
a linear-probing hash table over two flat arrays:

``keys : (capacity,) int64``
    ``unordered_pair_key(i, j)`` (``_pair_keys``: ``i << 32 | j`` with ``i < j``), or ``EMPTY``
    (-1) for a free slot. The key order is the lexicographic order of (i, j), so sorting keys
    sorts pairs.
``flags : (capacity,) uint8``
    ``IN_SET`` (overlapping now), ``WAS_IN`` (overlapping when the frame began) and ``TOUCHED``
    (changed this frame), so a frame's net events can be read off without a second set.

``meta : (1,) int64`` holds the number of occupied slots. The capacity is a power of two and
the load is kept at most one half, so probes stay short. Deletion shifts the following cluster
back (Knuth's algorithm R) instead of leaving tombstones, so a long run never degrades the
table. Functions that may grow the table return the (possibly new) arrays.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "EMPTY",
    "IN_SET",
    "TOUCHED",
    "WAS_IN",
    "new_table",
    "table_delete",
    "table_find",
    "table_from_keys",
    "table_insert",
]

EMPTY = -1
IN_SET = 1
WAS_IN = 2
TOUCHED = 4


@njit
def _home(key, mask):
    # Fibonacci hashing: keys of neighbouring pairs differ in low bits only, so mix them up
    # into the bits that the mask keeps.
    h = np.uint64(key) * np.uint64(0x9E3779B97F4A7C15)
    h ^= h >> np.uint64(31)
    return np.int64(h & np.uint64(mask))


def new_table(expected: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Empty table with room for ``expected`` pairs at load <= 1/2.

    Returns
    -------
    keys : (capacity,) int64, all ``EMPTY``
    flags : (capacity,) uint8, all zero
    meta : (1,) int64, ``[0]``
    """
    capacity = 16
    while capacity < 2 * expected + 2:
        capacity *= 2
    return (
        np.full(capacity, EMPTY, dtype=np.int64),
        np.zeros(capacity, dtype=np.uint8),
        np.zeros(1, dtype=np.int64),
    )


@njit
def table_find(keys, key):
    """Slot of ``key`` in ``keys``, or -1 when absent."""
    mask = keys.shape[0] - 1
    slot = _home(key, mask)
    while True:
        k = keys[slot]
        if k == key:
            return slot
        if k == EMPTY:
            return -1
        slot = (slot + 1) & mask


@njit
def _grow(keys, flags):
    capacity = keys.shape[0] * 2
    mask = capacity - 1
    new_keys = np.full(capacity, EMPTY, dtype=np.int64)
    new_flags = np.zeros(capacity, dtype=np.uint8)
    for s in range(keys.shape[0]):
        k = keys[s]
        if k != EMPTY:
            slot = _home(k, mask)
            while new_keys[slot] != EMPTY:
                slot = (slot + 1) & mask
            new_keys[slot] = k
            new_flags[slot] = flags[s]
    return new_keys, new_flags


@njit
def table_insert(keys, flags, meta, key, flag):
    """Insert ``key`` with ``flags = flag`` if absent; return ``(keys, flags, slot)``.

    The table doubles when it would pass half full, so the returned arrays may be new ones.
    An existing key keeps its flags (the caller edits ``flags[slot]``).
    """
    if 2 * (meta[0] + 1) > keys.shape[0]:
        keys, flags = _grow(keys, flags)
    mask = keys.shape[0] - 1
    slot = _home(key, mask)
    while True:
        k = keys[slot]
        if k == key:
            return keys, flags, slot
        if k == EMPTY:
            keys[slot] = key
            flags[slot] = flag
            meta[0] += 1
            return keys, flags, slot
        slot = (slot + 1) & mask


@njit
def table_delete(keys, flags, meta, slot):
    """Free ``slot`` and shift the rest of its probe cluster back so lookups stay correct."""
    mask = keys.shape[0] - 1
    hole = slot
    probe = slot
    while True:
        probe = (probe + 1) & mask
        k = keys[probe]
        if k == EMPTY:
            break
        home = _home(k, mask)
        # The entry at `probe` may move into the hole only if its home slot is not inside the
        # cyclic interval (hole, probe]; otherwise a lookup starting at home would miss it.
        if hole <= probe:
            stays = hole < home <= probe
        else:
            stays = home > hole or home <= probe
        if not stays:
            keys[hole] = k
            flags[hole] = flags[probe]
            hole = probe
    keys[hole] = EMPTY
    flags[hole] = 0
    meta[0] -= 1


@njit
def table_from_keys(pair_keys):
    """Table holding every key of ``pair_keys`` (distinct) with flag ``IN_SET``."""
    capacity = 16
    while capacity < 2 * pair_keys.shape[0] + 2:
        capacity *= 2
    keys = np.full(capacity, EMPTY, dtype=np.int64)
    flags = np.zeros(capacity, dtype=np.uint8)
    meta = np.zeros(1, dtype=np.int64)
    mask = capacity - 1
    for t in range(pair_keys.shape[0]):
        key = pair_keys[t]
        slot = _home(key, mask)
        while keys[slot] != EMPTY:
            slot = (slot + 1) & mask
        keys[slot] = key
        flags[slot] = IN_SET
    meta[0] = pair_keys.shape[0]
    return keys, flags, meta
