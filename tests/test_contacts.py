"""Contact report: points on both triangles, unit normals B -> A, depths, merging."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st
from reference import (
    MESH_KINDS,
    cluster_reference,
    examples,
    least_penetration_reference,
    point_triangle_distance,
    random_mesh,
    random_pose,
)

import thesis_rbd as rbd
from thesis_rbd.collision.mesh.contact_report import least_penetration, merge_contacts
from thesis_rbd.collision.queries.collide import MERGE_FRACTION


def _world_triangles(mesh, T):
    return mesh.triangles @ T[:3, :3].T + T[:3, 3]


def _check_contacts(res, mesh_a, T_a, mesh_b, T_b, tol):
    c = res.contacts
    n = len(c)
    assert c.points.shape == (n, 3) and c.normals.shape == (n, 3)
    assert c.depths.shape == (n,) and c.faces.shape == (n, 2) and c.faces.dtype == np.int64
    assert np.all(np.isfinite(c.points)) and np.all(np.isfinite(c.normals))
    np.testing.assert_allclose(np.linalg.norm(c.normals, axis=1), 1.0, atol=1e-12)
    assert np.all(c.depths >= 0)
    assert res.colliding == (n > 0)
    # Every contact comes from an intersecting pair.
    pairs = set(map(tuple, res.pairs))
    assert set(map(tuple, c.faces)) <= pairs
    # Points lie on both triangles of their pair, up to rounding (a point of the pair's
    # intersection, or for a degenerate triangle the midpoint of two touching features).
    size = max(mesh_a.scale, mesh_b.scale)
    ta = _world_triangles(mesh_a, T_a)
    tb = _world_triangles(mesh_b, T_b)
    for x, (fa, fb) in zip(c.points, c.faces, strict=True):
        assert point_triangle_distance(x, ta[fa]) <= 1e-9 * size
        assert point_triangle_distance(x, tb[fb]) <= 1e-9 * size
    # No two contacts closer than the merge tolerance.
    if n > 1:
        gaps = np.linalg.norm(c.points[:, None] - c.points[None], axis=2)
        gaps[np.arange(n), np.arange(n)] = np.inf
        assert gaps.min() > tol


@settings(max_examples=examples(40))
@given(
    kind_a=st.sampled_from(MESH_KINDS),
    kind_b=st.sampled_from(MESH_KINDS),
    seed=st.integers(0, 2**31),
)
# a degenerate mesh's collinear corners, rounded, make a sliver whose plane is noise
@example(kind_a="degenerate", kind_b="torus", seed=458428995)
@example(kind_a="degenerate", kind_b="noisy_sphere", seed=565751911)
def test_contact_properties_on_random_scenes(kind_a, kind_b, seed):
    mesh_a = random_mesh(kind_a, seed)
    mesh_b = random_mesh(kind_b, seed + 1)
    reach = 0.5 * (mesh_a.scale + mesh_b.scale)
    T_a = random_pose(seed + 2, reach)
    T_b = random_pose(seed + 3, reach)
    tree_a = rbd.OBBTree(mesh_a)
    tree_b = rbd.OBBTree(mesh_b, leafless=False)
    res = rbd.collide(tree_a, T_a, tree_b, T_b, mode="contacts")
    tol = MERGE_FRACTION * max(mesh_a.scale, mesh_b.scale)
    _check_contacts(res, mesh_a, T_a, mesh_b, T_b, tol)
    # A coarser merge keeps a subset of the points, still valid and further apart.
    coarse = rbd.collide(tree_a, T_a, tree_b, T_b, mode="contacts", merge_tolerance=0.05)
    _check_contacts(coarse, mesh_a, T_a, mesh_b, T_b, 0.05)
    assert len(coarse.contacts) <= len(res.contacts)
    assert set(map(tuple, coarse.contacts.points)) <= set(map(tuple, res.contacts.points))


def test_box_resting_on_box_gives_upward_normals_and_the_penetration():
    box = rbd.OBBTree(rbd.shapes.box((1.0, 1.0, 1.0)))
    floor = rbd.OBBTree(rbd.shapes.box((4.0, 4.0, 1.0)))
    T_a = np.eye(4)
    T_a[:3, 3] = (0.1, -0.2, 0.99)  # A's bottom 0.01 below the floor's top (z = 0.5)
    T_b = np.eye(4)
    res = rbd.collide(box, T_a, floor, T_b, mode="contacts")
    c = res.contacts
    assert len(c) >= 4
    np.testing.assert_allclose(c.normals, np.tile([0, 0, 1.0], (len(c), 1)), atol=1e-12)
    np.testing.assert_allclose(c.depths, 0.01, atol=1e-12)
    np.testing.assert_allclose(c.points[:, 2], 0.5, atol=1e-12)
    # The four corners of the box's footprint are among the points.
    for sx in (-0.5, 0.5):
        for sy in (-0.5, 0.5):
            corner = np.array([0.1 + sx, -0.2 + sy, 0.5])
            assert np.linalg.norm(c.points - corner, axis=1).min() < 1e-12
    # Swapping A and B flips the normals.
    swapped = rbd.collide(floor, T_b, box, T_a, mode="contacts").contacts
    np.testing.assert_allclose(
        swapped.normals, np.tile([0, 0, -1.0], (len(swapped), 1)), atol=1e-12
    )


def test_duplicates_of_shared_polyline_corners_are_merged():
    sphere = rbd.OBBTree(rbd.shapes.icosphere(1.0, 2))
    T_b = np.eye(4)
    T_b[:3, 3] = (1.3, 0.2, 0.1)
    res = rbd.collide(sphere, np.eye(4), sphere, T_b, mode="contacts")
    before = res.stats["contacts_before_merge"]
    # Each corner of the closed intersection curve is produced by the two pairs on either side
    # of the crossing edge: merging halves the count.
    assert before == 2 * len(res.pairs)
    assert len(res.contacts) == len(res.pairs)
    unmerged = rbd.collide(sphere, np.eye(4), sphere, T_b, mode="contacts", merge_tolerance=0.0)
    assert len(unmerged.contacts) == len(res.contacts)  # the duplicates are bitwise equal


def test_edge_edge_contact_normal():
    # Two long thin boxes crossing like a plus sign, A above B, A's bottom edge (along y) dug
    # into B's top edge (along x): the normal is along z, from B to A.
    a = rbd.OBBTree(rbd.shapes.box((0.2, 4.0, 0.2)))
    b = rbd.OBBTree(rbd.shapes.box((4.0, 0.2, 0.2)))
    rot45x = np.eye(4)
    c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
    rot45x[:3, :3] = [[1, 0, 0], [0, c, -s], [0, s, c]]
    rot45y = np.eye(4)
    rot45y[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    T_a = rot45y.copy()
    T_a[2, 3] = 0.2 * np.sqrt(2) - 0.01
    T_b = rot45x
    res = rbd.collide(a, T_a, b, T_b, mode="contacts")
    assert res.colliding
    n = res.contacts.normals
    assert np.all(n[:, 2] > 0.99)
    assert np.all(res.contacts.depths < 0.011)


@settings(max_examples=examples(100))
@given(seed=st.integers(0, 2**31), flat=st.sampled_from([None, "a", "b"]))
def test_least_penetration_matches_reference(seed, flat):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(3, 3))
    Q = rng.normal(size=(3, 3))
    # a sliver: the middle of an edge, rounded, for a corner (its plane is noise)
    if flat == "a":
        P[1] = 0.5 * (P[0] + P[2])
    elif flat == "b":
        Q[1] = 0.5 * (Q[0] + Q[2])
    u, d = least_penetration(*map(tuple, P), *map(tuple, Q))
    u_ref, d_ref = least_penetration_reference(P, Q)
    assert abs(d - d_ref) <= 1e-12 * (1 + d_ref)
    u = np.array(u)
    np.testing.assert_allclose(np.linalg.norm(u), 1.0)
    # Depth along the returned normal is the returned depth; the normal is the reference's
    # unless two candidates tie.
    assert abs(max(max(Q @ u) - min(P @ u), 0.0) - d) <= 1e-12 * (1 + d)
    assert np.allclose(u, u_ref, atol=1e-9) or abs(max(Q @ u_ref) - min(P @ u_ref) - d) < 1e-12


@settings(max_examples=examples(60))
@given(seed=st.integers(0, 2**31), tol=st.sampled_from([0.0, 0.05, 0.2]))
def test_merge_matches_cluster_reference(seed, tol):
    rng = np.random.default_rng(seed)
    base = rng.uniform(0, 1, size=(int(rng.integers(1, 30)), 3))
    # Exact duplicates and near neighbours.
    points = np.vstack([base, base[: len(base) // 2], base[:3] + 0.01])
    depths = rng.uniform(0, 1, len(points))
    keep = merge_contacts(points, depths, tol)
    clusters = cluster_reference(points, tol)
    expected = sorted(min(cl, key=lambda i: (depths[i], i)) for cl in clusters)
    np.testing.assert_array_equal(keep, expected)
