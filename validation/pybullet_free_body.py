"""pybullet as a peer for free rigid-body motion: one box, no gravity, no damping.

Two pybullet body kinds are measured, because they are integrated differently:

- ``multibody``: ``createMultiBody`` as pybullet does by default, a Featherstone
  ``btMultiBody`` with a floating base and no links;
- ``rigidbody``: ``createMultiBody(..., useMaximalCoordinates=True)``, a ``btRigidBody``.

Both step with Bullet's semi-implicit Euler at ``fixedTimeStep = dt`` with one sub-step.
pybullet's Python API has no switch for the gyroscopic term: Bullet's ``btRigidBody`` applies
its implicit body-frame gyroscopic impulse by default, and the Featherstone base includes the
velocity-product terms in its bias forces. Linear and angular damping default to 0.04 in
pybullet; they are set to 0 here. The mass and the principal inertia are set explicitly
(``localInertiaDiagonal``) to the library's values.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["PybulletBox"]


class PybulletBox:
    """A single box tumbling freely in its own pybullet DIRECT client.

    Parameters
    ----------
    extents : (3,) float
        Box side lengths (m).
    mass : float
    inertia_diagonal : (3,) float
        Principal moments of inertia about the centre of mass, box axes.
    dt : float
        pybullet's fixed time step.
    kind : {"multibody", "rigidbody"}
        Featherstone base or maximal-coordinate rigid body.
    position : (3,) float
    linear_velocity, angular_velocity : (3,) float
        World frame; the box starts with the identity orientation.
    """

    def __init__(
        self,
        extents,
        mass,
        inertia_diagonal,
        dt,
        kind="multibody",
        position=(0.0, 0.0, 0.0),
        linear_velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0),
    ):
        import pybullet

        if kind not in ("multibody", "rigidbody"):
            raise ValueError(f"kind must be 'multibody' or 'rigidbody', got {kind!r}")
        self._p = pybullet
        self.client = pybullet.connect(pybullet.DIRECT)
        c = self.client
        pybullet.setGravity(0, 0, 0, physicsClientId=c)
        pybullet.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=1, physicsClientId=c)
        shape = pybullet.createCollisionShape(
            pybullet.GEOM_BOX, halfExtents=[e / 2 for e in extents], physicsClientId=c
        )
        self.body = pybullet.createMultiBody(
            baseMass=mass,
            baseCollisionShapeIndex=shape,
            basePosition=list(position),
            baseInertialFramePosition=[0, 0, 0],
            useMaximalCoordinates=(kind == "rigidbody"),
            physicsClientId=c,
        )
        pybullet.changeDynamics(
            self.body,
            -1,
            linearDamping=0.0,
            angularDamping=0.0,
            localInertiaDiagonal=list(inertia_diagonal),
            physicsClientId=c,
        )
        pybullet.resetBaseVelocity(
            self.body, list(linear_velocity), list(angular_velocity), physicsClientId=c
        )
        self.inertia_diagonal = np.asarray(inertia_diagonal, dtype=np.float64)

    def state(self):
        """Position (3,), (x, y, z, w) orientation (4,), angular velocity (3,) in the world."""
        p, c = self._p, self.client
        position, orientation = p.getBasePositionAndOrientation(self.body, physicsClientId=c)
        _, omega = p.getBaseVelocity(self.body, physicsClientId=c)
        return np.array(position), np.array(orientation), np.array(omega)

    def record(self, steps: int):
        """Step ``steps`` times, returning the states at every step, the initial one first.

        Returns
        -------
        positions : (steps + 1, 3) float
        orientations : (steps + 1, 4) float
        angular_velocities : (steps + 1, 3) float
        """
        positions = np.empty((steps + 1, 3))
        orientations = np.empty((steps + 1, 4))
        omegas = np.empty((steps + 1, 3))
        step, c = self._p.stepSimulation, self.client
        positions[0], orientations[0], omegas[0] = self.state()
        for k in range(1, steps + 1):
            step(physicsClientId=c)
            positions[k], orientations[k], omegas[k] = self.state()
        return positions, orientations, omegas

    def time_steps(self, steps: int) -> float:
        """Wall-clock seconds (perf_counter) of ``steps`` bare ``stepSimulation`` calls."""
        step, c = self._p.stepSimulation, self.client
        start = time.perf_counter()
        for _ in range(steps):
            step(physicsClientId=c)
        return time.perf_counter() - start

    def close(self) -> None:
        """Disconnect the client."""
        self._p.disconnect(physicsClientId=self.client)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
