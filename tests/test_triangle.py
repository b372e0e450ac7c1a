"""Triangle-triangle and triangle-box kernels against exact, plain-Python SAT and LP oracles.

The triangle-triangle test is exact for the float64 corners it is given, so every answer must
equal the exact oracles' (``reference.tri_tri_sat`` with Fractions, ``reference_exact``'s edge
against triangle test in integers), touching, coplanar and degenerate pairs included.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import examples, tri_box_lp, tri_tri_lp, tri_tri_sat
from reference_exact import tri_box_exact, tri_tri_exact
from scipy.spatial.transform import Rotation

from thesis_rbd.collision.mesh.triangle import triangle_box_overlap, triangles_overlap

# The predicates are exact while no product of coordinate differences underflows (see
# predicates.py): magnitudes below 1e-30 are drawn as zero.
coord = st.floats(-2.0, 2.0, allow_nan=False, width=64).map(lambda x: 0.0 if abs(x) < 1e-30 else x)
triangle = st.lists(coord, min_size=9, max_size=9).map(lambda v: np.array(v).reshape(3, 3))
small_int = st.integers(-3, 3)
int_triangle = st.lists(small_int, min_size=9, max_size=9).map(
    lambda v: np.array(v, dtype=float).reshape(3, 3)
)
# Segment- and point-shaped triangles: a repeated corner, or all three equal.
degenerate_triangle = st.one_of(
    int_triangle.map(lambda t: t[[0, 1, 1]]), int_triangle.map(lambda t: t[[0, 0, 0]])
)


@settings(max_examples=examples(300))
@given(P=triangle, Q=triangle)
def test_tri_tri_matches_sat_reference(P, Q):
    assert triangles_overlap(P, Q) == tri_tri_sat(P, Q, exact=True)[0]


@settings(max_examples=examples(60))
@given(P=triangle, Q=triangle)
def test_tri_tri_matches_lp_away_from_touching(P, Q):
    _, margin = tri_tri_sat(P, Q)
    if abs(margin) < 1e-7:
        return  # touching within LP tolerance: the LP cannot decide
    assert triangles_overlap(P, Q) == tri_tri_lp(P, Q)


@settings(max_examples=examples(300))
@given(P=int_triangle, Q=int_triangle)
def test_tri_tri_exact_on_integer_grids(P, Q):
    # Small integers make every product exact, so touching, coplanar and degenerate cases are
    # decided exactly by both: compare with the exact-rational reference.
    assert triangles_overlap(P, Q) == tri_tri_sat(P, Q, exact=True)[0]


@settings(max_examples=examples(200))
@given(P=degenerate_triangle, Q=st.one_of(degenerate_triangle, int_triangle))
def test_tri_tri_degenerate_against_lp(P, Q):
    # Exactly representable data, away from LP tolerance issues: grow/shrink is not possible
    # for points, so compare with the LP on the exact-SAT margin's clear cases.
    overlap, margin = tri_tri_sat(P, Q, exact=True)
    assert triangles_overlap(P, Q) == overlap
    if abs(margin) > 1e-6 or overlap:
        assert tri_tri_lp(P, Q) == overlap


CASES = {
    # name: (P, Q, overlap)
    "crossing": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0]],
        True,
    ),
    "above": ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0, 0, 1], [2, 0, 1], [0, 2, 1]], False),
    "coplanar_overlap": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[1, 1, 0], [-1, 0.5, 0], [0.5, -1, 0]],
        True,
    ),
    "coplanar_inside": (
        [[0, 0, 0], [4, 0, 0], [0, 4, 0]],
        [[0.5, 0.5, 0], [1, 0.5, 0], [0.5, 1, 0]],
        True,
    ),
    "coplanar_apart": ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 1, 0], [2, 1, 0], [1, 2, 0]], False),
    "touch_vertex_on_face": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[0.5, 0.5, 0], [0.5, 0.5, 1], [1, 0, 1]],
        True,
    ),
    "touch_vertex_vertex": (
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        [[1, 0, 0], [2, 0, 1], [2, 1, 0]],
        True,
    ),
    "shared_edge": ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [1, 0, 0], [0, -1, 1]], True),
    "identical": ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], True),
    "segment_piercing": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[0.5, 0.5, -1], [0.5, 0.5, 1], [0.5, 0.5, 1]],
        True,
    ),
    "segment_missing": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[3, 3, -1], [3, 3, 1], [3, 3, 0]],
        False,
    ),
    "point_on_face": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[0.5, 0.5, 0], [0.5, 0.5, 0], [0.5, 0.5, 0]],
        True,
    ),
    "point_off_face": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[0.5, 0.5, 0.1], [0.5, 0.5, 0.1], [0.5, 0.5, 0.1]],
        False,
    ),
    "coplanar_segment_crossing_edge": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0]],
        [[1, 1, 0], [3, 3, 0], [3, 3, 0]],
        True,
    ),
    "point_beside_segment": (
        [[1, 1, 1], [1, 1, 1], [1, 1, 1]],
        [[0, 0, 0], [0, 0, 2], [0, 0, 2]],
        False,
    ),
    "point_on_segment": (
        [[0, 0, 1], [0, 0, 1], [0, 0, 1]],
        [[0, 0, 0], [0, 0, 2], [0, 0, 2]],
        True,
    ),
    "point_beyond_segment_end": (
        [[0, 0, 3], [0, 0, 3], [0, 0, 3]],
        [[0, 0, 0], [0, 0, 2], [0, 0, 2]],
        False,
    ),
    "two_points": ([[0, 0, 0], [0, 0, 0], [0, 0, 0]], [[0, 0, 1], [0, 0, 1], [0, 0, 1]], False),
    "parallel_segments": (
        [[0, 0, 0], [1, 0, 0], [1, 0, 0]],
        [[0, 1, 0], [1, 1, 0], [1, 1, 0]],
        False,
    ),
    "skew_segments": (
        [[0, 0, 0], [1, 0, 0], [1, 0, 0]],
        [[0.5, -1, 0.1], [0.5, 1, 0.1], [0.5, 1, 0.1]],
        False,
    ),
    "crossing_segments": (
        [[0, 0, 0], [1, 0, 0], [1, 0, 0]],
        [[0.5, -1, 0], [0.5, 1, 0], [0.5, 1, 0]],
        True,
    ),
    "parallel_edges_near": (
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        [[0, 1e-12, 1e-9], [1, 1e-12, 1e-9], [0, -1, 1]],
        False,
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_tri_tri_named_cases(name):
    P, Q, expected = (np.asarray(x, float) if i < 2 else x for i, x in enumerate(CASES[name]))
    assert triangles_overlap(P, Q) == expected
    assert triangles_overlap(Q, P) == expected
    assert tri_tri_sat(P, Q, exact=True)[0] == expected


def test_tri_tri_is_invariant_under_corner_order():
    rng = np.random.default_rng(0)
    for _ in range(200):
        P = rng.normal(size=(3, 3))
        Q = rng.normal(size=(3, 3))
        want = triangles_overlap(P, Q)
        for perm in ([1, 2, 0], [2, 1, 0]):
            assert triangles_overlap(P[perm], Q) == want
            assert triangles_overlap(P, Q[perm]) == want


half = st.lists(st.floats(0.0, 1.5), min_size=3, max_size=3).map(np.array)


@settings(max_examples=examples(60))
@given(V=triangle, h=half)
def test_tri_box_matches_lp(V, h):
    # Closed-set answers agree up to touching: an overlap must survive growing the box by a
    # hair, a separation must survive shrinking it.
    delta = 1e-7
    if triangle_box_overlap(V, h):
        assert tri_box_lp(V, h + delta)
    elif np.all(h > delta):
        assert not tri_box_lp(V, h - delta)
    if tri_box_lp(V, h):
        assert triangle_box_overlap(V, h + delta)


@settings(max_examples=examples(100))
@given(V=int_triangle, h=st.lists(st.integers(1, 2), min_size=3, max_size=3).map(np.array))
def test_tri_box_equals_box_as_triangles(V, h):
    # Independent exact check: a triangle meets a box iff it meets one of the box's 12 face
    # triangles or lies inside it (closed sets; integer data, so the SAT reference is exact).
    h = h.astype(float)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
    faces = [
        (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ]  # fmt: skip
    inside = np.all(np.abs(V) <= h)
    meets = inside or any(tri_tri_sat(V, corners[list(f)], exact=True)[0] for f in faces)
    assert triangle_box_overlap(V, h) == meets


# A triangle whose corners are collinear up to round-off (twice its area is 4e-17, its edges
# 0.35 m): its computed normal points anywhere, and the plane-side rejection on it once
# reported this segment-through-triangle pair as apart (python-fcl and the LP say it meets).
ROUND_OFF_FLAT = np.array(
    [
        [0.6695392912257001, -0.14115520850740723, -0.2718040447380686],
        [0.5278692432268419, -0.2444643970446581, -0.3003254744231647],
        [0.3861991952279836, -0.34777358558190913, -0.3288469041082608],
    ]
)
CROSSED = np.array(
    [
        [0.6933997706584684, -0.16860817243401716, -0.4282870533660401],
        [0.398312294000003, -0.32906839919836306, -0.21745411887569055],
        [0.38965264119031223, -0.27899873466283776, -0.5644515190099776],
    ]
)


def test_round_off_flat_triangle_is_decided_as_a_segment():
    assert tri_tri_lp(ROUND_OFF_FLAT, CROSSED)
    assert triangles_overlap(ROUND_OFF_FLAT, CROSSED)
    assert triangles_overlap(CROSSED, ROUND_OFF_FLAT)


def test_round_off_flat_triangle_meets_a_box_around_its_middle():
    middle = ROUND_OFF_FLAT[1]
    assert triangle_box_overlap(ROUND_OFF_FLAT - middle, np.array([1e-3, 1e-3, 1e-3]))


@given(st.integers(0, 2**32 - 1), st.floats(-1.0, 2.0))
def test_nearly_collinear_triangles_against_the_exact_oracle(seed, t):
    """Corners on a line plus round-off-sized noise, against random triangles."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, 3))
    flat = np.array([a, b, a + t * (b - a)]) + rng.normal(scale=1e-16, size=(3, 3))
    Q = rng.normal(size=(3, 3)) * 0.7
    assert triangles_overlap(flat, Q) == tri_tri_exact(flat, Q)


# ---------------------------------------------------------------- exact pairs in any pose
# Pairs built where floating-point tests fail (shared corners and edges, bitwise; coplanar
# triangles touching, overlapping or apart; segments and points), then moved: either by an
# exact motion (axis permutation, sign flips, a power-of-two scale, a lattice translation),
# which keeps every coincidence exact, or by a random rotation, a scale of 1e-6..1e6 and a
# translation, whose rounding leaves coincidences broken by an ulp or kept (shared corners
# are moved by the same operations, so they stay bitwise shared). Whatever the result, the
# kernel must answer as exact arithmetic on the final floats does.
PAIR_KINDS = (
    "general",
    "shared_corner",
    "shared_edge",
    "coplanar",
    "coplanar_shared",
    "segment",
    "point",
    "both_flat",
)


def _lattice_plane(rng, count):
    """``count`` integer points on a random integer plane (small coefficients)."""
    o = rng.integers(-4, 5, size=3)
    u, v = rng.integers(-2, 3, size=(2, 3))
    while not np.cross(u, v).any():
        u, v = rng.integers(-2, 3, size=(2, 3))
    coeff = rng.integers(-3, 4, size=(count, 2))
    return (o + coeff[:, :1] * u + coeff[:, 1:] * v).astype(float)


def _flat(rng, pts, kind):
    """A segment (collinear corners, maybe repeated) or a point, from lattice points."""
    a, b = pts[0], pts[1]
    if kind == "point":
        return np.array([a, a, a])
    t = rng.integers(-1, 3)
    return rng.permutation(np.array([a, b, a + t * (b - a)]))


def make_pair(kind, seed):
    """(P, Q) of the given kind, before any motion."""
    rng = np.random.default_rng(seed)
    if kind == "general":
        return rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    if kind in ("shared_corner", "shared_edge"):
        P = rng.normal(size=(3, 3))
        Q = rng.normal(size=(3, 3))
        shared = 1 if kind == "shared_corner" else 2
        Q[rng.permutation(3)[:shared]] = P[rng.permutation(3)[:shared]]
        if rng.random() < 0.3:  # the third corner in P's plane (up to rounding)
            w = rng.normal(size=2)
            Q[2 if shared == 2 else 1] = P[0] + w[0] * (P[1] - P[0]) + w[1] * (P[2] - P[0])
        return P, Q
    pts = _lattice_plane(rng, 6)
    if kind == "coplanar":
        return pts[:3], pts[3:]
    if kind == "coplanar_shared":
        P, Q = pts[:3], pts[3:].copy()
        Q[rng.integers(3)] = P[rng.integers(3)]
        return P, Q
    off_plane = rng.random() < 0.5
    other = rng.integers(-4, 5, size=(3, 3)).astype(float) if off_plane else pts[3:]
    if kind == "both_flat":
        return _flat(rng, pts[:3], "segment"), _flat(rng, other, rng.choice(["segment", "point"]))
    return _flat(rng, pts[:3], kind), other


def move(pts, seed, exact):
    """Apply one motion to the (n, 3) points (see above)."""
    rng = np.random.default_rng(seed)
    if exact:
        signs = rng.choice([-1.0, 1.0], size=3)
        moved = pts[:, rng.permutation(3)] * signs
        return (moved + rng.integers(-8, 9, size=3)) * 2.0 ** int(rng.integers(-20, 21))
    R = Rotation.random(random_state=rng).as_matrix()
    scale = 10.0 ** rng.uniform(-6, 6)
    return (pts @ R.T) * scale + rng.normal(size=3) * scale * rng.uniform(0, 10)


@settings(max_examples=examples(600), deadline=None)
@given(kind=st.sampled_from(PAIR_KINDS), seed=st.integers(0, 2**32 - 1), exact=st.booleans())
def test_tri_tri_equals_exact_oracle_in_any_pose(kind, seed, exact):
    P, Q = make_pair(kind, seed)
    moved = move(np.vstack([P, Q]), seed + 1, exact)
    P, Q = moved[:3], moved[3:]
    want = tri_tri_exact(P, Q)
    assert triangles_overlap(P, Q) == want
    assert triangles_overlap(Q, P) == want
    assert triangles_overlap(P[[1, 2, 0]], Q[[0, 2, 1]]) == want


@settings(max_examples=examples(60), deadline=None)
@given(kind=st.sampled_from(PAIR_KINDS), seed=st.integers(0, 2**32 - 1), exact=st.booleans())
def test_the_two_exact_oracles_agree(kind, seed, exact):
    P, Q = make_pair(kind, seed)
    moved = move(np.vstack([P, Q]), seed + 1, exact)
    assert tri_tri_exact(moved[:3], moved[3:]) == tri_tri_sat(moved[:3], moved[3:], exact=True)[0]


@settings(max_examples=examples(200), deadline=None)
@given(seed=st.integers(0, 2**32 - 1), exact=st.booleans())
def test_tri_box_never_separates_a_triangle_that_meets_the_box(seed, exact):
    """The culling test is conservative: it may keep a triangle within a rounding-sized
    distance of the box, never drop one that meets it (touching corners, edges, faces)."""
    rng = np.random.default_rng(seed)
    h = rng.integers(1, 4, size=3).astype(float)
    # Corners on the box's surface lattice or just around it, often exactly touching.
    V = rng.integers(-4, 5, size=(3, 3)).astype(float) / 2.0
    on_face = rng.integers(3)
    V[rng.integers(3), on_face] = rng.choice([-1.0, 1.0]) * h[on_face]
    scale = 2.0 ** int(rng.integers(-20, 21))
    if not exact:
        scale *= rng.uniform(0.5, 2.0)
        V = V + rng.normal(size=(3, 3)) * 1e-15 * np.abs(V).max()
    V, h = V * scale, h * scale
    got = triangle_box_overlap(V, h)
    if tri_box_exact(V, h):
        assert got
    if got:
        size = max(np.abs(V).max(), h.max())
        assert tri_box_exact(V, h + 1e-13 * size)
