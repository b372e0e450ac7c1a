"""The step, written once (``world/step_kernel.py``): one kernel runs every stage, in order,
behind its guard, and stops where Python must go on.

Paths through it: a call that runs many steps, a call per step, and calls that resume a step
after every stage Python runs (an applied force gathered, a sweep-and-prune update, mesh pairs,
a waking island, the tunnelling sweep, a time of impact, the impacts, the sleep stage). All
must give the same trajectories to the bit, on generated scenes that reach each of those
stages.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from reference import examples, random_mesh
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.world.stage_names import STAGE_NAMES
from thesis_rbd.world.stage_profile import StageProfile
from thesis_rbd.world.step_kernel import FINISHED, FORCES

DT = 1.0 / 240.0
STATE = ("position", "orientation", "linear_momentum", "angular_momentum")


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


SHAPES = {
    "box": lambda seed: rbd.shapes.box(0.4 + np.random.default_rng(seed).uniform(0, 0.6, 3)),
    "hull": lambda seed: random_mesh("hull", seed),
    "ball": lambda seed: rbd.shapes.icosphere(0.4, 1),
    "torus": lambda seed: rbd.shapes.torus(0.5, 0.2, 10, 6),  # a mesh body
}


@st.composite
def scenes(draw):
    """(build, pushes): a function making a world of a floor and a few bodies of the drawn
    kinds dropped over it, some thrown fast at it, and the applied forces to start (at the
    end of the k-th call) and last some steps, so that the forces stage starts and stops."""
    kinds = draw(st.lists(st.sampled_from(sorted(SHAPES)), min_size=1, max_size=5))
    seed = draw(st.integers(0, 2**16))
    sleeping = draw(st.booleans())
    fast = draw(st.lists(st.booleans(), min_size=len(kinds), max_size=len(kinds)))
    pushes = draw(
        st.lists(
            st.tuples(st.integers(0, 5), st.integers(0, len(kinds) - 1), st.integers(1, 30)),
            max_size=3,
        )
    )

    def build():
        rng = np.random.default_rng(seed)
        world = rbd.World(dt=DT, gravity=(0, 0, -9.81), sleeping=sleeping)
        world.add_body(rbd.shapes.box((10, 10, 1)), static=True, position=(0, 0, -0.5))
        for k, kind in enumerate(kinds):
            world.add_body(
                SHAPES[kind](seed + k), mass=1.0, friction=0.5, restitution=0.2,
                position=(1.5 * k - 3.0, rng.uniform(-0.5, 0.5), rng.uniform(0.7, 1.5)),
                orientation=Rotation.random(random_state=rng).as_quat(),
                linear_velocity=(0.0, 0.0, -150.0 if fast[k] else 0.0),
            )  # fmt: skip
        return world

    return build, pushes


def run(world: rbd.World, pushes, chunks) -> list:
    """Step ``world`` in calls of ``chunks`` steps, starting the pushes at their steps; the
    state after every call."""
    starts = {}
    for step, body, duration in pushes:
        starts.setdefault(step, []).append((body + 1, duration))
    trace = []
    for chunk in chunks:
        for step in range(world.steps_taken, world.steps_taken + chunk):
            for body, duration in starts.get(step, []):
                world.apply_force(body, (30.0, 0.0, 20.0), point=world.position(body) + 0.1,
                                  duration=duration * DT)  # fmt: skip
        world.step(chunk)
        trace.append(snapshot(world))
    return trace


def snapshot(world: rbd.World) -> dict:
    found = {f: getattr(world.bodies, f).copy() for f in STATE}
    found.update({f"contact_{k}": v for k, v in world.contacts.items()})
    found["sleeping"] = world.sleeping
    found["time"] = np.array([world.time, world.steps_taken])
    found["calls"] = np.array([world.profile[name]["calls"] for name in STAGE_NAMES])
    return found


def assert_same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


@settings(
    max_examples=examples(12), deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)  # fmt: skip
@given(scenes(), st.lists(st.integers(1, 40), min_size=1, max_size=6))
def test_calls_of_any_length_give_the_same_steps_to_the_bit(scene, chunks):
    """Boxes, general hulls, balls and a mesh body, sleeping on and off, pushes that start and
    stop, bodies thrown fast: one step per call and calls of any length agree to the bit."""
    build, pushes = scene
    # the pushes start between calls of the chunked run, so that both runs apply them at
    # the same step
    bounds = np.cumsum(chunks)
    pushes = [(int(bounds[step % len(bounds)]), body, d) for step, body, d in pushes]
    total = int(bounds[-1])
    by_step = run(build(), pushes, [1] * total)
    chunked = run(build(), pushes, chunks)
    for k, end in enumerate(bounds):
        assert_same(chunked[k], by_step[end - 1])


@pytest.mark.parametrize("sleeping", [False, True])
@pytest.mark.parametrize("scene", [resting_row, tumbling_pile])
def test_long_calls_are_single_steps_to_the_bit(scene, sleeping):
    chunked, single = scene(sleeping), scene(sleeping)
    for chunk in (1, 7, 50, 1, 183):  # calls of several lengths, stops inside them
        chunked.step(chunk)
        for _ in range(chunk):
            single.step()
        assert_same(snapshot(chunked), snapshot(single))


def test_the_kernel_runs_whole_steps_and_stops_where_python_must_go_on():
    """A resting row runs every step it is asked for in one call; the pile's falling cubes
    stop it (a refit or an impact), and it says at which stage."""
    world = resting_row(sleeping=False)
    world.step(2)  # the first steps fit the fat boxes
    assert world._run_kernel(40, FORCES, False) == (40, FINISHED)
    assert world.steps_taken == 42
    pile = tumbling_pile(sleeping=False)
    pile.step(2)
    stops = set()
    for _ in range(150):
        _, stop = pile._run_kernel(10, FORCES, False)
        if stop != FINISHED:
            stops.add(STAGE_NAMES[stop])
            pile._run_python_stage(stop)
            pile._run(1, stop + 1)  # the rest of that step
    assert {"broad_phase", "time_of_impact"} <= stops
    assert pile.profile["impacts"]["calls"] > 0  # the rest of a step that hit something


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


def test_a_free_body_runs_only_the_integrator():
    world = rbd.World(dt=DT)
    world.add_body(rbd.shapes.box((1, 2, 3)), mass=1.0, angular_velocity=(0, 1, 0.1))
    world.step(30)
    assert world.stages == ["integrate"]
    assert {k: v["calls"] for k, v in world.profile.items() if v["calls"]} == {"integrate": 30}


@pytest.mark.parametrize("sleeping", [False, True])
def test_a_non_finite_step_leaves_the_world_as_it_was(sleeping):
    world = resting_row(sleeping)
    world.step(10)
    world.bodies.angular_momentum[2] = (1e308, -1e308, 1e308)  # w overflows to inf
    before = snapshot(world)
    with pytest.raises(rbd.NonFiniteStateError, match=r"body 2 \('body2'\).*step 10"):
        world.step(5)
    after = snapshot(world)
    before.pop("calls"), after.pop("calls")  # the failed stage's call is counted
    assert_same(after, before)


def test_without_a_cycle_counter_the_kernel_time_is_shared_by_calls():
    """Off x86-64 the kernel counts no cycles: each stage then gets its share of calls."""
    profile = StageProfile()
    cycles = np.zeros(len(STAGE_NAMES), np.int64)
    calls = np.zeros(len(STAGE_NAMES), np.int64)
    calls[STAGE_NAMES.index("contacts")], calls[STAGE_NAMES.index("integrate")] = 3, 1
    profile.add_kernel_call(2.0, cycles, calls)
    assert profile.as_dict()["contacts"] == {"calls": 3, "seconds": 1.5}
    assert profile.as_dict()["integrate"] == {"calls": 1, "seconds": 0.5}
    cycles[STAGE_NAMES.index("contacts")], cycles[STAGE_NAMES.index("integrate")] = 10, 30
    profile.add_kernel_call(2.0, cycles, calls)
    assert profile.as_dict()["contacts"]["seconds"] == pytest.approx(1.5 + 0.5)
    assert profile.as_dict()["integrate"]["seconds"] == pytest.approx(0.5 + 1.5)
    profile.add_stage(STAGE_NAMES.index("sleep"), 0.25)
    assert profile.as_dict()["sleep"] == {"calls": 1, "seconds": 0.25}
