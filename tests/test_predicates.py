"""Orientation predicates against exact rational determinants (Fractions).

Inputs are chosen where floating point fails: exactly coplanar or collinear points in
arbitrary orientation and scale (integer lattices scaled by powers of two), the same moved
by one ulp, and points rotated off such lattices so that the determinant is a tiny residue
of rounding. The filter must hand each of these to the exact fallback, and the fallback must
get the sign right.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import examples
from scipy.spatial.transform import Rotation

from thesis_rbd.collision.mesh.predicates import orient2d, orient3d, plane_sides


def _sign(x) -> int:
    return (x > 0) - (x < 0)


def orient3d_exact(a, b, c, d) -> int:
    a, b, c, d = ([Fraction(float(v)) for v in p] for p in (a, b, c, d))
    u = [a[i] - d[i] for i in range(3)]
    v = [b[i] - d[i] for i in range(3)]
    w = [c[i] - d[i] for i in range(3)]
    return _sign(
        u[0] * (v[1] * w[2] - v[2] * w[1])
        + u[1] * (v[2] * w[0] - v[0] * w[2])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
    )


def orient2d_exact(a, b, c) -> int:
    a, b, c = ([Fraction(float(v)) for v in p] for p in (a, b, c))
    return _sign((a[0] - c[0]) * (b[1] - c[1]) - (a[1] - c[1]) * (b[0] - c[0]))


def _tuple(p):
    return tuple(float(x) for x in p)


@st.composite
def lattice_points(draw, count, dim):
    """``count`` points on an integer lattice plane (dim 3) or line (dim 2), scaled by
    2**e, with e from -20 to 20 (about 1e-6 to 1e6): exactly coplanar / collinear."""
    small = st.integers(-6, 6)
    origin = np.array([draw(st.integers(-(2**20), 2**20)) for _ in range(dim)])
    basis = [np.array([draw(small) for _ in range(dim)]) for _ in range(dim - 1)]
    pts = [origin + sum(draw(st.integers(-50, 50)) * b for b in basis) for _ in range(count)]
    scale = 2.0 ** draw(st.integers(-20, 20))
    return [np.asarray(p, float) * scale for p in pts]


def _nudge(draw, pts):
    """Move one coordinate of one point by one ulp, or not at all (a zero coordinate by one
    ulp of the largest one: a subnormal would leave the predicates' domain)."""
    k = draw(st.integers(-1, len(pts) * len(pts[0]) - 1))
    if k < 0:
        return pts
    pts = [p.copy() for p in pts]
    i, j = divmod(k, len(pts[0]))
    direction = draw(st.sampled_from([-1.0, 1.0]))
    if pts[i][j] == 0.0:
        pts[i][j] = direction * np.spacing(max(np.abs(np.array(pts)).max(), 1e-30))
    else:
        pts[i][j] = np.nextafter(pts[i][j], direction * np.inf)
    return pts


@settings(max_examples=examples(300))
@given(st.data())
def test_orient3d_on_coplanar_lattices_and_ulp_nudges(data):
    pts = _nudge(data.draw, data.draw(lattice_points(4, 3)))
    a, b, c, d = (_tuple(p) for p in pts)
    want = orient3d_exact(a, b, c, d)
    assert orient3d(a, b, c, d) == want


@settings(max_examples=examples(300))
@given(st.data())
def test_orient2d_on_collinear_lattices_and_ulp_nudges(data):
    pts = _nudge(data.draw, data.draw(lattice_points(3, 2)))
    a, b, c = (_tuple(p) for p in pts)
    assert orient2d(a, b, c) == orient2d_exact(a, b, c)


@settings(max_examples=examples(300))
@given(st.integers(0, 2**32 - 1), st.floats(-6.0, 6.0))
def test_orient3d_on_rotated_coplanar_points(seed, log_scale):
    """Coplanar points turned by a random rotation: the determinant is rounding residue
    (or exactly zero), far below the filter's bound, and only exact arithmetic decides."""
    rng = np.random.default_rng(seed)
    flat = np.column_stack([rng.normal(size=(4, 2)), np.zeros(4)])
    R = Rotation.random(random_state=rng).as_matrix()
    pts = (flat @ R.T + rng.normal(size=3)) * 10.0**log_scale
    a, b, c, d = (_tuple(p) for p in pts)
    assert orient3d(a, b, c, d) == orient3d_exact(a, b, c, d)


@settings(max_examples=examples(200))
@given(st.data())
def test_plane_sides_equal_orient3d_of_each_point(data):
    use_lattice = data.draw(st.booleans())
    if use_lattice:
        pts = _nudge(data.draw, data.draw(lattice_points(6, 3)))
    else:
        seed = data.draw(st.integers(0, 2**32 - 1))
        pts = list(np.random.default_rng(seed).normal(size=(6, 3)))
    q0, q1, q2, p0, p1, p2 = (_tuple(p) for p in pts)
    want = tuple(orient3d_exact(p, q0, q1, q2) for p in (p0, p1, p2))
    assert plane_sides(q0, q1, q2, p0, p1, p2) == want


def test_filter_passes_clear_cases_and_exact_zeros():
    # Clear signs and exact zeros (a repeated point, an axis-aligned plane).
    a, b, c = (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    assert orient3d((0.0, 0.0, 1.0), a, b, c) == orient3d_exact((0, 0, 1.0), a, b, c) == 1
    assert orient3d((0.0, 0.0, -1.0), a, b, c) == -1
    assert orient3d((0.3, 0.7, 0.0), a, b, c) == 0
    assert orient3d(a, a, b, c) == 0
    assert orient2d((0.0, 0.0), (1.0, 0.0), (0.5, 0.0)) == 0
    assert orient2d((0.0, 0.0), (1.0, 0.0), (0.5, 1e-300)) == 1


def test_cancellation_near_1e6():
    # Four points 1e6 from the origin, coplanar to within one unit in the last place.
    base = 1e6
    a = (base, base, base)
    b = (base + 1.0, base, base)
    c = (base, base + 1.0, base)
    d = (base + 0.25, base + 0.25, np.nextafter(base, np.inf))
    assert orient3d(d, a, b, c) == orient3d_exact(d, a, b, c) == 1
    d = (base + 0.25, base + 0.25, np.nextafter(base, -np.inf))
    assert orient3d(d, a, b, c) == -1
