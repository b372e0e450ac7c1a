"""Contact manifolds of two convex polyhedra: clip the incident face, keep four points.

For a face contact the reference face is the face whose normal is the contact axis; the
incident face is the other hull's face most opposed to it. The incident polygon is clipped
(Sutherland-Hodgman) against the side planes of the reference face, one per reference edge,
and, if the two faces are within 0.01 rad of parallel, against the reference plane itself
lifted by the speculative margin, which leaves the part of the incident face that lies over
the reference face and below the lifted plane: the contact polygon, whose corners above the
reference plane are speculative contacts (negative depth, a gap that may close). A tilted
incident face keeps only its corners below the lifted plane (a vertex pressed into a face
is one contact, at the vertex). Each of its corners is an
incident vertex or the crossing of an incident edge (or an earlier clip line) with a clip
plane, and is tagged so: the tag, with the two faces, names the corner's features, and stays
the same from step to step while they do.

Of more than four corners, four are kept: the deepest one, and the three that with it span
the largest area (exact, by dynamic programming over the fan from the deepest corner: the
quadrilateral's area is two fan triangles sharing a middle corner). Depth matters for the
penetration, area for a stable support. Corners tied for deepest (faces pressed flat on each
other, to a tolerance the caller gives) are each tried as the deepest, and the largest area
wins.

An edge-edge contact is one point, midway between the closest points of the two edges.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "DEEPEST_VERTEX_TAG",
    "PARALLEL_COSINE",
    "TAG_BITS",
    "clip_incident_face",
    "edge_contact_point",
    "emit_face_contacts",
    "feature_id",
    "four_corners",
]

# A corner's tag: an incident vertex k is k; the crossing of the edge labelled L with clip
# plane e is (1 + e) * 1024 + L, where an incident edge k is labelled k and reference side e'
# is 512 + e'. Unique while faces have fewer than 512 sides; masked to TAG_BITS bits.
TAG_BITS = 21
_SIDE_LABEL = 512
_LABEL_MASK = 511
_TAG_MASK = (1 << TAG_BITS) - 1
# Incident faces this close to parallel with the reference face (cosine) are clipped at the
# reference plane too; tilted ones keep only their corners below it
PARALLEL_COSINE = math.cos(1e-2)
# Clip tag of a contact at the incident hull's deepest vertex (no incident corner below)
DEEPEST_VERTEX_TAG = _TAG_MASK
_FACE_BITS = 20
_FACE_MASK = (1 << _FACE_BITS) - 1


@njit(allocates=False)
def feature_id(kind, first, second, tag):
    """Feature id of a contact: kind (2 bits), two face or edge indices (20 bits each), tag."""
    return (
        (np.int64(kind) << 61)
        | ((np.int64(first) & _FACE_MASK) << 41)
        | ((np.int64(second) & _FACE_MASK) << 21)
        | np.int64(tag)
    )


@njit(allocates=False)
def _clip(src, src_tag, src_label, count, distance, plane, dst, dst_tag, dst_label):
    """Keep the part of polygon ``src`` (first ``count`` rows) whose signed ``distance`` from
    the clip plane is <= 0; returns the new count. A crossing point's label is the clip
    plane's when the polygon runs along it from there."""
    out = 0
    plane_label = _SIDE_LABEL + (plane & _LABEL_MASK)
    for k in range(count):
        q = k + 1 if k + 1 < count else 0
        dp = distance[k]
        dq = distance[q]
        if dp <= 0.0:
            dst[out, 0], dst[out, 1], dst[out, 2] = src[k, 0], src[k, 1], src[k, 2]
            dst_tag[out] = src_tag[k]
            dst_label[out] = src_label[k] if (dq <= 0.0 or dp < 0.0) else plane_label
            out += 1
        if (dp < 0.0 and dq > 0.0) or (dp > 0.0 and dq < 0.0):
            s = dp / (dp - dq)
            for a in range(3):
                dst[out, a] = src[k, a] + s * (src[q, a] - src[k, a])
            dst_tag[out] = ((1 + plane) * 1024 + src_label[k]) & _TAG_MASK
            dst_label[out] = plane_label if dp < 0.0 else src_label[k]
            out += 1
    return out


@njit(allocates=False, separate=True)
def clip_incident_face(
    reference, reference_count, nx, ny, nz, d, incident, incident_count, parallel, margin,
    tolerance, points, tags, spare, spare_tags, labels, spare_labels, distance,
):  # fmt: skip
    """The part of the incident polygon over the reference face and below its plane
    lifted by ``margin``.

    Nearly ``parallel`` faces are clipped at the lifted reference plane too, so the polygon
    keeps its corners where the incident face comes within the margin of the plane; a tilted
    incident face keeps only its corners at or below the lifted plane (a vertex pressed into
    a face is one point, not the vertex and two crossings of its face's edges, which would
    spin a ball landing on it). The margin makes faces a small gap apart (or touching, their
    corners a round-off above the plane) clip as faces pressed together do. Distances within
    ``tolerance`` of a clip plane count as on it, so faces flush with a side of the
    reference face keep their corners.

    Parameters
    ----------
    reference : (>= k, 3) float64
        The reference face's corners, counter-clockwise seen along its outward normal
        (nx, ny, nz); its plane is n.x = d.
    margin : float
        How far above the reference plane (>= 0) the incident face is kept.
    incident : (>= m, 3) float64
        The incident face's corners, in loop order.
    points, spare : (>= m + k + 1, 3) float64 scratch; tags, spare_tags, labels,
        spare_labels : (>= m + k + 1,) int64 scratch; distance : (>= m + k + 1,) float64
        scratch

    Returns
    -------
    count : int
        The contact polygon is ``points[:count]`` with ``tags[:count]`` (see ``TAG_BITS``).
    """
    for k in range(incident_count):
        points[k, 0], points[k, 1], points[k, 2] = incident[k, 0], incident[k, 1], incident[k, 2]
        tags[k] = k & _TAG_MASK
        labels[k] = k & _LABEL_MASK
    count = incident_count
    src, src_tag, src_label = points, tags, labels
    dst, dst_tag, dst_label = spare, spare_tags, spare_labels
    for e in range(reference_count + 1):
        if e < reference_count:
            q = e + 1 if e + 1 < reference_count else 0
            ex = reference[q, 0] - reference[e, 0]
            ey = reference[q, 1] - reference[e, 1]
            ez = reference[q, 2] - reference[e, 2]
            # outward side normal: edge x face normal
            sx, sy, sz = ey * nz - ez * ny, ez * nx - ex * nz, ex * ny - ey * nx
            length = math.sqrt(sx * sx + sy * sy + sz * sz)
            if length == 0.0:
                continue
            sx, sy, sz = sx / length, sy / length, sz / length
            sd = sx * reference[e, 0] + sy * reference[e, 1] + sz * reference[e, 2]
        elif parallel:
            sx, sy, sz, sd = nx, ny, nz, d + margin
        else:
            break
        # a plane with every corner inside (the reference face's far sides, for a small
        # incident face on a large reference face) changes nothing
        outside = False
        for k in range(count):
            gap = sx * src[k, 0] + sy * src[k, 1] + sz * src[k, 2] - sd
            distance[k] = 0.0 if abs(gap) <= tolerance else gap
            outside |= distance[k] > 0.0
        if not outside:
            continue
        count = _clip(src, src_tag, src_label, count, distance, e, dst, dst_tag, dst_label)
        src, dst = dst, src
        src_tag, dst_tag = dst_tag, src_tag
        src_label, dst_label = dst_label, src_label
        if count == 0:
            break
    kept = 0
    for k in range(count):
        gap = nx * src[k, 0] + ny * src[k, 1] + nz * src[k, 2] - d
        if not parallel and gap > margin + tolerance:
            continue
        points[kept, 0], points[kept, 1], points[kept, 2] = src[k, 0], src[k, 1], src[k, 2]
        tags[kept] = src_tag[k]
        kept += 1
    return kept


@njit(allocates=False)
def _fan_area(points, o, i, j, nx, ny, nz):
    """Signed area of triangle (o, i, j) of ``points`` seen along (nx, ny, nz), doubled."""
    ax = points[i, 0] - points[o, 0]
    ay = points[i, 1] - points[o, 1]
    az = points[i, 2] - points[o, 2]
    bx = points[j, 0] - points[o, 0]
    by = points[j, 1] - points[o, 1]
    bz = points[j, 2] - points[o, 2]
    return nx * (ay * bz - az * by) + ny * (az * bx - ax * bz) + nz * (ax * by - ay * bx)


@njit(allocates=False)
def _best_quad_from(points, count, first, sign, nx, ny, nz):
    """Largest doubled area of a quadrilateral of polygon corners that includes corner
    ``first``, and its other three corners (offsets from ``first`` along the loop).

    The quadrilateral (first, i, j, l) with i < j < l in loop order is the fan triangles
    (first, i, j) and (first, j, l): for each middle corner j the best i and the best l are
    found independently.
    """
    best, best_i, best_j, best_l = -np.inf, 1, 2, 3
    for j in range(2, count - 1):
        cj = (first + j) % count
        left, left_i = -np.inf, 1
        for i in range(1, j):
            a = sign * _fan_area(points, first, (first + i) % count, cj, nx, ny, nz)
            if a > left:
                left, left_i = a, i
        right, right_l = -np.inf, j + 1
        for m in range(j + 1, count):
            a = sign * _fan_area(points, first, cj, (first + m) % count, nx, ny, nz)
            if a > right:
                right, right_l = a, m
        if left + right > best:
            best, best_i, best_j, best_l = left + right, left_i, j, right_l
    return best, best_i, best_j, best_l


# Of corners tied for deepest, at most this many are tried as the kept deepest corner
_TIED_TRIES = 8


@njit(allocates=False, separate=True)
def four_corners(points, depths, count, nx, ny, nz, tie, keep):
    """At most four corners of a convex polygon: the deepest and the largest-area three more.

    Parameters
    ----------
    points : (>= count, 3) float64
        Polygon corners in loop order.
    depths : (>= count,) float64
    nx, ny, nz : float
        The polygon's normal, either way round.
    tie : float
        Corners less deep than the deepest by at most this are as deep: the one of them
        that allows the largest area is kept (faces pressed flat on each other are all
        equally deep).
    keep : (4,) int64
        Receives the indices kept, in loop order starting at the deepest.

    Returns
    -------
    int
        How many were kept (min(count, 4)).
    """
    deepest = 0
    for k in range(1, count):
        if depths[k] > depths[deepest]:
            deepest = k
    if count <= 4:
        for k in range(count):
            keep[k] = (deepest + k) % count
        return count
    # the polygon's orientation is unknown: areas take the sign of the whole fan
    sign = 0.0
    for k in range(1, count - 1):
        sign += _fan_area(points, 0, k, k + 1, nx, ny, nz)
    sign = 1.0 if sign >= 0.0 else -1.0
    tied = 0
    for k in range(count):
        if depths[k] >= depths[deepest] - tie:
            tied += 1
    stride = max(1, tied // _TIED_TRIES)
    best, seen = -np.inf, 0
    for k in range(count):
        if depths[k] < depths[deepest] - tie:
            continue
        seen += 1
        if (seen - 1) % stride != 0 and k != deepest:
            continue
        area, i, j, m = _best_quad_from(points, count, k, sign, nx, ny, nz)
        if area > best:
            best = area
            keep[0] = k
            keep[1] = (k + i) % count
            keep[2] = (k + j) % count
            keep[3] = (k + m) % count
    return 4


@njit(allocates=False)
def edge_contact_point(pa, qa, pb, qb):
    """Midpoint of the closest points of segments pa-qa and pb-qb, each (3,).

    Returns (x, y, z, gap2): the midpoint and the squared distance between the closest
    points. Closest points of the two lines, clamped to the segments (Ericson, Real-Time
    Collision Detection, 5.1.9).
    """
    d1x, d1y, d1z = qa[0] - pa[0], qa[1] - pa[1], qa[2] - pa[2]
    d2x, d2y, d2z = qb[0] - pb[0], qb[1] - pb[1], qb[2] - pb[2]
    rx, ry, rz = pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denominator = a * e - b * b
    s = min(max((b * f - c * e) / denominator, 0.0), 1.0) if denominator > 0.0 else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    ux, uy, uz = pa[0] + s * d1x, pa[1] + s * d1y, pa[2] + s * d1z
    vx, vy, vz = pb[0] + t * d2x, pb[1] + t * d2y, pb[2] + t * d2z
    gap2 = (ux - vx) ** 2 + (uy - vy) ** 2 + (uz - vz) ** 2
    return 0.5 * (ux + vx), 0.5 * (uy + vy), 0.5 * (uz + vz), gap2


@njit(allocates=False, separate=True)
def emit_face_contacts(
    points, tags, depths, count, nx, ny, nz, d, kind, reference_face, incident_face,
    tolerance, flat, keep, Ri, ti, out_points, out_depths, out_features, c,
):  # fmt: skip
    """A face contact's corners ``points[:count]`` (tags ``tags``, the reference frame A's)
    written out from row c: repeats dropped, at most four kept (``four_corners``, corners
    within ``flat`` of the deepest as deep), in the order of their feature ids, each midway
    between the surfaces and mapped into the world by (Ri, ti); returns how many.

    The reference plane is n.x = d; a corner's depth is how far it lies below it.
    ``depths`` (>= count,) and ``keep`` (4,) are scratch.
    """
    # drop corners that repeat their predecessor (a vertex on a clip plane)
    kept = 0
    for q in range(count):
        if kept > 0:
            gap = (
                abs(points[q, 0] - points[kept - 1, 0])
                + abs(points[q, 1] - points[kept - 1, 1])
                + abs(points[q, 2] - points[kept - 1, 2])
            )
            if gap <= tolerance:
                continue
        points[kept, 0], points[kept, 1], points[kept, 2] = (
            points[q, 0],
            points[q, 1],
            points[q, 2],
        )
        tags[kept] = tags[q]
        kept += 1
    while kept > 1 and (
        abs(points[kept - 1, 0] - points[0, 0])
        + abs(points[kept - 1, 1] - points[0, 1])
        + abs(points[kept - 1, 2] - points[0, 2])
        <= tolerance
    ):
        kept -= 1
    for q in range(kept):
        depths[q] = d - (nx * points[q, 0] + ny * points[q, 1] + nz * points[q, 2])
    n_keep = four_corners(points, depths, kept, nx, ny, nz, flat, keep)
    # Out in the order of their feature ids, not from the deepest corner on: which corner of
    # a flat face is deepest is decided by rounding, and the contact solver sweeps contacts
    # in order, so the same contacts must come out in the same order (the same stack placed
    # far from the origin then steps as at the origin, up to rounding).
    for r in range(1, n_keep):
        q = keep[r]
        s = r
        while s > 0 and tags[keep[s - 1]] > tags[q]:
            keep[s] = keep[s - 1]
            s -= 1
        keep[s] = q
    for r in range(n_keep):
        q = keep[r]
        half = 0.5 * depths[q]
        px = points[q, 0] + half * nx
        py = points[q, 1] + half * ny
        pz = points[q, 2] + half * nz
        for a in range(3):
            out_points[c + r, a] = Ri[a, 0] * px + Ri[a, 1] * py + Ri[a, 2] * pz + ti[a]
        out_depths[c + r] = depths[q]
        out_features[c + r] = feature_id(kind, reference_face, incident_face, tags[q])
    return n_keep
