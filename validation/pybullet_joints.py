"""pybullet's multibody double pendulum, set up as the built-in ``double_pendulum`` scene.

Two 0.5 x 0.04 x 0.04 m rods of 1 kg, hinged end to end about +y, the first to a fixed base
at the origin, released level along +x; gravity 9.81, pybullet's inertia from the same box
shapes. Its defaults are changed only where the scene says otherwise: link damping zeroed
(``changeDynamics`` linearDamping, angularDamping and jointDamping 0; pybullet damps links by
default, our joints have no damping), and the default joint motors off (VELOCITY_CONTROL with
force 0; pybullet holds every joint still with them by default).
"""

from __future__ import annotations

import numpy as np

__all__ = ["double_pendulum_energy_errors"]

_LENGTH, _WIDTH, _MASS, _G = 0.5, 0.04, 1.0, 9.81


def _rod_inertia() -> np.ndarray:
    """A rod's inertia about its centre, body axes along the rod (x) and across."""
    along = _MASS * 2 * _WIDTH**2 / 12
    across = _MASS * (_LENGTH**2 + _WIDTH**2) / 12
    return np.diag([along, across, across])


def double_pendulum_energy_errors(dt: float, seconds: float) -> np.ndarray:
    """|E(t) - E(0)| (J) after each of pybullet's steps of the released double pendulum."""
    import pybullet as p

    client = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -_G, physicsClientId=client)
        p.setTimeStep(dt, physicsClientId=client)
        box = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=[_LENGTH / 2, _WIDTH / 2, _WIDTH / 2], physicsClientId=client
        )
        body = p.createMultiBody(
            baseMass=0, baseCollisionShapeIndex=-1, basePosition=[0, 0, 0],
            linkMasses=[_MASS, _MASS], linkCollisionShapeIndices=[box, box],
            linkVisualShapeIndices=[-1, -1], linkPositions=[[0, 0, 0], [_LENGTH, 0.06, 0]],
            linkOrientations=[[0, 0, 0, 1]] * 2,
            linkInertialFramePositions=[[_LENGTH / 2, 0, 0]] * 2,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * 2, linkParentIndices=[0, 1],
            linkJointTypes=[p.JOINT_REVOLUTE] * 2, linkJointAxis=[[0, 1, 0]] * 2,
            physicsClientId=client,
        )  # fmt: skip
        for link in range(2):
            p.setJointMotorControl2(body, link, p.VELOCITY_CONTROL, force=0, physicsClientId=client)
            p.changeDynamics(body, link, linearDamping=0, angularDamping=0, jointDamping=0,
                             physicsClientId=client)  # fmt: skip
        inertia = _rod_inertia()

        def energy() -> float:
            total = 0.0
            for link in range(2):
                state = p.getLinkState(body, link, computeLinkVelocity=1, physicsClientId=client)
                R = np.array(p.getMatrixFromQuaternion(state[1])).reshape(3, 3)
                v, w = np.array(state[6]), np.array(state[7])
                total += 0.5 * _MASS * v @ v + 0.5 * w @ R @ inertia @ R.T @ w
                total += _MASS * _G * state[0][2]
            return total

        start = energy()
        errors = np.empty(round(seconds / dt))
        for k in range(len(errors)):
            p.stepSimulation(physicsClientId=client)
            errors[k] = abs(energy() - start)
        return errors
    finally:
        p.disconnect(client)
