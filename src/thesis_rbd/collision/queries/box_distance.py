"""Lower bounds on the distance between two oriented boxes, and between a triangle and a box.

A distance query descends two OBBTrees and skips every pair of boxes that cannot hold a pair
of triangles closer than the best found so far; all it needs from the boxes is a cheap bound
that never exceeds their true distance. Projecting both on a unit axis ``L`` gives one: the
gap between the two projected intervals, ``|T . L| - (r_A(L) + r_B(L))`` for centre offset
``T`` and projected radii ``r``, is at most the distance, because projection onto a unit axis
shortens every segment. The bound here is the largest gap over the separating-axis test's 15
axes (each edge-edge axis normalised) plus the line through the two centres, which is the
axis along which far-apart boxes are actually separated (the 15 axes alone underestimate the
distance of two cubes offset along a diagonal by up to a factor sqrt(3)). Swept-sphere
rectangles (PQP's and FCL's RSS) give tighter bounds for flat boxes at a higher price per
test; these bounds reuse the tree's OBBs as they are.

Like the overlap test, every |R_ij| is enlarged by ``SAT_EPSILON`` (boxes stored in float32
have axes orthonormal only to about 6e-8), and the result is shrunk by a relative 2e-6, so
round-off in the axes can lower a bound but never raise it above the true distance: a
traversal pruning with it misses no closer pair.
"""

from __future__ import annotations

import math

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.obb import SAT_EPSILON

__all__ = ["box_box_gap", "triangle_box_gap"]

# Relative shrink of every bound (see the module docstring).
_SHRINK = 1.0 - 2e-6


@njit
def _edge_gap(projection, radius, norm2):
    """Gap along an unnormalised axis of squared length ``norm2`` (-inf if degenerate)."""
    if norm2 <= 1e-24:
        return -math.inf
    return (abs(projection) - radius) / math.sqrt(norm2)


# Inlined into the distance traversal, its only caller: called, it cost about 4 % of a
# descent's time in passing its tuples and returning (the distance_paths poses that descend)
@njit(inline="always")
def box_box_gap(R, T, a, b, cutoff):
    """Lower bound on the distance between two boxes (0 when they may overlap).

    The face axes and the centre line come first; if their bound already reaches ``cutoff``
    (a distance the caller only compares the bound with), the nine edge-edge axes are not
    tried.

    Parameters
    ----------
    R : tuple of 9 float
        Row-major rotation of box B's axes in box A's frame (``A.T @ B``).
    T : tuple of 3 float
        Centre of B minus centre of A, in box A's frame.
    a, b : tuple of 3 float
        Half-extents of A and B.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    e = SAT_EPSILON
    q00 = abs(r00) + e
    q01 = abs(r01) + e
    q02 = abs(r02) + e
    q10 = abs(r10) + e
    q11 = abs(r11) + e
    q12 = abs(r12) + e
    q20 = abs(r20) + e
    q21 = abs(r21) + e
    q22 = abs(r22) + e
    t0, t1, t2 = T
    a0, a1, a2 = a
    b0, b1, b2 = b
    # A's face axes.
    g = abs(t0) - (a0 + b0 * q00 + b1 * q01 + b2 * q02)
    g = max(g, abs(t1) - (a1 + b0 * q10 + b1 * q11 + b2 * q12))
    g = max(g, abs(t2) - (a2 + b0 * q20 + b1 * q21 + b2 * q22))
    # B's face axes.
    s0 = t0 * r00 + t1 * r10 + t2 * r20
    s1 = t0 * r01 + t1 * r11 + t2 * r21
    s2 = t0 * r02 + t1 * r12 + t2 * r22
    g = max(g, abs(s0) - (b0 + a0 * q00 + a1 * q10 + a2 * q20))
    g = max(g, abs(s1) - (b1 + a0 * q01 + a1 * q11 + a2 * q21))
    g = max(g, abs(s2) - (b2 + a0 * q02 + a1 * q12 + a2 * q22))
    # The line through the centres.
    tt = t0 * t0 + t1 * t1 + t2 * t2
    if tt > 0.0:
        length = math.sqrt(tt)
        ra = a0 * abs(t0) + a1 * abs(t1) + a2 * abs(t2)
        rb = b0 * abs(s0) + b1 * abs(s1) + b2 * abs(s2)
        g = max(g, length - (ra + rb) / length - e * (a0 + a1 + a2 + b0 + b1 + b2))
    if g * _SHRINK >= cutoff:
        return g * _SHRINK
    # Edge-edge axes A_i x B_j.
    g = max(g, _edge_gap(t2 * r10 - t1 * r20, a1 * q20 + a2 * q10 + b1 * q02 + b2 * q01,
                         r10 * r10 + r20 * r20))  # fmt: skip
    g = max(g, _edge_gap(t2 * r11 - t1 * r21, a1 * q21 + a2 * q11 + b0 * q02 + b2 * q00,
                         r11 * r11 + r21 * r21))  # fmt: skip
    g = max(g, _edge_gap(t2 * r12 - t1 * r22, a1 * q22 + a2 * q12 + b0 * q01 + b1 * q00,
                         r12 * r12 + r22 * r22))  # fmt: skip
    g = max(g, _edge_gap(t0 * r20 - t2 * r00, a0 * q20 + a2 * q00 + b1 * q12 + b2 * q11,
                         r00 * r00 + r20 * r20))  # fmt: skip
    g = max(g, _edge_gap(t0 * r21 - t2 * r01, a0 * q21 + a2 * q01 + b0 * q12 + b2 * q10,
                         r01 * r01 + r21 * r21))  # fmt: skip
    g = max(g, _edge_gap(t0 * r22 - t2 * r02, a0 * q22 + a2 * q02 + b0 * q11 + b1 * q10,
                         r02 * r02 + r22 * r22))  # fmt: skip
    g = max(g, _edge_gap(t1 * r00 - t0 * r10, a0 * q10 + a1 * q00 + b1 * q22 + b2 * q21,
                         r00 * r00 + r10 * r10))  # fmt: skip
    g = max(g, _edge_gap(t1 * r01 - t0 * r11, a0 * q11 + a1 * q01 + b0 * q22 + b2 * q20,
                         r01 * r01 + r11 * r11))  # fmt: skip
    g = max(g, _edge_gap(t1 * r02 - t0 * r12, a0 * q12 + a1 * q02 + b0 * q21 + b1 * q20,
                         r02 * r02 + r12 * r12))  # fmt: skip
    return max(g, 0.0) * _SHRINK


@njit
def _interval_gap(p0, p1, p2, radius):
    """Gap between the interval of three projections and [-radius, radius]."""
    return max(min(p0, p1, p2) - radius, -radius - max(p0, p1, p2))


@njit
def triangle_box_gap(v0, v1, v2, h, cutoff):
    """Lower bound on the distance between a triangle and a box (0 when they may overlap).

    As in :func:`box_box_gap`, the nine edge axes are skipped once the box face axes, the
    triangle normal and the centroid line give a bound of at least ``cutoff``.

    Parameters
    ----------
    v0, v1, v2 : tuple of 3 float
        The triangle's corners in the box's frame (box centre at the origin, axes along x, y,
        z).
    h : tuple of 3 float
        The box's half-extents.
    cutoff : float
        See above.
    """
    e = SAT_EPSILON
    h0 = h[0] * (1.0 + e)
    h1 = h[1] * (1.0 + e)
    h2 = h[2] * (1.0 + e)
    # Box face axes.
    g = _interval_gap(v0[0], v1[0], v2[0], h0)
    g = max(g, _interval_gap(v0[1], v1[1], v2[1], h1))
    g = max(g, _interval_gap(v0[2], v1[2], v2[2], h2))
    # Triangle normal.
    e1 = (v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2])
    e2 = (v2[0] - v1[0], v2[1] - v1[1], v2[2] - v1[2])
    e3 = (v0[0] - v2[0], v0[1] - v2[1], v0[2] - v2[2])
    n = (
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    )
    nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
    if nn > 0.0:
        # every corner projected: the normal of a triangle with (nearly) collinear corners
        # is round-off, and the corners are not at one height along it
        p0 = n[0] * v0[0] + n[1] * v0[1] + n[2] * v0[2]
        p1 = n[0] * v1[0] + n[1] * v1[1] + n[2] * v1[2]
        p2 = n[0] * v2[0] + n[1] * v2[1] + n[2] * v2[2]
        r = h0 * abs(n[0]) + h1 * abs(n[1]) + h2 * abs(n[2])
        g = max(g, _interval_gap(p0, p1, p2, r) / math.sqrt(nn))
    # The line from the box centre through the triangle's centroid.
    c = (
        (v0[0] + v1[0] + v2[0]) / 3.0,
        (v0[1] + v1[1] + v2[1]) / 3.0,
        (v0[2] + v1[2] + v2[2]) / 3.0,
    )
    cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    if cc > 0.0:
        r = h0 * abs(c[0]) + h1 * abs(c[1]) + h2 * abs(c[2])
        p0 = v0[0] * c[0] + v0[1] * c[1] + v0[2] * c[2]
        p1 = v1[0] * c[0] + v1[1] * c[1] + v1[2] * c[2]
        p2 = v2[0] * c[0] + v2[1] * c[1] + v2[2] * c[2]
        g = max(g, (min(p0, p1, p2) - r) / math.sqrt(cc))
    if g * _SHRINK >= cutoff:
        return g * _SHRINK
    # Edge x box-axis axes: for edge d, d x x = (0, d_z, -d_y), d x y = (-d_z, 0, d_x),
    # d x z = (d_y, -d_x, 0); two of the three corners project to the same value.
    for d in (e1, e2, e3):
        p0 = v0[1] * d[2] - v0[2] * d[1]
        p1 = v1[1] * d[2] - v1[2] * d[1]
        p2 = v2[1] * d[2] - v2[2] * d[1]
        r = h1 * abs(d[2]) + h2 * abs(d[1])
        nn = d[1] * d[1] + d[2] * d[2]
        if nn > 1e-24:
            g = max(g, _interval_gap(p0, p1, p2, r) / math.sqrt(nn))
        p0 = v0[2] * d[0] - v0[0] * d[2]
        p1 = v1[2] * d[0] - v1[0] * d[2]
        p2 = v2[2] * d[0] - v2[0] * d[2]
        r = h0 * abs(d[2]) + h2 * abs(d[0])
        nn = d[0] * d[0] + d[2] * d[2]
        if nn > 1e-24:
            g = max(g, _interval_gap(p0, p1, p2, r) / math.sqrt(nn))
        p0 = v0[0] * d[1] - v0[1] * d[0]
        p1 = v1[0] * d[1] - v1[1] * d[0]
        p2 = v2[0] * d[1] - v2[1] * d[0]
        r = h0 * abs(d[1]) + h1 * abs(d[0])
        nn = d[0] * d[0] + d[1] * d[1]
        if nn > 1e-24:
            g = max(g, _interval_gap(p0, p1, p2, r) / math.sqrt(nn))
    return max(g, 0.0) * _SHRINK
