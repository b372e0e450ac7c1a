"""distance() and the pose batches against a brute force over triangle pairs and python-fcl."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import MESH_KINDS, examples, point_triangle_distance, random_mesh, random_pose
from reference_queries import brute_force_distance, segment_distance, triangle_distance_reference

import thesis_rbd as rbd
from validation.fcl_adapter import fcl_model, fcl_object, require_fcl
from validation.tori import tori_mesh, tori_poses

VARIANTS = [
    dict(leafless=True, dtype=np.float64),
    dict(leafless=False, dtype=np.float64),
    dict(leafless=True, dtype=np.float32),
]


def fcl_distance(mesh_a, T_a, mesh_b, T_b) -> float:
    """python-fcl's distance of two OBBRSS models (negative or 0 when they collide)."""
    fcl = require_fcl()
    request = fcl.DistanceRequest(enable_nearest_points=True)
    result = fcl.DistanceResult()
    return fcl.distance(
        fcl_object(fcl_model(mesh_a), T_a), fcl_object(fcl_model(mesh_b), T_b), request, result
    )


def _check_points_and_faces(result, mesh_a, T_a, mesh_b, T_b, tolerance):
    """The points are ``distance`` apart and lie on the faces reported."""
    pa, pb = result.points
    assert abs(np.linalg.norm(pa - pb) - result.distance) <= tolerance
    sides = ((pa, mesh_a, T_a, result.faces[0]), (pb, mesh_b, T_b, result.faces[1]))
    for point, mesh, T, face in sides:
        tri = mesh.triangles[face] @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3]
        assert point_triangle_distance(point, tri) <= tolerance


@settings(max_examples=examples(40))
@given(
    kind_a=st.sampled_from(MESH_KINDS),
    kind_b=st.sampled_from(MESH_KINDS),
    seed=st.integers(0, 2**31),
    reach=st.floats(0.3, 1.6),
    variant=st.sampled_from(VARIANTS),
)
def test_distance_matches_brute_force_and_fcl(kind_a, kind_b, seed, reach, variant):
    mesh_a = random_mesh(kind_a, seed)
    mesh_b = random_mesh(kind_b, seed + 1)
    size = max(mesh_a.scale, mesh_b.scale)
    T_a = random_pose(seed + 2, reach * size)
    T_b = random_pose(seed + 3, reach * size)
    tree_a = rbd.OBBTree(mesh_a, **variant)
    tree_b = rbd.OBBTree(mesh_b)
    result = rbd.distance(tree_a, T_a, tree_b, T_b)
    tolerance = 1e-9 * size
    assert result.distance == pytest.approx(
        brute_force_distance(mesh_a, T_a, mesh_b, T_b), abs=tolerance
    )
    colliding = rbd.collide(tree_a, T_a, tree_b, T_b).colliding
    assert (result.distance == 0.0) == colliding
    theirs = fcl_distance(mesh_a, T_a, mesh_b, T_b)
    if colliding:
        assert theirs <= tolerance
    else:
        assert result.distance == pytest.approx(theirs, abs=tolerance)
    _check_points_and_faces(result, mesh_a, T_a, mesh_b, T_b, tolerance)
    assert result.points.shape == (2, 3) and result.faces.dtype == np.int64


def test_tori_path_matches_fcl():
    mesh = tori_mesh()
    tree = rbd.OBBTree(mesh)
    poses = tori_poses()[::5]
    fcl = require_fcl()
    model = fcl_model(mesh)
    separated = 0
    for T_b in poses:
        ours = rbd.distance(tree, np.eye(4), tree, T_b)
        theirs = fcl.distance(
            fcl_object(model), fcl_object(model, T_b), fcl.DistanceRequest(), fcl.DistanceResult()
        )
        if ours.distance > 0:
            separated += 1
            assert ours.distance == pytest.approx(theirs, abs=1e-9 * mesh.scale)
        else:
            assert theirs <= 0.0
    assert 5 < separated < len(poses) - 5


def test_triangle_reference_cases():
    # Parallel faces one above the other, a vertex over a face, crossing edges, touching.
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    assert triangle_distance_reference(P, P + [0, 0, 0.5]) == pytest.approx(0.5)
    apex = np.array([[0.2, 0.2, 0.3], [0.5, 0.5, 2], [0.1, 0.6, 2]], float)
    assert triangle_distance_reference(P, apex) == pytest.approx(0.3)
    assert segment_distance([0, 0, 0], [1, 0, 0], [0.5, -1, 1], [0.5, 1, 1]) == pytest.approx(1)
    assert triangle_distance_reference(P, P + [1, 0, 0]) == 0.0


@pytest.mark.parametrize("leafless", [True, False])
def test_single_triangles_and_known_distances(leafless):
    tri = rbd.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    tree = rbd.OBBTree(tri, leafless=leafless)
    lifted = np.eye(4)
    lifted[:3, 3] = (0.1, 0.1, 0.75)
    res = rbd.distance(tree, np.eye(4), tree, lifted)
    assert res.distance == pytest.approx(0.75, abs=1e-15)
    np.testing.assert_allclose(res.points[1] - res.points[0], [0, 0, 0.75], atol=1e-15)
    box = rbd.OBBTree(rbd.shapes.box((1.0, 1.0, 1.0)), leafless=leafless)
    apart = np.eye(4)
    apart[:3, 3] = (3.0, 2.0, 0.0)
    res = rbd.distance(box, np.eye(4), box, apart)
    assert res.distance == pytest.approx(np.hypot(2.0, 1.0), abs=1e-12)
    np.testing.assert_allclose(np.abs(res.points[0][:2]), [0.5, 0.5], atol=1e-12)


def test_overlapping_meshes_give_zero_and_a_common_point():
    sphere = rbd.shapes.icosphere(1.0, 2)
    tree = rbd.OBBTree(sphere)
    T_b = np.eye(4)
    T_b[:3, 3] = (0.7, 0.2, 0.1)
    res = rbd.distance(tree, np.eye(4), tree, T_b)
    assert res.distance == 0.0
    _check_points_and_faces(res, sphere, np.eye(4), sphere, T_b, 1e-12)


def test_pose_stacks_and_batches_equal_single_queries():
    mesh_a = random_mesh("torus", 3)
    mesh_b = random_mesh("noisy_sphere", 4)
    tree_a = rbd.OBBTree(mesh_a)
    tree_b = rbd.OBBTree(mesh_b)
    T_a = random_pose(9, 1.0)
    stack = np.stack([random_pose(20 + k, 2.0) for k in range(12)])
    singles = [rbd.distance(tree_a, T_a, tree_b, T) for T in stack]
    res = rbd.distance(tree_a, T_a, tree_b, stack)
    assert res.distance.shape == (12,) and res.points.shape == (12, 2, 3)
    assert res.faces.shape == (12, 2)
    np.testing.assert_array_equal(res.distance, [s.distance for s in singles])
    np.testing.assert_array_equal(res.points, [s.points for s in singles])
    np.testing.assert_array_equal(res.faces, [s.faces for s in singles])
    np.testing.assert_array_equal(
        rbd.distance_batch(tree_a, T_a, tree_b, stack), [s.distance for s in singles]
    )
    # Stacks on both sides, and the stack on A's side.
    both = rbd.distance_batch(tree_a, np.repeat(T_a[None], 12, axis=0), tree_b, stack)
    np.testing.assert_array_equal(both, res.distance)
    flipped = rbd.distance_batch(tree_b, stack, tree_a, T_a)
    np.testing.assert_allclose(flipped, res.distance, atol=1e-12)
    colliding = rbd.collide_batch(tree_a, T_a, tree_b, stack)
    assert colliding.dtype == np.bool_ and colliding.shape == (12,)
    np.testing.assert_array_equal(
        colliding, [rbd.collide(tree_a, T_a, tree_b, T).colliding for T in stack]
    )
    assert colliding.any() and not colliding.all()
    np.testing.assert_array_equal(colliding, res.distance == 0.0)
    assert rbd.collide_batch(tree_a, T_a, tree_b, T_a).shape == (1,)


def test_tori_path_batch_equals_single_queries():
    tree = rbd.OBBTree(tori_mesh())
    poses = tori_poses()[::4]
    single = [rbd.collide(tree, np.eye(4), tree, T).colliding for T in poses]
    np.testing.assert_array_equal(rbd.collide_batch(tree, np.eye(4), tree, poses), single)


@pytest.mark.parametrize("threads", [1, 2])
def test_a_fine_path_batch_equals_single_queries_on_any_thread_count(threads):
    """On a path fine enough that one pose's intersecting pair mostly still intersects at the
    next (the batch then answers from that witness), and on one thread or two (each thread's
    runs keep their own witnesses), every answer is the single query's."""
    tree = rbd.OBBTree(tori_mesh())
    poses = tori_poses(2000)[560:860]
    single = [rbd.collide(tree, np.eye(4), tree, T) for T in poses]
    colliding = [s.colliding for s in single]
    witnessed = sum(
        rbd.collide(tree, np.eye(4), tree, T, mode="all").pairs.tolist().count(list(s.pairs[0]))
        for s, T in zip(single[:-1], poses[1:], strict=True)
        if s.colliding
    )
    assert 0 < witnessed < sum(colliding) and not all(colliding)
    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        batch = rbd.collide_batch(tree, np.eye(4), tree, poses)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(batch, colliding)


@pytest.mark.parametrize(
    "T, message",
    [
        (np.diag([1.0, 1.0, 2.0, 1.0]), "rigid"),
        (np.full((4, 4), np.nan), "non-finite"),
        (np.eye(3), "shape"),
        (np.zeros((0, 4, 4)), "at least one"),
        (np.stack([np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0])]), r"T_b\[1\]"),
    ],
)
def test_invalid_poses_raise_naming_the_argument(T, message):
    tree = rbd.OBBTree(rbd.shapes.box())
    with pytest.raises(ValueError, match=message):
        rbd.distance(tree, np.eye(4), tree, T)
    with pytest.raises(ValueError, match=message):
        rbd.distance_batch(tree, np.eye(4), tree, T)
    with pytest.raises(ValueError, match=message):
        rbd.collide_batch(tree, np.eye(4), tree, T)


def test_invalid_trees_and_stack_lengths_raise():
    tree = rbd.OBBTree(rbd.shapes.box())
    with pytest.raises(ValueError, match="tree_a"):
        rbd.distance(tree.mesh, np.eye(4), tree, np.eye(4))
    with pytest.raises(ValueError, match="same length"):
        rbd.distance_batch(tree, np.stack([np.eye(4)] * 2), tree, np.stack([np.eye(4)] * 3))
    with pytest.raises(ValueError, match=r"T_a.*rigid"):
        rbd.distance(tree, np.diag([2.0, 1.0, 1.0, 1.0]), tree, np.eye(4))


def test_fortran_readonly_and_list_poses_give_the_same_answer():
    tree = rbd.OBBTree(rbd.shapes.icosphere(1.0, 2))
    T_b = random_pose(5, 3.0)
    want = rbd.distance(tree, np.eye(4), tree, T_b).distance
    readonly = T_b.copy()
    readonly.flags.writeable = False
    for T in (np.asfortranarray(T_b), readonly, T_b.tolist(), T_b.astype(np.float32)):
        assert rbd.distance(tree, np.eye(4), tree, T).distance == pytest.approx(want, rel=1e-6)


def test_distance_is_zero_exactly_where_collide_says_they_intersect_on_a_fine_grid():
    """Triangles with corners on a 1e-6 grid (a few grid steps across, so many pairs touch
    exactly and many miss by less than round-off resolves): ``distance`` is 0.0 exactly where
    ``collide`` (an exact predicate) reports an intersection. Closest points that round to
    one point once made 3 of 1000 such pairs 0.0 apart that collide calls apart."""
    rng = np.random.default_rng(1)
    identity = np.eye(4)
    touching = 0
    for _ in range(1000):
        corners = rng.integers(0, 4, (2, 3, 3)) * 1e-6
        if any(np.linalg.norm(np.cross(c[1] - c[0], c[2] - c[0])) == 0.0 for c in corners):
            continue
        a, b = (rbd.OBBTree(rbd.TriangleMesh(c, [[0, 1, 2]])) for c in corners)
        colliding = rbd.collide(a, identity, b, identity).colliding
        assert (rbd.distance(a, identity, b, identity).distance == 0.0) == colliding
        touching += colliding
    assert touching > 100
