"""Linear complementarity problems: Lemke's exact pivoting method.

An LCP(M, q) asks for z such that

    w = M z + q,   z >= 0,   w >= 0,   z . w = 0.

Contact with restitution, resting contact and friction become one such problem per island of
touching bodies (thesis 7.2, and its further work). The contact stage solves it iteratively
(projected Gauss-Seidel on contact rows, ``pgs``) or exactly, selectably so the reports can show
what the exact answer costs; this module is the exact solver:

* ``lemke`` -- complementary pivoting on a dense tableau (Lemke 1965, as in Cottle, Pang and
  Stone, "The Linear Complementarity Problem", 4.4). It returns an exact solution (to round-off)
  whenever Lemke's method terminates on a secondary ray-free path, which Anitescu and Potra
  (1997) proved for the velocity-level contact LCP with a polyhedral friction cone used here.
A numba kernel on dense float64 arrays; an island's LCP is small (tens of rows).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["LCP_STATUS", "lemke"]

# Outcomes of ``lemke``; anything but SOLVED leaves z at the last basis' values.
LCP_STATUS = {0: "solved", 1: "secondary ray (no solution found)", 2: "iteration limit"}


@njit
def _lexicographic_ratio_test(T, basis, entering, n, artificial, pivot_tolerance):
    """Leaving row for ``entering``: the lexicographic minimum ratio test, or -1 (ray).

    Rows with a positive pivot compete on rhs / pivot; ties (redundant contacts make many)
    are broken on the rows of B^-1 divided by the pivot, in column order, which cannot tie
    for two rows and so rules out cycling (Cottle, Pang and Stone 4.9). If the artificial
    variable's row is among the minimisers it leaves, ending the path.
    """
    width = 2 * n + 1
    column_scale = 0.0
    for i in range(n):
        column_scale = max(column_scale, abs(T[i, entering]))
    threshold = pivot_tolerance * max(column_scale, 1.0)
    candidates = np.empty(n, np.int64)
    count = 0
    for i in range(n):
        if T[i, entering] > threshold:
            candidates[count] = i
            count += 1
    if count == 0:
        return -1
    for key in range(-1, n):
        column = width if key < 0 else key
        best = np.inf
        for c in range(count):
            i = candidates[c]
            best = min(best, T[i, column] / T[i, entering])
        tolerance = 1e-12 * max(1.0, abs(best))
        kept = 0
        for c in range(count):
            i = candidates[c]
            if T[i, column] / T[i, entering] <= best + tolerance:
                candidates[kept] = i
                kept += 1
        count = kept
        if key < 0:
            for c in range(count):
                if basis[candidates[c]] == artificial:
                    return candidates[c]
        if count == 1:
            break
    return candidates[0]


@njit(separate=True)
def lemke(M, q, max_pivots=0, pivot_tolerance=1e-7):
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
        Column entries at or below this fraction of the column's largest (or of 1, if that is
        larger: callers scale M to a unit diagonal, so 1 is the problem's own scale) are not
        pivots.
        Redundant (coplanar) contacts make M singular; pivoting on an entry that is only
        round-off of a zero wrecks the tableau: at 1e-12 that happens on a ten-box stack
        (tests/data/stack_projection_lcp.npz), at 1e-7 it does not.

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
    z0 = 2n. The tableau holds B^-1 [I, -M, -d | q]; the leaving row comes from the
    lexicographic minimum ratio test, so the degenerate problems that redundant contacts
    produce cannot make the path cycle.
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
        row = _lexicographic_ratio_test(T, basis, entering, n, artificial, pivot_tolerance)
        if row < 0:
            status = 1
            break

    for i in range(n):
        b = basis[i]
        if n <= b < 2 * n:
            z[b - n] = max(T[i, width], 0.0)
    return z, status, pivots
