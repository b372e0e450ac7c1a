"""Warm starts: each contact begins the solve with the impulse its predecessor ended with.

A contact is recognised across steps by its body pair and, where the narrow phase names the
features that made it (a feature id >= 0: the convex path's face, edge and clip ids), by that
id; otherwise (the mesh path) by where it sits on body a: the nearest previous contact of the
same pair within ``MATCH_FRACTION`` of the smaller body's thickness, measured in a's body frame.
Impulses are kept as world vectors and read back in the new contact frame, whose tangents may
have turned.

The remembered contacts are two plain arrays sorted by pair key, ``keys`` (m, 2) int64 (the
pair key ``_pair_keys.pair_key(a, b)`` and the feature id, -1: none) and ``values`` (m, 6)
float64 (the contact point in body a's frame about its centre of mass, and the world-frame
impulse vector it applied to body a), kept in the world's step state and passed to the
contact kernel, which writes their successors into new arrays the caller passes.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["MATCH_FRACTION", "find_warm_impulses"]

MATCH_FRACTION = 0.1


@njit
def find_warm_impulses(keys, features, local_points, radius, old_keys, old_values):
    """World impulse vectors (c, 3) of each contact's predecessor; zero where none.

    Parameters
    ----------
    keys, features : (c,) int64
    local_points : (c, 3) float64
        The new contacts in body a's frame.
    radius : (c,) float64
        How far a predecessor without a matching feature id may lie.
    old_keys, old_values
        The remembered contacts (keys sorted by pair; see the module docstring).
    """
    c = keys.shape[0]
    m = old_keys.shape[0]
    warm = np.zeros((c, 3))
    pair_column = np.ascontiguousarray(old_keys[:, 0])
    for k in range(c):
        i = np.searchsorted(pair_column, keys[k])
        best, best_d2 = -1, radius[k] * radius[k]
        while i < m and pair_column[i] == keys[k]:
            if features[k] >= 0 and old_keys[i, 1] == features[k]:
                best = i
                break
            d2 = 0.0
            for a in range(3):
                d2 += (old_values[i, a] - local_points[k, a]) ** 2
            if d2 <= best_d2:
                best, best_d2 = i, d2
            i += 1
        if best >= 0:
            for a in range(3):
                warm[k, a] = old_values[best, 3 + a]
    return warm
