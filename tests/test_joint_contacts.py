"""Contacts of jointed bodies, solved with their joints held (``dynamics.jointed_contacts``).

Oracles: a brute-force solve of the whole velocity problem (joint rows as equalities, contact
rows complementary, every active set tried) for the kernel; for the world, the single rigid
body that two welded halves make, and a weld that rests and sleeps on a floor.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.dynamics.contact_settings import ContactSettings
from thesis_rbd.dynamics.contact_solver import contact_basis
from thesis_rbd.dynamics.joint_rows import body_pose, equality_row_count, joint_rows
from thesis_rbd.dynamics.joint_set import JOINT_KINDS, JointSet
from thesis_rbd.dynamics.jointed_contacts import solve_jointed_island
from thesis_rbd.dynamics.pgs import friction_polygon

G = 9.81


def _kkt_reference(M, joint_rows_, normal_rows, velocity):
    """v+ nearest to ``velocity`` in the metric M with every joint row held (J_j v+ = 0) and
    every contact row non-negative and complementary to its impulse, by trying every set of
    active contacts (numpy least squares; redundant rows are harmless)."""
    c = normal_rows.shape[0]
    for active in itertools.product([False, True], repeat=c):
        rows = np.vstack([joint_rows_, normal_rows[list(active)]])
        r = rows.shape[0]
        kkt = np.block([[M, -rows.T], [rows, np.zeros((r, r))]])
        rhs = np.concatenate([M @ velocity, np.zeros(r)])
        solution = np.linalg.lstsq(kkt, rhs, rcond=None)[0]
        v_plus, multipliers = solution[: M.shape[0]], solution[M.shape[0] :]
        impulses = multipliers[joint_rows_.shape[0] :]
        if np.all(impulses >= -1e-9) and np.all(normal_rows @ v_plus >= -1e-9):
            return v_plus
    raise AssertionError("no active set solves the problem")


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(sorted(JOINT_KINDS)),
    contacts=st.integers(1, 3),
    seed=st.integers(0, 2**31 - 1),
)
def test_jointed_island_matches_the_whole_velocity_problem(kind, contacts, seed):
    """Two random bodies joined by a joint of each kind, touching a static body at up to
    three frictionless points: the kernel's velocities equal the brute-force answer of the
    whole problem, joint rows and contact rows together."""
    rng = np.random.default_rng(seed)
    world = rbd.World()
    for _ in range(2):
        world.add_body(
            rbd.shapes.box(rng.uniform(0.2, 1.0, 3)), mass=rng.uniform(0.5, 5.0),
            position=rng.normal(0, 0.3, 3), orientation=Rotation.random(random_state=rng).as_quat(),
        )  # fmt: skip
    world.add_body(rbd.shapes.box((4, 4, 1)), position=(0, 0, -3), static=True)
    bodies = world.bodies
    joints = JointSet()
    anchor = rng.normal(0, 0.2, 3)
    anchor_b = anchor + rng.normal(0, 0.3, 3) if kind == "distance" else None
    axis, options = rng.normal(size=3), {}
    if kind == "generic":  # one travel and two turns locked: line and hinge rows
        options["axes"] = ("free", "locked", "locked", "locked", "free", "locked")
    joints.add(kind, 0, 1, anchor, axis, anchor_b, False, None, bodies, options)
    n = bodies.count
    inverse_mass = np.array([1 / bodies.mass[0], 1 / bodies.mass[1], 0.0])
    R = Rotation.from_quat(bodies.orientation).as_matrix()
    inverse_inertia = np.array([R[i] @ bodies.inverse_inertia_body[i] @ R[i].T for i in range(n)])
    inverse_inertia[2] = 0.0
    v, w = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    v[2] = w[2] = 0.0
    body_a = rng.integers(0, 2, contacts)
    body_b = np.full(contacts, 2)
    points = bodies.position[body_a] + rng.normal(0, 0.3, (contacts, 3))
    normals = rng.normal(size=(contacts, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    arm_a = points - bodies.position[body_a]
    arm_b = points - bodies.position[body_b]
    basis = contact_basis(normals)
    impulse = np.zeros((contacts, 3))
    stats = np.zeros(6, np.int64)
    solve_jointed_island(
        0, contacts, ContactSettings(solver="exact").as_array(1 / 240), friction_polygon(8),
        body_a, body_b, arm_a, arm_b, basis, np.zeros(contacts), np.zeros(contacts),
        np.zeros(contacts), np.full(contacts, 1e-9), inverse_mass, inverse_inertia,
        v_after := v.copy(), w_after := w.copy(), impulse, stats, np.array([0]), joints.ints,
        joints.floats, bodies.position, bodies.orientation,
    )  # fmt: skip

    # the reference: the two moving bodies' (v, w) stacked, their rows written out here
    M = np.zeros((12, 12))
    for i in range(2):
        M[6 * i : 6 * i + 3, 6 * i : 6 * i + 3] = np.eye(3) / inverse_mass[i]
        M[6 * i + 3 : 6 * i + 6, 6 * i + 3 : 6 * i + 6] = np.linalg.inv(inverse_inertia[i])
    rows = np.zeros((7, 10))
    xa, qa = body_pose(0, bodies.position, bodies.orientation)
    xb, qb = body_pose(1, bodies.position, bodies.orientation)
    joint_rows(JOINT_KINDS[kind], joints.floats[0], xa, qa, xb, qb, rows, 0, True)
    equality = rows[: equality_row_count(JOINT_KINDS[kind], joints.floats[0])]
    J = np.zeros((len(equality), 12))
    J[:, 0:3], J[:, 3:6] = equality[:, 0:3], equality[:, 3:6]
    J[:, 6:9], J[:, 9:12] = -equality[:, 0:3], equality[:, 6:9]
    N = np.zeros((contacts, 12))
    for k in range(contacts):
        column = 6 * body_a[k]
        N[k, column : column + 3] = normals[k]
        N[k, column + 3 : column + 6] = np.cross(arm_a[k], normals[k])
    velocity = np.concatenate([v[0], w[0], v[1], w[1]])
    expected = _kkt_reference(M, J, N, velocity)
    got = np.concatenate([v_after[0], w_after[0], v_after[1], w_after[1]])
    scale = np.abs(expected).max() + 1.0
    assert np.abs(got - expected).max() <= 1e-7 * scale


def _welded_or_whole(welded, friction=0.5):
    """A 0.2 x 0.2 x 0.4 m, 2 kg block tossed tumbling onto a floor: two welded 1 kg cubes,
    or one body. The same motion, given the same (rigid) initial velocities."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G), integrator="symplectic_euler")
    world.add_body(rbd.shapes.box((4, 4, 1)), position=(0, 0, -0.5), static=True, friction=0.5)
    turn = Rotation.from_rotvec([0.3, 0.2, 0.1])
    centre, velocity, spin = np.array([0, 0, 0.5]), np.array([1.0, 0, 0]), np.array([0, 2.0, 0])
    if not welded:
        world.add_body(
            rbd.shapes.box((0.2, 0.2, 0.4)), mass=2.0, position=centre,
            orientation=turn.as_quat(), friction=friction, linear_velocity=velocity,
            angular_velocity=spin,
        )  # fmt: skip
        return world, lambda: world.bodies.position[1].copy()
    for half in (-0.1, 0.1):
        offset = turn.apply([0, 0, half])
        world.add_body(
            rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=centre + offset,
            orientation=turn.as_quat(), friction=friction,
            linear_velocity=velocity + np.cross(spin, offset), angular_velocity=spin,
        )  # fmt: skip
    world.add_joint("fixed", 1, 2, anchor=centre)
    return world, lambda: world.bodies.position[1:3].mean(axis=0)


def test_welded_halves_move_as_the_body_they_make():
    """Two cubes welded into a block land tumbling, slide with friction and come to rest
    where the one-piece block does (within 1 mm over 2 s; the contacts of the two differ by
    the PGS tolerance only). The weld holds to 0.1 mm over the run and 1e-9 m at rest: the
    time of impact retraces each body's path as a parabola, which a turning weld's halves
    follow to O(w^2 r t^2) only, and the next step's projection closes that."""
    welded, welded_centre = _welded_or_whole(True)
    whole, whole_centre = _welded_or_whole(False)
    worst_apart, worst_gap = 0.0, 0.0
    for _ in range(480):
        welded.step()
        whole.step()
        worst_apart = max(worst_apart, np.linalg.norm(welded_centre() - whole_centre()))
        worst_gap = max(worst_gap, welded.joints["gap"].max())
    assert worst_apart <= 1e-3
    assert worst_gap <= 1e-4
    assert welded.joints["gap"].max() <= 1e-9
    assert np.linalg.norm(whole_centre() - [0, 0, 0.5]) > 0.3  # it did move: a real test


def test_jointed_bodies_sleep_and_wake_together():
    """Two boxes welded one on the other rest on a floor, only the lower touching it: the
    floor carries both (the contact is solved with the weld held), they fall asleep as one
    island, and a force on the upper one wakes both."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    world.add_body(rbd.shapes.box((4, 4, 1)), position=(0, 0, -0.5), static=True)
    low = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1))
    high = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.3))
    world.add_joint("fixed", high, low, anchor=(0, 0, 0.2))
    world.step(480)
    assert world.sleeping[[low, high]].all()
    assert world.bodies.position[low, 2] == pytest.approx(0.1, abs=1e-4)
    world.apply_force(high, (1.0, 0, 0), duration=0.1)
    world.step(1)
    assert not world.sleeping[[low, high]].any()
