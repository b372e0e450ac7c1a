"""OBBTree build: invariants (validator), sizes, variants, invalid input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import MESH_KINDS, examples, random_mesh

import thesis_rbd as rbd
from thesis_rbd.collision.mesh.obbtree import OBBTree
from validation.tori import tori_poses

OPTIONS = [
    dict(leafless=lf, dtype=dt, fit=fit)
    for lf in (True, False)
    for dt in (np.float64, np.float32)
    for fit in ("triangles", "hull")
]


@settings(max_examples=examples(40))
@given(kind=st.sampled_from(MESH_KINDS), seed=st.integers(0, 2**31), opts=st.sampled_from(OPTIONS))
def test_random_trees_are_valid(kind, seed, opts):
    mesh = random_mesh(kind, seed)
    tree = rbd.OBBTree(mesh, **opts)
    tree.validate()
    m = len(mesh)
    assert tree.node_count == (m - 1 if opts["leafless"] else 2 * m - 1)
    assert tree.mesh is mesh
    assert tree.centers.dtype == opts["dtype"]
    assert tree.nbytes == sum(
        a.nbytes for a in (tree.centers, tree.rotations, tree.half_extents, tree.children)
    )
    # Rotations are (float32-rounded) proper rotations.
    R = tree.rotations.astype(float)
    err = np.abs(np.einsum("nij,nik->njk", R, R) - np.eye(3)).max()
    assert err < (1e-12 if opts["dtype"] == np.float64 else 1e-6)
    assert np.all(np.linalg.det(R) > 0)
    assert np.all(tree.half_extents >= 0)


def test_bytes_per_triangle():
    mesh = rbd.shapes.torus()
    per_tri = {
        (lf, np.dtype(dt).name): rbd.OBBTree(mesh, leafless=lf, dtype=dt).nbytes / len(mesh)
        for lf in (True, False)
        for dt in (np.float64, np.float32)
    }
    assert per_tri[(True, "float64")] <= 150
    assert per_tri[(True, "float32")] < per_tri[(True, "float64")] * 0.6
    assert per_tri[(False, "float64")] == pytest.approx(2 * per_tri[(True, "float64")], rel=0.01)


def test_default_is_leafless_float64_triangle_fit():
    tree = rbd.OBBTree(rbd.shapes.box())
    assert tree.leafless and tree.dtype == np.float64 and tree.fit == "triangles"
    assert tree.node_count == 11


def test_root_box_is_tight_for_a_box_mesh():
    # The root box of a box mesh is the box itself (its axes are the covariance's).
    mesh = rbd.shapes.box((3.0, 2.0, 1.0))
    tree = rbd.OBBTree(mesh)
    np.testing.assert_allclose(np.sort(tree.half_extents[0]), [0.5, 1.0, 1.5], rtol=1e-9)
    np.testing.assert_allclose(tree.centers[0], 0, atol=1e-12)


def test_identical_centroids_still_split():
    # Every face is the same triangle: no mean split can separate them, the count fallback must.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    mesh = rbd.TriangleMesh(v, np.tile([0, 1, 2], (9, 1)))
    for leafless in (True, False):
        tree = rbd.OBBTree(mesh, leafless=leafless)
        tree.validate()
        assert tree.depth <= 6


def test_all_degenerate_mesh_builds_and_validates():
    v = np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 0, 0]], float)
    mesh = rbd.TriangleMesh(v, [[0, 1, 2], [1, 2, 3], [0, 0, 0], [3, 3, 1]])
    for opts in OPTIONS:
        rbd.OBBTree(mesh, **opts).validate()


def test_validator_catches_a_shrunk_box_and_a_broken_child():
    tree = rbd.OBBTree(rbd.shapes.icosphere(1.0, 2))
    broken = rbd.OBBTree(rbd.shapes.icosphere(1.0, 2))
    broken.half_extents = broken.half_extents.copy()
    broken.half_extents[5] *= 0.5
    with pytest.raises(AssertionError, match="outside"):
        broken.validate()
    broken = rbd.OBBTree(rbd.shapes.icosphere(1.0, 2))
    broken.children = broken.children.copy()
    broken.children[3, 1] = broken.children[3, 0]
    with pytest.raises(AssertionError):
        broken.validate()
    tree.validate()


def test_invalid_input_raises():
    with pytest.raises(ValueError, match="TriangleMesh"):
        OBBTree(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="fit"):
        OBBTree(rbd.shapes.box(), fit="sphere")
    with pytest.raises(ValueError, match="dtype"):
        OBBTree(rbd.shapes.box(), dtype=np.int32)
    with pytest.raises(ValueError, match="empty"):
        OBBTree(rbd.TriangleMesh(np.zeros((0, 3)), np.zeros((0, 3), int)))
    with pytest.raises(ValueError, match="non-finite"):
        OBBTree(rbd.TriangleMesh([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]))
    # a fit whose moments overflow (a 1e150 m box was once built with NaN boxes, and two of
    # them 4e150 apart were reported colliding)
    with pytest.raises(ValueError, match="too large for the box fit"):
        OBBTree(
            rbd.TriangleMesh(np.array(rbd.shapes.box().vertices) * 1e150, rbd.shapes.box().faces)
        )


def test_a_float32_tree_far_from_the_origin_stays_tight():
    """A torus 1e6 m from its mesh origin: the float32 tree's boxes are the float64 tree's
    grown by no more than float32 rounding of the torus's own size (1e-5 of it), and the
    queries test about as many boxes with either (here 1.5x; they were 2.4-3.6x while the
    boxes were fitted through float32 axes in far coordinates, which rebuilt each centre
    7 cm off, and 2e-6 of the 1.7e6 m distance, 3.4 m on every box, before that); both trees
    hold every triangle. Boxes counted, not timed: the counts are what the time follows."""
    torus = rbd.shapes.torus(1.0, 0.3, 50, 50)
    far = rbd.TriangleMesh(torus.vertices + 1e6, torus.faces)
    tight = rbd.OBBTree(far, dtype=np.float64)
    rounded = rbd.OBBTree(far, dtype=np.float32)
    tight.validate()
    rounded.validate()
    grown = rounded.half_extents.astype(np.float64) - tight.half_extents
    assert grown[tight.root].max() <= 1e-5 * far.scale
    assert np.median(grown) <= 1e-5 * far.scale
    # the tori demo's motion, carried out to the torus at 1e6
    offset = np.eye(4)
    offset[:3, 3] = 1e6
    identity = np.eye(4)
    for pose in tori_poses()[::20]:
        T_b = offset @ pose @ np.linalg.inv(offset)
        for tests in (
            lambda t, T_b=T_b: rbd.collide(t, identity, t, T_b, mode="all").stats["bv_tests"],
            lambda t, T_b=T_b: rbd.distance(t, identity, t, T_b).stats["bv_tests"],
        ):
            assert tests(rounded) <= 1.5 * tests(tight) + 10
