"""The ragdoll scene: issue 34's acceptance, "Ragdoll onto steps: gap at rest <= 1 mm,
penetration within the suite's contact bounds".

The scene is run once and every step recorded. Bounds: the issue's 1 mm for the joints; the
stability suite's geometry bound for penetration (``TOLERANCE``, 1 %, of the thinner body of
each contact: 0.8 mm for a forearm on a step); round-off for the hinge limits, which the
joints stage holds exactly at the end of a step.
"""

from __future__ import annotations

import numpy as np
import pytest

import thesis_rbd as rbd
from validation.studies.stability_suite import TOLERANCE

GAP = 1e-3  # m, the bound on a joint's anchor gap
LIMIT_SLACK = 1e-6  # rad past a hinge limit: the projection stops a hinge on it to round-off
SETTLED = 0.01  # the landing is over once the kinetic energy is below 1 % of its peak
HINGES = ("elbow_left", "elbow_right", "knee_left", "knee_right")


@pytest.fixture(scope="module")
def run():
    """Each step's largest anchor gap, largest depth as a share of the suite's bound, hinge
    angles, kinetic energy, whether every segment sleeps and whether every state is finite."""
    scene = rbd.scenes.get("ragdoll")
    world = scene.build()
    dynamic = ~world.bodies.static
    # the thickness of each body (its box's least extent); static steps never the thinner
    thickness = np.array(
        [np.inf if body.static else min(body.shape["extents"]) for body in scene.bodies]
    )
    joints = world.joints
    hinges = [joints["name"].index(name) for name in HINGES]
    limits = np.array([scene.joints[i].limits for i in hinges])
    steps = round(scene.seconds / world.dt)
    record = {key: np.empty(steps) for key in ("gap", "depth_share", "energy")}
    record |= {key: np.zeros(steps, bool) for key in ("asleep", "finite")}
    record["hinge"] = np.empty((steps, len(hinges)))
    for k in range(steps):
        world.step()
        joints, contacts = world.joints, world.contacts
        bound = TOLERANCE * np.minimum(thickness[contacts["body_a"]], thickness[contacts["body_b"]])
        record["gap"][k] = joints["gap"].max()
        record["depth_share"][k] = (contacts["depths"] / bound).max(initial=0.0)
        record["hinge"][k] = joints["position"][hinges]
        record["energy"][k] = world.kinetic_energy()
        record["asleep"][k] = world.sleeping[dynamic].all()
        b = world.bodies
        record["finite"][k] = all(
            np.isfinite(x[dynamic]).all()
            for x in (b.position, b.orientation, b.linear_momentum, b.angular_momentum)
        )
    record["limits"] = limits
    # the landing is over from the first step after the fall's peak with under 1 % of it left
    peak = int(np.argmax(record["energy"]))
    below = np.flatnonzero(record["energy"][peak:] < SETTLED * record["energy"][peak])
    record["settled"] = peak + int(below[0]) if below.size else steps
    return record


def _within_limits(angles, limits):
    return np.all((angles >= limits[:, 0] - LIMIT_SLACK) & (angles <= limits[:, 1] + LIMIT_SLACK))


def test_ragdoll_lands_whole_and_holds_its_joints_and_limits_at_the_end(run):
    """Every state finite; at the end of the run every anchor gap under 1 mm (measured:
    5e-16 m) and every elbow and knee within its 0 to 150 degree limits (measured: on the
    lower limit, within 1e-7 rad inside it)."""
    assert run["finite"].all()
    assert run["gap"][-1] <= GAP
    assert _within_limits(run["hinge"][-1], run["limits"])


def test_ragdoll_joints_and_limits_hold_through_the_landing(run):
    """After every step: every anchor gap under 1 mm and every hinge within its limits."""
    assert run["gap"].max() <= GAP
    assert all(_within_limits(angles, run["limits"]) for angles in run["hinge"])


def test_ragdoll_comes_to_rest(run):
    """Every segment asleep by the end of the run (the landing is over by 0.53 s)."""
    assert run["asleep"][-1]


def test_ragdoll_penetration_within_the_suite_bound_once_landed(run):
    """Once the landing is over (kinetic energy under 1 % of its peak), no contact deeper
    than 1 % of the thinner body."""
    assert run["settled"] < run["gap"].size
    assert run["depth_share"][run["settled"] :].max() <= 1.0
