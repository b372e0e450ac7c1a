"""Time of impact: bodies that ended their step inside something are stepped back.

A body that ends the step inside another met it during the step. This stage finds when: each
group of such bodies (joined by the contacts between bodies that moved) retraces its
ballistic path,

    x(-t) = x - v t + a t^2 / 2,   v(-t) = v - a t,   q turned back freely,

exact for a constant force and torque-free spin over the step, and bisection on the yes/no
intersection query finds the last moment before the present at which the group's hit pairs
did not touch (for a convex pair that touched already, were not deeper than allowed), to
the step / 2^``HALVINGS``. A path goes back no further than it is known: the step, the part
of it before the tunnelling sweep caught the body, or the time since a collision earlier in
the step. The bodies are left there with their velocities of that moment, and the contacts of
their pairs are found anew; what remains of the step is the impact stage's
(``dynamics/impacts.py``). A group that already touched where its path begins (a contact
found then by the yes/no query but not by the contact generator, as at an exact touch) goes
back there: its whole step is the impact stage's.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._pair_keys import (
    first_of,
    keys_to_pairs,
    pair_key,
    pair_keys,
    second_of,
    unordered_pair_key,
)
from thesis_rbd._sorting import unique_sorted
from thesis_rbd._union_find import find_root, join
from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.touching import pairs_deeper, pairs_touch
from thesis_rbd.dynamics.contact_kinematics import contact_tolerances
from thesis_rbd.dynamics.contact_settings import SLOP_FRACTION
from thesis_rbd.dynamics.free_rotation import turn_freely

__all__ = [
    "HALVINGS",
    "beyond_slop",
    "bisect_to_contact",
    "depth_before",
    "group_contacts",
    "impact_groups",
    "new_or_deeper",
    "passed_through",
    "step_back_to_impact",
    "unique_pairs",
]

HALVINGS = 12


@njit
def impact_groups(body_count, body_a, body_b, hits, travelled, links):
    """Group the bodies that go back in time together: the ``travelled`` (n,) bool bodies
    joined by a contact to a travelled body of a hit contact (``hits`` (c,) bool), directly
    or through other travelled ones, and the moving bodies jointed to them (``links``
    (p, 2) int64: a body stepped back without its jointed partner would pull their joint
    apart).

    Travelled bodies in contact move together over the step (two touching cubes flying into
    a third): stepping one back to its time of impact and not the other would leave them
    overlapping. A body that hardly moved over the step (a pile that a falling cube lands
    on), or a static or sleeping one, is an obstacle for the search and joins nothing; the
    impact stage carries on the resting bodies that the collision moves. Returns ``group``
    (n,) int64: the group of each such body, -1 elsewhere, and the number of groups.
    """
    parent = np.arange(body_count)
    travelled = travelled.copy()
    for k in range(links.shape[0]):
        a, b = links[k, 0], links[k, 1]
        if travelled[a] or travelled[b]:
            travelled[a] = travelled[b] = True
            join(parent, a, b)
    for k in range(body_a.shape[0]):
        if travelled[body_a[k]] and travelled[body_b[k]]:
            join(parent, body_a[k], body_b[k])
    hit_root = np.zeros(body_count, np.bool_)
    for k in range(body_a.shape[0]):
        if hits[k]:
            for i in (body_a[k], body_b[k]):
                if travelled[i]:
                    hit_root[find_root(parent, i)] = True
    label = np.full(body_count, -1)
    group = np.full(body_count, -1)
    groups = 0
    for i in range(body_count):
        if not travelled[i]:
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


def step_back_to_impact(
    detector, bodies, contacts, hits, allowed, travelled, links, v, acceleration, reach_back,
    cache,
):  # fmt: skip
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
    allowed : (c,) float64
        For a hit whose pair touched before (convex pairs only), the depth (m) it may reach
        (the group goes back to when it went further in); -inf for a pair that did not touch
        (the group goes back to when it first touched).
    travelled : (n,) bool
        Bodies that moved more than their slop over the step (``impact_groups``).
    links : (p, 2) int64
        Jointed pairs of moving bodies: they go back together (``impact_groups``).
    v : (n, 3) float64
        Velocities at the end of the step; stepped-back bodies get those of their time of
        impact (their angular momenta, the bodies', are kept: torque-free spin).
    acceleration : (n, 3) float64
        Constant acceleration of each body over the step (external force / mass).
    reach_back : (n,) float64
        How far back (s) each body's present path goes: the step, or the time since a
        collision earlier in the step changed its velocity. A group goes back no further
        than the least of its members'.
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
    group, groups = impact_groups(n, body_a, body_b, hits, travelled, links)
    position, orientation = bodies.full("position"), bodies.full("orientation")
    renewed = np.zeros(len(body_a), bool)
    deeper = hits & np.isfinite(allowed)
    touched = hits & ~deeper
    deep_pairs, deep_allowed = np.zeros((0, 2), np.int64), np.zeros(0)
    for g in range(groups):
        members, mine, pairs = group_contacts(group, g, body_a, body_b, touched)
        if deeper.any():
            deep = mine & deeper
            deep_pairs, deep_allowed = _deepest_allowed(body_a[deep], body_b[deep], allowed[deep])
        t = bisect_to_contact(
            members, pairs, deep_pairs, deep_allowed, v, bodies.full("angular_momentum"),
            bodies.full("inverse_inertia_body"), acceleration, position, orientation,
            reach_back[members].min(), bodies.full("center_of_mass_local"),
            detector.touch_inputs(cache),
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


def _deepest_allowed(body_a, body_b, allowed):
    """The distinct pairs (p, 2) of contacts (k,) and the least depth each may reach (p,)."""
    keys = pair_keys(body_a, body_b)
    distinct, which = np.unique(keys, return_inverse=True)
    least = np.full(len(distinct), np.inf)
    np.minimum.at(least, which, allowed)
    return keys_to_pairs(distinct), least


@njit
def depth_before(body_a, body_b, asked, before_a, before_b, before_depths):
    """How deep the pair of each ``asked`` (c,) bool contact (``body_a``, ``body_b`` (c,))
    was in the contacts ``before`` (``before_a``, ``before_b``, ``before_depths`` (m,), the
    same bodies earlier in the step): its deepest contact there (m), -inf where the pair did
    not touch (no contact, or only a gap) and for contacts not asked."""
    m = before_a.shape[0]
    keys = np.empty(m, np.int64)
    deepest = np.empty(m)
    touching = 0
    for k in range(m):
        if before_depths[k] >= 0.0:
            keys[touching] = unordered_pair_key(before_a[k], before_b[k])
            deepest[touching] = before_depths[k]
            touching += 1
    order = np.argsort(keys[:touching])
    keys, deepest = keys[:touching][order], deepest[:touching][order]
    found = np.full(body_a.shape[0], -np.inf)
    for k in range(body_a.shape[0]):
        if not asked[k]:
            continue
        key = unordered_pair_key(body_a[k], body_b[k])
        i = np.searchsorted(keys, key)
        while i < touching and keys[i] == key:
            found[k] = max(found[k], deepest[i])
            i += 1
    return found


def new_or_deeper(contacts, before, asked, frozen, thickness, hull_of_body):
    """Which of the ``asked`` (c,) bool ``contacts`` are of a pair that did not touch in
    ``before`` (a ``ContactSet`` of the same step, earlier), and which of a convex pair gone
    deeper than it was there by more than the contact's slop; and, for those, the depth the
    search may let them reach (m). Returns ``apart``, ``deeper`` (c,) bool and ``allowed``
    (c,) float64."""
    a, b = contacts["body_a"], contacts["body_b"]
    depth = depth_before(a, b, asked, before["body_a"], before["body_b"], before["depths"])
    apart = depth == -np.inf
    allowed = depth + contact_tolerances(a, b, frozen, thickness, SLOP_FRACTION)
    convex = (hull_of_body[a] >= 0) & (hull_of_body[b] >= 0)
    return apart, ~apart & convex & (contacts["depths"] > allowed), allowed


def beyond_slop(bodies, position, orientation):
    """(n,) bool: the bodies a point of which may lie further than its contact slop from
    where it was at ``position`` (n, 3), ``orientation`` (n, 4). A body nearer than that to
    where the detection found its contacts has no contact deeper than the slop that it
    lacked there (the slop of the thinnest moving body, whatever it touches)."""
    shift = np.linalg.norm(bodies.position - position, axis=1)
    # the angle between the two orientations: 2 acos(|q1 . q2|)
    near = np.abs(np.einsum("ij,ij->i", bodies.orientation, orientation))
    angle = 2.0 * np.arccos(np.minimum(near, 1.0))
    thickness = bodies.thickness
    slop = SLOP_FRACTION * np.minimum(thickness, thickness[~bodies.static].min())
    return shift + angle * bodies.size > slop


@njit
def bisect_to_contact(
    members, pairs, deep_pairs, allowed, v, angular_momentum, inverse_inertia_body,
    acceleration, position, orientation, reach_back, center_of_mass_local, touch_inputs,
):  # fmt: skip
    """Leave ``members`` just inside first contact of ``pairs`` (or just deeper than allowed
    in ``deep_pairs``) and return how far back that is (s), in one call.

    The group goes back along its ballistic path as far as it goes (``reach_back``, s: the
    step, or less after a collision earlier in the step) and, unless its pairs touched
    already then (``reach_back`` is returned, the bodies left there), bisection on
    ``touching.pairs_touch`` and ``touching.pairs_deeper`` finds the last moment at which
    they touched, to reach_back / 2^``HALVINGS``. Each probe places the bodies at their pose
    s back from the end of the step (``place_back``), so where a body is tried depends on s
    alone.

    Parameters
    ----------
    members : (m,) int64
        The group's bodies.
    pairs : (p, 2) int64
        The pairs whose contact is sought.
    deep_pairs : (q, 2) int64
        Convex pairs that touched already: sought is when one went deeper than its
        ``allowed`` (q,) depth (m).
    v : (n, 3) float64
        Velocities at the end of the step; the members' are left at the time found.
    angular_momentum, inverse_inertia_body : (n, 3), (n, 3, 3) float64
        World angular momenta (kept: torque-free spin) and body-frame inverse inertias.
    acceleration : (n, 3) float64
        Constant acceleration over the step.
    position, orientation : (n, 3), (n, 4) float64
        Poses at the end of the step; the members' are left at the time found.
    reach_back : float
        How far back (s) the group's path goes.
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
    place_back(reach_back, *ballistic)
    if _collide(pairs, deep_pairs, allowed, position, orientation, center_of_mass_local,
                touch_inputs):  # fmt: skip
        return reach_back
    inside, outside = 0.0, reach_back
    for _ in range(HALVINGS):
        middle = 0.5 * (inside + outside)
        place_back(middle, *ballistic)
        if _collide(pairs, deep_pairs, allowed, position, orientation, center_of_mass_local,
                    touch_inputs):  # fmt: skip
            inside = middle
        else:
            outside = middle
    place_back(inside, *ballistic)
    return inside


@njit(inline="always")
def _collide(pairs, deep_pairs, allowed, position, orientation, center_of_mass_local,
             touch_inputs):  # fmt: skip
    """Whether ``pairs`` touch or ``deep_pairs`` are deeper than ``allowed``."""
    if pairs_touch(pairs, position, orientation, center_of_mass_local, *touch_inputs):
        return True
    return pairs_deeper(
        deep_pairs, allowed, position, orientation, center_of_mass_local, *touch_inputs
    )


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
