"""Boxes among the convex hulls: the separating-axis test of two boxes in closed form.

A box pair has 15 candidate axes (three face normals each, nine edge-direction cross
products), and each axis's separation follows from the boxes' half extents and the cosines
between their axes (Gottschalk's OBB test, here giving the separation instead of a yes/no):
no vertex is visited, no edge pair pruned. The answer is the general test's (``sat_query``):
the same kind of axis, the same hull face or edge indices, and the same separation up to
round-off. A face contact of two boxes (``box_face_contacts``) reads the reference and
incident faces off the box frames instead of searching the hulls, and clips them as the
general face manifold does. A hull is a box when it has 8 vertices and 6 faces in three
antiparallel pairs with mutually perpendicular normals, every vertex a corner of the box
the faces bound.

Per hull, ``box_frames`` (h, 5, 3) holds the unit axes (rows 0-2: the outward normals of the
box's +x, +y, +z faces), the centre (row 3) and the half extents (row 4), in the mesh frame;
``box_features`` (h, 18) int64 holds the hull face index of each face, ``[2 k + s]`` for the
face whose outward normal is (2 s - 1) times axis k, then the hull edge index of each edge,
``[6 + 4 k + 2 s1 + s2]`` for the edge along axis k on the side s1 of axis k + 1 and s2 of
axis k + 2 (mod 3); -1 everywhere for a hull that is not a box.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.convex.manifold import (
    DEEPEST_VERTEX_TAG,
    PARALLEL_COSINE,
    clip_incident_face,
    emit_face_contacts,
)
from thesis_rbd.collision.convex.sat import EDGES, FACE_A, FACE_B, PARALLEL_SINE

__all__ = ["box_box_query", "box_face_contacts", "box_frame"]

# Normals this close to antiparallel or perpendicular (|cosine| off by at most this), and
# vertices this close to the box's corners (relative to the size), make a hull a box: the
# closed form is then exact to round-off for the polyhedron the hull is.
_BOX_TOLERANCE = 1e-12
# The corners of a box face, counter-clockwise seen along its axis k from outside when
# (alpha, beta) multiply the half extents along axes k + 1 and k + 2
_ALPHA = (1.0, -1.0, -1.0, 1.0)
_BETA = (1.0, 1.0, -1.0, -1.0)


def box_frame(vertices, planes, edges, size) -> tuple[np.ndarray, np.ndarray] | None:
    """(frame (5, 3), features (18,)) of a hull that is a box (see the module docstring);
    None for any other hull.

    Parameters
    ----------
    vertices : (v, 3) float64, planes : (f, 4) float64, edges : (e, 2) int64
        The hull's vertices, face planes n.x = d and edges, mesh frame.
    size : float
        The hull's size, which the tolerance scales with.
    """
    if len(vertices) != 8 or len(planes) != 6 or len(edges) != 12:
        return None
    normals = planes[:, :3]
    opposite = np.argmin(normals @ normals.T, axis=1)
    if np.any(opposite[opposite] != np.arange(6)):
        return None
    frame = np.zeros((5, 3))
    features = np.full(18, -1, np.int64)
    plus = []
    for face in range(6):
        if face < opposite[face]:
            plus.append(face)
    if len(plus) != 3:
        return None
    for k, face in enumerate(plus):
        back = opposite[face]
        if normals[face] @ normals[back] > -1.0 + _BOX_TOLERANCE:
            return None
        frame[k] = normals[face]
        # the face planes n.x = d_plus and -n.x = d_minus bound the box along n
        d_plus, d_minus = planes[face, 3], planes[back, 3]
        frame[3] += normals[face] * 0.5 * (d_plus - d_minus)
        frame[4, k] = 0.5 * (d_plus + d_minus)
        features[2 * k + 1], features[2 * k] = face, back
    axes = frame[:3]
    if np.abs(axes @ axes.T - np.eye(3)).max() > _BOX_TOLERANCE:
        return None
    if np.linalg.det(axes) < 0:
        # a right-handed frame (the edge axes' formulas assume one): the third axis the
        # other way round, its two faces swapped
        frame[2] = -frame[2]
        features[4], features[5] = features[5], features[4]
    local = (vertices - frame[3]) @ axes.T
    signs = local > 0
    corners = np.where(signs, frame[4], -frame[4])
    if np.abs(local - corners).max() > _BOX_TOLERANCE * size:
        return None
    for e, (tail, head) in enumerate(edges):
        along = np.flatnonzero(signs[tail] != signs[head])
        if len(along) != 1:
            return None
        k = int(along[0])
        s1, s2 = signs[tail, (k + 1) % 3], signs[tail, (k + 2) % 3]
        features[6 + 4 * k + 2 * s1 + s2] = e
    if np.any(features < 0):
        return None
    return frame, features


@njit(allocates=False, separate=True)
def box_box_query(frames, features, ha, hb, R, t, tie):
    """Separating-axis test of box hulls ha and hb in closed form, in A's hull frame.

    Parameters
    ----------
    frames, features : ``HullSet.box_frames`` (h, 5, 3) and ``box_features`` (h, 18)
    ha, hb : int
        Two hulls that are boxes.
    R, t : (3, 3), (3,) float64
        B's hull frame in A's: x_A = R x_B + t.
    tie : float
        As ``sat_query``'s: a face of A wins over a face of B, and a face over an edge
        pair, unless beaten by more than ``tie``. All 15 axes are always tried, so the
        separation is the greatest at any distance (``sat_query`` stops at the first axis
        beyond its margin).

    Returns
    -------
    kind, i, j, separation, ux, uy, uz
        As ``sat_query``: hull face i of A (``FACE_A``) or of B (``FACE_B``), or hull edges
        i of A and j of B (``EDGES``); the separation along the axis (u, from A towards
        B, A's frame).
    """
    # Everything in A's box coordinates: C[3 k + j] is the cosine between A's axis k and
    # B's axis j, D[k] B's centre less A's along A's axis k. Tuples, not arrays: they stay
    # in registers (a per-pair array costs an allocation and reference counting).
    B = _rotated_axes(frames, hb, R)
    C = (
        _dot_row(frames, ha, 0, B[0], B[1], B[2]), _dot_row(frames, ha, 0, B[3], B[4], B[5]),
        _dot_row(frames, ha, 0, B[6], B[7], B[8]), _dot_row(frames, ha, 1, B[0], B[1], B[2]),
        _dot_row(frames, ha, 1, B[3], B[4], B[5]), _dot_row(frames, ha, 1, B[6], B[7], B[8]),
        _dot_row(frames, ha, 2, B[0], B[1], B[2]), _dot_row(frames, ha, 2, B[3], B[4], B[5]),
        _dot_row(frames, ha, 2, B[6], B[7], B[8]),
    )  # fmt: skip
    gx = R[0, 0] * frames[hb, 3, 0] + R[0, 1] * frames[hb, 3, 1] + R[0, 2] * frames[hb, 3, 2]
    gy = R[1, 0] * frames[hb, 3, 0] + R[1, 1] * frames[hb, 3, 1] + R[1, 2] * frames[hb, 3, 2]
    gz = R[2, 0] * frames[hb, 3, 0] + R[2, 1] * frames[hb, 3, 1] + R[2, 2] * frames[hb, 3, 2]
    gx += t[0] - frames[ha, 3, 0]
    gy += t[1] - frames[ha, 3, 1]
    gz += t[2] - frames[ha, 3, 2]
    D = (
        _dot_row(frames, ha, 0, gx, gy, gz),
        _dot_row(frames, ha, 1, gx, gy, gz),
        _dot_row(frames, ha, 2, gx, gy, gz),
    )
    ea = (frames[ha, 4, 0], frames[ha, 4, 1], frames[ha, 4, 2])
    eb = (frames[hb, 4, 0], frames[hb, 4, 1], frames[hb, 4, 2])

    # faces of A: how far B's extent along axis k lies beyond A's face on B's side
    sep_a, face_a, sign_a = -np.inf, 0, 1.0
    for k in range(3):
        s = (
            abs(D[k])
            - ea[k]
            - (eb[0] * abs(C[3 * k]) + eb[1] * abs(C[3 * k + 1]) + eb[2] * abs(C[3 * k + 2]))
        )
        if s > sep_a:
            sep_a, face_a, sign_a = s, k, 1.0 if D[k] >= 0.0 else -1.0
    # faces of B: A's extent along B's axis j beyond B's face on A's side
    sep_b, face_b, sign_b = -np.inf, 0, 1.0
    for j in range(3):
        along = -(C[j] * D[0] + C[3 + j] * D[1] + C[6 + j] * D[2])
        s = abs(along) - eb[j] - (ea[0] * abs(C[j]) + ea[1] * abs(C[3 + j]) + ea[2] * abs(C[6 + j]))
        if s > sep_b:
            sep_b, face_b, sign_b = s, j, 1.0 if along >= 0.0 else -1.0
    # edge pairs, A's axis k across B's axis j: L = e_k x C[:, j] in A's box coordinates,
    # whose components are cosines, and B's extent along it is (for orthonormal frames)
    # eb[j1] |C[k, j2]| + eb[j2] |C[k, j1]| (Gottschalk's OBB test)
    sep_e, edge_k, edge_j, edge_sign = -np.inf, 0, 0, 1.0
    for k in range(3):
        k1, k2 = (k + 1) % 3, (k + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            c1, c2 = C[3 * k1 + j], C[3 * k2 + j]
            length2 = c1 * c1 + c2 * c2
            if length2 <= PARALLEL_SINE**2:
                continue
            along = D[k2] * c1 - D[k1] * c2
            reach = ea[k1] * abs(c2) + ea[k2] * abs(c1)
            reach += eb[j1] * abs(C[3 * k + j2]) + eb[j2] * abs(C[3 * k + j1])
            s = (abs(along) - reach) / math.sqrt(length2)
            if s > sep_e:
                sep_e, edge_k, edge_j = s, k, j
                edge_sign = 1.0 if along >= 0.0 else -1.0

    if sep_b > sep_a + tie:
        face_sep = sep_b
        kind, index = FACE_B, features[hb, 2 * face_b + (1 if sign_b > 0.0 else 0)]
        # B's face towards A has outward normal sign_b b_j; the axis runs against it
        fx = -sign_b * B[3 * face_b]
        fy = -sign_b * B[3 * face_b + 1]
        fz = -sign_b * B[3 * face_b + 2]
    else:
        face_sep = sep_a
        kind, index = FACE_A, features[ha, 2 * face_a + (1 if sign_a > 0.0 else 0)]
        fx = sign_a * frames[ha, face_a, 0]
        fy = sign_a * frames[ha, face_a, 1]
        fz = sign_a * frames[ha, face_a, 2]
    if not sep_e > face_sep + tie:
        return kind, index, 0, face_sep, fx, fy, fz
    # the edge axis u (towards B): L's components on A's axes, signed
    k, j = edge_k, edge_j
    k1, k2, j1, j2 = (k + 1) % 3, (k + 2) % 3, (j + 1) % 3, (j + 2) % 3
    c1, c2 = C[3 * k1 + j], C[3 * k2 + j]
    scale = edge_sign / math.sqrt(c1 * c1 + c2 * c2)
    l1, l2 = -c2 * scale, c1 * scale
    ux = l1 * frames[ha, k1, 0] + l2 * frames[ha, k2, 0]
    uy = l1 * frames[ha, k1, 1] + l2 * frames[ha, k2, 1]
    uz = l1 * frames[ha, k1, 2] + l2 * frames[ha, k2, 2]
    # the edges that meet along it: A's supporting edge along +u, B's along -u
    edge_a = features[ha, 6 + 4 * k + 2 * (l1 > 0.0) + (l2 > 0.0)]
    # u . b_j1 = C[k, j2] and u . b_j2 = -C[k, j1], both times the scale
    b1, b2 = C[3 * k + j2] * scale < 0.0, C[3 * k + j1] * scale > 0.0
    edge_b = features[hb, 6 + 4 * j + 2 * b1 + b2]
    return EDGES, edge_a, edge_b, sep_e, ux, uy, uz


@njit(allocates=False)
def _rotated_axes(frames, h, R):
    """Box h's three axes turned by R, flattened: (x0, y0, z0, x1, ..., z2)."""
    return (
        R[0, 0] * frames[h, 0, 0] + R[0, 1] * frames[h, 0, 1] + R[0, 2] * frames[h, 0, 2],
        R[1, 0] * frames[h, 0, 0] + R[1, 1] * frames[h, 0, 1] + R[1, 2] * frames[h, 0, 2],
        R[2, 0] * frames[h, 0, 0] + R[2, 1] * frames[h, 0, 1] + R[2, 2] * frames[h, 0, 2],
        R[0, 0] * frames[h, 1, 0] + R[0, 1] * frames[h, 1, 1] + R[0, 2] * frames[h, 1, 2],
        R[1, 0] * frames[h, 1, 0] + R[1, 1] * frames[h, 1, 1] + R[1, 2] * frames[h, 1, 2],
        R[2, 0] * frames[h, 1, 0] + R[2, 1] * frames[h, 1, 1] + R[2, 2] * frames[h, 1, 2],
        R[0, 0] * frames[h, 2, 0] + R[0, 1] * frames[h, 2, 1] + R[0, 2] * frames[h, 2, 2],
        R[1, 0] * frames[h, 2, 0] + R[1, 1] * frames[h, 2, 1] + R[1, 2] * frames[h, 2, 2],
        R[2, 0] * frames[h, 2, 0] + R[2, 1] * frames[h, 2, 1] + R[2, 2] * frames[h, 2, 2],
    )


@njit(allocates=False)
def _dot_row(frames, h, k, x, y, z):
    """Box h's axis k dotted with (x, y, z)."""
    return frames[h, k, 0] * x + frames[h, k, 1] * y + frames[h, k, 2] * z


@njit(allocates=False)
def _axis(frames, h, m, R, turned):
    """Box h's axis m in A's frame: turned by R if h is B's (``turned``)."""
    x, y, z = frames[h, m, 0], frames[h, m, 1], frames[h, m, 2]
    if not turned:
        return x, y, z
    return (
        R[0, 0] * x + R[0, 1] * y + R[0, 2] * z,
        R[1, 0] * x + R[1, 1] * y + R[1, 2] * z,
        R[2, 0] * x + R[2, 1] * y + R[2, 2] * z,
    )


@njit(allocates=False)
def _centre(frames, h, R, t, turned):
    """Box h's centre in A's frame: placed by (R, t) if h is B's (``turned``)."""
    x, y, z = _axis(frames, h, 3, R, turned)
    if turned:
        return x + t[0], y + t[1], z + t[2]
    return x, y, z


@njit(allocates=False)
def _face_corners(frames, h, k, sign, R, t, turned, out):
    """The corners of box h's face along sign * axis k into ``out`` (4, 3), A's frame,
    counter-clockwise seen from outside; returns the face centre's offset along the
    face's normal (the plane n.x = d's d)."""
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    nx, ny, nz = _axis(frames, h, k, R, turned)
    ux, uy, uz = _axis(frames, h, k1, R, turned)
    vx, vy, vz = _axis(frames, h, k2, R, turned)
    cx, cy, cz = _centre(frames, h, R, t, turned)
    depth = sign * frames[h, 4, k]
    cx, cy, cz = cx + depth * nx, cy + depth * ny, cz + depth * nz
    eu, ev = frames[h, 4, k1], frames[h, 4, k2]
    for q in range(4):
        # seen from the other side the loop runs the other way
        r = q if sign > 0.0 else (4 - q) % 4
        a, b = _ALPHA[r] * eu, _BETA[r] * ev
        out[q, 0] = cx + a * ux + b * vx
        out[q, 1] = cy + a * uy + b * vy
        out[q, 2] = cz + a * uz + b * vz
    return sign * (nx * cx + ny * cy + nz * cz)


@njit(allocates=False, separate=True)
def box_face_contacts(
    frames, features, ha, hb, kind, face, R, t, margin, apart, tolerance, flat,
    reference, incident, points, tags, spare, spare_tags, labels, spare_labels, depths, keep,
    Ri, ti, out_points, out_depths, out_features, c,
):  # fmt: skip
    """Contacts of a face axis of two boxes into the outputs from row c (world frame);
    (their count, the reference normal in A's frame).

    The general face manifold (``contacts._face_manifold``: same arguments, same
    answers, the tags numbering the corners in box order), with the faces and the incident
    hull's deepest vertex read off the box frames instead of searched on the hulls.
    """
    own, other = (ha, hb) if kind == FACE_A else (hb, ha)
    own_turned = kind != FACE_A
    k, sign = 0, 1.0
    for m in range(6):
        if features[own, m] == face:
            k, sign = m // 2, 1.0 if m % 2 else -1.0
    nx, ny, nz = _axis(frames, own, k, R, own_turned)
    nx, ny, nz = sign * nx, sign * ny, sign * nz
    d = _face_corners(frames, own, k, sign, R, t, own_turned, reference)
    # the incident face: the other box's face most opposed to n
    best, j = -1.0, 0
    for m in range(3):
        x, y, z = _axis(frames, other, m, R, not own_turned)
        cosine = abs(x * nx + y * ny + z * nz)
        if cosine > best:
            best, j = cosine, m
    x, y, z = _axis(frames, other, j, R, not own_turned)
    incident_sign = -1.0 if x * nx + y * ny + z * nz > 0.0 else 1.0
    incident_face = features[other, 2 * j + (1 if incident_sign > 0.0 else 0)]
    _face_corners(frames, other, j, incident_sign, R, t, not own_turned, incident)
    parallel = best >= PARALLEL_COSINE
    count = _lying_inside(
        frames, own, k, R, t, own_turned, nx, ny, nz, d, incident, parallel, margin, tolerance,
        points, tags,
    )  # fmt: skip
    if count < 0:
        count = clip_incident_face(
            reference, 4, nx, ny, nz, d, incident, 4, parallel, margin, tolerance, points,
            tags, spare, spare_tags, labels, spare_labels, depths,
        )  # fmt: skip
    if count == 0:
        if apart:
            return 0, nx, ny, nz  # no speculative contact (see ``_face_manifold``)
        # the other box's deepest corner: against n along each of its axes
        count = 1
        tags[0] = DEEPEST_VERTEX_TAG
        px, py, pz = _centre(frames, other, R, t, not own_turned)
        for m in range(3):
            x, y, z = _axis(frames, other, m, R, not own_turned)
            reach = -frames[other, 4, m] if x * nx + y * ny + z * nz > 0.0 else frames[other, 4, m]
            px, py, pz = px + reach * x, py + reach * y, pz + reach * z
        points[0, 0], points[0, 1], points[0, 2] = px, py, pz
    n_keep = emit_face_contacts(
        points, tags, depths, count, nx, ny, nz, d, kind, face, incident_face, tolerance,
        flat, keep, Ri, ti, out_points, out_depths, out_features, c,
    )  # fmt: skip
    return n_keep, nx, ny, nz


@njit(allocates=False)
def _lying_inside(
    frames, h, k, R, t, turned, nx, ny, nz, d, incident, parallel, margin, tolerance, points,
    tags,
):  # fmt: skip
    """The contact polygon without clipping, where the incident face lies over the
    reference face (box h's face along axis k, normal n, plane n.x = d) and no clip plane
    cuts it: the common case of a box resting on a larger one. Its corners (tags 0-3, as
    ``clip_incident_face`` tags unclipped corners) into ``points``; their count, or -1
    where the general clip is needed (a corner beyond a side, or, for nearly parallel
    faces, above the plane lifted by ``margin``).
    """
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    ax, ay, az = _axis(frames, h, k1, R, turned)
    bx, by, bz = _axis(frames, h, k2, R, turned)
    cx, cy, cz = _centre(frames, h, R, t, turned)
    reach_a = frames[h, 4, k1] + tolerance
    reach_b = frames[h, 4, k2] + tolerance
    ceiling = margin + tolerance
    count = 0
    for q in range(4):
        x, y, z = incident[q, 0], incident[q, 1], incident[q, 2]
        if abs((x - cx) * ax + (y - cy) * ay + (z - cz) * az) > reach_a:
            return -1
        if abs((x - cx) * bx + (y - cy) * by + (z - cz) * bz) > reach_b:
            return -1
        if nx * x + ny * y + nz * z - d > ceiling:
            if parallel:
                return -1  # the lifted plane cuts the face: crossings to find
            continue  # a tilted face keeps only its corners below the lifted plane
        points[count, 0], points[count, 1], points[count, 2] = x, y, z
        tags[count] = q
        count += 1
    return count
