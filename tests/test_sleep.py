"""Sleep only for islands at rest on something: still and supported.

A body that is momentarily slow is not at rest: at the top of its flight, or drifting in zero
gravity, it must keep moving as the analytic free flight says. An island sleeps only when it
touches a static body or a sleeping island. The answers are ballistic motion and conserved
momentum; the resting cases check that supported bodies still fall asleep.
"""

import numpy as np
import pytest

import thesis_rbd as rbd

DT = 1 / 240


def test_bodies_drifting_slowly_in_zero_gravity_never_sleep():
    """Two 1 m cubes drifting at 5 mm/s (0.01 radii/s is 8.7 mm/s for them), apart and
    touching each other: momentum stays exact and nobody sleeps."""
    world = rbd.World(dt=DT)
    cube = rbd.shapes.box((1.0, 1.0, 1.0))
    apart = world.add_body(cube, mass=2.0, position=(-5, 0, 0), linear_velocity=(0.005, 0, 0))
    left = world.add_body(cube, mass=2.0, position=(0, 0, 0), linear_velocity=(0.005, 0, 0))
    right = world.add_body(cube, mass=2.0, position=(1, 0, 0), linear_velocity=(0.005, 0, 0))
    for _ in range(round(6 / DT)):
        world.step()
        assert not world.sleeping.any()
    for body in (apart, left, right):
        np.testing.assert_allclose(world.linear_momentum(body), (0.01, 0, 0), atol=1e-12)
    assert world.position(apart)[0] == pytest.approx(-5 + 0.005 * world.time, abs=1e-9)


@pytest.mark.parametrize(
    "size, height, gravity, speed",
    [(1000.0, 500.0, 9.81, 0.0), (100.0, 10.0, 1.62, 1.0)],
    ids=["km_block_released", "boulder_at_its_apex_on_the_moon"],
)
def test_a_body_in_free_flight_follows_its_parabola_past_its_apex(size, height, gravity, speed):
    """A 1 km block released 500 m above a floor, and a 100 m boulder thrown up at 1 m/s
    under the Moon's gravity (apex at 0.62 s), stay on z(t) = z0 + u t - g t^2 / 2 and awake
    until they land."""
    world = rbd.World(dt=DT, gravity=(0, 0, -gravity))
    world.add_body(
        rbd.shapes.box((40 * size, 40 * size, size)), static=True, position=(0, 0, -size / 2)
    )
    z0 = height + size / 2
    body = world.add_body(
        rbd.shapes.box((size, size, size)), mass=1.0, position=(0, 0, z0),
        linear_velocity=(0, 0, speed),
    )  # fmt: skip
    seconds = 2.0
    for _ in range(round(seconds / DT)):
        world.step()
        assert not world.sleeping[body]
    t = world.time
    expected = z0 + speed * t - 0.5 * gravity * t * t
    assert world.position(body)[2] == pytest.approx(expected, rel=1e-9)


def test_a_world_of_one_body_on_a_floor_and_a_stack_still_sleep():
    """Supported islands sleep as before: a cube on a floor, and a stack of three cubes
    (only the bottom one touches the floor; the island is supported through it)."""
    world = rbd.World(dt=DT, gravity=(0, 0, -9.81))
    world.add_body(rbd.shapes.box((10, 10, 1)), static=True, position=(0, 0, -0.5))
    cube = rbd.shapes.box((1.0, 1.0, 1.0))
    alone = world.add_body(cube, mass=1.0, position=(5, 0, 0.5))
    stack = [world.add_body(cube, mass=1.0, position=(-3, 0, 0.5 + k)) for k in range(3)]
    world.step(round(2 / DT))
    assert world.sleeping[alone]
    assert world.sleeping[stack].all()
