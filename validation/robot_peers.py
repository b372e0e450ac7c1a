"""The KUKA iiwa of pybullet_data's ``kuka_iiwa/model.urdf`` in each engine, set up alike:
welded to the world, falling from a bent pose under gravity at dt = 1/240 with its URDF joint
damping (0.5 N m s/rad), no control (issue 35's speed case).

Each engine at its defaults, changed only where written:

* ours: ``load_urdf(fixed_base=True)``, the links kept from colliding with each other
  (``self_collision=False``, pybullet's default), joint substeps "auto", the arm stepped in
  joint coordinates (``joint_coordinates="auto"``) or held in maximal ones ("maximal");
* pybullet: ``URDF_USE_INERTIA_FROM_FILE``, its links' own damping zeroed (``changeDynamics``;
  it damps links by default, the URDF damps joints), its default joint motors off
  (VELOCITY_CONTROL with force 0), so its joints are damped by the URDF's 0.5 alone;
  self-collision off (its default);
* MuJoCo: the URDF compiled by ``mujoco.MjModel.from_xml_path`` (its URDF import reads the
  joint damping), dt set to 1/240, contacts off (``mjDSBL_CONTACT``): its URDF import lets
  the arm's non-adjacent links collide, which ours and pybullet do not.

Each builder returns (step, joint positions): ``step()`` advances one step (``steps`` of
them for ours where asked: ``World.step(steps)`` is one kernel call).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

DT = 1 / 240
START = np.array([0.3, 0.8, -0.4, -1.0, 0.5, 0.9, 0.2])

__all__ = ["DT", "START", "iiwa_mujoco", "iiwa_ours", "iiwa_path", "iiwa_pybullet"]


def iiwa_path() -> Path:
    """pybullet_data's iiwa URDF (pybullet_data installs with pybullet)."""
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"


def iiwa_ours(steps: int = 1, coordinates: str = "auto"):
    import thesis_rbd as rbd

    world = rbd.World(dt=DT, gravity=(0, 0, -9.81), joint_coordinates=coordinates)
    robot = rbd.load_urdf(world, iiwa_path(), fixed_base=True)
    robot.set_joint_positions(START)
    return (lambda: world.step(steps)), robot.joint_positions


def iiwa_pybullet(substeps: int = 1):
    """pybullet's arm; ``step()`` advances dt in ``substeps`` steps of its own (the reference
    at dt / 16 is pybullet's own discretisation converged)."""
    import pybullet as p

    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    p.setTimeStep(DT / substeps, physicsClientId=client)
    arm = p.loadURDF(str(iiwa_path()), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE,
                     physicsClientId=client)  # fmt: skip
    for j in range(len(START)):
        p.changeDynamics(arm, j, linearDamping=0, angularDamping=0, physicsClientId=client)
        p.setJointMotorControl2(arm, j, p.VELOCITY_CONTROL, force=0, physicsClientId=client)
        p.resetJointState(arm, j, START[j], physicsClientId=client)

    def positions():
        states = p.getJointStates(arm, range(len(START)), physicsClientId=client)
        return np.array([state[0] for state in states])

    def step():
        for _ in range(substeps):
            p.stepSimulation(physicsClientId=client)

    if substeps == 1:  # timed: no loop around the one call
        return (lambda: p.stepSimulation(physicsClientId=client)), positions
    return step, positions


def iiwa_mujoco():
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(iiwa_path()))
    model.opt.timestep = DT
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    data = mujoco.MjData(model)
    data.qpos[:] = START
    return (lambda: mujoco.mj_step(model, data)), (lambda: data.qpos.copy())
