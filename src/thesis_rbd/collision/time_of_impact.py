"""Time of impact: bodies that ended their free flight inside something are stepped back.

A body that flew freely through a step (the contact stage did not act on it) and ends it
inside another body met it during the step. This stage finds when: each group of such bodies
(joined by the contacts that hit them) retraces its ballistic path,

    x(-t) = x - v t + a t^2 / 2,   v(-t) = v - a t,   q turned by -w t,

exact for a constant force and torque-free spin over the step, and bisection on the yes/no
intersection query finds the last moment before the present at which the group's pairs did
not touch, to dt / 2^``HALVINGS``. The bodies are left there with their velocities of that
moment, and the contacts of their pairs are found anew; what remains of the step is the
impact stage's (``dynamics/impacts.py``). A group that already touched at the start of the
step (a contact found then by the yes/no query but not by the contact generator, as at an
exact touch) goes back to where it started: its whole step is the impact stage's.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd._union_find import find_root, join
from thesis_rbd.collision.convex_contacts import convex_contacts_for_pairs
from thesis_rbd.spatial.quaternion import mul, normalize

__all__ = [
    "HALVINGS",
    "bisect_convex_group",
    "group_contacts",
    "impact_groups",
    "move_ballistic",
    "step_back_to_impact",
    "unique_pairs",
]

HALVINGS = 12


@njit
def move_ballistic(members, t, v, w, acceleration, position, orientation):
    """Move the bodies ``members`` (m,) by time t (negative: back) along their ballistic paths.

    Velocities ``v`` (n, 3) follow (v + a t); ``w`` (n, 3) is kept (torque-free spin).
    """
    for idx in range(members.shape[0]):
        i = members[idx]
        for a in range(3):
            position[i, a] += v[i, a] * t + 0.5 * acceleration[i, a] * t * t
            v[i, a] += acceleration[i, a] * t
        rx, ry, rz = w[i, 0] * t, w[i, 1] * t, w[i, 2] * t
        angle = math.sqrt(rx * rx + ry * ry + rz * rz)
        if angle == 0.0:
            continue
        s = math.sin(0.5 * angle) / angle
        turn = (rx * s, ry * s, rz * s, math.cos(0.5 * angle))
        q = (orientation[i, 0], orientation[i, 1], orientation[i, 2], orientation[i, 3])
        q = normalize(mul(turn, q))
        for k in range(4):
            orientation[i, k] = q[k]


@njit
def impact_groups(body_count, body_a, body_b, hits, movers):
    """Group the movers of the contacts ``hits`` (c,) bool that join them.

    Returns ``group`` (n,) int64: the group of each mover in a hit contact, -1 elsewhere, and
    the number of groups. Bodies that are not movers (static, resting, solved this step) are
    obstacles: they join nothing.
    """
    parent = np.arange(body_count)
    for k in range(body_a.shape[0]):
        if hits[k] and movers[body_a[k]] and movers[body_b[k]]:
            join(parent, body_a[k], body_b[k])
    label = np.full(body_count, -1)
    group = np.full(body_count, -1)
    groups = 0
    for k in range(body_a.shape[0]):
        if not hits[k]:
            continue
        for i in (body_a[k], body_b[k]):
            if movers[i]:
                r = find_root(parent, i)
                if label[r] < 0:
                    label[r] = groups
                    groups += 1
                group[i] = label[r]
    return group, groups


@njit
def unique_pairs(body_a, body_b, selected, body_count):
    """(p, 2) int64: the distinct body pairs of the ``selected`` (c,) bool contacts, sorted by
    (a, b) (as ``np.unique(..., axis=0)``, which costs tens of microseconds a call)."""
    keys = np.empty(body_a.shape[0], np.int64)
    m = 0
    for k in range(body_a.shape[0]):
        if selected[k]:
            keys[m] = body_a[k] * (body_count + 1) + body_b[k]
            m += 1
    distinct = np.unique(keys[:m])
    pairs = np.empty((distinct.shape[0], 2), np.int64)
    for r in range(distinct.shape[0]):
        pairs[r, 0], pairs[r, 1] = divmod(distinct[r], body_count + 1)
    return pairs


@njit
def group_contacts(group, g, body_a, body_b):
    """Group g's bodies (m,) int64, its contacts (c,) bool (those with a body in the group)
    and their distinct pairs (``unique_pairs``), from ``group`` (n,) of ``impact_groups``."""
    members = np.flatnonzero(group == g)
    mine = np.zeros(body_a.shape[0], np.bool_)
    for k in range(body_a.shape[0]):
        mine[k] = group[body_a[k]] == g or group[body_b[k]] == g
    return members, mine, unique_pairs(body_a, body_b, mine, group.shape[0])


def step_back_to_impact(detector, bodies, contacts, hits, movers, v, w, acceleration, dt):
    """Step each group of movers with a hit contact back to its time of impact.

    Parameters
    ----------
    detector : CollisionPipeline
        Answers ``intersects(bodies, pairs)`` and ``contacts_of(bodies, pairs)``.
    bodies : BodyArrays
        Positions and orientations of stepped-back bodies are moved to their time of impact.
    contacts : dict of arrays
        This step's contacts at the end of the step.
    hits : (c,) bool
        Contacts that a mover ran into during the step.
    movers : (n,) bool
        Bodies in free flight this step.
    v, w : (n, 3) float64
        Velocities at the end of the step; stepped-back bodies get those of their time of
        impact.
    acceleration : (n, 3) float64
        Constant acceleration of each body over the step (external force / mass).
    dt : float
        The step: no body goes back further.

    Returns
    -------
    rewind : (n,) float64
        How far (s) each body went back; 0 for bodies left where they were.
    contacts : dict of arrays
        The contact set with the stepped-back bodies' contacts found again where they are now.
    """
    n = bodies.count
    rewind = np.zeros(n)
    body_a, body_b = contacts["body_a"], contacts["body_b"]
    group, groups = impact_groups(n, body_a, body_b, hits, movers)
    position, orientation = bodies.full("position"), bodies.full("orientation")
    renewed = np.zeros(len(body_a), bool)
    for g in range(groups):
        members, mine, pairs = group_contacts(group, g, body_a, body_b)
        convex = detector.convex_inputs(pairs)
        if convex is None:
            t = _bisect(
                detector, bodies, members, pairs, v, w, acceleration, position, orientation, dt
            )
        else:
            t = bisect_convex_group(
                members, pairs, v, w, acceleration, position, orientation, dt,
                bodies.full("center_of_mass_local"), *convex,
            )  # fmt: skip
        if t > 0.0:
            rewind[members] = t
            renewed |= mine
    if not renewed.any():
        return rewind, contacts
    fresh = detector.contacts_of(bodies, unique_pairs(body_a, body_b, renewed, n))
    kept = ~renewed
    return rewind, {key: np.concatenate([contacts[key][kept], fresh[key]]) for key in fresh}


def _bisect(detector, bodies, members, pairs, v, w, acceleration, position, orientation, dt):
    """Leave ``members`` just inside first contact and return how far back that is (s).

    Returns ``dt`` (with the bodies where they started the step) when the pairs already
    touched then. Any pairs, through the detector's yes/no query; ``bisect_convex_group``
    is the same search in one kernel call for pairs of convex bodies.
    """
    at = 0.0

    def move_to(t):
        nonlocal at
        move_ballistic(members, at - t, v, w, acceleration, position, orientation)
        at = t

    move_to(dt)
    if detector.intersects(bodies, pairs):
        return dt
    inside, outside = 0.0, dt
    for _ in range(HALVINGS):
        middle = 0.5 * (inside + outside)
        move_to(middle)
        if detector.intersects(bodies, pairs):
            inside = middle
        else:
            outside = middle
    move_to(inside)
    return inside


@njit
def bisect_convex_group(
    members, pairs, v, w, acceleration, position, orientation, dt, center_of_mass_local,
    hull_of_body, hull_arrays, longest_loop, cache_keys, cache_features, cache_axes,
):  # fmt: skip
    """``_bisect`` for a group whose ``pairs`` (p, 2) are all of convex bodies, in one call.

    The same moves and the same yes/no answers in the same order (the convex contact test
    without its speculative margin, as ``CollisionPipeline.intersects`` asks it, with the
    pipeline's coherence cache), so the same time and poses to the bit; the bisection in
    Python cost a kernel call and its glue per halving, most of a pile's step.

    Parameters
    ----------
    members : (m,) int64
        The group's bodies, moved back along their ballistic paths.
    pairs : (p, 2) int64
        The pairs whose contact is sought.
    v, w, acceleration, position, orientation
        As ``move_ballistic``; ``v`` and the poses are left at the time found.
    dt : float
        The step: no body goes back further.
    center_of_mass_local, hull_of_body, hull_arrays, longest_loop, cache_keys,
    cache_features, cache_axes
        As ``convex_contacts_for_pairs``.

    Returns
    -------
    float
        How far back (s) the bodies were left: just inside first contact, or ``dt`` (where
        they started the step) if the pairs touched already then.
    """
    p = pairs.shape[0]
    ints = np.empty(1 + 24 * p, np.int64)
    floats = np.empty(31 * p)
    query = (
        hull_of_body, hull_arrays, longest_loop, position, orientation, center_of_mass_local,
        cache_keys, cache_features, cache_axes,
    )  # fmt: skip
    move_ballistic(members, -dt, v, w, acceleration, position, orientation)
    at = dt
    if _touching(pairs, query, ints, floats):
        return dt
    inside, outside = 0.0, dt
    for _ in range(HALVINGS):
        middle = 0.5 * (inside + outside)
        move_ballistic(members, at - middle, v, w, acceleration, position, orientation)
        at = middle
        if _touching(pairs, query, ints, floats):
            inside = middle
        else:
            outside = middle
    move_ballistic(members, at - inside, v, w, acceleration, position, orientation)
    return inside


@njit
def _touching(pairs, query, ints, floats):
    """Whether any of the convex ``pairs`` overlaps or touches: the convex contact test
    without its speculative margin; ``query`` holds its other inputs, ``ints`` and
    ``floats`` are its output buffers."""
    return convex_contacts_for_pairs(pairs, *query, 0.0, 0.0, ints, floats) > 0
