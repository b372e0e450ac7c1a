"""The world: bodies, the force model, and a step that reads as its list of stages.

A step runs only the stages the scene calls for (``World.stages``), each timed into
``World.profile``, and the stages hand each other explicit arrays:

    forces -> contacts -> integrate -> bounds -> broad_phase -> narrow_phase -> tunnelling
           -> time_of_impact -> impacts -> sleep

``contacts`` resolves the contacts found at the end of the previous step (where the bodies are
now) before anything moves, so resting bodies never sink under gravity; ``integrate`` moves the
bodies it acted on with their new velocities and every other body by the chosen ODE method;
detection then finds the contacts of the new positions, which are the next step's;
``time_of_impact`` steps bodies that flew into something back to the moment they touched, and
``impacts`` resolves those collisions and carries the bodies to the end of the step.

The plan is derived from the scene and refreshed whenever bodies or forces change: no gravity
or applied force, no forces stage; no dynamic body, nothing at all; fewer than two bodies, no
collision stages; no contact response wanted (a detection-only scene), no contact stages.
Stages are also skipped step by step when they have nothing to do (a skipped stage is not
called and costs nothing): the contact stage without contacts, the narrow phase without
candidate pairs, the tunnelling check when no body moved further than its own thickness, the
impact stages when no body hit anything, everything but the forces when all bodies sleep; so
are the broad phase while no body left its fat box (``collision/broad_phase/bounds.py``) and
the sleep stage while it would change nothing.

While every body is convex and awake and gravity is the only force, each stage is one known
kernel, and ``steady_steps.run_steady_steps`` runs the stages of many steps in one call: it
stops at the first stage that needs Python (a sweep-and-prune update, the tunnelling check, a
time of impact, the sleep stage), and the step goes on from there stage by stage. Its steps are
the staged steps to the bit, and ``World.profile`` gets each stage's share of its time.

A step whose state turns non-finite (a huge force, a diverging solve) raises
``NonFiniteStateError`` naming the body, the stage and the step, and leaves the world as it
was before that step; the kernels report the first bad body as they write, so a good step pays
only for one copy of the state.
"""

from __future__ import annotations

import dataclasses
from time import perf_counter
from typing import NoReturn

import numpy as np

from thesis_rbd._validate import as_finite_array, as_positive_scalar
from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.pipeline import CollisionPipeline
from thesis_rbd.dynamics.bodies import BodyArrays
from thesis_rbd.dynamics.body_builder import body_fields
from thesis_rbd.dynamics.contact_settings import ContactSettings
from thesis_rbd.dynamics.contact_stats import BAD_BODY, ISLANDS, STATS
from thesis_rbd.dynamics.forces import (
    AppliedForces,
    DragCoefficients,
    PointForces,
    world_arm_to_body,
)
from thesis_rbd.dynamics.impacts import any_free_body, find_hits, resolve_impacts
from thesis_rbd.dynamics.integrators import INTEGRATORS, integrate_bodies
from thesis_rbd.dynamics.pgs import friction_polygon
from thesis_rbd.dynamics.resting_contact import solve_contacts
from thesis_rbd.dynamics.sleep import SleepSettings, SleepState
from thesis_rbd.dynamics.warm_start import WarmStart
from thesis_rbd.world.readout import WorldReadout
from thesis_rbd.world.stage_names import STAGE_NAMES
from thesis_rbd.world.steady import WorldSteadySteps
from thesis_rbd.world.steady_steps import FINISHED
from thesis_rbd.world.time_of_impact import passed_through, step_back_to_impact

__all__ = ["STAGE_NAMES", "NonFiniteStateError", "World"]


# no contacts, and what a step without contact impulses acted at: (contacts, impulses (c, 3))
_NO_CONTACTS = ContactSet.empty()
_NO_CONTACT_ACTED = (_NO_CONTACTS, np.zeros((0, 3)))


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


class World(WorldSteadySteps, WorldReadout):
    """A rigid-body world stepped at a fixed time step.

    Parameters
    ----------
    dt : float
        Time step (s), > 0.
    gravity : (3,) array_like
        Gravitational acceleration (m/s^2); (0, 0, 0) by default (no effect is on by default).
    integrator : {"euler", "symplectic_euler", "midpoint", "rk4"}
        ODE method for bodies that no contact acts on.
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
    penetration : {"toi", "bias"}
        Step bodies that flew into something back to their time of impact, or leave them
        where they ended and push them out through the contact velocities.
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
        contact_solver: str = ContactSettings.solver,
        contact_iterations: int = ContactSettings.iterations,
        friction_sides: int = ContactSettings.friction_sides,
        penetration: str = ContactSettings.penetration,
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
        self.steps_taken = 0
        self.bodies = BodyArrays()
        self.applied_forces = AppliedForces()
        self.profile = {name: {"calls": 0, "seconds": 0.0} for name in STAGE_NAMES}
        self.contact_response = bool(contact_response)
        self._contact_settings = ContactSettings(
            solver=contact_solver,
            iterations=contact_iterations,
            friction_sides=friction_sides,
            penetration=penetration,
        )
        self._collision = CollisionPipeline(narrow_phase)
        self.narrow_phase = narrow_phase
        self._sleep = SleepState(SleepSettings(enabled=bool(sleeping)))
        self._warm_start = WarmStart()
        self._contact_stats = np.zeros(len(STATS), np.int64)
        self._impact_count = 0
        # what the stages hand each other (see the module docstring)
        self._contacts = _NO_CONTACTS  # at the bodies' current positions
        self._acted = _NO_CONTACT_ACTED  # what this step's impulses acted at
        self._candidates = np.zeros((0, 2), np.int64)
        self._fast = np.zeros(0, bool)
        self._fast_count = 0
        self._slowest = np.inf
        self._rewind = np.zeros(0)
        self._rewound = False
        self._pipeline: list[tuple] = []
        self._plan_stages()

    # ------------------------------------------------------------------ building the scene
    def add_body(
        self,
        mesh,
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
            Label used in trajectories and errors; "body<i>" by default.
        collidable : bool
            False keeps the body out of collision detection (free flight only); with fewer
            than two collidable bodies the world runs no collision stage at all.
        """
        fields = body_fields(
            mesh, mass, density, position, orientation, linear_velocity, angular_velocity,
            restitution, friction, static, collidable,
        )  # fmt: skip
        index = self.bodies.append(
            mesh, name if name is not None else f"body{self.bodies.count}", **fields
        )
        self._collision.add_body(mesh, fields["center_of_mass_local"])
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
        responds = collides and self.contact_response
        pipeline = []
        if gathers_forces:
            pipeline.append(("forces", self._stage_forces, _always))
        if responds:
            pipeline.append(("contacts", self._stage_contacts, self._has_contacts))
        if dynamic:
            pipeline.append(("integrate", self._stage_integrate, self._any_awake))
        if collides:
            pipeline.append(("bounds", self._stage_bounds, self._any_awake))
            pipeline.append(("broad_phase", self._stage_broad_phase, self._broad_phase_due))
            pipeline.append(("narrow_phase", self._stage_narrow_phase, self._has_candidates))
            pipeline.append(("tunnelling", self._stage_tunnelling, self._has_fast_bodies))
        if responds and self.contact_settings.penetration == "toi":
            pipeline.append(("time_of_impact", self._stage_time_of_impact, self._may_have_hit))
            pipeline.append(("impacts", self._stage_impacts, self._has_rewound))
        if collides and self._sleep.settings.enabled:
            # bodies come to rest through contact: without collisions nothing would sleep
            pipeline.append(("sleep", self._stage_sleep, self._sleep_due))
        self._pipeline = [(*entry, self.profile[entry[0]]) for entry in pipeline]
        # where in the pipeline a step that stopped at stage k resumes
        ranks = [STAGE_NAMES.index(entry[0]) for entry in pipeline]
        self._resume_at = [
            next((i for i, rank in enumerate(ranks) if rank >= k), len(ranks))
            for k in range(len(STAGE_NAMES))
        ]
        # every stage a known kernel while the bodies are convex and awake: run_steady_steps
        self._steady = (
            responds
            and self.contact_settings.penetration == "toi"
            and len(self.applied_forces) == 0
        )
        self._collision_planned = collides
        self._contacts_stale = responds
        # speculative contacts across the gap gravity closes in a step, twice over (a body
        # that lost its support for a step falls g dt^2 and gains g dt): a 2 mm cube's is
        # 8 % of its edge, far beyond the margin relative to its size
        reach = 2.0 * float(np.linalg.norm(self.gravity)) * self.dt**2
        self._collision.plan(b, reach)
        n = b.count
        self._start_position = b.position.copy()
        self._start_orientation = b.orientation.copy()
        self._solved = np.zeros(n, bool)
        self._fast = np.zeros(n, bool)
        self._rewind = np.zeros(n)
        # the kernels' body arguments, looked up once per plan (arrays change only on add_body)
        full = b.full
        self._state = tuple(
            full(f) for f in ("position", "orientation", "linear_momentum", "angular_momentum")
        )
        self._constants = tuple(
            full(f)
            for f in (
                "inverse_mass", "inverse_inertia_body", "inertia_body", "thickness",
                "restitution", "friction",
            )
        )  # fmt: skip
        self._settings = self.contact_settings.as_array(self.dt)
        self._polygon = friction_polygon(self.contact_settings.friction_sides)
        self._sleep_changed()
        self._stale_plan = False
        # M g is constant between scene changes: computed here, not every step
        self._gravity_force = np.where(b.static, 0.0, b.mass)[:, None] * self.gravity
        self._external_force = self._gravity_force
        self._point_forces = PointForces.empty(n)
        if self._steady:
            self._gather_steady_arguments()

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
            if self._steady_now():
                done, first, bad = self._run_steady_steps(remaining)
                remaining -= done
                if first == FINISHED:
                    continue
                if bad >= 0:
                    self._fail(bad, STAGE_NAMES[first])
            else:
                self._save()
                first = 0
            self._run_stages(first)
            remaining -= 1

    def _run_stages(self, first: int) -> None:
        """Run the stages of this step from the one ``STAGE_NAMES[first]`` on, then end it."""
        for name, stage, guard, entry in self._pipeline[self._resume_at[first] :]:
            if not guard():
                continue
            start = perf_counter()
            try:
                stage()
            except _StepFailed as failure:
                self._fail(failure.body, name)
            entry["seconds"] += perf_counter() - start
            entry["calls"] += 1
        self.time += self.dt
        self.steps_taken += 1
        if self._stale_plan:
            self._plan_stages()

    def _fail(self, body: int, stage: str) -> NoReturn:
        """Put the world back as it was before this step and raise the error naming the
        body that went non-finite, the stage and the step."""
        self._restore()
        raise NonFiniteStateError(body, self.bodies.names[body], stage, self.steps_taken) from None

    def _detect_contacts(self) -> None:
        """Find the contacts where the bodies are now, for the first step after the scene
        changed: the contact stage acts on contacts found at the end of the previous step."""
        self._contacts_stale = False
        for name, stage, guard, entry in self._pipeline:
            if name in ("bounds", "broad_phase", "narrow_phase") and guard():
                start = perf_counter()
                stage()
                entry["seconds"] += perf_counter() - start
                entry["calls"] += 1

    def _save(self) -> None:
        """Keep what a failed step must put back: the body state and the stage hand-overs."""
        self.bodies.save_state()
        forces = self.applied_forces
        # applied forces change only while some are active (their durations run down)
        self._saved = (
            self._contacts,
            self._acted,
            dataclasses.replace(forces) if len(forces) else forces,
        )
        self._acted = _NO_CONTACT_ACTED
        self._solved[:] = False
        self._rewound = False

    def _restore(self) -> None:
        self.bodies.restore_state()
        self._contacts, self._acted, self.applied_forces = self._saved
        self._plan_stages()  # fat boxes refitted around the restored positions

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
        ``_awake`` says whether any body moves at all, ``_any_asleep`` whether any sleeps.
        """
        self._frozen = self.bodies.static | self._sleep.asleep
        self._awake = not bool(np.all(self._frozen))
        self._any_asleep = self._sleep.any_asleep

    def _any_awake(self) -> bool:
        return self._awake

    def _has_contacts(self) -> bool:
        return self._awake and self._contacts.count > 0

    def _stage_contacts(self) -> None:
        """Impulses of the contacts where the bodies are now, before they move."""
        b, c, pf = self.bodies, self._contacts, self._point_forces
        count = c.count
        impulses = np.empty((count, 3))
        warm = self._warm_start
        keys, values = np.empty((count, 2), np.int64), np.empty((count, 6))
        stats = self._contact_stats
        solve_contacts(
            self._settings, self._polygon, b.count, self._frozen, c.ints, c.floats, count,
            *self._state, *self._constants, self._external_force, self._drag_array, pf.start,
            pf.arm, pf.force, warm.keys, warm.values, keys, values, impulses, self._solved,
            stats,
        )  # fmt: skip
        warm.keys, warm.values = keys, values
        if stats[BAD_BODY] >= 0:
            raise _StepFailed(int(stats[BAD_BODY]))
        self._acted = (c, impulses)
        self._impact_count = 0

    def _stage_integrate(self) -> None:
        """Move every awake body: those the contact stage acted on with their new velocities,
        the others by the ODE method."""
        b = self.bodies
        pf = self._point_forces
        bad = integrate_bodies(
            INTEGRATORS[self.integrator], self.dt, b.count, self._frozen, self._solved,
            *self._state, *self._constants[:2],
            self._external_force, self._drag_array, pf.start, pf.arm, pf.force,
            # where the step started: fast bodies are swept from here (no tunnelling)
            self._collision_planned, self._start_position, self._start_orientation,
        )  # fmt: skip
        if bad >= 0:
            raise _StepFailed(bad)

    def _stage_bounds(self) -> None:
        """Fast bodies (moved further than their own thickness) and fat boxes, refitted if a
        moving body left its own."""
        self._fast, self._fast_count, self._slowest = self._collision.bounds(
            self.bodies, self._frozen, self._start_position, self.dt
        )

    def _broad_phase_due(self) -> bool:
        # not due: no fat pairs, so the last call already left no candidates and no contacts
        return self._awake and self._collision.broad_phase_due

    def _stage_broad_phase(self) -> None:
        """Sweep-and-prune on the fat boxes if they changed; candidate pairs with at least one
        moving body and overlapping tight boxes."""
        self._candidates = self._collision.broad_phase(self._frozen)
        if len(self._candidates) == 0:
            self._contacts = _NO_CONTACTS  # the narrow phase will not run this step

    def _has_candidates(self) -> bool:
        return self._awake and len(self._candidates) > 0

    def _stage_narrow_phase(self) -> None:
        """Contacts of the candidate pairs (convex pairs by the convex kernel, the others by
        the OBBTree); a touched sleeping island wakes."""
        self._contacts = self._collision.narrow_phase(self._candidates)
        if self._any_asleep and self._sleep.wake_touched(self._contacts, self.bodies.static):
            self._sleep_changed()
            # the woken islands' own contacts were not candidates: find them now
            self._candidates = self._collision.broad_phase(self._frozen)
            self._contacts = self._collision.narrow_phase(self._candidates)

    def _has_fast_bodies(self) -> bool:
        return self._awake and self._fast_count > 0

    def _stage_tunnelling(self) -> None:
        """Sampling along the step for fast bodies only: put back what passed through."""
        self._contacts, _ = self._collision.sweep(
            self.bodies, self._candidates, self._contacts, self._fast, self._start_position,
            self._start_orientation,
        )  # fmt: skip

    def _may_have_hit(self) -> bool:
        """Whether a contact has a body that flew freely this step (neither resting nor
        moved by the contact stage): only such a body can have run into something."""
        if not self._has_contacts():
            return False
        c = self._contacts
        return any_free_body(c.ints, c.count, self._frozen, self._solved)

    def _stage_time_of_impact(self) -> None:
        """Bodies in free flight that ran into something go back to when they touched."""
        b, c = self.bodies, self._contacts
        n = b.count
        movers = ~(self._frozen | self._solved[:n])
        hits, receding, v, w = find_hits(
            n, self._frozen, movers, c.ints, c.floats, c.count, *self._state,
            *self._constants[:2],
        )  # fmt: skip
        if receding.any():
            hits |= passed_through(
                self._collision, c, receding, self._start_position, self._start_orientation
            )
        if not hits.any():
            return
        acceleration = self._external_force * b.inverse_mass[:, None]
        self._rewind, self._contacts = step_back_to_impact(
            self._collision, b, c, hits, movers, v, w, acceleration, self.dt
        )
        rewound = self._rewind > 0
        self._rewound = bool(rewound.any())
        # the stepped-back bodies carry the velocity of their time of impact
        b.linear_momentum[rewound] = v[rewound] / b.inverse_mass[rewound, None]

    def _has_rewound(self) -> bool:
        return self._rewound

    def _stage_impacts(self) -> None:
        """Collisions at the time of impact, then the rest of the step for those bodies."""
        b, c, pf = self.bodies, self._contacts, self._point_forces
        impulses = np.zeros((c.count, 3))
        stats, resolved = resolve_impacts(
            self._settings, self._polygon, b.count, self._frozen, self._rewind, c.ints,
            c.floats, c.count, *self._state, *self._constants, self._external_force,
            self._drag_array, pf.start, pf.arm, pf.force, impulses,
        )  # fmt: skip
        if stats[BAD_BODY] >= 0:
            raise _StepFailed(int(stats[BAD_BODY]))
        self._rewind[:] = 0.0
        acted, acted_impulses = self._acted
        self._acted = (
            ContactSet.concatenate([acted, c.select(resolved)]),
            np.concatenate([acted_impulses, impulses[resolved]]),
        )
        self._impact_count = int(stats[ISLANDS])

    def _sleep_due(self) -> bool:
        return self._awake and self._sleep.update_due(self._slowest, self._has_contacts())

    def _stage_sleep(self) -> None:
        """Islands still for long enough fall asleep with zero velocity."""
        b = self.bodies
        fell = self._sleep.update(b, self._contacts, self.dt)
        if len(fell):
            b.linear_momentum[fell] = 0.0
            b.angular_momentum[fell] = 0.0
            self._sleep_changed()
            # contacts between sleeping (or static) bodies need no solving
            c = self._contacts
            active = ~(self._frozen[c["body_a"]] & self._frozen[c["body_b"]])
            self._contacts = c.select(active)

    @property
    def contact_info(self) -> dict:
        """What the last contact stage did: ``islands``, PGS ``sweeps`` (in all) and
        ``max_sweeps`` (of one island), ``exact_islands`` solved by Lemke's method,
        ``unconverged`` islands (PGS at its sweep limit, or an exact solve that fell back),
        and ``impacts``, islands resolved at their time of impact in the last step."""
        info = dict(zip(STATS[:BAD_BODY], self._contact_stats[:BAD_BODY].tolist(), strict=True))
        info["impacts"] = self._impact_count
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
        contacts (see ``collision.convex_contacts``); ``faces`` (c, 2) [face of a, face of b]
        (-1 for convex pairs); ``features`` (c,) int64 feature ids of convex pairs' contacts,
        the same from step to step while their features are (-1 for mesh pairs);
        ``impulses`` (c, 3) (normal, t1, t2). With a response, these are the contacts the
        step's impulses acted at: those found where the bodies were at the start of the step,
        and those of collisions at their time of impact. In a detection-only world, the
        contacts the narrow phase found at the end of the step, with zero impulses.
        """
        if self.contact_response:
            contacts, impulses = self._acted
        else:
            contacts = self._contacts
            impulses = np.zeros((contacts.count, 3))
        found = {key: value.copy() for key, value in contacts.items()}
        found["impulses"] = impulses.copy()
        return found


def _always() -> bool:
    return True
