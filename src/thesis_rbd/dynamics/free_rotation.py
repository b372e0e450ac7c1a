"""Torque-free rotation that keeps kinetic energy and angular momentum exactly.

A body turning freely keeps its world angular momentum L, and its body-frame momentum
M = R^T L obeys Euler's equations dM/dt = M x (I^-1 M). Both |M|^2 and the kinetic energy
M . I^-1 M / 2 are quadratic invariants, and the implicit midpoint rule keeps every quadratic
invariant of a flow exactly (Hairer, Lubich & Wanner, Geometric Numerical Integration, IV.2):

    M1 = M0 + h m x (I^-1 m),   m = (M0 + M1) / 2.

That step is a rotation of M by the Cayley transform of h w, w = I^-1 m (M1 = cay(h w)^T M0),
so turning the body by the same rotation, R1 = R0 cay(h w), gives R1 M1 = R0 M0 = L: the world
momentum is unchanged, the energy is unchanged, and the orientation stays a rotation. The
Cayley rotation's quaternion needs no trigonometry: (h w / 2, 1) / |(h w / 2, 1)|.

An explicit update (q turned by w dt with w held, or a Runge-Kutta method on q) lets a body
spinning about an axis other than a principal one drift towards its axis of least inertia,
gaining energy until it spins about it: a thin rod tumbling at 100 rad/s gains its inertia
ratio (200x) within a tenth of a second at dt = 1/240. The implicit step has no such drift at
any spin; it is solved by Newton's method on m (a 3x3 system, two to five iterations). A step
in which the body may turn by more than half a radian is cut into equal pieces (the bound
comes from the energy and |I^-1|, which the turn keeps), as is one in which Newton does not
converge near M0; each piece is exact in energy and momentum.
"""

from __future__ import annotations

import math

from thesis_rbd._numba.jit import njit
from thesis_rbd.spatial.quaternion import conjugate, mul, normalize, rotate

__all__ = ["turn_freely"]

# Newton iterations before a step is split in two; the iteration converges quadratically,
# so a step that needs more is one Newton does not reach from its starting point
_MOST_ITERATIONS = 12
# the most pieces of a step, so that its work is bounded whatever the spin: a body turning by
# more than 2048 rad in a step (half a million rad/s at dt = 1/240) is not turned; its
# orientation comes back not a number, which the integrator reports as a failed step
_MOST_PIECES = 4096
# converged when the Newton correction is below this fraction of |m|: round-off
_TOLERANCE = 4e-16
# the largest turn (rad) of one piece of a step, bounded by the motion's invariants
_LARGEST_TURN = 0.5
# the most the midpoint momentum may differ from the start's, as a fraction of |M| (M turns by
# at most about 30 degrees in the body frame per piece): the implicit equation has other
# roots far from M when h |M| |I^-1| is large, and a piece this short keeps near the one that
# the flow reaches
_LARGEST_CHANGE = 0.25


@njit
def turn_freely(q, L, inverse_inertia_body, h):
    """Orientation after time ``h`` of torque-free rotation, as a unit 4-tuple.

    Parameters
    ----------
    q : 4-indexable
        Orientation (x, y, z, w) at the start, unit.
    L : 3-indexable
        World angular momentum (kg m^2/s), constant over the step.
    inverse_inertia_body : (3, 3) float64
        I_body^-1 (body frame).
    h : float
        Time (s); negative turns the body back.

    Returns
    -------
    tuple
        The orientation at time ``h``; R(q1)^T L has the length and the kinetic energy of
        R(q)^T L to round-off. Not a number where the body would turn by more than
        ``_MOST_PIECES`` half radians, or Newton converges in no division of the step.
    """
    q = (q[0], q[1], q[2], q[3])
    M = rotate(conjugate(q), L)
    if M[0] == 0.0 and M[1] == 0.0 and M[2] == 0.0:
        return q
    pieces = _pieces(M, inverse_inertia_body, h)
    while pieces <= _MOST_PIECES:
        turned, converged = _turn_in_pieces(q, M, inverse_inertia_body, h, pieces)
        if converged:
            return turned
        pieces *= 2
    nan = math.nan
    return (nan, nan, nan, nan)


@njit
def _pieces(M, A, h):
    """Pieces of the step such that none turns the body by more than ``_LARGEST_TURN``.

    The bound on |w| comes from the motion's invariants, |A M|^2 <= |A| (M . A M) = 2 E |A|
    with |A| the largest moment of A (its Frobenius norm bounds it), so every step of one
    free motion is cut alike."""
    a2 = 0.0
    for r in range(3):
        for c in range(3):
            a2 += A[r, c] * A[r, c]
    twice_energy = 0.0
    for r in range(3):
        twice_energy += M[r] * (A[r, 0] * M[0] + A[r, 1] * M[1] + A[r, 2] * M[2])
    fastest = math.sqrt(max(twice_energy, 0.0) * math.sqrt(a2))
    turn = abs(h) * fastest
    if not turn <= _LARGEST_TURN * _MOST_PIECES:
        return 2 * _MOST_PIECES  # more than the most: not turned
    return max(1, math.ceil(turn / _LARGEST_TURN))


@njit
def _turn_in_pieces(q, M, A, h, pieces):
    """``q`` turned through ``pieces`` implicit midpoint steps of h / pieces from body momentum
    ``M``; also whether Newton converged in every piece."""
    step = h / pieces
    for _ in range(pieces):
        m, converged = _midpoint_momentum(M, A, step)
        if not converged:
            return q, False
        wx = A[0, 0] * m[0] + A[0, 1] * m[1] + A[0, 2] * m[2]
        wy = A[1, 0] * m[0] + A[1, 1] * m[1] + A[1, 2] * m[2]
        wz = A[2, 0] * m[0] + A[2, 1] * m[1] + A[2, 2] * m[2]
        half = 0.5 * step
        cayley = normalize((half * wx, half * wy, half * wz, 1.0))
        q = normalize(mul(q, cayley))
        # the body momentum turns back by the same rotation: M1 = cay(h w)^T M0
        M = rotate(conjugate(cayley), M)
    return q, True


@njit
def _midpoint_momentum(M, A, h):
    """The midpoint m = M + (h/2) m x (A m) of one implicit midpoint step, by Newton's
    method from m = M; also whether it converged within ``_LARGEST_CHANGE`` of M."""
    c = 0.5 * h
    m0, m1, m2 = M[0], M[1], M[2]
    scale2 = m0 * m0 + m1 * m1 + m2 * m2
    largest2 = _LARGEST_CHANGE * _LARGEST_CHANGE * scale2
    for _ in range(_MOST_ITERATIONS):
        a0 = A[0, 0] * m0 + A[0, 1] * m1 + A[0, 2] * m2
        a1 = A[1, 0] * m0 + A[1, 1] * m1 + A[1, 2] * m2
        a2 = A[2, 0] * m0 + A[2, 1] * m1 + A[2, 2] * m2
        # residual r = m - M - c m x (A m)
        r0 = m0 - M[0] - c * (m1 * a2 - m2 * a1)
        r1 = m1 - M[1] - c * (m2 * a0 - m0 * a2)
        r2 = m2 - M[2] - c * (m0 * a1 - m1 * a0)
        # Jacobian J = I - c (skew(m) A - skew(A m))
        J = _newton_matrix(m0, m1, m2, a0, a1, a2, A, c)
        d0, d1, d2, ok = _solve3(J, r0, r1, r2)
        if not ok:
            return (m0, m1, m2), False
        m0, m1, m2 = m0 - d0, m1 - d1, m2 - d2
        if d0 * d0 + d1 * d1 + d2 * d2 <= _TOLERANCE * _TOLERANCE * scale2:
            e0, e1, e2 = m0 - M[0], m1 - M[1], m2 - M[2]
            return (m0, m1, m2), e0 * e0 + e1 * e1 + e2 * e2 <= largest2
        if not math.isfinite(m0 + m1 + m2):
            return (m0, m1, m2), False
    return (m0, m1, m2), False


@njit
def _newton_matrix(m0, m1, m2, a0, a1, a2, A, c):
    """I - c (skew(m) A - skew(a)) as a row-major 9-tuple, a = A m."""
    # skew(m) A: row i is m x (column j of A) read per column
    s = (
        m1 * A[2, 0] - m2 * A[1, 0], m1 * A[2, 1] - m2 * A[1, 1], m1 * A[2, 2] - m2 * A[1, 2],
        m2 * A[0, 0] - m0 * A[2, 0], m2 * A[0, 1] - m0 * A[2, 1], m2 * A[0, 2] - m0 * A[2, 2],
        m0 * A[1, 0] - m1 * A[0, 0], m0 * A[1, 1] - m1 * A[0, 1], m0 * A[1, 2] - m1 * A[0, 2],
    )  # fmt: skip
    # skew(a) = [[0, -a2, a1], [a2, 0, -a0], [-a1, a0, 0]]
    return (
        1.0 - c * s[0], -c * (s[1] + a2), -c * (s[2] - a1),
        -c * (s[3] - a2), 1.0 - c * s[4], -c * (s[5] + a0),
        -c * (s[6] + a1), -c * (s[7] - a0), 1.0 - c * s[8],
    )  # fmt: skip


@njit
def _solve3(J, r0, r1, r2):
    """x with J x = r for a row-major 3x3 ``J`` (Cramer's rule); also False if J is
    singular."""
    c00 = J[4] * J[8] - J[5] * J[7]
    c01 = J[5] * J[6] - J[3] * J[8]
    c02 = J[3] * J[7] - J[4] * J[6]
    det = J[0] * c00 + J[1] * c01 + J[2] * c02
    if det == 0.0 or not math.isfinite(det):
        return 0.0, 0.0, 0.0, False
    inv = 1.0 / det
    x0 = (c00 * r0 + (J[2] * J[7] - J[1] * J[8]) * r1 + (J[1] * J[5] - J[2] * J[4]) * r2) * inv
    x1 = (c01 * r0 + (J[0] * J[8] - J[2] * J[6]) * r1 + (J[2] * J[3] - J[0] * J[5]) * r2) * inv
    x2 = (c02 * r0 + (J[1] * J[6] - J[0] * J[7]) * r1 + (J[0] * J[4] - J[1] * J[3]) * r2) * inv
    return x0, x1, x2, True
