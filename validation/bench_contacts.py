"""Contact benchmarks (issue 5): N cubes dropped in a grid onto a floor, against pybullet.

Run with ``pytest validation/bench_contacts.py --benchmark-enable``. For N = 10, 100, 1000
unit cubes (mass 1, friction 0.5) in a square grid 1.5 m apart, 0.5 m above a static floor,
each world is timed per step in three phases, each against the same scene in pybullet
(``validation/pybullet_contact.py``) in the same run, like against like:

* falling: the first steps after release (no contact yet: forces, integration, bounds and
  the broad phase); both engines at their defaults;
* at rest, asleep: after 2.5 s, when every cube lies on the floor; ours at its defaults
  (sleeping on), pybullet with sleeping enabled (``ACTIVATION_STATE_ENABLE_SLEEPING``: its
  multibodies never sleep by default);
* at rest, awake: the same, every contact solved every step; ours with ``sleeping=False``,
  pybullet at its defaults.

pybullet runs without its #3094 restitution tuning (no body bounces here) and with damping 0
as in our scene.

Targets: at N = 1000 no slower than pybullet in any phase; the resting scene asleep at least
20x cheaper than the same scene awake.
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


def pybullet_world(count, sleeping=False):
    """The grid in pybullet; ``sleeping`` enables its sleeping (off by default there)."""
    from validation.pybullet_contact import PybulletScene

    centres, half = grid(count)
    scene = PybulletScene(DT, floor_half_extents=half)
    for centre in centres:
        body = scene.add_box((0.5, 0.5, 0.5), 1.0, centre, friction=0.5)
        if sleeping:
            scene.p.changeDynamics(
                body,
                -1,
                activationState=scene.p.ACTIVATION_STATE_ENABLE_SLEEPING,
                physicsClientId=scene.client,
            )
    return scene


# phase -> (our World's sleeping, pybullet's sleeping, pybullet's label)
PHASES = {
    "falling": (True, False, "pybullet (defaults)"),
    "rest_asleep": (True, True, "pybullet (sleeping enabled)"),
    "rest_awake": (False, False, "pybullet (defaults: never sleeps)"),
}


@pytest.mark.parametrize("count", COUNTS)
@pytest.mark.parametrize("phase", list(PHASES))
@pytest.mark.parametrize("engine", ["ours", "pybullet"])
def test_cube_grid_step(benchmark, engine, phase, count):
    pytest.importorskip("pybullet")
    ours_sleep, peer_sleep, peer_label = PHASES[phase]
    benchmark.group = f"cube grid {phase.replace('_', ', ')}, N = {count}"
    benchmark.extra_info.update(bodies=count, phase=phase, engine=engine)
    if engine == "pybullet":
        benchmark.extra_info["peer"] = peer_label
        world = pybullet_world(count, sleeping=peer_sleep)
    else:
        world = our_world(count, sleeping=ours_sleep)
    step = world.step
    step(2)  # compile or warm up outside the timing
    if phase != "falling":
        step(SETTLE_STEPS)
    rounds = 20 if phase == "falling" else 50
    benchmark.pedantic(step, rounds=rounds, iterations=1, warmup_rounds=0)
    if phase == "rest_asleep":
        # the timed scene really was asleep, in both engines
        if engine == "ours":
            assert world.sleeping[1:].all()
        else:
            assert all(not world.velocity(b).any() for b in range(1, count + 1))


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
