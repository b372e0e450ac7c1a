"""Chains of bodies jointed end to end, built alike in thesis_rbd, pybullet and MuJoCo.

A chain (:class:`ChainSpec`) hangs from the world: link 0 is joined to the world at anchor 0
and link i to link i - 1 at anchor i; every link starts unrotated and at rest, and no two links
collide in any engine (ours: every link in collision group 1 with an empty collision mask,
which leaves ours' collision stages running with nothing to find, or ``collidable=False``,
which drops them; pybullet: ``setCollisionFilterGroupMask(..., 0, 0)`` on every body or link;
MuJoCo: contype and conaffinity 0 on every geom). Every engine is given the same masses and
the same inertia: ours computes it from the link's mesh, pybullet takes its diagonal through
``changeDynamics(localInertiaDiagonal=...)``, MuJoCo through an explicit ``<inertial>``.

The peers run at their defaults except where the scene says otherwise (validation/PEERS.md):
pybullet's link damping (0.04 by default) is zeroed on every body and link, as the scene has
none, and its multibody's default joint motors are released (VELOCITY_CONTROL with force 0),
as validation/pybullet_joints.py does. Left at their defaults unless a caller changes them:
pybullet's 50 solver iterations, the 500 N cap on each constraint's force, the 100 rad/s clamp
on a multibody joint's speed; separate pybullet bodies are what ``createMultiBody`` makes by
default (each a floating-base btMultiBody with no links, joined by btMultiBodyPoint2Point
constraints); MuJoCo's Euler integrator and its solver.

Every chain here has ``step(n)``, which raises :class:`ChainDiverged` where the engine
reports a non-finite state, ``energy()`` and ``close()``; ours and pybullet's point-to-point
chain also have ``gap()``, the largest distance between a joint's two anchor points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import thesis_rbd as rbd
from thesis_rbd.spatial import quat_rotate, quat_to_matrix

__all__ = [
    "ChainDiverged",
    "ChainSpec",
    "MujocoHingeChain",
    "OursChain",
    "PybulletHingeMultibody",
    "PybulletPointChain",
    "heavy_chain",
    "straight_chain",
]


class ChainDiverged(FloatingPointError):
    """The engine reported a non-finite state (ours' NonFiniteStateError, MuJoCo's bad
    acceleration warning after which it resets itself)."""


@dataclass(frozen=True)
class ChainSpec:
    """A chain of n bodies, each joined to the one before it (the first to the world).

    Attributes
    ----------
    name : str
    meshes : list of TriangleMesh
        Ours' shape of each body, centred on its centre of mass.
    shapes : list of tuple
        The peers' geometry of each body: ``("box", (3,) full extents)`` or
        ``("sphere", radius)`` (m); it sets no mass property, the peers' collisions are off.
    masses : (n,) float ndarray
        kg.
    positions : (n, 3) float ndarray
        World centres of mass at t = 0 (m).
    inertia : (n, 3) float ndarray
        Principal moments about the centre of mass along the world axes at t = 0 (kg m^2),
        from ours' meshes.
    anchors : (n, 3) float ndarray
        World point of joint i, between body i and body i - 1 (the world for i = 0), m.
    """

    name: str
    meshes: list
    shapes: list
    masses: np.ndarray
    positions: np.ndarray
    inertia: np.ndarray
    anchors: np.ndarray

    @classmethod
    def build(cls, name, meshes, shapes, masses, positions, anchors) -> ChainSpec:
        """The spec with each body's inertia computed by ours from its mesh; ValueError where
        a body's inertia is not diagonal along the world axes (the peers take only the
        diagonal)."""
        masses = np.asarray(masses, dtype=np.float64)
        inertia = []
        for mesh, mass in zip(meshes, masses, strict=True):
            tensor = rbd.mass_properties(mesh, mass=float(mass)).inertia
            off_diagonal = tensor - np.diag(np.diag(tensor))
            if np.abs(off_diagonal).max() > 1e-9 * np.abs(tensor).max():
                raise ValueError(f"{name}: a body's inertia is not diagonal: {tensor.tolist()}")
            inertia.append(np.diag(tensor))
        return cls(
            name,
            list(meshes),
            list(shapes),
            masses,
            np.asarray(positions, dtype=np.float64),
            np.array(inertia),
            np.asarray(anchors, dtype=np.float64),
        )

    def __len__(self) -> int:
        return len(self.masses)

    def pivots(self) -> tuple[np.ndarray, np.ndarray]:
        """(child, parent), each (n, 3): joint i's anchor relative to body i's centre and to
        body i - 1's (to the world origin for i = 0), unrotated frames (m)."""
        child = self.anchors - self.positions
        parent = self.anchors.copy()
        parent[1:] -= self.positions[:-1]
        return child, parent

    def released_energy(self, g: float) -> float:
        """Potential energy (J) the chain gives up hanging straight down from anchor 0: each
        body's centre falls by its distance from the anchor, the scale of energy errors."""
        depth = np.linalg.norm(self.positions - self.anchors[0], axis=1)
        return float(g * self.masses @ depth)


def straight_chain(links: int, length: float = 0.1, width: float = 0.01, mass: float = 0.05):
    """``links`` boxes of ``length`` x ``width`` x ``width`` m and ``mass`` kg end to end
    along +x from the origin (horizontal), jointed at their ends."""
    extents = (length, width, width)
    centres = np.zeros((links, 3))
    centres[:, 0] = length * (np.arange(links) + 0.5)
    anchors = np.zeros((links, 3))
    anchors[:, 0] = length * np.arange(links)
    return ChainSpec.build(
        f"{links}-link chain",
        [rbd.shapes.box(extents)] * links,
        [("box", extents)] * links,
        np.full(links, mass),
        centres,
        anchors,
    )


def heavy_chain() -> ChainSpec:
    """The built-in ``heavy_chain`` scene (ten 0.1 kg links, a 10 kg bob, ball joints,
    released horizontal) as a chain spec: its bodies and anchors as the scene file gives
    them; ValueError if the file no longer describes a chain hung from the world."""
    scene = rbd.scenes.get("heavy_chain")
    for index, joint in enumerate(scene.joints):
        expected = None if index == 0 else index - 1
        if joint.kind != "spherical" or joint.body_a != index or joint.body_b != expected:
            raise ValueError(
                f"heavy_chain's joint {index} no longer joins body {index} to the one before"
            )
    shapes = []
    for body in scene.bodies:
        table = dict(body.shape)
        if table["type"] == "box":
            shapes.append(("box", tuple(table["extents"])))
        elif table["type"] == "icosphere":
            shapes.append(("sphere", float(table["radius"])))
        else:
            raise ValueError(f"heavy_chain has a {table['type']} body; boxes and spheres only")
    return ChainSpec.build(
        "heavy_chain",
        [body.mesh for body in scene.bodies],
        shapes,
        [body.mass for body in scene.bodies],
        [body.position for body in scene.bodies],
        [joint.anchor for joint in scene.joints],
    )


class OursChain:
    """The chain in a thesis_rbd World.

    Parameters
    ----------
    spec : ChainSpec
    joint : {"spherical", "revolute"}
        Hinges turn about the world y axis (the chain swings in the x-z plane).
    dt, g : float
        Step (s) and gravity along -z (m/s^2).
    substeps : int or "auto"
        ``World(joint_substeps=...)``.
    collidable : bool
        True: every body in collision group 1 with collision mask 0 (no pair collides; the
        collision stages run); False: ``collidable=False`` (no collision stage at all).
    """

    def __init__(self, spec, joint, dt, g, substeps="auto", collidable=True):
        world = rbd.World(dt=dt, gravity=(0.0, 0.0, -g), joint_substeps=substeps)
        for index, (mesh, mass, position) in enumerate(
            zip(spec.meshes, spec.masses, spec.positions, strict=True)
        ):
            world.add_body(
                mesh,
                mass=float(mass),
                position=position,
                name=f"link{index}",
                collidable=collidable,
                collision_group=1,
                collision_mask=0,
            )
            parent = None if index == 0 else index - 1
            world.add_joint(joint, index, parent, anchor=spec.anchors[index], axis=(0, 1, 0))
        self.world = world

    def step(self, n: int) -> None:
        try:
            self.world.step(n)
        except rbd.NonFiniteStateError as error:
            raise ChainDiverged(str(error)) from error

    def gap(self) -> float:
        """Largest anchor gap over the joints now (m), from ``World.joints``."""
        return float(self.world.joints["gap"].max())

    def energy(self) -> float:
        """Kinetic plus gravitational potential energy (J), zero potential at z = 0."""
        return self.world.kinetic_energy() + self.world.potential_energy()

    def close(self) -> None:
        """Nothing to release (the peers disconnect their clients)."""


def _kinetic_energy(masses, inertia, v, w, R) -> float:
    """Sum of 1/2 m v.v + 1/2 w.(R I R^T) w over bodies: v, w (n, 3) world, R (n, 3, 3)."""
    w_body = np.einsum("nji,nj->ni", R, w)
    return float(
        0.5 * masses @ np.einsum("ni,ni->n", v, v)
        + 0.5 * np.einsum("ni,ni->", w_body * inertia, w_body)
    )


class _PybulletClient:
    """A pybullet DIRECT client with the scene's gravity and time step."""

    def __init__(self, dt, g):
        import pybullet

        self.p = pybullet
        self.client = pybullet.connect(pybullet.DIRECT)
        pybullet.setGravity(0, 0, -g, physicsClientId=self.client)
        pybullet.setTimeStep(dt, physicsClientId=self.client)
        self.g = g

    def shape(self, geometry) -> int:
        kind, size = geometry
        p = self.p
        if kind == "box":
            half = [0.5 * float(x) for x in size]
            return p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        return p.createCollisionShape(p.GEOM_SPHERE, radius=size, physicsClientId=self.client)

    def step(self, n: int) -> None:
        for _ in range(n):
            self.p.stepSimulation(physicsClientId=self.client)

    def solver_iterations(self) -> int:
        """pybullet's numSolverIterations as the client reports it."""
        parameters = self.p.getPhysicsEngineParameters(physicsClientId=self.client)
        return int(parameters["numSolverIterations"])

    def close(self) -> None:
        self.p.disconnect(self.client)


class PybulletPointChain(_PybulletClient):
    """The chain as separate pybullet bodies joined by ``JOINT_POINT2POINT`` constraints
    (ball joints; pybullet's ``createConstraint`` has no hinge), solved by its sequential
    impulses (projected Gauss-Seidel).

    Parameters
    ----------
    spec : ChainSpec
    dt, g : float
    iterations : int
        ``setPhysicsEngineParameter(numSolverIterations=...)``; 50 is pybullet's default.
    max_force : float, optional
        ``changeConstraint(maxForce=...)`` on every joint (N); None keeps the default 500 N.
    """

    def __init__(self, spec, dt, g, iterations=50, max_force=None):
        super().__init__(dt, g)
        p, c = self.p, self.client
        p.setPhysicsEngineParameter(numSolverIterations=iterations, physicsClientId=c)
        child, parent = spec.pivots()
        self.bodies = []
        for index in range(len(spec)):
            body = p.createMultiBody(
                baseMass=float(spec.masses[index]),
                baseCollisionShapeIndex=self.shape(spec.shapes[index]),
                basePosition=spec.positions[index].tolist(),
                physicsClientId=c,
            )
            p.changeDynamics(
                body,
                -1,
                linearDamping=0,
                angularDamping=0,
                localInertiaDiagonal=spec.inertia[index].tolist(),
                physicsClientId=c,
            )
            p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
            # frames relative to each body's centre of mass; the world's frame is the world
            other = -1 if index == 0 else self.bodies[-1]
            constraint = p.createConstraint(
                body,
                -1,
                other,
                -1,
                p.JOINT_POINT2POINT,
                [0, 0, 0],
                child[index].tolist(),
                parent[index].tolist(),
                physicsClientId=c,
            )
            if max_force is not None:
                p.changeConstraint(constraint, maxForce=max_force, physicsClientId=c)
            self.bodies.append(body)
        self.masses, self.inertia = spec.masses, spec.inertia
        self.child, self.parent = child, parent
        self.world_anchor = spec.anchors[0]

    def _poses(self):
        """(x (n, 3), q (n, 4) x-y-z-w) of the bodies' centres of mass."""
        p, c = self.p, self.client
        poses = [p.getBasePositionAndOrientation(b, physicsClientId=c) for b in self.bodies]
        return np.array([x for x, _ in poses]), np.array([q for _, q in poses])

    def gap(self) -> float:
        """Largest distance between a joint's anchor point on each of its bodies (m)."""
        x, q = self._poses()
        on_child = x + quat_rotate(q, self.child)
        on_parent = np.vstack([self.world_anchor, x[:-1] + quat_rotate(q[:-1], self.parent[1:])])
        return float(np.linalg.norm(on_child - on_parent, axis=1).max())

    def energy(self) -> float:
        p, c = self.p, self.client
        x, q = self._poses()
        velocities = [p.getBaseVelocity(b, physicsClientId=c) for b in self.bodies]
        v = np.array([lin for lin, _ in velocities])
        w = np.array([ang for _, ang in velocities])
        kinetic = _kinetic_energy(self.masses, self.inertia, v, w, quat_to_matrix(q))
        return kinetic + self.g * float(self.masses @ x[:, 2])


class PybulletHingeMultibody(_PybulletClient):
    """The chain as one pybullet multibody (Featherstone, reduced coordinates): a fixed
    massless base at anchor 0, link i on a revolute joint about y at anchor i.

    Parameters
    ----------
    spec : ChainSpec
    dt, g : float
    """

    def __init__(self, spec, dt, g):
        super().__init__(dt, g)
        p, c = self.p, self.client
        n = len(spec)
        # a multibody link's frame is its joint's frame: put it at the anchor
        frames = np.diff(spec.anchors, axis=0, prepend=spec.anchors[:1])
        self.body = p.createMultiBody(
            baseMass=0,
            baseCollisionShapeIndex=-1,
            basePosition=spec.anchors[0].tolist(),
            linkMasses=spec.masses.tolist(),
            linkCollisionShapeIndices=[self.shape(s) for s in spec.shapes],
            linkVisualShapeIndices=[-1] * n,
            linkPositions=frames.tolist(),
            linkOrientations=[[0, 0, 0, 1]] * n,
            linkInertialFramePositions=(spec.positions - spec.anchors).tolist(),
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=list(range(n)),
            linkJointTypes=[p.JOINT_REVOLUTE] * n,
            linkJointAxis=[[0, 1, 0]] * n,
            physicsClientId=c,
        )
        for link in range(n):
            p.setJointMotorControl2(self.body, link, p.VELOCITY_CONTROL, force=0, physicsClientId=c)
            p.changeDynamics(
                self.body,
                link,
                linearDamping=0,
                angularDamping=0,
                jointDamping=0,
                localInertiaDiagonal=spec.inertia[link].tolist(),
                physicsClientId=c,
            )
            p.setCollisionFilterGroupMask(self.body, link, 0, 0, physicsClientId=c)
        self.masses, self.inertia = spec.masses, spec.inertia

    def energy(self) -> float:
        p = self.p
        # forward kinematics on request: without it pybullet may return the previous poses
        states = p.getLinkStates(
            self.body,
            list(range(len(self.masses))),
            computeLinkVelocity=1,
            computeForwardKinematics=1,
            physicsClientId=self.client,
        )
        x = np.array([s[0] for s in states])
        R = quat_to_matrix(np.array([s[1] for s in states]))
        v = np.array([s[6] for s in states])
        w = np.array([s[7] for s in states])
        kinetic = _kinetic_energy(self.masses, self.inertia, v, w, R)
        return kinetic + self.g * float(self.masses @ x[:, 2])


class MujocoHingeChain:
    """The chain in MuJoCo: nested bodies (reduced coordinates), link i on a hinge about y at
    anchor i, from an MJCF string built here.

    Parameters
    ----------
    spec : ChainSpec
    dt, g : float
    integrator : str, optional
        MJCF ``<option integrator=...>``; None keeps MuJoCo's default (Euler).

    Raises
    ------
    ImportError
        Where the optional ``mujoco`` package is not installed.
    """

    def __init__(self, spec, dt, g, integrator=None):
        from validation.mujoco_contact import require_mujoco

        mujoco = require_mujoco()
        self.mujoco = mujoco
        inner = ""
        # bodies nest from the last link out; each body's frame sits at its centre of mass
        for index in reversed(range(len(spec))):
            parent = spec.positions[index - 1] if index else np.zeros(3)
            inner = (
                f'<body pos="{_vector(spec.positions[index] - parent)}">'
                f'<joint type="hinge" axis="0 1 0" '
                f'pos="{_vector(spec.anchors[index] - spec.positions[index])}"/>'
                f'<inertial pos="0 0 0" mass="{float(spec.masses[index])!r}" '
                f'diaginertia="{_vector(spec.inertia[index])}"/>'
                f"{_mjcf_geom(spec.shapes[index])}{inner}</body>"
            )
        option = f' integrator="{integrator}"' if integrator else ""
        xml = (
            f'<mujoco><option timestep="{float(dt)!r}" gravity="0 0 {-float(g)!r}"{option}/>'
            f"<worldbody>{inner}</worldbody></mujoco>"
        )
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)

    def step(self, n: int) -> None:
        mujoco = self.mujoco
        # the state's warning counter reports a divergence below; MuJoCo's own handler would
        # also print it and append it to MUJOCO_LOG.TXT in the working directory
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(_ignore_warning)
        try:
            mujoco.mj_step(self.model, self.data, n)
        finally:
            mujoco.set_mju_user_warning(previous)
        # on a bad acceleration MuJoCo warns and silently resets the state to t = 0
        if self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
            raise ChainDiverged("MuJoCo reported a bad acceleration and reset the simulation")

    def energy(self) -> float:
        mujoco = self.mujoco
        # after mj_step the derived quantities are those of the state before the step
        mujoco.mj_forward(self.model, self.data)
        mujoco.mj_energyPos(self.model, self.data)
        mujoco.mj_energyVel(self.model, self.data)
        return float(self.data.energy.sum())

    def close(self) -> None:
        """Nothing to release (kept for symmetry with the pybullet peers)."""


def _ignore_warning(_message: str) -> None:
    pass


def _vector(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def _mjcf_geom(geometry) -> str:
    """A geom that collides with nothing (contype and conaffinity 0); MJCF sizes are half
    extents."""
    kind, size = geometry
    sizes = _vector(0.5 * np.asarray(size)) if kind == "box" else repr(float(size))
    return f'<geom type="{kind}" size="{sizes}" contype="0" conaffinity="0"/>'
