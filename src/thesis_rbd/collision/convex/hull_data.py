"""Convex hulls as polyhedra in flat arrays: what the convex narrow phase walks.

A closed mesh whose every vertex lies on its convex hull (within a tolerance relative to the
mesh's size) and whose volume is the hull's is convex: it collides as that hull. The hull
comes from qhull (``scipy.spatial.ConvexHull``); its triangles are merged into polygon faces
wherever neighbouring triangles lie in one plane to round-off, so a box is 6 quads with one
plane each, not 12 triangles: fewer separating axes, and whole faces to clip for a manifold.

Per hull the convex narrow phase needs

* vertices, and for each the neighbouring vertices (hill-climbing support search) and the
  faces around it (the incident face next to a support vertex);
* faces as counter-clockwise vertex loops seen from outside, with one plane each;
* unique edges as vertex pairs with the two faces beside them: the two face normals are the
  edge's arc on the Gauss map, which prunes edge-pair axes.

:class:`HullSet` concatenates the hulls of a world's convex meshes into flat arrays with
offsets, like ``GeometrySet`` does for trees.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull as _Qhull
from scipy.spatial import QhullError

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.convex.box import box_frame
from thesis_rbd.geometry.width import hull_thickness

__all__ = [
    "CONVEXITY_TOLERANCE",
    "ConvexHull",
    "HullFields",
    "HullSet",
    "convex_hull",
    "is_convex",
    "unpack_hulls",
]

# A vertex may lie this far inside its hull, and the mesh's volume this far below the hull's,
# relative to the mesh's size (its bounding-box diagonal, or its cube): float32 exports of
# convex shapes stay convex.
CONVEXITY_TOLERANCE = 1e-7
# Neighbouring hull triangles are one polygon face if each lies in the other's plane to this
# fraction of the size: round-off only, so a face's plane is off none of its vertices by more.
_COPLANAR_TOLERANCE = 1e-12


@dataclass(frozen=True)
class ConvexHull:
    """One convex polyhedron, in its mesh's frame.

    Attributes
    ----------
    vertices : (v, 3) float64
    neighbor_start : (v + 1,) int64, neighbors and neighbor_edges : (2e,) int64
        Vertex k's neighbours are ``neighbors[neighbor_start[k]:neighbor_start[k + 1]]``,
        joined to it by the edges ``neighbor_edges[...]`` of the same rows.
    vertex_face_start : (v + 1,) int64 and vertex_faces : (l,) int64
        The faces around vertex k, likewise.
    loop_start : (f + 1,) int64 and loops : (l,) int64
        Face k's vertices, counter-clockwise seen from outside.
    planes : (f, 4) float64
        Face k's outward unit normal and offset d: the plane n.x = d.
    edges : (e, 2) int64
        Vertex pairs [tail, head], each edge once.
    edge_faces : (e, 2) int64
        [face on whose loop tail -> head runs, the face on the other side].
    centroid : (3,) float64
        Mean of the vertices, an interior point.
    size : float
        Largest distance of a vertex from ``centroid``: the length tolerances scale with.
    thickness : float
        Least width over the face normals (``geometry.width.hull_thickness``): the length
        the speculative contact margin scales with.
    """

    vertices: np.ndarray
    neighbor_start: np.ndarray
    neighbors: np.ndarray
    neighbor_edges: np.ndarray
    vertex_face_start: np.ndarray
    vertex_faces: np.ndarray
    loop_start: np.ndarray
    loops: np.ndarray
    planes: np.ndarray
    edges: np.ndarray
    edge_faces: np.ndarray
    centroid: np.ndarray
    size: float
    thickness: float


def _qhull(points: np.ndarray):
    try:
        return _Qhull(points)
    except QhullError:
        return None  # flat or degenerate: no volume hull


def _signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def is_convex(mesh, tolerance: float = CONVEXITY_TOLERANCE) -> bool:
    """Whether a mesh is a convex polyhedron: closed, consistently oriented, outward, every
    vertex on its convex hull and its volume the hull's, to ``tolerance`` of its size."""
    if not (mesh.is_closed and mesh.is_consistently_oriented) or len(mesh.degenerate_faces):
        return False
    vertices = mesh.vertices
    hull = _qhull(vertices)
    if hull is None:
        return False
    size = mesh.scale
    # qhull's equations are outward unit normals n and offsets e with n.x + e <= 0 inside
    gap = -(vertices @ hull.equations[:, :3].T + hull.equations[:, 3]).max(axis=1)
    if gap.max() > tolerance * size:
        return False
    return abs(_signed_volume(vertices, mesh.faces) - hull.volume) <= tolerance * size**3


@njit
def _chain_loops(group_of_edge, tails, heads, vertex_count):
    """Boundary edges of each polygon chained into a loop.

    Parameters
    ----------
    group_of_edge, tails, heads : (b,) int64
        Each directed boundary edge tail -> head and the polygon it bounds, sorted by group.

    Returns
    -------
    loops : (b,) int64
        Vertices of each polygon in loop order, polygons in group order.
    """
    b = tails.shape[0]
    next_edge = np.full(b, -1, np.int64)
    start_of = np.full(vertex_count, -1, np.int64)
    loops = np.empty(b, np.int64)
    first = 0
    while first < b:
        last = first
        while last < b and group_of_edge[last] == group_of_edge[first]:
            last += 1
        for e in range(first, last):
            start_of[tails[e]] = e
        for e in range(first, last):
            next_edge[e] = start_of[heads[e]]
        e = first
        for k in range(first, last):
            loops[k] = tails[e]
            e = next_edge[e]
        for e in range(first, last):
            start_of[tails[e]] = -1
        first = last
    return loops


def _csr(keys: np.ndarray, values: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    order = np.argsort(keys, kind="stable")
    start = np.zeros(count + 1, np.int64)
    np.cumsum(np.bincount(keys, minlength=count), out=start[1:])
    return start, values[order].astype(np.int64)


def convex_hull(mesh) -> ConvexHull:
    """The polygon-faced convex hull of a mesh's vertices, in the mesh frame.

    Raises
    ------
    ValueError
        If the vertices span no volume.
    """
    hull = _qhull(mesh.vertices)
    if hull is None:
        raise ValueError("the mesh's vertices span no volume: it has no convex hull")
    used = np.unique(hull.simplices)
    vertices = np.ascontiguousarray(mesh.vertices[used])
    renumber = np.full(len(mesh.vertices), -1, np.int64)
    renumber[used] = np.arange(len(used))
    triangles = renumber[hull.simplices]
    normals = hull.equations[:, :3]
    # qhull's simplices are not consistently wound: turn each counter-clockwise from outside
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), normals) < 0
    triangles[flip] = triangles[flip][:, [0, 2, 1]]
    offsets = -hull.equations[:, 3]
    centroid = vertices.mean(axis=0)
    size = float(np.linalg.norm(vertices - centroid, axis=1).max())

    # merge neighbouring triangles lying in each other's plane; qhull's neighbors[i, k] is
    # the triangle across the edge opposite simplices[i, k]
    simplices = renumber[hull.simplices]
    t = len(triangles)
    i = np.repeat(np.arange(t), 3)
    j = hull.neighbors.reshape(-1)
    far_of_i = simplices.reshape(-1)
    far_of_j = simplices[j][hull.neighbors[j] == i[:, None]]
    gap_j = np.abs(np.einsum("ij,ij->i", normals[i], vertices[far_of_j]) - offsets[i])
    gap_i = np.abs(np.einsum("ij,ij->i", normals[j], vertices[far_of_i]) - offsets[j])
    coplanar = (np.maximum(gap_i, gap_j) <= _COPLANAR_TOLERANCE * size) & (
        np.einsum("ij,ij->i", normals[i], normals[j]) > 0
    )
    graph = coo_matrix((np.ones(coplanar.sum()), (i[coplanar], j[coplanar])), shape=(t, t))
    face_count, group = connected_components(graph, directed=False)

    # boundary of each polygon: directed triangle edges whose reverse lies in another polygon
    tails = triangles.reshape(-1)
    heads = triangles[:, [1, 2, 0]].reshape(-1)
    edge_group = np.repeat(group, 3)
    nv = np.int64(len(vertices))
    key = tails * nv + heads
    order = np.argsort(key)
    other = order[np.searchsorted(key[order], heads * nv + tails)]
    boundary = edge_group[other] != edge_group
    by_group = np.argsort(edge_group[boundary], kind="stable")
    bt = tails[boundary][by_group]
    bh = heads[boundary][by_group]
    bg = edge_group[boundary][by_group]
    loops = _chain_loops(bg, bt, bh, len(vertices))
    loop_start = np.zeros(face_count + 1, np.int64)
    np.cumsum(np.bincount(bg, minlength=face_count), out=loop_start[1:])
    loop_face = np.repeat(np.arange(face_count), np.diff(loop_start))

    # each polygon's plane: area-weighted normal of its triangles, through its outermost vertex
    area_normal = np.cross(
        vertices[triangles[:, 1]] - vertices[triangles[:, 0]],
        vertices[triangles[:, 2]] - vertices[triangles[:, 0]],
    )
    plane_normal = np.zeros((face_count, 3))
    np.add.at(plane_normal, group, area_normal)
    plane_normal /= np.linalg.norm(plane_normal, axis=1)[:, None]
    plane_offset = np.full(face_count, -np.inf)
    np.maximum.at(
        plane_offset, loop_face, np.einsum("ij,ij->i", plane_normal[loop_face], vertices[loops])
    )
    planes = np.column_stack([plane_normal, plane_offset])

    # unique edges: each boundary edge once (tail < head), with the polygon on each side
    once = bt < bh
    edges = np.column_stack([bt[once], bh[once]])
    boundary_key = bt * nv + bh
    border = np.argsort(boundary_key)
    twin = border[np.searchsorted(boundary_key[border], bh[once] * nv + bt[once])]
    edge_faces = np.column_stack([bg[once], bg[twin]])

    ends = np.concatenate([edges[:, 0], edges[:, 1]])
    other_ends = np.concatenate([edges[:, 1], edges[:, 0]])
    neighbor_start, neighbors = _csr(ends, other_ends, len(vertices))
    _, neighbor_edges = _csr(ends, np.tile(np.arange(len(edges)), 2), len(vertices))
    vertex_face_start, vertex_faces = _csr(loops, loop_face, len(vertices))
    return ConvexHull(
        vertices=vertices,
        neighbor_start=neighbor_start,
        neighbors=neighbors,
        neighbor_edges=neighbor_edges,
        vertex_face_start=vertex_face_start,
        vertex_faces=vertex_faces,
        loop_start=loop_start,
        loops=loops.astype(np.int64),
        planes=np.ascontiguousarray(planes),
        edges=np.ascontiguousarray(edges, dtype=np.int64),
        edge_faces=np.ascontiguousarray(edge_faces, dtype=np.int64),
        centroid=centroid,
        size=size,
        thickness=hull_thickness(vertices),
    )


class HullSet:
    """The convex hulls of a world's convex meshes, concatenated into flat arrays.

    Hull k owns rows ``vertex_start[k]:vertex_start[k + 1]`` of the vertex arrays, and likewise
    for faces and edges; every index stored inside a hull's rows (loops, neighbours, edges,
    edge faces, vertex faces) is local to that hull. The CSR offsets ``neighbor_start`` and
    ``vertex_face_start`` (indexed by global vertex row, one extra entry at the end) and
    ``loop_start`` (by global face row) point into the concatenated lists.

    Attributes
    ----------
    hulls : list of ConvexHull
    vertex_start, face_start, edge_start : (h + 1,) int64
    vertices : (V, 3) float64
    neighbor_start : (V + 1,) int64, neighbors and neighbor_edges : (N,) int64
    vertex_face_start : (V + 1,) int64 and vertex_faces : (L,) int64
    planes : (F, 4) float64 and loop_start : (F + 1,) int64 and loops : (L,) int64
    edges, edge_faces : (E, 2) int64
    edge_arcs : (E, 3) float64
        n2 x n1 for the normals n1, n2 of an edge's two faces: the normal of its Gauss arc.
    centroids : (h, 3) float64, sizes : (h,) float64 and thicknesses : (h,) float64
    box_frames : (h, 5, 3) float64 and box_features : (h, 18) int64
        Each hull's box axes, centre and half extents and its faces and edges by box axis
        (``box``); features -1 for a hull that is not a box.
    """

    def __init__(self, tolerance: float = CONVEXITY_TOLERANCE, find_boxes: bool = True):
        self.tolerance = tolerance
        # False leaves every hull to the general convex path (the closed form's reference)
        self.find_boxes = find_boxes
        self.hulls: list[ConvexHull] = []
        # each hull's edge arcs and box frame, worked out once when it is added: the set is
        # packed again after every new hull, and working them out for every hull at every
        # pack made adding n bodies O(n^2) box fits (18 s for 300 boxes)
        self._arcs: list[np.ndarray] = []
        self._boxes: list = []
        self._index: dict[int, int] = {}
        self._meshes: list = []  # held, so that no other mesh can take a known one's id
        self._pack()

    def hull_of(self, mesh) -> int:
        """Index of ``mesh``'s hull, built on first use; -1 if the mesh is not convex.

        Meshes are told apart by identity, as ``GeometrySet`` does.
        """
        key = id(mesh)
        if key not in self._index:
            self._meshes.append(mesh)
            if is_convex(mesh, self.tolerance):
                self._index[key] = len(self.hulls)
                hull = convex_hull(mesh)
                self.hulls.append(hull)
                self._arcs.append(
                    np.cross(
                        hull.planes[hull.edge_faces[:, 1], :3],
                        hull.planes[hull.edge_faces[:, 0], :3],
                    )
                )
                self._boxes.append(
                    box_frame(hull.vertices, hull.planes, hull.edges, hull.size)
                    if self.find_boxes
                    else None
                )
                self._pack()
            else:
                self._index[key] = -1
        return self._index[key]

    def _pack(self) -> None:
        hulls = self.hulls

        def offsets(sizes):
            return np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)]).astype(np.int64)

        def stacked(arrays, shape, dtype):
            return np.ascontiguousarray(
                np.concatenate(arrays) if arrays else np.zeros((0, *shape), dtype), dtype=dtype
            )

        def csr(starts, lists):
            shift = offsets([len(values) for values in lists])
            rows = [start[:-1] + s for start, s in zip(starts, shift, strict=False)] + [shift[-1:]]
            return stacked(rows, (), np.int64), stacked(lists, (), np.int64)

        self.vertex_start = offsets([len(h.vertices) for h in hulls])
        self.face_start = offsets([len(h.planes) for h in hulls])
        self.edge_start = offsets([len(h.edges) for h in hulls])
        self.vertices = stacked([h.vertices for h in hulls], (3,), np.float64)
        self.neighbor_start, self.neighbors = csr(
            [h.neighbor_start for h in hulls], [h.neighbors for h in hulls]
        )
        _, self.neighbor_edges = csr(
            [h.neighbor_start for h in hulls], [h.neighbor_edges for h in hulls]
        )
        self.vertex_face_start, self.vertex_faces = csr(
            [h.vertex_face_start for h in hulls], [h.vertex_faces for h in hulls]
        )
        self.loop_start, self.loops = csr([h.loop_start for h in hulls], [h.loops for h in hulls])
        self.planes = stacked([h.planes for h in hulls], (4,), np.float64)
        self.edges = stacked([h.edges for h in hulls], (2,), np.int64)
        self.edge_faces = stacked([h.edge_faces for h in hulls], (2,), np.int64)
        self.edge_arcs = stacked(self._arcs, (3,), np.float64)
        self.centroids = stacked([h.centroid[None] for h in hulls], (3,), np.float64)
        self.sizes = np.array([h.size for h in hulls], dtype=np.float64)
        self.thicknesses = np.array([h.thickness for h in hulls], dtype=np.float64)
        boxes = self._boxes
        self.box_frames = stacked(
            [np.zeros((1, 5, 3)) if box is None else box[0][None] for box in boxes],
            (5, 3),
            np.float64,
        )
        self.box_features = stacked(
            [np.full((1, 18), -1, np.int64) if box is None else box[1][None] for box in boxes],
            (18,),
            np.int64,
        )
        loops_per_face = np.diff(self.loop_start)
        self.longest_loop = int(loops_per_face.max()) if len(loops_per_face) else 0
        self._packed = _pack_fields(self)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The hull set packed for the convex kernels: (ints, floats), two flat arrays that
        ``unpack_hulls`` turns back into the fields (one argument each would cost every
        kernel call a conversion per field: more than a small scene's whole narrow phase)."""
        return self._packed


_FIELDS = (
    "vertex_start", "vertices", "neighbor_start", "neighbors", "neighbor_edges",
    "vertex_face_start", "vertex_faces", "face_start", "planes", "loop_start", "loops",
    "edge_start", "edges", "edge_faces", "edge_arcs", "centroids", "sizes", "thicknesses",
    "box_frames", "box_features",
)  # fmt: skip
# The fields of a hull set as the convex kernels read them, by name (``H.planes``): a numba
# named tuple of views into the packed arrays, so naming a field costs nothing at run time.
HullFields = namedtuple("HullFields", _FIELDS)
# Header of the packed ints: per field, its offset into its own array (ints or floats) and
# up to three dimensions
_HEADER = 4 * len(_FIELDS)


def _pack_fields(hulls: HullSet) -> tuple[np.ndarray, np.ndarray]:
    """(ints, floats): ``_HEADER`` ints describing the fields, then the int fields' values;
    the float fields' values."""
    header = np.zeros(_HEADER, np.int64)
    parts: dict[type, list[np.ndarray]] = {np.int64: [], np.float64: []}
    used = {np.int64: _HEADER, np.float64: 0}
    for k, name in enumerate(_FIELDS):
        value = getattr(hulls, name)
        kind = np.int64 if value.dtype.kind == "i" else np.float64
        header[4 * k] = used[kind]
        header[4 * k + 1 : 4 * k + 1 + value.ndim] = value.shape
        parts[kind].append(value.ravel().astype(kind))
        used[kind] += value.size
    ints = np.concatenate([header, *parts[np.int64]])
    floats = np.concatenate([np.zeros(0), *parts[np.float64]])
    return ints, floats


@njit
def _int_field(ints, k):
    o, n = ints[4 * k], ints[4 * k + 1]
    return ints[o : o + n]


@njit
def _int_rows(ints, k):
    o, n, m = ints[4 * k], ints[4 * k + 1], ints[4 * k + 2]
    return ints[o : o + n * m].reshape((n, m))


@njit
def _float_field(ints, floats, k):
    o, n = ints[4 * k], ints[4 * k + 1]
    return floats[o : o + n]


@njit
def _float_rows(ints, floats, k):
    o, n, m = ints[4 * k], ints[4 * k + 1], ints[4 * k + 2]
    return floats[o : o + n * m].reshape((n, m))


@njit
def _float_blocks(ints, floats, k):
    o, n, m, r = ints[4 * k], ints[4 * k + 1], ints[4 * k + 2], ints[4 * k + 3]
    return floats[o : o + n * m * r].reshape((n, m, r))


@njit
def unpack_hulls(packed):
    """The fields of a packed hull set (``HullSet.arrays()``), as views: the ``HullFields``
    the convex kernels read (``H.vertex_start``, ``H.planes``, ...)."""
    ints, floats = packed
    return HullFields(
        _int_field(ints, 0), _float_rows(ints, floats, 1), _int_field(ints, 2),
        _int_field(ints, 3), _int_field(ints, 4), _int_field(ints, 5), _int_field(ints, 6),
        _int_field(ints, 7), _float_rows(ints, floats, 8), _int_field(ints, 9),
        _int_field(ints, 10), _int_field(ints, 11), _int_rows(ints, 12), _int_rows(ints, 13),
        _float_rows(ints, floats, 14), _float_rows(ints, floats, 15),
        _float_field(ints, floats, 16), _float_field(ints, floats, 17),
        _float_blocks(ints, floats, 18), _int_rows(ints, 19),
    )  # fmt: skip
