"""Contact benchmarks (issue 5): N cubes dropped in a grid onto a floor, against pybullet.

Run with ``pytest validation/bench_contacts.py --benchmark-enable``. For N = 10, 100, 1000
unit cubes (mass 1, friction 0.5) in a square grid 1.5 m apart, 0.5 m above a static floor,
each world is timed per step in two phases, in the same run as the same scene in pybullet
(``validation/pybullet_contact.py``):

* falling: the first steps after release (no contact yet: forces, integration, bounds and
  the broad phase);
* at rest: after 2.5 s, when every cube lies on the floor — with sleeping on (ours by
  default), with sleeping off (every contact solved every step), and pybullet's.

Targets: at N = 1000 no slower than pybullet in either phase; the resting scene asleep at
least 20x cheaper than the same scene awake.
"""

import numpy as np
import pytest

import thesis_rbd as rbd

DT = 1 / 240
SPACING = 1.5
COUNTS = (10, 100, 1000)
SETTLE_STEPS = round(2.5 / DT)


def grid(count):
    """Cube centres (count, 3) and the floor's half extents."""
    side = int(np.ceil(np.sqrt(count)))
    i, j = np.divmod(np.arange(count), side)
    centres = np.stack(
        [(i - side / 2) * SPACING, (j - side / 2) * SPACING, np.full(count, 1.0)], axis=1
    )
    half = side * SPACING / 2 + 1.0
    return centres, (half, half, 0.5)


def our_world(count, sleeping=True):
    centres, half = grid(count)
    world = rbd.World(dt=DT, gravity=(0, 0, -9.81), sleeping=sleeping)
    world.add_body(
        rbd.shapes.box(2 * np.array(half)), static=True, position=(0, 0, -0.5), friction=0.5
    )
    cube = rbd.shapes.box((1.0, 1.0, 1.0))
    for centre in centres:
        world.add_body(cube, mass=1.0, position=centre, friction=0.5)
    return world


def pybullet_world(count):
    from validation.pybullet_contact import PybulletScene

    centres, half = grid(count)
    scene = PybulletScene(DT, floor_half_extents=half)
    for centre in centres:
        scene.add_box((0.5, 0.5, 0.5), 1.0, centre, friction=0.5)
    return scene


@pytest.mark.parametrize("count", COUNTS)
@pytest.mark.parametrize("phase", ["falling", "rest"])
@pytest.mark.parametrize("engine", ["ours", "ours_awake", "pybullet"])
def test_cube_grid_step(benchmark, engine, phase, count):
    pytest.importorskip("pybullet")
    benchmark.group = f"cube grid {phase}, N = {count}"
    benchmark.extra_info.update(bodies=count, phase=phase, engine=engine)
    if engine == "pybullet":
        benchmark.extra_info["peer"] = "pybullet"
        world = pybullet_world(count)
        step = world.step
    else:
        world = our_world(count, sleeping=engine == "ours")
        step = world.step
    step(2)  # compile or warm up outside the timing
    if phase == "rest":
        step(SETTLE_STEPS)
    rounds = 20 if phase == "falling" else 50
    benchmark.pedantic(step, rounds=rounds, iterations=1, warmup_rounds=0)
    if engine == "ours" and phase == "rest":
        assert world.sleeping[1:].all()  # the timed scene really was asleep


def test_resting_grid_is_the_same_scene_in_both_engines():
    """The peer scene matches ours: after settling, pybullet's cubes rest where ours do."""
    pytest.importorskip("pybullet")
    ours = our_world(10)
    ours.step(SETTLE_STEPS)
    theirs = pybullet_world(10)
    theirs.step(SETTLE_STEPS)
    bullet_positions = np.array([theirs.position(body) for body in range(1, 11)])
    np.testing.assert_allclose(ours.positions[1:], bullet_positions, atol=5e-3)
    theirs.close()
