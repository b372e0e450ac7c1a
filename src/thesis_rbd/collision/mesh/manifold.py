"""Contact manifolds for dynamics, from the intersecting triangle pairs of one body pair.

Dynamics needs more from a contact than ``collide``'s per-triangle-pair answer, and gets it
here, in four steps:

* one normal per contact region. The intersecting triangle pairs of a body pair fall into
  regions (pairs linked by a shared triangle); each region gets the axis of least penetration
  over its triangles as a whole: candidates are the outward normals of B's region faces, the
  reversed normals of A's, and (for small regions) their edge-edge cross products; the depth
  along u is max over B's region vertices of u.x minus min over A's. Judged per triangle
  pair, two exactly stacked boxes have coplanar side faces whose own least-penetration axis
  is sideways with depth 0; judged over the region, the vertical axis wins with the true
  depth, as in the thesis's vertex-face / edge-edge classification of a whole contact.
* one contact per cluster of intersection points closer than the merge tolerance, at the
  cluster's centroid. A vertex pressed into a face gives a small intersection polygon around
  the vertex; its centroid is the vertex, which puts the impulse where the touch is and not
  at a corner of the polygon (which would spin a ball landing on its pole);
* the vertex-face contacts of the thesis added to the crossing points: corners of either
  side's region faces that lie inside the other side's faces within the region's depth
  (for two boxes face on face, the corners of the overlap square, which crossing points
  miss when the boxes' edges nearly coincide);
* at most four contacts per region, the corners spanning the largest area: a box resting on
  a box keeps the four corners of the overlap instead of a cloud of crossing points that
  changes from step to step and makes a stack jitter.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._sorting import sort_with_order, stable_argsort, unique_sorted
from thesis_rbd._union_find import find_root, join
from thesis_rbd.collision.mesh.contact_report import cluster_points

__all__ = ["reduce_contacts", "region_manifolds", "region_normals", "region_of_faces"]


@njit
def region_of_faces(tri_pairs, region, faces):
    """Region of each contact, looked up by its [face of A, face of B] pair."""
    width = tri_pairs[:, 1].max() + 1
    keys = tri_pairs[:, 0] * width + tri_pairs[:, 1]
    sorted_keys, order = sort_with_order(keys)
    out = np.empty(faces.shape[0], np.int64)
    for c in range(faces.shape[0]):
        out[c] = region[order[np.searchsorted(sorted_keys, faces[c, 0] * width + faces[c, 1])]]
    return out


@njit
def reduce_contacts(points, normals, depths, faces, tolerance):
    """One contact per cluster of points closer than ``tolerance`` (transitively).

    Parameters
    ----------
    points, normals : (c, 3) float64
    depths : (c,) float64
    faces : (c, 2) int64
    tolerance : float

    Returns
    -------
    points, normals, depths, faces
        Per cluster, in order of first member: the centroid of its points, the normal and
        faces of its deepest member, and that depth.
    """
    c = points.shape[0]
    parent = cluster_points(points, tolerance)
    label = np.full(c, -1)
    clusters = 0
    for i in range(c):
        r = find_root(parent, i)
        if label[r] < 0:
            label[r] = clusters
            clusters += 1
    out_points = np.zeros((clusters, 3))
    out_normals = np.zeros((clusters, 3))
    out_depths = np.full(clusters, -np.inf)
    out_faces = np.zeros((clusters, 2), np.int64)
    members = np.zeros(clusters)
    for i in range(c):
        k = label[find_root(parent, i)]
        members[k] += 1.0
        for a in range(3):
            out_points[k, a] += points[i, a]
        if depths[i] > out_depths[k]:
            out_depths[k] = depths[i]
            out_normals[k, 0], out_normals[k, 1], out_normals[k, 2] = (
                normals[i, 0],
                normals[i, 1],
                normals[i, 2],
            )
            out_faces[k, 0], out_faces[k, 1] = faces[i, 0], faces[i, 1]
    for k in range(clusters):
        for a in range(3):
            out_points[k, a] /= members[k]
    return out_points, out_normals, out_depths, out_faces


# Edge-edge candidate axes grow as (faces of A) x (faces of B) x 9; past this many face
# pairs a region is judged by its face normals alone.
_EDGE_AXES_FACE_PAIRS = 64


@njit
def _corner(V, F, f, k, R, t):
    """Corner k of face f, mapped by (R, t)."""
    v = V[F[f, k]]
    return (
        R[0, 0] * v[0] + R[0, 1] * v[1] + R[0, 2] * v[2] + t[0],
        R[1, 0] * v[0] + R[1, 1] * v[1] + R[1, 2] * v[2] + t[1],
        R[2, 0] * v[0] + R[2, 1] * v[1] + R[2, 2] * v[2] + t[2],
    )


@njit
def _region_depth(u, corners_a, corners_b):
    """How far A's region must move along u to clear B's: max_B u.x - min_A u.x."""
    hi = -np.inf
    for k in range(corners_b.shape[0]):
        hi = max(hi, u[0] * corners_b[k, 0] + u[1] * corners_b[k, 1] + u[2] * corners_b[k, 2])
    lo = np.inf
    for k in range(corners_a.shape[0]):
        lo = min(lo, u[0] * corners_a[k, 0] + u[1] * corners_a[k, 1] + u[2] * corners_a[k, 2])
    return hi - lo


@njit
def _edge_vectors(corners):
    """Distinct edge directions (up to sign, to 1e-12) of the triangles in ``corners``."""
    m = corners.shape[0]
    edges = np.empty((m, 3))
    count = 0
    for k in range(m):
        t = k // 3
        a, b = corners[k], corners[3 * t + (k % 3 + 1) % 3]
        e = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
        length = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        if length == 0.0:
            continue
        repeat = False
        for j in range(count):
            cross = (
                edges[j, 1] * e[2] - edges[j, 2] * e[1],
                edges[j, 2] * e[0] - edges[j, 0] * e[2],
                edges[j, 0] * e[1] - edges[j, 1] * e[0],
            )
            if cross[0] ** 2 + cross[1] ** 2 + cross[2] ** 2 <= 1e-24 * length * length:
                repeat = True  # parallel to a kept edge: the same axis
                break
        if not repeat:
            edges[count, 0], edges[count, 1], edges[count, 2] = (
                e[0] / length, e[1] / length, e[2] / length,
            )  # fmt: skip
            count += 1
    return edges[:count]


@njit
def region_normals(tri_pairs, Va, Fa, Vb, Fb, Rab, tab):
    """Region of each intersecting triangle pair, and each region's normal and depth.

    Parameters
    ----------
    tri_pairs : (k, 2) int64
        Intersecting [face of A, face of B] pairs.
    Va, Fa, Vb, Fb
        The meshes in their own frames.
    Rab, tab
        B's mesh frame in A's.

    Returns
    -------
    region : (k,) int64
        Region index of each pair (pairs sharing a face are in one region).
    normals : (r, 3) float64
        Unit axis of least penetration per region, A's frame, pointing from B towards A.
    depths : (r,) float64
        Penetration along it, >= 0.
    """
    k = tri_pairs.shape[0]
    parent = np.arange(k)
    for column in range(2):
        order = stable_argsort(tri_pairs[:, column].copy())
        for r in range(1, k):
            if tri_pairs[order[r], column] == tri_pairs[order[r - 1], column]:
                join(parent, order[r], order[r - 1])
    region = np.full(k, -1)
    count = 0
    for r in range(k):
        root = find_root(parent, r)
        if region[root] < 0:
            region[root] = count
            count += 1
        region[r] = region[root]
    identity = np.eye(3)
    zero = np.zeros(3)
    normals = np.zeros((count, 3))
    depths = np.zeros(count)
    for g in range(count):
        faces_a = unique_sorted(tri_pairs[region == g, 0])
        faces_b = unique_sorted(tri_pairs[region == g, 1])
        corners_a = np.empty((3 * faces_a.shape[0], 3))
        corners_b = np.empty((3 * faces_b.shape[0], 3))
        for i in range(faces_a.shape[0]):
            for c in range(3):
                corners_a[3 * i + c] = _corner(Va, Fa, faces_a[i], c, identity, zero)
        for i in range(faces_b.shape[0]):
            for c in range(3):
                corners_b[3 * i + c] = _corner(Vb, Fb, faces_b[i], c, Rab, tab)
        best, best_u = np.inf, (0.0, 0.0, 1.0)
        for side in range(2):
            corners = corners_b if side == 0 else corners_a
            sign = 1.0 if side == 0 else -1.0
            for i in range(corners.shape[0] // 3):
                e1 = corners[3 * i + 1] - corners[3 * i]
                e2 = corners[3 * i + 2] - corners[3 * i]
                n = np.cross(e1, e2)
                length = np.sqrt(n @ n)
                if length <= 1e-300:
                    continue
                u = (sign * n[0] / length, sign * n[1] / length, sign * n[2] / length)
                d = _region_depth(u, corners_a, corners_b)
                if d < best:
                    best, best_u = d, u
        if faces_a.shape[0] * faces_b.shape[0] <= _EDGE_AXES_FACE_PAIRS:
            # Orient each edge-edge axis from B towards A by the faces' own sides: B's
            # outward normals point at A and A's at B, so their area-weighted sums give the
            # direction; the centroids of two surface patches do not (a ball's patch and a
            # floor's lie side by side, not one above the other).
            towards_a = np.zeros(3)
            for i in range(faces_b.shape[0]):
                towards_a += np.cross(
                    corners_b[3 * i + 1] - corners_b[3 * i], corners_b[3 * i + 2] - corners_b[3 * i]
                )
            for i in range(faces_a.shape[0]):
                towards_a -= np.cross(
                    corners_a[3 * i + 1] - corners_a[3 * i], corners_a[3 * i + 2] - corners_a[3 * i]
                )
            if towards_a @ towards_a == 0.0:
                for c in range(corners_a.shape[0]):
                    towards_a += corners_a[c] / corners_a.shape[0]
                for c in range(corners_b.shape[0]):
                    towards_a -= corners_b[c] / corners_b.shape[0]
            edges_a = _edge_vectors(corners_a)
            edges_b = _edge_vectors(corners_b)
            for ia in range(edges_a.shape[0]):
                pa = edges_a[ia]
                la2 = pa[0] * pa[0] + pa[1] * pa[1] + pa[2] * pa[2]
                for ib in range(edges_b.shape[0]):
                    pb = edges_b[ib]
                    n0 = pa[1] * pb[2] - pa[2] * pb[1]
                    n1 = pa[2] * pb[0] - pa[0] * pb[2]
                    n2 = pa[0] * pb[1] - pa[1] * pb[0]
                    length = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
                    lb2 = pb[0] * pb[0] + pb[1] * pb[1] + pb[2] * pb[2]
                    if length <= 1e-9 * np.sqrt(la2 * lb2):
                        continue  # parallel edges: no axis
                    if n0 * towards_a[0] + n1 * towards_a[1] + n2 * towards_a[2] < 0.0:
                        length = -length
                    u = (n0 / length, n1 / length, n2 / length)
                    d = _region_depth(u, corners_a, corners_b)
                    if d < best:
                        best, best_u = d, u
        normals[g, 0], normals[g, 1], normals[g, 2] = best_u
        depths[g] = max(best, 0.0)
    return region, normals, depths


@njit
def _manifold_corners(points, normal):
    """Indices of at most four points spanning the largest area across ``normal``.

    The first is the point farthest from the centroid, the second the farthest from it, the
    third and fourth the points making the largest triangle with those two on either side:
    for the intersection points around a face-on-face contact these are the corners of the
    overlap, which stay put from step to step (the reduction of Bullet's and Box2D's
    manifolds).
    """
    m = points.shape[0]
    if m <= 4:
        return np.arange(m)
    centroid = np.zeros(3)
    for i in range(m):
        centroid += points[i] / m
    first = 0
    best = -1.0
    for i in range(m):
        d = points[i] - centroid
        if d @ d > best:
            best, first = d @ d, i
    second = first
    best = -1.0
    for i in range(m):
        d = points[i] - points[first]
        if d @ d > best:
            best, second = d @ d, i
    edge = points[second] - points[first]
    third, fourth = -1, -1
    most, least = 0.0, 0.0
    for i in range(m):
        area = np.cross(edge, points[i] - points[first]) @ normal
        if area > most:
            most, third = area, i
        if area < least:
            least, fourth = area, i
    chosen = [first, second]
    if third >= 0:
        chosen.append(third)
    if fourth >= 0:
        chosen.append(fourth)
    return np.array(chosen)


@njit
def _project_along(p, u, corners, t, margin):
    """Signed distance s with p + s u on triangle t of ``corners`` (rows 3t..3t+2), or NaN
    if it misses the triangle by more than about ``margin`` (a length)."""
    t0, t1, t2 = corners[3 * t], corners[3 * t + 1], corners[3 * t + 2]
    e1 = (t1[0] - t0[0], t1[1] - t0[1], t1[2] - t0[2])
    e2 = (t2[0] - t0[0], t2[1] - t0[1], t2[2] - t0[2])
    n = (
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    )
    along = n[0] * u[0] + n[1] * u[1] + n[2] * u[2]
    if abs(along) <= 1e-12 * np.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2):
        return np.nan
    s = (n[0] * (t0[0] - p[0]) + n[1] * (t0[1] - p[1]) + n[2] * (t0[2] - p[2])) / along
    x = (p[0] + s * u[0] - t0[0], p[1] + s * u[1] - t0[1], p[2] + s * u[2] - t0[2])
    # barycentric coordinates of x in (e1, e2)
    d11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]
    d12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]
    d22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]
    d1 = x[0] * e1[0] + x[1] * e1[1] + x[2] * e1[2]
    d2 = x[0] * e2[0] + x[1] * e2[1] + x[2] * e2[2]
    det = d11 * d22 - d12 * d12
    if det <= 0.0:
        return np.nan
    b1 = (d22 * d1 - d12 * d2) / det
    b2 = (d11 * d2 - d12 * d1) / det
    slack = margin / np.sqrt(min(d11, d22))
    if b1 < -slack or b2 < -slack or b1 + b2 > 1.0 + slack:
        return np.nan
    return s


@njit
def _face_corners(faces, V, F, R, t):
    """(3k, 3) corners of ``faces`` of mesh (V, F), mapped by (R, t)."""
    corners = np.empty((3 * faces.shape[0], 3))
    for i in range(faces.shape[0]):
        for c in range(3):
            x = _corner(V, F, faces[i], c, R, t)
            corners[3 * i + c, 0], corners[3 * i + c, 1], corners[3 * i + c, 2] = x
    return corners


@njit
def _vertex_face_points(faces_a, faces_b, Va, Fa, Vb, Fb, Rab, tab, u, depth, band):
    """Vertex-face contacts of a region (thesis 5.2): corners of one side's region faces
    that lie inside the other side's region faces, touching or at most ``depth + band`` deep
    along u (a corner short of the face is no contact: it would get restitution it has not
    earned). A corner within ``band`` of a face's edge counts as inside: where two boxes'
    edges nearly coincide, the corner of their overlap is such a corner.

    Returns points (q, 3) in A's frame, midway between the corner and the face it is
    pressed into, and their [face of A, face of B] pairs.
    """
    corners_a = _face_corners(faces_a, Va, Fa, np.eye(3), np.zeros(3))
    corners_b = _face_corners(faces_b, Vb, Fb, Rab, tab)
    capacity = corners_a.shape[0] + corners_b.shape[0]
    points = np.empty((capacity, 3))
    pairs = np.empty((capacity, 2), np.int64)
    found = 0
    for side in range(2):
        own = corners_a if side == 0 else corners_b
        other = corners_b if side == 0 else corners_a
        sign = 1.0 if side == 0 else -1.0
        direction = (sign * u[0], sign * u[1], sign * u[2])
        for k in range(own.shape[0]):
            p = own[k]
            for t in range(other.shape[0] // 3):
                s = _project_along(p, direction, other, t, band)
                if s == s and -1e-9 * band <= s <= depth + band:
                    for a in range(3):
                        points[found, a] = p[a] + 0.5 * s * direction[a]
                    face_own = faces_a[k // 3] if side == 0 else faces_b[k // 3]
                    face_other = faces_b[t] if side == 0 else faces_a[t]
                    pairs[found, 0] = face_own if side == 0 else face_other
                    pairs[found, 1] = face_other if side == 0 else face_own
                    found += 1
                    break
    return points[:found], pairs[:found]


@njit
def region_manifolds(
    points, faces, point_region, tri_pairs, region, region_normal, region_depth, tolerance,
    Va, Fa, Vb, Fb, Rab, tab,
):  # fmt: skip
    """Per region: crossing points plus vertex-face points, clustered, then at most four
    corners; every contact takes the region's normal and depth."""
    out_points = np.empty((0, 3))
    out_faces = np.empty((0, 2), np.int64)
    out_normals = np.empty((0, 3))
    out_depths = np.empty(0)
    for g in range(region_normal.shape[0]):
        members = np.flatnonzero(point_region == g)
        in_region = region == g
        vertex_points, vertex_faces = _vertex_face_points(
            unique_sorted(tri_pairs[in_region, 0]), unique_sorted(tri_pairs[in_region, 1]),
            Va, Fa, Vb, Fb, Rab, tab, region_normal[g], region_depth[g], tolerance,
        )  # fmt: skip
        candidates = np.concatenate((points[members], vertex_points))
        candidate_faces = np.concatenate((faces[members], vertex_faces))
        count = candidates.shape[0]
        if count == 0:
            continue
        normals = np.empty((count, 3))
        depths = np.empty(count)
        for r in range(count):
            normals[r, 0], normals[r, 1], normals[r, 2] = (
                region_normal[g, 0],
                region_normal[g, 1],
                region_normal[g, 2],
            )
            depths[r] = region_depth[g]
        pts, nrm, dep, fcs = reduce_contacts(
            candidates, normals, depths, candidate_faces, tolerance
        )
        keep = _manifold_corners(pts, region_normal[g])
        out_points = np.concatenate((out_points, pts[keep]))
        out_normals = np.concatenate((out_normals, nrm[keep]))
        out_depths = np.concatenate((out_depths, dep[keep]))
        out_faces = np.concatenate((out_faces, fcs[keep]))
    return out_points, out_normals, out_depths, out_faces
