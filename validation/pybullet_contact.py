"""pybullet peers for contact scenes: a bouncing ball, grids of cubes, the stability suite's scenes.

pybullet runs in one of two configurations, and every table that shows it names which:

* ``"defaults"``: pybullet as it comes. Only the scene is set: the time step, gravity, the
  bodies' masses, restitution and friction, and linear and angular damping 0 (pybullet's
  default is 0.04; the scenes have no drag, so both engines integrate the same physics).
  Used for resting contact and stacking.
* ``"restitution"``: additionally tuned as pybullet's issue #3094 advises for faithful
  restitution: ``warmStartingFactor`` 0, ``restitutionVelocityThreshold`` 0,
  ``useSplitImpulse`` 1, and ``contactProcessingThreshold`` 0 on every body. Warm starting
  and early contact points add impulse before an impact, which skews bounce heights. Used
  for bouncing and impact scenes, where it is pybullet's best.

pybullet's bodies may sleep by default; ``sleeping=False`` keeps them awake
(``ACTIVATION_STATE_DISABLE_SLEEPING``) where a benchmark compares awake stepping.
Quaternions are (x, y, z, w) in pybullet as here, so no reordering is needed.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CONFIGURATIONS", "PybulletScene", "bounce_heights"]

# configuration -> the label tables show
CONFIGURATIONS = {
    "defaults": "pybullet (defaults)",
    "restitution": "pybullet (tuned for restitution, its issue #3094)",
}

# what each configuration changes, in words, for the reports
CONFIGURATION_TEXT = {
    "defaults": "pybullet at its defaults (only the time step, gravity, masses, restitution, "
    "friction and zero damping set, as in the scene)",
    "restitution": "pybullet tuned for restitution as its issue #3094 advises "
    "(warmStartingFactor 0, restitutionVelocityThreshold 0, useSplitImpulse 1, "
    "contactProcessingThreshold 0 on every body; damping 0 as in the scene)",
}


class PybulletScene:
    """A DIRECT-mode pybullet world with a static box floor whose top is at z = 0.

    Parameters
    ----------
    dt : float
        Fixed time step.
    gravity : float
        Magnitude of g along -z.
    floor_half_extents : (3,) float or None
        Half sizes of the floor box; None builds no floor (add static boxes instead).
    floor_restitution, floor_friction : float
    configuration : {"defaults", "restitution"}
        See the module docstring.
    sleeping : bool
        False keeps every dynamic body awake.
    """

    def __init__(
        self,
        dt: float,
        gravity: float = 9.81,
        floor_half_extents=(2.0, 2.0, 0.5),
        floor_restitution: float = 1.0,
        floor_friction: float = 0.5,
        configuration: str = "defaults",
        sleeping: bool = True,
    ):
        import pybullet

        if configuration not in CONFIGURATIONS:
            raise ValueError(
                f"configuration must be one of {sorted(CONFIGURATIONS)}, got {configuration!r}"
            )
        self.p = pybullet
        self.configuration = configuration
        self.sleeping = sleeping
        self.client = pybullet.connect(pybullet.DIRECT)
        p, c = self.p, self.client
        p.setGravity(0, 0, -gravity, physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=dt, physicsClientId=c)
        if configuration == "restitution":
            p.setPhysicsEngineParameter(
                restitutionVelocityThreshold=0.0,
                warmStartingFactor=0.0,
                useSplitImpulse=1,
                physicsClientId=c,
            )
        self.floor = None
        if floor_half_extents is not None:
            half = np.asarray(floor_half_extents, float)
            self.floor = self.add_box(
                half, 0.0, (0, 0, -half[2]), floor_restitution, floor_friction
            )

    def _set_material(self, body: int, mass: float, restitution: float, friction: float) -> None:
        options = {
            "restitution": restitution,
            "lateralFriction": friction,
            "linearDamping": 0.0,
            "angularDamping": 0.0,
        }
        if self.configuration == "restitution":
            options["contactProcessingThreshold"] = 0.0
        if mass > 0 and not self.sleeping:
            options["activationState"] = self.p.ACTIVATION_STATE_DISABLE_SLEEPING
        self.p.changeDynamics(body, -1, physicsClientId=self.client, **options)

    def add_sphere(self, radius, mass, position, restitution=0.0, friction=0.0) -> int:
        shape = self.p.createCollisionShape(
            self.p.GEOM_SPHERE, radius=radius, physicsClientId=self.client
        )
        body = self.p.createMultiBody(
            mass, shape, basePosition=list(position), physicsClientId=self.client
        )
        self._set_material(body, mass, restitution, friction)
        return body

    def add_box(
        self,
        half_extents,
        mass,
        position,
        restitution=0.0,
        friction=0.0,
        orientation=(0.0, 0.0, 0.0, 1.0),
        linear_velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0),
    ) -> int:
        """A box body (mass 0: static); orientation (x, y, z, w), velocities in the world."""
        p, c = self.p, self.client
        shape = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=[float(h) for h in half_extents], physicsClientId=c
        )
        body = p.createMultiBody(
            float(mass),
            shape,
            basePosition=[float(x) for x in position],
            baseOrientation=[float(x) for x in orientation],
            physicsClientId=c,
        )
        self._set_material(body, mass, restitution, friction)
        if mass > 0:
            p.resetBaseVelocity(
                body, list(linear_velocity), list(angular_velocity), physicsClientId=c
            )
        return body

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self.p.stepSimulation(physicsClientId=self.client)

    def position(self, body: int) -> np.ndarray:
        return np.array(self.p.getBasePositionAndOrientation(body, physicsClientId=self.client)[0])

    def orientation(self, body: int) -> np.ndarray:
        return np.array(self.p.getBasePositionAndOrientation(body, physicsClientId=self.client)[1])

    def velocity(self, body: int) -> np.ndarray:
        return np.array(self.p.getBaseVelocity(body, physicsClientId=self.client)[0])

    def angular_velocity(self, body: int) -> np.ndarray:
        return np.array(self.p.getBaseVelocity(body, physicsClientId=self.client)[1])

    def max_penetration(self) -> float:
        """Deepest overlap (m) among the contact points of the last step; 0 without any."""
        points = self.p.getContactPoints(physicsClientId=self.client)
        return max((-point[8] for point in points), default=0.0)  # [8]: signed distance

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.client)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def bounce_heights(
    e: float, dt: float, seconds: float, radius: float = 0.5, configuration: str = "restitution"
):
    """pybullet ball (mass 1) dropped from 1 m above the floor: apex heights above rest, and
    the total energy (kinetic + potential) at every step. Restitution scenes use the
    configuration tuned for them by default."""
    with PybulletScene(dt, configuration=configuration) as scene:
        ball = scene.add_sphere(radius, 1.0, (0, 0, 1.0 + radius), restitution=e)
        heights, energies = [], []
        for _ in range(round(seconds / dt)):
            scene.step()
            z = scene.position(ball)[2]
            v = scene.velocity(ball)
            heights.append(z - radius)
            energies.append(0.5 * v @ v + 9.81 * z)
    h = np.array(heights)
    apex = np.flatnonzero((h[1:-1] > h[:-2]) & (h[1:-1] >= h[2:])) + 1
    return h[apex], np.array(energies)
