"""Tight and fat world boxes: tight ones contain the posed mesh, fat ones contain the tight ones,
refits are rare in steady motion, and the candidate pairs are those of an all-pairs test."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from reference_broad_phase import brute_force_pairs
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.broad_phase.bounds import (
    PREDICTION_STEPS,
    overlapping_pairs,
    tight_bounds,
    update_fat_bounds,
)
from thesis_rbd.collision.convex.contacts import SPECULATIVE_FRACTION


def tight_boxes(world, members=None, fast=None, speculative=0.0, reach=0.0):
    """(2, n, 3) tight boxes of the bodies of a world (all, unless ``members``), grown by
    the speculative margin max(speculative * thickness, reach)."""
    b, c = world.bodies, world._collision
    n = len(world)
    members = np.arange(n) if members is None else members
    fast = np.zeros(n, bool) if fast is None else fast
    tight = np.full((2, n, 3), np.nan)
    tight_bounds(
        members, c.box_offset, c.box_half, b.size, b.position, b.orientation,
        world._state.start_position, fast, b.thickness, speculative, reach, tight,
    )  # fmt: skip
    return tight


def fit_fat_boxes(world, frozen, everything=True):
    """(refit, fast_count, slowest, fat, fast) of ``update_fat_bounds`` on a world's state."""
    b = world.bodies
    n = len(world)
    fat, fast = np.zeros((2, n, 3)), np.zeros(n, bool)
    result = update_fat_bounds(
        n, everything, frozen, b.size, b.thickness, b.position, world._state.start_position,
        b.linear_momentum, b.inverse_mass, PREDICTION_STEPS * world.dt, fat, fast,
    )  # fmt: skip
    return (*result, fat, fast)


@given(st.integers(0, 10**6))
def test_tight_box_contains_the_posed_mesh_and_fat_box_the_tight_one(seed):
    rng = np.random.default_rng(seed)
    mesh = rbd.shapes.torus(1.0, 0.3, 12, 8)
    world = rbd.World()
    for _ in range(3):
        world.add_body(
            mesh,
            mass=1.0,
            position=rng.normal(scale=10, size=3),
            orientation=Rotation.random(random_state=rng.integers(1 << 31)).as_quat(),
            linear_velocity=rng.normal(scale=5, size=3),
        )
    tight = tight_boxes(world)
    _, _, _, fat, _ = fit_fat_boxes(world, np.zeros(3, bool))
    for i in range(3):
        T = world.transform(i)
        vertices = mesh.vertices @ T[:3, :3].T + T[:3, 3]
        assert np.all(vertices >= tight[0, i] - 1e-12)
        assert np.all(vertices <= tight[1, i] + 1e-12)
        # the fat box holds the sphere's box with a margin, whatever the body's orientation
        x, r = world.position(i), world.bodies.size[i]
        assert np.all(fat[0, i] < x - r) and np.all(fat[1, i] > x + r)


def test_axis_aligned_box_is_tight_and_a_static_fat_box_is_its_tight_box():
    box = rbd.shapes.box((1.0, 2.0, 3.0))
    world = rbd.World()
    world.add_body(box, static=True, position=(5, 6, 7))
    world.add_body(box, mass=1.0, position=(50, 0, 0))
    tight = tight_boxes(world)
    np.testing.assert_allclose(tight[0, 0], [4.5, 5, 5.5])
    np.testing.assert_allclose(tight[1, 0], [5.5, 7, 8.5])
    world.step()
    # grown by the speculative margin: a thousandth of its thickness, or gravity's reach
    reach = 2.0 * np.linalg.norm(world.gravity) * world.dt**2
    grown = tight_boxes(world, speculative=SPECULATIVE_FRACTION, reach=reach)
    np.testing.assert_array_equal(world._collision.fat[:, 0], grown[:, 0])
    margin = max(SPECULATIVE_FRACTION * 1.0, reach)
    np.testing.assert_allclose(grown[0, 0], tight[0, 0] - margin, rtol=0, atol=1e-12)
    np.testing.assert_allclose(grown[1, 0], tight[1, 0] + margin, rtol=0, atol=1e-12)


def test_tight_box_is_the_arvo_box_clipped_to_the_bounding_sphere():
    """A tetrahedron, whose centre of mass is off its box's centre, turned so that the box's
    diagonal points up: its Arvo box pokes out of the sphere's box above, which bounds the
    mesh as well; the tight box is the intersection of the two."""
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    tetrahedron = rbd.TriangleMesh(corners, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    turn, _ = Rotation.align_vectors([[0, 0, 1]], [[1, 1, 1]])
    world = rbd.World()
    world.add_body(tetrahedron, mass=1.0, orientation=turn.as_quat())
    R = turn.as_matrix()
    offset = np.full(3, 0.5) - 0.25  # box centre minus centre of mass, mesh frame
    center, extent = R @ offset, np.abs(R) @ np.full(3, 0.5)
    r = world.bodies.size[0]
    tight = tight_boxes(world)
    assert center[2] + extent[2] > r + 0.1  # the sphere clips the top
    np.testing.assert_allclose(tight[0, 0], np.maximum(center - extent, -r))
    np.testing.assert_allclose(tight[1, 0], np.minimum(center + extent, r))


def test_fast_body_tight_box_covers_where_its_step_started():
    world = rbd.World(dt=0.1)
    body = world.add_body(rbd.shapes.icosphere(0.5, 1), mass=1.0, linear_velocity=(20, 0, 0))
    world.step()
    _, fast_count, _, fat, fast = fit_fat_boxes(world, np.zeros(1, bool))
    assert fast_count == 1 and fast[body]
    tight = tight_boxes(world, fast=fast)
    assert tight[0, body, 0] <= -0.5 and tight[1, body, 0] >= 2.5
    assert np.all(fat[0, body] <= tight[0, body]) and np.all(fat[1, body] >= tight[1, body])


def test_steady_motion_refits_the_fat_boxes_rarely_and_all_at_once():
    rng = np.random.default_rng(1)
    world = rbd.World()
    for i in range(20):
        world.add_body(
            rbd.shapes.box((1.0, 2.0, 3.0)),
            mass=1.0,
            position=(50.0 * i, 0, 0),
            linear_velocity=rng.normal(size=3),
            angular_velocity=rng.normal(scale=3.0, size=3),
        )
    steps = 4 * PREDICTION_STEPS
    world.step(steps)
    refits = world.profile["broad_phase"]["calls"]
    assert 1 < refits <= 1 + steps // PREDICTION_STEPS
    # the speeds are far above the sleep tolerance: the sleep stage never ran
    assert world.profile["sleep"]["calls"] == 0


def test_overlapping_pairs_matches_an_all_pairs_test():
    rng = np.random.default_rng(2)
    n = 40
    lower = rng.uniform(0, 10, (n, 3))
    tight = np.stack([lower, lower + rng.uniform(0, 3, (n, 3))])
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], np.int64)
    resting = rng.random(n) < 0.3
    expected = [
        (i, j)
        for i, j in brute_force_pairs(tight[0], tight[1]).tolist()
        if not (resting[i] and resting[j])
    ]
    out = np.full((len(pairs), 2), -7, np.int64)
    kept = overlapping_pairs(pairs, tight, resting, out)
    np.testing.assert_array_equal(out[:kept], np.array(expected).reshape(-1, 2))
    assert np.all(out[kept:] == -7)  # nothing written beyond the kept rows


def test_fat_boxes_lose_no_candidate_pair():
    """Bodies crossing each other's paths in a detection-only world: every step, the
    candidates are exactly the pairs whose tight boxes overlap (all-pairs oracle)."""
    rng = np.random.default_rng(3)
    world = rbd.World(contact_response=False)
    shapes = [rbd.shapes.box((1.0, 0.5, 2.0)), rbd.shapes.icosphere(0.4, 1)]
    for i in range(12):
        world.add_body(
            shapes[i % 2],
            mass=1.0,
            position=rng.uniform(-3, 3, 3),
            orientation=Rotation.random(random_state=i).as_quat(),
            linear_velocity=rng.normal(scale=4.0, size=3),
            angular_velocity=rng.normal(scale=2.0, size=3),
        )
    world.add_body(rbd.shapes.box((8, 8, 0.5)), static=True, position=(0, 0, -4))
    sap, updates = world._collision.sap, []
    update = sap.update
    sap.update = lambda *args, **kwargs: updates.append(1) or update(*args, **kwargs)
    checked = 0
    for _ in range(120):
        world.step()
        tight = tight_boxes(world, fast=world._state.fast)
        expected = brute_force_pairs(tight[0], tight[1])
        expected = expected[~(world.bodies.static[expected].all(axis=1))]
        candidates = world._collision.candidates(world._state.candidate_count)
        np.testing.assert_array_equal(candidates, expected)
        checked += len(expected)
    assert checked > 0
    assert len(updates) < 60  # the fat boxes spared most sweep-and-prune updates
