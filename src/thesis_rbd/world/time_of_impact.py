"""Time of impact: bodies that ended their free flight inside something are stepped back.

A body that flew freely through a step (the contact stage did not act on it) and ends it
inside another body met it during the step. This stage finds when: each group of such bodies
(joined by the contacts that hit them) retraces its ballistic path,

    x(-t) = x - v t + a t^2 / 2,   v(-t) = v - a t,   q turned back freely,

exact for a constant force and torque-free spin over the step, and bisection on the yes/no
intersection query finds the last moment before the present at which the group's pairs did
not touch, to dt / 2^``HALVINGS``. The bodies are left there with their velocities of that
moment, and the contacts of their pairs are found anew; what remains of the step is the
impact stage's (``dynamics/impacts.py``). A group that already touched at the start of the
step (a contact found then by the yes/no query but not by the contact generator, as at an
exact touch) goes back to where it started: its whole step is the impact stage's.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._pair_keys import first_of, pair_key, second_of
from thesis_rbd._sorting import unique_sorted
from thesis_rbd._union_find import find_root, join
from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.touching import pairs_touch
from thesis_rbd.dynamics.free_rotation import turn_freely

__all__ = [
    "HALVINGS",
    "bisect_to_contact",
    "group_contacts",
    "impact_groups",
    "passed_through",
    "step_back_to_impact",
    "unique_pairs",
]

HALVINGS = 12


@njit
def impact_groups(body_count, body_a, body_b, hits, movers):
    """Group the movers that go back in time together: those joined by a contact to a mover
    of a hit contact (``hits`` (c,) bool), directly or through other movers.

    Movers in contact move together over the step (two touching cubes flying into a third):
    stepping one back to its time of impact and not the other would leave them overlapping.
    Returns ``group`` (n,) int64: the group of each such mover, -1 elsewhere, and the number
    of groups. Bodies that are not movers (static, resting) are obstacles: they join nothing.
    """
    parent = np.arange(body_count)
    for k in range(body_a.shape[0]):
        if movers[body_a[k]] and movers[body_b[k]]:
            join(parent, body_a[k], body_b[k])
    hit_root = np.zeros(body_count, np.bool_)
    for k in range(body_a.shape[0]):
        if hits[k]:
            for i in (body_a[k], body_b[k]):
                if movers[i]:
                    hit_root[find_root(parent, i)] = True
    label = np.full(body_count, -1)
    group = np.full(body_count, -1)
    groups = 0
    for i in range(body_count):
        if not movers[i]:
            continue
        r = find_root(parent, i)
        if not hit_root[r]:
            continue
        if label[r] < 0:
            label[r] = groups
            groups += 1
        group[i] = label[r]
    return group, groups


@njit
def unique_pairs(body_a, body_b, selected):
    """(p, 2) int64: the distinct body pairs of the ``selected`` (c,) bool contacts, sorted by
    (a, b) (as ``np.unique(..., axis=0)``, which costs tens of microseconds a call)."""
    keys = np.empty(body_a.shape[0], np.int64)
    m = 0
    for k in range(body_a.shape[0]):
        if selected[k]:
            keys[m] = pair_key(body_a[k], body_b[k])
            m += 1
    distinct = unique_sorted(keys[:m])
    pairs = np.empty((distinct.shape[0], 2), np.int64)
    for r in range(distinct.shape[0]):
        pairs[r, 0], pairs[r, 1] = first_of(distinct[r]), second_of(distinct[r])
    return pairs


@njit
def group_contacts(group, g, body_a, body_b, hits):
    """Group g's bodies (m,) int64, its contacts (c,) bool (those with a body in the group)
    and the distinct pairs (``unique_pairs``) of those it hit (``hits`` (c,) bool), from
    ``group`` (n,) of ``impact_groups``.

    Only the hit pairs are searched for a first contact: a pair that touches at the start of
    the step (a row of boxes face to face) touched before the impact, and searching it too
    would send the group back to the start of the step every step."""
    members = np.flatnonzero(group == g)
    mine = np.zeros(body_a.shape[0], np.bool_)
    for k in range(body_a.shape[0]):
        mine[k] = group[body_a[k]] == g or group[body_b[k]] == g
    return members, mine, unique_pairs(body_a, body_b, mine & hits)


def passed_through(detector, contacts, receding, start_position, start_orientation, cache):
    """Which receding contacts (``impacts.find_hits``) a body ran into during the step.

    A penetrating contact of a body in free flight that recedes along its normal is a hit
    when its pair was apart at the start of the step: the body flew past the middle of the
    other (a small body through a thin plate), so the least penetration points out of the
    far side. Such contacts are rare, so each distinct pair is asked on its own.

    Parameters
    ----------
    detector : CollisionPipeline
        Answers ``intersects(pairs, position, orientation, cache)``.
    contacts : ContactSet
        This step's contacts (c rows).
    receding : (c,) bool
    start_position : (n, 3) float64
    start_orientation : (n, 4) float64
        The bodies' poses at the start of the step (world frame).
    cache : tuple
        The convex coherence cache (``convex.contacts``).

    Returns
    -------
    (c,) bool
        The receding contacts whose pair did not touch at the start of the step.
    """
    pairs = np.stack([contacts["body_a"], contacts["body_b"]], axis=1)[receding]
    distinct, which = np.unique(pairs, axis=0, return_inverse=True)
    touched = [
        detector.intersects(pair[None], start_position, start_orientation, cache)
        for pair in distinct
    ]
    apart = ~np.array(touched, bool)
    passed = np.zeros(len(receding), bool)
    passed[receding] = apart[which.ravel()]
    return passed


def step_back_to_impact(detector, bodies, contacts, hits, movers, v, acceleration, dt, cache):
    """Step each group of movers with a hit contact back to its time of impact.

    Parameters
    ----------
    detector : CollisionPipeline
        Gives ``touch_inputs(cache)`` and answers ``contacts(pairs, position, orientation,
        cache)``.
    bodies : BodyArrays
        Positions and orientations of stepped-back bodies are moved to their time of impact.
    contacts : ContactSet
        This step's contacts at the end of the step.
    hits : (c,) bool
        Contacts that a mover ran into during the step.
    movers : (n,) bool
        Bodies in free flight this step.
    v : (n, 3) float64
        Velocities at the end of the step; stepped-back bodies get those of their time of
        impact (their angular momenta, the bodies', are kept: torque-free spin).
    acceleration : (n, 3) float64
        Constant acceleration of each body over the step (external force / mass).
    dt : float
        The step: no body goes back further.
    cache : tuple
        The convex coherence cache (``convex.contacts``).

    Returns
    -------
    rewind : (n,) float64
        How far (s) each body went back; 0 for bodies left where they were.
    contacts : ContactSet
        The contact set with the stepped-back bodies' contacts found again where they are now.
    """
    n = bodies.count
    rewind = np.zeros(n)
    body_a, body_b = contacts["body_a"], contacts["body_b"]
    group, groups = impact_groups(n, body_a, body_b, hits, movers)
    position, orientation = bodies.full("position"), bodies.full("orientation")
    renewed = np.zeros(len(body_a), bool)
    for g in range(groups):
        members, mine, pairs = group_contacts(group, g, body_a, body_b, hits)
        t = bisect_to_contact(
            members, pairs, v, bodies.full("angular_momentum"),
            bodies.full("inverse_inertia_body"), acceleration, position, orientation, dt,
            bodies.full("center_of_mass_local"), detector.touch_inputs(cache),
        )  # fmt: skip
        if t > 0.0:
            rewind[members] = t
            renewed |= mine
    if not renewed.any():
        return rewind, contacts
    fresh, _ = detector.contacts(
        unique_pairs(body_a, body_b, renewed), position, orientation, cache
    )
    kept = ~renewed
    return rewind, ContactSet.concatenate([contacts.select(kept), fresh])


@njit
def bisect_to_contact(
    members, pairs, v, angular_momentum, inverse_inertia_body, acceleration, position,
    orientation, dt, center_of_mass_local, touch_inputs,
):  # fmt: skip
    """Leave ``members`` just inside first contact of ``pairs`` and return how far back that
    is (s), in one call.

    The group goes back along its ballistic path to the start of the step and, unless its
    pairs touched already then (``dt`` is returned, the bodies left there), bisection on
    ``touching.pairs_touch`` finds the last moment at which they touched, to
    dt / 2^``HALVINGS``. Each probe places the bodies at their pose s back from the end of
    the step (``place_back``), so where a body is tried depends on s alone.

    Parameters
    ----------
    members : (m,) int64
        The group's bodies.
    pairs : (p, 2) int64
        The pairs whose contact is sought.
    v : (n, 3) float64
        Velocities at the end of the step; the members' are left at the time found.
    angular_momentum, inverse_inertia_body : (n, 3), (n, 3, 3) float64
        World angular momenta (kept: torque-free spin) and body-frame inverse inertias.
    acceleration : (n, 3) float64
        Constant acceleration over the step.
    position, orientation : (n, 3), (n, 4) float64
        Poses at the end of the step; the members' are left at the time found.
    dt : float
        The step: no body goes back further.
    center_of_mass_local : (n, 3) float64
    touch_inputs : tuple
        ``CollisionPipeline.touch_inputs(cache)``.
    """
    end_position = position[members].copy()
    end_orientation = orientation[members].copy()
    end_v = v[members].copy()
    ballistic = (
        members, end_position, end_orientation, end_v, angular_momentum, inverse_inertia_body,
        acceleration, position, orientation, v,
    )  # fmt: skip
    place_back(dt, *ballistic)
    if pairs_touch(pairs, position, orientation, center_of_mass_local, *touch_inputs):
        return dt
    inside, outside = 0.0, dt
    for _ in range(HALVINGS):
        middle = 0.5 * (inside + outside)
        place_back(middle, *ballistic)
        if pairs_touch(pairs, position, orientation, center_of_mass_local, *touch_inputs):
            inside = middle
        else:
            outside = middle
    place_back(inside, *ballistic)
    return inside


@njit
def place_back(
    s, members, end_position, end_orientation, end_v, angular_momentum, inverse_inertia_body,
    acceleration, position, orientation, v,
):  # fmt: skip
    """Put ``members`` (m,) where their ballistic paths had them s before the end of the step
    (``end_position``, ``end_orientation``, ``end_v``, one row per member): x = x1 - v1 s
    + a s^2 / 2, v = v1 - a s, q turned back freely by s with L held."""
    for k in range(members.shape[0]):
        i = members[k]
        for a in range(3):
            position[i, a] = end_position[k, a] - end_v[k, a] * s + 0.5 * acceleration[i, a] * s * s
            v[i, a] = end_v[k, a] - acceleration[i, a] * s
        q = turn_freely(end_orientation[k], angular_momentum[i], inverse_inertia_body[i], -s)
        for a in range(4):
            orientation[i, a] = q[a]
