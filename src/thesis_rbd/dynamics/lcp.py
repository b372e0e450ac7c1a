"""Linear complementarity problems: Lemke's exact pivoting method and projected Gauss-Seidel.

An LCP(M, q) asks for z such that

    w = M z + q,   z >= 0,   w >= 0,   z . w = 0.

Contact with restitution, resting contact and friction become one such problem per island of
touching bodies (thesis 7.2, and its further work). Two solvers, selectable so the reports can
show what the exact answer costs:

* ``lemke`` -- complementary pivoting on a dense tableau (Lemke 1965, as in Cottle, Pang and
  Stone, "The Linear Complementarity Problem", 4.4). It returns an exact solution (to round-off)
  whenever Lemke's method terminates on a secondary ray-free path, which Anitescu and Potra
  (1997) proved for the velocity-level contact LCP with a polyhedral friction cone used here.
* ``projected_gauss_seidel`` -- the iterative sweep of most game engines: each row solved
  for its own variable, clamped at zero; converges for symmetric positive (semi-)definite M.
  (The friction-aware block version lives in ``contact_solver``.)

Both are numba kernels on dense float64 arrays; an island's LCP is small (tens of rows).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit

__all__ = ["LCP_STATUS", "lemke", "projected_gauss_seidel"]

# Outcomes of ``lemke``; anything but SOLVED leaves z at the last basis' values.
LCP_STATUS = {0: "solved", 1: "secondary ray (no solution found)", 2: "iteration limit"}


@njit
def lemke(M, q, max_pivots=0, pivot_tolerance=1e-12):
    """Solve LCP(M, q) by Lemke's method with the covering vector d = 1.

    Parameters
    ----------
    M : (n, n) float64
        LCP matrix.
    q : (n,) float64
        LCP vector.
    max_pivots : int
        Pivot limit; 0 means 50 * (n + 1).
    pivot_tolerance : float
        Column entries at or below this (relative to the column's largest) are not pivots.

    Returns
    -------
    z : (n,) float64
        The solution (valid when status is 0).
    status : int
        0 solved, 1 secondary ray, 2 pivot limit (see ``LCP_STATUS``).
    pivots : int
        Number of pivots taken.

    Notes
    -----
    Variables are numbered w_0..w_{n-1} = 0..n-1, z_0..z_{n-1} = n..2n-1 and the artificial
    z0 = 2n. The tableau holds B^-1 [I, -M, -d | q]; the ratio test breaks ties in favour of
    z0 leaving (ending the path) and then of the largest pivot, which keeps the path out of
    near-singular pivots on the degenerate problems redundant contacts produce.
    """
    n = q.shape[0]
    z = np.zeros(n)
    if n == 0:
        return z, 0, 0
    if max_pivots <= 0:
        max_pivots = 50 * (n + 1)
    qmin = 0
    for i in range(1, n):
        if q[i] < q[qmin]:
            qmin = i
    if q[qmin] >= 0.0:
        return z, 0, 0

    width = 2 * n + 1
    T = np.zeros((n, width + 1))
    for i in range(n):
        T[i, i] = 1.0
        for j in range(n):
            T[i, n + j] = -M[i, j]
        T[i, 2 * n] = -1.0
        T[i, width] = q[i]
    basis = np.arange(n)
    artificial = 2 * n

    entering = artificial
    row = qmin
    pivots = 0
    status = 2
    while pivots < max_pivots:
        # pivot on (row, entering)
        leaving = basis[row]
        inv = 1.0 / T[row, entering]
        for k in range(width + 1):
            T[row, k] *= inv
        for i in range(n):
            if i != row:
                factor = T[i, entering]
                if factor != 0.0:
                    for k in range(width + 1):
                        T[i, k] -= factor * T[row, k]
        basis[row] = entering
        pivots += 1
        if leaving == artificial:
            status = 0
            break
        # the complement of the leaving variable enters
        entering = leaving + n if leaving < n else leaving - n
        column_scale = 0.0
        for i in range(n):
            column_scale = max(column_scale, abs(T[i, entering]))
        threshold = pivot_tolerance * max(column_scale, 1.0)
        row = -1
        best_ratio = np.inf
        for i in range(n):
            a = T[i, entering]
            if a > threshold:
                ratio = T[i, width] / a
                if row < 0 or ratio < best_ratio - 1e-12 * max(1.0, abs(best_ratio)):
                    row, best_ratio = i, ratio
                elif ratio <= best_ratio + 1e-12 * max(1.0, abs(best_ratio)):
                    # tie: let z0 leave, else take the larger pivot
                    if basis[i] == artificial or (
                        basis[row] != artificial and a > T[row, entering]
                    ):
                        row, best_ratio = i, min(ratio, best_ratio)
        if row < 0:
            status = 1
            break

    for i in range(n):
        b = basis[i]
        if n <= b < 2 * n:
            z[b - n] = max(T[i, width], 0.0)
    return z, status, pivots


@njit
def projected_gauss_seidel(M, q, z, iterations):
    """Projected Gauss-Seidel sweeps on LCP(M, q), in place from the warm start ``z``.

    Row i solves ``(M z + q)_i = 0`` for ``z_i`` and clamps it at zero.

    Parameters
    ----------
    M : (n, n) float64
        Symmetric positive semi-definite with a positive diagonal (rows with a zero diagonal
        are skipped).
    q : (n,) float64
    z : (n,) float64
        Warm start; overwritten with the result.
    iterations : int
        Number of full sweeps.

    Returns
    -------
    change : float
        Largest change of any z_i in the last sweep (a convergence measure).
    """
    n = q.shape[0]
    change = 0.0
    for _ in range(iterations):
        change = 0.0
        for i in range(n):
            diagonal = M[i, i]
            if diagonal <= 0.0:
                continue
            r = q[i]
            for j in range(n):
                r += M[i, j] * z[j]
            value = max(z[i] - r / diagonal, 0.0)
            change = max(change, abs(value - z[i]))
            z[i] = value
    return change
