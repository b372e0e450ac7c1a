"""Newton's cradle: impacts between jointed bodies, against the laws of elastic impact.

Cradle A, the built-in scene, has gaps wider than a ball's travel in a step: its collisions
come one pair at a time, and two equal balls exchange their velocities. Cradle B has the
struck bodies touching: the blow meets all of them at once, and Poisson's simultaneous impact
(every contact gives back e times its compression impulse) sends the striker back at 3/5 of
its speed and the four others on at 2/5 each, which keeps both momentum and energy. Its
bodies are cubes, whose flush faces make every contact normal the line of the row: a
polyhedral ball's facets tilt its normals by a few degrees (1.8 % off that answer with 1280
facets, 3.7 % with 320), which is the shape's answer, not the solver's.
"""

from __future__ import annotations

import numpy as np
import pytest

import thesis_rbd as rbd

G = 9.81
LENGTH = 0.3  # m, each ball's centre below its hinge (the built-in scene's)
RADIUS = 0.025
MASS = 0.5


def _height_energy(world, balls):
    """Kinetic plus potential energy (J) of the balls, zero with all hanging at rest."""
    b = world.bodies
    kinetic = world.kinetic_energy()
    return kinetic + MASS * G * float(np.sum(b.position[balls, 2] + LENGTH))


def test_cradle_with_gaps_passes_the_blow_along_without_gaining_energy():
    """The first ball strikes at its speed from 30 degrees; the last leaves with at least 95 %
    of it and rises no higher than the first was released from (no energy gained)."""
    world = rbd.scenes.get("cradle").build()
    balls = np.flatnonzero(~world.bodies.static)
    release = world.bodies.position[balls[0], 2]
    impact_speed = np.sqrt(2 * G * LENGTH * (1 - np.cos(np.radians(30))))
    last_speed, last_peak = 0.0, -np.inf
    for _ in range(round(0.75 / world.dt)):
        world.step()
        last_speed = max(last_speed, world.bodies.linear_momentum[balls[-1], 0] / MASS)
        last_peak = max(last_peak, world.bodies.position[balls[-1], 2])
    assert last_speed >= 0.95 * impact_speed
    assert last_peak <= release
    assert last_peak >= release - 0.1 * (release + LENGTH)  # it did swing up: a real test


def _touching_row(speed):
    """Four cubes of the balls' size and mass hanging face to face, the fifth 1 mm short of
    them at the bottom of its swing with ``speed`` (m/s) along +x."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    bodies = []
    for i in range(5):
        x = 2 * RADIUS * i
        start = (x - 0.001, 0, -LENGTH) if i == 0 else (x, 0, -LENGTH)
        spin = (0, -speed / LENGTH, 0) if i == 0 else (0, 0, 0)
        body = world.add_body(
            rbd.shapes.box((2 * RADIUS,) * 3), mass=MASS, position=start, restitution=1.0,
            linear_velocity=(speed if i == 0 else 0, 0, 0), angular_velocity=spin,
        )  # fmt: skip
        world.add_joint("revolute", body, None, anchor=(start[0], 0, 0), axis=(0, 1, 0))
        bodies.append(body)
    return world, np.array(bodies)


def test_cradle_of_touching_bodies_takes_the_blow_as_poisson_says():
    """The striker comes back at 3/5 of its impact speed and the other four go on at 2/5,
    each within 1 % of those speeds, and the impact adds no energy beyond 1e-3 of it."""
    world, bodies = _touching_row(0.888)
    before = _height_energy(world, bodies)
    incoming = world.bodies.linear_momentum[bodies[0], 0] / MASS
    world.step()
    velocity = world.bodies.linear_momentum[bodies, 0] / MASS
    assert velocity == pytest.approx(incoming * np.array([-3, 2, 2, 2, 2]) / 5, rel=0.01)
    assert _height_energy(world, bodies) - before <= 1e-3 * before
