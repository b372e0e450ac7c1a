"""The convex-hull certificate of the distance query, against brute force and python-fcl.

``distance`` first runs GJK over the two meshes' convex hulls and accepts the triangle pair
around the hulls' closest features when its distance meets the hulls' lower bound
(:mod:`thesis_rbd.collision.queries.hull_distance`); elsewhere it descends the trees. These
tests check the hull block a tree carries (its vertex graph finds every support point a
brute-force scan over the mesh finds; the faces listed around each hull vertex are exactly
the mesh's), that convex sides facing each other are answered by the hulls alone, and that a
concavity the hull spans (a ball above a torus's hole, where the hull's cap is nearer than
the torus) is searched, not taken from the hull.
"""

from __future__ import annotations

import numpy as np
import trimesh
from hypothesis import example, given, settings
from hypothesis import strategies as st
from numba import njit
from reference import examples, random_pose
from test_distance import fcl_distance

import thesis_rbd as rbd
from thesis_rbd.collision.mesh.packed import hull_row, layout
from thesis_rbd.collision.mesh.packed_hull import hull_fields
from thesis_rbd.collision.queries.triangle_distance import triangle_distance


@njit(cache=True)
def _all_pairs(ta, tb):
    best = np.inf
    for i in range(ta.shape[0]):
        p = (ta[i, 0, 0], ta[i, 0, 1], ta[i, 0, 2])
        q = (ta[i, 1, 0], ta[i, 1, 1], ta[i, 1, 2])
        r = (ta[i, 2, 0], ta[i, 2, 1], ta[i, 2, 2])
        for j in range(tb.shape[0]):
            d = triangle_distance(
                p, q, r, (tb[j, 0, 0], tb[j, 0, 1], tb[j, 0, 2]),
                (tb[j, 1, 0], tb[j, 1, 1], tb[j, 1, 2]), (tb[j, 2, 0], tb[j, 2, 1], tb[j, 2, 2]),
            )[0]  # fmt: skip
            best = min(best, d)
    return best


def all_pairs_distance(mesh_a, T_a, mesh_b, T_b) -> float:
    """Least distance over every triangle pair, each measured by the package's exact triangle
    distance (itself checked against the plain-Python reference in test_distance.py): the
    naive search a tree descent must agree with, fast enough for a ring of near-equal pairs
    that the Python brute force would take minutes over."""
    world = [
        np.ascontiguousarray(m.triangles @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3])
        for m, T in ((mesh_a, T_a), (mesh_b, T_b))
    ]
    return float(_all_pairs(*world))


def convex_mesh(kind: str, seed: int) -> rbd.TriangleMesh:
    rng = np.random.default_rng(seed)
    if kind == "icosphere":
        return rbd.shapes.icosphere(rng.uniform(0.2, 1.0), 2)
    if kind == "cylinder":
        return rbd.shapes.cylinder(rng.uniform(0.2, 0.6), rng.uniform(0.3, 2.0), 24)
    if kind == "capsule":
        m = trimesh.creation.capsule(height=rng.uniform(0.2, 1.5), radius=0.3, count=[16, 8])
        return rbd.TriangleMesh(m.vertices, m.faces)
    points = rng.normal(size=(int(rng.integers(8, 200)), 3)) * rng.uniform(0.2, 1.0, 3)
    return rbd.TriangleMesh.from_trimesh(trimesh.convex.convex_hull(points))


CONVEX = st.sampled_from(["icosphere", "cylinder", "capsule", "hull"])


def inside(mesh_a, T_a, mesh_b, T_b) -> bool:
    """Whether a vertex of convex mesh A lies inside convex mesh B (Qhull's facet planes):
    surfaces apart, one body inside the other, whose hulls then overlap."""
    from scipy.spatial import ConvexHull

    a = np.asarray(mesh_a.vertices) @ np.asarray(T_a)[:3, :3].T + np.asarray(T_a)[:3, 3]
    b = np.asarray(mesh_b.vertices) @ np.asarray(T_b)[:3, :3].T + np.asarray(T_b)[:3, 3]
    planes = ConvexHull(b).equations
    return bool(((a @ planes[:, :3].T + planes[:, 3]) < 0).all(axis=1).any())


def unpacked_hull(tree):
    """(coordinates (h, 3), neighbour lists, faces around each hull vertex) of a tree."""
    P = tree.query_array(hull=True)
    F = P.reshape(-1)
    h, xyz, start, neighbours, face_start, faces = hull_fields(F, 3 * hull_row(P, layout(P)))
    coordinates = F[xyz : xyz + 3 * h].reshape(h, 3)
    starts = F[start : start + h + 1].astype(int)
    around = F[face_start : face_start + h + 1].astype(int)
    return (
        coordinates,
        [F[neighbours + starts[v] : neighbours + starts[v + 1]].astype(int) for v in range(h)],
        [F[faces + around[v] : faces + around[v + 1]].astype(int) for v in range(h)],
    )


def test_the_hull_block_finds_every_support_and_lists_the_faces_around():
    """From any start, climbing the hull's vertex graph reaches the mesh vertex farthest along
    a direction (a brute-force scan of all vertices); the faces listed around a hull vertex
    are the mesh faces that hold it."""
    rng = np.random.default_rng(0)
    for mesh in (rbd.shapes.torus(1.0, 0.3, 24, 12), rbd.shapes.box((1, 2, 3)),
                 convex_mesh("hull", 3), convex_mesh("capsule", 4)):  # fmt: skip
        coordinates, neighbours, around = unpacked_hull(rbd.OBBTree(mesh))
        vertices = np.asarray(mesh.vertices)
        for d in rng.normal(size=(200, 3)):
            v = int(rng.integers(len(coordinates)))
            moved = True
            while moved:
                moved = False
                for u in neighbours[v]:
                    if coordinates[u] @ d > coordinates[v] @ d:
                        v, moved = u, True
            assert coordinates[v] @ d >= (vertices @ d).max() - 1e-12 * mesh.scale
        for point, faces in zip(coordinates, around, strict=True):
            (index,) = np.flatnonzero((vertices == point).all(axis=1))
            np.testing.assert_array_equal(
                np.sort(faces), np.flatnonzero((np.asarray(mesh.faces) == index).any(axis=1))
            )


def test_a_flat_mesh_has_no_hull_and_is_searched():
    square = rbd.TriangleMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    tree = rbd.OBBTree(square)
    P = tree.query_array(hull=True)
    assert P.reshape(-1)[3 * hull_row(P, layout(P))] == 0.0
    pose = np.eye(4)
    pose[2, 3] = 0.5
    result = rbd.distance(tree, np.eye(4), tree, pose)
    assert result.distance == 0.5 and result.stats["bv_tests"] > 0


@settings(max_examples=examples(40))
@given(kind_a=CONVEX, kind_b=CONVEX, seed=st.integers(0, 2**31), reach=st.floats(1.0, 4.0))
# GJK's starting vertices already the closest pair: it stopped before taking a feature
@example(kind_a="hull", kind_b="hull", seed=177, reach=2.0)
def test_convex_sides_apart_are_answered_by_the_hulls(kind_a, kind_b, seed, reach):
    """Two convex meshes apart: the distance equals a search over every triangle pair and
    python-fcl's to 1e-9 of the size, and the hulls prove it (no box tested) wherever
    every mesh vertex is a hull vertex and neither body lies inside the other (surfaces
    apart, hulls overlapping: the trees measure the surfaces' distance). A cylinder's caps
    are fans around a centre vertex that lies inside the hull's cap faces: where a closest
    point falls in a fan triangle away from the hull face's corners, the trees are
    searched."""
    mesh_a = convex_mesh(kind_a, seed)
    mesh_b = convex_mesh(kind_b, seed + 1)
    size = max(mesh_a.scale, mesh_b.scale)
    T_a = random_pose(seed + 2, reach * size)
    T_b = random_pose(seed + 3, reach * size)
    result = rbd.distance(rbd.OBBTree(mesh_a), T_a, rbd.OBBTree(mesh_b), T_b)
    exact = all_pairs_distance(mesh_a, T_a, mesh_b, T_b)
    if exact == 0.0:
        assert result.distance == 0.0
        return
    nested = inside(mesh_a, T_a, mesh_b, T_b) or inside(mesh_b, T_b, mesh_a, T_a)
    if "cylinder" not in (kind_a, kind_b) and not nested:
        assert result.stats["bv_tests"] == 0
    assert abs(result.distance - exact) <= 1e-9 * size
    assert abs(result.distance - fcl_distance(mesh_a, T_a, mesh_b, T_b)) <= 1e-9 * size


@settings(max_examples=examples(30))
@given(height=st.floats(0.1, 3.0), shift=st.floats(0.0, 0.3), radius=st.floats(0.05, 0.4))
def test_a_ball_above_a_torus_hole_is_searched_not_taken_from_the_hull(height, shift, radius):
    """A ball on (or near) a torus's axis: the torus's hull has a cap over the hole nearer the
    ball than any of its triangles, so the hulls' bound cannot meet the triangles' distance;
    the trees are searched and the answer is the brute force's (accepting the triangles
    around the hull's closest features here was 2 % too far on the distance paths)."""
    torus = rbd.shapes.torus(1.0, 0.3, 32, 12)
    ball = rbd.shapes.icosphere(radius, 2)
    pose = np.eye(4)
    pose[:3, 3] = (shift, 0.0, 0.3 + radius + height)
    result = rbd.distance(rbd.OBBTree(torus), np.eye(4), rbd.OBBTree(ball), pose)
    exact = all_pairs_distance(torus, np.eye(4), ball, pose)
    assert result.stats["bv_tests"] > 0
    assert abs(result.distance - exact) <= 1e-9 * torus.scale
    assert abs(result.distance - fcl_distance(torus, np.eye(4), ball, pose)) <= 1e-9 * torus.scale
