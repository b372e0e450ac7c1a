"""The node supports behind the distance descent's centre-line bounds, against brute force.

Each tree node stores its support along a grid of cube-surface directions
(:mod:`thesis_rbd.collision.mesh.packed_support`), and :func:`support_along` combines three
of them into an upper bound on the support along any direction. A bound that is ever low
would let the descent prune a pair holding the closest triangles, so these tests check it
against the exact support (a maximum over the node's vertices, in NumPy) for every node, at
random directions and at the grid directions themselves, where it is exact up to the float32
rounding; and they run the distance query on curved meshes, where the support bounds do most
of the pruning, against an all-pairs search.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit
from reference import examples, random_pose
from test_hull_distance import _all_pairs

import thesis_rbd as rbd
from thesis_rbd.collision.mesh.packed import layout, support_values
from thesis_rbd.collision.mesh.packed_support import (
    DIRECTIONS,
    GRID,
    SUPPORT_ROWS,
    grid_points,
    support_along,
)


# not cached: numba keys a cache on this file alone, and support_along is inlined
@njit
def _bounds(P, directions):
    """(n nodes, k directions) support_along of every node of packed tree P."""
    S, start = support_values(P, layout(P))
    n = int(P[0, 0])
    out = np.empty((n, directions.shape[0]))
    for k in range(n):
        for d in range(directions.shape[0]):
            x, y, z = directions[d, 0], directions[d, 1], directions[d, 2]
            out[k, d] = support_along(S, start, k, x, y, z)
    return out


def _node_vertices(tree, faces):
    """Vertex indices under each node of ``tree`` (a list, one array per node)."""
    children = tree.children
    under: list = [None] * len(children)

    def collect(code):
        if code < 0:
            return set(faces[-code - 1])
        if under[code] is None:
            found = set()
            for c in set(children[code]):
                found |= collect(int(c))
            under[code] = found
        return under[code]

    collect(tree.root)
    return [np.array(sorted(s)) for s in under]


def _exact(tree, mesh, directions):
    """(n, k) exact supports of every node about its box centre."""
    vertices = np.asarray(mesh.vertices)
    centers = np.asarray(tree.centers, dtype=np.float64) + tree.origin
    return np.array(
        [
            ((vertices[ids] - centers[k]) @ directions.T).max(axis=0)
            for k, ids in enumerate(_node_vertices(tree, np.asarray(mesh.faces)))
        ]
    )


def _radii(tree, mesh):
    """(n,) largest distance of a node's vertices from its box centre."""
    vertices = np.asarray(mesh.vertices)
    centers = np.asarray(tree.centers, dtype=np.float64) + tree.origin
    nodes = _node_vertices(tree, np.asarray(mesh.faces))
    return np.array(
        [np.linalg.norm(vertices[ids] - centers[k], axis=1).max() for k, ids in enumerate(nodes)]
    )


def _meshes():
    torus = rbd.shapes.torus(1.0, 0.3, 16, 8)
    capsule = trimesh.creation.capsule(height=1.0, radius=0.3, count=[12, 8])
    rng = np.random.default_rng(3)
    points = rng.normal(size=(40, 3)) * (0.6, 0.4, 0.2)
    hull = trimesh.convex.convex_hull(points)
    return {
        "torus": torus,
        "capsule": rbd.TriangleMesh(capsule.vertices, capsule.faces),
        "hull": rbd.TriangleMesh(hull.vertices, hull.faces),
        # far from its frame's origin: the supports are about each node's centre
        "far torus": rbd.TriangleMesh(np.asarray(torus.vertices) + 1e6, torus.faces),
    }


MESHES = _meshes()


def _tree(name, dtype):
    tree = rbd.OBBTree(MESHES[name], dtype=dtype)
    tree.query_array(hull=True)
    return tree


@settings(max_examples=examples(40), deadline=None)
@given(
    name=st.sampled_from(sorted(MESHES)),
    dtype=st.sampled_from([np.float64, np.float32]),
    seed=st.integers(0, 2**32 - 1),
    length=st.sampled_from([1e-6, 1.0, 1e6]),
)
def test_support_along_never_below_a_nodes_exact_support(name, dtype, seed, length):
    tree = _tree(name, dtype)
    directions = np.random.default_rng(seed).normal(size=(16, 3))
    directions *= length / np.linalg.norm(directions, axis=1, keepdims=True)
    bound = _bounds(tree.query_array(hull=True), directions)
    exact = _exact(tree, MESHES[name], directions)
    reach = _radii(tree, MESHES[name])[:, None] * length
    assert (bound >= exact - 1e-12 * reach).all()
    # and a bound worth having: a support changes by at most the node's radius r per unit
    # change of direction, and the three grid points read lie within a cell's diagonal,
    # 2 sqrt(2) / GRID of the cube's unit, of where the direction meets the cube
    assert (bound <= exact + 2.0 * np.sqrt(2.0) / GRID * reach).all()


@pytest.mark.parametrize("name", sorted(MESHES))
def test_support_along_is_exact_at_the_grid_directions(name):
    tree = _tree(name, np.float64)
    points = grid_points()
    assert len(points) == DIRECTIONS
    bound = _bounds(tree.query_array(hull=True), points)
    exact = _exact(tree, MESHES[name], points)
    size = np.abs(exact).max(axis=1, keepdims=True)
    # float32 storage, rounded up: never below, at most a few float32 ulps above
    assert (bound >= exact).all()
    assert (bound - exact <= 4e-7 * size + 1e-300).all()


def test_support_block_sits_between_the_faces_and_the_hull():
    tree = _tree("torus", np.float64)
    P = tree.query_array(hull=True)
    n, _, nf = (int(v) for v in P[0])
    L = layout(P)
    _, start = support_values(P, L)
    assert start == 6 * (L[5] + nf)
    without = rbd.OBBTree(MESHES["torus"]).query_array()
    hull_rows = P.shape[0] - without.shape[0] - n * SUPPORT_ROWS
    assert hull_rows > 0
    np.testing.assert_array_equal(P[3 : without.shape[0]], without[3:])


@settings(max_examples=examples(30), deadline=None)
@given(
    pair=st.sampled_from([("torus", "capsule"), ("torus", "torus"), ("far torus", "hull")]),
    dtype=st.sampled_from([np.float64, np.float32]),
    seed=st.integers(0, 2**32 - 1),
    reach=st.sampled_from([0.8, 2.0, 4.0]),
)
def test_distance_with_support_bounds_matches_all_pairs(pair, dtype, seed, reach):
    """Curved meshes at random poses, some interlocked: exactly the all-pairs distance."""
    mesh_a, mesh_b = MESHES[pair[0]], MESHES[pair[1]]
    tree_a, tree_b = _tree(pair[0], dtype), _tree(pair[1], dtype)
    T_a = random_pose(seed, 0.0)
    T_b = random_pose(seed + 1, reach)
    offset = np.asarray(mesh_a.vertices).mean(axis=0) - np.asarray(mesh_b.vertices).mean(axis=0)
    T_b[:3, 3] += T_a[:3, :3] @ offset
    result = rbd.distance(tree_a, T_a, tree_b, T_b)
    ta = np.asarray(mesh_a.vertices)[np.asarray(mesh_a.faces)] @ T_a[:3, :3].T + T_a[:3, 3]
    tb = np.asarray(mesh_b.vertices)[np.asarray(mesh_b.faces)] @ T_b[:3, :3].T + T_b[:3, 3]
    expected = _all_pairs(ta, tb)
    scale = 1.0 + np.abs(T_b[:3, 3]).max()
    if expected == 0.0:
        assert result.distance == 0.0
    else:
        assert result.distance == pytest.approx(expected, abs=1e-9 * scale)
