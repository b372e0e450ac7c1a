"""Triangle meshes: the one validated geometry container of the package.

A :class:`TriangleMesh` owns two read-only arrays, ``vertices`` (n, 3) float64 and ``faces``
(m, 3) int64, checked once on construction so that no kernel downstream ever meets a NaN, an
out-of-range index or a wrongly shaped array. Everything else (areas, normals, topology) is
derived on demand and cached.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np

from thesis_rbd._validate import as_finite_array

__all__ = ["TriangleMesh", "load_mesh"]

# A face whose area is below this fraction of (mesh size)^2 is reported as degenerate: at that
# point its normal is numerical noise.
_DEGENERATE_AREA_FRACTION = 1e-14


class TriangleMesh:
    """A triangle mesh with validated, immutable arrays.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Vertex positions in the mesh (body) frame.
    faces : (m, 3) array_like of int
        Vertex indices of each triangle, counter-clockwise seen from outside for a closed mesh.

    Raises
    ------
    ValueError
        If an array has the wrong shape or dtype, holds a non-finite number, a face index is out
        of range, or the mesh has no vertices or no faces.

    Notes
    -----
    Degenerate faces (zero area, or a repeated vertex index) are allowed, since real meshes
    have them and collision queries must cope; they are listed in :attr:`degenerate_faces`.
    """

    def __init__(self, vertices, faces):
        vertices = as_finite_array(vertices, "vertices", shape=(None, 3))
        faces_in = np.asarray(faces)
        if faces_in.ndim != 2 or faces_in.shape[1] != 3:
            raise ValueError(f"faces must have shape (m, 3), got {faces_in.shape}")
        if faces_in.size and not np.issubdtype(faces_in.dtype, np.integer):
            # (text, objects: isfinite would raise TypeError on them)
            if (
                not np.issubdtype(faces_in.dtype, np.floating)
                or not np.all(np.isfinite(faces_in))
                or np.any(faces_in != np.round(faces_in))
            ):
                raise ValueError(
                    f"faces must hold integer vertex indices, got dtype {faces_in.dtype}"
                )
        faces_in = faces_in.astype(np.int64)
        if len(vertices) == 0:
            raise ValueError("mesh is empty: vertices has no rows")
        if len(faces_in) == 0:
            raise ValueError("mesh is empty: faces has no rows")
        bad = (faces_in < 0) | (faces_in >= len(vertices))
        if bad.any():
            row = int(np.argwhere(bad)[0, 0])
            raise ValueError(
                f"face {row} has vertex index {faces_in[row].tolist()} out of range "
                f"[0, {len(vertices)})"
            )
        self._vertices = np.ascontiguousarray(vertices)
        self._faces = np.ascontiguousarray(faces_in)
        self._vertices.flags.writeable = False
        self._faces.flags.writeable = False

    # ------------------------------------------------------------------ construction helpers
    @classmethod
    def from_trimesh(cls, mesh) -> TriangleMesh:
        """Build from a ``trimesh.Trimesh`` (its vertices and faces are copied)."""
        return cls(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces))

    def to_trimesh(self):
        """Return a ``trimesh.Trimesh`` copy (no vertex merging, no face removal)."""
        import trimesh

        return trimesh.Trimesh(self.vertices.copy(), self.faces.copy(), process=False)

    # ------------------------------------------------------------------ arrays
    @property
    def vertices(self) -> np.ndarray:
        """(n, 3) float64 read-only vertex positions in the mesh frame."""
        return self._vertices

    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int64 read-only vertex indices per triangle."""
        return self._faces

    @cached_property
    def triangles(self) -> np.ndarray:
        """(m, 3, 3) float64 corner positions per face."""
        tri = self._vertices[self._faces]
        tri.flags.writeable = False
        return tri

    @cached_property
    def face_cross(self) -> np.ndarray:
        """(m, 3) float64 ``(b - a) x (c - a)``: twice the area times the unit normal."""
        tri = self.triangles
        return np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])

    @cached_property
    def face_areas(self) -> np.ndarray:
        """(m,) float64 triangle areas."""
        return 0.5 * np.linalg.norm(self.face_cross, axis=1)

    @cached_property
    def face_normals(self) -> np.ndarray:
        """(m, 3) float64 unit normals by the right-hand rule; zero rows for degenerate faces."""
        length = 2.0 * self.face_areas
        normals = np.zeros_like(self.face_cross)
        ok = length > 0
        normals[ok] = self.face_cross[ok] / length[ok, None]
        return normals

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 axis-aligned lower and upper corners of the vertices."""
        return np.stack([self._vertices.min(axis=0), self._vertices.max(axis=0)])

    @property
    def scale(self) -> float:
        """Length of the bounding-box diagonal: the mesh's size for relative tolerances."""
        lo, hi = self.bounds
        return float(np.linalg.norm(hi - lo))

    @cached_property
    def degenerate_faces(self) -> np.ndarray:
        """(k,) int64 indices of faces with a repeated vertex or (near-)zero area."""
        f = self._faces
        repeated = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
        tiny = self.face_areas <= _DEGENERATE_AREA_FRACTION * max(self.scale, 1e-300) ** 2
        return np.flatnonzero(repeated | tiny)

    # ------------------------------------------------------------------ topology
    @cached_property
    def _edge_counts(self) -> tuple[np.ndarray, np.ndarray]:
        """Counts of each undirected edge and of each directed edge (codes as int64 keys)."""
        f = self._faces
        heads = f.reshape(-1)
        tails = f[:, [1, 2, 0]].reshape(-1)
        n = np.int64(len(self._vertices))
        directed = heads * n + tails
        undirected = np.minimum(heads, tails) * n + np.maximum(heads, tails)
        _, undirected_counts = np.unique(undirected, return_counts=True)
        _, directed_counts = np.unique(directed, return_counts=True)
        return undirected_counts, directed_counts

    @property
    def is_closed(self) -> bool:
        """True if every edge is shared by exactly two faces (a closed 2-manifold surface)."""
        undirected_counts, _ = self._edge_counts
        return bool(np.all(undirected_counts == 2))

    @property
    def is_consistently_oriented(self) -> bool:
        """True if no directed edge repeats, i.e. neighbouring faces wind the same way."""
        _, directed_counts = self._edge_counts
        return bool(np.all(directed_counts == 1))

    def __len__(self) -> int:
        return len(self._faces)

    def __repr__(self) -> str:
        return f"TriangleMesh(vertices={len(self._vertices)}, faces={len(self._faces)})"


def load_mesh(path: str | Path) -> TriangleMesh:
    """Load a triangle mesh from a file through trimesh (OBJ, STL, PLY, glTF, OFF, ...).

    Parameters
    ----------
    path : str or Path
        The mesh file; scenes with several geometries are concatenated into one mesh, and
        coincident vertices are welded, also across texture and normal seams.

    Raises
    ------
    ValueError
        If the file does not exist, cannot be parsed, or holds no triangles.
    """
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"mesh file not found: {path}")
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many kinds; the user needs the path and reason
        raise ValueError(f"cannot read mesh file {path}: {exc}") from exc
    if not hasattr(loaded, "faces") or len(loaded.faces) == 0:
        raise ValueError(f"mesh file {path} holds no triangles")
    # STL and some OBJ exports store each triangle's corners separately, and textured models
    # (OBJ, glTF, PLY) duplicate every vertex on a texture or normal seam; weld coincident
    # corners whatever their texture coordinates and normals, so that a closed surface reads
    # as closed (no face is removed or reordered).
    loaded.merge_vertices(merge_tex=True, merge_norm=True)
    return TriangleMesh.from_trimesh(loaded)
