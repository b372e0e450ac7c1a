"""Islands: groups of dynamic bodies connected through contacts.

Contacts never connect through a static body (it cannot pass an impulse on), so a pile of
separate boxes on one floor is one island per box. Islands are solved independently, which
keeps the exact solver's dense matrices small, and fall asleep as a whole.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._sorting import stable_argsort
from thesis_rbd._union_find import find_root, join

__all__ = ["find_islands", "find_linked_islands", "order_from_the_top"]


@njit(separate=True)
def find_islands(body_count, body_a, body_b, static):
    """``find_linked_islands`` without links: bodies joined by their contacts only."""
    none = np.empty(0, np.int64)
    return _label_islands(body_count, body_a, body_b, static, none, none)


@njit(separate=True)
def find_linked_islands(body_count, body_a, body_b, static, link_a, link_b):
    """Label bodies and contacts by island, bodies joined by their contacts and by links
    (``_label_islands``)."""
    return _label_islands(body_count, body_a, body_b, static, link_a, link_b)


@njit(inline="always")
def _label_islands(body_count, body_a, body_b, static, link_a, link_b):
    """Label bodies and contacts by island, bodies joined by their contacts and by links
    (inlined in each of the two kernels above, so that a scene without joints compiles only
    ``find_islands``).

    Parameters
    ----------
    body_count : int
        Number of bodies n.
    body_a, body_b : (c,) int64
        The two bodies of each contact.
    static : (n,) bool
        Static bodies belong to no island.
    link_a, link_b : (l,) int64
        Pairs of bodies that belong to one island whether they touch or not (the bodies of a
        joint; -1, the world, links nothing).

    Returns
    -------
    body_island : (n,) int64
        Island index of each dynamic body that touches something or is linked to a body
        that does; -1 for static bodies and the rest.
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
    for k in range(link_a.shape[0]):
        a, b = link_a[k], link_b[k]
        if a < 0 or b < 0 or static[a] or static[b]:
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


@njit(separate=True)
def order_from_the_top(body_count, body_a, body_b, static, contact_order, island_start):
    """Re-order each island's contacts so that those furthest from a static support come first.

    A body's level is its number of contacts away from a static body (1 for a body resting
    on the floor; 0 for bodies of an island that touches nothing static). A contact's level is
    the larger of its bodies'. Sequential impulses that start at the top of a stack carry the
    weight of every body above to the support within one sweep; starting at the bottom, each
    sweep passes it one body further down.

    Parameters
    ----------
    body_count, body_a, body_b, static
        As ``find_islands``.
    contact_order, island_start
        ``find_islands``'s output.

    Returns
    -------
    (c,) int64
        The contact order, island slices unchanged, each slice sorted by level (highest
        first, ties in their previous order).
    """
    c = body_a.shape[0]
    # bodies' neighbours through contacts between two movable bodies (CSR)
    degree = np.zeros(body_count + 1, np.int64)
    for k in range(c):
        a, b = body_a[k], body_b[k]
        if not static[a] and not static[b]:
            degree[a + 1] += 1
            degree[b + 1] += 1
    start = np.cumsum(degree)
    fill = start[:-1].copy()
    neighbour = np.empty(start[-1], np.int64)
    level = np.zeros(body_count, np.int64)
    queue = np.empty(body_count, np.int64)
    head = tail = 0
    for k in range(c):
        a, b = body_a[k], body_b[k]
        if not static[a] and not static[b]:
            neighbour[fill[a]] = b
            fill[a] += 1
            neighbour[fill[b]] = a
            fill[b] += 1
        else:
            supported = b if static[a] else a
            if not static[supported] and level[supported] == 0:
                level[supported] = 1
                queue[tail] = supported
                tail += 1
    while head < tail:  # breadth first from the supported bodies
        i = queue[head]
        head += 1
        for idx in range(start[i], start[i + 1]):
            j = neighbour[idx]
            if level[j] == 0:
                level[j] = level[i] + 1
                queue[tail] = j
                tail += 1
    # one stable sort by (island, level from the top): islands keep their slices
    highest = 0
    for i in range(body_count):
        highest = max(highest, level[i])
    key = np.empty(c, np.int64)
    for isl in range(island_start.shape[0] - 1):
        for idx in range(island_start[isl], island_start[isl + 1]):
            k = contact_order[idx]
            key[idx] = isl * (highest + 1) + highest - max(level[body_a[k]], level[body_b[k]])
    return contact_order[stable_argsort(key)]
