"""The AABB tree of the OBB-vs-AABB study: a valid tree, and an oracle for the OBB tree's pairs.

As an oracle it decides triangle pairs with its own separating-axis test
(``validation/triangle_sat.py``), checked here against the plain-Python exact reference.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import thesis_rbd as rbd
from tests.reference import (
    brute_force_pairs,
    examples,
    random_mesh,
    random_pose,
    tri_tri_sat,
)
from validation.aabb_tree import (
    AABBTree,
    aabb_collide,
    record_aabb_traversal,
    record_obb_traversal,
)
from validation.tori import tori_mesh, tori_poses
from validation.triangle_sat import triangles_overlap

coord = st.floats(-2.0, 2.0, allow_nan=False, width=64)
triangle = st.lists(coord, min_size=9, max_size=9).map(lambda v: np.array(v).reshape(3, 3))
int_triangle = st.lists(st.integers(-3, 3), min_size=9, max_size=9).map(
    lambda v: np.array(v, dtype=float).reshape(3, 3)
)
# segment- and point-shaped: a repeated corner, or all three equal
degenerate_triangle = st.one_of(
    int_triangle.map(lambda t: t[[0, 1, 1]]), int_triangle.map(lambda t: t[[0, 0, 0]])
)


@settings(max_examples=examples(60))
@given(P=triangle, Q=triangle)
def test_own_triangle_test_matches_the_exact_reference(P, Q):
    overlap, margin = tri_tri_sat(P, Q, exact=True)
    assume(abs(margin) >= 1e-9)  # touching: decided by rounding in any float test
    assert triangles_overlap(P, Q) == overlap


@settings(max_examples=examples(100))
@given(
    P=st.one_of(int_triangle, degenerate_triangle), Q=st.one_of(int_triangle, degenerate_triangle)
)
def test_own_triangle_test_is_exact_on_integer_grids(P, Q):
    """Small integers make every product exact: touching, coplanar and degenerate pairs are
    decided exactly, as by the rational-arithmetic reference."""
    assert triangles_overlap(P, Q) == tri_tri_sat(P, Q, exact=True)[0]


def test_every_node_box_holds_its_triangles():
    mesh = random_mesh("noisy_sphere", 3)
    tree = AABBTree(mesh)
    assert tree.node_count == 2 * len(mesh) - 1
    tris = mesh.triangles
    seen = np.zeros(len(mesh), dtype=int)

    def below(node):
        a, b = tree.children[node]
        if a < 0:
            return [-a - 1]
        return below(a) + below(b)

    for node in range(tree.node_count):
        faces = below(node)
        corners = tris[faces].reshape(-1, 3)
        assert np.all(corners >= tree.lower[node]) and np.all(corners <= tree.upper[node])
    for t in below(0):
        seen[t] += 1
    assert np.all(seen == 1)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("kind", ["hull", "noisy_sphere", "torus", "thin_plate"])
def test_pairs_equal_the_obb_tree_and_brute_force(kind, seed):
    mesh_a = random_mesh(kind, seed)
    mesh_b = random_mesh("noisy_sphere", seed + 100)
    T_a, T_b = random_pose(seed, 0.3), random_pose(seed + 7, 1.2)
    pairs, stats = aabb_collide(AABBTree(mesh_a), T_a, AABBTree(mesh_b), T_b)
    obb = rbd.collide(rbd.OBBTree(mesh_a), T_a, rbd.OBBTree(mesh_b), T_b, mode="all")
    np.testing.assert_array_equal(pairs, obb.pairs)
    np.testing.assert_array_equal(pairs, brute_force_pairs(mesh_a, T_a, mesh_b, T_b))
    assert stats["tri_tests"] >= len(pairs)
    first, _ = aabb_collide(AABBTree(mesh_a), T_a, AABBTree(mesh_b), T_b, mode="first")
    assert len(first) == min(len(pairs), 1)


def test_recorded_traversals_count_what_the_queries_count():
    mesh = random_mesh("torus", 5)
    T_b = random_pose(11, 0.4)
    obb = rbd.OBBTree(mesh, leafless=False)
    result = rbd.collide(obb, np.eye(4), obb, T_b, mode="all")
    boxes, triangles = record_obb_traversal(obb, np.eye(4), obb, T_b)
    assert (len(boxes), len(triangles)) == (result.stats["bv_tests"], result.stats["tri_tests"])
    aabb = AABBTree(mesh)
    _, stats = aabb_collide(aabb, np.eye(4), aabb, T_b)
    boxes, triangles = record_aabb_traversal(aabb, np.eye(4), aabb, T_b)
    assert (len(boxes), len(triangles)) == (stats["bv_tests"], stats["tri_tests"])
    with pytest.raises(ValueError, match="leafless"):
        record_obb_traversal(rbd.OBBTree(mesh), np.eye(4), obb, T_b)


def test_tori_demo_pairs_equal_the_obb_tree():
    mesh = tori_mesh()
    aabb, obb = AABBTree(mesh), rbd.OBBTree(mesh)
    for P in tori_poses()[::25]:
        pairs, _ = aabb_collide(aabb, np.eye(4), aabb, P)
        np.testing.assert_array_equal(pairs, rbd.collide(obb, np.eye(4), obb, P, "all").pairs)
        # the cost instrument's variant (the library's triangle test) finds the same pairs
        library, _ = aabb_collide(aabb, np.eye(4), aabb, P, triangle_test="library")
        np.testing.assert_array_equal(library, pairs)


def test_unknown_triangle_test_is_refused():
    tree = AABBTree(rbd.shapes.box((1, 1, 1)))
    with pytest.raises(ValueError, match="triangle_test"):
        aabb_collide(tree, np.eye(4), tree, np.eye(4), triangle_test="fast")
