"""Contact impulses against analytic outcomes, conservation laws and the exact LCP solution."""

import itertools

import numpy as np
import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st

from tests.reference_pgs import ContactRows, nearest_in_polygon, reference_pgs
from tests.reference_subspace import reference_subspace_step
from thesis_rbd.dynamics.contact_solver import (
    contact_basis,
    delassus_matrix,
    relative_velocity,
    solve_exact,
    solve_pgs,
)
from thesis_rbd.dynamics.island_solver import island_tolerances
from thesis_rbd.dynamics.pgs import (
    apply_warm_start,
    build_rows,
    friction_polygon,
    project_onto_polygon,
)
from thesis_rbd.dynamics.subspace import subspace_step, sweep_with_subspace_steps

SOLVERS = ["exact", "pgs"]


def make_problem(body_a, body_b, points, normals, positions, masses, inertias):
    """Contact and body tuples for the kernels; mass inf marks a static body."""
    body_a = np.asarray(body_a, np.int64)
    body_b = np.asarray(body_b, np.int64)
    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    positions = np.asarray(positions, float).reshape(-1, 3)
    masses = np.asarray(masses, float)
    inverse_mass = np.where(np.isinf(masses), 0.0, 1.0 / masses)
    inverse_inertia = np.array(
        [
            np.zeros((3, 3)) if np.isinf(m) else np.linalg.inv(I)
            for m, I in zip(masses, inertias, strict=True)
        ]
    )
    contacts = (
        body_a,
        body_b,
        points - positions[body_a],
        points - positions[body_b],
        contact_basis(normals),
    )
    return contacts, inverse_mass, inverse_inertia


def solve(
    solver,
    contacts,
    bias,
    friction,
    velocity,
    angular_velocity,
    inverse_mass,
    inverse_inertia,
    sides=8,
):
    """Solve in place; returns the impulses and the exact solver's status (0 for PGS)."""
    bodies = (velocity, angular_velocity, inverse_mass, inverse_inertia)
    impulse = np.zeros((len(bias), 3))
    status = 0
    if solver == "exact":
        status = solve_exact(sides, contacts, bias, friction, bodies, impulse, 1e-4)
    else:
        solve_pgs(500, sides, contacts, bias, friction, bodies, impulse, tolerance=1e-14)
    return impulse, status


def cube_on_floor(e, velocity_z=-2.0, spin=(0, 0, 0), tangential=(0, 0), mu=0.0):
    """Unit cube (mass 1) touching a static floor (body 1) at its four bottom corners."""
    corners = np.array([[x, y, -0.5] for x in (-0.5, 0.5) for y in (-0.5, 0.5)])
    contacts, im, ii = make_problem(
        [0] * 4,
        [1] * 4,
        corners,
        [[0, 0, 1]] * 4,
        [[0, 0, 0], [0, 0, -0.5]],
        [1.0, np.inf],
        [np.eye(3) / 6, np.eye(3)],
    )
    v = np.array([[tangential[0], tangential[1], velocity_z], [0, 0, 0]], float)
    w = np.array([spin, [0, 0, 0]], float)
    bodies = (v, w, im, ii)
    u_n = np.array([relative_velocity(k, 0, contacts, bodies) for k in range(4)])
    bias = e * np.minimum(u_n, 0.0)
    return contacts, bias, np.full(4, mu), v, w, im, ii


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("e", [0.0, 0.5, 0.8, 1.0])
def test_cube_landing_flat_bounces_with_e_and_no_spin(solver, e):
    contacts, bias, mu, v, w, im, ii = cube_on_floor(e)
    impulse, status = solve(solver, contacts, bias, mu, v, w, im, ii)
    assert status == 0
    np.testing.assert_allclose(v[0], [0, 0, 2.0 * e], atol=1e-9)
    np.testing.assert_allclose(w[0], 0, atol=1e-9)
    assert impulse[:, 0].sum() == pytest.approx(2.0 * (1 + e), rel=1e-9)
    assert np.all(impulse[:, 0] >= -1e-12)


@pytest.mark.parametrize("solver", SOLVERS)
def test_head_on_equal_bodies_exchange_velocities(solver):
    I = np.eye(3) / 6
    contacts, im, ii = make_problem(
        [1], [0], [[0, 0, 0]], [[1, 0, 0]], [[-0.5, 0, 0], [0.5, 0, 0]], [1.0, 1.0], [I, I]
    )
    v = np.array([[3.0, 0, 0], [-1.0, 0, 0]])
    w = np.zeros((2, 3))
    u_n = relative_velocity(0, 0, contacts, (v, w, im, ii))
    solve(solver, contacts, np.array([1.0 * min(u_n, 0)]), np.zeros(1), v, w, im, ii)
    np.testing.assert_allclose(v, [[-1.0, 0, 0], [3.0, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(w, 0, atol=1e-12)


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize(("speed", "sticks"), [(0.5, True), (5.0, False)])
def test_coulomb_friction_sticks_or_slides(solver, speed, sticks):
    """Cube landing at -2 m/s while sliding: normal impulse 2 (e = 0), friction limit mu * 2."""
    mu = 0.4
    contacts, bias, friction, v, w, im, ii = cube_on_floor(0.0, tangential=(speed, 0), mu=mu)
    solve(solver, contacts, bias, friction, v, w, im, ii)
    # friction at the bottom face also tips the cube: compare the contact-point velocity
    slip = v[0, 0] + np.cross(w[0], [0, 0, -0.5])[0]
    if sticks:
        assert abs(slip) < 1e-8
    else:
        assert slip > 0
        # linear momentum lost to friction is exactly mu * normal impulse (direction on a vertex)
        assert speed - v[0, 0] == pytest.approx(mu * 2.0, rel=1e-6)


def random_free_bodies(seed, contacts_count):
    rng = np.random.default_rng(seed)
    n = 3
    positions = rng.normal(size=(n, 3))
    masses = rng.uniform(0.5, 3.0, n)
    inertias = []
    for m in masses:
        A = rng.normal(size=(3, 3))
        inertias.append(m * (A @ A.T + 0.2 * np.eye(3)))
    pairs = [rng.choice(n, 2, replace=False) for _ in range(contacts_count)]
    contacts, im, ii = make_problem(
        [p[0] for p in pairs],
        [p[1] for p in pairs],
        rng.normal(size=(contacts_count, 3)),
        rng.normal(size=(contacts_count, 3)),
        positions,
        masses,
        inertias,
    )
    v = rng.normal(size=(n, 3))
    w = rng.normal(size=(n, 3))
    bodies = (v, w, im, ii)
    u_n = np.array([relative_velocity(k, 0, contacts, bodies) for k in range(contacts_count)])
    bias = rng.uniform(0, 1, contacts_count) * np.minimum(u_n, 0)
    friction = rng.choice([0.0, 0.3, 1.0], contacts_count)
    return contacts, bias, friction, v, w, im, ii, positions, masses, inertias


def momenta(v, w, positions, masses, inertias):
    P = (masses[:, None] * v).sum(axis=0)
    L = sum(
        np.cross(x, m * vi) + I @ wi
        for x, m, vi, wi, I in zip(positions, masses, v, w, inertias, strict=True)
    )
    return P, L


@given(st.integers(0, 10**6), st.integers(1, 5), st.sampled_from(SOLVERS))
def test_impulses_between_free_bodies_conserve_momentum(seed, count, solver):
    contacts, bias, friction, v, w, im, ii, x, m, inertias = random_free_bodies(seed, count)
    P0, L0 = momenta(v, w, x, m, inertias)
    solve(solver, contacts, bias, friction, v, w, im, ii)
    P1, L1 = momenta(v, w, x, m, inertias)
    np.testing.assert_allclose(P1, P0, rtol=1e-9, atol=1e-9 * np.abs(P0).max())
    np.testing.assert_allclose(L1, L0, rtol=1e-6, atol=1e-6 * np.abs(L0).max())


@given(st.integers(0, 10**6), st.integers(1, 4))
@example(seed=180585, count=4)
def test_exact_solution_satisfies_the_contact_conditions(seed, count):
    """Non-penetration, complementarity and the friction cone after the exact solve.

    Random contacts can pose a nearly contradictory problem whose exact answer has huge
    impulses that cancel (the example: 3e7 against velocities of order 1). The normal velocity
    is then a sum of terms of size sum_j |A_kj| |lambda_j|, and round-off in forming it (here,
    and in the solver) grows with that sum, as for any floating-point sum (Higham, Accuracy
    and Stability, 4.2): so each contact's velocity bound is 1e-8 plus 64 units of round-off
    of that sum. For impulses of order 1 the second term is about 1e-14 and the bound is 1e-8.
    """
    contacts, bias, friction, v, w, im, ii, *_ = random_free_bodies(seed, count)
    summands = np.abs(delassus_matrix(contacts, (v, w, im, ii)))
    impulse, status = solve("exact", contacts, bias, friction, v, w, im, ii)
    assume(status == 0)  # the rare fallback to PGS is counted in its own test below
    bodies = (v, w, im, ii)
    scale = 1 + np.abs(impulse).max()
    summed = summands @ np.abs(impulse).reshape(-1)
    for k in range(count):
        u_n = relative_velocity(k, 0, contacts, bodies) + bias[k]
        velocity_tolerance = 1e-8 + 64 * np.finfo(float).eps * summed[3 * k]
        assert u_n >= -velocity_tolerance and impulse[k, 0] >= -1e-10
        assert abs(u_n * impulse[k, 0]) <= velocity_tolerance * scale
        tangential = np.hypot(impulse[k, 1], impulse[k, 2])
        assert tangential <= friction[k] * impulse[k, 0] + 1e-9 * scale


def kinetic_energy(v, w, masses, inertias):
    return sum(
        0.5 * m * vi @ vi + 0.5 * wi @ I @ wi
        for m, vi, wi, I in zip(masses, v, w, inertias, strict=True)
    )


@given(st.integers(0, 10**6), st.integers(1, 5))
def test_exact_solution_never_adds_more_energy_than_its_bias_allows(seed, count):
    """Complementarity bounds the energy change of any exact answer by -sum lambda_n bias
    (sliding friction only removes energy); checked here from the body velocities."""
    contacts, bias, friction, v, w, im, ii, _, m, inertias = random_free_bodies(seed, count)
    before = kinetic_energy(v, w, m, inertias)
    impulse, status = solve("exact", contacts, bias, friction, v, w, im, ii)
    assume(status == 0)
    allowed = -(impulse[:, 0] @ bias)
    assert kinetic_energy(v, w, m, inertias) - before <= allowed + 1e-9 * (1 + before)


@given(st.integers(0, 10**6), st.integers(1, 4))
def test_pgs_converges_to_the_exact_velocities_without_friction(seed, count):
    """Frictionless, the LCP is monotone and the velocities after it are unique, so PGS must
    reach Lemke's; with friction the answer need not be unique and only the conditions
    above are checked."""
    contacts, bias, _, v, w, im, ii, *_ = random_free_bodies(seed, count)
    frictionless = np.zeros(count)
    v_pgs, w_pgs = v.copy(), w.copy()
    _, status = solve("exact", contacts, bias, frictionless, v, w, im, ii)
    assume(status == 0)
    pgs = np.zeros((count, 3))
    solve_pgs(20000, 8, contacts, bias, frictionless, (v_pgs, w_pgs, im, ii), pgs, tolerance=0.0)
    np.testing.assert_allclose(v_pgs, v, atol=1e-5 * (1 + np.abs(v).max()))
    np.testing.assert_allclose(w_pgs, w, atol=1e-5 * (1 + np.abs(w).max()))


@given(st.integers(0, 10**6), st.integers(1, 6), st.integers(1, 4), st.booleans())
def test_pgs_sweeps_agree_with_a_row_by_row_reference(seed, count, sweeps, warm):
    """The kernel reads a contact's three velocities at once and applies its three impulses
    together; the reference solves row after row from the Jacobians. Same iteration."""
    contacts, bias, friction, v, w, im, ii, *_ = random_free_bodies(seed, count)
    rng = np.random.default_rng(seed + 1)
    start = np.zeros((count, 3))
    if warm:
        start[:, 0] = rng.uniform(0, 1, count)
        start[:, 1:] = rng.uniform(-0.3, 0.3, (count, 2)) * (friction * start[:, 0])[:, None]
    v_ref, w_ref, ours = v.copy(), w.copy(), start.copy()
    reference = start.copy()
    reference_pgs(sweeps, 8, contacts, bias, friction, (v_ref, w_ref, im, ii), reference)
    solve_pgs(sweeps, 8, contacts, bias, friction, (v, w, im, ii), ours, tolerance=0.0)
    scale = 1 + np.abs(reference).max()
    np.testing.assert_allclose(ours, reference, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(v, v_ref, rtol=0, atol=1e-9 * (1 + np.abs(v_ref).max()))
    np.testing.assert_allclose(w, w_ref, rtol=0, atol=1e-9 * (1 + np.abs(w_ref).max()))


def random_warm_start(seed, friction):
    """Impulses with some normals zero, some friction inside its cone and some on it."""
    rng = np.random.default_rng(seed + 1)
    count = len(friction)
    start = np.zeros((count, 3))
    start[:, 0] = rng.uniform(0, 1, count) * (rng.uniform(size=count) < 0.8)
    turn = rng.uniform(0, 2 * np.pi, count)
    reach = rng.choice([0.3, 0.95, 1.0], count) * friction * start[:, 0]
    start[:, 1] = reach * np.cos(turn)
    start[:, 2] = reach * np.sin(turn)
    return start


def pgs_arrays(contacts, im, ii):
    body_a, body_b, arm_a, arm_b, basis = contacts
    return build_rows(body_a, body_b, arm_a, arm_b, basis, im, ii)


def reference_subspace_run(seed, count, iterations, symmetrise):
    """The dense reference's step on ``random_free_bodies(seed, count)`` from its random warm
    start: (impulse, velocity, angular velocity)."""
    contacts, bias, friction, v, w, im, ii, *_ = random_free_bodies(seed, count)
    start = random_warm_start(seed, friction)
    ContactRows(contacts, (v, w, im, ii)).apply_all(start)
    impulse = start.copy()
    reference_subspace_step(
        iterations, 8, contacts, bias, friction, (v, w, im, ii), impulse, symmetrise
    )
    return impulse, v, w


@given(st.integers(0, 10**6), st.integers(1, 6), st.integers(1, 8))
@example(7, 4, 7)  # dependent rows: CG's last direction had round-off curvature
@example(48926, 5, 6)  # ill-conditioned: round-off grows a thousandfold per step
def test_subspace_step_agrees_with_a_dense_reference(seed, count, iterations):
    """The kernel's matrix-free conjugate gradients on the active rows against the same
    iteration on the dense matrix of those rows, and the same projection.

    Past the first few steps on an ill-conditioned island CG amplifies round-off a
    thousandfold per step, so the kernel is asked to agree as closely as two references that
    differ in round-off only (the matrix as built, and symmetrised) agree with each other
    (times 1000), and to 1e-8 of the largest impulse in any case."""
    contacts, bias, friction, v, w, im, ii, *_ = random_free_bodies(seed, count)
    ours = random_warm_start(seed, friction)
    angular_a, angular_b, response_a, response_b, normal_step, tangent_step, _ = pgs_arrays(
        contacts, im, ii
    )
    body_a, body_b, _, _, basis = contacts
    apply_warm_start(0, count, body_a, body_b, basis, response_a, response_b, im, v, w, ours)
    scratch = [np.empty((count, 3)) for _ in range(5)] + [np.empty_like(v), np.empty_like(w)]
    subspace_step(
        0, count, iterations, friction_polygon(8), body_a, body_b, basis, angular_a, angular_b,
        response_a, response_b, normal_step, tangent_step, im, bias, friction, v, w, ours,
        *scratch,
    )  # fmt: skip
    reference = reference_subspace_run(seed, count, iterations, symmetrise=False)
    symmetrised = reference_subspace_run(seed, count, iterations, symmetrise=True)
    for got, expected, other in zip((ours, v, w), reference, symmetrised, strict=True):
        spread = np.abs(expected - other).max()
        tolerance = 1e-8 * (1 + np.abs(expected).max()) + 1000 * spread
        np.testing.assert_allclose(got, expected, rtol=0, atol=tolerance)


def solve_with_subspace_steps(contacts, bias, friction, v, w, im, ii, tolerance):
    """``sweep_with_subspace_steps`` on the whole problem, from no warm start."""
    count = len(bias)
    body_a, body_b, _, _, basis = contacts
    impulse = np.zeros((count, 3))
    _, converged = sweep_with_subspace_steps(
        0, count, 20000, np.full(count, tolerance), friction_polygon(8), body_a, body_b, basis,
        pgs_arrays(contacts, im, ii), im, bias, friction, v, w, impulse,
    )  # fmt: skip
    return impulse, converged


@given(st.integers(0, 10**6), st.integers(1, 5))
def test_subspace_steps_converge_to_the_exact_velocities_without_friction(seed, count):
    """Sweeps with conjugate-gradient steps between them reach Lemke's unique velocities."""
    contacts, bias, _, v, w, im, ii, *_ = random_free_bodies(seed, count)
    frictionless = np.zeros(count)
    v_ours, w_ours = v.copy(), w.copy()
    _, status = solve("exact", contacts, bias, frictionless, v, w, im, ii)
    assume(status == 0)
    solve_with_subspace_steps(contacts, bias, frictionless, v_ours, w_ours, im, ii, 0.0)
    np.testing.assert_allclose(v_ours, v, atol=1e-5 * (1 + np.abs(v).max()))
    np.testing.assert_allclose(w_ours, w, atol=1e-5 * (1 + np.abs(w).max()))


@given(st.integers(0, 10**6), st.integers(1, 5))
@example(489927, 4)  # dependent rows: an unbounded CG step once gave impulses of 4e11
def test_subspace_steps_meet_the_contact_conditions_with_friction(seed, count):
    contacts, bias, friction, v, w, im, ii, *_ = random_free_bodies(seed, count)
    impulse, converged = solve_with_subspace_steps(contacts, bias, friction, v, w, im, ii, 1e-12)
    assume(converged)
    bodies = (v, w, im, ii)
    scale = 1 + np.abs(impulse).max()
    for k in range(count):
        u_n = relative_velocity(k, 0, contacts, bodies) + bias[k]
        assert u_n >= -1e-8 and impulse[k, 0] >= 0.0
        assert abs(u_n * impulse[k, 0]) <= 1e-8 * scale
        assert np.hypot(impulse[k, 1], impulse[k, 2]) <= friction[k] * impulse[k, 0] * (1 + 1e-12)


def test_exact_solver_rarely_falls_back():
    """Random contact sets can be jammed (no velocity satisfies every contact); Lemke's path
    then ends on a secondary ray and the island goes to PGS. Count how often."""
    fallbacks = 0
    for seed in range(200):
        contacts, bias, friction, v, w, im, ii, *_ = random_free_bodies(seed, 5)
        impulse, status = solve("exact", contacts, bias, friction, v, w, im, ii)
        fallbacks += status != 0
        assert np.all(np.isfinite(impulse)) and np.all(impulse[:, 0] >= 0)
    assert fallbacks <= 10  # 5 %


def test_polygon_projection_against_brute_force():
    rng = np.random.default_rng(0)
    sides, radius = 6, 1.3
    angles = 2 * np.pi * np.arange(sides) / sides
    vertices = radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    # dense sample of the polygon boundary and interior as the oracle
    s = np.linspace(0, 1, 2001)
    boundary = np.concatenate(
        [vertices[j] + s[:, None] * (vertices[(j + 1) % sides] - vertices[j]) for j in range(sides)]
    )
    for point in rng.normal(scale=2.0, size=(200, 2)):
        p = np.array(project_onto_polygon(point[0], point[1], radius, friction_polygon(sides)))
        inside = np.all(
            (vertices[(np.arange(sides) + 1) % sides] - vertices)[:, 0]
            * (point[1] - vertices[:, 1])
            - (vertices[(np.arange(sides) + 1) % sides] - vertices)[:, 1]
            * (point[0] - vertices[:, 0])
            >= 0
        )
        if inside:
            np.testing.assert_allclose(p, point, atol=1e-12)
        else:
            nearest = boundary[np.argmin(np.linalg.norm(boundary - point, axis=1))]
            assert np.linalg.norm(p - point) <= np.linalg.norm(nearest - point) + 1e-12
            assert np.linalg.norm(p - nearest) < 2e-3
    assert project_onto_polygon(1.0, 1.0, 0.0, friction_polygon(4)) == (0.0, 0.0)


@given(st.floats(-10, 10, allow_nan=False), st.floats(-10, 10, allow_nan=False), st.integers(3, 12))
def test_polygon_projection_finds_the_sector_of_any_angle(x1, x2, sides):
    """The sector search (no arctangent) on every side count and angle, vertices and axes
    included, against the nearest of all edges' projections."""
    ours = np.array(project_onto_polygon(x1, x2, 1.7, friction_polygon(sides)))
    np.testing.assert_allclose(ours, nearest_in_polygon((x1, x2), 1.7, sides), atol=1e-12)


def test_basis_is_orthonormal_and_right_handed():
    normals = np.random.default_rng(1).normal(size=(50, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    basis = contact_basis(normals)
    for frame, n in zip(basis, normals, strict=True):
        np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(frame[0], n)
        np.testing.assert_allclose(np.cross(frame[1], frame[2]), n, atol=1e-14)


@given(st.integers(0, 10**6), st.integers(1, 6), st.integers(1, 30), st.booleans())
def test_island_tolerances_follow_each_islands_fastest_contact_point(seed, islands, c, rest):
    """Each contact's tolerance is raised to the fraction of its own island's fastest
    contact-point speed, against a direct NumPy computation; an island at rest keeps its own."""
    rng = np.random.default_rng(seed)
    n = 8
    cuts = np.sort(rng.choice(np.arange(1, c), size=min(islands - 1, c - 1), replace=False))
    island_start = np.concatenate(([0], cuts, [c])).astype(np.int64)
    body_a = rng.integers(0, n, c).astype(np.int64)
    body_b = ((body_a + rng.integers(1, n, c)) % n).astype(np.int64)
    arm_a, arm_b = rng.normal(size=(c, 3)), rng.normal(size=(c, 3))
    v, w = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    if rest:
        v[:], w[:] = 0.0, 0.0
    tolerance = 10.0 ** rng.uniform(-8, 0, c)
    relative = 10.0 ** rng.uniform(-4, -1)

    got = island_tolerances(island_start, body_a, body_b, arm_a, arm_b, v, w, tolerance, relative)

    u = v[body_a] + np.cross(w[body_a], arm_a) - v[body_b] - np.cross(w[body_b], arm_b)
    speed = np.linalg.norm(u, axis=1)
    expected = tolerance.copy()
    for s, e in itertools.pairwise(island_start):
        expected[s:e] = np.maximum(tolerance[s:e], relative * speed[s:e].max())
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    if rest:
        np.testing.assert_array_equal(got, tolerance)
