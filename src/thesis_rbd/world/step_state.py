"""What the stages of a world step hand each other, and each step the next: one value.

A stage that runs in Python takes the ``StepState`` and returns it with the fields it produced
replaced (``dataclasses.replace``); the step kernel takes its fields as arguments, and the
world writes what the kernel hands back into the state (in place: a new value per kernel call
would cost a one-body step a third more). Nothing a stage needs is stashed on another object,
so a copy of the state at the start of a step is all a failed step must put back (with the
body state the kernel saved); the world makes that copy when a step stops mid-way for Python.

The arrays in it are never written after they are made, except the per-step scratch the
stages fill in place (``solved``, ``start_position``, ``start_orientation``, ``fast``), which
a step begins by resetting.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from thesis_rbd.collision.contact_set import ContactSet
from thesis_rbd.collision.convex.contacts import empty_cache
from thesis_rbd.dynamics.forces import PointForces

__all__ = ["StepState"]


@dataclasses.dataclass(slots=True)
class StepState:
    """The hand-overs of a world's step.

    Attributes
    ----------
    contacts : ContactSet
        The contacts where the bodies are now (the last narrow phase's): the next contact
        stage acts on them before anything moves.
    acted : ContactSet
        What the last step's impulses acted at: its contact stage's contacts and those of
        collisions at their time of impact.
    impulses : (c, 3) float64
        Their impulses (normal, t1, t2).
    warm_keys, warm_values : (m, 2) int64, (m, 6) float64
        The warm start the last contact stage left (``dynamics.warm_start``).
    convex_cache : tuple
        The convex pairs' coherence cache from the last narrow phase (``convex.contacts``).
    external_force : (n, 3) float64
        The step's force on each body: M g, plus the applied forces while any is active.
    point_forces : PointForces
        The active applied forces with a torque arm.
    frozen : (n,) bool
        Immovable this step (static, kinematic or asleep): no contact, joint or force moves
        it, and the integrator skips it.
    stationary : (n,) bool
        Does not move this step (frozen, and not a kinematic body with a velocity): the
        detection stages keep its boxes, and two such bodies make no new contact. The same
        array as ``frozen`` in a scene without kinematic bodies; the step kernel derives its
        own from the kinematic velocities.
    awake, any_asleep : bool
        Whether any body moves; whether any sleeps.
    candidate_count : int
        Candidate pairs the last broad phase wrote (``CollisionPipeline.candidates``).
    fast_count : int
        Bodies that moved further than their thickness in the last bounds stage.
    slowest : float
        Smallest (speed / bounding radius)^2 (1/s^2) of a moving body in that stage.
    fat_changed : bool
        A bounds stage refitted the fat boxes, and the sweep-and-prune has not seen them.
    refit_all : bool
        The next bounds stage refits every fat box (the scene changed).
    rewound : bool
        This step's time of impact stepped a body back; ``rewind`` (n,) says how far (s).
    unrewound : tuple
        (position (n, 3), orientation (n, 4)): where the bodies were before the time of
        impact last stepped any back (empty arrays before it has).
    impact_count : int
        Islands resolved at their time of impact in the last step.
    contact_stats : (len(contact_stats.STATS),) int64
        What the last contact or impact stage counted.
    solved : (n,) bool
        Scratch: the bodies the contact stage moved this step.
    reach_back : (n,) float64
        Scratch: how far back (s) each body's path over this step goes (``dt``; less for a
        body the tunnelling stage caught part way), for the time of impact.
    start_position, start_orientation : (n, 3), (n, 4) float64
        Scratch: where each body began the step.
    fast : (n,) bool
        Scratch: the fast bodies of the last bounds stage.
    """

    contacts: ContactSet
    acted: ContactSet
    impulses: np.ndarray
    warm_keys: np.ndarray
    warm_values: np.ndarray
    convex_cache: tuple
    external_force: np.ndarray
    point_forces: PointForces
    frozen: np.ndarray
    stationary: np.ndarray
    awake: bool
    any_asleep: bool
    candidate_count: int
    fast_count: int
    slowest: float
    fat_changed: bool
    refit_all: bool
    rewound: bool
    rewind: np.ndarray
    unrewound: tuple
    impact_count: int
    contact_stats: np.ndarray
    solved: np.ndarray
    reach_back: np.ndarray
    start_position: np.ndarray
    start_orientation: np.ndarray
    fast: np.ndarray

    @classmethod
    def initial(cls, count: int, stat_count: int) -> StepState:
        """The state of a world of ``count`` bodies that has not stepped."""
        return cls(
            contacts=ContactSet.empty(), acted=ContactSet.empty(), impulses=np.zeros((0, 3)),
            warm_keys=np.zeros((0, 2), np.int64), warm_values=np.zeros((0, 6)),
            convex_cache=empty_cache(), external_force=np.zeros((count, 3)),
            point_forces=PointForces.empty(count), frozen=np.zeros(count, bool),
            stationary=np.zeros(count, bool), awake=False,
            any_asleep=False, candidate_count=0, fast_count=0, slowest=np.inf,
            fat_changed=False, refit_all=True, rewound=False, rewind=np.zeros(count),
            unrewound=(np.zeros((0, 3)), np.zeros((0, 4))),
            impact_count=0, contact_stats=np.zeros(stat_count, np.int64),
            solved=np.zeros(count, bool), reach_back=np.zeros(count),
            start_position=np.zeros((count, 3)), start_orientation=np.zeros((count, 4)),
            fast=np.zeros(count, bool),
        )  # fmt: skip
