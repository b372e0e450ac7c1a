"""Distance and continuous collision with degenerate triangles, against python-fcl, a brute
force over triangle pairs and ``collide``.

A mesh may hold zero-area triangles (``TriangleMesh.degenerate_faces`` lists them): a sliver
whose third corner lies on the segment of the other two, or one with a repeated corner. Such
a triangle is a segment, and the queries must treat it as one: ``distance`` is 0.0 exactly
where ``collide`` reports an intersection and the least distance to the segment elsewhere,
``distance_batch`` agrees with it pose by pose, and ``continuous_collide`` finds a first
contact no later than sampling the motion with ``collide`` does. (The distance traversal's
triangle-box bound once projected one corner only on the triangle's normal, which for a
segment is round-off: it pruned the boxes that held the closest pair.)
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import examples, random_pose
from reference_queries import brute_force_distance
from test_distance import fcl_distance

import thesis_rbd as rbd

OBSTACLES = {
    "box": lambda: rbd.shapes.box((2.0, 1.5, 1.0)),
    "icosphere": lambda: rbd.shapes.icosphere(1.0, 2),
}


def degenerate_mesh(kind: str, seed: int) -> rbd.TriangleMesh:
    """A mesh of zero-area triangles only: one sliver (third corner at a point of the other
    two's segment), one with a repeated corner, or a fan of slivers."""
    rng = np.random.default_rng(seed)
    a, b = rng.uniform(-1.0, 1.0, (2, 3))
    if kind == "sliver":
        return rbd.TriangleMesh(np.array([a, b, 0.5 * (a + b)]), np.array([[0, 1, 2]]))
    if kind == "repeated":
        return rbd.TriangleMesh(np.array([a, b, b]), np.array([[0, 1, 2]]))
    corners = [a, b]
    for fraction in rng.uniform(0.05, 0.95, 4):
        corners.append(a + fraction * (b - a))
    faces = [[0, 1, k] for k in range(2, len(corners))]
    return rbd.TriangleMesh(np.array(corners), np.array(faces))


KINDS = st.sampled_from(["sliver", "repeated", "fan"])


@settings(max_examples=examples(60))
@given(
    kind=KINDS,
    obstacle=st.sampled_from(sorted(OBSTACLES)),
    seed=st.integers(0, 2**31),
    reach=st.floats(0.2, 2.0),
)
def test_distance_to_degenerate_triangles_is_exact(kind, obstacle, seed, reach):
    """Against python-fcl and the brute force to 1e-9 of the size, 0.0 exactly where
    ``collide`` says they intersect and positive elsewhere; ``distance_batch`` the same."""
    mesh = degenerate_mesh(kind, seed)
    other = OBSTACLES[obstacle]()
    tree, other_tree = rbd.OBBTree(mesh), rbd.OBBTree(other)
    poses = np.stack([random_pose(seed + k, reach) for k in range(8)])
    identity = np.eye(4)
    found = rbd.distance_batch(other_tree, identity, tree, poses)
    for T, d in zip(poses, found, strict=True):
        single = rbd.distance(other_tree, identity, tree, T).distance
        assert single == d
        colliding = rbd.collide(other_tree, identity, tree, T).colliding
        assert (d == 0.0) == colliding
        if not colliding:
            expected = brute_force_distance(other, identity, mesh, T)
            assert abs(d - expected) <= 1e-9 * 2.0
            assert abs(d - fcl_distance(other, identity, mesh, T)) <= 1e-9 * 2.0
        else:
            assert fcl_distance(other, identity, mesh, T) <= 1e-9


@settings(max_examples=examples(40))
@given(kind=KINDS, seed=st.integers(0, 2**31))
def test_a_degenerate_triangle_moving_into_a_box_is_caught_first(kind, seed):
    """Zero-area triangles sliding into a box from 4 m away (eight motions): the first
    contact of ``continuous_collide`` is never later than the first of 401 ``collide``
    samples along the motion."""
    rng = np.random.default_rng(seed)
    box = rbd.OBBTree(rbd.shapes.box((2.0, 2.0, 2.0)))
    tree = rbd.OBBTree(degenerate_mesh(kind, seed))
    identity = np.eye(4)
    times = np.linspace(0.0, 1.0, 401)
    for k in range(8):
        start = random_pose(seed + k, 1.0)
        direction = rng.normal(size=3)
        start[:3, 3] = 4.0 * direction / np.linalg.norm(direction)
        end = start.copy()
        end[:3, 3] = rng.uniform(-0.5, 0.5, 3)
        result = rbd.continuous_collide(box, identity, identity, tree, start, end)
        samples = np.repeat(start[None], len(times), axis=0)
        samples[:, :3, 3] = (1.0 - times)[:, None] * start[:3, 3] + times[:, None] * end[:3, 3]
        hits = rbd.collide_batch(box, identity, tree, samples)
        if hits.any():
            assert result.colliding and result.time <= times[np.argmax(hits)] + 1e-9
