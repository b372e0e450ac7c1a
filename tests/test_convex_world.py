"""The narrow phase a World chooses per pair: convex pairs by the convex kernel, others by the
OBBTree ("auto"), or every pair by the OBBTree ("mesh")."""

import numpy as np
import pytest

import thesis_rbd as rbd
from thesis_rbd.collision.convex.contacts import cache_views

FLOOR = rbd.shapes.box((6.0, 6.0, 1.0))
CUBE = rbd.shapes.box((1.0, 1.0, 1.0))
TORUS = rbd.shapes.torus(0.6, 0.2, 24, 12)


def scene(narrow_phase):
    world = rbd.World(gravity=(0, 0, -9.81), narrow_phase=narrow_phase, sleeping=False)
    world.add_body(FLOOR, static=True, position=(0, 0, -0.5), friction=0.5)
    world.add_body(CUBE, mass=1.0, position=(-1.5, 0, 0.6), friction=0.5)
    world.add_body(TORUS, mass=1.0, position=(1.5, 0, 0.3), friction=0.5)
    return world


def test_unknown_narrow_phase_is_refused_by_name():
    with pytest.raises(ValueError, match="narrow_phase 'fast'"):
        rbd.World(narrow_phase="fast")


def test_auto_sends_convex_pairs_to_the_convex_kernel_and_the_rest_to_the_tree():
    world = scene("auto")
    pipeline = world._collision
    assert pipeline.hull_of_body.tolist() == [0, 1, -1]
    world.step(120)
    contacts = world.contacts
    cube = contacts["body_b"] == 1
    torus = contacts["body_b"] == 2
    assert cube.any() and torus.any()
    # convex contacts carry feature ids, mesh contacts none
    assert (contacts["features"][cube] >= 0).all()
    assert (contacts["features"][torus] == -1).all()
    assert pipeline.stats["convex_pairs"] == 1
    # the convex pair's coherence cache holds that pair, keyed (0, 1)
    assert cache_views(world._state.convex_cache)[0].tolist() == [1]


def test_mesh_sends_every_pair_to_the_tree():
    world = scene("mesh")
    assert world._collision.hull_of_body.tolist() == [-1, -1, -1]
    world.step(120)
    assert (world.contacts["features"] == -1).all()
    assert world._collision.stats["convex_pairs"] == 0


def test_both_paths_rest_the_bodies_in_the_same_place():
    worlds = [scene(kind) for kind in ("auto", "mesh")]
    for world in worlds:
        world.step(480)
    np.testing.assert_allclose(worlds[0].positions, worlds[1].positions, atol=2e-3)
    for world in worlds:
        assert abs(world.position(1)[2] - 0.5) < 1e-3  # the cube rests on its face


def test_a_scene_of_convex_bodies_builds_no_tree():
    """Trees are built when a pair first needs the mesh path: a scene of convex bodies never
    builds one (nor compiles the tree builder); adding a torus builds the trees then."""
    world = rbd.World(gravity=(0, 0, -9.81), sleeping=False)
    world.add_body(FLOOR, static=True, position=(0, 0, -0.5))
    world.add_body(CUBE, mass=1.0, position=(0, 0, 0.6))
    world.step(60)
    geometry = world._collision.geometry
    assert len(world.contacts["depths"]) and geometry._trees == []
    world.add_body(TORUS, mass=1.0, position=(1.5, 0, 0.3))
    world.step(60)
    assert len(geometry._trees) == 3
