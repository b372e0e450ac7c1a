"""World axis-aligned boxes of posed bodies: fat ones for the broad phase, tight ones for pairs.

A body's mesh lies in the sphere of its bounding radius r about its centre of mass x, whatever
the body's orientation, so the box x ± r bounds it at no cost per step. The broad phase works on
*fat* boxes (Bullet's and Box2D's enlarged AABBs): that sphere's box grown by a margin of
``MARGIN_FRACTION`` r on every side and, on the side the body moves towards, by the distance its
velocity predicts over ``PREDICTION_STEPS`` steps (at most r). A fat box stays put while the
sphere's box stays inside it, which a step checks with six comparisons per body and no
rotation; once one leaves, every moving body's fat box is refitted at once, which keeps the
refits in step, so a scene of bodies in steady motion needs a broad-phase update only every
``PREDICTION_STEPS`` steps or so instead of every step. A body that moved further than its
thickness in one step (a *fast* body) must also keep the sphere's box where the step started
inside its fat box, so that the broad phase sees everything it passed through.

Pairs of fat boxes are only candidates. The *tight* box of a body is exact for its mesh's local
box: posed by the rotation R, the local box (centre offset o from the centre of mass,
half-extents h) has centre x + R o and half-extents |R| h (Arvo 1990), at most sqrt(3) times
too large for the mesh and with no per-vertex work; intersected with x ± r, and for a fast body
joined with the sphere's box at the start of the step. ``tight_bounds`` computes it for the
bodies of fat pairs only, and ``overlapping_pairs`` keeps the pairs whose tight boxes overlap
(``candidate_pairs`` does both in one call).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.spatial.quaternion import to_matrix

__all__ = [
    "MARGIN_FRACTION",
    "PREDICTION_STEPS",
    "candidate_pairs",
    "overlapping_pairs",
    "tight_bounds",
    "update_fat_bounds",
]

# Fat-box margin on every side, as a fraction of the body's bounding radius: room for the
# jitter of resting contact without a refit.
MARGIN_FRACTION = 0.1
# Steps of motion at the current velocity a fat box leaves room for (Box2D v2 predicts 4; more
# steps mean rarer broad-phase updates and slightly more fat pairs to filter).
PREDICTION_STEPS = 128


@njit(allocates=False)
def _posed_box(R, offset, half, x, radius, lower, upper):
    """Tight box of one posed body (Arvo box of the local box within x ± r) into the rows
    ``lower``, ``upper`` (3,); R is the body's rotation, rows as 3-tuples."""
    for a in range(3):
        r = R[a]
        center = x[a] + r[0] * offset[0] + r[1] * offset[1] + r[2] * offset[2]
        extent = abs(r[0]) * half[0] + abs(r[1]) * half[1] + abs(r[2]) * half[2]
        lower[a] = max(center - extent, x[a] - radius)
        upper[a] = min(center + extent, x[a] + radius)


@njit(allocates=False)
def update_fat_bounds(
    count, everything, frozen, radius, thickness, position, start_position, linear_momentum,
    inverse_mass, horizon, fat, fast,
):  # fmt: skip
    """Find the fast bodies and check every moving body against its fat box; refit on a miss.

    Parameters
    ----------
    count : int
        Number of bodies n (the body arrays may be longer).
    everything : bool
        Refit every moving body's fat box (after a scene change).
    frozen : (>= n,) bool
        Bodies that did not move this step (static, asleep, or kinematic and still): their fat
        boxes are kept (the caller makes them their tight boxes: they do not move). A moving
        kinematic body (inverse mass 0) is checked against its fat box like any moving body
        but is never fast (its motion is set, not swept back) and has no speed here (nothing
        it does waits on the sleep stage).
    radius : (>= n,) float64
        Bounding radius r of each body's mesh about its centre of mass.
    thickness : (>= n,) float64
        Smallest width of each body: one that moved further than this is fast.
    position, start_position : (>= n, 3) float64
        World centre of mass now and at the start of the step.
    linear_momentum : (>= n, 3) float64
        P, world frame: the velocity P / M predicts the motion a fat box leaves room for.
    inverse_mass : (>= n,) float64
    horizon : float
        Seconds of motion at the current velocity a refitted fat box covers.
    fat : (2, n, 3) float64
        [lower, upper] fat boxes, world frame; rewritten on a refit.
    fast : (n,) bool
        Output: moved further than its thickness this step.

    Returns
    -------
    refit : bool
        Whether the fat boxes changed (the broad phase must be updated).
    fast_count : int
        Number of fast bodies.
    slowest : float
        Smallest (|P / M| / r)^2 of a moving body (1/s^2, inf if none), its speed in bounding
        radii per second: the sleep stage has nothing to do while every body is faster than
        its tolerance, which is relative to its size.
    """
    refit = everything
    fast_count = 0
    slowest = np.inf
    for i in range(count):
        if frozen[i]:
            fast[i] = False
            continue
        x, x0, r = position[i], start_position[i], radius[i]
        P, im = linear_momentum[i], inverse_mass[i]
        travel2 = (x[0] - x0[0]) ** 2 + (x[1] - x0[1]) ** 2 + (x[2] - x0[2]) ** 2
        is_fast = travel2 > thickness[i] * thickness[i] and im > 0.0
        fast[i] = is_fast
        fast_count += is_fast
        if im > 0.0:
            slowest = min(slowest, (P[0] * P[0] + P[1] * P[1] + P[2] * P[2]) * (im * im / (r * r)))
        for a in range(3):
            lower, upper = x[a] - r, x[a] + r
            if is_fast:
                lower, upper = min(lower, x0[a] - r), max(upper, x0[a] + r)
            refit |= (lower < fat[0, i, a]) | (upper > fat[1, i, a])
    if refit:
        for i in range(count):
            if not frozen[i]:
                _fatten(i, position, start_position, linear_momentum, inverse_mass, radius,
                        fast, horizon, fat)  # fmt: skip
    return refit, fast_count, slowest


@njit(allocates=False)
def _fatten(i, position, start_position, linear_momentum, inverse_mass, radius, fast, horizon, fat):
    """Fat box of moving body i from its sphere's box and its velocity."""
    x, x0, P, im, r = position[i], start_position[i], linear_momentum[i], inverse_mass[i], radius[i]
    margin = MARGIN_FRACTION * r
    for a in range(3):
        lower, upper = x[a] - r, x[a] + r
        if fast[i]:
            lower, upper = min(lower, x0[a] - r), max(upper, x0[a] + r)
        ahead = min(max(P[a] * im * horizon, -r), r)
        fat[0, i, a] = lower - margin + min(ahead, 0.0)
        fat[1, i, a] = upper + margin + max(ahead, 0.0)


@njit(allocates=False)
def tight_bounds(
    members, box_offset, box_half, radius, position, orientation, start_position, fast,
    thickness, speculative, reach, tight,
):  # fmt: skip
    """Tight boxes of the bodies ``members`` (m,) int64 into ``tight`` (2, n, 3) [lower, upper].

    ``box_offset``, ``box_half`` (n, 3) are each body's mesh-frame box (centre offset o from
    the centre of mass, half-extents h) and ``orientation`` (>= n, 4) its (x, y, z, w)
    orientation; a ``fast`` body's box also covers the sphere's box where it started the step.
    Each box is grown by the speculative margin of its body, the larger of ``speculative``
    times its ``thickness`` (n,) and ``reach``, so that pairs a margin apart are candidates
    (see ``convex.contacts``). The other arguments are as in ``update_fat_bounds``.
    """
    for k in range(members.shape[0]):
        i = members[k]
        R = to_matrix(orientation[i])
        _posed_box(R, box_offset[i], box_half[i], position[i], radius[i], tight[0, i], tight[1, i])
        if fast[i]:
            for a in range(3):
                tight[0, i, a] = min(tight[0, i, a], start_position[i, a] - radius[i])
                tight[1, i, a] = max(tight[1, i, a], start_position[i, a] + radius[i])
        pad = max(speculative * thickness[i], reach)
        for a in range(3):
            tight[0, i, a] -= pad
            tight[1, i, a] += pad


@njit(allocates=False)
def overlapping_pairs(pairs, tight, resting, out):
    """The pairs whose tight boxes overlap and that have a moving body.

    Parameters
    ----------
    pairs : (p, 2) int64
        Body pairs (of overlapping fat boxes).
    tight : (2, n, 3) float64
        [lower, upper] tight boxes of (at least) the bodies of ``pairs``; closed intervals, so
        touching boxes overlap.
    resting : (n,) bool
        Bodies that do not move this step: two of them cannot make a new contact.
    out : (>= p, 2) int64
        Receives the kept rows of ``pairs``, in order (written, not returned: an array a
        kernel returns costs more to hand to Python than this whole test of a small scene).

    Returns
    -------
    int
        How many were kept (rows of ``out``).
    """
    kept = 0
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 0], pairs[k, 1]
        if resting[i] and resting[j]:
            continue
        overlap = True
        for a in range(3):
            if tight[0, i, a] > tight[1, j, a] or tight[0, j, a] > tight[1, i, a]:
                overlap = False
                break
        if overlap:
            out[kept, 0], out[kept, 1] = i, j
            kept += 1
    return kept


@njit(allocates=False)
def candidate_pairs(
    pairs, members, box_offset, box_half, radius, position, orientation, start_position, fast,
    thickness, speculative, reach, tight, resting, out,
):  # fmt: skip
    """``tight_bounds`` of ``members`` then ``overlapping_pairs`` of ``pairs``, in one call
    (arguments as theirs); returns the count of candidate pairs written to ``out``."""
    tight_bounds(
        members, box_offset, box_half, radius, position, orientation, start_position, fast,
        thickness, speculative, reach, tight,
    )  # fmt: skip
    return overlapping_pairs(pairs, tight, resting, out)
