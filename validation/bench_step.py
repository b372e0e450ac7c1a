"""Whole-step benchmarks of resting and piled contact scenes against pybullet and MuJoCo.

Run with ``pytest validation/bench_step.py --benchmark-enable``. Every scene is built from
one description (:mod:`validation.studies.contact_scenes`: unit cubes of 1 kg, friction 0.5,
at 240 Hz) in each engine, settled untimed, then timed step by step, every body kept awake:

* ``one_cube`` and ``ten_cubes``: cubes resting on a floor (the fixed cost of a small scene);
* ``pyramid_15`` and ``pyramid_20``: 2D pyramids of 15 and 20 rows, every cube on two;
* ``pile_256``: 256 cubes released in random orientations from 16 layers, timed from 4 s on,
  while the column's last cubes still fall onto the pile (most steps have impacts; the pile
  comes to rest after about 9 s); ``pile_256_seed2`` and ``pile_256_seed3`` are the same
  pour from other random orientations. A pile is chaotic: any change of rounding sends it
  down another path, and the cost of 200 steps depends on the path by tens of percent, so
  one seed alone would be a draw;
* ``grid_1000``: 1000 cubes resting 1.5 m apart (1000 separate islands on one floor).

Engines: ours at its defaults (``narrow_phase="auto"``: convex pairs as convex polyhedra),
ours with ``narrow_phase="mesh"`` (every pair through the OBBTree, the thesis's path), pybullet
at its defaults with its bodies kept awake (ACTIVATION_STATE_DISABLE_SLEEPING; damping 0 as in
the scene), and MuJoCo at its defaults where the optional ``mujoco`` package is installed
(it never sleeps by default). For ours, ``extra_info`` records each stage's share of the timed
steps (``narrow_phase_ms`` is what issue 11 bounds), the contacts per step, and for the
pyramids the largest drift of any cube over settling and timing (the pyramid must stand).
"""

import time

import numpy as np
import pytest

from validation.studies import contact_scenes as scenes

DT = 1 / 240
SCENES = {
    "one_cube": (lambda: scenes.resting_row(1), 60),
    "ten_cubes": (lambda: scenes.resting_row(10), 60),
    "pyramid_15": (lambda: scenes.pyramid(15), 240),
    "pyramid_20": (lambda: scenes.pyramid(20), 240),
    "pile_256": (lambda: scenes.poured_pile(256), 960),
    "pile_256_seed2": (lambda: scenes.poured_pile(256, seed=2), 960),
    "pile_256_seed3": (lambda: scenes.poured_pile(256, seed=3), 960),
    "grid_1000": (lambda: scenes.resting_grid(1000), 60),
}
ENGINES = ("ours", "ours_mesh", "pybullet", "mujoco")
# steps per timed round: small scenes cost microseconds, so a round holds several steps
STEPS_PER_ROUND = {"one_cube": 20, "ten_cubes": 20}
# steps timed per engine: this shared machine switches between a fast and a slow speed every
# few hundred to few thousand steps of a small scene, so its engines are timed over enough
# steps to see both, or one engine's median may be all fast and another's all slow
TIMED_STEPS = {"one_cube": 4000, "ten_cubes": 4000}


def build(scene: str, engine: str):
    """(step function, positions function, world or None) of ``scene`` in ``engine``."""
    spec = SCENES[scene][0]()
    dynamic = spec.dynamic()
    if engine in ("ours", "ours_mesh"):
        narrow_phase = "auto" if engine == "ours" else "mesh"
        world = scenes.build_world(spec, DT, sleeping=False, narrow_phase=narrow_phase)
        return world.step, lambda: world.positions[dynamic].copy(), world
    if engine == "pybullet":
        pybullet = scenes.build_pybullet(spec, DT, "defaults", sleeping=False)
        return (
            pybullet.step,
            lambda: np.array([pybullet.position(i) for i in dynamic]),
            None,
        )
    pytest.importorskip("mujoco")
    mujoco = scenes.build_mujoco(spec, DT)
    return mujoco.step, lambda: np.array([mujoco.position(i) for i in dynamic]), None


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("scene", list(SCENES))
def test_step(benchmark, scene, engine):
    if engine == "pybullet":
        pytest.importorskip("pybullet")
    step, positions, world = build(scene, engine)
    benchmark.group = f"step: {scene}"
    benchmark.extra_info.update(scene=scene, engine=engine, bodies=len(positions()))
    if engine in ("pybullet", "mujoco"):
        benchmark.extra_info["peer"] = engine
    start = positions()
    settle = SCENES[scene][1]
    step(settle)
    repeat = STEPS_PER_ROUND.get(scene, 1)
    before = {k: dict(v) for k, v in world.profile.items()} if world is not None else None
    contacts = []

    def timed():
        step(repeat)
        if world is not None:
            contacts.append(len(world.contacts["depths"]))

    rounds = TIMED_STEPS.get(scene, 200) // repeat
    clock = time.perf_counter()
    benchmark.pedantic(timed, rounds=rounds, iterations=1, warmup_rounds=0)
    wall = time.perf_counter() - clock
    benchmark.extra_info["steps_per_round"] = repeat
    benchmark.extra_info["max_drift"] = float(np.abs(positions() - start).max())
    if world is not None:
        steps = rounds * repeat
        for name, entry in world.profile.items():
            calls = entry["calls"] - before[name]["calls"]
            if calls:
                seconds = entry["seconds"] - before[name]["seconds"]
                benchmark.extra_info[f"{name}_ms"] = 1e3 * seconds / steps
        benchmark.extra_info["contacts"] = float(np.mean(contacts))
        benchmark.extra_info["wall_ms_per_step"] = 1e3 * wall / steps
