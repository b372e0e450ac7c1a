"""certify_face_axis: a cached face accepted without a search must be the exact answer.

The oracle is the naive least-penetration search (every face normal and edge-pair cross
product, tests/reference_convex.py); the cache-free kernel call is the second reference.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from tests.reference_convex import least_penetration
from tests.test_convex_contacts import Pair, face_pairs, pairs
from thesis_rbd.collision.convex.coherence import certify_face_axis
from thesis_rbd.collision.convex.contacts import _TIE, cache_views
from thesis_rbd.collision.convex.hull_data import unpack_hulls
from thesis_rbd.collision.convex.sat import FACE_A, FACE_B
from validation.convex_oracle import hull_planes


def relative_frame(pair):
    """(R, t) with x_A = R x_B + t (mesh frames; the bodies' centres of mass at their mesh
    origins, as Pair places them)."""
    Ra = Rotation.from_quat(pair.orientation[0]).as_matrix()
    Rb = Rotation.from_quat(pair.orientation[1]).as_matrix()
    return Ra.T @ Rb, Ra.T @ (pair.position[1] - pair.position[0]), Ra


def tie_of(pair):
    """The tie the convex kernel passes the certificate for this pair."""
    H = unpack_hulls(pair.hulls.arrays())
    ha, hb = pair.hull_of_body
    return _TIE * (H.sizes[ha] + H.sizes[hb])


def certify(pair, kind, face, start=0):
    H = unpack_hulls(pair.hulls.arrays())
    R, t, Ra = relative_frame(pair)
    ha, hb = pair.hull_of_body
    certified, separation, *axis, _ = certify_face_axis(
        H, ha, hb, np.ascontiguousarray(R), t, kind, face, start, tie_of(pair),
        np.empty((3, 3)), np.empty(3),
    )  # fmt: skip
    return certified, separation, Ra @ np.array(axis)


def face_a_condition(pair, face):
    """The certificate's condition for face ``face`` of A, by brute force in the world frame
    (module docstring of ``coherence``): B's vertex deepest under the face lies deeper than
    the tie, and deeper than its depth plus the tie under every other face plane of A's hull
    (qhull's planes, not the package's faces). None where round-off could decide it: a
    margin within 1e-9 of the size, or equally deep vertices that disagree."""
    Ra = Rotation.from_quat(pair.orientation[0]).as_matrix()
    plane = pair.hulls.hulls[0].planes[face]
    n = Ra @ plane[:3]
    d = plane[3] + n @ pair.position[0]
    depths = d - pair.points_b @ n
    deepest = depths.max()
    eps, tie = 1e-9 * pair.size, tie_of(pair)
    normals, offsets = hull_planes(pair.points_a)
    others = normals @ n < 1.0 - 1e-9  # qhull's triangles of the offered face are that face
    answers = set()
    for b in pair.points_b[depths >= deepest - eps]:
        margins = np.append(offsets[others] - normals[others] @ b - (deepest + tie), deepest - tie)
        if np.abs(margins).min() <= eps:
            return None
        answers.add(bool(margins.min() > 0.0))
    return answers.pop() if len(answers) == 1 else None


def check_certified_answers(pair, kind, face, start=0):
    """If the certificate accepts (kind, face), its depth is the exact least penetration and
    its axis the exact one where that is unique; returns whether it accepted."""
    certified, separation, axis = certify(pair, kind, face, start)
    if not certified:
        return False
    depth, normal, runner_up, _, _ = least_penetration(pair.points_a, pair.points_b)
    size = pair.size
    assert depth > 0.0
    assert abs(-separation - depth) <= 1e-9 * size
    if runner_up > depth + 1e-8 * size:
        # the oracle's normal points from B towards A; the certificate's axis from A to B
        assert math.acos(min(1.0, float(-axis @ normal))) <= 1e-6
    return True


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.one_of(pairs(depths=(1e-6, 1e-3, 0.05, 0.3)), face_pairs()),
    st.sampled_from([FACE_A, FACE_B]),
    st.integers(0, 10**6),
    st.booleans(),
)
def test_any_face_it_accepts_is_the_exact_axis(pair, kind, pick, offer_the_answer):
    """Whatever face is offered (most are wrong, or the one facing the oracle's normal), and
    from whatever vertex the climb to the other hull's deepest starts, an accepted face is the
    right answer; and a face of A is accepted exactly when its condition holds by brute force
    (so a certificate that accepted nothing would fail here)."""
    own, other = (0, 1) if kind == FACE_A else (1, 0)
    planes = pair.hulls.hulls[own].planes
    faces = planes.shape[0]
    vertices = len(pair.hulls.hulls[other].vertices)
    face, start = pick % faces, (pick // faces) % vertices
    if offer_the_answer:
        _, normal, _, _, _ = least_penetration(pair.points_a, pair.points_b)
        R = Rotation.from_quat(pair.orientation[own]).as_matrix()
        # A's answering face faces B (along -normal), B's faces A
        face = int(np.argmax(planes[:, :3] @ R.T @ (-normal if own == 0 else normal)))
    accepted = check_certified_answers(pair, kind, face, start)
    if kind == FACE_A:
        expected = face_a_condition(pair, face)
        if expected is not None:
            assert accepted == expected


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(pairs(depths=(1e-6, 1e-3, 0.05)), face_pairs()), st.floats(-7, -3))
def test_the_cached_path_gives_the_cache_free_contacts(pair, nudge):
    """Contacts with last step's cache, after a small move, equal those found without one."""
    _, cache = pair.contacts()
    rng = np.random.default_rng(0)
    pair.position[1] += rng.normal(size=3) * 10.0**nudge * pair.size
    cold, _ = pair.contacts()
    warm, _ = pair.contacts(cache)
    assert len(warm["depths"]) == len(cold["depths"])
    if len(cold["depths"]):
        np.testing.assert_array_equal(warm["features"], cold["features"])
        for key in ("depths", "points"):
            np.testing.assert_allclose(warm[key], cold[key], rtol=0, atol=1e-12 * pair.size)
        np.testing.assert_allclose(warm["normals"], cold["normals"], rtol=0, atol=1e-12)


def test_a_resting_icosphere_and_box_are_certified_on_either_side():
    """The cases it exists for: a sphere on a floor (floor first or second), a box on a
    sphere; a box tipped onto an edge of the floor is not (an edge pair decides)."""
    floor = rbd.shapes.box((10.0, 10.0, 1.0))
    ball = rbd.shapes.icosphere(0.5, 2)
    identity = np.array([0, 0, 0, 1.0])
    lowest = ball.vertices[:, 2].min()
    on_floor = (np.array([0.1, -0.2, 0.5 - lowest - 1e-4]), identity)
    pair = Pair(floor, ball, (np.zeros(3), identity), on_floor)
    top = int(np.argmax(pair.hulls.hulls[0].planes[:, 2]))
    assert check_certified_answers(pair, FACE_A, top)
    flipped = Pair(ball, floor, on_floor, (np.zeros(3), identity))
    assert check_certified_answers(flipped, FACE_B, top)
    # the floor's side face is no answer for a ball resting on its top
    side = int(np.argmax(pair.hulls.hulls[0].planes[:, 0]))
    assert not certify(pair, FACE_A, side)[0]
    # a ball off the floor's edge: sitting over the edge, the top face may not be proved
    over_edge = (np.array([5.0, 0.0, 0.5 - lowest - 1e-4]), identity)
    edge_pair = Pair(floor, ball, (np.zeros(3), identity), over_edge)
    assert not certify(edge_pair, FACE_A, top)[0]


def test_a_face_of_b_gives_way_to_a_face_of_a_it_ties_with():
    """A can tipped on the floor's top face (a face of B) that settles flat ties with its
    own bottom face: the separating-axis test then keeps the face of A, and so must the
    cached path. (Two boxes take the closed form and never reach the certificate.)"""
    can, floor = rbd.shapes.cylinder(0.5, 1.0, 12), rbd.shapes.box((10.0, 10.0, 1.0))
    identity = np.array([0, 0, 0, 1.0])
    tipped = Rotation.from_rotvec([2e-3, 0.0, 0.0]).as_quat()
    lowest = can.vertices[:, 2].min()
    pair = Pair(
        can, floor, (np.array([0.0, 0.0, 0.5 - lowest - 1e-4]), tipped), (np.zeros(3), identity)
    )
    _, cache = pair.contacts()
    assert cache_views(cache)[1][0, 0] == FACE_B
    pair.orientation[0] = identity
    cold, _ = pair.contacts()
    warm, _ = pair.contacts(cache)
    assert len(cold["features"]) == 4
    np.testing.assert_array_equal(warm["features"], cold["features"])
