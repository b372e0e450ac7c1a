"""Keys of body pairs: one int64 per pair, ``i << 32 | j``, for ids below 2**31.

Every table of pairs in the package (the sweep-and-prune overlap set, the convex coherence
cache, the warm start, the time-of-impact groups) keys a pair this way, so that sorting keys
sorts pairs lexicographically by (i, j) and one key names the same pair everywhere.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "first_of",
    "keys_to_pairs",
    "pair_key",
    "pair_keys",
    "second_of",
    "unordered_pair_key",
]

_LOW32 = (1 << 32) - 1


@njit(allocates=False)
def pair_key(i, j):
    """Key of the ordered pair (i, j)."""
    return (np.int64(i) << 32) | np.int64(j)


@njit(allocates=False)
def unordered_pair_key(i, j):
    """Key of the unordered pair {i, j}: that of (min, max)."""
    if i < j:
        return pair_key(i, j)
    return pair_key(j, i)


@njit(allocates=False)
def first_of(key):
    """i of the pair whose key is ``key``."""
    return key >> 32


@njit(allocates=False)
def second_of(key):
    """j of the pair whose key is ``key``."""
    return key & _LOW32


@njit
def pair_keys(body_a, body_b):
    """(c,) int64 keys of the ordered pairs (body_a[k], body_b[k])."""
    keys = np.empty(body_a.shape[0], np.int64)
    for k in range(body_a.shape[0]):
        keys[k] = pair_key(body_a[k], body_b[k])
    return keys


def keys_to_pairs(keys: np.ndarray) -> np.ndarray:
    """(k,) int64 pair keys -> (k, 2) int64 rows ``[i, j]`` in the same order."""
    out = np.empty((keys.shape[0], 2), dtype=np.int64)
    out[:, 0] = keys >> 32
    out[:, 1] = keys & _LOW32
    return out
