"""Whether body pairs overlap or touch, or overlap deeper than a given depth: the yes/no
queries of tunnelling and time-of-impact searches, which ask them about a few pairs many
times over.

Convex pairs answer by the convex contact test without its speculative margin (so the
answer agrees with the contacts the convex path reports), the others by the OBBTree's
first intersecting triangle pair. ``touch_inputs`` of the collision pipeline gathers what
``pairs_touch`` needs besides the pairs and the poses, so that a kernel can ask it in a loop.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.convex.contacts import (
    OUTPUT_FLOATS,
    OUTPUT_INTS,
    convex_contacts_for_pairs,
)
from thesis_rbd.collision.mesh.narrow_phase import any_intersection

__all__ = ["pairs_deeper", "pairs_touch"]


@njit
def pairs_touch(
    pairs, position, orientation, center_of_mass_local, hull_of_body, hull_arrays,
    longest_loop, query_scratch, cache_ints, cache_floats, cache_int_offset,
    cache_float_offset, cache_count, geometry_of_body, geometry_arrays,
):  # fmt: skip
    """Whether any of the body ``pairs`` (p, 2) int64 overlaps or touches.

    ``position``, ``orientation``, ``center_of_mass_local`` are the body poses; the hull
    and cache arguments are as ``convex_contacts_for_pairs`` takes them (a pair is convex
    when both bodies have a hull, ``hull_of_body`` >= 0), ``geometry_of_body`` and
    ``geometry_arrays`` as ``mesh.narrow_phase.any_intersection`` takes them (``geometry_arrays``
    None when every body is convex). Convex pairs are asked first, in the order given, then
    the others.
    """
    convex = np.empty(pairs.shape[0], np.bool_)
    for k in range(pairs.shape[0]):
        convex[k] = hull_of_body[pairs[k, 0]] >= 0 and hull_of_body[pairs[k, 1]] >= 0
    convex_pairs = pairs[convex]
    p = convex_pairs.shape[0]
    if p > 0:
        ints = np.empty(OUTPUT_INTS * p, np.int64)
        floats = np.empty(OUTPUT_FLOATS * p)
        count = convex_contacts_for_pairs(
            convex_pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position,
            orientation, center_of_mass_local, cache_ints, cache_floats, cache_int_offset,
            cache_float_offset, cache_count, 0.0, 0.0, ints, floats,
        )  # fmt: skip
        if count > 0:
            return True
    if geometry_arrays is None or p == pairs.shape[0]:
        return False  # (None: every body convex, a branch numba drops when compiling)
    return any_intersection(
        pairs[~convex], geometry_of_body, geometry_arrays, position, orientation,
        center_of_mass_local,
    )  # fmt: skip


@njit
def pairs_deeper(
    pairs, allowed, position, orientation, center_of_mass_local, hull_of_body, hull_arrays,
    longest_loop, query_scratch, cache_ints, cache_floats, cache_int_offset,
    cache_float_offset, cache_count, geometry_of_body, geometry_arrays,
):  # fmt: skip
    """Whether any of the convex body ``pairs`` (p, 2) int64 has a contact deeper than its
    ``allowed`` (p,) depth (m): a pair that touched already and is asked when it went further
    in. The other arguments are ``pairs_touch``'s (the mesh ones unused: a penetration depth
    is the convex path's)."""
    p = pairs.shape[0]
    if p == 0:
        return False
    ints = np.empty(OUTPUT_INTS * p, np.int64)
    floats = np.empty(OUTPUT_FLOATS * p)
    count = convex_contacts_for_pairs(
        pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position, orientation,
        center_of_mass_local, cache_ints, cache_floats, cache_int_offset, cache_float_offset,
        cache_count, 0.0, 0.0, ints, floats,
    )  # fmt: skip
    for j in range(count):
        a, b, depth = ints[j], ints[count + j], floats[6 * count + j]
        for k in range(p):
            same = (pairs[k, 0] == a and pairs[k, 1] == b) or (
                pairs[k, 0] == b and pairs[k, 1] == a
            )
            if same and depth > allowed[k]:
                return True
    return False
