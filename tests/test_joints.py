"""Joints against analytic answers and the oracles of reference_joints.py.

Gaps and angle errors are the maximum over the whole run, first step included, as the
campaign measures them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import reference_joints as ref
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import ellipk

import thesis_rbd as rbd
from thesis_rbd.collision.pipeline import some_pair_may_collide
from thesis_rbd.dynamics.joint_rows import equality_row_count, joint_rows
from thesis_rbd.dynamics.joint_set import JOINT_KINDS
from thesis_rbd.dynamics.joint_tree import (
    elimination_order,
    factor_tree,
    later_neighbours,
    left_solve,
    lu_in_place,
    solve_tree,
)
from thesis_rbd.scene import parse_scene

G = 9.81


def _ball(radius=0.02):
    return rbd.shapes.icosphere(radius, 3)


def _pendulum(degrees, dt=1 / 240, kind="revolute"):
    """A 1 kg ball of radius 2 cm, its centre 1 m from a hinge at the origin about +y,
    released at ``degrees`` from hanging."""
    world = rbd.World(dt=dt, gravity=(0, 0, -G))
    theta = np.radians(degrees)
    body = world.add_body(_ball(), mass=1.0, position=(np.sin(theta), 0, -np.cos(theta)))
    world.add_joint(kind, body, None, anchor=(0, 0, 0), axis=(0, 1, 0))
    return world, body


def _poses(world):
    b = world.bodies
    return [ref.pose(x, q) for x, q in zip(b.position, b.orientation, strict=True)]


def _run_max(world, steps, key):
    """Largest ``world.joints[key]`` over ``steps`` steps, each step read."""
    worst = 0.0
    for _ in range(steps):
        world.step()
        worst = max(worst, float(np.max(world.joints[key])))
    return worst


# ----------------------------------------------------------------------------- the pendulum
@pytest.mark.parametrize("degrees", [90, 150, 170])
def test_pendulum_keeps_the_exact_period_and_amplitude(degrees):
    """Mean of all full periods over 30 s within 0.01 % of the compound pendulum's exact
    period, amplitude kept to 99.9 %, hinge gap <= 1e-6 m at every step."""
    world, body = _pendulum(degrees)
    inertia = world.bodies.inertia_body[body][1, 1] + 1.0  # about the pivot
    theta0 = np.radians(degrees)
    exact = 4.0 * np.sqrt(inertia / G) * ellipk(np.sin(theta0 / 2) ** 2)
    steps = 30 * 240
    angle, times, gap = np.empty(steps), np.empty(steps), 0.0
    creation = _poses(world)[body]
    for k in range(steps):
        world.step()
        x, R = _poses(world)[body]
        angle[k] = np.arctan2(x[0], -x[2])
        times[k] = world.time
        # the oracle: the ball's attachment point carried to now, against the hinge
        gap = max(gap, np.linalg.norm(ref.attached((0, 0, 0), creation, (x, R))))
    up = np.flatnonzero((angle[:-1] < 0) & (angle[1:] >= 0))
    crossings = times[up] + (times[up + 1] - times[up]) * -angle[up] / (angle[up + 1] - angle[up])
    period = np.diff(crossings).mean()
    assert abs(period / exact - 1.0) <= 1e-4
    assert np.abs(angle).max() >= 0.999 * theta0
    assert np.abs(angle).max() <= theta0 * (1 + 1e-3)
    assert gap <= 1e-6


def test_hanging_pendulum_reports_its_weight_and_angle():
    """At rest, the world holds the ball up with its weight (force on a at the anchor, torque
    about the anchor zero); turning the ball about +axis reads a positive angle."""
    world = rbd.World(gravity=(0, 0, -G))
    body = world.add_body(_ball(), mass=2.0, position=(0, 0, -1))
    world.add_joint("revolute", body, None, anchor=(0, 0, 0), axis=(0, 1, 0))
    world.step(10)
    j = world.joints
    np.testing.assert_allclose(j["force"][0], (0, 0, 2.0 * G), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(j["torque"][0], 0.0, atol=1e-9)
    assert abs(j["position"][0]) < 1e-12
    # released at +x, the ball swings back towards hanging: about +y (which turns -z
    # towards -x), so its angle grows
    world2, ball = _pendulum(20)
    creation = _poses(world2)
    world2.step(5)
    now = _poses(world2)
    world_pose = ref.pose((0, 0, 0), (0, 0, 0, 1))
    expected = ref.hinge_angle((0, 1, 0), creation[ball], now[ball], world_pose, world_pose)
    assert world2.joints["position"][0] == pytest.approx(expected, abs=1e-9)
    assert expected > 0


# ----------------------------------------------------------------------------- every kind
def _two_bodies(kind, seed):
    """Two boxes jointed at a point between them, flying and spinning with random velocities
    in zero gravity."""
    rng = np.random.default_rng(seed)
    world = rbd.World(dt=1 / 240)
    a = world.add_body(rbd.shapes.box((0.4, 0.2, 0.1)), mass=1.0, position=(-0.25, 0, 0))
    b = world.add_body(rbd.shapes.box((0.3, 0.3, 0.2)), mass=3.0, position=(0.2, 0, 0))
    anchor = rng.uniform(-0.05, 0.05, 3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    anchor_b = anchor + (0.1, 0.02, 0.0) if kind == "distance" else None
    frame = _frame(axis, rng)
    world.add_joint(kind, a, b, anchor=anchor, anchor_b=anchor_b, **_kind_arguments(kind, frame))
    for body in (a, b):
        world.bodies.linear_momentum[body] = rng.normal(size=3)
        world.bodies.angular_momentum[body] = 0.1 * rng.normal(size=3)
    return world, anchor, frame, anchor_b


def _frame(axis, rng):
    """(3, 3) rows x = axis, y square to it at random, z = x cross y."""
    y = np.cross(axis, rng.normal(size=3))
    y /= np.linalg.norm(y)
    return np.stack([axis, y, np.cross(axis, y)])


# A generic joint here slides along x and turns about y and z: its rows are a line's and one
# square pair's (b's y against a's z), the case no other kind spells.
GENERIC_AXES = ("free", "locked", "locked", "locked", "free", "free")


def _kind_arguments(kind, frame):
    """add_joint's axis (and a generic joint's axes) for a joint of ``kind`` in ``frame``."""
    if kind == "universal":
        return {"axis": frame[:2]}
    if kind == "generic":
        return {"axis": frame[:2], "axes": GENERIC_AXES}
    return {"axis": frame[0]}


def _momenta(world):
    b = world.bodies
    linear = b.linear_momentum.sum(axis=0)
    angular = (np.cross(b.position, b.linear_momentum) + b.angular_momentum).sum(axis=0)
    return linear, angular


@pytest.mark.parametrize("kind", list(JOINT_KINDS))
def test_every_kind_holds_and_conserves_momentum(kind):
    """Two jointed bodies thrown spinning: the joint holds (oracle: the creation anchors and
    axes carried by each body), and the total linear and angular momentum stay to 1e-12."""
    world, anchor, frame, anchor_b = _two_bodies(kind, seed=JOINT_KINDS[kind])
    axis = frame[0]
    creation = _poses(world)
    linear0, angular0 = _momenta(world)
    scale = max(np.abs(linear0).max(), np.abs(angular0).max())
    gap = angle = 0.0
    for _ in range(480):
        world.step()
        now = _poses(world)
        a0, a1, b0, b1 = creation[0], now[0], creation[1], now[1]
        if kind == "distance":
            length = np.linalg.norm(np.asarray(anchor) - anchor_b)
            offset = ref.anchor_offset(anchor, a0, a1, b0, b1, anchor_b)
            gap = max(gap, abs(np.linalg.norm(offset) - length))
        elif kind in ("prismatic", "generic"):
            gap = max(gap, ref.off_line(anchor, axis, a0, a1, b0, b1))
        else:
            gap = max(gap, np.linalg.norm(ref.anchor_offset(anchor, a0, a1, b0, b1)))
        if kind == "revolute":
            angle = max(angle, ref.axis_misalignment(axis, a0, a1, b0, b1))
        elif kind in ("fixed", "prismatic"):
            angle = max(angle, ref.relative_rotation_angle(a0, a1, b0, b1))
        elif kind == "universal":  # b's x square to a's y
            angle = max(angle, ref.square_pair_error(frame[0], frame[1], a0, a1, b0, b1))
        elif kind == "generic":  # b's y square to a's z
            angle = max(angle, ref.square_pair_error(frame[1], frame[2], a0, a1, b0, b1))
    linear, angular = _momenta(world)
    assert gap <= 1e-10
    assert angle <= 1e-10
    np.testing.assert_allclose(linear, linear0, atol=1e-12 * scale)
    np.testing.assert_allclose(angular, angular0, atol=1e-12 * scale)
    # the readout agrees with the oracle's last values
    assert world.joints["gap"][0] <= 1e-10
    assert world.joints["angle_error"][0] <= 1e-10


def test_free_degrees_stay_free():
    """A hinge leaves the spin about its axis alone, a slider the motion along its axis: a
    body jointed to the world, spun about / pushed along the axis in zero gravity, keeps its
    speed and the joint reads position = rate * t (the hinge to the phase error of the free
    rotation's Cayley step, (h w)^2 / 12 of the angle)."""
    world = rbd.World(dt=1 / 240)
    wheel = world.add_body(rbd.shapes.cylinder(0.3, 0.1), mass=2.0, position=(0, 0, 0))
    world.add_joint("revolute", wheel, None, anchor=(0, 0, 0), axis=(0, 0, 1))
    slider = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=(2, 0, 0))
    world.add_joint("prismatic", slider, None, anchor=(2, 0, 0), axis=(1, 1, 0))
    world.bodies.angular_momentum[wheel] = world.bodies.inertia_body[wheel][2, 2] * np.array(
        [0, 0, 3.0]
    )
    world.bodies.linear_momentum[slider] = np.array([0.5, 0.5, 0.0])
    world.step(120)
    j = world.joints
    t = world.time
    assert j["velocity"][0] == pytest.approx(3.0, rel=1e-12)
    cayley = (3.0 / 240) ** 2 / 12
    assert j["position"][0] == pytest.approx(np.angle(np.exp(1j * 3.0 * t)), rel=1.01 * cayley)
    assert j["velocity"][1] == pytest.approx(np.sqrt(0.5), rel=1e-12)
    assert j["position"][1] == pytest.approx(np.sqrt(0.5) * t, rel=1e-9)


def test_slider_under_gravity_falls_along_its_axis():
    """A slider inclined at 30 deg: travel 1/2 g sin(30) t^2 to symplectic Euler's first-order
    error (g h t / 2 of the travel per second), and no motion across its line."""
    dt = 1 / 240
    world = rbd.World(dt=dt, gravity=(0, 0, -G))
    body = world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), mass=1.0)
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    world.add_joint("prismatic", body, None, anchor=(0, 0, 0), axis=(-c, 0, -s))
    world.step(240)
    t = world.time
    a = G * s
    travel = world.joints["position"][0]
    assert abs(travel - 0.5 * a * t * t) <= 0.5 * a * dt * t * 1.01
    assert world.joints["gap"][0] <= 1e-12


# ----------------------------------------------------------------------------- chains
def _chain(links, link_mass, bob_mass, horizontal, substeps="auto", kind="spherical"):
    """``links`` rods of 0.1 m from a hinge at the origin and a ball of radius 3 cm at the
    end, hanging down or held out along +x."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G), joint_substeps=substeps)
    length = 0.1
    direction = np.array([1.0, 0, 0]) if horizontal else np.array([0, 0, -1.0])
    extents = (length, 0.01, 0.01) if horizontal else (0.01, 0.01, length)
    rod = rbd.shapes.box(extents)
    previous = None
    for i in range(links):
        body = world.add_body(rod, mass=link_mass, position=(i + 0.5) * length * direction)
        world.add_joint(kind, body, previous, anchor=i * length * direction, axis=(0, 1, 0))
        previous = body
    bob = world.add_body(_ball(0.03), mass=bob_mass, position=(links * length + 0.03) * direction)
    world.add_joint(kind, bob, previous, anchor=links * length * direction, axis=(0, 1, 0))
    return world


@pytest.mark.parametrize(
    ("bob_mass", "horizontal", "bound"),
    [(10.0, False, 1e-5), (0.1, False, 1e-5), (10.0, True, 1e-3)],
    ids=["1:100 at rest", "equal masses at rest", "1:100 swung from horizontal"],
)
def test_light_chain_with_a_heavy_bob_does_not_stretch(bob_mass, horizontal, bound):
    """Ten 0.1 kg links of 0.1 m and a bob: gap <= 0.01 mm at rest, <= 1 mm swung."""
    world = _chain(10, 0.1, bob_mass, horizontal)
    assert _run_max(world, 480, "gap") <= bound


def test_hundred_link_chain_released_horizontal_holds_for_ten_seconds():
    """A chain of 100 links of 50 g and 0.1 m released horizontal (no bob, links that
    collide with nothing): every state finite and every gap within 1 mm over 10 s, the
    largest after every step; its energy (245 J released) kept to 1 %."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    rod = rbd.shapes.box((0.1, 0.01, 0.01))
    previous = None
    for i in range(100):
        body = world.add_body(rod, mass=0.05, position=((i + 0.5) * 0.1, 0, 0), collidable=False)
        world.add_joint("spherical", body, previous, anchor=(i * 0.1, 0, 0))
        previous = body
    start = world.kinetic_energy() + world.potential_energy()
    worst_gap, worst_energy = 0.0, 0.0
    for _ in range(10 * 240):
        world.step()
        worst_gap = max(worst_gap, world.joints["gap"].max())
        energy = world.kinetic_energy() + world.potential_energy()
        worst_energy = max(worst_energy, abs(energy - start))
    assert worst_gap <= 1e-3
    assert worst_energy <= 0.01 * 0.05 * 100 * G * 5.0  # 1 % of m g (L / 2) per link


def test_fixed_substeps_that_cannot_resolve_the_chain_fail_loudly():
    """One substep cannot follow a 1:100 chain swung from horizontal (h w > 1): the step
    raises with the world left as before it, instead of drifting apart."""
    world = _chain(10, 0.1, 10.0, True, substeps=1)
    with pytest.raises(rbd.NonFiniteStateError):
        world.step(480)


# ----------------------------------------------------------------------------- kernels
def _quaternion(data):
    q = np.array(data.draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4)))
    if np.linalg.norm(q) < 0.1:
        q = np.array([0.0, 0.0, 0.0, 1.0])
    return q / np.linalg.norm(q)


@settings(max_examples=40)
@given(st.sampled_from(list(JOINT_KINDS)), st.data())
def test_row_jacobians_match_finite_differences(kind, data):
    """Each row's (lin, ang_a, ang_b) is the derivative of its error under small motions of
    either body (central differences, world-frame rotations), at poses away from creation."""
    world = rbd.World()
    a = world.add_body(rbd.shapes.box((0.4, 0.2, 0.1)), position=(-0.25, 0, 0))
    b = world.add_body(rbd.shapes.box((0.3, 0.3, 0.2)), position=(0.2, 0, 0))
    anchor_b = (0.1, 0.05, 0.0) if kind == "distance" else None
    frame = _frame(np.array([0.3, 0.4, 1.0]) / np.linalg.norm([0.3, 0.4, 1.0]),
                   np.random.default_rng(0))  # fmt: skip
    arguments = _kind_arguments(kind, frame)
    if kind == "generic":
        # a row of every sort: locked travel and turn, limited travel and Cardan turn (limits
        # this narrow are passed at every pose drawn, so their rows are written with errors)
        arguments["axes"] = ((-1e-9, 1e-9), "locked", "free", "locked", (-1e-9, 1e-9), "free")
    world.add_joint(kind, a, b, anchor=(0, 0, 0), anchor_b=anchor_b, **arguments)
    f = world._joints.floats[0]
    code = JOINT_KINDS[kind]
    xa = tuple(data.draw(st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3)))
    xb = tuple(data.draw(st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3)))
    qa, qb = tuple(_quaternion(data)), tuple(_quaternion(data))
    rows = np.zeros((6, 10))
    n = joint_rows(code, f, xa, qa, xb, qb, rows, 0, False)

    def errors(xa, qa, xb, qb):
        out = np.zeros((6, 10))
        joint_rows(code, f, tuple(xa), tuple(qa), tuple(xb), tuple(qb), out, 0, False)
        return out[:n, 9]

    def turned(q, v):
        from scipy.spatial.transform import Rotation

        return (Rotation.from_rotvec(v) * Rotation.from_quat(q)).as_quat()

    eps = 1e-6
    # a limit row's error has a kink at its limit: rows within a step's reach of one have no
    # derivative there to compare
    smooth = np.ones(n, bool)
    held = equality_row_count(code, f)
    smooth[held:] = np.abs(errors(xa, qa, xb, qb)[held:]) > 10 * eps
    for k in range(3):
        e = np.zeros(3)
        e[k] = eps
        d_xa = (errors(np.add(xa, e), qa, xb, qb) - errors(np.subtract(xa, e), qa, xb, qb)) / (
            2 * eps
        )
        d_ta = (errors(xa, turned(qa, e), xb, qb) - errors(xa, turned(qa, -e), xb, qb)) / (2 * eps)
        d_xb = (errors(xa, qa, np.add(xb, e), qb) - errors(xa, qa, np.subtract(xb, e), qb)) / (
            2 * eps
        )
        d_tb = (errors(xa, qa, xb, turned(qb, e)) - errors(xa, qa, xb, turned(qb, -e))) / (2 * eps)
        written = rows[:n][smooth]
        np.testing.assert_allclose(written[:, k], d_xa[smooth], atol=1e-6)
        np.testing.assert_allclose(-written[:, k], d_xb[smooth], atol=1e-6)
        if kind in ("fixed", "prismatic"):
            # the orientation rows' Jacobian is the identity at zero error; away from it the
            # Newton step only needs it close (the error is a rotation vector)
            continue
        np.testing.assert_allclose(written[:, 3 + k], d_ta[smooth], atol=1e-6)
        np.testing.assert_allclose(written[:, 6 + k], d_tb[smooth], atol=1e-6)


@settings(max_examples=30)
@given(st.integers(2, 12), st.integers(0, 3), st.integers(0, 2**32 - 1))
def test_factor_drops_redundant_rows_and_solves_the_rest(size, redundant, seed):
    """The L U with dropped pivots solves a consistent system whose matrix repeats some rows
    (a closed loop's redundant constraints) to round-off, against numpy's least squares."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(size, 3 * size))
    for r in range(min(redundant, size - 1)):
        J[size - 1 - r] = J[r] * rng.uniform(0.5, 2.0) + J[(r + 1) % (size - 1)]
    K = J @ J.T
    rhs = K @ rng.normal(size=(size, 3))  # consistent, three columns solved at once
    factor = K.copy()
    kept = np.empty(size, bool)
    lu_in_place(factor, size, kept)
    x = rhs.copy()
    left_solve(factor, kept, size, x, 0)
    assert kept.sum() == np.linalg.matrix_rank(K)
    np.testing.assert_allclose(K @ x, rhs, atol=1e-8 * np.abs(rhs).max())


# ----------------------------------------------------------------------------- the world
def test_jointed_bodies_do_not_collide_unless_asked():
    """Two overlapping boxes jointed together produce no contacts; with collide=True, or
    without the joint, they do; exclude_pair removes a pair without a joint."""

    def world_with(collide=None, exclude=False):
        world = rbd.World(dt=1 / 240)
        a = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), position=(0, 0, 0))
        b = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), position=(0.15, 0, 0))
        if collide is not None:
            world.add_joint("fixed", a, b, anchor=(0.075, 0, 0), collide=collide)
        if exclude:
            world.exclude_pair(a, b)
        world.step()
        return len(world.contacts["body_a"])

    assert world_with() > 0
    assert world_with(collide=True) > 0
    assert world_with(collide=False) == 0
    assert world_with(exclude=True) == 0


def test_a_scene_without_joints_runs_no_joint_stage():
    world = rbd.World(gravity=(0, 0, -G))
    world.add_body(_ball(), mass=1.0)
    assert "joints" not in world.stages
    world.add_joint("spherical", 0, None, anchor=(0, 0, 0.5))
    assert world.stages == ["forces", "integrate", "joints"]


_BAD_JOINTS = {
    "unknown joint kind 'hinge'": dict(kind="hinge"),
    "zero length": dict(axis=(0, 0, 0)),
    "jointed to itself": dict(body_b=0),
    "far from both bodies": dict(anchor=(50, 0, 0)),
    "body_b: no body 7": dict(body_b=7),
    "anchor holds a non-finite": dict(anchor=(0, np.nan, 0)),
    "anchor_b apart": dict(kind="distance"),
    "anchor_b is for distance": dict(anchor_b=(1, 0, 0)),
    "immovable": dict(body_a=2, body_b=None),
    "body_a must be a body index": dict(body_a=1.5),
    "limits out of order": dict(kind="revolute", limits=(1.0, -1.0)),
    "lie in \\[-pi, pi\\]": dict(kind="revolute", limits=(-4.0, 0.0)),
    "limits must be \\(lower, upper\\)": dict(kind="prismatic", limits=(1.0,)),
    "limits must be numbers": dict(kind="prismatic", limits=(np.nan, 1.0)),
    "joint name must be a non-empty string": dict(name=""),
}


@pytest.mark.parametrize("message", list(_BAD_JOINTS))
def test_bad_joints_are_refused_naming_the_field(message):
    """Each fault of add_joint's input is a ValueError naming it, and no joint is added."""
    world = rbd.World()
    world.add_body(rbd.shapes.box(), position=(0, 0, 0))
    world.add_body(rbd.shapes.box(), position=(1, 0, 0))
    world.add_body(rbd.shapes.box(), position=(0, 3, 0), static=True)
    arguments = dict(kind="spherical", body_a=0, body_b=1, anchor=(0.5, 0, 0))
    arguments.update(_BAD_JOINTS[message])
    with pytest.raises(ValueError, match=message):
        world.add_joint(**arguments)
    assert len(world.joints["kind"]) == 0


def test_exclude_pair_needs_two_bodies():
    world = rbd.World()
    world.add_body(rbd.shapes.box())
    with pytest.raises(ValueError, match="two different bodies"):
        world.exclude_pair(0, 0)


@pytest.mark.parametrize("value", [0, -1, 1.5, True, "fast", 10_000])
def test_bad_joint_substeps_are_refused(value):
    with pytest.raises(ValueError, match="joint_substeps"):
        rbd.World(joint_substeps=value)


@settings(max_examples=30)
@given(st.integers(1, 14), st.integers(0, 2**32 - 1))
def test_tree_solve_matches_a_dense_solve(joints, seed):
    """The block elimination of joint_tree on a random tree of joints (1-6 rows each, each
    joint's body jointed to an earlier body or the world) solves the same system as numpy
    on the assembled dense matrix."""
    rng = np.random.default_rng(seed)
    a = np.arange(joints)
    b = np.array([rng.integers(-1, i) if i else -1 for i in range(joints)])
    static = np.zeros(joints, bool)
    depth, tree = elimination_order(a, b, static, np.zeros(joints, np.int64), 1)
    assert tree.all()
    order = np.argsort(-depth, kind="stable")
    start, neighbour = later_neighbours(a, b, static, order, np.array([0, joints]))
    rows = rng.integers(1, 7, joints)
    row_start = np.concatenate([[0], np.cumsum(rows)])
    # K = J W^T with W a perturbed J: a joint's rows touch its two bodies only
    size = int(row_start[-1])
    J = np.zeros((size, 6 * joints))
    for e, j in enumerate(order):
        for body in (a[j], b[j]):
            if body >= 0:
                block = rng.normal(size=(rows[e], 6))
                J[row_start[e] : row_start[e + 1], 6 * body : 6 * body + 6] = block
    K = J @ (J + 0.01 * rng.normal(size=J.shape) * (J != 0)).T
    self_slot = np.concatenate([[0], np.cumsum(1 + np.diff(start))])
    slot_neighbour = np.full(self_slot[-1], -1)
    for e in range(joints):
        slot_neighbour[self_slot[e] + 1 : self_slot[e + 1]] = neighbour[start[e] : start[e + 1]]
    upper = np.zeros((self_slot[-1], 6, 6))
    lower = np.zeros((self_slot[-1], 6, 6))
    for e in range(joints):
        for s in range(self_slot[e], self_slot[e + 1]):
            f = e if s == self_slot[e] else slot_neighbour[s]
            re, rf = slice(row_start[e], row_start[e + 1]), slice(row_start[f], row_start[f + 1])
            upper[s, : rows[e], : rows[f]] = K[re, rf]
            lower[s, : rows[f], : rows[e]] = K[rf, re]
    kept = np.zeros((joints, 6), bool)
    factor_tree(rows, self_slot, slot_neighbour, upper, lower, kept)
    rhs = rng.normal(size=(size, 3))  # three columns solved at once
    x = rhs.copy()
    solve_tree(rows, row_start, self_slot, slot_neighbour, upper, lower, kept, x)
    assert kept[np.arange(6) < rows[:, None]].all()
    # backward error: the solve is exact for a matrix within round-off of K
    assert np.abs(K @ x - rhs).max() <= 1e-10 * np.abs(K).sum(axis=1).max() * np.abs(x).max()


def test_islands_are_solved_alike_wherever_they_come_in_the_world():
    """A swinging Y (a rod hinged to the world, two rods hinged to its end) moves bit for
    bit alike alone and as the second island, after a five-link chain: each island's Newton
    matrix is laid out from its own joints' neighbours (the second island's once read the
    first's, a wrong layout, here a neighbour beyond the island, read out of bounds)."""
    box = rbd.shapes.box((0.3, 0.05, 0.05))

    def add_chain(world):
        links = [world.add_body(box, position=(0.15 + 0.3 * k, 3.0, 0), collidable=False)
                 for k in range(5)]  # fmt: skip
        world.add_joint("revolute", links[0], None, anchor=(0, 3.0, 0), axis=(0, 1, 0))
        for k in range(1, 5):
            world.add_joint("revolute", links[k], links[k - 1], anchor=(0.3 * k, 3.0, 0),
                            axis=(0, 1, 0))  # fmt: skip

    def add_y(world):
        root = world.add_body(box, position=(0.15, 0, 0), collidable=False)
        world.add_joint("revolute", root, None, anchor=(0, 0, 0), axis=(0, 1, 0))
        for side in (-1, 1):
            arm = world.add_body(box, position=(0.45, 0.06 * side, 0), collidable=False)
            world.add_joint("revolute", arm, root, anchor=(0.3, 0.06 * side, 0),
                            axis=(0, 1, 0))  # fmt: skip

    def y_after(builders) -> tuple:
        world = rbd.World(dt=1 / 240, gravity=(0, 0, -G), joint_substeps=2)
        for build in builders:
            build(world)
        world.step(120)
        return world.positions[-3:], world.orientations[-3:]

    alone, second = y_after([add_y]), y_after([add_chain, add_y])
    np.testing.assert_array_equal(alone[0], second[0])
    np.testing.assert_array_equal(alone[1], second[1])


def test_a_closed_loop_is_held_with_its_redundant_rows():
    """A parallelogram four-bar (two cranks hinged to the world, a coupler hinged to both):
    its loop repeats constraints, which the dense solve drops, and the loop holds to 0.1 mm
    swinging under gravity from 60 deg, staying in its plane."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    crank = rbd.shapes.box((0.02, 0.02, 0.4))
    s, c = np.sin(np.radians(60)), np.cos(np.radians(60))
    tip = 0.4 * np.array([s, 0, -c])
    turn = (0, np.sin(np.radians(30)), 0, np.cos(np.radians(30)))
    left = world.add_body(crank, mass=1.0, position=0.5 * tip, orientation=turn)
    right = world.add_body(crank, mass=1.0, position=0.5 * tip + (0.5, 0, 0), orientation=turn)
    coupler = world.add_body(
        rbd.shapes.box((0.5, 0.02, 0.02)), mass=2.0, position=tip + (0.25, 0, 0)
    )
    y = (0, 1, 0)
    world.add_joint("revolute", left, None, anchor=(0, 0, 0), axis=y)
    world.add_joint("revolute", right, None, anchor=(0.5, 0, 0), axis=y)
    world.add_joint("revolute", coupler, left, anchor=tip, axis=y)
    world.add_joint("revolute", coupler, right, anchor=tip + (0.5, 0, 0), axis=y)
    tree = world._joints.islands(world.bodies.static)[4]
    assert not tree.any()  # the island is a loop: solved densely
    assert _run_max(world, 480, "gap") <= 1e-4
    assert abs(world.bodies.position[coupler][1]) < 1e-9


# ----------------------------------------------------------------------------- scene files
_SCENE = """
[world]
gravity = [0.0, 0.0, -9.81]
joint_substeps = {substeps}

[[body]]
name = "ball"
shape = {{ type = "icosphere", radius = 0.02, subdivisions = 3 }}
mass = 1.0
position = [1.0, 0.0, 0.0]

[[joint]]
{joint}
"""


def _scene(joint, substeps='"auto"'):
    return parse_scene(_SCENE.format(joint=joint, substeps=substeps), "s", "s.toml", Path("."))


def test_a_scene_file_joint_builds_the_same_world_as_add_joint():
    scene = _scene('kind = "revolute"\nbody_a = "ball"\nanchor = [0, 0, 0]\naxis = [0, 1, 0]')
    built = scene.build()
    direct, _ = _pendulum(90)
    built.step(100)
    direct.step(100)
    # (the direct pendulum starts at (sin 90, 0, -cos 90): 6e-17 off the scene's)
    np.testing.assert_allclose(built.positions, direct.positions, atol=1e-12)
    assert built.joints["kind"].tolist() == ["revolute"]


@pytest.mark.parametrize(
    ("joint", "substeps", "message"),
    [
        ('kind = "revolute"\nanchor = [0, 0, 0]', '"auto"', "joint\\[0\\]: missing 'body_a'"),
        ('kind = "revolute"\nbody_a = "bal"\nanchor = [0, 0, 0]', '"auto"', "did you mean 'ball'"),
        ('kind = "hinge"\nbody_a = "ball"\nanchor = [0, 0, 0]', '"auto"', "unknown joint kind"),
        ('kind = "revolute"\nbody_a = "ball"\nanchor = [0, 0]', '"auto"', "anchor"),
        ('kind = "revolute"\nbody_a = "ball"\nanchor = [0, 0, 0]\nlimit = 1', '"auto"',
         "unknown key 'limit'"),
        ('kind = "revolute"\nbody_a = "ball"\nanchor = [0, 0, 0]', "0", "joint_substeps"),
    ],
)  # fmt: skip
def test_bad_scene_joints_name_the_table_and_field(joint, substeps, message):
    with pytest.raises(rbd.SceneError, match=message):
        _scene(joint, substeps).build()


@pytest.mark.parametrize("name", ["pendulum", "double_pendulum", "heavy_chain", "four_bar"])
def test_built_in_jointed_scenes_hold_their_joints(name):
    """Each built-in jointed scene runs a second with every joint held to 1e-9 m."""
    world = rbd.scenes.get(name).build()
    assert _run_max(world, 240, "gap") <= 1e-9


# ----------------------------------------------------------------------------- limits
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_hinge_limit_stops_the_swing_without_overshoot(side):
    """A 1 kg ball 0.8 m from a hinge, released horizontal, limit 70 deg below: overshoot
    <= 0.6 deg at every step, and at rest within 0.01 deg of the limit (mirrored: the
    lower limit of a swing the other way)."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    ball = world.add_body(_ball(), mass=1.0, position=(0.8 * side, 0, 0))
    limit = np.radians(70)
    limits = (-np.inf, limit) if side > 0 else (-limit, np.inf)
    world.add_joint("revolute", ball, None, anchor=(0, 0, 0), axis=(0, 1, 0), limits=limits)
    creation = _poses(world)[ball]
    world_pose = ref.pose((0, 0, 0), (0, 0, 0, 1))
    overshoot = 0.0
    for _ in range(3 * 240):
        world.step()
        angle = side * ref.hinge_angle((0, 1, 0), creation, _poses(world)[ball], world_pose,
                                       world_pose)  # fmt: skip
        overshoot = max(overshoot, angle - limit)
    assert np.degrees(overshoot) <= 0.6
    assert abs(np.degrees(angle - limit)) <= 0.01
    assert abs(world.joints["velocity"][0]) < 1e-9


def test_slider_limits_hold_both_ways():
    """A slider along x between -0.1 and 0.2 m pushed at 1 m/s one way then the other: it
    stops at each limit (restitution 0) and never passes it."""
    world = rbd.World(dt=1 / 240)
    body = world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), mass=1.0)
    world.add_joint("prismatic", body, None, anchor=(0, 0, 0), axis=(1, 0, 0), limits=(-0.1, 0.2))
    world.bodies.linear_momentum[body] = (1.0, 0.0, 0.0)
    travel = []
    for _ in range(120):
        world.step()
        travel.append(world.bodies.position[body][0])
    assert max(travel) <= 0.2 + 1e-12
    assert travel[-1] == pytest.approx(0.2, abs=1e-12)
    assert abs(world.linear_velocity(body)[0]) < 1e-9
    world.bodies.linear_momentum[body] = (-1.0, 0.0, 0.0)
    for _ in range(120):
        world.step()
        travel.append(world.bodies.position[body][0])
    assert min(travel) >= -0.1 - 1e-12
    assert travel[-1] == pytest.approx(-0.1, abs=1e-12)


# ----------------------------------------------------------------------------- motors
def test_slider_velocity_motor_reaches_its_target_at_its_force_cap():
    """A 1 kg slider, 1 m/s target, 2 N cap: it accelerates at 2 m/s^2, so it reaches 99 %
    of the target at 0.495 s (within 1 %), and never passes the target by more than 0.1 %;
    the motor reports its 2 N while accelerating."""
    dt = 1 / 240
    world = rbd.World(dt=dt)
    body = world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), mass=1.0)
    motor = {"velocity": 1.0, "max_force": 2.0}
    world.add_joint("prismatic", body, None, anchor=(0, 0, 0), axis=(1, 0, 0), motor=motor)
    speeds, forces = [], []
    for _ in range(240):
        world.step()
        speeds.append(world.joints["velocity"][0])
        forces.append(world.joints["motor_force"][0])
    speeds = np.array(speeds)
    reached = (np.argmax(speeds >= 0.99) + 1) * dt
    assert reached == pytest.approx(0.495, rel=0.01)
    assert speeds.max() <= 1.001
    assert speeds[-1] == pytest.approx(1.0, rel=1e-9)
    assert forces[10] == pytest.approx(2.0, rel=1e-9)
    assert abs(forces[-1]) < 1e-9


def test_hinge_torque_motor_spins_a_wheel_as_newton_says():
    """A set torque on a wheel hinged to the world in zero gravity: w = tau t / I about the
    axis (the wheel's own moment of inertia), and switching the motor off keeps that rate."""
    world = rbd.World(dt=1 / 240)
    wheel = world.add_body(rbd.shapes.cylinder(0.3, 0.1), mass=2.0)
    joint = world.add_joint(
        "revolute", wheel, None, anchor=(0, 0, 0), axis=(0, 0, 1), motor={"torque": 0.5}
    )
    world.step(120)
    inertia = world.bodies.inertia_body[wheel][2, 2]
    rate = 0.5 * world.time / inertia
    assert world.joints["velocity"][0] == pytest.approx(rate, rel=1e-9)
    assert world.joints["motor_force"][0] == pytest.approx(0.5, rel=1e-12)
    world.set_motor(joint)
    world.step(60)
    assert world.joints["velocity"][0] == pytest.approx(rate, rel=1e-9)


def test_a_motor_between_two_free_bodies_conserves_momentum():
    """A hinge motor spinning two floating, tumbling bodies against each other: their total
    linear and angular momentum stay where they were (equal and opposite impulses), and the
    hinge turns near its target (the motor sets the rate before the bodies move; their
    tumbling changes it within the substep, by about h w^2)."""
    world, *_ = _two_bodies("revolute", seed=5)
    world.set_motor(0, velocity=3.0, max_force=5.0)
    linear0, angular0 = _momenta(world)
    world.step(240)
    linear, angular = _momenta(world)
    assert world.joints["velocity"][0] == pytest.approx(3.0, abs=0.1)
    np.testing.assert_allclose(linear, linear0, atol=1e-12)
    np.testing.assert_allclose(angular, angular0, atol=1e-12)


@pytest.mark.parametrize(
    ("motor", "error", "message"),
    [
        ({"velocity": 1.0}, ValueError, "give"),
        ({"velocity": 1.0, "max_force": -1.0}, ValueError, "max_force must be >= 0"),
        ({"torque": np.inf}, ValueError, "motor torque must be finite"),
        ({"position": 0.5, "stiffness": 10.0}, ValueError, "give"),
        ({"servo": 5.0}, ValueError, "lies in \\[-pi, pi\\]"),
        ({"servo": 0.5, "max_velocity": -1.0}, ValueError, "max_velocity must be >= 0"),
        ("fast", ValueError, "motor must be a dict"),
    ],
)
def test_bad_motors_are_refused(motor, error, message):
    world = rbd.World()
    world.add_body(rbd.shapes.box())
    with pytest.raises(error, match=message):
        world.add_joint("revolute", 0, None, anchor=(0, 0, 0), motor=motor)
    with pytest.raises(ValueError, match="no joint 3"):
        world.set_motor(3, torque=1.0)


def test_four_bar_swings_with_the_period_its_inertias_give():
    """The built-in parallelogram four-bar from 60 deg: the coupler translates without
    turning, so the linkage is one compound pendulum of inertia 2 I_crank + M L^2 about the
    pivots and gravity moment (2 m L / 2 + M L) g sin(theta); the mean period over 5 s is
    within 0.05 % of 4 sqrt(I / (m_eff g)) K(sin^2(theta0 / 2)), the loop gap <= 0.1 mm."""
    world = rbd.scenes.get("four_bar").build()
    left, coupler = 0, 2
    b = world.bodies
    m, M, length = b.mass[left], b.mass[coupler], 0.4
    crank_axis = b.inertia_body[left][1, 1] + m * (length / 2) ** 2  # about its pivot
    inertia = 2 * crank_axis + M * length**2
    moment = (2 * m * length / 2 + M * length) * G
    theta0 = np.radians(60)
    exact = 4 * np.sqrt(inertia / moment) * ellipk(np.sin(theta0 / 2) ** 2)
    angle, times, gap = [], [], 0.0
    for _ in range(5 * 240):
        world.step()
        tip = world.bodies.position[coupler] - (0.25, 0, 0)
        angle.append(np.arctan2(tip[0], -tip[2]))
        times.append(world.time)
        gap = max(gap, world.joints["gap"].max())
    angle, times = np.array(angle), np.array(times)
    up = np.flatnonzero((angle[:-1] < 0) & (angle[1:] >= 0))
    crossings = times[up] + (times[up + 1] - times[up]) * -angle[up] / (angle[up + 1] - angle[up])
    assert len(crossings) >= 3
    assert abs(np.diff(crossings).mean() / exact - 1) <= 5e-4
    assert gap <= 1e-4


@pytest.mark.parametrize(
    ("group_a", "mask_a", "group_b", "mask_b", "collide"),
    [(1, 0xFFFF, 1, 0xFFFF, True), (1, 4, 2, 0xFFFF, False), (2, 1, 1, 2, True),
     (4, 0xFFFF, 1, 3, False), (0, 0xFFFF, 1, 0xFFFF, False)],
)  # fmt: skip
def test_collision_groups_and_masks_follow_bullets_rule(group_a, mask_a, group_b, mask_b, collide):
    """Two overlapping boxes collide only if each one's group shares a bit with the other's
    mask (checked against the rule written out here)."""
    world = rbd.World(dt=1 / 240)
    box = rbd.shapes.box((0.2, 0.2, 0.2))
    world.add_body(box, collision_group=group_a, collision_mask=mask_a)
    world.add_body(box, position=(0.15, 0, 0), collision_group=group_b, collision_mask=mask_b)
    world.step()
    assert collide == (bool(group_a & mask_b) and bool(group_b & mask_a))
    assert (len(world.contacts["body_a"]) > 0) == collide


@settings(max_examples=80, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 7), st.integers(0, 7), st.booleans(), st.booleans()),
        min_size=0, max_size=6,
    ),
    st.sets(st.tuples(st.integers(0, 5), st.integers(0, 5)), max_size=15),
)  # fmt: skip
def test_some_pair_may_collide_agrees_with_every_pair(specs, exclusions):
    """The planner's test of whether any pair may collide (over kinds of bodies, pairs
    listed only where exclusions might cover them all) agrees with the pair-by-pair rule;
    a world with no such pair plans no collision stage."""
    world = rbd.World(dt=1 / 240)
    for k, (group, mask, static, collidable) in enumerate(specs):
        world.add_body(
            rbd.shapes.box(), position=(3.0 * k, 0, 0), static=static, collidable=collidable,
            collision_group=group, collision_mask=mask,
        )  # fmt: skip
    excluded = {(min(a, b), max(a, b)) for a, b in exclusions if a != b and max(a, b) < len(specs)}
    for a, b in excluded:
        world.exclude_pair(a, b)
    expected = any(
        a[3] and b[3] and not (a[2] and b[2]) and (a[0] & b[1]) and (b[0] & a[1])
        and (i, i + 1 + k) not in excluded
        for i, a in enumerate(specs)
        for k, b in enumerate(specs[i + 1 :])
    )  # fmt: skip
    pairs = np.array(sorted(excluded), np.int64).reshape(-1, 2)
    assert some_pair_may_collide(world.bodies, pairs) == expected
    world.step()
    moving = any(not spec[2] for spec in specs)
    assert (world.profile["bounds"]["calls"] > 0) == (expected and moving)


@pytest.mark.parametrize("value", [-1, 1.5, True, 2**62])
def test_bad_collision_groups_are_refused(value):
    world = rbd.World()
    with pytest.raises(ValueError, match="collision_group"):
        world.add_body(rbd.shapes.box(), collision_group=value)


def _wheel(motor):
    world = rbd.World(dt=1 / 240)
    wheel = world.add_body(rbd.shapes.cylinder(0.3, 0.1), mass=2.0)
    world.add_joint("revolute", wheel, None, anchor=(0, 0, 0), axis=(0, 0, 1), motor=motor)
    return world, world.bodies.inertia_body[wheel][2, 2]


def test_position_motor_rings_at_its_damped_frequency_and_settles_on_target():
    """A wheel held by a position motor (stiffness k, damping c) towards 0.5 rad: it rings at
    the damped frequency sqrt(k/I - (c/2I)^2) (within 1 %) and comes to rest on the target."""
    inertia = _wheel(None)[1]
    k, c = (2 * np.pi) ** 2 * inertia, 0.4 * np.pi * inertia  # 1 Hz, damping ratio 0.1
    world, _ = _wheel({"position": 0.5, "stiffness": k, "damping": c})
    angle, times = [], []
    for _ in range(4 * 240):
        world.step()
        angle.append(world.joints["position"][0] - 0.5)
        times.append(world.time)
    angle, times = np.array(angle), np.array(times)
    up = np.flatnonzero((angle[:-1] < 0) & (angle[1:] >= 0))
    crossings = times[up] + (times[up + 1] - times[up]) * -angle[up] / (angle[up + 1] - angle[up])
    damped = np.sqrt(k / inertia - (c / (2 * inertia)) ** 2) / (2 * np.pi)
    assert 1.0 / np.diff(crossings).mean() == pytest.approx(damped, rel=0.01)
    world.step(20 * 240)
    assert world.joints["position"][0] == pytest.approx(0.5, abs=1e-6)


def test_a_very_stiff_position_motor_stays_stable():
    """Stiffness 1e9 N m/rad on a wheel of inertia 0.09: far beyond what an explicit spring
    could take at 240 Hz (h w ~ 400), the implicit motor still settles on its target."""
    world, _ = _wheel({"position": -1.0, "stiffness": 1e9, "damping": 1.0})
    world.step(240)
    assert world.joints["position"][0] == pytest.approx(-1.0, abs=1e-6)


def test_capped_servo_brakes_before_its_target():
    """A servo capped at 5 N m turns a hinged rod (no gravity) 1 rad: it can accelerate at
    a = 5 / I at most, so the time-optimal move (full torque, then full braking) takes
    2 sqrt(1 / a). It brakes on the curve v = sqrt(2 a e) and arrives without ringing; a
    servo that only braked on arriving overshot by 0.97 rad and never settled."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, 0))
    rod = world.add_body(rbd.shapes.box((0.1, 0.1, 1.0)), mass=2.0, position=(0, 0, -0.5))
    world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(1, 0, 0))
    world.set_motor(0, servo=1.0, max_force=5.0)
    inertia = 2.0 * (0.01 + 1.0) / 12 + 2.0 * 0.25
    fastest = 2.0 * math.sqrt(1.0 / (5.0 / inertia))
    angles = []
    for _ in range(2 * 240):
        world.step()
        angles.append(world.joints["position"][0])
    angles = np.array(angles)
    assert angles.max() - 1.0 < 0.01
    settled = np.flatnonzero(np.abs(angles - 1.0) > 1e-3).max() + 1
    assert settled / 240 < 1.3 * fastest
    assert abs(angles[-1] - 1.0) < 1e-9


def test_uncapped_servo_turns_to_a_distant_target():
    """An uncapped servo asked for 3 rad: it turns at most a quarter radian per substep,
    which the joint's projection follows (asking for the whole turn in one substep, at a
    rate that grew as the failed substeps were halved, went non-finite)."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
    rod = world.add_body(rbd.shapes.box((0.1, 0.1, 1.0)), mass=2.0, position=(0, 0, -0.5))
    world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(1, 0, 0))
    world.set_motor(0, servo=3.0)
    world.step(30)
    assert world.joints["position"][0] == pytest.approx(3.0, abs=1e-9)


def test_a_servo_given_its_targets_velocity_tracks_a_moving_target():
    """A hinged rod (no gravity) follows q(t) = A sin(w t), its servo given q and the rate
    q' at the start of each step. Without the rate the servo reaches each target a step late
    (an error of about A w dt); with it, the target moves on at q' and is met where it will
    be, the error that of the rate's change over the step (A w^2 dt^2 / 2). The target also
    moves on over a step's substeps, and past +-pi."""
    A, w, dt = 0.8, 2.0 * np.pi, 1 / 240

    def tracking_error(feed: bool, substeps) -> float:
        world = rbd.World(dt=dt, gravity=(0, 0, 0), joint_substeps=substeps)
        rod = world.add_body(rbd.shapes.box((0.1, 0.1, 1.0)), mass=2.0, position=(0, 0, -0.5))
        world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(1, 0, 0))
        worst = 0.0
        for k in range(240):
            t = k * dt
            rate = A * w * math.cos(w * t) if feed else 0.0
            world.set_motor(0, servo=A * math.sin(w * t), velocity=rate)
            world.step()
            worst = max(worst, abs(world.joints["position"][0] - A * math.sin(w * (t + dt))))
        return worst

    late = tracking_error(False, 1)
    assert late == pytest.approx(A * w * dt, rel=0.05)
    for substeps in (1, 4):
        assert tracking_error(True, substeps) < A * w**2 * dt**2
    # a target turning past pi moves on through -pi
    world = rbd.World(dt=dt, gravity=(0, 0, 0))
    rod = world.add_body(rbd.shapes.box((0.1, 0.1, 1.0)), mass=2.0, position=(0, 0, -0.5))
    world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(1, 0, 0))
    world.set_motor(0, servo=3.0, velocity=2.0)
    world.step(60)  # 0.25 s: to 3.5 rad, read as 3.5 - 2 pi
    assert world.joints["position"][0] == pytest.approx(3.5 - 2.0 * np.pi, abs=1e-6)


def test_servo_holds_a_pendulum_level_within_its_force_and_speed():
    """A servo holds a 1 kg ball 0.5 m from a hinge level against gravity (torque m g L =
    4.905 N m within a 10 N m cap), reporting that torque; with a 4 N m cap it cannot, and
    the ball falls; a servo capped at 0.5 rad/s turns 1 rad in 2 s."""

    def pendulum(servo):
        world = rbd.World(dt=1 / 240, gravity=(0, 0, -G))
        ball = world.add_body(_ball(), mass=1.0, position=(0.5, 0, 0))
        world.add_joint("revolute", ball, None, anchor=(0, 0, 0), axis=(0, 1, 0), motor=servo)
        return world

    held = pendulum({"servo": 0.0, "max_force": 10.0})
    held.step(240)
    assert abs(held.joints["position"][0]) < 1e-3
    assert abs(held.joints["motor_force"][0]) == pytest.approx(4.905, rel=0.01)
    weak = pendulum({"servo": 0.0, "max_force": 4.0})
    weak.step(240)
    assert weak.joints["position"][0] > 0.5
    world, _ = _wheel({"servo": 1.0, "max_velocity": 0.5})
    rates = []
    for _ in range(3 * 240):
        world.step()
        rates.append(world.joints["velocity"][0])
    assert max(rates) <= 0.5 + 1e-9
    assert world.joints["position"][0] == pytest.approx(1.0, abs=1e-9)
