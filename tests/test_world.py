"""World: body set-up, applied forces and torques, stage planning, accessors, bad input."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from validation.bench_effects import far_apart_world

CUBE = rbd.shapes.box((1.0, 1.0, 1.0))  # I = m/6 about every axis


def test_position_is_the_centre_of_mass_and_transform_maps_the_mesh():
    offset_box = rbd.TriangleMesh(CUBE.vertices + [5.0, 0.0, 0.0], CUBE.faces)
    world = rbd.World()
    q = Rotation.from_euler("z", 90, degrees=True).as_quat()
    body = world.add_body(offset_box, mass=1.0, position=(0, 0, 1), orientation=q)
    T = world.transform(body)
    # the mesh's centre of mass (5, 0, 0) lands on the body position
    np.testing.assert_allclose(T @ [5, 0, 0, 1], [0, 0, 1, 1], atol=1e-12)
    np.testing.assert_allclose(world.positions, [[0, 0, 1]])
    assert not world.positions.flags.writeable


def test_initial_velocities_round_trip_through_momenta():
    world = rbd.World()
    q = Rotation.from_euler("xyz", [0.3, -0.2, 1.0]).as_quat()
    body = world.add_body(
        rbd.shapes.box((1, 2, 3)),
        density=3.0,
        orientation=q,
        linear_velocity=(1, 2, 3),
        angular_velocity=(0.5, -0.25, 2.0),
    )
    np.testing.assert_allclose(world.linear_velocity(body), [1, 2, 3], rtol=1e-14)
    np.testing.assert_allclose(world.angular_velocity(body), [0.5, -0.25, 2.0], rtol=1e-12)
    m = 18.0
    np.testing.assert_allclose(world.linear_momentum(body), m * np.array([1, 2, 3]), rtol=1e-14)
    R = Rotation.from_quat(q).as_matrix()
    I_world = R @ (m / 12 * np.diag([13, 10, 5])) @ R.T
    np.testing.assert_allclose(
        world.angular_momentum(body), I_world @ [0.5, -0.25, 2.0], rtol=1e-12
    )
    expected_energy = 0.5 * m * 14 + 0.5 * np.array([0.5, -0.25, 2.0]) @ I_world @ [0.5, -0.25, 2.0]
    assert world.kinetic_energy() == pytest.approx(expected_energy, rel=1e-12)


def test_force_with_duration_delivers_exact_impulse():
    """A 0.01 s push at dt = 1/240 ends mid-step; the impulse must still be F * duration."""
    world = rbd.World(dt=1 / 240)
    body = world.add_body(CUBE, mass=2.0)
    world.apply_force(body, (3.0, 0.0, 0.0), duration=0.01)
    assert world.stages == ["forces", "integrate"]
    world.step(10)
    np.testing.assert_allclose(world.linear_momentum(body), [0.03, 0, 0], rtol=1e-12)
    # the force has expired: the forces stage leaves the pipeline
    assert world.stages == ["integrate"]
    calls = world.profile["forces"]["calls"]
    world.step(5)
    assert world.profile["forces"]["calls"] == calls


def test_force_at_a_point_gives_torque_r_cross_f():
    world = rbd.World(dt=1 / 1000)
    body = world.add_body(CUBE, mass=6.0)  # I = 1 about every axis
    world.apply_force(body, (0.0, 2.0, 0.0), point=(0.5, 0.0, 0.0), duration=0.001)
    world.step()
    # L = r x F * duration = (0.5, 0, 0) x (0, 2, 0) * 0.001
    np.testing.assert_allclose(world.angular_momentum(body), [0, 0, 0.001], rtol=1e-9)
    np.testing.assert_allclose(world.linear_momentum(body), [0, 0.002, 0], rtol=1e-12)


def test_point_force_arm_turns_with_the_body():
    """A constant world force at a body-fixed point: the torque follows the rotated arm."""
    world = rbd.World(dt=1 / 240)
    q = Rotation.from_euler("z", 90, degrees=True).as_quat()
    body = world.add_body(CUBE, mass=6.0, orientation=q)
    # world point (0, 0.5, 0) is body-frame arm (0.5, 0, 0) after the 90 degree turn
    world.apply_force(body, (0.0, 0.0, 1.0), point=(0.0, 0.5, 0.0), duration=1 / 240)
    world.step()
    torque = np.cross([0.0, 0.5, 0.0], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(world.angular_momentum(body), torque / 240, rtol=1e-4, atol=1e-15)


def test_static_bodies_never_move_nor_count_in_energy():
    world = rbd.World(gravity=(0, 0, -9.81))
    floor = world.add_body(rbd.shapes.box((10, 10, 1)), static=True, position=(0, 0, -0.5))
    assert world.stages == []  # nothing dynamic: no stage at all
    ball = world.add_body(rbd.shapes.icosphere(0.5, 2), mass=1.0, position=(0, 0, 2))
    assert world.stages == [
        "forces",
        "contacts",
        "integrate",
        "bounds",
        "broad_phase",
        "narrow_phase",
        "tunnelling",
        "time_of_impact",
        "impacts",
        "sleep",
    ]
    world.step(24)
    np.testing.assert_allclose(world.position(floor), [0, 0, -0.5])
    np.testing.assert_allclose(world.linear_velocity(floor), 0)
    assert world.potential_energy() == pytest.approx(9.81 * world.position(ball)[2], rel=1e-12)


def test_stage_plan_follows_the_scene_and_skipped_stages_are_never_called():
    world = rbd.World()
    world.add_body(CUBE, mass=1.0, angular_velocity=(0, 0, 1))
    assert world.stages == ["integrate"]
    world.step(3)
    assert world.profile["forces"]["calls"] == 0
    assert world.profile["integrate"]["calls"] == 3
    # every stage a step can run has its entry, in pipeline order (as the guide lists them),
    # and the stages this scene does not plan show no call
    assert list(world.profile) == [
        "forces", "contacts", "integrate", "kinematic", "joints", "bounds", "broad_phase",
        "narrow_phase", "tunnelling", "time_of_impact", "impacts", "sleep",
    ]  # fmt: skip
    assert all(world.profile[name]["calls"] == 0 for name in world.profile if name != "integrate")


def test_static_open_mesh_is_allowed_dynamic_open_mesh_is_not():
    plate = rbd.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    world = rbd.World()
    world.add_body(plate, static=True)
    with pytest.raises(ValueError, match="open"):
        world.add_body(plate, mass=1.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"mass": 0.0}, "mass"),
        ({"mass": -1.0}, "mass"),
        ({"density": -2.0}, "density"),
        ({"mass": 1.0, "density": 1.0}, "not both"),
        ({"position": (0, np.nan, 0)}, "position"),
        ({"position": (0, 0)}, "position must have shape"),
        ({"orientation": (0, 0, 0, 0)}, "zero length"),
        ({"linear_velocity": (np.inf, 0, 0)}, "linear_velocity"),
        ({"restitution": 1.5}, "restitution"),
        ({"friction": -0.1}, "friction"),
    ],
)
def test_add_body_rejects_bad_input(kwargs, message):
    world = rbd.World()
    with pytest.raises(ValueError, match=message):
        world.add_body(CUBE, **kwargs)
    assert len(world) == 0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": np.nan}, "dt"),
        ({"gravity": (0, 0)}, "gravity"),
        ({"integrator": "leapfrog"}, "unknown integrator"),
        ({"linear_drag": -1.0}, "drag"),
    ],
)
def test_world_rejects_bad_options(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rbd.World(**kwargs)


def test_apply_force_and_accessors_reject_bad_input():
    world = rbd.World()
    body = world.add_body(CUBE, mass=1.0)
    with pytest.raises(ValueError, match="no body"):
        world.apply_force(3, (1, 0, 0))
    with pytest.raises(ValueError, match="force"):
        world.apply_force(body, (1, np.nan, 0))
    with pytest.raises(ValueError, match="duration"):
        world.apply_force(body, (1, 0, 0), duration=-1.0)
    with pytest.raises(ValueError, match="no body"):
        world.position(-1)
    with pytest.raises(ValueError, match="non-negative"):
        world.step(-2)


def test_many_bodies_grow_the_arrays_without_losing_state():
    world = rbd.World()
    for i in range(40):
        world.add_body(CUBE, mass=1.0, position=(i, 0, 0), linear_velocity=(0, i, 0))
    world.step(10)
    np.testing.assert_allclose(world.positions[:, 0], np.arange(40))
    np.testing.assert_allclose(world.positions[:, 1], np.arange(40) * world.time, rtol=1e-12)
    assert world.names[7] == "body7"


def test_non_collidable_bodies_fly_through_and_skip_the_collision_stages():
    world = rbd.World()
    a = world.add_body(CUBE, mass=1.0, position=(-1, 0, 0), linear_velocity=(2, 0, 0))
    world.add_body(CUBE, mass=1.0, position=(1, 0, 0), collidable=False)
    assert world.stages == ["integrate"]
    world.step(240)
    np.testing.assert_allclose(world.linear_velocity(a), [2, 0, 0])  # passed straight through
    world.add_body(CUBE, mass=1.0, position=(5, 0, 0))
    assert "narrow_phase" in world.stages


def test_stages_with_nothing_to_do_are_not_called():
    """Far apart: no candidate pair, so no narrow phase, tunnelling or contact call; the
    bodies stay inside their fat boxes, so the broad phase runs only once, when the first step
    finds the contacts where the bodies start (one bounds call more than steps); they move too
    fast to be still, so the sleep stage never runs."""
    world = rbd.World()
    world.add_body(CUBE, mass=1.0, position=(-50, 0, 0), linear_velocity=(1, 0, 0))
    world.add_body(CUBE, mass=1.0, position=(50, 0, 0), linear_velocity=(-1, 0, 0))
    world.step(20)
    calls = {name: entry["calls"] for name, entry in world.profile.items()}
    assert calls["integrate"] == calls["bounds"] - 1 == 20
    assert calls["broad_phase"] == 1
    assert calls["narrow_phase"] == calls["tunnelling"] == calls["contacts"] == 0
    assert calls["sleep"] == 0
    assert world.profile["narrow_phase"]["seconds"] == 0.0


def test_a_scene_pays_only_for_the_stages_it_uses():
    """Issue 6: 1000 far-apart bodies without gravity. Forces, narrow phase, tunnelling,
    contacts and sleep are never called; the broad phase only when a body leaves its fat box,
    on a small fraction of the steps. (What that is worth in time, a full step against the
    integration alone, is measured by validation/bench_effects.py.)"""
    world = far_apart_world()
    assert world.stages == [
        "contacts",
        "integrate",
        "bounds",
        "broad_phase",
        "narrow_phase",
        "tunnelling",
        "time_of_impact",
        "impacts",
        "sleep",
    ]
    world.step(480)
    calls = {name: entry["calls"] for name, entry in world.profile.items()}
    assert calls["integrate"] == calls["bounds"] - 1 == 481
    skipped_stages = ("forces", "contacts", "narrow_phase", "tunnelling", "time_of_impact",
                      "impacts", "sleep")  # fmt: skip
    for skipped in skipped_stages:
        assert calls[skipped] == 0, skipped
        assert world.profile[skipped]["seconds"] == 0.0
    assert 1 < calls["broad_phase"] <= 481 // 40


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e20, 1e200, 1e300])
def test_an_orientation_of_any_finite_size_is_normalised(scale):
    """Components near 1e200 once overflowed the norm to inf and made the quaternion zero
    (a ZeroDivisionError at step 0). (Shorter than 1e-12 is refused as zero length.)"""
    world = rbd.World()
    body = world.add_body(rbd.shapes.box(), orientation=[0.0, 0.0, scale, scale])
    np.testing.assert_allclose(world.orientations[body], [0, 0, 2**-0.5, 2**-0.5], atol=1e-15)
    world.step()
    assert np.all(np.isfinite(world.orientations))


def test_set_body_state_puts_a_body_where_and_how_fast_it_is_told():
    """A box tumbling through the air is put elsewhere with a new velocity: from then on it
    moves exactly as a box added there with that state does; a new orientation keeps its
    angular velocity, and the static floor is refused by name."""
    world = rbd.World(dt=0.01, gravity=(0, 0, -9.81))
    floor = world.add_body(rbd.shapes.box((4, 4, 0.2)), static=True, position=(0, 0, -0.1))
    shape = rbd.shapes.box((0.2, 0.3, 0.5))
    box = world.add_body(shape, mass=2.0, position=(0, 0, 1.0), angular_velocity=(1, 2, 3))
    world.step(10)
    turned = Rotation.from_euler("xyz", [0.3, -0.2, 0.9]).as_quat()
    spin = world.angular_velocity(box)
    world.set_body_state(box, position=(1.0, 2.0, 3.0), orientation=turned, velocity=(0.5, 0, 0))
    np.testing.assert_allclose(world.position(box), [1.0, 2.0, 3.0])
    np.testing.assert_allclose(world.linear_velocity(box), [0.5, 0.0, 0.0])
    np.testing.assert_allclose(world.angular_velocity(box), spin, atol=1e-12)
    fresh = rbd.World(dt=0.01, gravity=(0, 0, -9.81))
    twin = fresh.add_body(shape, mass=2.0, position=(1.0, 2.0, 3.0), orientation=turned,
                          linear_velocity=(0.5, 0, 0), angular_velocity=spin)  # fmt: skip
    world.step(20)
    fresh.step(20)
    np.testing.assert_allclose(world.position(box), fresh.position(twin), atol=1e-12)
    np.testing.assert_allclose(world.orientation(box), fresh.orientation(twin), atol=1e-12)
    world.set_body_state(box, angular_velocity=(0.0, 0.0, 0.0))
    np.testing.assert_allclose(world.angular_momentum(box), 0.0)
    with pytest.raises(ValueError, match="is static: set_body_state sets the state of dynamic"):
        world.set_body_state(floor, position=(0, 0, 0))
    with pytest.raises(ValueError, match="velocity"):
        world.set_body_state(box, velocity=(np.nan, 0, 0))


def test_set_body_state_wakes_a_sleeping_body_and_finds_its_contacts_again():
    """A box asleep on the floor, lifted and dropped from 0.5 m, falls and lands again."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81), sleeping=True)
    world.add_body(rbd.shapes.box((4, 4, 0.2)), static=True, position=(0, 0, -0.1))
    box = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), position=(0, 0, 0.1))
    world.step(2 * 240)
    assert world.sleeping[box]
    world.set_body_state(box, position=(0, 0, 0.6))
    assert not world.sleeping[box]
    world.step(240)
    assert world.position(box)[2] == pytest.approx(0.1, abs=2e-3)
