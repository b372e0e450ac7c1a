"""Distance joints (rope, spring) and the forces in joints (friction, viscous damping)
against analytic answers and the oracles of reference_joints.py.

Lengths and gaps are the maximum over the whole run, first step included.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import reference_joints as ref
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.dynamics.joint_rows import joint_rows
from thesis_rbd.scene import parse_scene

G = 9.81
DT = 1 / 240


def _ball(radius=0.02):
    return rbd.shapes.icosphere(radius, 3)


def _upward_crossings(times, signal):
    """Times where ``signal`` crosses zero upwards, linearly interpolated."""
    up = np.flatnonzero((signal[:-1] < 0) & (signal[1:] >= 0))
    return times[up] + (times[up + 1] - times[up]) * -signal[up] / (signal[up + 1] - signal[up])


def _momenta(world):
    b = world.bodies
    linear = b.linear_momentum.sum(axis=0)
    angular = (np.cross(b.position, b.linear_momentum) + b.angular_momentum).sum(axis=0)
    return linear, angular


# ----------------------------------------------------------------------------- springs
def _spring(stiffness, damping, dt=DT):
    """A 1 kg ball in zero gravity on a spring to the world at the origin, rest length 1 m,
    released 0.2 m stretched along +x."""
    world = rbd.World(dt=dt)
    ball = world.add_body(_ball(0.05), mass=1.0, position=(1.2, 0, 0))
    spring = {"stiffness": stiffness, "damping": damping, "rest_length": 1.0}
    world.add_joint("distance", ball, None, anchor=(1.2, 0, 0), anchor_b=(0, 0, 0), spring=spring)
    return world, ball


@pytest.mark.parametrize(
    ("ratio", "dt"), [(0.0, DT), (0.05, 1 / 1000)], ids=["undamped", "damping ratio 0.05"]
)
def test_spring_rings_at_its_frequency_and_decays_at_its_damping(ratio, dt):
    """A mass m on a spring k with damper c rings at w_d = sqrt(k/m - (c/2m)^2): the mean
    period over 10 s is within 0.1 % of 2 pi / w_d. Its amplitude decays as exp(-r t), r
    fitted to the swings' peaks: the damper's c / 2m plus the implicit step's own h k / 2m
    (numerics: ln(1 + h (k h + c) / m) / 2h to first order), within 1 %. The damped spring
    runs at 1 kHz: the implicit step takes the damper half a step late, which lengthens the
    period by about h c / 2m (0.15 % at 240 Hz)."""
    mass, stiffness = 1.0, (2 * np.pi) ** 2
    damping = 2 * ratio * np.sqrt(stiffness * mass)
    world, ball = _spring(stiffness, damping, dt)
    steps = round(10 / dt)
    stretch, times = np.empty(steps), np.empty(steps)
    for k in range(steps):
        world.step()
        stretch[k] = world.bodies.position[ball][0] - 1.0
        times[k] = world.time
    assert np.abs(world.bodies.position[ball][1:]).max() == 0.0  # along its line only
    damped = np.sqrt(stiffness / mass - (damping / (2 * mass)) ** 2)
    period = np.diff(_upward_crossings(times, stretch)).mean()
    assert period == pytest.approx(2 * np.pi / damped, rel=1e-3)
    peaks = np.flatnonzero((stretch[1:-1] > stretch[:-2]) & (stretch[1:-1] >= stretch[2:])) + 1
    rate = -np.polyfit(times[peaks], np.log(stretch[peaks]), 1)[0]
    assert rate == pytest.approx((damping + dt * stiffness) / (2 * mass), rel=0.01)
    # the readout: the joint's length and the spring's pull on the ball
    joint = world.joints
    assert joint["position"][0] == pytest.approx(1.0 + stretch[-1], abs=1e-12)
    assert joint["gap"][0] == 0.0  # a spring holds nothing rigidly


def test_a_very_stiff_spring_stays_stable():
    """Stiffness 1e9 N/m on a 1 kg ball (h w ~ 130 at 240 Hz, far past an explicit step's
    2): the implicit spring settles on its rest length instead of blowing up."""
    world, _ = _spring(1e9, 0.0)
    world.step(240)
    assert world.joints["position"][0] == pytest.approx(1.0, abs=1e-9)
    assert abs(world.joints["velocity"][0]) < 1e-6


# ----------------------------------------------------------------------------- ropes
def test_rope_pendulum_falls_freely_until_taut_then_never_stretches():
    """A ball on a 1 m rope from the origin, released at (0.6, 0, 0): inside the rope's
    circle it falls freely (z = -g t^2 / 2 to symplectic Euler's first-order error g h t / 2,
    no force in the rope) until the rope goes taut at z = -0.8; from then on the rope is
    never longer than 1 m by more than 1e-6 m, at any step. The taut rope stops the fall's
    radial speed (an inelastic catch) and leaves the tangential, 0.6 sqrt(2 g 0.8): the ball
    swings up the other side to z = -1 + (0.36 * 2 g 0.8 / 2 + g 0.2) / g = -0.512 (within
    1 mm: the catch falls within a step, not at its exact instant)."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    ball = world.add_body(_ball(), mass=1.0, position=(0.6, 0, 0))
    world.add_joint("distance", ball, None, anchor=(0.6, 0, 0), anchor_b=(0, 0, 0),
                    limits=(0.0, 1.0))  # fmt: skip
    assert world.joints["kind"].tolist() == ["distance"]
    taut, longest, highest = None, 0.0, -np.inf
    for _ in range(3 * 240):
        world.step()
        x = world.bodies.position[ball]
        length = np.linalg.norm(x)
        longest = max(longest, length)
        if taut is None and length < 1.0 - 1e-9:
            t = world.time
            assert x[0] == 0.6
            assert abs(x[2] + 0.5 * G * t * t) <= 0.5 * G * DT * t * (1 + 1e-9)
            np.testing.assert_array_equal(world.joints["force"][0], 0.0)
            assert world.joints["gap"][0] == 0.0
        elif taut is None:
            taut = world.time
        elif x[0] < 0:
            highest = max(highest, x[2])
    assert taut is not None
    assert abs(taut - np.sqrt(2 * 0.8 / G)) <= DT
    assert longest - 1.0 <= 1e-6
    assert highest == pytest.approx(-1 + (0.36 * G * 0.8 + G * 0.2) / G, abs=1e-3)


def test_distance_limit_row_is_the_derivative_of_the_length():
    """A rope's row (lin, ang_a, ang_b) is the derivative of the anchors' distance (the
    oracle's, from rotation matrices) under small motions of either body, at random poses
    beyond its limit (central differences, world-frame rotations)."""
    world = rbd.World()
    a = world.add_body(rbd.shapes.box((0.4, 0.2, 0.1)), position=(-0.25, 0, 0))
    b = world.add_body(rbd.shapes.box((0.3, 0.3, 0.2)), position=(0.2, 0, 0))
    anchor, anchor_b = np.array([-0.1, 0.05, 0.0]), np.array([0.15, -0.05, 0.1])
    world.add_joint("distance", a, b, anchor=anchor, anchor_b=anchor_b, limits=(0.0, 0.01))
    f = world._joints.floats[0]
    code = world._joints.ints[0, 0]
    creation = [ref.pose((-0.25, 0, 0), (0, 0, 0, 1)), ref.pose((0.2, 0, 0), (0, 0, 0, 1))]
    rng = np.random.default_rng(7)

    def length(xa, qa, xb, qb):
        offset = ref.anchor_offset(anchor, creation[0], ref.pose(xa, qa), creation[1],
                                   ref.pose(xb, qb), anchor_b)  # fmt: skip
        return np.linalg.norm(offset)

    def turned(q, v):
        return (Rotation.from_rotvec(v) * Rotation.from_quat(q)).as_quat()

    for _ in range(20):
        xa, xb = rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.5, 0.5, 3)
        qa, qb = (
            Rotation.random(random_state=rng).as_quat(),
            Rotation.random(random_state=rng).as_quat(),
        )
        rows = np.zeros((1, 10))
        assert joint_rows(code, f, tuple(xa), tuple(qa), tuple(xb), tuple(qb), rows, 0, True) == 1
        assert rows[0, 9] == pytest.approx(length(xa, qa, xb, qb) - 0.01, abs=1e-12)
        eps = 1e-6
        for k in range(3):
            e = np.eye(3)[k] * eps
            d_xa = (length(xa + e, qa, xb, qb) - length(xa - e, qa, xb, qb)) / (2 * eps)
            d_ta = (length(xa, turned(qa, e), xb, qb) - length(xa, turned(qa, -e), xb, qb)) / (
                2 * eps
            )
            d_tb = (length(xa, qa, xb, turned(qb, e)) - length(xa, qa, xb, turned(qb, -e))) / (
                2 * eps
            )
            assert rows[0, k] == pytest.approx(d_xa, abs=1e-6)
            assert rows[0, 3 + k] == pytest.approx(d_ta, abs=1e-6)
            assert rows[0, 6 + k] == pytest.approx(d_tb, abs=1e-6)


def test_ropes_springs_and_joint_friction_conserve_momentum():
    """Four boxes thrown tumbling in zero gravity, a rope from the first to the second, a
    damped spring on to the third, a hinge with friction and damping on to the fourth: the
    total linear and angular momentum stay to 1e-12 (every joint force acts equally and
    oppositely), and the rope is never longer than its limit by more than 1e-9 m. The boxes
    collide with nothing (collision group 0): the joints alone are under test."""
    rng = np.random.default_rng(3)
    world = rbd.World(dt=DT)
    box = rbd.shapes.box((0.2, 0.1, 0.1))
    bodies = [world.add_body(box, mass=m, position=(0.3 * i, 0, 0), collision_group=0)
              for i, m in enumerate((1.0, 2.0, 0.5, 1.5))]  # fmt: skip
    world.add_joint("distance", bodies[0], bodies[1], anchor=(0.05, 0, 0), anchor_b=(0.25, 0, 0),
                    limits=(0.0, 0.25))  # fmt: skip
    world.add_joint("distance", bodies[1], bodies[2], anchor=(0.35, 0, 0), anchor_b=(0.55, 0, 0),
                    spring={"stiffness": 50.0, "damping": 0.5})  # fmt: skip
    world.add_joint("revolute", bodies[3], bodies[2], anchor=(0.75, 0, 0), axis=(0, 0, 1),
                    friction=0.02, damping=0.01)  # fmt: skip
    for body in bodies:
        world.bodies.linear_momentum[body] = rng.normal(size=3)
        world.bodies.angular_momentum[body] = 0.05 * rng.normal(size=3)
    linear0, angular0 = _momenta(world)
    scale = max(np.abs(linear0).max(), np.abs(angular0).max())
    longest = 0.0
    for _ in range(480):
        world.step()
        longest = max(longest, world.joints["position"][0])
    linear, angular = _momenta(world)
    np.testing.assert_allclose(linear, linear0, atol=1e-12 * scale)
    np.testing.assert_allclose(angular, angular0, atol=1e-12 * scale)
    assert longest <= 0.25 + 1e-9


# ----------------------------------------------------------------------------- friction
def _wheel(**options):
    """A 2 kg wheel (radius 0.3 m) on a hinge about +z at its centre, zero gravity."""
    world = rbd.World(dt=DT)
    wheel = world.add_body(rbd.shapes.cylinder(0.3, 0.1), mass=2.0)
    world.add_joint("revolute", wheel, None, anchor=(0, 0, 0), axis=(0, 0, 1), **options)
    return world, wheel, world.bodies.inertia_body[wheel][2, 2]


def _spin(world, wheel, rate):
    inertia = world.bodies.inertia_body[wheel][2, 2]
    world.bodies.angular_momentum[wheel] = (0.0, 0.0, inertia * rate)


def test_hinge_friction_stops_a_wheel_at_its_time_and_holds_it():
    """A wheel of inertia I spun at w0 against friction T_f slows at T_f / I and stops after
    I w0 / T_f (within one step), then stays stopped; the joint reports the friction torque
    against the spin while it turns."""
    friction, w0 = 0.07, 3.0
    world, wheel, inertia = _wheel(friction=friction)
    _spin(world, wheel, w0)
    rates = []
    for _ in range(5 * 240):
        world.step()
        rates.append(world.joints["velocity"][0])
        if len(rates) == 10:
            assert world.joints["torque"][0][2] == pytest.approx(-friction, rel=1e-9)
    rates = np.array(rates)
    times = DT * np.arange(1, len(rates) + 1)
    stopped = np.flatnonzero(np.abs(rates) <= 1e-12)
    assert abs(times[stopped[0]] - inertia * w0 / friction) <= DT
    assert np.all(np.abs(rates[stopped[0] :]) <= 1e-12)
    turning = times < inertia * w0 / friction - DT
    np.testing.assert_allclose(rates[turning], w0 - friction * times[turning] / inertia,
                               rtol=1e-9)  # fmt: skip


@pytest.mark.parametrize(("friction", "moves"), [(60.0, False), (45.0, True)])
def test_frictional_hinge_holds_a_load_below_its_friction(friction, moves):
    """A 10 kg ball 0.5 m out on a hinge about +y, held level by gravity's torque m g r =
    49.05 N m: with 60 N m of friction it does not move (angle <= 1e-9 rad over 2 s); with
    45 N m it falls."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    ball = world.add_body(_ball(0.05), mass=10.0, position=(0.5, 0, 0))
    world.add_joint("revolute", ball, None, anchor=(0, 0, 0), axis=(0, 1, 0), friction=friction)
    turned = 0.0
    for _ in range(2 * 240):
        world.step()
        turned = max(turned, abs(world.joints["position"][0]))
    assert (turned > 0.1) if moves else (turned <= 1e-9)


def test_motors_work_against_joint_friction():
    """Friction acts with a motor: a torque motor of tau against friction T_f < tau spins the
    wheel up at (tau - T_f) / I, one below T_f leaves it still; a velocity motor holds its
    target rate and reports the torque friction takes, T_f."""
    world, _, inertia = _wheel(friction=0.3, motor={"torque": 0.5})
    world.step(240)
    assert world.joints["velocity"][0] == pytest.approx(0.2 * world.time / inertia, rel=1e-9)
    world, *_ = _wheel(friction=0.6, motor={"torque": 0.5})
    world.step(240)
    assert abs(world.joints["velocity"][0]) <= 1e-12
    world, *_ = _wheel(friction=0.3, motor={"velocity": 2.0, "max_force": 5.0})
    world.step(240)
    assert world.joints["velocity"][0] == pytest.approx(2.0, rel=1e-9)
    assert world.joints["motor_force"][0] == pytest.approx(0.3, rel=1e-9)


# ----------------------------------------------------------------------------- damping
@pytest.mark.parametrize("kind", ["revolute", "prismatic"])
def test_viscous_joint_damping_decays_exponentially(kind):
    """A wheel spun on a hinge with damping c (or a 1 kg block pushed along a slider) decays
    as exp(-c t / I) (or exp(-c t / m)): over 2 s the fitted rate is c / I to the implicit
    step's first-order error, h (c / I)^2 / 2."""
    damping = 0.12
    if kind == "revolute":
        world, body, inertia = _wheel(damping=damping)
        _spin(world, body, 3.0)
    else:
        world = rbd.World(dt=DT)
        body = world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), mass=1.0)
        world.add_joint("prismatic", body, None, anchor=(0, 0, 0), axis=(1, 1, 0),
                        damping=damping)  # fmt: skip
        inertia = 1.0
        world.bodies.linear_momentum[body] = 3.0 * np.array([1, 1, 0]) / np.sqrt(2)
    rates, times = [], []
    for _ in range(2 * 240):
        world.step()
        rates.append(world.joints["velocity"][0])
        times.append(world.time)
    decay = -np.polyfit(times, np.log(rates), 1)[0]
    exact = damping / inertia
    assert abs(decay - exact) <= 0.5 * DT * exact**2 * 1.01


# ----------------------------------------------------------------------------- input
_BAD = {
    "spring stiffness must be >= 0": dict(kind="distance", spring={"stiffness": -1.0}),
    "spring damping must be >= 0": dict(kind="distance", spring={"stiffness": 1.0, "damping": -1}),
    "spring rest_length must be >= 0": dict(
        kind="distance", spring={"stiffness": 1.0, "rest_length": -0.5}
    ),
    "spring stiffness must be finite": dict(kind="distance", spring={"stiffness": np.inf}),
    "spring must be a dict": dict(kind="distance", spring={"stifness": 1.0}),
    "spring is for distance joints": dict(kind="revolute", spring={"stiffness": 1.0}),
    "^damping must be >= 0": dict(kind="revolute", damping=-0.1),
    "^friction must be >= 0": dict(kind="prismatic", friction=-1.0),
    "friction must be a number": dict(kind="revolute", friction="high"),
    "friction resists a hinge's turning": dict(kind="spherical", friction=0.5),
    "damping resists .* 'fixed'": dict(kind="fixed", damping=0.5),
    "a distance joint's damping is its spring's": dict(kind="distance", damping=0.5),
    "limits out of order": dict(kind="distance", limits=(1.0, 0.5)),
    "limits bound its length": dict(kind="distance", limits=(-0.5, 1.0)),
    "no free motion to limit": dict(kind="fixed", limits=(0.0, 1.0)),
    "a motor drives a hinge or a slider": dict(kind="distance", motor={"torque": 1.0}),
}


@pytest.mark.parametrize("message", list(_BAD))
def test_bad_joint_forces_are_refused_naming_the_field(message):
    """Each fault is a ValueError naming its field, and no joint is added."""
    world = rbd.World()
    world.add_body(rbd.shapes.box(), position=(0, 0, 0))
    world.add_body(rbd.shapes.box(), position=(1, 0, 0))
    arguments = dict(body_a=0, body_b=1, anchor=(0.5, 0, 0), anchor_b=None)
    arguments.update(_BAD[message])
    if arguments["kind"] == "distance":
        arguments["anchor_b"] = (0.8, 0, 0)
    with pytest.raises(ValueError, match=message):
        world.add_joint(**arguments)
    assert len(world.joints["kind"]) == 0


# ----------------------------------------------------------------------------- scene files
_SCENE = """
[world]
gravity = [0.0, 0.0, 0.0]

[[body]]
name = "ball"
shape = {{ type = "icosphere", radius = 0.05, subdivisions = 3 }}
mass = 1.0
position = [1.2, 0.0, 0.0]

[[body]]
name = "wheel"
shape = {{ type = "cylinder", radius = 0.3, height = 0.1 }}
mass = 2.0
position = [0.0, 3.0, 0.0]
angular_velocity = [0.0, 0.0, 3.0]

[[joint]]
kind = "distance"
body_a = "ball"
anchor = [1.2, 0.0, 0.0]
anchor_b = [0.0, 0.0, 0.0]
{distance}

[[joint]]
kind = "revolute"
body_a = "wheel"
anchor = [0.0, 3.0, 0.0]
{hinge}
"""


def _scene(distance, hinge):
    text = _SCENE.format(distance=distance, hinge=hinge)
    return parse_scene(text, "s", "s.toml", Path("."))


def test_scene_joints_take_springs_ropes_friction_and_damping():
    """[[joint]] tables with spring, limits, friction and damping build the world add_joint
    builds."""
    scene = _scene(
        "spring = { stiffness = 39.5, damping = 0.3, rest_length = 1.0 }\nlimits = [0.0, 1.3]",
        "friction = 0.05\ndamping = 0.02",
    )
    built = scene.build()
    direct = rbd.World(gravity=(0, 0, 0))
    ball = direct.add_body(_ball(0.05), mass=1.0, position=(1.2, 0, 0))
    wheel = direct.add_body(rbd.shapes.cylinder(0.3, 0.1), mass=2.0, position=(0, 3, 0),
                            angular_velocity=(0, 0, 3))  # fmt: skip
    direct.add_joint("distance", ball, None, anchor=(1.2, 0, 0), anchor_b=(0, 0, 0),
                     limits=(0.0, 1.3),
                     spring={"stiffness": 39.5, "damping": 0.3, "rest_length": 1.0})  # fmt: skip
    direct.add_joint("revolute", wheel, None, anchor=(0, 3, 0), friction=0.05, damping=0.02)
    built.step(100)
    direct.step(100)
    np.testing.assert_array_equal(built.positions, direct.positions)
    np.testing.assert_array_equal(built.joints["velocity"], direct.joints["velocity"])


@pytest.mark.parametrize(
    ("distance", "hinge", "message"),
    [
        ("spring = { stifness = 1.0 }", "", "joint\\[0\\]: field 'spring': unknown spring key"),
        ("spring = 5.0", "", "field 'spring': must be a table"),
        ("", "friction = -1.0", "joint\\[1\\]: field 'friction': must be >= 0"),
        ("", "damping = true", "joint\\[1\\]: field 'damping': must be a number"),
        ("spring = { stiffness = -1.0 }", "", "joint\\[0\\]: spring stiffness must be >= 0"),
        ("", "spring = { stiffness = 1.0 }", "joint\\[1\\]: spring is for distance joints"),
    ],
)  # fmt: skip
def test_bad_scene_joint_forces_name_the_table_and_field(distance, hinge, message):
    with pytest.raises(rbd.SceneError, match=message):
        _scene(distance, hinge).build()
