"""The KUKA iiwa's step against pybullet's multibody and MuJoCo's, on the same URDF file.

Run with ``pytest validation/bench_robot.py --benchmark-enable``. The arm falls from a bent
pose with its URDF joint damping, no control (:mod:`validation.robot_peers` sets each engine
up). Each engine is built afresh, stepped 24 steps untimed (numba's compile, the peers' first
steps), then timed one ``step`` call per round over the rest of a 2 s fall; ``ours_batched``
times ``World.step(24)`` per round (a Python loop of ``step()`` pays the kernel call each
time, as pybullet's and MuJoCo's loops pay theirs), its time per step in ``extra_info``.
"""

from __future__ import annotations

import numpy as np
import pytest

from validation import robot_peers as peers

WARM_UP = 24
BATCH = 24
ENGINES = ("ours", "ours_batched", "pybullet", "mujoco")


@pytest.mark.parametrize("engine", ENGINES)
def test_iiwa_damped_fall_step(benchmark, engine):
    pytest.importorskip("pybullet_data", reason="the iiwa ships with pybullet")
    steps_per_call = BATCH if engine == "ours_batched" else 1
    if engine.startswith("ours"):
        pytest.importorskip("yourdfpy", reason="load_urdf parses through yourdfpy")
        step, positions = peers.iiwa_ours(steps_per_call)
    elif engine == "pybullet":
        pytest.importorskip("pybullet")
        step, positions = peers.iiwa_pybullet()
    else:
        pytest.importorskip("mujoco")
        step, positions = peers.iiwa_mujoco()
    for _ in range(WARM_UP // steps_per_call):
        step()
    benchmark.group = "iiwa damped fall: one step"
    benchmark.extra_info.update(engine=engine, steps_per_call=steps_per_call)
    # the rest of the 2 s fall: the timed steps are the fall's, not an arm at rest
    rounds = (2 * 240 - WARM_UP) // steps_per_call
    benchmark.pedantic(step, rounds=rounds, iterations=1, warmup_rounds=0)
    benchmark.extra_info["median_us_per_step"] = benchmark.stats.stats.median / steps_per_call * 1e6
    assert np.all(np.isfinite(positions()))
