"""Narrow phase for a whole world: contacts of every candidate body pair in one kernel call.

``collide`` answers one query from Python; a simulation step asks for hundreds, so the
trees of all distinct meshes are concatenated once into a :class:`GeometrySet` (flat arrays
plus offsets, the layout of pynndescent's flat trees) and :func:`contacts_for_pairs` walks the
candidate pairs inside numba, calling the same traversal and contact kernels as ``collide``.
Bodies sharing a mesh share its tree.

Dynamics needs more from a contact than ``collide``'s per-triangle-pair answer, and gets it
here in two steps:

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

from thesis_rbd._jit import njit
from thesis_rbd._union_find import find_root, join
from thesis_rbd.collision.collide import MERGE_FRACTION, traverse
from thesis_rbd.collision.contacts import cluster_points, compute_contacts
from thesis_rbd.collision.obbtree import OBBTree
from thesis_rbd.spatial.quaternion import to_matrix_into

__all__ = ["GeometrySet", "any_intersection", "contacts_for_pairs", "reduce_contacts"]


class GeometrySet:
    """The OBBTrees of a world's distinct meshes, concatenated into flat arrays.

    Attributes
    ----------
    trees : list of OBBTree
        One per distinct mesh, in order of first use.
    node_start, vertex_start, face_start : (g + 1,) int64
        Geometry k owns rows ``start[k]:start[k + 1]`` of the node, vertex and face arrays.
    centers, rotations, half_extents, children : concatenated node arrays (float64, int32)
    roots, leafless, depths : (g,) per-tree root code, variant and depth
    vertices, faces : concatenated mesh arrays (faces index their own mesh's vertices)
    merge_tolerance : (g,) float64
        Contacts of a pair closer than the larger of the two meshes' values are merged.
    """

    def __init__(self, merge_fraction: float = 1e-3):
        self.merge_fraction = merge_fraction
        self.trees: list[OBBTree] = []
        self._index: dict[int, int] = {}
        self._pack()

    def geometry_of(self, mesh) -> int:
        """Index of ``mesh``'s tree, building it on first use (identity, not equality)."""
        key = id(mesh)
        if key not in self._index:
            self._index[key] = len(self.trees)
            self.trees.append(OBBTree(mesh))
            self._pack()
        return self._index[key]

    def _pack(self) -> None:
        trees = self.trees

        def offsets(sizes):
            return np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)]).astype(np.int64)

        def stacked(arrays, shape, dtype):
            return np.ascontiguousarray(
                np.concatenate(arrays) if arrays else np.zeros((0, *shape), dtype), dtype=dtype
            )

        self.node_start = offsets([t.node_count for t in trees])
        self.vertex_start = offsets([len(t.mesh.vertices) for t in trees])
        self.face_start = offsets([len(t.mesh.faces) for t in trees])
        self.centers = stacked([t.centers for t in trees], (3,), np.float64)
        self.rotations = stacked([t.rotations for t in trees], (3, 3), np.float64)
        self.half_extents = stacked([t.half_extents for t in trees], (3,), np.float64)
        self.children = stacked([t.children for t in trees], (2,), np.int32)
        self.roots = np.array([t.root for t in trees], dtype=np.int64)
        self.leafless = np.array([t.leafless for t in trees], dtype=np.bool_)
        self.depths = np.array([t.depth for t in trees], dtype=np.int64)
        self.vertices = stacked([t.mesh.vertices for t in trees], (3,), np.float64)
        self.faces = stacked([t.mesh.faces for t in trees], (3,), np.int64)
        self.merge_tolerance = np.array(
            [max(self.merge_fraction, MERGE_FRACTION) * t.scale for t in trees], dtype=np.float64
        )
        self.local_lower = stacked([t.mesh.bounds[:1] for t in trees], (3,), np.float64)
        self.local_upper = stacked([t.mesh.bounds[1:] for t in trees], (3,), np.float64)

    def arrays(self) -> tuple:
        """The flat arrays in the order ``contacts_for_pairs`` takes them."""
        return (
            self.node_start,
            self.vertex_start,
            self.face_start,
            self.centers,
            self.rotations,
            self.half_extents,
            self.children,
            self.roots,
            self.leafless,
            self.depths,
            self.vertices,
            self.faces,
            self.merge_tolerance,
        )


@njit
def _region_of_faces(tri_pairs, region, faces):
    """Region of each contact, looked up by its [face of A, face of B] pair."""
    width = tri_pairs[:, 1].max() + 1
    keys = tri_pairs[:, 0] * width + tri_pairs[:, 1]
    order = np.argsort(keys)
    sorted_keys = keys[order]
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
            out_normals[k] = normals[i]
            out_faces[k] = faces[i]
    for k in range(clusters):
        out_points[k] /= members[k]
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
        order = np.argsort(tri_pairs[:, column], kind="mergesort")
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
        faces_a = np.unique(tri_pairs[region == g, 0])
        faces_b = np.unique(tri_pairs[region == g, 1])
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


@njit(inline="always")
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
def _region_manifolds(
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
            np.unique(tri_pairs[in_region, 0]), np.unique(tri_pairs[in_region, 1]),
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
            normals[r] = region_normal[g]
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


@njit
def _mesh_to_world(i, position, orientation, center_of_mass_local):
    """(4, 4) transform of body i's mesh frame: x = R (p - c) + position."""
    T = np.eye(4)
    R = np.empty((3, 3))
    to_matrix_into(orientation[i], R)
    for a in range(3):
        for b in range(3):
            T[a, b] = R[a, b]
        T[a, 3] = position[i, a] - (
            R[a, 0] * center_of_mass_local[i, 0]
            + R[a, 1] * center_of_mass_local[i, 1]
            + R[a, 2] * center_of_mass_local[i, 2]
        )
    return T


@njit
def contacts_for_pairs(
    pairs, geometry, geometry_arrays, position, orientation, center_of_mass_local
):
    """Contacts of every candidate body pair, world frame.

    Parameters
    ----------
    pairs : (p, 2) int64
        Candidate body pairs [i, j].
    geometry : (n,) int64
        Geometry (tree) index of each body.
    geometry_arrays : tuple
        ``GeometrySet.arrays()``.
    position, orientation, center_of_mass_local : body state arrays (n, 3), (n, 4), (n, 3)

    Returns
    -------
    body_a, body_b : (c,) int64
        The pair of each contact (a = i, b = j).
    points, normals : (c, 3) float64
        World contact points and unit normals from b towards a.
    depths : (c,) float64
        Penetration depths >= 0.
    faces : (c, 2) int64
        [face of a, face of b].
    stats : (3,) int64
        Box tests, triangle-box tests and triangle tests summed over all pairs.
    """
    (
        node_start, vertex_start, face_start, centers, rotations, halves, children,
        roots, leafless, depths, vertices, faces, merge_tolerance,
    ) = geometry_arrays  # fmt: skip
    results = []
    stats = np.zeros(3, np.int64)
    total = 0
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        gi, gj = geometry[i], geometry[j]
        ni0, ni1 = node_start[gi], node_start[gi + 1]
        nj0, nj1 = node_start[gj], node_start[gj + 1]
        Vi = vertices[vertex_start[gi] : vertex_start[gi + 1]]
        Vj = vertices[vertex_start[gj] : vertex_start[gj + 1]]
        Fi = faces[face_start[gi] : face_start[gi + 1]]
        Fj = faces[face_start[gj] : face_start[gj + 1]]
        Ti = _mesh_to_world(i, position, orientation, center_of_mass_local)
        Tj = _mesh_to_world(j, position, orientation, center_of_mass_local)
        tri_pairs, bv, box, tri = traverse(
            False,
            centers[ni0:ni1], rotations[ni0:ni1], halves[ni0:ni1], children[ni0:ni1],
            roots[gi], leafless[gi], Vi, Fi,
            centers[nj0:nj1], rotations[nj0:nj1], halves[nj0:nj1], children[nj0:nj1],
            roots[gj], leafless[gj], Vj, Fj,
            Ti, Tj, 2 * (depths[gi] + depths[gj]) + 8,
        )  # fmt: skip
        stats[0] += bv
        stats[1] += box
        stats[2] += tri
        if tri_pairs.shape[0] == 0:
            continue
        # B's mesh frame in A's: R_ab = R_a^T R_b, t_ab = R_a^T (t_b - t_a)
        Ri = np.ascontiguousarray(Ti[:3, :3].T)
        Rab = Ri @ np.ascontiguousarray(Tj[:3, :3])
        tab = Ri @ np.ascontiguousarray(Tj[:3, 3] - Ti[:3, 3])
        pts, _, _, fcs = compute_contacts(tri_pairs, Vi, Fi, Vj, Fj, Rab, tab)
        region, region_normal, region_depth = region_normals(tri_pairs, Vi, Fi, Vj, Fj, Rab, tab)
        pts, nrm, dep, fcs = _region_manifolds(
            pts, fcs, _region_of_faces(tri_pairs, region, fcs), tri_pairs, region,
            region_normal, region_depth, max(merge_tolerance[gi], merge_tolerance[gj]),
            Vi, Fi, Vj, Fj, Rab, tab,
        )  # fmt: skip
        k = dep.shape[0]
        world_points = np.empty((k, 3))
        world_normals = np.empty((k, 3))
        for r in range(k):
            for a in range(3):
                world_points[r, a] = Ti[a, 3] + (
                    Ti[a, 0] * pts[r, 0] + Ti[a, 1] * pts[r, 1] + Ti[a, 2] * pts[r, 2]
                )
                world_normals[r, a] = (
                    Ti[a, 0] * nrm[r, 0] + Ti[a, 1] * nrm[r, 1] + Ti[a, 2] * nrm[r, 2]
                )
        results.append((i, j, world_points, world_normals, dep, fcs))
        total += k

    body_a = np.empty(total, np.int64)
    body_b = np.empty(total, np.int64)
    points = np.empty((total, 3))
    normals = np.empty((total, 3))
    out_depths = np.empty(total)
    out_faces = np.empty((total, 2), np.int64)
    c = 0
    for i, j, wp, wn, dp, fc in results:
        k = dp.shape[0]
        body_a[c : c + k] = i
        body_b[c : c + k] = j
        points[c : c + k] = wp
        normals[c : c + k] = wn
        out_depths[c : c + k] = dp
        out_faces[c : c + k] = fc
        c += k
    return body_a, body_b, points, normals, out_depths, out_faces, stats


@njit
def any_intersection(pairs, geometry, geometry_arrays, position, orientation, center_of_mass_local):
    """True if any candidate body pair has an intersecting triangle pair (stops at the first).

    Same arguments as ``contacts_for_pairs``; the yes/no query of time-of-impact searches.
    """
    (
        node_start, vertex_start, face_start, centers, rotations, halves, children,
        roots, leafless, depths, vertices, faces, _,
    ) = geometry_arrays  # fmt: skip
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        gi, gj = geometry[i], geometry[j]
        ni0, ni1 = node_start[gi], node_start[gi + 1]
        nj0, nj1 = node_start[gj], node_start[gj + 1]
        tri_pairs, _, _, _ = traverse(
            True,
            centers[ni0:ni1], rotations[ni0:ni1], halves[ni0:ni1], children[ni0:ni1],
            roots[gi], leafless[gi],
            vertices[vertex_start[gi] : vertex_start[gi + 1]],
            faces[face_start[gi] : face_start[gi + 1]],
            centers[nj0:nj1], rotations[nj0:nj1], halves[nj0:nj1], children[nj0:nj1],
            roots[gj], leafless[gj],
            vertices[vertex_start[gj] : vertex_start[gj + 1]],
            faces[face_start[gj] : face_start[gj + 1]],
            _mesh_to_world(i, position, orientation, center_of_mass_local),
            _mesh_to_world(j, position, orientation, center_of_mass_local),
            2 * (depths[gi] + depths[gj]) + 8,
        )  # fmt: skip
        if tri_pairs.shape[0] > 0:
            return True
    return False
