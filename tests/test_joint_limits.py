"""A spherical joint's cone and twist limits, against finite differences and the geometry of
the bodies' poses (scipy rotations, sharing no code with ``dynamics.joint_rows``).

The cone bounds the angle between an axis fixed in body a and the same axis fixed in body b
(both the joint's axis at creation); the twist bounds a's turn about b's axis. Bounds as the
issue sets them for a hinge limit: overshoot at most 0.6 degrees at any step's end, at rest
within 0.01 degrees of the limit.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.dynamics.joint_rows import joint_row_count, joint_rows
from thesis_rbd.dynamics.joint_set import JOINT_KINDS, JointSet

G = 9.81
OVERSHOOT = np.radians(0.6)
AT_REST = np.radians(0.01)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3),
    st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3),
    st.integers(0, 2**31 - 1),
)
def test_cone_and_twist_rows_are_the_derivatives_of_their_errors(xa, xb, seed):
    """Limits (1e-9, 0, 0) keep both rows beyond their limits at any pose, so their errors
    are the cone angle and the twist themselves: each row's (lin, ang_a, ang_b) matches the
    central differences of its error under world-frame turns of either body."""
    world = rbd.World()
    world.add_body(rbd.shapes.box((0.4, 0.2, 0.1)), position=(-0.25, 0, 0))
    world.add_body(rbd.shapes.box((0.3, 0.3, 0.2)), position=(0.2, 0, 0))
    joints = JointSet()
    joints.add(
        "spherical", 0, 1, np.zeros(3), np.array([0.3, 0.4, 1.0]), None, False, None,
        world.bodies, {"limits": (1e-9, 0.0, 0.0)},
    )  # fmt: skip
    f, code = joints.floats[0], JOINT_KINDS["spherical"]
    rng = np.random.default_rng(seed)
    qa, qb = Rotation.random(2, random_state=rng).as_quat()
    n = joint_row_count(code, f)
    assert n == 5

    def errors(qa, qb):
        out = np.zeros((6, 10))
        joint_rows(code, f, tuple(xa), tuple(qa), tuple(xb), tuple(qb), out, 0, False)
        return out[:n, 9]

    def turned(q, v):
        return (Rotation.from_rotvec(v) * Rotation.from_quat(q)).as_quat()

    rows = np.zeros((6, 10))
    joint_rows(code, f, tuple(xa), tuple(qa), tuple(xb), tuple(qb), rows, 0, False)
    twist = errors(qa, qb)[4]
    if abs(abs(twist) - np.pi) < 1e-3:
        return  # the twist wraps at a half turn: no derivative there
    eps = 1e-6
    for k in range(3):
        e = np.zeros(3)
        e[k] = eps
        d_ta = (errors(turned(qa, e), qb) - errors(turned(qa, -e), qb)) / (2 * eps)
        d_tb = (errors(qa, turned(qb, e)) - errors(qa, turned(qb, -e))) / (2 * eps)
        np.testing.assert_allclose(rows[3:5, 3 + k], d_ta[3:5], atol=1e-6)
        np.testing.assert_allclose(rows[3:5, 6 + k], d_tb[3:5], atol=1e-6)


def _cone_pendulum(cone):
    """A 1 kg ball on a 1 m massless-ish rod from a ball joint at the origin, held out level
    along +x at creation, the joint's axis along the rod: the cone bounds how far the rod
    may turn from level."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    ball = world.add_body(rbd.shapes.icosphere(0.02, 2), mass=1.0, position=(1.0, 0, 0))
    world.add_joint(
        "spherical", ball, None, anchor=(0, 0, 0), axis=(1, 0, 0),
        limits=(np.radians(30), -np.inf, np.inf),
    )  # fmt: skip
    return world, ball


def test_cone_limit_stops_a_falling_ball_on_its_cone():
    """Released level, the ball falls until its rod is 30 degrees below level, stops there
    (the rod's angle from level, from the ball's position, never more than 0.6 degrees past
    30 at any step's end) and comes to rest on the cone, within 0.01 degrees of it."""
    world, ball = _cone_pendulum(np.radians(30))
    worst = 0.0
    for _ in range(3 * 240):
        world.step()
        rod = world.bodies.position[ball]
        worst = max(worst, np.arccos(np.clip(rod[0] / np.linalg.norm(rod), -1, 1)))
    assert worst <= np.radians(30) + OVERSHOOT
    assert worst >= np.radians(29)  # it did reach the cone: a real test
    rod = world.bodies.position[ball]
    assert abs(np.arccos(rod[0] / np.linalg.norm(rod)) - np.radians(30)) <= AT_REST
    assert np.linalg.norm(world.bodies.linear_momentum[ball]) <= 1e-3


def test_twist_limit_stops_a_spinning_rod_at_its_limit():
    """A rod on a ball joint to the world, spun about its own axis at 4 rad/s (no gravity)
    with twist limits of +-0.5 rad: its turn about the axis (from its orientation) never
    passes 0.5 rad by more than 0.6 degrees and it ends at rest on the limit."""
    world = rbd.World(dt=1 / 240)
    rod = world.add_body(
        rbd.shapes.box((0.05, 0.05, 0.5)), mass=1.0, position=(0, 0, -0.25),
        angular_velocity=(0, 0, 4.0),
    )  # fmt: skip
    world.add_joint(
        "spherical", rod, None, anchor=(0, 0, 0), axis=(0, 0, 1), limits=(np.pi, -0.5, 0.5)
    )
    worst = 0.0
    for _ in range(240):
        world.step()
        turn = Rotation.from_quat(world.bodies.orientation[rod]).as_rotvec()
        worst = max(worst, turn[2])
    assert 0.5 - AT_REST <= worst <= 0.5 + OVERSHOOT
    assert Rotation.from_quat(world.bodies.orientation[rod]).as_rotvec()[2] == pytest.approx(
        0.5, abs=AT_REST
    )
    assert np.linalg.norm(world.bodies.angular_momentum[rod]) <= 1e-9


@pytest.mark.parametrize(
    "limits",
    [(0.0, -1, 1), (4.0, -1, 1), (np.nan, -1, 1), (1.0, 1, -1), (1.0, -4, 1), (1.0, 2)],
)
def test_bad_cone_or_twist_limits_are_refused(limits):
    world = rbd.World()
    body = world.add_body(rbd.shapes.box(), mass=1.0)
    with pytest.raises(ValueError, match=r"limits|cone|twist"):
        world.add_joint("spherical", body, None, anchor=(0, 0, 0.5), limits=limits)
