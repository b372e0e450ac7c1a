"""Islands: groups of dynamic bodies connected through contacts.

Contacts never connect through a static body (it cannot pass an impulse on), so a pile of
separate boxes on one floor is one island per box. Islands are solved independently, which
keeps the exact solver's dense matrices small, and fall asleep as a whole.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd._union_find import find_root, join

__all__ = ["find_islands"]


@njit
def find_islands(body_count, body_a, body_b, static):
    """Label bodies and contacts by island.

    Parameters
    ----------
    body_count : int
        Number of bodies n.
    body_a, body_b : (c,) int64
        The two bodies of each contact.
    static : (n,) bool
        Static bodies belong to no island.

    Returns
    -------
    body_island : (n,) int64
        Island index of each dynamic body that touches something; -1 for static bodies and
        for bodies without contacts.
    contact_order : (c,) int64
        Contacts sorted by island.
    island_start : (m + 1,) int64
        Contacts of island i are contact_order[island_start[i]:island_start[i + 1]]; only
        islands with at least one contact are counted (m of them, numbered from 0).
    """
    parent = np.arange(body_count)
    c = body_a.shape[0]
    for k in range(c):
        a, b = body_a[k], body_b[k]
        if static[a] or static[b]:
            continue
        join(parent, a, b)
    # number the islands that own contacts, in order of their first contact
    label = np.full(body_count, -1)
    contact_island = np.empty(c, np.int64)
    islands = 0
    for k in range(c):
        a = body_a[k] if not static[body_a[k]] else body_b[k]
        r = find_root(parent, a)
        if label[r] < 0:
            label[r] = islands
            islands += 1
        contact_island[k] = label[r]
    body_island = np.full(body_count, -1)
    for i in range(body_count):
        if not static[i]:
            body_island[i] = label[find_root(parent, i)]
    counts = np.zeros(islands + 1, np.int64)
    for k in range(c):
        counts[contact_island[k] + 1] += 1
    island_start = np.cumsum(counts)
    fill = island_start[:-1].copy()
    contact_order = np.empty(c, np.int64)
    for k in range(c):
        i = contact_island[k]
        contact_order[fill[i]] = k
        fill[i] += 1
    return body_island, contact_order, island_start
