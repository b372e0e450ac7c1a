"""LCP solvers against a brute-force oracle that enumerates complementary bases."""

import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from reference_pgs import dense_projected_gauss_seidel

from thesis_rbd.dynamics.lcp import lemke


def brute_force_lcp(M, q, tolerance=1e-9):
    """Every z with w = Mz + q, z, w >= 0, z.w = 0, found by trying all 2^n supports."""
    n = len(q)
    solutions = []
    for support in itertools.product([False, True], repeat=n):
        idx = np.flatnonzero(support)
        z = np.zeros(n)
        if len(idx):
            try:
                z[idx] = np.linalg.solve(M[np.ix_(idx, idx)], -q[idx])
            except np.linalg.LinAlgError:
                continue
        w = M @ z + q
        if z.min() >= -tolerance and w.min() >= -tolerance:
            solutions.append(z)
    return solutions


def assert_complementary(M, q, z, tolerance):
    w = M @ z + q
    scale = 1 + np.abs(q).max()
    assert z.min() >= -tolerance * scale
    assert w.min() >= -tolerance * scale
    assert abs(z @ w) <= tolerance * scale * (1 + np.abs(z).max())


def random_problem(seed, n, kind):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    if kind == "positive_definite":
        M = A @ A.T + 0.1 * np.eye(n)
    elif kind == "semidefinite":  # rank-deficient, like redundant contacts
        B = rng.normal(size=(n, max(1, n // 2)))
        M = B @ B.T
    else:  # P-matrix that is not symmetric
        M = A @ A.T + 0.1 * np.eye(n) + 0.5 * (A - A.T)
    return M, rng.normal(size=n)


@given(st.integers(0, 10**6), st.integers(1, 7), st.sampled_from(["positive_definite", "p_matrix"]))
def test_lemke_finds_the_unique_solution(seed, n, kind):
    M, q = random_problem(seed, n, kind)
    z, status, _ = lemke(M, q)
    assert status == 0
    assert_complementary(M, q, z, 1e-9)
    (expected,) = brute_force_lcp(M, q)  # a P-matrix LCP has exactly one solution
    np.testing.assert_allclose(z, expected, atol=1e-8 * (1 + np.abs(expected).max()))


@given(st.integers(0, 10**6), st.integers(2, 8))
def test_lemke_solves_semidefinite_feasible_problems(seed, n):
    M, q = random_problem(seed, n, "semidefinite")
    # make it feasible: q in the range so some z >= 0 gives w >= 0
    z_feasible = np.abs(np.random.default_rng(seed + 1).normal(size=n))
    q = -M @ z_feasible + np.abs(q)
    z, status, _ = lemke(M, q)
    assert status == 0
    assert_complementary(M, q, z, 1e-8)


def test_lemke_reports_infeasible_problems():
    # w = -z - 1 can never be >= 0 with z >= 0
    _, status, _ = lemke(-np.eye(1), np.array([-1.0]))
    assert status == 1


def test_trivial_problems():
    z, status, pivots = lemke(np.eye(3), np.array([1.0, 2.0, 0.0]))
    assert status == 0 and pivots == 0 and not z.any()
    z, status, _ = lemke(np.zeros((0, 0)), np.zeros(0))
    assert status == 0 and z.shape == (0,)


@pytest.mark.parametrize("seed", range(5))
def test_projected_gauss_seidel_converges_to_lemke(seed):
    M, q = random_problem(seed, 12, "positive_definite")
    exact, status, _ = lemke(M, q)
    assert status == 0
    z = np.zeros(12)
    errors = []
    for _ in range(8):
        dense_projected_gauss_seidel(M, q, z, 50)
        errors.append(np.abs(z - exact).max())
    assert errors[-1] < 1e-6 * (1 + np.abs(exact).max())
    assert errors[-1] <= errors[0]


def test_lemke_solves_a_singular_problem_from_coplanar_contacts():
    """The position-projection LCP of a ten-box stack (40 contacts, 4 per face, rank 30):
    pivoting on round-off entries once left w = Mz + q at -1e-4 with max |q| 1e-4."""
    data = np.load(Path(__file__).parent / "data" / "stack_projection_lcp.npz")
    M, q = data["M"], data["q"]
    assert np.linalg.matrix_rank(M) < len(q)
    z, status, _ = lemke(M, q)
    w = M @ z + q
    scale = np.abs(q).max()
    assert status == 0
    assert z.min() >= 0.0
    assert w.min() >= -1e-6 * scale
    # complementarity, each side against the problem's own scale: w against q's, z against
    # the impulse q_i / M_ii that a row alone would take
    impulse_scale = scale / np.diag(M).max()
    assert np.minimum(z / impulse_scale, w / scale).max() <= 1e-6
