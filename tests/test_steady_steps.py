"""Steady steps run in one kernel call (``world/steady_steps.py``) and must be the staged steps.

The oracle is the world's own stage-by-stage path (the one every other scene takes): a world
told that no step is steady runs it. Both must give the same state, contacts, profile call
counts and time to the bit, also where the kernel stops mid-step for a stage it leaves to
Python (a refitted broad phase, an impact, the sleep stage).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.world.stage_names import STAGE_NAMES
from thesis_rbd.world.steady_steps import FINISHED

DT = 1.0 / 240.0


def resting_row(sleeping: bool) -> rbd.World:
    world = rbd.World(dt=DT, gravity=(0, 0, -9.81), sleeping=sleeping)
    world.add_body(rbd.shapes.box((12, 4, 1)), static=True, position=(0, 0, -0.5), friction=0.5)
    for x in (-3.0, 0.0, 3.0):
        world.add_body(rbd.shapes.box((1, 1, 1)), mass=1.0, position=(x, 0, 0.5), friction=0.5)
    return world


def tumbling_pile(sleeping: bool) -> rbd.World:
    """24 cubes in random orientations in three layers over a floor: they fall, hit each
    other and the floor (time of impact, impacts, refits of the fat boxes) and settle."""
    world = rbd.World(dt=DT, gravity=(0, 0, -9.81), sleeping=sleeping)
    world.add_body(rbd.shapes.box((12, 12, 1)), static=True, position=(0, 0, -0.5), friction=0.5)
    rng = np.random.default_rng(3)
    for k in range(24):
        layer, cell = divmod(k, 8)
        i, j = divmod(cell, 4)
        world.add_body(
            rbd.shapes.box((1, 1, 1)), mass=1.0, friction=0.5, restitution=0.3,
            position=(1.8 * (i - 0.5), 1.8 * (j - 1.5), 1.0 + 1.8 * layer),
            orientation=Rotation.random(random_state=rng).as_quat(),
        )  # fmt: skip
    return world


def staged(world: rbd.World) -> rbd.World:
    world._steady_now = lambda: False
    return world


def assert_same_worlds(a: rbd.World, b: rbd.World) -> None:
    for field in ("position", "orientation", "linear_momentum", "angular_momentum"):
        np.testing.assert_array_equal(getattr(a.bodies, field), getattr(b.bodies, field))
    assert a.time == b.time and a.steps_taken == b.steps_taken
    ca, cb = a.contacts, b.contacts
    assert ca.keys() == cb.keys()
    for key in ca:
        np.testing.assert_array_equal(ca[key], cb[key])
    assert {k: v["calls"] for k, v in a.profile.items()} == {
        k: v["calls"] for k, v in b.profile.items()
    }
    np.testing.assert_array_equal(a.sleeping, b.sleeping)


@pytest.mark.parametrize("sleeping", [False, True])
@pytest.mark.parametrize("scene", [resting_row, tumbling_pile])
def test_steady_steps_are_the_staged_steps_to_the_bit(scene, sleeping):
    fused, reference = scene(sleeping), staged(scene(sleeping))
    for chunk in (1, 7, 50, 1, 183):  # calls of several lengths, stops inside them
        fused.step(chunk)
        reference.step(chunk)
        assert_same_worlds(fused, reference)


def test_the_kernel_runs_whole_steps_and_stops_where_python_must_go_on():
    """A resting row runs every step it is asked for in one call; the pile's falling cubes
    stop it (an impact or a refit), and it says at which stage."""
    world = resting_row(sleeping=False)
    world.step(2)  # the first steps fit the fat boxes, stage by stage
    done, stop, bad = world._run_steady_steps(40)
    assert (done, stop, bad) == (40, FINISHED, -1)
    assert world.steps_taken == 42
    pile = tumbling_pile(sleeping=False)
    pile.step(2)
    stops = set()
    for _ in range(150):
        done, stop, bad = pile._run_steady_steps(10)
        assert bad == -1
        if stop != FINISHED:
            stops.add(STAGE_NAMES[stop])
            pile._run_stages(stop)
    assert {"broad_phase", "time_of_impact"} <= stops


def test_the_profile_shares_the_kernel_time_among_the_stages_it_ran():
    world = resting_row(sleeping=False)
    world.step(2)
    before = {k: dict(v) for k, v in world.profile.items()}
    world.step(200)
    for name in ("forces", "contacts", "integrate", "bounds", "broad_phase", "narrow_phase"):
        assert world.profile[name]["calls"] == before[name]["calls"] + 200
        if name != "forces":  # gravity alone: already in the step's force, no work
            assert world.profile[name]["seconds"] > before[name]["seconds"]
    for name in ("tunnelling", "time_of_impact", "impacts", "sleep"):
        assert world.profile[name] == before[name]


@pytest.mark.parametrize("sleeping", [False, True])
def test_a_non_finite_steady_step_leaves_the_world_as_it_was(sleeping):
    world = resting_row(sleeping)
    world.step(10)
    assert world._steady_now()
    world.bodies.angular_momentum[2] = (1e308, -1e308, 1e308)  # w overflows to inf
    before = {
        f: getattr(world.bodies, f).copy()
        for f in ("position", "orientation", "linear_momentum", "angular_momentum")
    }
    contacts, time = world.contacts, world.time
    with pytest.raises(rbd.NonFiniteStateError, match=r"body 2 \('body2'\).*step 10"):
        world.step(5)
    for field, value in before.items():
        np.testing.assert_array_equal(getattr(world.bodies, field), value)
    assert world.time == time and world.steps_taken == 10
    for key, value in contacts.items():
        np.testing.assert_array_equal(world.contacts[key], value)


def test_without_a_cycle_counter_the_kernel_time_is_shared_by_calls():
    """Off x86-64 the kernel counts no cycles: each stage then gets its share of calls."""
    world = resting_row(sleeping=False)
    cycles = np.zeros(len(STAGE_NAMES), np.int64)
    calls = np.zeros(len(STAGE_NAMES), np.int64)
    calls[STAGE_NAMES.index("contacts")], calls[STAGE_NAMES.index("integrate")] = 3, 1
    world._share_profile(2.0, cycles, calls)
    assert world.profile["contacts"] == {"calls": 3, "seconds": 1.5}
    assert world.profile["integrate"] == {"calls": 1, "seconds": 0.5}
    cycles[STAGE_NAMES.index("contacts")], cycles[STAGE_NAMES.index("integrate")] = 10, 30
    world._share_profile(2.0, cycles, calls)
    assert world.profile["contacts"]["seconds"] == pytest.approx(1.5 + 0.5)
    assert world.profile["integrate"]["seconds"] == pytest.approx(0.5 + 1.5)
