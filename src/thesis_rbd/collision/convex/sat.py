"""Separating-axis test between two convex polyhedra, edge pairs pruned on the Gauss map.

Two convex polyhedra overlap unless some axis separates them, and the candidates are the
normals of the faces of their Minkowski difference: face normals of A, face normals of B,
and cross products of an edge of A with an edge of B, but only for those edge pairs that
build a face of the Minkowski difference. An edge is an arc on the Gauss map (between the
normals of its two faces); edges of A and of B build a face exactly when A's arc and B's
negated arc cross (Gregorius, "The Separating Axis Test between Convex Polyhedra", GDC
2013). Of a box pair's 144 edge pairs a handful pass, and the test needs only signs of dot
products with the arcs' plane normals, which are gathered per face and edge beforehand.

The separation along a candidate is how far B lies beyond A along it (negative: overlap);
the largest over all candidates is positive exactly when the hulls are apart, and otherwise
minus the penetration depth, attained on the axis of least penetration.

Everything here works in A's hull frame, with B's vertices, planes and arcs already placed
there (``place_hull``).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "EDGES",
    "FACE_A",
    "FACE_B",
    "PARALLEL_SINE",
    "axis_separation",
    "edge_pair_separation",
    "face_separation",
    "place_hull",
    "sat_query",
]

# Kinds of separating axis / contact feature
FACE_A = 1
FACE_B = 2
EDGES = 3
# Edges closer to parallel than this (sine of their angle) give no axis of their own: their
# Minkowski face is a face of one hull, already a candidate.
PARALLEL_SINE = 1e-9


@njit
def place_hull(vertices, planes, arcs, R, t, out_vertices, out_planes, out_arcs):
    """Vertices (v, 3), face planes (f, 4) and edge arcs (e, 3) of a hull mapped by x -> R x + t.

    Writes the first v, f and e rows of ``out_vertices``, ``out_planes``, ``out_arcs``.
    """
    for k in range(vertices.shape[0]):
        x, y, z = vertices[k, 0], vertices[k, 1], vertices[k, 2]
        for a in range(3):
            out_vertices[k, a] = R[a, 0] * x + R[a, 1] * y + R[a, 2] * z + t[a]
    for k in range(planes.shape[0]):
        x, y, z = planes[k, 0], planes[k, 1], planes[k, 2]
        d = planes[k, 3]
        for a in range(3):
            n = R[a, 0] * x + R[a, 1] * y + R[a, 2] * z
            out_planes[k, a] = n
            d += n * t[a]
        out_planes[k, 3] = d
    for k in range(arcs.shape[0]):
        x, y, z = arcs[k, 0], arcs[k, 1], arcs[k, 2]
        for a in range(3):
            out_arcs[k, a] = R[a, 0] * x + R[a, 1] * y + R[a, 2] * z


@njit
def face_separation(planes, f, vertices, count):
    """How far the first ``count`` rows of ``vertices`` (k, 3) lie beyond face f's plane:
    min over them of n.x - d."""
    nx, ny, nz, d = planes[f, 0], planes[f, 1], planes[f, 2], planes[f, 3]
    lowest = np.inf
    for v in range(count):
        s = nx * vertices[v, 0] + ny * vertices[v, 1] + nz * vertices[v, 2]
        if s < lowest:
            lowest = s
    return lowest - d


@njit
def axis_separation(vertices_a, count_a, vertices_b, count_b, ux, uy, uz):
    """How far B lies beyond A along the unit axis u (negative: their extents overlap):
    min over B's first ``count_b`` vertices of u.x less max over A's first ``count_a``."""
    highest_a, lowest_b = -np.inf, np.inf
    for v in range(count_a):
        highest_a = max(
            highest_a, ux * vertices_a[v, 0] + uy * vertices_a[v, 1] + uz * vertices_a[v, 2]
        )
    for v in range(count_b):
        lowest_b = min(
            lowest_b, ux * vertices_b[v, 0] + uy * vertices_b[v, 1] + uz * vertices_b[v, 2]
        )
    return lowest_b - highest_a


@njit
def _face_query(planes, vertices, count, margin):
    """(largest separation, its face) over all faces of ``planes`` against ``vertices``;
    returns at the first face separating by more than ``margin``."""
    best, best_face = -np.inf, -1
    for f in range(planes.shape[0]):
        s = face_separation(planes, f, vertices, count)
        if s > best:
            best, best_face = s, f
            if s > margin:
                break
    return best, best_face


@njit
def edge_pair_separation(vertices_a, edges_a, ea, centroid_a, vertices_b, edges_b, eb, above):
    """Separation of B beyond A along the cross product of edge ea of A and edge eb of B.

    The axis points away from A's centroid. Returns (separation, ux, uy, uz), or -inf when
    the edges are parallel or the separation is not above ``above`` (< 0), which is decided
    without a square root. Meaningful only for pairs that build a Minkowski face.
    """
    ta, ha = edges_a[ea, 0], edges_a[ea, 1]
    tb, hb = edges_b[eb, 0], edges_b[eb, 1]
    ax = vertices_a[ha, 0] - vertices_a[ta, 0]
    ay = vertices_a[ha, 1] - vertices_a[ta, 1]
    az = vertices_a[ha, 2] - vertices_a[ta, 2]
    bx = vertices_b[hb, 0] - vertices_b[tb, 0]
    by = vertices_b[hb, 1] - vertices_b[tb, 1]
    bz = vertices_b[hb, 2] - vertices_b[tb, 2]
    ux = ay * bz - az * by
    uy = az * bx - ax * bz
    uz = ax * by - ay * bx
    length2 = ux * ux + uy * uy + uz * uz
    if length2 <= PARALLEL_SINE**2 * (ax * ax + ay * ay + az * az) * (bx * bx + by * by + bz * bz):
        return -np.inf, 0.0, 0.0, 0.0
    px, py, pz = vertices_a[ta, 0], vertices_a[ta, 1], vertices_a[ta, 2]
    if ux * (px - centroid_a[0]) + uy * (py - centroid_a[1]) + uz * (pz - centroid_a[2]) < 0.0:
        ux, uy, uz = -ux, -uy, -uz
    raw = (
        ux * (vertices_b[tb, 0] - px)
        + uy * (vertices_b[tb, 1] - py)
        + uz * (vertices_b[tb, 2] - pz)
    )
    # raw / |u| > above (< 0): true for raw >= 0, else when raw^2 < above^2 |u|^2
    if raw < 0.0 and raw * raw >= above * above * length2:
        return -np.inf, 0.0, 0.0, 0.0
    length = math.sqrt(length2)
    return raw / length, ux / length, uy / length, uz / length


@njit
def _arc_signs(planes, face_count, arcs, edge_count, out, by_edge):
    """Face normals dotted with arc normals: out[f, e], or out[e, f] with ``by_edge``."""
    for f in range(face_count):
        nx, ny, nz = planes[f, 0], planes[f, 1], planes[f, 2]
        for e in range(edge_count):
            s = nx * arcs[e, 0] + ny * arcs[e, 1] + nz * arcs[e, 2]
            if by_edge:
                out[e, f] = s
            else:
                out[f, e] = s


@njit(separate=True)
def sat_query(
    vertices_a, planes_a, edges_a, faces_a, arcs_a, centroid_a,
    vertices_b, planes_b, edges_b, faces_b, arcs_b,
    cached_kind, cached_i, cached_j, tie, margin, signs_a, signs_b,
):  # fmt: skip
    """Separating-axis test of hull A against hull B, both in A's frame.

    Parameters
    ----------
    vertices_a, planes_a, edges_a, faces_a, arcs_a : A's hull arrays (v, 3) (f, 4) (e, 2)
        (e, 2) (e, 3), and centroid_a (3,)
    vertices_b, planes_b, edges_b, faces_b, arcs_b : B's, placed in A's frame
    cached_kind, cached_i, cached_j : int
        The axis that separated or gave the contact last time (``FACE_A`` i, ``FACE_B`` i,
        ``EDGES`` i j, or 0 for none): tested first, since it usually separates again.
    tie : float
        Separations closer than this count as equal: a face of A wins over a face of B and a
        face over an edge pair unless beaten by more, so round-off does not flip features.
    margin : float
        Separations up to this (>= 0) are wanted: an axis separating by more ends the test
        at once, one separating by less does not, so that for a pair within the margin the
        greatest separation over all candidates is found.
    signs_a, signs_b : (>= f_a, >= e_b) and (>= e_a, >= f_b) float64 scratch

    Returns
    -------
    kind, i, j : int
        Axis: ``FACE_A`` (face i of A), ``FACE_B`` (face i of B) or ``EDGES`` (edge i of
        A with edge j of B).
    separation : float
        > 0: the hulls are apart along it (the greatest separation if at most ``margin``);
        <= 0: minus the penetration depth.
    ux, uy, uz : float
        The axis, pointing from A towards B (A's frame).
    """
    va, vb = vertices_a.shape[0], vertices_b.shape[0]
    if cached_kind == FACE_A and cached_i < planes_a.shape[0]:
        s = face_separation(planes_a, cached_i, vertices_b, vb)
        if s > margin:
            return FACE_A, cached_i, 0, s, planes_a[cached_i, 0], planes_a[cached_i, 1], \
                planes_a[cached_i, 2]  # fmt: skip
    elif cached_kind == FACE_B and cached_i < planes_b.shape[0]:
        s = face_separation(planes_b, cached_i, vertices_a, va)
        if s > margin:
            return FACE_B, cached_i, 0, s, -planes_b[cached_i, 0], -planes_b[cached_i, 1], \
                -planes_b[cached_i, 2]  # fmt: skip
    elif cached_kind == EDGES and cached_i < edges_a.shape[0] and cached_j < edges_b.shape[0]:
        s, ux, uy, uz = edge_pair_separation(
            vertices_a, edges_a, cached_i, centroid_a, vertices_b, edges_b, cached_j, -np.inf
        )
        # The two edges' own distance along their axis is the hulls' separation only while
        # they build a Minkowski face, which the last step's pose no longer guarantees: two
        # boxes 0.4 deep into each other kept a cached edge pair 'apart' for 30 steps of a
        # poured pile. The hulls' separation along the axis decides.
        if s > margin:
            s = axis_separation(vertices_a, va, vertices_b, vb, ux, uy, uz)
            if s > margin:
                return EDGES, cached_i, cached_j, s, ux, uy, uz

    sep_a, face_a = _face_query(planes_a, vertices_b, vb, margin)
    if sep_a > margin:
        return FACE_A, face_a, 0, sep_a, planes_a[face_a, 0], planes_a[face_a, 1], \
            planes_a[face_a, 2]  # fmt: skip
    sep_b, face_b = _face_query(planes_b, vertices_a, va, margin)
    if sep_b > margin:
        return FACE_B, face_b, 0, sep_b, -planes_b[face_b, 0], -planes_b[face_b, 1], \
            -planes_b[face_b, 2]  # fmt: skip

    # Edge pairs, pruned on the Gauss map: edge i of A and edge j of B build a Minkowski
    # face when A's arc and B's negated arc cross: B's arc ends (the normals of B's faces
    # beside j) lie on both sides of A's arc plane, A's arc ends on both sides of B's, and
    # on the same hemisphere. signs_b[i, g] is A's arc normal i . B's face normal g,
    # signs_a[f, j] A's face normal f . B's arc normal j.
    ea_count, eb_count = edges_a.shape[0], edges_b.shape[0]
    _arc_signs(planes_a, planes_a.shape[0], arcs_b, eb_count, signs_a, False)
    _arc_signs(planes_b, planes_b.shape[0], arcs_a, ea_count, signs_b, True)
    sep_e, edge_a, edge_b = -np.inf, -1, -1
    ex = ey = ez = 0.0
    for i in range(ea_count):
        across = signs_b[i]
        beside_first = signs_a[faces_a[i, 0]]
        beside_second = signs_a[faces_a[i, 1]]
        for j in range(eb_count):
            s1 = across[faces_b[j, 0]]
            s2 = across[faces_b[j, 1]]
            s4 = beside_second[j]
            # one branch for the three tests: most pairs fail, and unpredictably
            if (s1 * s2 < 0.0) & (beside_first[j] * s4 < 0.0) & (s1 * s4 < 0.0):
                s, ux, uy, uz = edge_pair_separation(
                    vertices_a, edges_a, i, centroid_a, vertices_b, edges_b, j, sep_e
                )
                if s > sep_e:
                    sep_e, edge_a, edge_b, ex, ey, ez = s, i, j, ux, uy, uz
                    if s > margin:
                        return EDGES, i, j, s, ux, uy, uz

    if sep_b > sep_a + tie:
        kind, index, face_sep = FACE_B, face_b, sep_b
        fx, fy, fz = -planes_b[face_b, 0], -planes_b[face_b, 1], -planes_b[face_b, 2]
    else:
        kind, index, face_sep = FACE_A, face_a, sep_a
        fx, fy, fz = planes_a[face_a, 0], planes_a[face_a, 1], planes_a[face_a, 2]
    if sep_e > face_sep + tie:
        return EDGES, edge_a, edge_b, sep_e, ex, ey, ez
    return kind, index, 0, face_sep, fx, fy, fz
