"""collide(): yes/no and pair sets against a brute-force reference and python-fcl."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import MESH_KINDS, brute_force_pairs, examples, random_mesh, random_pose

import thesis_rbd as rbd
from validation.fcl_adapter import fcl_collide, fcl_model, fcl_object
from validation.tori import tori_mesh, tori_poses

VARIANTS = [
    dict(leafless=True, dtype=np.float64),
    dict(leafless=False, dtype=np.float64),
    dict(leafless=True, dtype=np.float32),
    dict(leafless=False, dtype=np.float32),
]

# Two generated meshes and their tree variants, as the hypothesis tests draw them.
SCENES = dict(
    kind_a=st.sampled_from(MESH_KINDS),
    kind_b=st.sampled_from(MESH_KINDS),
    seed=st.integers(0, 2**31),
    variant_a=st.sampled_from(VARIANTS),
    variant_b=st.sampled_from(VARIANTS),
)


def _sorted(pairs):
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def _faces_under(tree, code):
    """The faces under a code of ``tree`` (node ``k >= 0`` or face ``-k - 1``), by its
    children array."""
    faces, codes = [], [int(code)]
    while codes:
        k = codes.pop()
        if k < 0:
            faces.append(-k - 1)
            continue
        c0, c1 = (int(c) for c in tree.children[k])
        codes.extend([c0] if c0 == c1 else [c0, c1])  # a classic leaf holds (-t-1, -t-1)
    return faces


def _pairs_under(tree_a, tree_b, code_pairs):
    """Every face pair under each code pair, as a list (a pair under two code pairs twice)."""
    return [
        (face_a, face_b)
        for x, y in code_pairs
        for face_a in _faces_under(tree_a, x)
        for face_b in _faces_under(tree_b, y)
    ]


def _every_pair(mesh_a, mesh_b):
    return [(a, b) for a in range(len(mesh_a.faces)) for b in range(len(mesh_b.faces))]


def _resumed_walk(first_only, P_a, P_b, M, t, start):
    """``walk`` from the code pairs ``start`` (k, 2) to its end, as the package's callers run
    it: begun with one spare stack row and one row each for pairs and front, so that it stops
    often, and resumed each time with the full array doubled. Returns (pairs, front, stops)."""
    from thesis_rbd.collision.mesh.packed import layout
    from thesis_rbd.collision.queries.collide import walk, with_room

    La, Lb = layout(P_a), layout(P_b)
    stack = np.empty((len(start) + 1, 2), dtype=np.int64)
    stack[: len(start)] = start
    pairs = np.empty((1, 2), dtype=np.int64)
    front = np.empty((1, 2), dtype=np.int64)
    counts = np.zeros(3, dtype=np.int64)
    top, found, n_front, stops = len(start), 0, 0, 0
    while True:
        top, found, n_front = walk(
            first_only, P_a, La, P_b, Lb, M, t, stack, top, pairs, found, counts, front, n_front
        )
        if top == 0 or (first_only and found):
            return pairs[:found], front[:n_front], stops
        stops += 1
        if found == len(pairs):
            pairs = with_room(pairs)
        elif n_front == len(front):
            front = with_room(front)
        else:
            stack = with_room(stack)


def _scene(kind_a, kind_b, seed):
    mesh_a = random_mesh(kind_a, seed)
    mesh_b = random_mesh(kind_b, seed + 1)
    reach = 0.6 * (mesh_a.scale + mesh_b.scale)
    return mesh_a, random_pose(seed + 2, reach), mesh_b, random_pose(seed + 3, reach)


@settings(max_examples=examples(60))
@given(**SCENES)
def test_all_modes_match_brute_force_and_fcl(kind_a, kind_b, seed, variant_a, variant_b):
    mesh_a, T_a, mesh_b, T_b = _scene(kind_a, kind_b, seed)
    tree_a = rbd.OBBTree(mesh_a, **variant_a)
    tree_b = rbd.OBBTree(mesh_b, **variant_b)
    expected = brute_force_pairs(mesh_a, T_a, mesh_b, T_b)

    res_all = rbd.collide(tree_a, T_a, tree_b, T_b, mode="all")
    np.testing.assert_array_equal(res_all.pairs, expected)
    assert res_all.colliding == (len(expected) > 0)
    assert res_all.pairs.dtype == np.int64 and res_all.pairs.shape[1] == 2

    res_first = rbd.collide(tree_a, T_a, tree_b, T_b, mode="first")
    assert res_first.colliding == (len(expected) > 0)
    assert len(res_first.pairs) == (1 if len(expected) else 0)
    if len(expected):
        assert tuple(res_first.pairs[0]) in set(map(tuple, expected))

    res_contacts = rbd.collide(tree_a, T_a, tree_b, T_b, mode="contacts")
    np.testing.assert_array_equal(res_contacts.pairs, expected)
    assert res_contacts.colliding == res_all.colliding

    obj_a = fcl_object(fcl_model(mesh_a), T_a)
    obj_b = fcl_object(fcl_model(mesh_b), T_b)
    hit_fcl, pairs_fcl = fcl_collide(obj_a, obj_b, max_contacts=100000)
    assert hit_fcl == res_all.colliding == res_first.colliding
    np.testing.assert_array_equal(_sorted(pairs_fcl), res_all.pairs)


def test_tori_demo_poses_match_fcl():
    mesh = tori_mesh()
    poses = tori_poses()[::7]
    model = fcl_model(mesh)
    obj_a = fcl_object(model)
    trees = [rbd.OBBTree(mesh, **v) for v in VARIANTS[:3]]
    hits = 0
    for T_b in poses:
        hit_fcl, pairs_fcl = fcl_collide(obj_a, fcl_object(model, T_b))
        hits += hit_fcl
        for tree in trees:
            res = rbd.collide(tree, np.eye(4), tree, T_b, mode="all")
            assert res.colliding == hit_fcl
            np.testing.assert_array_equal(res.pairs, _sorted(pairs_fcl))
            assert rbd.collide(tree, np.eye(4), tree, T_b, mode="first").colliding == hit_fcl
    assert 0 < hits < len(poses)


def test_pairs_sorted_and_unique_and_world_frame_invariant():
    mesh = rbd.shapes.icosphere(1.0, 2)
    tree = rbd.OBBTree(mesh)
    T_b = np.eye(4)
    T_b[:3, 3] = (1.2, 0.3, 0.1)
    res = rbd.collide(tree, np.eye(4), tree, T_b, mode="all")
    assert len(res.pairs) > 10
    assert len(np.unique(res.pairs, axis=0)) == len(res.pairs)
    np.testing.assert_array_equal(res.pairs, _sorted(res.pairs))
    # Moving both meshes by the same rigid motion changes nothing.
    G = random_pose(7, 5.0)
    moved = rbd.collide(tree, G, tree, G @ T_b, mode="all")
    np.testing.assert_array_equal(moved.pairs, res.pairs)
    # Swapping A and B swaps the columns.
    swapped = rbd.collide(tree, T_b, tree, np.eye(4), mode="all")
    np.testing.assert_array_equal(_sorted(swapped.pairs[:, ::-1]), res.pairs)


def test_far_apart_costs_one_box_test_and_stats_count():
    tree = rbd.OBBTree(rbd.shapes.box())
    T_b = np.eye(4)
    T_b[0, 3] = 10.0
    res = rbd.collide(tree, np.eye(4), tree, T_b, mode="all")
    assert not res.colliding and res.pairs.shape == (0, 2)
    assert res.stats["bv_tests"] == 1 and res.stats["tri_tests"] == 0
    assert res.contacts is None
    T_b[0, 3] = 0.5
    res = rbd.collide(tree, np.eye(4), tree, T_b, mode="all")
    assert res.colliding
    assert res.stats["tri_tests"] >= len(res.pairs) > 0
    assert res.stats["bv_tests"] > 1


def test_touching_faces_count_as_colliding():
    # Two unit cubes sharing the face x = 0.5 exactly (integer-friendly coordinates).
    tree = rbd.OBBTree(rbd.shapes.box())
    T_b = np.eye(4)
    T_b[0, 3] = 1.0
    assert rbd.collide(tree, np.eye(4), tree, T_b).colliding
    T_b[0, 3] = 1.0 + 1e-9
    assert not rbd.collide(tree, np.eye(4), tree, T_b).colliding


def test_single_triangle_meshes():
    tri = rbd.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    for leafless in (True, False):
        tree = rbd.OBBTree(tri, leafless=leafless)
        assert tree.node_count == (0 if leafless else 1)
        T_b = np.eye(4)
        T_b[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # stood up, crossing the first
        T_b[:3, 3] = (0.2, 0.2, -0.5)
        big = rbd.OBBTree(rbd.shapes.icosphere(1.0, 1), leafless=leafless)
        for a, b in ((tree, tree), (tree, big), (big, tree)):
            res = rbd.collide(a, np.eye(4), b, T_b, mode="all")
            assert np.array_equal(res.pairs, brute_force_pairs(a.mesh, np.eye(4), b.mesh, T_b))
        assert rbd.collide(tree, np.eye(4), tree, T_b).colliding


@pytest.mark.parametrize(
    "T, message",
    [
        (np.diag([1.0, 1.0, 2.0, 1.0]), "rigid"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "rigid"),
        (np.full((4, 4), np.nan), "non-finite"),
        (np.eye(3), "shape"),
        ("eye", "numeric"),
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]], float), "homogeneous"),
    ],
)
def test_invalid_transforms_raise(T, message):
    tree = rbd.OBBTree(rbd.shapes.box())
    with pytest.raises(ValueError, match=message):
        rbd.collide(tree, T, tree, np.eye(4))
    with pytest.raises(ValueError, match=message):
        rbd.collide(tree, np.eye(4), tree, T)


def test_integer_and_list_transforms_are_accepted():
    tree = rbd.OBBTree(rbd.shapes.box())
    res = rbd.collide(tree, np.eye(4, dtype=int), tree, np.eye(4).tolist(), mode="all")
    assert res.colliding


def test_invalid_mode_tree_and_tolerance_raise():
    tree = rbd.OBBTree(rbd.shapes.box())
    with pytest.raises(ValueError, match="mode"):
        rbd.collide(tree, np.eye(4), tree, np.eye(4), mode="any")
    with pytest.raises(ValueError, match="OBBTree"):
        rbd.collide(tree.mesh, np.eye(4), tree, np.eye(4))
    with pytest.raises(ValueError, match="merge_tolerance"):
        rbd.collide(tree, np.eye(4), tree, np.eye(4), mode="contacts", merge_tolerance=-1)


def test_fcl_adapter_quaternion_round_trip():
    from scipy.spatial.transform import Rotation

    from validation.fcl_adapter import fcl_transform, quat_wxyz_to_xyzw, quat_xyzw_to_wxyz

    q = Rotation.random(5, random_state=4).as_quat()  # (x, y, z, w)
    np.testing.assert_array_equal(quat_wxyz_to_xyzw(quat_xyzw_to_wxyz(q)), q)
    np.testing.assert_array_equal(quat_xyzw_to_wxyz(q)[:, 0], q[:, 3])
    T = random_pose(11, 3.0)
    tf = fcl_transform(T)
    np.testing.assert_allclose(tf.getRotation(), T[:3, :3], atol=1e-12)
    np.testing.assert_allclose(tf.getTranslation(), T[:3, 3])
    back = Rotation.from_quat(quat_wxyz_to_xyzw(tf.getQuatRotation())).as_matrix()
    np.testing.assert_allclose(back, T[:3, :3], atol=1e-12)


def test_fortran_ordered_and_readonly_poses_give_the_same_answer():
    tree = rbd.OBBTree(rbd.shapes.icosphere(1.0, 2))
    T_b = random_pose(5, 1.5)
    want = rbd.collide(tree, np.eye(4), tree, T_b, mode="all").pairs
    fortran = np.asfortranarray(T_b)
    readonly = T_b.copy()
    readonly.flags.writeable = False
    for T in (fortran, readonly, T_b.tolist()):
        np.testing.assert_array_equal(rbd.collide(tree, np.eye(4), tree, T, mode="all").pairs, want)


@settings(max_examples=examples(20))
@given(**SCENES)
def test_a_walk_resumed_whenever_it_runs_out_of_room_finds_every_pair(
    kind_a, kind_b, seed, variant_a, variant_b
):
    """The traversal stops, its state intact, when its stack or its pair rows are full, and
    the caller resumes it with a larger copy: started with room for two stack rows and one
    pair, so it stops and resumes over and over, it must still find exactly the brute-force
    pairs (and the first pair in "first" mode)."""
    from thesis_rbd.collision.queries._query_args import relative_pose

    mesh_a, T_a, mesh_b, T_b = _scene(kind_a, kind_b, seed)
    tree_a = rbd.OBBTree(mesh_a, **variant_a)
    tree_b = rbd.OBBTree(mesh_b, **variant_b)
    P_a, P_b = tree_a.query_array(), tree_b.query_array()
    M, t = relative_pose(T_a, T_b)
    roots = np.array([[tree_a.root, tree_b.root]])
    expected = brute_force_pairs(mesh_a, T_a, mesh_b, T_b)
    for first_only in (False, True):
        pairs, front, stops = _resumed_walk(first_only, P_a, P_b, M, t, roots)
        # Any descent fills a two-row stack.
        assert stops > 0 or len(expected) == 0 or tree_a.root < 0 or tree_b.root < 0
        if first_only:
            assert len(pairs) == min(1, len(expected))
            if len(pairs):
                assert tuple(pairs[0]) in set(map(tuple, expected))
        else:
            np.testing.assert_array_equal(_sorted(pairs), expected)
            # Resumed whenever the front was full too, the front holds every pair not found.
            under = _pairs_under(tree_a, tree_b, front)
            assert sorted(under + list(map(tuple, expected))) == _every_pair(mesh_a, mesh_b)


@settings(max_examples=examples(20))
@given(**SCENES, overlap=st.floats(0.0, 0.3))
def test_walk_stack_has_room_for_every_walk(kind_a, kind_b, seed, variant_a, variant_b, overlap):
    """walk_stack sizes the stack from the tree depths (a descent adds at most one row per
    level): a whole "all" walk, meshes pushed into each other, never stops for room."""
    from thesis_rbd.collision.mesh.packed import layout
    from thesis_rbd.collision.queries._query_args import relative_pose
    from thesis_rbd.collision.queries.collide import walk, walk_stack

    mesh_a = random_mesh(kind_a, seed)
    mesh_b = random_mesh(kind_b, seed + 1)
    T_b = random_pose(seed + 2, overlap * (mesh_a.scale + mesh_b.scale))
    P_a = rbd.OBBTree(mesh_a, **variant_a).query_array()
    P_b = rbd.OBBTree(mesh_b, **variant_b).query_array()
    La, Lb = layout(P_a), layout(P_b)
    M, t = relative_pose(np.eye(4), T_b)
    stack = walk_stack(P_a, P_b)
    stack[0] = La[6], Lb[6]
    pairs = np.empty((len(mesh_a.faces) * len(mesh_b.faces), 2), dtype=np.int64)
    counts = np.zeros(3, dtype=np.int64)
    top, found, _ = walk(False, P_a, La, P_b, Lb, M, t, stack, 1, pairs, 0, counts, None, 0)
    assert top == 0
    np.testing.assert_array_equal(
        _sorted(pairs[:found]), brute_force_pairs(mesh_a, np.eye(4), mesh_b, T_b)
    )


@settings(max_examples=examples(30))
@given(**SCENES, step=st.floats(0.0, 0.1))
def test_a_walk_from_the_front_at_a_nearby_pose_finds_every_pair(
    kind_a, kind_b, seed, variant_a, variant_b, step
):
    """A whole walk's front (the code pairs it found disjoint) and the pairs it found cover
    every face pair exactly once, and no face pair under the front intersects; a walk at a
    nearby pose that starts from them (as collide_batch's runs start from the previous
    pose's front) finds exactly the brute-force pairs there."""
    from scipy.spatial.transform import Rotation

    from thesis_rbd.collision.queries._query_args import relative_pose

    mesh_a, T_a, mesh_b, T_b = _scene(kind_a, kind_b, seed)
    tree_a = rbd.OBBTree(mesh_a, **variant_a)
    tree_b = rbd.OBBTree(mesh_b, **variant_b)
    P_a, P_b = tree_a.query_array(), tree_b.query_array()

    def whole_walk(T, start):
        pairs, front, _ = _resumed_walk(False, P_a, P_b, *relative_pose(T_a, T), start)
        return pairs, front

    pairs, front = whole_walk(T_b, np.array([[tree_a.root, tree_b.root]]))
    expected = brute_force_pairs(mesh_a, T_a, mesh_b, T_b)
    np.testing.assert_array_equal(_sorted(pairs), expected)
    under = _pairs_under(tree_a, tree_b, front)
    assert set(under).isdisjoint(map(tuple, expected))
    assert sorted(under + list(map(tuple, expected))) == _every_pair(mesh_a, mesh_b)

    rng = np.random.default_rng(seed)
    nearby = T_b.copy()
    nearby[:3, :3] = Rotation.from_rotvec(rng.normal(size=3) * step).as_matrix() @ T_b[:3, :3]
    nearby[:3, 3] += rng.normal(size=3) * step * mesh_b.scale
    start = np.concatenate([front, -pairs - 1])  # the found pairs as face codes
    pairs_nearby, _ = whole_walk(nearby, start)
    np.testing.assert_array_equal(
        _sorted(pairs_nearby), brute_force_pairs(mesh_a, T_a, mesh_b, nearby)
    )
