"""OBBTree: a binary tree of oriented bounding boxes over a triangle mesh, as flat arrays.

Layout (pynndescent-style flat tree, walked by numba kernels with an explicit stack):

* ``centers`` (n, 3), ``rotations`` (n, 3, 3) (columns = box axes), ``half_extents`` (n, 3):
  the node boxes in the mesh frame, float64 or float32.
* ``children`` (n, 2) int32: a value ``k >= 0`` is node ``k``; a value ``k < 0`` is triangle
  (face) ``-k - 1``.

Two variants (thesis 5.4):

* ``leafless=False``: the classic OBBTree with 2m - 1 nodes; leaf node ``i`` bounds one
  triangle and has ``children[i] = (-t - 1, -t - 1)``.
* ``leafless=True`` (thesis 5.4.2): the leaves are dropped and their triangles are stored in
  the parents' child slots, m - 1 nodes; a traversal meeting a triangle against a box uses the
  triangle-box test instead of a box-box test.

Build (top-down, thesis 4.8/5.1): fit a box to the node's triangles (axes from the triangle or
convex-hull covariance, see :mod:`.obb` and :mod:`.obb_hull`), split the triangles at the mean of
their centroids along the box's longest axis, recurse. It runs as one numba kernel
over an index array partitioned in place, so the whole build is O(m log m) with no Python per
node. If the mean split leaves one side empty (e.g. identical centroids), the next-longest axis
is tried, and as a last resort the range is halved by count, so the tree is always complete.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.obb import symmetric_eigenvectors, triangle_moments
from thesis_rbd.collision.mesh.obb_hull import hull_moments
from thesis_rbd.collision.mesh.packed import pack_tree, packed_views, with_hull
from thesis_rbd.geometry.mesh import TriangleMesh

__all__ = ["OBBTree"]

_FITS = ("triangles", "hull")

# Relative padding of the half-extents, so that a box contains its triangles despite the
# rounding of the stored centre and axes: a few ulps for float64; for float32 the axes are
# rounded to ~6e-8 and are orthonormal only to that accuracy, so 2e-6 leaves a margin.
_PAD = {np.dtype(np.float64): 1e-12, np.dtype(np.float32): 2e-6}
# Padding per metre of a box's distance from the mesh origin: float64 rounding in projecting
# far coordinates (a few ulps, 2.2e-16 each), whatever the stored precision.
_ARITHMETIC = 1e-14


@njit
def _node_points(V, F, order, start, end, stamp, node):
    """The distinct vertices (k, 3) of faces ``order[start:end]`` (``stamp`` marks seen ids)."""
    ids = np.empty(3 * (end - start), dtype=np.int64)
    k = 0
    for i in range(start, end):
        for j in range(3):
            v = F[order[i], j]
            if stamp[v] != node:
                stamp[v] = node
                ids[k] = v
                k += 1
    P = np.empty((k, 3))
    for i in range(k):
        P[i] = V[ids[i]]
    return P


@njit
def _fit_axes(tris, order, start, end, area, wcent, wmom, hull_fit, V, F, stamp, node):
    """Box axes (3, 3) for triangles ``order[start:end]`` from the summed moments.

    With ``hull_fit`` the moments are those of the convex hull of the node's vertices
    (Gottschalk); a node whose vertices span no volume falls back to its own triangles.
    """
    if hull_fit and end - start > 1:
        total, cs, ms = hull_moments(_node_points(V, F, order, start, end, stamp, node))
        if total > 0.0:
            C = np.empty((3, 3))
            for i in range(3):
                for j in range(3):
                    C[i, j] = ms[i, j] / total - (cs[i] / total) * (cs[j] / total)
            return symmetric_eigenvectors(C)
    total = 0.0
    cs = np.zeros(3)
    ms = np.zeros((3, 3))
    for k in range(start, end):
        t = order[k]
        total += area[t]
        for i in range(3):
            cs[i] += wcent[t, i]
            for j in range(3):
                ms[i, j] += wmom[t, i, j]
    C = np.empty((3, 3))
    if total > 0.0:
        for i in range(3):
            for j in range(3):
                C[i, j] = ms[i, j] / total - (cs[i] / total) * (cs[j] / total)
    else:
        # Only degenerate (zero-area) triangles: fall back to the covariance of the corners.
        n = 3 * (end - start)
        mean = np.zeros(3)
        for k in range(start, end):
            for v in range(3):
                for i in range(3):
                    mean[i] += tris[order[k], v, i] / n
        C[:] = 0.0
        for k in range(start, end):
            for v in range(3):
                for i in range(3):
                    di = tris[order[k], v, i] - mean[i]
                    for j in range(3):
                        C[i, j] += di * (tris[order[k], v, j] - mean[j]) / n
    return symmetric_eigenvectors(C)


@njit
def _fit_box(tris, order, start, end, axes, round32, pad, origin, center, half):
    """Centre (relative to ``origin``) and half-extents of the box with ``axes`` around
    ``order[start:end]``.

    With ``round32`` the axes are first rounded to float32 (in place) so the stored box is
    the one whose extents were measured, and so is the centre's offset from ``origin``; the
    centre shift caused by rounding it is added to the half-extents, which are then padded
    so the rounded box still contains every corner.
    """
    if round32:
        for i in range(3):
            for j in range(3):
                axes[i, j] = np.float32(axes[i, j])
    # corners measured from the origin: with float32-rounded axes (orthonormal to ~6e-8 only)
    # a centre rebuilt through them is off by that fraction of the distances involved,
    # which are then the mesh's own size, not its distance from the frame's origin
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for k in range(start, end):
        t = order[k]
        for v in range(3):
            x = tris[t, v, 0] - origin[0]
            y = tris[t, v, 1] - origin[1]
            z = tris[t, v, 2] - origin[2]
            for j in range(3):
                s = axes[0, j] * x + axes[1, j] * y + axes[2, j] * z
                lo[j] = min(lo[j], s)
                hi[j] = max(hi[j], s)
    mid = 0.5 * (lo + hi)
    for i in range(3):
        c = axes[i, 0] * mid[0] + axes[i, 1] * mid[1] + axes[i, 2] * mid[2]
        center[i] = np.float32(c) if round32 else c
    # the padding scales with the box's own extent, not with its distance from the origin:
    # the stored centre's rounding is measured exactly (back - mid below), and axes
    # orthonormal to ~6e-8 misplace a corner by that fraction of its distance from the
    # centre; only the float64 arithmetic of projecting far coordinates (queries work in
    # the mesh frame) adds a few ulps of that distance
    size = 0.0
    reach = 0.0
    far = math.sqrt(origin[0] ** 2 + origin[1] ** 2 + origin[2] ** 2)
    for j in range(3):
        size = max(size, hi[j] - lo[j])
        reach = max(reach, abs(mid[j]) + far)
    for j in range(3):
        back = axes[0, j] * center[0] + axes[1, j] * center[1] + axes[2, j] * center[2]
        half[j] = (
            (0.5 * (hi[j] - lo[j]) + abs(back - mid[j])) * (1.0 + pad)
            + pad * size
            + _ARITHMETIC * reach
        )


@njit
def _partition(tris, order, start, end, axes):
    """Split ``order[start:end]`` in place at the mean along the longest axis; return mid."""
    count = end - start
    for attempt in range(3):
        # Columns of `axes` are sorted by decreasing spread, so attempt 0 is the longest.
        ax = attempt
        mean = 0.0
        for k in range(start, end):
            t = order[k]
            c = 0.0
            for i in range(3):
                c += axes[i, ax] * (tris[t, 0, i] + tris[t, 1, i] + tris[t, 2, i])
            mean += c
        mean /= count
        i = start
        j = end - 1
        while i <= j:
            t = order[i]
            c = 0.0
            for d in range(3):
                c += axes[d, ax] * (tris[t, 0, d] + tris[t, 1, d] + tris[t, 2, d])
            if c < mean:
                i += 1
            else:
                order[i], order[j] = order[j], order[i]
                j -= 1
        if start < i < end:
            return i
    return start + count // 2


@njit
def _build(tris, V, F, area, wcent, wmom, leafless, hull_fit, round32, pad, origin):
    """Top-down build; returns (centers, rotations, half_extents, children, root, depth),
    the centres relative to ``origin``."""
    m = tris.shape[0]
    n_nodes = m - 1 if leafless else 2 * m - 1
    centers = np.zeros((n_nodes, 3))
    rotations = np.zeros((n_nodes, 3, 3))
    halves = np.zeros((n_nodes, 3))
    children = np.zeros((n_nodes, 2), dtype=np.int32)
    order = np.arange(m)
    stamp = np.full(V.shape[0], -1, dtype=np.int64)
    if n_nodes == 0:
        return centers, rotations, halves, children, np.int64(-1), np.int64(1)
    # Explicit stack of pending nodes: (node, start, end, depth). Depth <= m, so m + 1 fits.
    stack = np.empty((m + 1, 4), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    stack[0, 2] = m
    stack[0, 3] = 1
    top = 1
    next_node = 1
    max_depth = 1
    while top > 0:
        top -= 1
        node = stack[top, 0]
        start = stack[top, 1]
        end = stack[top, 2]
        depth = stack[top, 3]
        max_depth = max(max_depth, depth)
        axes = _fit_axes(tris, order, start, end, area, wcent, wmom, hull_fit, V, F, stamp, node)
        _fit_box(tris, order, start, end, axes, round32, pad, origin, centers[node], halves[node])
        rotations[node] = axes
        if end - start == 1:
            # Leaf of the classic tree (never reached by the leafless build).
            children[node, 0] = -order[start] - 1
            children[node, 1] = -order[start] - 1
            continue
        mid = _partition(tris, order, start, end, axes)
        # Children get consecutive indices, so siblings sit side by side in memory.
        for side in range(2):
            s = start if side == 0 else mid
            e = mid if side == 0 else end
            if leafless and e - s == 1:
                children[node, side] = -order[s] - 1
                max_depth = max(max_depth, depth + 1)
            else:
                children[node, side] = next_node
                stack[top, 0] = next_node
                stack[top, 1] = s
                stack[top, 2] = e
                stack[top, 3] = depth + 1
                top += 1
                next_node += 1
    return centers, rotations, halves, children, np.int64(0), np.int64(max_depth)


@njit
def _validate_kernel(tris, centers, rotations, halves, children, root, tol):
    """Return (node, code) of the first violation found, or (-1, 0).

    code 1: a triangle corner outside its node's box; 2: a child node index out of range or
    visited twice; 3: a triangle reached twice or never.
    """
    n_nodes = centers.shape[0]
    m = tris.shape[0]
    seen_tri = np.zeros(m, dtype=np.int64)
    seen_node = np.zeros(n_nodes, dtype=np.int64)
    if root < 0:
        return (-1, 0) if m == 1 else (-1, 3)
    # For every node, every triangle below it must be inside its box; walk each subtree.
    # O(m log m) corner checks: fine for a validator.
    for node in range(n_nodes):
        stack = np.empty(n_nodes + m + 2, dtype=np.int64)
        stack[0] = node
        top = 1
        while top > 0:
            top -= 1
            code = stack[top]
            if code < 0:
                t = -code - 1
                if t >= m:
                    return node, 2
                for v in range(3):
                    for j in range(3):
                        s = 0.0
                        for i in range(3):
                            s += rotations[node, i, j] * (tris[t, v, i] - centers[node, i])
                        if abs(s) > halves[node, j] + tol:
                            return node, 1
                continue
            if code >= n_nodes:
                return node, 2
            a = children[code, 0]
            b = children[code, 1]
            if a < 0 and a == b:
                stack[top] = a
                top += 1
            else:
                stack[top] = a
                stack[top + 1] = b
                top += 2
    # Structure: every node reached once from the root, every triangle once.
    stack = np.empty(n_nodes + m + 2, dtype=np.int64)
    stack[0] = root
    top = 1
    while top > 0:
        top -= 1
        code = stack[top]
        if code < 0:
            seen_tri[-code - 1] += 1
            continue
        seen_node[code] += 1
        if seen_node[code] > 1:
            return code, 2
        a = children[code, 0]
        b = children[code, 1]
        if a < 0 and a == b:
            stack[top] = a
            top += 1
        else:
            stack[top] = a
            stack[top + 1] = b
            top += 2
    for k in range(n_nodes):
        if seen_node[k] != 1:
            return k, 2
    for t in range(m):
        if seen_tri[t] != 1:
            return -1, 3
    return -1, 0


class OBBTree:
    """Bounding-volume hierarchy of oriented boxes over a :class:`TriangleMesh`.

    Parameters
    ----------
    mesh : TriangleMesh
        The geometry, in its own (body) frame. The tree keeps a reference, not a copy.
    fit : {"triangles", "hull"}
        Covariance used for the box axes: the node's own triangles (RAPID; default) or the
        triangles of the convex hull of the node's vertices (Gottschalk, thesis 4.5.1).
    leafless : bool
        True (default): m - 1 nodes with triangles stored in the parents (thesis 5.4.2).
        False: the classic 2m - 1 node tree with one triangle per leaf box.
    dtype : numpy float dtype
        Storage of the node boxes, ``np.float64`` (default) or ``np.float32`` (half the
        memory; boxes are padded so they remain conservative, and their centres are stored
        relative to the mesh's middle, ``origin``). Queries compute in float64.

    Notes
    -----
    The defaults were chosen by measurement on the thesis demo (two 5000-triangle tori; the
    figures are in the report's ``obbtree_variants`` study and ``python -m
    validation.bench_obbtree``): the leafless tree needs half the memory of the classic one
    (128 against 256 bytes per triangle in float64), builds faster and answers "first" as
    fast; the classic tree is slightly faster for all pairs, because its leaf box tests are
    cheaper than the leafless tree's triangle-box tests. The hull fit gives about the same
    number of tests on that scene and builds several times slower (an incremental hull per
    node), so the triangle fit is the default. float32 storage halves the memory again with
    the same answers and about the same speed, since the arithmetic stays float64.

    Attributes
    ----------
    centers : (n, 3) dtype
        Box centres in the mesh frame, relative to ``origin``.
    origin : (3,) float64
        The point the centres are measured from: zero for a float64 tree, the middle of the
        mesh's bounding box for a float32 one (so that a float32 centre is rounded to the
        mesh's own size, not to its distance from the frame's origin).
    rotations : (n, 3, 3) dtype
        Box axes as columns, mesh frame.
    half_extents : (n, 3) dtype
        Box half-sizes along the axes.
    children : (n, 2) int32
        Child codes: ``k >= 0`` node, ``k < 0`` triangle ``-k - 1``.
    root : int
        Code of the root (0, or -1 for a leafless tree over a single triangle).
    depth : int
        Number of levels, counting triangles stored in child slots as a level.
    scale : float
        The mesh's size (bounding-box diagonal), for relative tolerances.

    Raises
    ------
    ValueError
        If ``mesh`` is not a TriangleMesh (an empty mesh cannot be one), an option is
        invalid, or its coordinates are so large (beyond about 1e76) that the fit's moments
        overflow.
    """

    def __init__(self, mesh, fit: str = "triangles", leafless: bool = True, dtype=np.float64):
        if not isinstance(mesh, TriangleMesh):
            raise ValueError(f"mesh must be a thesis_rbd.TriangleMesh, got {type(mesh).__name__}")
        if fit not in _FITS:
            raise ValueError(f"fit must be one of {_FITS}, got {fit!r}")
        try:
            dtype = np.dtype(dtype)
        except TypeError as exc:
            raise ValueError(f"dtype must be float64 or float32, got {dtype!r}") from exc
        if dtype not in _PAD:
            raise ValueError(f"dtype must be float64 or float32, got {dtype}")
        self._mesh = mesh
        # Cached: TriangleMesh.scale recomputes the bounds, too slow for every query.
        self.scale = float(mesh.scale)
        self.fit = fit
        self.leafless = bool(leafless)
        self.dtype = dtype
        tris = np.ascontiguousarray(mesh.triangles)
        with np.errstate(over="ignore", invalid="ignore"):
            area, wcent, wmom = triangle_moments(tris)
        if not (np.isfinite(area).all() and np.isfinite(wmom).all()):
            far = float(np.abs(mesh.vertices).max())
            raise ValueError(
                f"mesh is too large for the box fit: its triangles' second moments overflow "
                f"float64 (largest coordinate {far:.3g}; keep coordinates below about 1e76)"
            )
        # float32 centres are offsets from the middle of the mesh, so that their rounding
        # is that of the mesh's own size, wherever the mesh lies in its frame
        origin = np.zeros(3)
        if dtype == np.float32:
            origin = 0.5 * (mesh.vertices.min(axis=0) + mesh.vertices.max(axis=0))
        self.origin = origin
        self.origin.flags.writeable = False
        centers, rotations, halves, children, root, depth = _build(
            tris,
            mesh.vertices,
            mesh.faces,
            area,
            wcent,
            wmom,
            self.leafless,
            fit == "hull",
            dtype == np.float32,
            _PAD[dtype],
            origin,
        )
        self.root = int(root)
        self.depth = int(depth)
        self._packed = None
        # the packed array with the hull block, once a distance query has asked for it
        self._hull_packed = None
        self.children = children
        self.children.flags.writeable = False
        if dtype == np.float64:
            # The public box arrays are views into the query array (see :mod:`.packed`).
            self._packed = pack_tree(
                centers, rotations, halves, children, self.root, self.leafless, self.depth,
                mesh.vertices, mesh.faces,
            )  # fmt: skip
            self._view(self._packed)
        else:
            self.centers = centers.astype(dtype)
            self.rotations = rotations.astype(dtype)
            self.half_extents = halves.astype(dtype)
            for array in (self.centers, self.rotations, self.half_extents):
                array.flags.writeable = False

    def query_array(self, hull: bool = False) -> np.ndarray:
        """The packed (rows, 3) float64 array the query kernels read (:mod:`.packed`).

        A float64 tree's box arrays are views into it already; a float32 tree gets a float64
        copy of its boxes (the same, exactly representable values) on its first query, so
        the kernels are compiled once, for float64. With ``hull`` the array also carries the
        mesh's convex hull (:mod:`.packed_hull`), built on the first query that asks (the
        distance queries): it costs about half a tree build again, which a tree that is
        only collided never pays.
        """
        if self._packed is None:
            self._packed = pack_tree(
                self.centers.astype(np.float64) + self.origin, self.rotations,
                self.half_extents, self.children, self.root, self.leafless, self.depth,
                self._mesh.vertices, self._mesh.faces,
            )  # fmt: skip
        if hull and self._hull_packed is None:
            self._packed = self._hull_packed = with_hull(self._packed)
            if self.dtype == np.float64:
                self._view(self._packed)
        return self._packed

    def _view(self, packed) -> None:
        """Make the public box arrays read-only views into ``packed``."""
        self.centers, self.rotations, self.half_extents = packed_views(packed)
        for array in (self.centers, self.rotations, self.half_extents):
            array.flags.writeable = False

    @property
    def mesh(self) -> TriangleMesh:
        """The mesh the tree was built over."""
        return self._mesh

    @property
    def node_count(self) -> int:
        """Number of box nodes (2m - 1 classic, m - 1 leafless)."""
        return int(self.centers.shape[0])

    @property
    def nbytes(self) -> int:
        """Bytes of the node arrays (boxes and child codes).

        The mesh's own vertex and face arrays, which the tree reads but does not copy, are
        not counted.
        """
        return int(
            self.centers.nbytes
            + self.rotations.nbytes
            + self.half_extents.nbytes
            + self.children.nbytes
        )

    def validate(self) -> None:
        """Check the tree's invariants; raise ``AssertionError`` naming the first violation.

        Every node's box contains every corner of every triangle below it (so, in particular,
        each child's span lies inside its parent's box), every node is reached exactly once
        from the root, and every triangle exactly once.
        """
        tris = np.ascontiguousarray(self._mesh.triangles)
        far = float(np.abs(self._mesh.vertices).max(initial=0.0))
        tol = 4.0 * (_PAD[self.dtype] * max(self._mesh.scale, 1e-300) + _ARITHMETIC * far)
        node, code = _validate_kernel(
            tris,
            self.centers.astype(np.float64) + self.origin,
            self.rotations.astype(np.float64),
            self.half_extents.astype(np.float64),
            self.children,
            np.int64(self.root),
            tol,
        )
        if code == 1:
            raise AssertionError(f"node {node}: a triangle corner lies outside its box")
        if code == 2:
            raise AssertionError(f"node {node}: child structure broken (range or repeat)")
        if code == 3:
            raise AssertionError("a triangle is stored more than once or not at all")

    def __repr__(self) -> str:
        kind = "leafless" if self.leafless else "leaf"
        return (
            f"OBBTree({len(self._mesh)} triangles, {self.node_count} nodes, {kind}, "
            f"fit={self.fit!r}, dtype={self.dtype.name}, {self.nbytes} bytes)"
        )
