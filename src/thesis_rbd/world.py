"""The world: bodies, the force model, and a step that reads as its list of stages.

A step runs only the stages the scene calls for (``World.stages``), each timed into
``World.profile``:

    forces -> integrate -> bounds -> broad_phase -> narrow_phase -> tunnelling -> contacts
           -> sleep

The plan is derived from the scene and refreshed whenever bodies or forces change: no gravity
or applied force, no forces stage; no dynamic body, nothing at all; fewer than two bodies, no
collision stages; no contact response wanted (a detection-only scene), no contacts stage. Two
stages are also skipped step by step when they have nothing to do: the narrow phase when the
broad phase found no candidate pair, the tunnelling check when no body moved further than its
own thickness, the contact response when there is no contact, everything but the forces when all
bodies sleep; a skipped stage is not called and costs nothing. So are two more: the broad
phase while no body left its fat box and no fat boxes overlap (``collision/bounds.py``), and
the sleep stage while every moving body is too fast to count as still, none has been still
and nothing touched (it would change nothing).
"""

from __future__ import annotations

import math
from time import perf_counter

import numpy as np

from thesis_rbd._validate import as_finite_array, as_positive_scalar, as_unit_quaternion
from thesis_rbd.collision.pipeline import CollisionPipeline, empty_contacts
from thesis_rbd.dynamics.bodies import BodyArrays
from thesis_rbd.dynamics.forces import (
    AppliedForces,
    DragCoefficients,
    PointForces,
    world_arm_to_body,
)
from thesis_rbd.dynamics.integrators import INTEGRATORS, integrate_bodies
from thesis_rbd.dynamics.response import ContactSettings, ImpulseCache, resolve_contacts
from thesis_rbd.dynamics.sleep import SleepSettings, SleepState
from thesis_rbd.geometry.mass import mass_properties
from thesis_rbd.geometry.mesh import TriangleMesh
from thesis_rbd.geometry.width import hull_thickness
from thesis_rbd.spatial.quaternion import quat_conjugate, quat_rotate, quat_to_matrix

__all__ = ["STAGE_NAMES", "World"]

# Every stage a world can run, in pipeline order; ``World.profile`` has an entry for each so
# that a skipped stage shows zero calls.
STAGE_NAMES = (
    "forces",
    "integrate",
    "bounds",
    "broad_phase",
    "narrow_phase",
    "tunnelling",
    "contacts",
    "sleep",
)


class World:
    """A rigid-body world stepped at a fixed time step.

    Parameters
    ----------
    dt : float
        Time step (s), > 0.
    gravity : (3,) array_like
        Gravitational acceleration (m/s^2); (0, 0, 0) by default (no effect is on by default).
    integrator : {"euler", "symplectic_euler", "midpoint", "rk4"}
        ODE method for free motion.
    linear_drag, quadratic_drag, angular_drag : float
        Air resistance on every dynamic body: F = -k1 v - k2 |v| v, tau = -ka w.
    contact_response : bool
        False makes a detection-only world: contacts are found (``World.contacts``) but
        bodies pass through each other.
    contact_solver : {"pgs", "exact"}
        Projected Gauss-Seidel or Lemke's exact method for the contact LCP.
    contact_iterations : int
        Largest number of PGS sweeps per step (they stop early once converged).
    friction_sides : int
        Sides of the polygonal friction cone.
    bounce_threshold : float
        Contacts approaching slower than this (m/s) do not bounce.
    slop : float
        Penetration (m) the position projection leaves, so resting contacts persist.
    penetration : {"toi", "projection"}
        Step impacting islands back to the time of impact, or only project positions.
    sleeping : bool
        Let islands at rest fall asleep (frozen, free of cost) until touched or pushed.
    narrow_phase : {"auto", "mesh"}
        "auto": pairs of convex bodies collide as convex polyhedra (separating axes, GJK and
        EPA), the others through the OBBTree; "mesh": the OBBTree for every pair.
    """

    def __init__(
        self,
        dt: float = 1.0 / 240.0,
        gravity=(0.0, 0.0, 0.0),
        integrator: str = "rk4",
        linear_drag: float = 0.0,
        quadratic_drag: float = 0.0,
        angular_drag: float = 0.0,
        contact_response: bool = True,
        contact_solver: str = "pgs",
        contact_iterations: int = 100,
        friction_sides: int = 8,
        bounce_threshold: float = 0.1,
        slop: float = 1e-4,
        penetration: str = "toi",
        sleeping: bool = True,
        narrow_phase: str = "auto",
    ):
        self.dt = as_positive_scalar(dt, "dt")
        self.gravity = as_finite_array(gravity, "gravity", shape=(3,))
        if integrator not in INTEGRATORS:
            raise ValueError(
                f"unknown integrator {integrator!r}; choose one of {sorted(INTEGRATORS)}"
            )
        self.integrator = integrator
        self.drag = DragCoefficients(linear_drag, quadratic_drag, angular_drag)
        self._drag_array = np.array([linear_drag, quadratic_drag, angular_drag], dtype=np.float64)
        self.time = 0.0
        self.bodies = BodyArrays()
        self.applied_forces = AppliedForces()
        self.profile = {name: {"calls": 0, "seconds": 0.0} for name in STAGE_NAMES}
        self._gravity_force = np.zeros((0, 3))
        self._external_force = self._gravity_force
        self._point_forces = PointForces.empty(0)
        self.contact_response = bool(contact_response)
        self.contact_settings = ContactSettings(
            solver=contact_solver,
            iterations=contact_iterations,
            friction_sides=friction_sides,
            bounce_threshold=bounce_threshold,
            slop=slop,
            penetration=penetration,
        )
        self._collision = CollisionPipeline(narrow_phase)
        self.narrow_phase = narrow_phase
        self._sleep = SleepState(SleepSettings(enabled=bool(sleeping)))
        self._impulse_cache = ImpulseCache()
        self._resolved: dict[str, np.ndarray] | None = None
        self.contact_info: dict = {}
        self._pipeline: list[tuple[str, object, object]] = []
        self._plan_stages()

    # ------------------------------------------------------------------ building the scene
    def add_body(
        self,
        mesh: TriangleMesh,
        mass: float | None = None,
        density: float | None = None,
        position=(0.0, 0.0, 0.0),
        orientation=(0.0, 0.0, 0.0, 1.0),
        linear_velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0),
        restitution: float = 0.0,
        friction: float = 0.0,
        static: bool = False,
        name: str | None = None,
        collidable: bool = True,
    ) -> int:
        """Add a body and return its index.

        Parameters
        ----------
        mesh : TriangleMesh
            Shape in its own (mesh) frame; closed for a dynamic body.
        mass, density : float, optional
            Give at most one; neither means density 1.0. Ignored for static bodies.
        position : (3,) array_like
            World position of the centre of mass (of the mesh frame origin for a static
            body whose mesh is open).
        orientation : (4,) array_like
            (x, y, z, w) rotation of the mesh frame into the world; normalised.
        linear_velocity, angular_velocity : (3,) array_like
            Initial v and w, world frame.
        restitution : float in [0, 1]
            Combined per contact as the product of the two bodies' values.
        friction : float >= 0
            Combined per contact as the geometric mean of the two bodies' values.
        static : bool
            An immovable body (zero inverse mass and inertia).
        name : str, optional
            Label used in trajectories; "body<i>" by default.
        collidable : bool
            False keeps the body out of collision detection (free flight only); with fewer
            than two collidable bodies the world runs no collision stage at all.
        """
        if not isinstance(mesh, TriangleMesh):
            raise ValueError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
        if mass is not None and density is not None:
            raise ValueError("give mass or density, not both")
        position = as_finite_array(position, "position", shape=(3,))
        q = as_unit_quaternion(orientation)
        v = as_finite_array(linear_velocity, "linear_velocity", shape=(3,))
        w = as_finite_array(angular_velocity, "angular_velocity", shape=(3,))
        restitution = float(restitution)
        if not 0.0 <= restitution <= 1.0:
            raise ValueError(f"restitution must lie in [0, 1], got {restitution!r}")
        friction = float(friction)
        if not (math.isfinite(friction) and friction >= 0.0):
            raise ValueError(f"friction must be finite and >= 0, got {friction!r}")

        if static:
            center = (
                mass_properties(mesh).center_of_mass
                if mesh.is_closed and mesh.is_consistently_oriented
                else np.zeros(3)
            )
            m, inv_m = math.inf, 0.0
            inertia, inv_inertia = np.zeros((3, 3)), np.zeros((3, 3))
            P, L = np.zeros(3), np.zeros(3)
        else:
            if mass is not None:
                props = mass_properties(mesh, mass=as_positive_scalar(mass, "mass"))
            else:
                props = mass_properties(mesh, density=1.0 if density is None else density)
            center, m, inertia = props.center_of_mass, props.mass, props.inertia
            inv_m, inv_inertia = 1.0 / m, np.linalg.inv(inertia)
            R = quat_to_matrix(q)
            P = m * v
            L = R @ inertia @ R.T @ w
        radius = float(np.linalg.norm(mesh.vertices - center, axis=1).max())
        index = self.bodies.append(
            mesh,
            name if name is not None else f"body{self.bodies.count}",
            position=position,
            orientation=q,
            linear_momentum=P,
            angular_momentum=L,
            inverse_mass=inv_m,
            inverse_inertia_body=inv_inertia,
            mass=m,
            inertia_body=inertia,
            center_of_mass_local=center,
            size=radius,
            # a flat mesh has no thickness; a thousandth of its radius keeps sampling finite
            thickness=max(hull_thickness(mesh.vertices), 1e-3 * radius),
            restitution=restitution,
            friction=friction,
            static=bool(static),
            collidable=bool(collidable),
        )
        self._collision.add_body(mesh, center)
        self._sleep.resize(self.bodies.count)
        self._plan_stages()
        return index

    def apply_force(self, body: int, force, point=None, duration: float | None = None) -> None:
        """Apply a world-frame force to a body.

        Parameters
        ----------
        body : int
            Body index.
        force : (3,) array_like
            Force (N), fixed in the world frame.
        point : (3,) array_like, optional
            World point of application now; it is attached to the body, so the torque arm
            turns with it. None applies the force through the centre of mass (no torque).
        duration : float, optional
            Seconds the force lasts (it delivers exactly force * duration of impulse); None
            means until the end of the run.
        """
        body = self._check_body(body)
        force = as_finite_array(force, "force", shape=(3,))
        if point is None:
            arm = np.zeros(3)
        else:
            point = as_finite_array(point, "point", shape=(3,))
            b = self.bodies
            arm = world_arm_to_body(point, b.position[body], b.orientation[body])
        remaining = math.inf if duration is None else as_positive_scalar(duration, "duration")
        self.applied_forces.add(body, force, arm, remaining)
        self._sleep.wake(np.array([body]))
        self._plan_stages()

    # ------------------------------------------------------------------ stepping
    @property
    def stages(self) -> list[str]:
        """Names of the stages this scene needs, in pipeline order."""
        return [entry[0] for entry in self._pipeline]

    def _plan_stages(self) -> None:
        """Derive the pipeline from the scene: only the effects it calls for.

        Each entry is (name, stage, guard, profile entry): a stage whose guard returns False
        this step is skipped without being called.
        """
        b = self.bodies
        dynamic = bool(b.count) and not bool(np.all(b.static))
        gathers_forces = dynamic and (bool(np.any(self.gravity)) or len(self.applied_forces) > 0)
        collidable = b.collidable
        collides = (
            dynamic
            and int(np.count_nonzero(collidable)) >= 2
            and not bool(np.all(b.static[collidable]))
        )
        always = _always
        pipeline = []
        if gathers_forces:
            pipeline.append(("forces", self._stage_forces, always))
        if dynamic:
            pipeline.append(("integrate", self._stage_integrate, self._any_awake))
        if collides:
            pipeline.append(("bounds", self._stage_bounds, self._any_awake))
            pipeline.append(("broad_phase", self._stage_broad_phase, self._broad_phase_due))
            pipeline.append(("narrow_phase", self._stage_narrow_phase, self._has_candidates))
            pipeline.append(("tunnelling", self._stage_tunnelling, self._has_fast_bodies))
            if self.contact_response:
                pipeline.append(("contacts", self._stage_contacts, self._has_contacts))
        if collides and self._sleep.settings.enabled:
            # bodies come to rest through contact: without collisions nothing would sleep
            pipeline.append(("sleep", self._stage_sleep, self._sleep_due))
        self._pipeline = [(*entry, self.profile[entry[0]]) for entry in pipeline]
        self._collision_planned = collides
        self._collision.plan(b.static, collidable)
        self._start_position = b.position.copy()
        self._start_orientation = b.orientation.copy()
        self._sleep_changed()
        self._stale_plan = False
        # M g is constant between scene changes: computed here, not every step
        self._gravity_force = np.where(b.static, 0.0, b.mass)[:, None] * self.gravity
        self._external_force = self._gravity_force
        self._point_forces = PointForces.empty(b.count)

    def step(self, n: int = 1) -> None:
        """Advance the world by ``n`` steps of ``dt``."""
        if int(n) != n or n < 0:
            raise ValueError(f"n must be a non-negative integer, got {n!r}")
        for _ in range(int(n)):
            for _name, stage, guard, entry in self._pipeline:
                if not guard():
                    continue
                start = perf_counter()
                stage()
                entry["seconds"] += perf_counter() - start
                entry["calls"] += 1
            self.time += self.dt
            if self._stale_plan:
                self._plan_stages()

    def _stage_forces(self) -> None:
        """Gather gravity and the applied forces active this step."""
        applied = self.applied_forces
        if len(applied) == 0:
            return  # gravity alone: _external_force already holds M g
        self._external_force, self._point_forces = applied.gather(
            self.dt, self._gravity_force, self.bodies.static
        )
        if len(applied) == 0:
            self._stale_plan = True  # the last applied force ran out: replan after this step

    def _sleep_changed(self) -> None:
        """Refresh what depends on who sleeps: called whenever a body falls asleep or wakes.

        ``_frozen`` (n,) bool marks the bodies that do not move this step (static or asleep);
        ``_awake`` says whether any body moves at all.
        """
        self._frozen = self.bodies.static | self._sleep.asleep
        self._awake = not bool(np.all(self._frozen))

    def _any_awake(self) -> bool:
        return self._awake

    def _stage_integrate(self) -> None:
        """Advance free motion of every dynamic body by one step."""
        b = self.bodies
        pf = self._point_forces
        integrate_bodies(
            INTEGRATORS[self.integrator],
            self.dt,
            b.count,
            self._frozen,
            b.full("position"),
            b.full("orientation"),
            b.full("linear_momentum"),
            b.full("angular_momentum"),
            b.full("inverse_mass"),
            b.full("inverse_inertia_body"),
            self._external_force,
            self._drag_array,
            pf.start,
            pf.arm,
            pf.force,
            # where the step started: fast bodies are swept from here (no tunnelling)
            self._collision_planned,
            self._start_position,
            self._start_orientation,
        )

    def _stage_bounds(self) -> None:
        """Fast bodies (moved further than their own thickness) and fat boxes, refitted if a
        moving body left its own."""
        self._collision.bounds(self.bodies, self._frozen, self._start_position, self.dt)

    def _has_fast_bodies(self) -> bool:
        return self._awake and self._collision.fast_count > 0

    def _stage_tunnelling(self) -> None:
        """Time-of-impact sampling for fast bodies only: put back what passed through."""
        self._collision.sweep(
            self.bodies, self._collision.fast, self._start_position, self._start_orientation
        )

    def _broad_phase_due(self) -> bool:
        return self._awake and self._collision.broad_phase_due

    def _stage_broad_phase(self) -> None:
        """Sweep-and-prune on the fat boxes if they changed; candidate pairs with at least one
        moving body and overlapping tight boxes."""
        self._collision.broad_phase(self.bodies, self._frozen)

    def _has_candidates(self) -> bool:
        return self._awake and len(self._collision.candidate_pairs) > 0

    def _stage_narrow_phase(self) -> None:
        """Contacts of the candidate pairs (convex pairs by the convex kernel, the others by
        the OBBTree); a touched sleeping island wakes."""
        self._collision.narrow_phase(self.bodies)
        if self._sleep.any_asleep and self._sleep.wake_touched(
            self._collision.contacts, self.bodies.static
        ):
            self._sleep_changed()
            # the woken islands' own contacts were not candidates: find them now
            self._collision.broad_phase(self.bodies, self._frozen)
            self._collision.narrow_phase(self.bodies)

    def _has_contacts(self) -> bool:
        return self._awake and len(self._collision.contacts["depths"]) > 0

    def _stage_contacts(self) -> None:
        """Impulses with restitution and friction, time of impact, position projection."""
        self._resolved, self.contact_info = resolve_contacts(
            self.bodies,
            self._collision.contacts,
            self._external_force,
            self.dt,
            self.contact_settings,
            self._impulse_cache,
            self._collision,
        )

    def _sleep_due(self) -> bool:
        return self._awake and self._sleep.update_due(
            self._collision.slowest_speed2, self._has_contacts()
        )

    def _stage_sleep(self) -> None:
        """Islands still for long enough fall asleep with zero velocity."""
        b = self.bodies
        contacts = self._collision.contacts if self._has_contacts() else empty_contacts()
        fell = self._sleep.update(b, contacts, self.dt)
        if len(fell):
            b.linear_momentum[fell] = 0.0
            b.angular_momentum[fell] = 0.0
            self._sleep_changed()

    @property
    def sleeping(self) -> np.ndarray:
        """(n,) bool copy: which bodies are asleep."""
        return self._sleep.asleep.copy()

    @property
    def contacts(self) -> dict[str, np.ndarray]:
        """Contacts of the last step, world frame.

        Keys: ``body_a``, ``body_b`` (c,) int64; ``points``, ``normals`` (c, 3), normals from
        body_b towards body_a; ``depths`` (c,); ``faces`` (c, 2) [face of a, face of b]
        (-1 for convex pairs); ``features`` (c,) int64 feature ids of convex pairs' contacts,
        the same from step to step while their features are (-1 for mesh pairs);
        ``impulses`` (c, 3) (normal, t1, t2) applied by the contact stage. With a response,
        these are the contacts the impulses acted at (for an impact, those at the time of
        impact); in a detection-only world, the narrow phase's contacts with zero impulses.
        """
        if self.contact_response and self._resolved is not None and self._has_contacts():
            source = self._resolved
        else:
            source = dict(self._collision.contacts)
            source["impulses"] = np.zeros((len(source["depths"]), 3))
        return {key: value.copy() for key, value in source.items()}

    # ------------------------------------------------------------------ accessors
    def _check_body(self, body) -> int:
        if isinstance(body, bool) or int(body) != body or not 0 <= body < self.bodies.count:
            raise ValueError(f"no body {body!r}: the world has {self.bodies.count} bodies")
        return int(body)

    def __len__(self) -> int:
        return self.bodies.count

    @property
    def positions(self) -> np.ndarray:
        """(n, 3) read-only view of the centres of mass (world)."""
        view = self.bodies.position.view()
        view.flags.writeable = False
        return view

    @property
    def orientations(self) -> np.ndarray:
        """(n, 4) read-only view of the (x, y, z, w) orientations."""
        view = self.bodies.orientation.view()
        view.flags.writeable = False
        return view

    @property
    def names(self) -> list[str]:
        return list(self.bodies.names)

    def position(self, body: int) -> np.ndarray:
        """(3,) world centre of mass of a body."""
        return self.bodies.position[self._check_body(body)].copy()

    def orientation(self, body: int) -> np.ndarray:
        """(4,) (x, y, z, w) orientation of a body."""
        return self.bodies.orientation[self._check_body(body)].copy()

    def linear_momentum(self, body: int) -> np.ndarray:
        """(3,) P = M v (world)."""
        return self.bodies.linear_momentum[self._check_body(body)].copy()

    def angular_momentum(self, body: int) -> np.ndarray:
        """(3,) L about the centre of mass (world)."""
        return self.bodies.angular_momentum[self._check_body(body)].copy()

    def linear_velocity(self, body: int) -> np.ndarray:
        """(3,) v = P / M (world); zero for a static body."""
        i = self._check_body(body)
        return self.bodies.linear_momentum[i] * self.bodies.inverse_mass[i]

    def angular_velocity(self, body: int) -> np.ndarray:
        """(3,) w = R I_body^-1 R^T L (world); zero for a static body."""
        i = self._check_body(body)
        R = quat_to_matrix(self.bodies.orientation[i])
        return R @ self.bodies.inverse_inertia_body[i] @ R.T @ self.bodies.angular_momentum[i]

    def transform(self, body: int) -> np.ndarray:
        """(4, 4) rigid transform from the body's mesh frame to the world."""
        i = self._check_body(body)
        b = self.bodies
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(b.orientation[i])
        T[:3, 3] = b.position[i] - T[:3, :3] @ b.center_of_mass_local[i]
        return T

    def kinetic_energy(self) -> float:
        """Total kinetic energy sum(P^2 / 2M + L.w / 2) of the dynamic bodies (J)."""
        b = self.bodies
        linear = 0.5 * np.einsum("ij,ij,i->", b.linear_momentum, b.linear_momentum, b.inverse_mass)
        L_body = quat_rotate(quat_conjugate(b.orientation), b.angular_momentum).reshape(-1, 3)
        angular = 0.5 * np.einsum("ij,ijk,ik->", L_body, b.inverse_inertia_body, L_body)
        return float(linear + angular)

    def potential_energy(self) -> float:
        """Gravitational potential energy -sum(M g . x) of the dynamic bodies (J)."""
        b = self.bodies
        dynamic = ~b.static
        return float(-np.sum(b.mass[dynamic] * (b.position[dynamic] @ self.gravity)))


def _always() -> bool:
    return True
