"""The world: bodies, the force model, and a step that reads as its list of stages.

A step runs only the stages the scene calls for (``World.stages``), each timed into
``World.profile``, and the stages hand each other one explicit value (``StepState``):

    forces -> contacts -> integrate -> kinematic -> joints -> bounds -> broad_phase
           -> narrow_phase -> tunnelling -> time_of_impact -> impacts -> sleep

``contacts`` resolves the contacts found at the end of the previous step (where the bodies are
now) before anything moves, so resting bodies never sink under gravity; ``integrate`` moves the
bodies it acted on with their new velocities and every other free body by the chosen ODE
method; ``kinematic`` moves the kinematic bodies by the velocities set on them; ``joints``
moves the jointed bodies by symplectic Euler and holds their joints;
detection then finds the contacts of the new positions, which are the next step's;
``time_of_impact`` steps bodies that flew into something back to the moment they touched, and
``impacts`` resolves those collisions and carries the bodies to the end of the step.

The order of the stages, the guard that skips each when it has nothing to do and the save at
the start of a step are written once, in the step kernel (``step_kernel.run_steps``): it runs
step after step in one call and stops at a stage whose work is Python's (an applied force to
gather, a sweep-and-prune update, mesh pairs, the tunnelling sweep, a time of impact, the
impacts, the sleep stage). The world runs that stage (``_STAGES_IN_PYTHON``) and calls the
kernel again from the next one. A scene pays only for the stages it calls for: no gravity or
applied force, no forces stage; no dynamic body, nothing at all; fewer than two bodies, no
collision stages; no contact response wanted (a detection-only scene), no contact stages; no
kinematic body, no kinematic stage; and what a scene lacks is compiled out of the kernel.

A step whose state turns non-finite (a huge force, a diverging solve) raises
``NonFiniteStateError`` naming the body, the stage and the step, and leaves the world as it
was before that step: the kernel saves the body state at the start of every step, and the
step state is a value, so the one the step began with is put back.
"""

from __future__ import annotations

import dataclasses
from time import perf_counter
from typing import NoReturn

import numpy as np

from thesis_rbd._validate import as_finite_array, as_positive_scalar
from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.pipeline import CollisionPipeline, some_pair_may_collide
from thesis_rbd.dynamics.bodies import BodyArrays
from thesis_rbd.dynamics.body_builder import body_fields, body_shape
from thesis_rbd.dynamics.contact_settings import SLOP_FRACTION, ContactSettings
from thesis_rbd.dynamics.contact_stats import BAD_BODY, ISLANDS, STATS
from thesis_rbd.dynamics.forces import (
    AppliedForces,
    DragCoefficients,
    PointForces,
    world_arm_to_body,
)
from thesis_rbd.dynamics.impacts import find_hits, resolve_impacts
from thesis_rbd.dynamics.integrators import INTEGRATORS
from thesis_rbd.dynamics.joint_set import JointSet
from thesis_rbd.dynamics.joint_solver import MOST_SUBSTEPS
from thesis_rbd.dynamics.kinematic import moving_bodies
from thesis_rbd.dynamics.pgs import friction_polygon
from thesis_rbd.dynamics.sleep import SleepSettings, SleepState
from thesis_rbd.world.joint_api import WorldJoints
from thesis_rbd.world.readout import WorldReadout
from thesis_rbd.world.stage_names import STAGE_NAMES
from thesis_rbd.world.stage_profile import StageProfile
from thesis_rbd.world.state_api import WorldStateSetters
from thesis_rbd.world.step_kernel import (
    BOUNDS,
    BROAD_PHASE,
    CONTACTS,
    FINISHED,
    FORCES,
    IMPACTS,
    KINEMATIC,
    NARROW_PHASE,
    SLEEP,
    TIME_OF_IMPACT,
    TUNNELLING,
    run_steps,
)
from thesis_rbd.world.step_state import StepState
from thesis_rbd.world.time_of_impact import (
    beyond_slop,
    new_or_deeper,
    passed_through,
    step_back_to_impact,
)

__all__ = ["STAGE_NAMES", "NonFiniteStateError", "World"]

# The time step a world takes unless told otherwise (s): Bullet's and MuJoCo's users' usual 240 Hz.
DEFAULT_DT = 1.0 / 240.0
# The longest time step a world takes (s): the step squares it (a fall under gravity over one
# step), and no body's motion is resolved by steps of days.
MAX_DT = 1e4


# The largest force component ``apply_force`` takes (N): the kernels square forces and the
# momenta they give, and 1e150 squared stays finite with room for sums.
MOST_FORCE = 1e150

# How jointed bodies may be stepped (``World``'s ``joint_coordinates``).
JOINT_COORDINATES = ("auto", "maximal")

# Rounds of collisions the impact stage resolves in one step: a body carried on after its
# collision may run into another within the step, and that one into a third.
IMPACT_ROUNDS = 8


def _checked_substeps(value) -> int | str:
    """``joint_substeps`` as given: "auto" or an integer in [1, MOST_SUBSTEPS]."""
    if isinstance(value, str) and value == "auto":
        return value
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f'joint_substeps must be "auto" or an integer >= 1, got {value!r}')
    if not 1 <= value <= MOST_SUBSTEPS:
        raise ValueError(f"joint_substeps must be between 1 and {MOST_SUBSTEPS}, got {value}")
    return int(value)


class NonFiniteStateError(FloatingPointError):
    """A step made a body's state non-finite; the world is left as it was before the step.

    Attributes
    ----------
    body : int
        Index of the first body whose state went bad.
    name : str
        Its name.
    stage : str
        The stage that produced it.
    step : int
        Index of the step (0 for the world's first).
    """

    def __init__(self, body: int, name: str, stage: str, step: int):
        self.body, self.name, self.stage, self.step = body, name, stage, step
        super().__init__(
            f"body {body} ({name!r}) got a non-finite state in stage {stage!r} of step {step}; "
            "the world is left as it was before that step"
        )


class _StepFailed(Exception):
    """Raised inside a step by the stage that found a bad body; turned into the public error."""

    def __init__(self, body: int):
        self.body = body


@dataclasses.dataclass
class _StepStart:
    """What a failed step puts back besides the body state the kernel saved: the step state
    it began with, the applied forces before the forces stage ran their durations down, and
    the sleep bookkeeping before a narrow phase woke an island (None: nothing changed)."""

    state: StepState
    applied_forces: AppliedForces
    sleep: tuple | None = None


class World(WorldReadout, WorldJoints, WorldStateSetters):
    """A rigid-body world stepped at a fixed time step.

    Parameters
    ----------
    dt : float
        Time step (s), > 0 and at most MAX_DT (1e4 s).
    gravity : (3,) array_like
        Gravitational acceleration (m/s^2); (0, 0, 0) by default (no effect is on by default).
    integrator : {"verlet", "euler", "symplectic_euler", "midpoint", "rk4"}
        ODE method for bodies that no contact acts on (``dynamics.integrators``). "verlet"
        keeps a torque-free body's kinetic energy and angular momentum at any spin; the
        thesis's explicit methods let a body tumbling off a principal axis gain energy.
    linear_drag, quadratic_drag, angular_drag : float
        Air resistance on every dynamic body: F = -k1 v - k2 |v| v, tau = -ka w.
    contact_response : bool
        False makes a detection-only world: contacts are found (``World.contacts``) but
        bodies pass through each other.
    contact_solver : {"auto", "pgs", "exact"}
        Projected Gauss-Seidel with the exact (Lemke) solve for small islands it does not
        converge on ("auto"), PGS alone, or Lemke for every island.
    contact_iterations : int
        Largest number of PGS sweeps per island and step (they stop early once converged;
        a tall stack needs a few hundred when it starts unwarmed).
    friction_sides : int
        Sides of the polygonal friction cone.
    contact_tolerance : float
        PGS sweeps stop once every contact's velocity is right to this fraction of its slop
        per step, or of its island's fastest contact-point speed; in (0, 1).
    penetration : {"toi", "bias"}
        Step bodies that flew into something back to their time of impact, or leave them
        where they ended and push them out through the contact velocities.
    sleeping : bool
        Let islands at rest fall asleep (frozen, free of cost) until touched or pushed.
    narrow_phase : {"auto", "mesh"}
        "auto": pairs of convex bodies collide as convex polyhedra (separating axes, GJK and
        EPA), the others through the OBBTree; "mesh": the OBBTree for every pair.
    joint_substeps : int or "auto"
        Equal parts each step of the jointed bodies is taken in (``dynamics.joint_solver``):
        light links carrying a heavy load need more than one. "auto" chooses for each island
        and step from the tension its lightest, shortest links carried over the last step.
    joint_coordinates : {"auto", "maximal"}
        "auto": a tree of hinges, sliders and welds hanging from the ground is stepped in
        its joint coordinates (``dynamics.articulated``, the articulated-body algorithm) on
        every step where only forces, set torques and joint damping act on it, and held in
        maximal coordinates (``dynamics.joint_solver``) on the others; "maximal": every
        jointed body always in maximal coordinates.
    """

    def __init__(
        self,
        dt: float = DEFAULT_DT,
        gravity=(0.0, 0.0, 0.0),
        integrator: str = "verlet",
        linear_drag: float = 0.0,
        quadratic_drag: float = 0.0,
        angular_drag: float = 0.0,
        contact_response: bool = True,
        contact_solver: str = ContactSettings.solver,
        contact_iterations: int = ContactSettings.iterations,
        friction_sides: int = ContactSettings.friction_sides,
        contact_tolerance: float = ContactSettings.tolerance,
        penetration: str = ContactSettings.penetration,
        sleeping: bool = True,
        narrow_phase: str = "auto",
        joint_substeps: int | str = "auto",
        joint_coordinates: str = "auto",
    ):
        self.dt = as_positive_scalar(dt, "dt")
        if self.dt > MAX_DT:
            raise ValueError(f"dt must be at most {MAX_DT:g} s, got {self.dt!r}")
        self.gravity = as_finite_array(gravity, "gravity", shape=(3,))
        if integrator not in INTEGRATORS:
            raise ValueError(
                f"unknown integrator {integrator!r}; choose one of {sorted(INTEGRATORS)}"
            )
        self.integrator = integrator
        self.joint_substeps = _checked_substeps(joint_substeps)
        if joint_coordinates not in JOINT_COORDINATES:
            raise ValueError(
                f"unknown joint_coordinates {joint_coordinates!r}; choose one of "
                f"{list(JOINT_COORDINATES)}"
            )
        self.joint_coordinates = joint_coordinates
        self.drag = DragCoefficients(linear_drag, quadratic_drag, angular_drag)
        self._drag_array = np.array([linear_drag, quadratic_drag, angular_drag], dtype=np.float64)
        self.time = 0.0
        self.steps_taken = 0
        self.bodies = BodyArrays()
        self.applied_forces = AppliedForces()
        self._profile = StageProfile()
        self.contact_response = bool(contact_response)
        self._contact_settings = ContactSettings(
            solver=contact_solver,
            iterations=contact_iterations,
            friction_sides=friction_sides,
            penetration=penetration,
            tolerance=contact_tolerance,
        )
        self._collision = CollisionPipeline(narrow_phase)
        self.narrow_phase = narrow_phase
        self._sleep = SleepState(SleepSettings(enabled=bool(sleeping)))
        self._joints = JointSet()
        self._excluded = np.zeros((0, 2), np.int64)
        self._joint_impulse = np.zeros((0, 7))
        self._state = StepState.initial(0, len(STATS))
        self._plan_stages()

    # ------------------------------------------------------------------ building the scene
    def add_body(
        self,
        mesh=None,
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
        collision_group: int = 1,
        collision_mask: int = 0xFFFF,
        kinematic: bool = False,
        center_of_mass=None,
        inertia=None,
        shapes=None,
        visual=None,
    ) -> int:
        """Add a body and return its index.

        Parameters
        ----------
        mesh : TriangleMesh, optional
            Shape in its own (mesh) frame; closed for a dynamic body unless its mass
            properties are given. Give it or ``shapes``.
        mass, density : float, optional
            Give at most one; neither means density 1.0. Ignored for static bodies; a
            kinematic body takes neither. With ``center_of_mass`` and ``inertia``, the mass.
        position : (3,) array_like
            World position of the centre of mass (of the mesh frame origin for a static
            body whose mesh is open).
        orientation : (4,) array_like
            (x, y, z, w) rotation of the mesh frame into the world; normalised.
        linear_velocity, angular_velocity : (3,) array_like
            Initial v and w, world frame (w about the centre of mass); a kinematic body keeps
            them until ``set_kinematic`` changes them, a static body ignores them.
        restitution : float in [0, 1]
            Combined per contact as the product of the two bodies' values.
        friction : float >= 0
            Combined per contact as the geometric mean of the two bodies' values.
        static : bool
            An immovable body (zero inverse mass and inertia).
        name : str, optional
            Label used in trajectories and errors; "body<i>" by default.
        collidable : bool
            False keeps the body out of collision detection (free flight only); with fewer
            than two collidable bodies the world runs no collision stage at all.
        collision_group, collision_mask : int
            Bit fields: two bodies collide only if each one's group shares a bit with the
            other's mask (Bullet's rule); by default every body is in group 1 and collides
            with groups 1-16.
        kinematic : bool
            A body moved by the user (not static as well): infinitely heavy to contacts and
            joints, which push against it and never move it; untouched by gravity and forces;
            it moves by its velocity and angular velocity each step (constant v, constant w
            about its centre of mass), and the bodies it touches or is jointed to see that
            motion. Two kinematic bodies, or a kinematic and a static one, never collide.
            ``set_kinematic`` moves it or changes its velocity between steps.
        center_of_mass : (3,) array_like, optional
            Explicit centre of mass in the mesh frame, given with ``mass`` and ``inertia``
            (a dynamic body only): the body takes these instead of its mesh's, which is then
            collision geometry only and may be open or in pieces.
        inertia : (3, 3) array_like, optional
            Explicit inertia tensor about ``center_of_mass``, axes parallel to the mesh
            frame: symmetric (to round-off), positive definite, its principal moments within
            the triangle inequality (to a millionth of the largest).
        shapes : sequence of (TriangleMesh, (4, 4) array_like), optional
            A compound body instead of ``mesh``: each part's mesh placed in the body's mesh
            frame by its rigid transform. Without explicit mass properties every part must be
            closed, and the body is their union (overlaps counted twice) at the density or
            scaled to the mass. A compound of several parts collides through the OBBTree of
            the parts merged into one mesh, never as one convex hull.
        visual : sequence of (TriangleMesh, (4, 4) array_like), optional
            What the viewer and the playback pages draw instead of the collision shape
            (a URDF link's ``<visual>``): meshes placed in the body's mesh frame as
            ``shapes`` are, open or closed; no part of the physics.
        """
        mesh, parts = body_shape(mesh, shapes)
        drawn = None if visual is None else body_shape(None, visual)[0]
        fields = body_fields(
            mesh, mass, density, position, orientation, linear_velocity, angular_velocity,
            restitution, friction, static, collidable, collision_group, collision_mask, kinematic,
            parts, center_of_mass, inertia,
        )  # fmt: skip
        index = self.bodies.append(
            mesh, name if name is not None else f"body{self.bodies.count}", drawn, **fields
        )
        self._collision.add_body(mesh, fields["center_of_mass_local"], convex=len(parts) == 1)
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
        if self.bodies.kinematic[body]:
            raise ValueError(
                f"body {body} is kinematic: no force moves it; give it a velocity with "
                "set_kinematic"
            )
        force = as_finite_array(force, "force", shape=(3,))
        if np.abs(force).max() > MOST_FORCE:
            raise ValueError(
                f"force {force.tolist()} exceeds {MOST_FORCE:g} N in a component: the kernels "
                "square forces and the momenta they give, which would overflow"
            )
        if point is None:
            arm = np.zeros(3)
        else:
            point = as_finite_array(point, "point", shape=(3,))
            b = self.bodies
            arm = world_arm_to_body(point, b.position[body], b.orientation[body])
        remaining = np.inf if duration is None else as_positive_scalar(duration, "duration")
        self.applied_forces.add(body, force, arm, remaining)
        self._sleep.wake(np.array([body]))
        self._plan_stages()

    @property
    def contact_settings(self) -> ContactSettings:
        """How contacts are resolved; assign a new ``ContactSettings`` to change it."""
        return self._contact_settings

    @contact_settings.setter
    def contact_settings(self, settings: ContactSettings) -> None:
        if not isinstance(settings, ContactSettings):
            raise ValueError(f"contact_settings must be ContactSettings, got {settings!r}")
        self._contact_settings = settings
        self._plan_stages()

    # ------------------------------------------------------------------ planning
    @property
    def stages(self) -> list[str]:
        """Names of the stages this scene needs, in pipeline order."""
        return [name for name, planned in zip(STAGE_NAMES, self._planned, strict=True) if planned]

    @property
    def profile(self) -> dict[str, dict]:
        """Calls and seconds of each stage so far, ``{stage: {"calls": int, "seconds":
        float}}`` in pipeline order (a new dict on each read)."""
        return self._profile.as_dict()

    def _plan_stages(self) -> None:
        """Derive the stages from the scene (only the effects it calls for) and what the step
        kernel takes of the world; called whenever bodies, forces or settings change."""
        b = self.bodies
        n = b.count
        dynamic = bool(n) and not bool(np.all(b.static))
        gathers_forces = dynamic and (bool(np.any(self.gravity)) or len(self.applied_forces) > 0)
        excluded = np.concatenate([self._excluded, self._joints.excluded_pairs()])
        collides = dynamic and some_pair_may_collide(b, excluded)
        responds = collides and self.contact_response
        toi = responds and self.contact_settings.penetration == "toi"
        # bodies come to rest through contact: without collisions nothing would sleep
        sleeps = collides and self._sleep.settings.enabled
        jointed = dynamic and len(self._joints) > 0
        planned = {
            "forces": gathers_forces, "contacts": responds, "integrate": dynamic,
            "kinematic": bool(np.any(b.kinematic)), "joints": jointed,
            "bounds": collides, "broad_phase": collides, "narrow_phase": collides,
            "tunnelling": collides, "time_of_impact": toi, "impacts": toi, "sleep": sleeps,
        }  # fmt: skip
        self._planned = np.array([planned[name] for name in STAGE_NAMES])
        self._contacts_stale = responds
        self._replan_after_step = False
        # speculative contacts across the gap gravity closes in a step, twice over (a body
        # that lost its support for a step falls g dt^2 and gains g dt): a 2 mm cube's is
        # 8 % of its edge, far beyond the margin relative to its size
        reach = 2.0 * float(np.linalg.norm(self.gravity)) * self.dt**2
        self._collision.plan(b, reach, excluded)
        # M g is constant between scene changes: computed here, not every step
        self._gravity_force = np.where(b.static, 0.0, b.mass)[:, None] * self.gravity
        fast = np.zeros(n, bool)
        self._state = dataclasses.replace(
            self._state, external_force=self._gravity_force,
            point_forces=PointForces.empty(n), solved=np.zeros(n, bool),
            reach_back=np.full(n, self.dt), start_position=b.position.copy(),
            start_orientation=b.orientation.copy(), fast=fast, rewind=np.zeros(n), refit_all=True,
            **self._sleep_fields(),
        )  # fmt: skip
        # the step kernel's arguments that change only with the plan
        full = b.full
        settings = self.contact_settings
        self._kernel_bodies = (
            *(full(f) for f in ("position", "orientation", "linear_momentum", "angular_momentum")),
            *(full(f) for f in (
                "inverse_mass", "inverse_inertia_body", "inertia_body", "thickness",
                "restitution", "friction", "kinematic_velocity", "kinematic_angular_velocity",
            )),
        )  # fmt: skip
        self._saved = b.saved_state()
        # the contact stage solves an island's contacts with its joints held
        contact_joints = (self._joints.ints, self._joints.floats) if jointed else None
        self._contact_group = (
            (settings.as_array(self.dt), friction_polygon(settings.friction_sides),
             self._state.contact_stats, contact_joints)
            if responds else None
        )  # fmt: skip
        self._joint_group = self._joint_arguments() if jointed else None
        # the kinematic stage's velocities: None compiles the stage out of a scene without
        # kinematic bodies
        self._kinematic_group = (
            (full("kinematic_velocity"), full("kinematic_angular_velocity"))
            if planned["kinematic"] else None
        )  # fmt: skip
        detector = self._collision
        self._detection_group = detector.detection_arguments(self.dt, fast) if collides else None
        self._convex_group = detector.convex_arguments() if collides else None
        self._method = INTEGRATORS[self.integrator]
        self._stage_cycles = np.zeros(len(STAGE_NAMES), np.int64)
        self._stage_calls = np.zeros(len(STAGE_NAMES), np.int64)

    def _joint_arguments(self) -> tuple:
        """What the step kernel's joint stages take (``run_steps``'s ``joint_group``)."""
        joints, b = self._joints, self.bodies
        *islands, fixed_base, parents, sides = joints.islands(b.static)
        if self.joint_coordinates == "maximal":
            fixed_base = np.zeros_like(fixed_base)
        self._joint_impulse = np.zeros((len(joints), 7))
        rows = len(b.full("inverse_mass"))
        jointed = np.zeros(rows, bool)
        jointed[: b.count] = joints.jointed(b.count)
        return (
            0 if self.joint_substeps == "auto" else self.joint_substeps, joints.ints,
            joints.floats, *islands, fixed_base, parents, sides, jointed, np.zeros(rows, bool),
            np.zeros((rows, 3)), np.zeros((rows, 4)), self._joint_impulse,
        )  # fmt: skip

    def _moving_kinematic(self) -> np.ndarray:
        """(n,) bool: the kinematic bodies with a velocity (``kinematic.moving_bodies``)."""
        b = self.bodies
        return moving_bodies(
            b.count, b.full("kinematic_velocity"), b.full("kinematic_angular_velocity")
        )

    def _sleep_fields(self) -> dict:
        """The step state's fields that follow who sleeps and which kinematic bodies move:
        ``frozen`` (n,) bool marks the immovable bodies (static, kinematic or asleep),
        ``stationary`` (n,) bool those that do not move this step (frozen, less the kinematic
        bodies with a velocity), ``awake`` whether any body moves, ``any_asleep`` whether any
        sleeps."""
        b = self.bodies
        frozen = b.static | self._sleep.asleep
        stationary = frozen
        if self._planned[KINEMATIC]:
            stationary = frozen & ~self._moving_kinematic()
        return dict(
            frozen=frozen, stationary=stationary, awake=not bool(np.all(stationary)),
            any_asleep=self._sleep.any_asleep,
        )  # fmt: skip

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> None:
        """Advance the world by ``n`` steps of ``dt``.

        Raises
        ------
        NonFiniteStateError
            If a body's state turns non-finite; the world is then as it was before the step
            that failed.
        """
        if int(n) != n or n < 0:
            raise ValueError(f"n must be a non-negative integer, got {n!r}")
        remaining = int(n)
        while remaining > 0:
            if self._contacts_stale:
                self._detect_contacts()
            remaining -= self._run(remaining, FORCES)

    def _run(self, steps: int, first: int, detect_only: bool = False) -> int:
        """Run up to ``steps`` steps from stage ``first`` of the current one: the kernel runs
        the stages, and each stage it stops at runs here, until it finishes, or until the end
        of a step after which the scene must be planned again. Returns the steps done."""
        done = 0
        while True:
            batch = 1 if self._replan_after_step else steps - done
            ran, stop = self._run_kernel(batch, first, detect_only)
            done += ran
            if stop == FINISHED:
                if self._replan_after_step:
                    self._plan_stages()
                return done
            self._run_python_stage(stop)
            first = stop + 1

    def _detect_contacts(self) -> None:
        """Find the contacts where the bodies are now, for the first step after the scene
        changed: the contact stage acts on contacts found at the end of the previous step."""
        self._contacts_stale = False
        self._step_start = _StepStart(dataclasses.replace(self._state), self.applied_forces)
        self._run(1, BOUNDS, detect_only=True)

    def _run_kernel(self, steps: int, first: int, detect_only: bool) -> tuple[int, int]:
        """One ``run_steps`` call from the current step state; takes what it returns.
        Returns the steps done and the stage it stopped at (``FINISHED``: none)."""
        s = self._state
        c, acted, pf = s.contacts, s.acted, s.point_forces
        cycles, calls = self._stage_cycles, self._stage_calls
        handed_in = (
            (c.ints, c.floats, c.count), (acted.ints, acted.floats, acted.count, s.impulses),
            (s.warm_keys, s.warm_values), s.convex_cache,
        )  # fmt: skip
        started = perf_counter()
        (
            done, self.time, stop, bad, contacts, acted, warm, cache, at_start,
            candidate_count, fast_count, slowest, fat_changed, refit_all, rewound,
        ) = run_steps(
            steps, first, detect_only, self.time, self.dt, self.bodies.count, self._method,
            self._planned, len(self.applied_forces) > 0, s.frozen, s.awake, s.any_asleep,
            self._sleep.still_any, self._sleep.settings.linear_tolerance**2,
            *self._kernel_bodies, s.external_force, self._drag_array,
            pf.start, pf.arm, pf.force, *self._saved, s.start_position, s.start_orientation,
            s.solved, s.reach_back, self._contact_group, self._joint_group,
            self._kinematic_group, self._detection_group, self._convex_group,
            *handed_in,
            s.candidate_count, s.fast_count, s.slowest, s.fat_changed, s.refit_all, s.rewound,
            cycles, calls,
        )  # fmt: skip
        self._profile.add_kernel_call(perf_counter() - started, cycles, calls)
        self.steps_taken += done
        # the kernel's hand-overs into the state in place: a dataclasses.replace per call
        # would cost a one-body scene's step a third more (the value a failed step puts back
        # is a copy, made below when a step stops mid-way)
        if calls[CONTACTS]:
            s.impact_count = 0
        s.contacts, s.acted, s.impulses = ContactSet(*contacts), ContactSet(*acted[:3]), acted[3]
        s.warm_keys, s.warm_values, s.convex_cache = warm[0], warm[1], cache
        s.candidate_count, s.fast_count, s.slowest = candidate_count, fast_count, slowest
        s.fat_changed, s.refit_all, s.rewound = fat_changed, refit_all, rewound
        if stop != FINISHED and (done > 0 or first == FORCES):
            # a step began in this call and stopped: what a failure in it must put back (the
            # kernel hands back the hand-overs at its start when it began after the first)
            start_contacts, start_acted, start_warm, start_cache = (
                at_start if at_start is not None else handed_in
            )
            self._step_start = _StepStart(
                dataclasses.replace(
                    s, contacts=ContactSet(*start_contacts),
                    acted=ContactSet(*start_acted[:3]), impulses=start_acted[3],
                    warm_keys=start_warm[0], warm_values=start_warm[1],
                    convex_cache=start_cache,
                ),
                self.applied_forces,
            )  # fmt: skip
        if bad >= 0:
            self._fail(int(bad), STAGE_NAMES[stop])
        return done, stop

    def _run_python_stage(self, stage: int) -> None:
        """Run the stage the kernel stopped at, timed into the profile."""
        name = STAGE_NAMES[stage]
        started = perf_counter()
        try:
            self._state = _STAGES_IN_PYTHON[stage](self, self._state)
        except _StepFailed as failure:
            self._fail(failure.body, name)
        self._profile.add_stage(stage, perf_counter() - started)

    def _fail(self, body: int, stage: str) -> NoReturn:
        """Put the world back as it was before this step and raise the error naming the
        body that went non-finite, the stage and the step."""
        start = self._step_start
        self.bodies.restore_state()
        self.applied_forces = start.applied_forces
        if start.sleep is not None:
            self._sleep.restore(start.sleep)
        self._state = start.state
        self._plan_stages()  # fat boxes refitted around the restored positions
        raise NonFiniteStateError(body, self.bodies.names[body], stage, self.steps_taken) from None

    # ------------------------------------------------------------------ stages in Python
    def _gather_forces(self, s: StepState) -> StepState:
        """Gravity and the applied forces active this step."""
        applied = self.applied_forces
        self._step_start.applied_forces = dataclasses.replace(applied)
        external_force, point_forces = applied.gather(
            self.dt, self._gravity_force, self.bodies.static
        )
        if len(applied) == 0:
            self._replan_after_step = True  # the last applied force ran out
        return dataclasses.replace(s, external_force=external_force, point_forces=point_forces)

    def _update_broad_phase(self, s: StepState) -> StepState:
        """Sweep-and-prune on the refitted fat boxes, then the candidate pairs: those with a
        moving body whose tight boxes overlap."""
        b = self.bodies
        count = self._collision.broad_phase(
            True, b.full("position"), b.full("orientation"), s.start_position, s.fast,
            s.stationary,
        )  # fmt: skip
        self._detection_group = self._collision.detection_arguments(self.dt, s.fast)
        contacts = s.contacts if count else ContactSet.empty()
        return dataclasses.replace(s, candidate_count=count, fat_changed=False, contacts=contacts)

    def _find_contacts(self, s: StepState) -> StepState:
        """Contacts of the candidate pairs (convex pairs by the convex kernel, the others by
        the OBBTree); a touched sleeping island wakes, and its own contacts are found too."""
        b, detector = self.bodies, self._collision
        position, orientation = b.full("position"), b.full("orientation")
        contacts, cache = detector.contacts(
            detector.candidates(s.candidate_count), position, orientation, s.convex_cache
        )
        sleep_before = self._sleep.snapshot() if s.any_asleep else None
        if s.any_asleep and self._sleep.wake_touched(contacts, ~s.stationary):
            self._step_start.sleep = sleep_before
            s = dataclasses.replace(s, **self._sleep_fields())
            # the woken islands' own contacts were not candidates: find them now
            count = detector.broad_phase(
                False, position, orientation, s.start_position, s.fast, s.stationary
            )
            s = dataclasses.replace(s, candidate_count=count)
            contacts, cache = detector.contacts(
                detector.candidates(count), position, orientation, cache
            )
        return dataclasses.replace(s, contacts=contacts, convex_cache=cache)

    def _catch_tunnelling(self, s: StepState) -> StepState:
        """Sampling along the step for fast bodies only: put back what passed through."""
        b = self.bodies
        contacts, caught, fraction, position, orientation = self._collision.sweep(
            self._collision.candidates(s.candidate_count), s.contacts, s.fast,
            b.full("position"), b.full("orientation"), s.start_position, s.start_orientation,
            s.convex_cache,
        )  # fmt: skip
        b.position[caught], b.orientation[caught] = position, orientation
        # a caught body lost the rest of its step: its path goes back to the start only
        s.reach_back[caught] = fraction * self.dt
        return dataclasses.replace(s, contacts=contacts)

    def _step_back_to_impact(self, s: StepState) -> StepState:
        """Bodies that ran into something during the step go back to when they touched."""
        n = self.bodies.count
        return self._step_back(
            s, s.contacts, s.acted, s.solved[:n], s.reach_back[:n].copy(), first=True
        )

    def _step_back(
        self, s, contacts, before, solved, reach_back, first=False, since=None
    ) -> StepState:
        """Find the ``contacts`` (a ``ContactSet``) a moving body ran into since ``before``
        (the contacts of the start of the step, or of a collision in it) and step each group
        of such bodies back to its time of impact, no further than ``reach_back`` (n,) s.

        ``solved`` (n,) bool: bodies whose velocities hold the forces of the rest of their
        step. A hit is a contact that penetrates and approaches, of a pair that did not touch
        before, or of a convex pair gone deeper than before by more than its slop (a
        spinning cube's corner driven into the one it rests on). On the ``first`` search of
        the step, any contact of a body that flew freely is a hit, and a receding one is too
        where its pair was apart at the start of the step (a body flown through a thin one).
        A body the contact stage moved by less than its slop since the pose ``since``
        ((position, orientation); None: the start of the step) is an obstacle, as a static
        one is.
        """
        b, detector, c = self.bodies, self._collision, contacts
        n = b.count
        # every moving body: one the contact stage moved can run into something too
        movers = ~s.frozen[:n]
        state, masses = self._kernel_bodies[:4], self._kernel_bodies[4:6]
        hits, receding, v, _ = find_hits(
            n, s.frozen, movers, solved, c.ints, c.floats, c.count, *state, *masses,
            b.full("kinematic_velocity"), b.full("kinematic_angular_velocity"),
            b.full("thickness"), SLOP_FRACTION,
        )  # fmt: skip
        a_, b_ = c["body_a"], c["body_b"]
        apart, deeper, allowed = new_or_deeper(
            c, before, hits, s.frozen, b.full("thickness"), detector.hull_of_body
        )
        qualifies = apart | deeper
        flew = movers & ~solved
        if first:
            qualifies |= flew[a_] | flew[b_]
            deeper &= ~(flew[a_] | flew[b_])
        if first and receding.any():
            hits |= passed_through(
                detector, c, receding, s.start_position, s.start_orientation, s.convex_cache
            )
        # a body the contact stage moved by less than its slop is an obstacle: it goes back
        # with no group (a falling cube landing on a pile steps back alone, not with the pile
        # it touches)
        if since is None:
            since = (s.start_position[:n], s.start_orientation[:n])
        travelled = flew | (movers & beyond_slop(b, *since))
        hits &= qualifies & (travelled[a_] | travelled[b_])
        if not hits.any():
            return dataclasses.replace(s, contacts=c)
        # a body whose velocity holds its forces already moves on at that velocity
        acceleration = np.where(solved[:, None], 0.0, s.external_force * b.inverse_mass[:, None])
        unrewound = (b.position.copy(), b.orientation.copy())
        rewind, c = step_back_to_impact(
            detector, b, c, hits, np.where(deeper, allowed, -np.inf), travelled,
            self._joints.moving_links(movers), v, acceleration, reach_back, s.convex_cache,
        )  # fmt: skip
        rewound = rewind > 0
        # the stepped-back bodies carry the velocity of their time of impact
        b.linear_momentum[rewound] = v[rewound] / b.inverse_mass[rewound, None]
        return dataclasses.replace(
            s, rewind=rewind, rewound=bool(rewound.any()), unrewound=unrewound, contacts=c
        )

    def _resolve_impacts(self, s: StepState) -> StepState:
        """Collisions at their time of impact, then the rest of the step for those bodies.

        A body carried on after its collision can run into a body it had no contact with
        within what is left of the step (the plates of a stack landing one on another in one
        step): it is stepped back again, no further than its collision, and resolved, for up
        to ``IMPACT_ROUNDS`` rounds."""
        b = self.bodies
        n = b.count
        # a body the tunnelling sweep caught keeps the shorter path it has
        solved, reach_back = s.solved[:n].copy(), s.reach_back[:n].copy()
        islands = 0
        for _ in range(IMPACT_ROUNDS):
            s, pushed, rewind = self._collide(s, solved)
            carried = rewind > 0
            reach_back[carried] = np.minimum(reach_back[carried], rewind[carried])
            islands += s.impact_count
            solved |= pushed
            s = self._step_back_again(s, carried & beyond_slop(b, *s.unrewound), solved, reach_back)
            if not s.rewound:
                break
        return dataclasses.replace(s, rewind=np.zeros(n), rewound=False, impact_count=islands)

    def _collide(self, s: StepState, solved: np.ndarray) -> tuple:
        """One round of ``_resolve_impacts``: the islands of the stepped-back bodies resolved
        and carried to the end of the step. Returns the state, the bodies the resting solve
        pushed (n,) bool, and how long before the end of the step each body carried on
        collided (n,) s (0: not carried)."""
        b, c, pf = self.bodies, s.contacts, s.point_forces
        impulses = np.zeros((c.count, 3))
        settings, polygon, _, joints = self._contact_group
        rewind = s.rewind.copy()
        stats, resolved, pushed = resolve_impacts(
            settings, polygon, b.count, s.frozen, solved, rewind, c.ints, c.floats, c.count,
            *self._kernel_bodies, s.external_force, self._drag_array, pf.start, pf.arm,
            pf.force, impulses, joints,
        )  # fmt: skip
        if stats[BAD_BODY] >= 0:
            raise _StepFailed(int(stats[BAD_BODY]))
        s = dataclasses.replace(
            s, rewind=np.zeros(b.count), rewound=False,
            acted=ContactSet.concatenate([s.acted, c.select(resolved)]),
            impulses=np.concatenate([s.impulses, impulses[resolved]]),
            impact_count=int(stats[ISLANDS]),
        )  # fmt: skip
        return s, pushed, rewind

    def _step_back_again(self, s, carried, solved, reach_back) -> StepState:
        """The contacts of the ``carried`` (n,) bool bodies found where the impacts left them;
        a body that ran into one it did not touch at its collision goes back to that moment."""
        detector, c = self._collision, s.contacts
        pairs = detector.candidates(s.candidate_count)
        moved = carried[pairs[:, 0]] | carried[pairs[:, 1]]
        if not moved.any():
            return s
        fresh, _ = detector.contacts(
            pairs[moved], self.bodies.full("position"), self.bodies.full("orientation"),
            s.convex_cache,
        )  # fmt: skip
        kept = ~(carried[c["body_a"]] | carried[c["body_b"]])
        contacts = ContactSet.concatenate([c.select(kept), fresh])
        return self._step_back(s, contacts, c, solved, reach_back, since=s.unrewound)

    def _fall_asleep(self, s: StepState) -> StepState:
        """Islands still for long enough fall asleep with zero velocity."""
        b = self.bodies
        fell = self._sleep.update(
            b, s.contacts, self.dt, self._joints.ints[:, 1:3], s.frozen & ~s.stationary
        )
        if not len(fell):
            return s
        b.linear_momentum[fell] = 0.0
        b.angular_momentum[fell] = 0.0
        s = dataclasses.replace(s, **self._sleep_fields())
        # contacts between sleeping (or static) bodies need no solving
        c = s.contacts
        active = ~(s.frozen[c["body_a"]] & s.frozen[c["body_b"]])
        return dataclasses.replace(s, contacts=c.select(active))

    # ------------------------------------------------------------------ read-outs
    @property
    def contact_info(self) -> dict:
        """What the last contact stage did: ``islands``, PGS ``sweeps`` (in all) and
        ``max_sweeps`` (of one island), ``exact_islands`` solved by Lemke's method,
        ``unconverged`` islands (PGS at its sweep limit, or an exact solve that fell back),
        and ``impacts``, islands resolved at their time of impact in the last step."""
        stats = self._state.contact_stats[:BAD_BODY].tolist()
        info = dict(zip(STATS[:BAD_BODY], stats, strict=True))
        info["impacts"] = self._state.impact_count
        return info

    @property
    def sleeping(self) -> np.ndarray:
        """(n,) bool copy: which bodies are asleep."""
        return self._sleep.asleep.copy()

    @property
    def contacts(self) -> dict[str, np.ndarray]:
        """Contacts of the last step, world frame.

        Keys: ``body_a``, ``body_b`` (c,) int64; ``points``, ``normals`` (c, 3), normals from
        body_b towards body_a; ``depths`` (c,), > 0 penetration, < 0 a gap: convex pairs
        apart by less than a thousandth of the thinner body's thickness have speculative
        contacts (see ``collision.convex.contacts``); ``faces`` (c, 2) [face of a, face of
        b] (-1 for convex pairs); ``features`` (c,) int64 feature ids of convex pairs'
        contacts, the same from step to step while their features are (-1 for mesh pairs);
        ``impulses`` (c, 3) (normal, t1, t2). With a response, these are the contacts the
        step's impulses acted at: those found where the bodies were at the start of the step,
        and those of collisions at their time of impact. In a detection-only world, the
        contacts the narrow phase found at the end of the step, with zero impulses.
        """
        s = self._state
        if self.contact_response:
            contacts, impulses = s.acted, s.impulses
        else:
            contacts = s.contacts
            impulses = np.zeros((contacts.count, 3))
        found = {key: value.copy() for key, value in contacts.items()}
        found["impulses"] = impulses.copy()
        return found

    @property
    def deepest_penetration(self) -> float:
        """Largest penetration depth among the contacts of the last step (m; 0 with none),
        without copying them out as :attr:`contacts` does: a study reads it every step."""
        s = self._state
        contacts = s.acted if self.contact_response else s.contacts
        if contacts.count == 0:
            return 0.0
        return max(float(contacts["depths"].max()), 0.0)


# The stages the step kernel leaves to Python, by stage index (their order and guards are the
# kernel's).
_STAGES_IN_PYTHON = {
    FORCES: World._gather_forces,
    BROAD_PHASE: World._update_broad_phase,
    NARROW_PHASE: World._find_contacts,
    TUNNELLING: World._catch_tunnelling,
    TIME_OF_IMPACT: World._step_back_to_impact,
    IMPACTS: World._resolve_impacts,
    SLEEP: World._fall_asleep,
}
