"""Exact-arithmetic oracles for the narrow phase: plain Python integers and Fractions.

Float64 numbers are dyadic rationals, so a set of them scaled by a common power of two is a set
of integers; every question below is then answered in integer arithmetic (Fractions only where
a closest point needs a division), with no rounding anywhere. Nothing here is shared with
``thesis_rbd.collision``, and the method differs from the kernel's: two closed triangles meet
iff an edge of one meets the other triangle (their intersection, if any, is bounded by such
points), a segment meets a triangle by where it crosses the plane, and two segments meet when
their exact closest points coincide.

:func:`kernel_frame_corners` reproduces, operation for operation, the float64 arithmetic by
which ``collide`` carries mesh B into mesh A's frame, so that the oracle decides on the very
coordinates the kernel decides on.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from reference import _cross, _dot, _sub

__all__ = [
    "exact_pairs",
    "kernel_frame_corners",
    "segment_meets_box_exact",
    "tri_box_exact",
    "tri_tri_exact",
]


# ------------------------------------------------------------------ exact integer coordinates
def _as_integers(*point_lists):
    """The points (sequences of 3 floats) scaled by one power of two to Python integers."""
    ratios = [[float(x).as_integer_ratio() for x in p] for pts in point_lists for p in pts]
    shift = max(d.bit_length() - 1 for r in ratios for _, d in r)
    ints = [[n << (shift - (d.bit_length() - 1)) for n, d in r] for r in ratios]
    out, k = [], 0
    for pts in point_lists:
        out.append(ints[k : k + len(pts)])
        k += len(pts)
    return out


def _clamp01(x):
    return min(max(x, Fraction(0)), Fraction(1))


def _segments_meet(p1, q1, p2, q2) -> bool:
    """Closed segments p1q1, p2q2 share a point: their exact closest points (Ericson's
    clamped solution, in Fractions) are at distance zero. Either may be a point."""
    d1 = [Fraction(x) for x in _sub(q1, p1)]
    d2 = [Fraction(x) for x in _sub(q2, p2)]
    r = [Fraction(x) for x in _sub(p1, p2)]
    a, e, f = _dot(d1, d1), _dot(d2, d2), _dot(d2, r)
    if a == 0 and e == 0:
        s = t = Fraction(0)
    elif a == 0:
        s, t = Fraction(0), _clamp01(f / e)
    else:
        c = _dot(d1, r)
        if e == 0:
            s, t = _clamp01(-c / a), Fraction(0)
        else:
            b = _dot(d1, d2)
            denom = a * e - b * b
            s = _clamp01((b * f - c * e) / denom) if denom != 0 else Fraction(0)
            t = (b * s + f) / e
            if t < 0:
                t, s = Fraction(0), _clamp01(-c / a)
            elif t > 1:
                t, s = Fraction(1), _clamp01((b - c) / a)
    gap = [p1[i] + s * d1[i] - p2[i] - t * d2[i] for i in range(3)]
    return _dot(gap, gap) == 0


def _in_triangle(x, w, t, n) -> bool:
    """Whether the point x / w (w != 0), on the plane of proper triangle t (normal n), lies
    in the closed triangle."""
    sign = 1 if w > 0 else -1
    for i in range(3):
        a, b = t[i], t[(i + 1) % 3]
        to_x = [x[k] - w * a[k] for k in range(3)]
        if sign * _dot(_cross(_sub(b, a), to_x), n) < 0:
            return False
    return True


def _segment_meets_triangle(a, b, t) -> bool:
    """Closed segment ab against closed triangle t (integer coordinates, t possibly flat)."""
    n = _cross(_sub(t[1], t[0]), _sub(t[2], t[0]))
    edges = ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))
    if n == [0, 0, 0]:
        return any(_segments_meet(a, b, c, d) for c, d in edges)
    da = _dot(n, _sub(a, t[0]))
    db = _dot(n, _sub(b, t[0]))
    if (da > 0 and db > 0) or (da < 0 and db < 0):
        return False
    if da == 0 and db == 0:
        return (
            _in_triangle(a, 1, t, n)
            or _in_triangle(b, 1, t, n)
            or any(_segments_meet(a, b, c, d) for c, d in edges)
        )
    if da == 0:
        return _in_triangle(a, 1, t, n)
    if db == 0:
        return _in_triangle(b, 1, t, n)
    # The crossing point a + da / (da - db) (b - a) in homogeneous form.
    x = [da * b[k] - db * a[k] for k in range(3)]
    return _in_triangle(x, da - db, t, n)


def _triangles_meet(p, q) -> bool:
    return any(_segment_meets_triangle(p[i], p[(i + 1) % 3], q) for i in range(3)) or any(
        _segment_meets_triangle(q[i], q[(i + 1) % 3], p) for i in range(3)
    )


def tri_tri_exact(P, Q) -> bool:
    """Do the closed triangles P and Q (3, 3) share a point? Exact for their float values."""
    p, q = _as_integers(np.asarray(P, float).tolist(), np.asarray(Q, float).tolist())
    return _triangles_meet(p, q)


def segment_meets_box_exact(a, b, h) -> bool:
    """Closed segment ab against the box ``|x| <= h`` (slab clipping in Fractions)."""
    lo, hi = Fraction(0), Fraction(1)
    for k in range(3):
        ak = Fraction(float(a[k]))
        dk = Fraction(float(b[k])) - ak
        hk = Fraction(float(h[k]))
        if dk == 0:
            if abs(ak) > hk:
                return False
            continue
        t0, t1 = (-hk - ak) / dk, (hk - ak) / dk
        lo, hi = max(lo, min(t0, t1)), min(hi, max(t0, t1))
        if lo > hi:
            return False
    return True


def tri_box_exact(V, h) -> bool:
    """Does the closed triangle V (3, 3) meet the box ``|x| <= h``? Exact: an edge of the
    triangle meets the box, or an edge of the box meets the triangle."""
    V = np.asarray(V, float)
    h = np.asarray(h, float)
    if any(segment_meets_box_exact(V[i], V[(i + 1) % 3], h) for i in range(3)):
        return True
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    box_edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
    t, c = _as_integers(V.tolist(), corners.tolist())
    return any(_segment_meets_triangle(c[i], c[j], t) for i, j in box_edges)


# ------------------------------------------------------------------ mesh pairs
def kernel_frame_corners(mesh_b, T_a, T_b) -> np.ndarray:
    """(m, 3, 3) corners of B's triangles in A's mesh frame, rounded as ``collide`` rounds.

    The relative pose is ``R_ab[i, j] = sum_k T_a[k, i] T_b[k, j]`` and
    ``t_ab[i] = sum_k T_a[k, i] (T_b[k, 3] - T_a[k, 3])``, each sum taken left to right; a
    corner v maps to ``((R[i, 0] v0 + R[i, 1] v1) + R[i, 2] v2) + t[i]``.
    """
    Ta = [[float(x) for x in row] for row in np.asarray(T_a, float)]
    Tb = [[float(x) for x in row] for row in np.asarray(T_b, float)]
    R = [
        [Ta[0][i] * Tb[0][j] + Ta[1][i] * Tb[1][j] + Ta[2][i] * Tb[2][j] for j in range(3)]
        for i in range(3)
    ]
    t = [
        Ta[0][i] * (Tb[0][3] - Ta[0][3])
        + Ta[1][i] * (Tb[1][3] - Ta[1][3])
        + Ta[2][i] * (Tb[2][3] - Ta[2][3])
        for i in range(3)
    ]
    v = mesh_b.triangles
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([R[i][0] * x + R[i][1] * y + R[i][2] * z + t[i] for i in range(3)], axis=-1)


def exact_pairs(mesh_a, T_a, mesh_b, T_b) -> np.ndarray:
    """Every intersecting [face of A, face of B] pair, sorted, decided exactly on the
    coordinates ``collide`` decides on (A's own, B's by :func:`kernel_frame_corners`).

    Pairs whose axis-aligned boxes miss are skipped (exact comparisons of the same floats:
    such triangles cannot meet); the rest are decided in integer arithmetic.
    """
    ta = np.asarray(mesh_a.triangles, float)
    tb = kernel_frame_corners(mesh_b, T_a, T_b)
    lo_a, hi_a = ta.min(axis=1), ta.max(axis=1)
    lo_b, hi_b = tb.min(axis=1), tb.max(axis=1)
    near = np.all((lo_a[:, None] <= hi_b[None]) & (lo_b[None] <= hi_a[:, None]), axis=2)
    out = []
    for i, j in zip(*np.nonzero(near), strict=True):
        p, q = _as_integers(ta[i].tolist(), tb[j].tolist())
        if _triangles_meet(p, q):
            out.append((int(i), int(j)))
    return np.array(out, dtype=np.int64).reshape(-1, 2)
