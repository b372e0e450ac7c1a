"""Exact orientation predicates for the collision kernels (Shewchuk 1997).

Every branch of the triangle tests is a sign of an orientation determinant: which side of a
plane a point lies on (``orient3d``), or which side of a line in a coordinate plane
(``orient2d``). Evaluated in floating point, a determinant that is exactly zero (touching,
flush, coplanar input) comes out as round-off of either sign, and a test that branches on it
decides at random. Here each sign is exact for the float64 coordinates given:

* a *filter* evaluates the determinant in floating point together with Shewchuk's bound on
  its rounding error (``errboundA``: the error is at most ``(7 + 56 eps) eps`` times the
  permanent for orient3d, ``(3 + 16 eps) eps`` for orient2d); when the value exceeds the
  bound, its sign is certain, which is the common case and costs a few multiplications;
* otherwise the determinant is evaluated *exactly* in expansion arithmetic: every number is
  kept as a sum of non-overlapping float64 components (``two_sum``, ``two_product`` by
  Dekker's split, ``scale_expansion`` and ``fast_expansion_sum`` with zero elimination), and
  the sign of the exact sum is the sign of its largest component. The exact routines are
  separate kernels, compiled once and only called when the filter cannot decide.

Exactness, of the filter's bound as of the expansions, assumes that no product of three
coordinate differences (nor its rounding error) overflows or underflows: nonzero differences
between about 1e-80 and 1e90 in magnitude, far beyond the range of any mesh.
Both rely on IEEE round-to-nearest-even without fused or reassociated arithmetic, which is the
package's numba policy (no ``fastmath``).
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["orient2d", "orient3d", "plane_sides"]

_EPS = 2.0**-53  # half an ulp of 1: the relative rounding error of one operation
_SPLITTER = 2.0**27 + 1.0  # Dekker's split of a 53-bit significand into two 26-bit halves
_ORIENT2D_BOUND = (3.0 + 16.0 * _EPS) * _EPS
_ORIENT3D_BOUND = (7.0 + 56.0 * _EPS) * _EPS
_UNSURE = 2  # a filtered sign the bound cannot vouch for


@njit
def _add_product(h, n, e, elen, b, work):
    """``h += e * b`` in place, for expansions h (length n) and e (length elen) and a float
    b; returns the new length of h. h needs ``n + 2 elen`` slots, ``work`` as many more
    than h's new length plus ``2 elen``.

    Expansions hold non-overlapping components in increasing magnitude, zeros dropped
    (length 0 is zero). First ``e * b`` (Shewchuk's scale_expansion_zeroelim): each product
    is split exactly into its rounded value and error by Dekker's algorithm (operands split
    into 26-bit halves), and accumulated by Knuth's two-sum; then the sum with h (his
    fast_expansion_sum_zeroelim): the components of both merged by magnitude and
    accumulated smallest first, every rounding error kept as a component.
    """
    c = _SPLITTER * b
    bhi = c - (c - b)
    blo = b - bhi
    m = 0
    q = 0.0
    for i in range(elen):
        a = e[i]
        c = _SPLITTER * a
        ahi = c - (c - a)
        alo = a - ahi
        p1 = a * b
        p0 = alo * blo - (((p1 - ahi * bhi) - alo * bhi) - ahi * blo)
        for x_in in (p0, p1):
            x = q + x_in
            bv = x - q
            err = (q - (x - bv)) + (x_in - bv)
            q = x
            if err != 0.0:
                work[m] = err
                m += 1
    if q != 0.0:
        work[m] = q
        m += 1
    # Merge h[:n] and work[:m] into work[m:], then copy back into h.
    i = 0
    j = 0
    k = m
    q = 0.0
    while i < n or j < m:
        if j == m or (i < n and abs(work[j]) > abs(h[i])):
            x_in = h[i]
            i += 1
        else:
            x_in = work[j]
            j += 1
        x = q + x_in
        bv = x - q
        err = (q - (x - bv)) + (x_in - bv)
        q = x
        if err != 0.0:
            work[k] = err
            k += 1
    if q != 0.0:
        work[k] = q
        k += 1
    for r in range(m, k):
        h[r - m] = work[r]
    return k - m


@njit
def _difference(a, b, h):
    """Write ``a - b`` exactly as an expansion of at most two components into h; length."""
    x = a - b
    bv = a - x
    y = (a - (x + bv)) + (bv - b)
    n = 0
    if y != 0.0:
        h[n] = y
        n += 1
    if x != 0.0:
        h[n] = x
        n += 1
    return n


@njit
def _orient2d_expansion(ax, ay, bx, by, cx, cy, h, work):
    """``h = (a - c) x (b - c)`` exactly; returns its length (h: 16 slots, work: 44).

    Each difference is an exact two-term expansion, and the cross product is accumulated
    from their component products.
    """
    acx = work[0:2]
    acy = work[2:4]
    bcx = work[4:6]
    bcy = work[6:8]
    n_acx = _difference(ax, cx, acx)
    n_acy = _difference(ay, cy, acy)
    n_bcx = _difference(bx, cx, bcx)
    n_bcy = _difference(by, cy, bcy)
    scratch = work[8:44]
    n = 0
    for j in range(n_bcy):
        n = _add_product(h, n, acx, n_acx, bcy[j], scratch)
    for j in range(n_bcx):
        n = _add_product(h, n, acy, n_acy, -bcx[j], scratch)
    return n


@njit
def orient2d(a, b, c):
    """Exact sign of the 2D orientation ``(a - c) x (b - c)`` of three points.

    Parameters
    ----------
    a, b, c : tuple of 2 float

    Returns
    -------
    int
        +1 if a, b, c turn counter-clockwise, -1 if clockwise, 0 if collinear (exactly).
    """
    left = (a[0] - c[0]) * (b[1] - c[1])
    right = (a[1] - c[1]) * (b[0] - c[0])
    det = left - right
    bound = _ORIENT2D_BOUND * (abs(left) + abs(right))
    if det > bound:
        return 1
    if det < -bound:
        return -1
    if left == 0.0 and right == 0.0:
        return 0  # both products exactly zero: a factor is an exact zero difference
    work = np.empty(60)
    h = work[44:60]
    n = _orient2d_expansion(a[0], a[1], b[0], b[1], c[0], c[1], h, work)
    # The sign of an expansion is the sign of its largest (last) component.
    return 0 if n == 0 else (1 if h[n - 1] > 0.0 else -1)


@njit
def _orient3d_exact(a, b, c, d):
    """Exact sign of ``(a - d) . ((b - d) x (c - d))`` (the filter's fallback).

    Component i of the cross product is the 2D orientation of b, c, d in coordinates
    ``(i + 1, i + 2)``; each is multiplied by the two-term expansion of ``a_i - d_i``.
    """
    work = np.empty(44)
    minor = np.empty(16)
    det = np.empty(192)
    scratch = np.empty(256)
    n = 0
    for i in range(3):
        j = (i + 1) % 3
        k = (i + 2) % 3
        m = _orient2d_expansion(b[j], b[k], c[j], c[k], d[j], d[k], minor, work)
        parts = _difference(a[i], d[i], work[0:2])
        for part in range(parts):
            n = _add_product(det, n, minor, m, work[part], scratch)
    return 0 if n == 0 else (1 if det[n - 1] > 0.0 else -1)


@njit
def _filtered(a, d, m0a, m0b, m1a, m1b, m2a, m2b):
    """Sign of orient3d(a, b, c, d) by Shewchuk's filter, given the products forming
    ``(b - d) x (c - d)`` (component i is ``mia - mib``), term for term as he evaluates it:
    +1, -1 or 0 when certain, ``_UNSURE`` when only exact arithmetic can tell."""
    adx = a[0] - d[0]
    ady = a[1] - d[1]
    adz = a[2] - d[2]
    det = adx * (m0a - m0b) + ady * (m1a - m1b) + adz * (m2a - m2b)
    permanent = (
        abs(adx) * (abs(m0a) + abs(m0b))
        + abs(ady) * (abs(m1a) + abs(m1b))
        + abs(adz) * (abs(m2a) + abs(m2b))
    )
    bound = _ORIENT3D_BOUND * permanent
    # Branch-free: the sign is data, and a taken/not-taken guess on it would miss half the
    # time. A zero permanent means every term has an exact zero factor: the sign is 0.
    sign = int(det > bound) - int(det < -bound)
    if sign == 0 and permanent != 0.0:
        return _UNSURE
    return sign


@njit
def orient3d(a, b, c, d):
    """Exact sign of the orientation determinant ``(a - d) . ((b - d) x (c - d))``.

    Parameters
    ----------
    a, b, c, d : tuple of 3 float

    Returns
    -------
    int
        +1 if a lies on the side of the plane through d, b, c that the normal
        ``(b - d) x (c - d)`` points to, -1 on the other side, 0 if the four points are
        coplanar (exactly).
    """
    bdx = b[0] - d[0]
    bdy = b[1] - d[1]
    bdz = b[2] - d[2]
    cdx = c[0] - d[0]
    cdy = c[1] - d[1]
    cdz = c[2] - d[2]
    sign = _filtered(a, d, bdy * cdz, bdz * cdy, bdz * cdx, bdx * cdz, bdx * cdy, bdy * cdx)
    if sign == _UNSURE:
        return _orient3d_exact(a, b, c, d)
    return sign


@njit
def plane_sides(q0, q1, q2, p0, p1, p2):
    """Exact side of each of p0, p1, p2 against the plane through q0, q1, q2.

    Equal to ``(orient3d(p0, q0, q1, q2), orient3d(p1, ...), orient3d(p2, ...))``: +1 on the
    side the normal ``(q0 - q2) x (q1 - q2)`` points to, -1 on the other, 0 on the plane;
    all three are 0 when q0, q1, q2 are collinear. The normal's products are shared (the
    hot path of the triangle test).
    """
    bdx = q0[0] - q2[0]
    bdy = q0[1] - q2[1]
    bdz = q0[2] - q2[2]
    cdx = q1[0] - q2[0]
    cdy = q1[1] - q2[1]
    cdz = q1[2] - q2[2]
    m0a = bdy * cdz
    m0b = bdz * cdy
    m1a = bdz * cdx
    m1b = bdx * cdz
    m2a = bdx * cdy
    m2b = bdy * cdx
    s0 = _filtered(p0, q2, m0a, m0b, m1a, m1b, m2a, m2b)
    s1 = _filtered(p1, q2, m0a, m0b, m1a, m1b, m2a, m2b)
    s2 = _filtered(p2, q2, m0a, m0b, m1a, m1b, m2a, m2b)
    if s0 == _UNSURE:
        s0 = _orient3d_exact(p0, q0, q1, q2)
    if s1 == _UNSURE:
        s1 = _orient3d_exact(p1, q0, q1, q2)
    if s2 == _UNSURE:
        s2 = _orient3d_exact(p2, q0, q1, q2)
    return s0, s1, s2
