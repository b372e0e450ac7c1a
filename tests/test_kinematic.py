"""Kinematic bodies against independent oracles: the analytic screw motion of constant v and w,
Coulomb's law for a box carried by a moving platform, Poisson restitution in the frame of a
moving platform or paddle, Galilean invariance of a pendulum hung from a moving body, and the
rigid motion of a body welded to one."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import examples
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd

G = 9.81
DT = 1 / 240
EPS = np.finfo(float).eps


def _screw(x0, q0, v, w, t):
    """Pose after t seconds of constant v and constant w about the centre: the oracle."""
    turn = Rotation.from_rotvec(np.asarray(w) * t)
    return np.asarray(x0) + np.asarray(v) * t, (turn * Rotation.from_quat(q0)).as_quat()


def _same_rotation(q, p):
    """Distance between two unit quaternions as rotations (q and -q are one rotation)."""
    return min(np.abs(q - p).max(), np.abs(q + p).max())


vectors = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3)


@settings(max_examples=examples(20))
@given(
    x0=vectors,
    v=vectors,
    w=vectors,
    axis=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
        lambda a: np.linalg.norm(a) > 0.1
    ),
    angle=st.floats(-np.pi, np.pi),
    steps=st.integers(1, 120),
)
def test_a_kinematic_body_follows_the_screw_motion_of_its_velocity(x0, v, w, axis, angle, steps):
    q0 = Rotation.from_rotvec(np.asarray(axis) / np.linalg.norm(axis) * angle).as_quat()
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    body = world.add_body(
        rbd.shapes.box((0.4, 0.3, 0.2)), kinematic=True, position=x0, orientation=q0,
        linear_velocity=v, angular_velocity=w,
    )  # fmt: skip
    world.step(steps)
    x, q = _screw(x0, q0, v, w, steps * DT)
    # each step adds v dt (one rounding of a sum of size |x|) and turns by one quaternion
    # product (a few roundings of unit numbers): the errors add up step by step
    scale = np.abs(x0).max() + np.abs(v).max() * steps * DT + 1.0
    assert np.abs(world.position(body) - x).max() <= 4 * steps * EPS * scale
    assert _same_rotation(world.orientation(body), q) <= 16 * steps * EPS
    assert np.array_equal(world.linear_velocity(body), v)
    assert np.array_equal(world.angular_velocity(body), w)
    assert world.stages == ["kinematic"]


def _platform_world(velocity, mu=0.5):
    """A kinematic 4 x 4 x 0.2 m platform (top at z = 0) moving at ``velocity`` under a
    0.2 m cube at rest on it; both bodies' friction ``mu``, so the contact's is ``mu``."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    platform = world.add_body(
        rbd.shapes.box((4, 4, 0.2)), kinematic=True, position=(0, 0, -0.1),
        linear_velocity=velocity, friction=mu,
    )  # fmt: skip
    box = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1),
                         friction=mu)  # fmt: skip
    return world, platform, box


@pytest.mark.parametrize("velocity", [(1.0, 0.0, 0.0), (0.0, -0.8, 0.0), (0.6, -0.8, 0.0)])
def test_a_box_on_a_moving_platform_is_carried_by_friction(velocity):
    """The platform slides under the box until friction has brought the box to its speed:
    Coulomb's law decelerates the relative motion at mu g, so it lasts u / (mu g) and the
    platform gains u^2 / (2 mu g) on the box. Time stepping applies that deceleration from
    the first step on, so the gain is short by up to one step's relative travel, u dt.
    The friction cone is a polygon of 8 sides (``World.friction_sides``), exact along the
    axes; off them maximal dissipation takes the polygon's force that opposes the sliding
    most, whose component against it is at least mu g cos(pi / 8): the relative path, and so
    the gain, is then at most u^2 / (2 mu g cos(pi / 8))."""
    mu = 0.5
    world, platform, box = _platform_world(velocity, mu)
    u = np.asarray(velocity)
    speed = np.linalg.norm(u)
    world.step(round(0.5 / DT))  # more than twice the u / (mu g) <= 0.2 s of sliding
    gain = world.position(platform)[:2] - world.position(box)[:2]
    along_an_axis = np.count_nonzero(u) == 1
    if along_an_axis:
        expected = speed**2 / (2 * mu * G) * u[:2] / speed
        assert np.linalg.norm(gain - expected) <= speed * DT
    else:
        assert np.linalg.norm(gain) <= speed**2 / (2 * mu * G * np.cos(np.pi / 8)) + speed * DT
    # stuck: static friction holds the box to the platform's velocity to the contact
    # solver's tolerance, a thousandth of the slop (a thousandth of the 0.2 m cube) per step
    tolerance = 1e-3 * 1e-3 * 0.2 / DT
    assert np.abs(world.linear_velocity(box) - u).max() <= tolerance
    # and it rests on the platform: no sinking beyond the slop, no rise
    assert abs(world.position(box)[2] - 0.1) <= 1e-3 * 0.2
    assert not world.sleeping[box]


def test_a_paddle_hits_a_ball_with_the_restitution_rule_in_its_frame():
    """No gravity: a kinematic paddle at u hits a ball at rest head on; with restitution e the
    ball leaves at u + e u (the relative velocity reversed and scaled by e). A collision with
    a rebound is solved to a millionth of the impact speed."""
    u, e = 2.0, 0.5
    world = rbd.World(dt=DT)
    paddle = world.add_body(
        rbd.shapes.box((0.1, 1.0, 1.0)), kinematic=True, position=(-0.3, 0, 0),
        linear_velocity=(u, 0, 0), restitution=1.0,
    )  # fmt: skip
    ball = world.add_body(rbd.shapes.icosphere(0.1, 3), mass=0.2, restitution=e)
    world.step(round(0.3 / DT))
    v = world.linear_velocity(ball)
    assert abs(v[0] - (1 + e) * u) <= 1e-6 * u
    assert np.abs(v[1:]).max() <= 1e-6 * u
    assert np.array_equal(world.linear_velocity(paddle), (u, 0, 0))
    assert world.position(ball)[0] > world.position(paddle)[0] + 0.15


def test_a_ball_dropped_on_a_rising_platform_rebounds_by_the_restitution_rule_in_its_frame():
    """A ball falls onto a kinematic platform rising at u; in the platform's frame it leaves
    with -e times the velocity it hit with: v_out = u - e (v_in - u). The instant of impact
    within its step is found from the two paths (the ball's parabola from the last step
    before, the platform's line), and the velocity expected at the end of the step follows.
    The step may resolve the collision anywhere within it (the time of impact searches
    against the platform where the step ends), so the answer can be off by up to what
    gravity changes in a step, before and after the collision: (1 + e) g dt."""
    u, e, r = 0.5, 0.8, 0.1
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    platform = world.add_body(
        rbd.shapes.box((2, 2, 0.2)), kinematic=True, position=(0, 0, -0.1),
        linear_velocity=(0, 0, u), restitution=1.0,
    )  # fmt: skip
    ball = world.add_body(rbd.shapes.icosphere(r, 3), mass=0.1, position=(0, 0, 1.0),
                          restitution=e)  # fmt: skip
    before = None
    for _ in range(round(1.0 / DT)):
        state = (world.position(ball)[2], world.linear_velocity(ball)[2],
                 world.position(platform)[2])  # fmt: skip
        world.step()
        if world.linear_velocity(ball)[2] > state[1] + 1.0:  # the bounce
            before = state
            break
    assert before is not None
    z, v, zp = before
    # z + v t - g t^2 / 2 - r = zp + 0.1 + u t: the ball's bottom meets the platform's top
    a, b, c = -G / 2, v - u, z - r - zp - 0.1
    t = (-b - np.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert 0.0 <= t <= DT
    v_in = v - G * t
    v_out = u - e * (v_in - u)
    expected = v_out - G * (DT - t)
    assert abs(world.linear_velocity(ball)[2] - expected) <= (1 + e) * G * DT
    assert np.array_equal(world.linear_velocity(platform), (0, 0, u))


def _hung_pendulum(kinematic, velocity, substeps):
    """A 1 kg ball 1 m beside a hinge about y, released horizontal, the hinge on a
    kinematic cart moving at ``velocity`` (its ball moving with it) or on the world; held in
    maximal coordinates both times (a moving cart always is; one hung from the world would
    otherwise be stepped in joint coordinates, another scheme)."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G), joint_substeps=substeps,
                      joint_coordinates="maximal")  # fmt: skip
    v = np.asarray(velocity if kinematic else (0.0, 0.0, 0.0))
    ball = world.add_body(rbd.shapes.icosphere(0.02, 3), mass=1.0, position=(1, 0, 0),
                          linear_velocity=v)  # fmt: skip
    cart = None
    if kinematic:
        cart = world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), kinematic=True,
                              linear_velocity=v, collidable=False)  # fmt: skip
    world.add_joint("revolute", ball, cart, anchor=(0, 0, 0), axis=(0, 1, 0))
    return world, ball


@pytest.mark.parametrize("substeps", [1, 3])
def test_a_pendulum_hung_from_a_moving_kinematic_body_swings_as_one_hung_still(substeps):
    """Galilean invariance: in the frame of a cart moving at constant v, a pendulum hung
    from it swings exactly as the same pendulum hung from the world, shifted by v t. The two
    runs differ by round-off and by the projection's stopping point, within 1e-10 of the
    joint's scale per step (the rows are held to that)."""
    velocity = (1.5, -0.5, 0.75)
    steps = round(1.0 / DT)
    moving, ball = _hung_pendulum(True, velocity, substeps)
    still, still_ball = _hung_pendulum(False, velocity, substeps)
    worst, lowest = 0.0, 0.0
    for k in range(1, steps + 1):
        moving.step()
        still.step()
        shifted = still.position(still_ball) + np.asarray(velocity) * k * DT
        worst = max(worst, np.abs(moving.position(ball) - shifted).max())
        lowest = min(lowest, still.position(still_ball)[2])
    assert worst <= steps * 1e-10
    assert lowest < -0.99  # it swung through the bottom, 1 m below the hinge
    assert moving.joints["gap"].max() <= 1e-9


def test_a_body_welded_to_a_turning_kinematic_body_moves_rigidly_with_it():
    """No gravity: a box welded 1 m out from a kinematic hub that moves at v and turns at w
    (and starting with the rigid motion's velocity, v + w x r) stays at that offset in the
    hub's frame: its pose is the hub's composed with the offset, to the weld's tolerance."""
    v, w = np.array([0.3, -0.2, 0.1]), np.array([0.0, 0.5, 2.0])
    offset = np.array([1.0, 0.0, 0.0])
    world = rbd.World(dt=DT, joint_substeps=2)
    box = world.add_body(
        rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=offset,
        linear_velocity=v + np.cross(w, offset), angular_velocity=w,
    )  # fmt: skip
    hub = world.add_body(rbd.shapes.box((0.3, 0.3, 0.3)), kinematic=True, linear_velocity=v,
                         angular_velocity=w, collidable=False)  # fmt: skip
    world.add_joint("fixed", box, hub, anchor=(0.5, 0, 0))
    world.step(round(1.0 / DT))
    x, q = _screw((0, 0, 0), (0, 0, 0, 1), v, w, world.time)
    turn = Rotation.from_quat(q)
    assert np.abs(world.position(box) - (x + turn.apply(offset))).max() <= 1e-8
    assert _same_rotation(world.orientation(box), q) <= 1e-8
    assert np.abs(world.position(hub) - x).max() <= 1e-12


def test_a_hinge_motor_acts_relative_to_the_kinematic_body_it_holds_to():
    """No gravity: a wheel hinged to a kinematic hub that turns at w about the hinge's axis,
    with a velocity motor of target 0, turns with the hub (its motion relative to the hub is
    what the motor drives to zero)."""
    w = np.array([0.0, 0.0, 3.0])
    world = rbd.World(dt=DT)
    wheel = world.add_body(rbd.shapes.cylinder(0.3, 0.05), mass=1.0)
    hub = world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), kinematic=True, angular_velocity=w,
                         collidable=False)  # fmt: skip
    world.add_joint("revolute", wheel, hub, anchor=(0, 0, 0), axis=(0, 0, 1),
                    motor={"velocity": 0.0, "max_force": 100.0})  # fmt: skip
    world.step(24)
    assert np.abs(world.angular_velocity(wheel) - w).max() <= 1e-6 * 3.0
    assert abs(world.joints["velocity"][0]) <= 1e-6 * 3.0


@pytest.mark.parametrize("hit", [(0.0, 0.0, -4.0), (3.0, 1.0, -2.0)])
def test_contacts_never_change_a_kinematic_body(hit):
    """Balls landing on a box on a kinematic platform push against the platform: its momenta
    stay zero, its velocities as set, and its path is bit for bit the one it takes alone."""
    velocity, spin = (0.4, 0.0, 0.1), (0.0, 0.0, 0.2)

    def platform_world(with_load):
        world = rbd.World(dt=DT, gravity=(0, 0, -G))
        platform = world.add_body(
            rbd.shapes.box((3, 3, 0.2)), kinematic=True, position=(0, 0, -0.1),
            linear_velocity=velocity, angular_velocity=spin, friction=0.5,
        )  # fmt: skip
        if with_load:
            world.add_body(rbd.shapes.box((0.4, 0.4, 0.4)), mass=5.0, position=(0, 0, 0.2),
                           friction=0.5)  # fmt: skip
            for k in range(3):
                world.add_body(rbd.shapes.icosphere(0.1, 2), mass=1.0, restitution=0.5,
                               position=(0.6 * k - 0.6, 0.3, 0.8), linear_velocity=hit)  # fmt: skip
        return world, platform

    loaded, platform = platform_world(True)
    alone, same = platform_world(False)
    for _ in range(round(0.75 / DT)):
        loaded.step()
        alone.step()
        assert np.array_equal(loaded.linear_momentum(platform), np.zeros(3))
        assert np.array_equal(loaded.angular_momentum(platform), np.zeros(3))
    assert np.array_equal(loaded.position(platform), alone.position(same))
    assert np.array_equal(loaded.orientation(platform), alone.orientation(same))
    assert np.array_equal(loaded.linear_velocity(platform), velocity)
    assert np.array_equal(loaded.angular_velocity(platform), spin)
    assert loaded.contact_info["islands"] > 0  # the load did touch it


def test_kinematic_bodies_do_not_collide_with_static_or_kinematic_bodies():
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    world.add_body(rbd.shapes.box((2, 2, 0.2)), static=True, position=(0, 0, -0.1))
    world.add_body(rbd.shapes.box((1, 1, 1)), kinematic=True, position=(0, 0, 0),
                   linear_velocity=(0.1, 0, 0))  # fmt: skip
    world.add_body(rbd.shapes.box((1, 1, 1)), kinematic=True, position=(0.5, 0, 0))
    assert "narrow_phase" not in world.stages  # no pair of them can collide
    box = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=(0.3, 0, 0.6))
    world.step(30)
    pairs = {
        tuple(sorted(p))
        for p in zip(*(world.contacts[k] for k in ("body_a", "body_b")), strict=True)
    }
    assert pairs and all(box in pair for pair in pairs)


def test_a_box_asleep_on_a_still_platform_wakes_when_it_moves_and_never_sleeps_carried():
    world, platform, box = _platform_world((0.0, 0.0, 0.0))
    assert "kinematic" in world.stages
    world.step(round(1.0 / DT))
    assert world.sleeping[box]
    world.set_kinematic(platform, velocity=(0.5, 0.0, 0.0))
    world.step()
    assert not world.sleeping[box]
    world.step(round(2.0 / DT))  # beyond the half second a still island takes to sleep
    assert not world.sleeping[box]
    assert abs(world.linear_velocity(box)[0] - 0.5) <= 1e-3


def test_set_kinematic_moves_the_body_and_keeps_what_is_left_out():
    world = rbd.World(dt=DT)
    body = world.add_body(rbd.shapes.box(), kinematic=True, linear_velocity=(1, 0, 0),
                          angular_velocity=(0, 0, 1))  # fmt: skip
    q = Rotation.from_rotvec((0.3, 0, 0)).as_quat()
    world.set_kinematic(body, position=(0, 2, 0), orientation=q)
    assert np.array_equal(world.position(body), (0, 2, 0))
    assert np.array_equal(world.linear_velocity(body), (1, 0, 0))
    world.set_kinematic(body, angular_velocity=(0, 0, 0))
    world.step(10)
    x, p = _screw((0, 2, 0), q, (1, 0, 0), (0, 0, 0), 10 * DT)
    assert np.abs(world.position(body) - x).max() <= 1e-14
    assert _same_rotation(world.orientation(body), p) <= 1e-15


def test_a_kinematic_body_that_jumps_into_a_box_pushes_it_out():
    """set_kinematic's pose is a jump: the contacts are found again where it lands, and the
    box it lands in is pushed out of it to within the contact's slop (a thousandth of the box),
    as out of a static body: by moving it, with no momentum left behind."""
    world = rbd.World(dt=DT)
    box = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1))
    plate = world.add_body(rbd.shapes.box((1, 1, 0.1)), kinematic=True, position=(3, 0, 1))
    world.step(5)
    world.set_kinematic(plate, position=(0, 0, 0.24))  # its bottom 1 cm into the box's top
    world.step(round(0.5 / DT))
    assert world.position(box)[2] + 0.1 <= 0.19 + 1e-3 * 0.2
    assert np.abs(world.linear_velocity(box)).max() <= 1e-9


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"static": True}, "static or kinematic"),
        ({"mass": 1.0}, "no mass or density"),
        ({"density": 2.0}, "no mass or density"),
        ({"linear_velocity": (np.inf, 0, 0)}, "linear_velocity"),
    ],
)
def test_bad_kinematic_bodies_are_refused(arguments, message):
    with pytest.raises(ValueError, match=message):
        rbd.World().add_body(rbd.shapes.box(), kinematic=True, **arguments)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"position": (0, np.nan, 0)}, "position"),
        ({"orientation": (0, 0, 0, 0)}, "orientation|quaternion"),
        ({"velocity": (1, 2)}, "velocity"),
        ({"angular_velocity": (0, 0, np.inf)}, "angular_velocity"),
    ],
)
def test_bad_set_kinematic_values_are_refused_and_change_nothing(arguments, message):
    world = rbd.World()
    body = world.add_body(rbd.shapes.box(), kinematic=True, linear_velocity=(1, 0, 0))
    with pytest.raises(ValueError, match=message):
        world.set_kinematic(body, **arguments)
    assert np.array_equal(world.position(body), (0, 0, 0))
    assert np.array_equal(world.linear_velocity(body), (1, 0, 0))


def test_set_kinematic_and_forces_on_other_bodies_are_refused():
    world = rbd.World()
    dynamic = world.add_body(rbd.shapes.box(), mass=1.0)
    static = world.add_body(rbd.shapes.box(), static=True, position=(3, 0, 0))
    kinematic = world.add_body(rbd.shapes.box(), kinematic=True, position=(6, 0, 0))
    for body in (dynamic, static):
        with pytest.raises(ValueError, match="not kinematic"):
            world.set_kinematic(body, velocity=(1, 0, 0))
    with pytest.raises(ValueError, match="kinematic"):
        world.apply_force(kinematic, (1, 0, 0))
    with pytest.raises(ValueError, match="no body"):
        world.set_kinematic(7, velocity=(1, 0, 0))


SCENE = """
[world]
dt = {dt}
gravity = [0.0, 0.0, -9.81]

[[body]]
name = "belt"
shape = {{ type = "box", extents = [4.0, 4.0, 0.2] }}
position = [0.0, 0.0, -0.1]
kinematic = true
linear_velocity = [1.0, 0.0, 0.0]
angular_velocity = [0.0, 0.0, 0.1]
friction = 0.5

[[body]]
name = "box"
shape = {{ type = "box", extents = [0.2, 0.2, 0.2] }}
mass = 1.0
position = [0.0, 0.0, 0.1]
friction = 0.5
"""


def test_a_scene_file_builds_a_kinematic_body(tmp_path):
    path = tmp_path / "belt.toml"
    path.write_text(SCENE.format(dt=DT))
    world = rbd.load_scene(path).build()
    belt = world.names.index("belt")
    assert world.bodies.kinematic.tolist() == [True, False]
    world.step(48)
    x, q = _screw((0, 0, -0.1), (0, 0, 0, 1), (1, 0, 0), (0, 0, 0.1), 48 * DT)
    assert np.abs(world.position(belt) - x).max() <= 1e-14
    assert _same_rotation(world.orientation(belt), q) <= 1e-14
    assert world.linear_velocity(world.names.index("box"))[0] > 0.5  # carried


def test_a_scene_file_refuses_a_body_both_static_and_kinematic(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(
        SCENE.format(dt=DT).replace("kinematic = true", "kinematic = true\nstatic = true")
    )
    with pytest.raises(rbd.SceneError, match=r"belt.*static or kinematic"):
        rbd.load_scene(path).build()
