"""A step either ends in a finite state or fails cleanly: every failure inside a step puts the
world back as it was and reaches the user as ``NonFiniteStateError``; inputs no step could
survive are refused where they are given."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from reference import examples

import thesis_rbd as rbd
from thesis_rbd.world.world import MOST_FORCE


def readouts(world: rbd.World) -> dict:
    """Every public readout of a world's state."""
    found = {
        "time": np.array([world.time, world.steps_taken]),
        "positions": world.positions.copy(),
        "orientations": world.orientations.copy(),
        "sleeping": world.sleeping,
    }
    for body in range(len(world)):
        found[f"P{body}"] = world.linear_momentum(body)
        found[f"L{body}"] = world.angular_momentum(body)
    found.update({f"contact_{key}": value for key, value in world.contacts.items()})
    return found


def assert_same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def extreme_world(dt, height, speed, spin, shape):
    """A floor, a body resting on it, and a body at ``height`` thrown at it at ``speed``."""
    world = rbd.World(dt=dt, gravity=(0.0, 0.0, -9.81))
    world.add_body(rbd.shapes.box((10.0, 10.0, 1.0)), static=True, position=(0, 0, -0.5))
    world.add_body(rbd.shapes.box((1.0, 1.0, 1.0)), mass=1.0, position=(2.0, 0.0, 0.5))
    mesh = rbd.shapes.box((1.0, 0.5, 0.2)) if shape == "box" else rbd.shapes.torus(0.5, 0.2, 8, 6)
    world.add_body(
        mesh, mass=1.0, position=(0.0, 0.0, height), linear_velocity=(0.1 * speed, 0.0, -speed),
        angular_velocity=(spin, 0.5 * spin, 0.0),
    )  # fmt: skip
    return world


@settings(
    max_examples=examples(40), deadline=None, suppress_health_check=[HealthCheck.too_slow]
)  # fmt: skip
@given(
    dt=st.sampled_from([1e-9, 1e-6, 1e-3, 1.0 / 240.0, 0.1, 1.0]),
    height=st.sampled_from([0.7, 5.0, 1e3, 1e8, 1e30, 1e100]),
    speed=st.sampled_from([0.0, 10.0, 1e4, 1e10, 1e50, 1e100]),
    spin=st.sampled_from([0.0, 1e3, 1e8, 1e50]),
    force=st.sampled_from([0.0, 1e3, 1e20, 1e100, MOST_FORCE]),
    shape=st.sampled_from(["box", "torus"]),
    steps=st.integers(1, 4),
)
# a spin whose quaternion update overflows: the integrator's check must catch it before the
# tunnelling sweep poses the torus with it
@example(dt=1e-9, height=0.7, speed=0.0, spin=0.0, force=1e100, shape="torus", steps=2)
def test_every_step_ends_finite_or_fails_with_the_world_restored(
    dt, height, speed, spin, force, shape, steps
):
    world = extreme_world(dt, height, speed, spin, shape)
    if force:
        world.apply_force(2, (force, -force, -force), point=world.position(2) + 0.3)
    for _ in range(steps):
        before = readouts(world)
        try:
            world.step()
        except rbd.NonFiniteStateError as failure:
            assert_same(readouts(world), before)
            with pytest.raises(rbd.NonFiniteStateError) as again:
                world.step()
            assert (again.value.body, again.value.stage, again.value.step) == (
                failure.body, failure.stage, failure.step,
            )  # fmt: skip
            assert_same(readouts(world), before)
            return
        for key, value in readouts(world).items():
            assert np.all(np.isfinite(value)), key


def test_a_step_that_overflows_fails_in_its_stage_and_puts_everything_back():
    world = extreme_world(1e-9, 0.7, 0.0, 0.0, "torus")
    world.apply_force(2, (1e100, -1e100, -1e100), point=world.position(2) + 0.3)
    before = readouts(world)
    with pytest.raises(rbd.NonFiniteStateError, match=r"body 2 .*'integrate' of step 0"):
        world.step()
    assert_same(readouts(world), before)


def test_a_force_no_step_could_integrate_is_refused():
    world = extreme_world(1.0 / 240.0, 5.0, 0.0, 0.0, "box")
    with pytest.raises(ValueError, match="force"):
        world.apply_force(2, (1e300, 0.0, 0.0))
    world.apply_force(2, (MOST_FORCE, 0.0, 0.0))


@pytest.mark.parametrize(
    "options, named",
    [
        ({"mass": 1e-320}, "mass"),
        ({"density": 1e-320}, "density"),
        ({"mass": 1.0, "linear_velocity": (1e308, 0.0, 0.0)}, None),
        ({"mass": 1e300, "linear_velocity": (1e10, 0.0, 0.0)}, "linear_velocity"),
        ({"mass": 1e300, "angular_velocity": (1e10, 0.0, 0.0)}, "angular_velocity"),
    ],
)
def test_a_body_no_step_could_move_is_refused(options, named):
    world = rbd.World()
    if named is None:  # large but representable: accepted
        world.add_body(rbd.shapes.box((1.0, 1.0, 1.0)), **options)
        return
    with pytest.raises(ValueError, match=named):
        world.add_body(rbd.shapes.box((1.0, 1.0, 1.0)), **options)
    assert len(world) == 0
