"""Narrow phase for a whole world: contacts of every candidate body pair in one kernel call.

``collide`` answers one query from Python; a simulation step asks for hundreds, so the
trees of all distinct meshes are concatenated once into a :class:`GeometrySet` (flat arrays
plus offsets, the layout of pynndescent's flat trees) and :func:`contacts_for_pairs` walks the
candidate pairs inside numba, calling the same traversal and contact kernels as ``collide``,
then turns each pair's intersection points into a contact manifold (``manifold.py``). Bodies
sharing a mesh share its tree.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.contact_report import compute_contacts
from thesis_rbd.collision.mesh.manifold import region_manifolds, region_normals, region_of_faces
from thesis_rbd.collision.mesh.obbtree import OBBTree
from thesis_rbd.collision.mesh.packed import mesh_vertices
from thesis_rbd.collision.queries.collide import MERGE_FRACTION, traverse
from thesis_rbd.spatial.quaternion import to_matrix_into

__all__ = ["GeometrySet", "any_intersection", "contacts_for_pairs"]


class GeometrySet:
    """The OBBTrees of a world's distinct meshes, concatenated into flat arrays.

    The trees are built when the flat arrays are first asked for, not when a mesh is added:
    a scene whose pairs all go through the convex path never builds one (nor compiles the
    tree builder).

    Attributes
    ----------
    meshes : list of TriangleMesh
        One per distinct mesh, in order of first use.
    local_lower, local_upper : (g, 3) float64
        Each mesh's axis-aligned box in its own frame.
    trees : list of OBBTree
        One per distinct mesh (built on first access).
    packed_start, face_start : (g + 1,) int64
        Geometry k owns rows ``start[k]:start[k + 1]`` of the packed and face arrays.
    packed : (rows, 3) float64
        The trees' packed query arrays (:mod:`.packed`: boxes and mesh), concatenated.
    faces : (f, 3) int64
        The meshes' faces, concatenated (each indexes its own mesh's vertices).
    merge_tolerance : (g,) float64
        Contacts of a pair closer than the larger of the two meshes' values are merged.
    """

    def __init__(self, merge_fraction: float = 1e-3):
        self.merge_fraction = merge_fraction
        self.meshes: list = []
        self._trees: list[OBBTree] = []
        self._index: dict[int, int] = {}
        self.local_lower = np.zeros((0, 3))
        self.local_upper = np.zeros((0, 3))
        self._arrays = None

    def geometry_of(self, mesh) -> int:
        """Index of ``mesh`` (identity, not equality), registering it on first use."""
        key = id(mesh)
        if key not in self._index:
            self._index[key] = len(self.meshes)
            self.meshes.append(mesh)
            bounds = np.asarray(mesh.bounds, dtype=np.float64)
            self.local_lower = np.vstack([self.local_lower, bounds[:1]])
            self.local_upper = np.vstack([self.local_upper, bounds[1:]])
            self._arrays = None
        return self._index[key]

    @property
    def trees(self) -> list[OBBTree]:
        """The meshes' trees, building those not built yet."""
        for mesh in self.meshes[len(self._trees) :]:
            self._trees.append(OBBTree(mesh))
        return self._trees

    def arrays(self) -> tuple:
        """The flat arrays in the order ``contacts_for_pairs`` takes them."""
        if self._arrays is None:
            self._arrays = self._pack()
        return self._arrays

    def _pack(self) -> tuple:
        trees = self.trees

        def offsets(sizes):
            return np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)]).astype(np.int64)

        def stacked(arrays, shape, dtype):
            return np.ascontiguousarray(
                np.concatenate(arrays) if arrays else np.zeros((0, *shape), dtype), dtype=dtype
            )

        packed = [t.query_array() for t in trees]
        self.packed_start = offsets([len(p) for p in packed])
        self.face_start = offsets([len(t.mesh.faces) for t in trees])
        self.packed = stacked(packed, (3,), np.float64)
        self.faces = stacked([t.mesh.faces for t in trees], (3,), np.int64)
        self.merge_tolerance = np.array(
            [max(self.merge_fraction, MERGE_FRACTION) * t.scale for t in trees], dtype=np.float64
        )
        return (self.packed_start, self.face_start, self.packed, self.faces, self.merge_tolerance)


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
    packed_start, face_start, packed, faces, merge_tolerance = geometry_arrays
    results = []
    stats = np.zeros(3, np.int64)
    total = 0
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        gi, gj = geometry[i], geometry[j]
        Pi = packed[packed_start[gi] : packed_start[gi + 1]]
        Pj = packed[packed_start[gj] : packed_start[gj + 1]]
        Vi = mesh_vertices(Pi)
        Vj = mesh_vertices(Pj)
        Fi = faces[face_start[gi] : face_start[gi + 1]]
        Fj = faces[face_start[gj] : face_start[gj + 1]]
        Ti = _mesh_to_world(i, position, orientation, center_of_mass_local)
        Tj = _mesh_to_world(j, position, orientation, center_of_mass_local)
        tri_pairs, bv, box, tri = traverse(False, Pi, Pj, Ti, Tj)
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
        pts, nrm, dep, fcs = region_manifolds(
            pts, fcs, region_of_faces(tri_pairs, region, fcs), tri_pairs, region,
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
    packed_start, _, packed, _, _ = geometry_arrays
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        gi, gj = geometry[i], geometry[j]
        tri_pairs, _, _, _ = traverse(
            True,
            packed[packed_start[gi] : packed_start[gi + 1]],
            packed[packed_start[gj] : packed_start[gj + 1]],
            _mesh_to_world(i, position, orientation, center_of_mass_local),
            _mesh_to_world(j, position, orientation, center_of_mass_local),
        )
        if tri_pairs.shape[0] > 0:
            return True
    return False
