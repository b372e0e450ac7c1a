"""Contacts of convex body pairs: every candidate pair of a step in one kernel call.

Per pair, in A's hull frame (B placed there by the relative transform): the axis of least
penetration, from the separating-axis test (``sat.py``) for hulls with few edges or
GJK and EPA (``gjk.py``) for hulls with many; then the manifold (``manifold.py``):
clipped incident face and four corners for a face axis, one point for an edge pair (unless
the edge axis lies within 0.01 rad of a face beside the edges: a face hanging over another's
edge, nearly flat, then gets that face's manifold at the edge axis' exact normal and depth).
Contact points lie midway between the two surfaces; every contact of a pair reports the
pair's penetration depth (minus its gap, for a speculative pair), as the mesh path's contacts
report their region's: a resting face whose corners straddle the plane by round-off tilt is
then seated or lifted as a whole, not rocked corner by corner.

Speculative contacts: a pair apart by at most a margin (``SPECULATIVE_FRACTION`` of the
thinner hull's thickness, or the caller's ``reach`` if more: the distance gravity can close
in a step) has contacts too, with negative depths (minus the gap), and so have the corners
of a face within the margin above the other's plane (kept by the clip). Bodies placed
exactly touching are apart or overlapping by round-off, and a solver's round-off lifts a
resting body a little; without the margin their contacts would come and go, and a resting
body would fall a step each time they went.
The contact stage lets a speculative contact's gap close over the step and no more.

Frame-to-frame coherence: a cache keyed by body pair remembers the axis that separated the
pair or gave its contact last time, as features (a face of A, a face of B, an edge pair) and
as a direction; the separating-axis test tries the feature first and GJK starts from the
direction, and either usually separates again at once. The caller owns the cache and passes
it in; the kernel returns the new one (one row per pair it was given).

Each contact carries a feature id (int64) that stays the same while its features do: the
kind of contact, the reference and incident faces (or the two edges) and the corner's clip
tag (``manifold.TAG_BITS``).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._pair_keys import pair_key
from thesis_rbd._sorting import stable_argsort
from thesis_rbd.collision.contact_set import FLOAT_WIDTH, INT_WIDTH, ContactSet, contact_views
from thesis_rbd.collision.convex.box import box_box_query, box_face_contacts
from thesis_rbd.collision.convex.coherence import certify_face_axis
from thesis_rbd.collision.convex.gjk import (
    CACHE_AXIS,
    epa_scratch,
    gjk_epa_query,
    mapped_support,
    support_vertex,
)
from thesis_rbd.collision.convex.hull_data import HullSet, unpack_hulls
from thesis_rbd.collision.convex.manifold import (
    DEEPEST_VERTEX_TAG,
    PARALLEL_COSINE,
    clip_incident_face,
    edge_contact_point,
    emit_face_contacts,
    feature_id,
)
from thesis_rbd.collision.convex.sat import EDGES, FACE_A, FACE_B, place_hull, sat_query
from thesis_rbd.spatial.quaternion import to_matrix_into

__all__ = [
    "CACHE_AXIS",
    "OUTPUT_FLOATS",
    "OUTPUT_INTS",
    "SAT_EDGE_PAIRS",
    "SPECULATIVE_FRACTION",
    "cache_views",
    "convex_contacts",
    "convex_contacts_for_pairs",
    "empty_cache",
    "feature_id",
    "find_convex_contacts",
    "query_scratch_for",
]

# Pairs apart by at most this fraction of the thinner hull's thickness get (speculative)
# contacts. A thousandth: far above round-off (bodies placed touching are apart by an ulp)
# and above the contact solver's position error per step at rest (a thousandth of the slop), the
# scale of the slop within which the contact stage leaves penetration alone, so that a
# resting contact is found on either side of touching; and small enough that few pairs
# merely passing close by become contacts (each costs the solver a row).
SPECULATIVE_FRACTION = 1e-3
# Output entries per pair: up to four contacts (``ContactSet`` layout), then the pair's cache
# row (key and three features; three axis components)
OUTPUT_INTS = 4 * INT_WIDTH + 4
OUTPUT_FLOATS = 4 * FLOAT_WIDTH + 3
# Pairs whose edge counts multiply to at most this go through the separating-axis test,
# larger ones through GJK and EPA: the SAT's cost grows with the product, GJK/EPA's hardly;
# resting on a box, the SAT was the faster at 576 (a 16-sided cylinder) and GJK/EPA at 1152.
SAT_EDGE_PAIRS = 600
# Separations within this fraction of the hulls' sizes are ties (see ``sat_query``): a face
# beats an edge pair that is deeper by less, which keeps whole-face manifolds for nearly
# parallel faces at a depth error below 1e-9 of the size.
_TIE = 1e-10
# Incident faces are searched over all faces of hulls with at most this many
_SCAN_FACES = 64
# An edge axis closer than this (rad) to the normal of a face beside the edges gets that
# face's clipped manifold instead of one point
_FLAT_EDGE_ANGLE = 1e-2
# Contact corners whose depths differ by less than this fraction of the hulls' sizes are
# equally deep when four are kept: a face resting on a face, tilted by round-off or by a
# few micro-radians, keeps its widest four corners whichever way it tilts, instead of
# flipping between sets as the tilt does.
_FLAT = 1e-5
# A's own frame for _gather_loop: module constants, which numba compiles in, so the face
# manifold allocates nothing per pair
_IDENTITY = np.eye(3)
_ORIGIN = np.zeros(3)


def empty_cache() -> tuple:
    """A coherence cache with no pair, as ``convex_contacts`` takes and returns it:
    (ints, floats, int offset, float offset, pairs)."""
    return np.zeros(0, np.int64), np.zeros(0), 0, 0, 0


def cache_views(cache: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A coherence cache's (keys (k,), features (k, 3), axes (k, 3)), for inspection."""
    return _cache_fields(*cache)


@njit
def _cache_fields(ints, floats, int_offset, float_offset, count):
    """(keys, features, axes) of a cache of ``count`` pairs packed in ``ints`` from
    ``int_offset`` and ``floats`` from ``float_offset``."""
    return (
        ints[int_offset : int_offset + count],
        ints[int_offset + count : int_offset + 4 * count].reshape((count, 3)),
        floats[float_offset : float_offset + 3 * count].reshape((count, 3)),
    )


@njit(allocates=False)
def _mesh_frame(i, position, orientation, center_of_mass_local, R, t):
    """Body i's mesh-to-world rotation R (3, 3) and translation t (3,)."""
    to_matrix_into(orientation[i], R)
    for a in range(3):
        t[a] = position[i, a] - (
            R[a, 0] * center_of_mass_local[i, 0]
            + R[a, 1] * center_of_mass_local[i, 1]
            + R[a, 2] * center_of_mass_local[i, 2]
        )


@njit(allocates=False)
def _relative_frame(Ra, ta, Rb, tb, R, t):
    """B's frame in A's: R = Ra^T Rb, t = Ra^T (tb - ta)."""
    for a in range(3):
        for b in range(3):
            R[a, b] = Ra[0, a] * Rb[0, b] + Ra[1, a] * Rb[1, b] + Ra[2, a] * Rb[2, b]
        t[a] = Ra[0, a] * (tb[0] - ta[0]) + Ra[1, a] * (tb[1] - ta[1]) + Ra[2, a] * (tb[2] - ta[2])


@njit(allocates=False)
def _incident_face(H, h, mx, my, mz, start_vertex):
    """Face of hull h whose outward normal is most nearly along (mx, my, mz) (hull frame):
    a scan over all faces of a small hull, the faces around the support vertex otherwise."""
    face_start, planes = H.face_start, H.planes
    f0, f1 = face_start[h], face_start[h + 1]
    best, best_face = -np.inf, 0
    if f1 - f0 <= _SCAN_FACES:
        for f in range(f0, f1):
            s = planes[f, 0] * mx + planes[f, 1] * my + planes[f, 2] * mz
            if s > best:
                best, best_face = s, f - f0
        return best_face
    vertex_start, vertices, neighbor_start, neighbors = (
        H.vertex_start,
        H.vertices,
        H.neighbor_start,
        H.neighbors,
    )
    vertex_face_start, vertex_faces = H.vertex_face_start, H.vertex_faces
    v0 = vertex_start[h]
    v = support_vertex(
        vertices[v0 : vertex_start[h + 1]], neighbor_start[v0 : vertex_start[h + 1] + 1],
        neighbors, mx, my, mz, start_vertex,
    )  # fmt: skip
    for k in range(vertex_face_start[v0 + v], vertex_face_start[v0 + v + 1]):
        f = f0 + vertex_faces[k]
        s = planes[f, 0] * mx + planes[f, 1] * my + planes[f, 2] * mz
        if s > best:
            best, best_face = s, vertex_faces[k]
    return best_face


@njit(allocates=False)
def _deepest_vertex(H, h, kind, R, t, nx, ny, nz, start_vertex, out):
    """Hull h's vertex farthest against (nx, ny, nz) (A's frame), climbing from its vertex
    ``start_vertex``, into out[0] (A's frame); h is B's hull when ``kind`` is FACE_A
    (mapped by R, t), A's otherwise."""
    if kind == FACE_A:
        x, y, z, _ = mapped_support(H, h, R, t, -nx, -ny, -nz, start_vertex)
    else:
        x, y, z, _ = mapped_support(H, h, _IDENTITY, _ORIGIN, -nx, -ny, -nz, start_vertex)
    out[0, 0], out[0, 1], out[0, 2] = x, y, z


@njit(allocates=False)
def _gather_loop(H, h, face, R, t, out):
    """Face ``face`` of hull h's corners mapped by x -> R x + t into ``out``; their count."""
    vertex_start, vertices, face_start, loop_start, loops = (
        H.vertex_start,
        H.vertices,
        H.face_start,
        H.loop_start,
        H.loops,
    )
    v0 = vertex_start[h]
    f = face_start[h] + face
    count = loop_start[f + 1] - loop_start[f]
    for k in range(count):
        v = v0 + loops[loop_start[f] + k]
        x, y, z = vertices[v, 0], vertices[v, 1], vertices[v, 2]
        for a in range(3):
            out[k, a] = R[a, 0] * x + R[a, 1] * y + R[a, 2] * z + t[a]
    return count


@njit(allocates=False, separate=True)
def _face_manifold(
    H, ha, hb, kind, reference_face, start_vertex, R, t, margin, apart, tolerance, flat,
    reference, incident, points, tags, spare, spare_tags, labels, spare_labels, depths, keep,
    Ri, ti, out_points, out_depths, out_features, c,
):  # fmt: skip
    """Contacts of a face axis into the outputs from row c (world frame); their count.

    ``kind`` is FACE_A (reference face on A) or FACE_B; (R, t) maps B into A's frame and
    (Ri, ti) A into the world. The incident hull's deepest vertex under the reference face
    is searched from its vertex ``start_vertex`` (0 when none is known). The incident face
    is kept up to ``margin`` above the reference plane; where none of it is, the incident
    hull's deepest vertex is the one contact, unless the pair is ``apart`` (then there is
    none). Each contact's depth is its corner's depth below that plane (negative above it).
    Of more than four corners, the deepest and the three that span the largest area with it
    are kept (``four_corners``); corners less deep than the deepest by at most ``flat`` are
    as deep for that choice.
    """
    planes, face_start = H.planes, H.face_start
    if kind == FACE_A:
        inc_hull = hb
        f = face_start[ha] + reference_face
        nx, ny, nz, d = planes[f, 0], planes[f, 1], planes[f, 2], planes[f, 3]
        # the incident face is B's most opposed to n: search along -R^T n in B's frame
        mx = -(R[0, 0] * nx + R[1, 0] * ny + R[2, 0] * nz)
        my = -(R[0, 1] * nx + R[1, 1] * ny + R[2, 1] * nz)
        mz = -(R[0, 2] * nx + R[1, 2] * ny + R[2, 2] * nz)
        incident_face = _incident_face(H, hb, mx, my, mz, start_vertex)
        k = _gather_loop(H, ha, reference_face, _IDENTITY, _ORIGIN, reference)
        m = _gather_loop(H, hb, incident_face, R, t, incident)
    else:
        inc_hull = ha
        f = face_start[hb] + reference_face
        bx, by, bz = planes[f, 0], planes[f, 1], planes[f, 2]
        nx = R[0, 0] * bx + R[0, 1] * by + R[0, 2] * bz
        ny = R[1, 0] * bx + R[1, 1] * by + R[1, 2] * bz
        nz = R[2, 0] * bx + R[2, 1] * by + R[2, 2] * bz
        d = planes[f, 3] + nx * t[0] + ny * t[1] + nz * t[2]
        incident_face = _incident_face(H, ha, -nx, -ny, -nz, start_vertex)
        k = _gather_loop(H, hb, reference_face, R, t, reference)
        m = _gather_loop(H, ha, incident_face, _IDENTITY, _ORIGIN, incident)
    # the incident face's normal (A's frame) against the reference normal
    g = face_start[inc_hull] + incident_face
    mx, my, mz = planes[g, 0], planes[g, 1], planes[g, 2]
    if kind == FACE_A:
        mx, my, mz = (
            R[0, 0] * mx + R[0, 1] * my + R[0, 2] * mz,
            R[1, 0] * mx + R[1, 1] * my + R[1, 2] * mz,
            R[2, 0] * mx + R[2, 1] * my + R[2, 2] * mz,
        )
    parallel = -(mx * nx + my * ny + mz * nz) >= PARALLEL_COSINE
    count = clip_incident_face(
        reference, k, nx, ny, nz, d, incident, m, parallel, margin, tolerance, points, tags,
        spare, spare_tags, labels, spare_labels, depths,
    )  # fmt: skip
    if count == 0:
        if apart:
            # no corner of the incident face within the margin over the reference face: the
            # other body's nearest vertex lies beside that face, possibly far from it, so
            # there is no speculative contact
            return 0, nx, ny, nz
        # no corner of the incident face below the lifted plane: the incident hull's
        # deepest vertex (its support against the reference normal) is the contact
        count = 1
        tags[0] = DEEPEST_VERTEX_TAG
        _deepest_vertex(H, inc_hull, kind, R, t, nx, ny, nz, start_vertex, points)
    n_keep = emit_face_contacts(
        points, tags, depths, count, nx, ny, nz, d, kind, reference_face, incident_face,
        tolerance, flat, keep, Ri, ti, out_points, out_depths, out_features, c,
    )  # fmt: skip
    return n_keep, nx, ny, nz


@njit(separate=True)
def _pair_query(H, ha, hb, R, t, cached_kind, cached_i, cached_j, ax, ay, az, margin, scratch):
    """Axis of pair (A, B): (kind, i, j, separation, ux, uy, uz), as ``sat_query``, exact
    for separations up to ``margin``.

    Pairs of few edges go through the separating-axis test, testing the cached feature
    first; others through GJK and EPA, starting from the cached axis. (Two boxes take the
    closed form, ``box_box_query``, and a resting pair's face that ``certify_face_axis``
    proves still the answer needs no query; both are called by the caller: this function's
    unpacking of the hull arrays alone costs a box pair's whole test.)
    """
    (vertex_start, vertices, _, _, _, _, _, face_start, planes, _, _, edge_start, edges,
     edge_faces, edge_arcs, centroids, sizes, _, _, _) = H  # fmt: skip
    placed_vertices, placed_planes, placed_arcs, signs_a, signs_b, epa = scratch
    tie = _TIE * (sizes[ha] + sizes[hb])
    ea0, ea1 = edge_start[ha], edge_start[ha + 1]
    eb0, eb1 = edge_start[hb], edge_start[hb + 1]
    if (ea1 - ea0) * (eb1 - eb0) > SAT_EDGE_PAIRS:
        return gjk_epa_query(H, ha, hb, R, t, ax, ay, az, tie, margin, epa)
    vb0, vb1 = vertex_start[hb], vertex_start[hb + 1]
    fb0, fb1 = face_start[hb], face_start[hb + 1]
    place_hull(vertices[vb0:vb1], planes[fb0:fb1], edge_arcs[eb0:eb1], R, t,
               placed_vertices, placed_planes, placed_arcs)  # fmt: skip
    return sat_query(
        vertices[vertex_start[ha] : vertex_start[ha + 1]],
        planes[face_start[ha] : face_start[ha + 1]],
        edges[ea0:ea1], edge_faces[ea0:ea1], edge_arcs[ea0:ea1], centroids[ha],
        placed_vertices[: vb1 - vb0], placed_planes[: fb1 - fb0],
        edges[eb0:eb1], edge_faces[eb0:eb1], placed_arcs[: eb1 - eb0],
        cached_kind, cached_i, cached_j, tie, margin, signs_a, signs_b,
    )  # fmt: skip


def query_scratch_for(hulls: HullSet) -> tuple | None:
    """The scratch arrays of the general pair query for ``hulls`` (``convex_contacts_for_pairs``
    takes them as ``query_scratch``), or None where every hull is a box.

    Two boxes take the closed form; None tells the kernels so when they are compiled, and
    the general query (GJK, EPA and the separating-axis search: most of the convex path's
    first-run compile) is then left out of them. Make them again when the set changes.
    """
    if np.all(hulls.box_features[:, 0] >= 0):
        return None
    return _scratch_arrays(hulls)


def _scratch_arrays(hulls: HullSet) -> tuple:
    """Arrays ``_pair_query`` works in, sized for the largest hull of ``hulls`` (at least one),
    reused over the pairs and the calls."""
    most_v, most_f, most_e = (
        max(int(np.diff(start).max()), 1)
        for start in (hulls.vertex_start, hulls.face_start, hulls.edge_start)
    )
    # a pair of the separating-axis test has at most SAT_EDGE_PAIRS / 6 edges on each side
    # (a hull has at least 6), and no more faces than edges
    side = SAT_EDGE_PAIRS // 6
    return (
        np.empty((most_v, 3)),
        np.empty((most_f, 4)),
        np.empty((most_e, 3)),
        np.empty((min(most_f, side), min(most_e, side))),
        np.empty((min(most_e, side), min(most_f, side))),
        epa_scratch(),
    )


@njit(separate=True)
def convex_contacts_for_pairs(
    pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position, orientation,
    center_of_mass_local, cache_ints, cache_floats, cache_int_offset, cache_float_offset,
    cache_count, speculative, reach, ints, floats,
):  # fmt: skip
    """Contacts of candidate pairs of convex bodies, world frame, in one call
    (``convex_contacts`` calls it and unpacks what it writes).

    Parameters
    ----------
    pairs : (p, 2) int64
        Candidate body pairs [i, j]; both bodies convex.
    hull_of_body : (n,) int64
        Hull index of each body (``HullSet.hull_of``).
    hull_arrays : (ints, floats)
        ``HullSet.arrays()``: the packed hull set.
    longest_loop : int
        ``HullSet.longest_loop``: most corners of any face.
    query_scratch : tuple or None
        ``query_scratch_for(hulls)``: arrays the general pair query works in, or None where
        every hull is a box (the general query is then not compiled into the kernel).
    position, orientation, center_of_mass_local : (n, 3), (n, 4), (n, 3) float64
        Body state: x_world = R(orientation) (x_mesh - center_of_mass_local) + position.
    cache_ints, cache_floats, cache_int_offset, cache_float_offset, cache_count
        The coherence cache of k = ``cache_count`` pairs (``empty_cache``, or the cache of
        the call before: its output arrays and where the cache starts in them):

        - keys (k,) int64 at ``cache_ints[cache_int_offset:]``, sorted: ``pair_key(i, j)``
          of each cached pair;
        - features (k, 3) int64 after them: [kind, i, j] of the axis that separated the
          pair or gave its contact last time: ``FACE_A`` face i, ``FACE_B`` face i (j: the
          other hull's vertex deepest under it where ``certify_face_axis`` found it, else 0),
          ``EDGES`` edge i of A and j of B, ``CACHE_AXIS`` a direction only, 0 nothing;
        - axes (k, 3) float64 at ``cache_floats[cache_float_offset:]``: that axis, from A
          towards B, in A's mesh frame.
    speculative : float
        Pairs apart by at most this fraction of the thinner hull's thickness get contacts
        (``SPECULATIVE_FRACTION``), or by at most ``reach`` if that is more; both 0
        report overlapping and touching pairs only.
    reach : float
        Length (>= 0) a body may close in one step whatever its size: the caller's fall
        under gravity over the step, so that a small body resting on another keeps its
        contact while a solver's round-off lifts it.

    ints, floats : (>= OUTPUT_INTS p,) int64 and (>= OUTPUT_FLOATS p,) float64
        Out: everything below (at most four contacts a pair): the contacts laid out as a
        ``ContactSet``'s, then the cache's keys and features (ints) and axes (floats).
        (Written, not returned: each array a kernel returns costs about a microsecond to
        hand to Python, a small scene's whole narrow phase.)

    Returns
    -------
    int
        The number of contacts c.

    Written
    -------
    body_a, body_b : (c,) int64
        The pair of each contact (a = i, b = j).
    points, normals : (c, 3) float64
        World contact points (midway between the two surfaces) and unit normals from b
        towards a.
    depths : (c,) float64
        The pair's penetration depth along the normal for its deepest contacts (those within
        ``speculative`` of the thinner body's thickness of the deepest), less for the others
        by as much as their corners lie above the deepest (a corner within the margin above
        the other body: a gap): > 0 penetration, < 0 a gap within the speculative margin.
    faces : (c, 2) int64
        -1: hull faces are not mesh triangles.
    features : (c,) int64
        Feature ids (``feature_id``).
    cache keys, features, axes : (p,), (p, 3), (p, 3)
        The new cache: a row per pair, sorted by key, after the contacts (int offset 5 c,
        float offset 7 c).
    """
    H = unpack_hulls(hull_arrays)
    sizes, thicknesses = H.sizes, H.thicknesses
    box_frames, box_features = H.box_frames, H.box_features
    cache_keys, cache_features, cache_axes = _cache_fields(
        cache_ints, cache_floats, cache_int_offset, cache_float_offset, cache_count
    )
    p = pairs.shape[0]
    corners = 2 * longest_loop + 2
    reference = np.empty((longest_loop, 3))
    incident = np.empty((longest_loop, 3))
    points = np.empty((corners, 3))
    spare = np.empty((corners, 3))
    tags = np.empty(corners, np.int64)
    spare_tags = np.empty(corners, np.int64)
    labels = np.empty(corners, np.int64)
    spare_labels = np.empty(corners, np.int64)
    depths = np.empty(corners)
    keep = np.empty(4, np.int64)

    body_a = np.empty(4 * p, np.int64)
    body_b = np.empty(4 * p, np.int64)
    out_points = np.empty((4 * p, 3))
    out_normals = np.empty((4 * p, 3))
    out_depths = np.empty(4 * p)
    out_features = np.empty(4 * p, np.int64)
    new_keys = np.empty(p, np.int64)
    new_features = np.zeros((p, 3), np.int64)
    new_axes = np.zeros((p, 3))

    Ra, ta = np.empty((3, 3)), np.empty(3)
    Rb, tb = np.empty((3, 3)), np.empty(3)
    R, t = np.empty((3, 3)), np.empty(3)
    M, shift = np.empty((3, 3)), np.empty(3)
    c = 0
    for q in range(p):
        i, j = pairs[q, 0], pairs[q, 1]
        ha, hb = hull_of_body[i], hull_of_body[j]
        key = pair_key(i, j)
        new_keys[q] = key
        _mesh_frame(i, position, orientation, center_of_mass_local, Ra, ta)
        _mesh_frame(j, position, orientation, center_of_mass_local, Rb, tb)
        _relative_frame(Ra, ta, Rb, tb, R, t)
        margin = max(speculative * min(thicknesses[ha], thicknesses[hb]), reach)
        tolerance = _TIE * (sizes[ha] + sizes[hb])
        boxes = box_features[ha, 0] >= 0 and box_features[hb, 0] >= 0
        if boxes:
            kind, fi, fj, separation, ux, uy, uz = box_box_query(
                box_frames, box_features, ha, hb, R, t, tolerance
            )
        elif query_scratch is None:  # (numba drops this branch or the next when compiling)
            raise ValueError("query_scratch is None, but a pair's hulls are not both boxes")
        else:
            # last step's axis first (two boxes need no cache: their test is closed form)
            cached_kind, cached_i, cached_j = 0, 0, 0
            ax, ay, az = 0.0, 0.0, 0.0
            slot = np.searchsorted(cache_keys, key)
            if slot < cache_keys.shape[0] and cache_keys[slot] == key:
                cached_kind = cache_features[slot, 0]
                cached_i, cached_j = cache_features[slot, 1], cache_features[slot, 2]
                ax, ay, az = cache_axes[slot, 0], cache_axes[slot, 1], cache_axes[slot, 2]
            certified = False
            if cached_kind == FACE_A or cached_kind == FACE_B:
                # a resting pair: last step's face, if provably still the answer, needs no
                # search; the cache's third entry is then the other hull's deepest vertex
                certified, separation, ux, uy, uz, fj = certify_face_axis(
                    H, ha, hb, R, t, cached_kind, cached_i, cached_j, tolerance, M, shift
                )
                kind, fi = cached_kind, cached_i
            if not certified:
                kind, fi, fj, separation, ux, uy, uz = _pair_query(
                    H, ha, hb, R, t, cached_kind, cached_i, cached_j, ax, ay, az, margin,
                    query_scratch,
                )  # fmt: skip
        new_features[q, 0], new_features[q, 1], new_features[q, 2] = kind, fi, fj
        new_axes[q, 0], new_axes[q, 1], new_axes[q, 2] = ux, uy, uz
        if separation > margin:
            continue
        flat = _FLAT * (sizes[ha] + sizes[hb])
        apart = separation > 0.0
        count = 0
        if kind == EDGES:
            # an edge axis within a small angle of a face beside the edges (a face hanging
            # over another's edge, nearly flat): the faces' clipped manifold, at the axis'
            # exact normal and depth
            face_kind, face = _face_beside_edges(H, ha, hb, fi, fj, R, ux, uy, uz)
            if face_kind:
                count, _, _, _ = _face_manifold(
                    H, ha, hb, face_kind, face, 0, R, t, margin, apart, tolerance, flat,
                    reference, incident, points, tags, spare, spare_tags, labels,
                    spare_labels, depths, keep, Ra, ta, out_points, out_depths, out_features, c,
                )  # fmt: skip
            if count == 0:
                count = 1
                gap2 = _edge_contact(H, ha, hb, fi, fj, R, t, Ra, ta, out_points, c)
                if apart and gap2 > (margin + tolerance) ** 2:
                    # apart along the edges' axis by at most the margin, but the segments
                    # themselves are further apart (their lines pass close elsewhere): no
                    # speculative contact
                    count = 0
                out_depths[c] = -separation
                out_features[c] = feature_id(EDGES, fi, fj, 0)
            # the normal runs from B towards A: against the axis
            nx, ny, nz = -ux, -uy, -uz
        else:
            if boxes:
                count, nx, ny, nz = box_face_contacts(
                    box_frames, box_features, ha, hb, kind, fi, R, t, margin, apart,
                    tolerance, flat, reference, incident, points, tags, spare, spare_tags,
                    labels, spare_labels, depths, keep, Ra, ta, out_points, out_depths,
                    out_features, c,
                )  # fmt: skip
            else:
                count, nx, ny, nz = _face_manifold(
                    H, ha, hb, kind, fi, fj, R, t, margin, apart, tolerance, flat, reference,
                    incident, points, tags, spare, spare_tags, labels, spare_labels, depths,
                    keep, Ra, ta, out_points, out_depths, out_features, c,
                )  # fmt: skip
            # against A's outward face normal, along B's
            if kind == FACE_A:
                nx, ny, nz = -nx, -ny, -nz
        level = max(flat, speculative * min(thicknesses[ha], thicknesses[hb]))
        _finish_pair_contacts(
            i, j, c, count, separation, level, margin, nx, ny, nz, Ra, body_a, body_b,
            out_normals, out_depths,
        )  # fmt: skip
        c += count
    _write_output(
        c, p, body_a, body_b, out_points, out_normals, out_depths, out_features, new_keys,
        new_features, new_axes, ints, floats,
    )  # fmt: skip
    return c


@njit(allocates=False, inline="always")
def _finish_pair_contacts(
    i, j, c, count, separation, level, margin, nx, ny, nz, Ra, body_a, body_b, out_normals,
    out_depths,
):  # fmt: skip
    """Rows ``c`` to ``c + count``: the pair, the world normal, and the depths.

    The contacts as deep as the deepest, to ``level`` (a thousandth of the thinner body, the
    speculative fraction: a face resting on a face, rocking by less), carry the pair's depth
    (its exact penetration, or minus its gap), so that a resting face's corners are alike to
    the bit; the others less by as much as their corners lie above the deepest: a corner that
    only the step's reach kept, higher above the other body than that, is a gap the solver
    lets close, not a support (a thin plate tilted on the floor would rest on its raised
    edge). No gap exceeds the ``margin``: along the normal, tilted from the reference face's
    where the clip measured it, a kept corner's gap can pass it by round-off."""
    wx = Ra[0, 0] * nx + Ra[0, 1] * ny + Ra[0, 2] * nz
    wy = Ra[1, 0] * nx + Ra[1, 1] * ny + Ra[1, 2] * nz
    wz = Ra[2, 0] * nx + Ra[2, 1] * ny + Ra[2, 2] * nz
    deepest = -np.inf
    for r in range(c, c + count):
        deepest = max(deepest, out_depths[r])
    for r in range(c, c + count):
        body_a[r], body_b[r] = i, j
        out_normals[r, 0], out_normals[r, 1], out_normals[r, 2] = wx, wy, wz
        above = deepest - out_depths[r]
        out_depths[r] = -separation if above <= level else max(-separation - above, -margin)


@njit(inline="always")
def _write_output(
    c, p, body_a, body_b, out_points, out_normals, out_depths, out_features, new_keys,
    new_features, new_axes, ints, floats,
):  # fmt: skip
    """Pack the ``c`` contacts into ``ints`` and ``floats`` as a ``ContactSet``, then the
    cache of the ``p`` pairs sorted by key."""
    order = np.arange(p)
    for q in range(1, p):
        if new_keys[q] < new_keys[q - 1]:  # (the broad phase's pairs come sorted)
            order = stable_argsort(new_keys)
            break
    put_a, put_b, put_points, put_normals, put_depths, put_faces, put_features = contact_views(
        ints, floats, c
    )
    for r in range(c):
        put_a[r], put_b[r] = body_a[r], body_b[r]
        put_features[r] = out_features[r]
        put_faces[r, 0] = put_faces[r, 1] = -1
        put_depths[r] = out_depths[r]
        for a in range(3):
            put_points[r, a] = out_points[r, a]
            put_normals[r, a] = out_normals[r, a]
    put_keys, put_cached, put_axes = _cache_fields(ints, floats, INT_WIDTH * c, FLOAT_WIDTH * c, p)
    for m in range(p):
        q = order[m]
        put_keys[m] = new_keys[q]
        for a in range(3):
            put_cached[m, a] = new_features[q, a]
            put_axes[m, a] = new_axes[q, a]


def convex_contacts(
    pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position, orientation,
    center_of_mass_local, cache, speculative, reach,
) -> tuple[ContactSet, tuple]:  # fmt: skip
    """``convex_contacts_for_pairs`` (same arguments, ``cache`` the tuple of its five cache
    arguments, as ``empty_cache`` makes it): the contacts as a ``ContactSet`` and the new
    cache, a tuple of the same form that points into the same output arrays."""
    contacts, cache = find_convex_contacts(
        pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position, orientation,
        center_of_mass_local, cache, speculative, reach,
    )  # fmt: skip
    return ContactSet(*contacts), cache


@njit(inline="always")
def find_convex_contacts(
    pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position, orientation,
    center_of_mass_local, cache, speculative, reach,
):  # fmt: skip
    """``convex_contacts_for_pairs`` into output arrays of its own: the contacts (ints,
    floats, count), laid out as a ``ContactSet``'s, and the new coherence cache (its five
    arguments, pointing into the same arrays), for the next call to take as ``cache``: the one
    place the cache's bookkeeping is written, for the world's step and for Python callers."""
    p = pairs.shape[0]
    ints = np.empty(OUTPUT_INTS * p, np.int64)
    floats = np.empty(OUTPUT_FLOATS * p)
    c = convex_contacts_for_pairs(
        pairs, hull_of_body, hull_arrays, longest_loop, query_scratch, position, orientation,
        center_of_mass_local, cache[0], cache[1], cache[2], cache[3], cache[4], speculative,
        reach, ints, floats,
    )  # fmt: skip
    return (ints, floats, c), (ints, floats, INT_WIDTH * c, FLOAT_WIDTH * c, p)


@njit(allocates=False)
def _face_beside_edges(H, ha, hb, edge_a, edge_b, R, ux, uy, uz):
    """(kind, face) of the face beside edge_a of A or edge_b of B whose outward normal is
    within ``_FLAT_EDGE_ANGLE`` of the edge axis u (A towards B; B's faces face -u); kind 0
    if none is."""
    planes, face_start, edge_start, edge_faces = H.planes, H.face_start, H.edge_start, H.edge_faces
    best, kind, face = math.cos(_FLAT_EDGE_ANGLE), 0, 0
    for k in range(2):
        f = edge_faces[edge_start[ha] + edge_a, k]
        row = face_start[ha] + f
        s = planes[row, 0] * ux + planes[row, 1] * uy + planes[row, 2] * uz
        if s > best:
            best, kind, face = s, FACE_A, f
        g = edge_faces[edge_start[hb] + edge_b, k]
        row = face_start[hb] + g
        nx = R[0, 0] * planes[row, 0] + R[0, 1] * planes[row, 1] + R[0, 2] * planes[row, 2]
        ny = R[1, 0] * planes[row, 0] + R[1, 1] * planes[row, 1] + R[1, 2] * planes[row, 2]
        nz = R[2, 0] * planes[row, 0] + R[2, 1] * planes[row, 1] + R[2, 2] * planes[row, 2]
        s = -(nx * ux + ny * uy + nz * uz)
        if s > best:
            best, kind, face = s, FACE_B, g
    return kind, face


@njit
def _edge_contact(H, ha, hb, edge_a, edge_b, R, t, Ri, ti, out_points, c):
    """The one contact of an edge pair, world frame, into ``out_points[c]``; returns the
    squared distance between the two edges' closest points."""
    vertex_start, vertices, edge_start, edges = H.vertex_start, H.vertices, H.edge_start, H.edges
    a0 = vertex_start[ha] + edges[edge_start[ha] + edge_a, 0]
    a1 = vertex_start[ha] + edges[edge_start[ha] + edge_a, 1]
    b0 = vertex_start[hb] + edges[edge_start[hb] + edge_b, 0]
    b1 = vertex_start[hb] + edges[edge_start[hb] + edge_b, 1]
    pb = R @ vertices[b0] + t
    qb = R @ vertices[b1] + t
    x, y, z, gap2 = edge_contact_point(vertices[a0], vertices[a1], pb, qb)
    for a in range(3):
        out_points[c, a] = Ri[a, 0] * x + Ri[a, 1] * y + Ri[a, 2] * z + ti[a]
    return gap2
