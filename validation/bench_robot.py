"""The KUKA iiwa's step against pybullet's multibody and MuJoCo's, on the same URDF file.

Run with ``pytest validation/bench_robot.py --benchmark-enable``. The arm of pybullet_data's
``kuka_iiwa/model.urdf`` is welded to the world and falls from a bent pose under gravity for
2 s at dt = 1/240 with its URDF joint damping (0.5 N m s/rad), no control: issue 35's speed
case. Each engine is built afresh, stepped 24 steps untimed (numba's compile, the peers'
first steps), then timed step by step, one ``step`` call per round.

Setups (each engine's defaults, changed only where written):

* ours: ``load_urdf(fixed_base=True)``, the links kept from colliding with each other
  (``self_collision=False``, pybullet's default), joint substeps "auto"; ``ours_batched``
  times ``World.step(24)`` per round and reports per step (a Python loop of ``step()``
  pays the kernel call each time, pybullet's and MuJoCo's loops pay theirs);
* pybullet: ``URDF_USE_INERTIA_FROM_FILE``, its links' own damping zeroed
  (``changeDynamics``; it damps links by default, the URDF damps joints), its default joint
  motors off (VELOCITY_CONTROL with force 0), so its joints are damped by the URDF's 0.5
  alone; self-collision off (its default);
* MuJoCo: the URDF compiled by ``mujoco.MjModel.from_xml_path`` (its URDF import reads the
  joint damping), dt set to 1/240, contacts off (``mjDSBL_CONTACT``): its URDF import lets
  the arm's non-adjacent links collide, which ours and pybullet do not.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import thesis_rbd as rbd

DT = 1 / 240
START = np.array([0.3, 0.8, -0.4, -1.0, 0.5, 0.9, 0.2])
WARM_UP = 24
BATCH = 24
ENGINES = ("ours", "ours_batched", "pybullet", "mujoco")


def _model() -> Path:
    pybullet_data = pytest.importorskip("pybullet_data", reason="the iiwa ships with pybullet")
    return Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"


def _ours(path: Path, batch: int):
    pytest.importorskip("yourdfpy", reason="load_urdf parses through yourdfpy")
    world = rbd.World(dt=DT, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, path, fixed_base=True)
    robot.set_joint_positions(START)
    return (lambda: world.step(batch)), robot.joint_positions


def _pybullet(path: Path):
    p = pytest.importorskip("pybullet")
    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    p.setTimeStep(DT, physicsClientId=client)
    arm = p.loadURDF(str(path), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE,
                     physicsClientId=client)  # fmt: skip
    for j in range(len(START)):
        p.changeDynamics(arm, j, linearDamping=0, angularDamping=0, physicsClientId=client)
        p.setJointMotorControl2(arm, j, p.VELOCITY_CONTROL, force=0, physicsClientId=client)
        p.resetJointState(arm, j, START[j], physicsClientId=client)

    def positions():
        states = p.getJointStates(arm, range(len(START)), physicsClientId=client)
        return np.array([state[0] for state in states])

    return (lambda: p.stepSimulation(physicsClientId=client)), positions


def _mujoco(path: Path):
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(path))
    model.opt.timestep = DT
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    data = mujoco.MjData(model)
    data.qpos[:] = START
    return (lambda: mujoco.mj_step(model, data)), (lambda: data.qpos.copy())


@pytest.mark.parametrize("engine", ENGINES)
def test_iiwa_damped_fall_step(benchmark, engine):
    path = _model()
    steps_per_call = BATCH if engine == "ours_batched" else 1
    if engine.startswith("ours"):
        step, positions = _ours(path, steps_per_call)
    elif engine == "pybullet":
        step, positions = _pybullet(path)
    else:
        step, positions = _mujoco(path)
    for _ in range(WARM_UP // steps_per_call):
        step()
    benchmark.group = "iiwa damped fall: one step"
    benchmark.extra_info.update(engine=engine, steps_per_call=steps_per_call)
    # 2 s of the fall at most: the timed steps are the fall's, not an arm at rest
    rounds = 2 * 240 // steps_per_call - WARM_UP // steps_per_call
    benchmark.pedantic(step, rounds=rounds, iterations=1, warmup_rounds=0)
    assert np.all(np.isfinite(positions()))
