"""Scene files: every field reaches the world, built-ins behave as described, faults are named."""

import math
import textwrap

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.scene import SceneError


def write_scene(folder, text, name="scene.toml"):
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


# ---------------------------------------------------------------------- every field
def test_every_field_reaches_the_world(tmp_path):
    trimesh.creation.box(extents=(2.0, 2.0, 2.0)).export(tmp_path / "cube.stl")
    floor = trimesh.Trimesh([[-5, -5, 0], [5, -5, 0], [0, 5, 0]], [[0, 1, 2]])  # open: static
    floor.export(tmp_path / "floor.obj")
    path = write_scene(
        tmp_path,
        """
        description = "Everything at once"
        seconds = 0.5

        [world]
        dt = 0.01
        gravity = [0.0, 0.0, -9.81]
        integrator = "midpoint"
        linear_drag = 0.1
        quadratic_drag = 0.2
        angular_drag = 0.3

        [[body]]
        name = "floor"
        shape = { type = "mesh", path = "floor.obj" }
        static = true
        restitution = 1.0
        friction = 0.9

        [[body]]
        name = "crate"
        shape = { type = "mesh", path = "cube.stl", scale = 0.5 }
        density = 2.0
        position = [1.0, 2.0, 3.0]
        orientation = [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]
        linear_velocity = [1.0, 0.0, 0.0]
        angular_velocity = [0.0, 0.0, 2.0]
        restitution = 0.5
        friction = 0.25

        [[body.force]]
        force = [0.0, 0.0, 30.0]
        point = [1.0, 2.5, 3.0]
        duration = 0.2

        [[body]]
        mass = 3.0
        [body.shape]
        type = "torus"
        major_radius = 1.0
        minor_radius = 0.25
        major_sections = 12
        minor_sections = 8
        """,
    )
    scene = rbd.load_scene(path)
    assert scene.name == "scene" and scene.summary == "Everything at once"
    assert scene.seconds == 0.5
    world = scene.build()
    assert world.dt == 0.01 and world.integrator == "midpoint"
    np.testing.assert_array_equal(world.gravity, [0, 0, -9.81])
    assert (world.drag.linear, world.drag.quadratic, world.drag.angular) == (0.1, 0.2, 0.3)
    assert world.names == ["floor", "crate", "body2"]
    b = world.bodies
    np.testing.assert_array_equal(b.static, [True, False, False])
    np.testing.assert_array_equal(b.restitution, [1.0, 0.5, 0.0])
    np.testing.assert_array_equal(b.friction, [0.9, 0.25, 0.0])
    # crate: a 1 m cube (2 m scaled by 0.5) of density 2
    assert b.mass[1] == pytest.approx(2.0)
    np.testing.assert_allclose(world.position(1), [1, 2, 3])
    np.testing.assert_allclose(world.orientation(1), [0, 0, math.sqrt(0.5), math.sqrt(0.5)])
    np.testing.assert_allclose(world.linear_velocity(1), [1, 0, 0], atol=1e-14)
    np.testing.assert_allclose(world.angular_velocity(1), [0, 0, 2], atol=1e-12)
    assert b.mass[2] == pytest.approx(3.0)
    assert len(b.meshes[2].faces) == 2 * 12 * 8
    assert len(world.applied_forces) == 1
    assert world.stages[:3] == ["forces", "contacts", "integrate"]  # collision stages follow


@pytest.mark.parametrize("extension", ["obj", "stl", "ply", "glb"])
def test_mesh_shapes_load_from_every_format(tmp_path, extension):
    trimesh.creation.box(extents=(1.0, 2.0, 3.0)).export(tmp_path / f"part.{extension}")
    (tmp_path / "scenes").mkdir()
    path = write_scene(
        tmp_path / "scenes",
        f"""
        [[body]]
        shape = {{ type = "mesh", path = "../part.{extension}" }}
        mass = 6.0
        """,
    )
    world = rbd.load_scene(path).build()
    assert len(world.bodies.meshes[0].faces) == 12
    # 1 x 2 x 3 box of mass 6: I = m/12 (b^2 + c^2, ...)
    np.testing.assert_allclose(np.diag(world.bodies.inertia_body[0]), [6.5, 5.0, 2.5])


def test_contact_settings_reach_the_world(tmp_path):
    path = write_scene(
        tmp_path,
        """
        [world]
        contact_response = false
        contact_solver = "exact"
        contact_iterations = 12
        friction_sides = 4
        penetration = "bias"
        sleeping = false
        narrow_phase = "mesh"
        """,
    )
    world = rbd.load_scene(path).build()
    assert world.contact_response is False
    assert world.narrow_phase == "mesh"
    settings = world.contact_settings
    assert (settings.solver, settings.iterations, settings.friction_sides) == ("exact", 12, 4)
    assert settings.penetration == "bias"
    assert "sleep" not in world.stages
    bad = write_scene(tmp_path, '[world]\ncontact_solver = "magic"\n', name="bad.toml")
    with pytest.raises(SceneError, match=r"bad\.toml: \[world\]: .*magic"):
        rbd.load_scene(bad)
    with pytest.raises(SceneError, match=r"overrides: .*magic"):
        rbd.load_scene(path).with_world(contact_solver="magic")
    # absolute tolerances are gone: the message says why
    old = write_scene(tmp_path, "[world]\nslop = 0.001\n", name="old.toml")
    with pytest.raises(SceneError, match=r"slop.*relative"):
        rbd.load_scene(old)
    with pytest.raises(SceneError, match=r"overrides: unknown narrow_phase 'convex'"):
        rbd.load_scene(path).with_world(narrow_phase="convex")


def test_defaults_are_the_world_defaults(tmp_path):
    path = write_scene(tmp_path, '[[body]]\nshape = { type = "icosphere" }\n')
    scene = rbd.load_scene(path)
    assert scene.seconds == 5.0 and scene.description == ""
    world = scene.build()
    reference = rbd.World()
    assert world.dt == reference.dt and world.integrator == reference.integrator
    np.testing.assert_array_equal(world.gravity, [0, 0, 0])
    # no gravity, no force, one body: it only moves freely (a "sleep" stage may follow)
    assert world.stages[0] == "integrate" and "forces" not in world.stages
    assert "broad_phase" not in world.stages and not scene.record_contacts
    np.testing.assert_array_equal(world.orientation(0), [0, 0, 0, 1])


def test_build_gives_a_fresh_world_each_time():
    scene = rbd.scenes.get("projectile")
    first = scene.build()
    first.step(10)
    second = scene.build()
    assert second.time == 0.0
    np.testing.assert_array_equal(second.position(0), [0, 0, 0])


def test_with_world_overrides_and_validates():
    scene = rbd.scenes.get("dzhanibekov")
    faster = scene.with_world(dt=0.01, integrator="euler")
    assert faster.build().dt == 0.01 and faster.build().integrator == "euler"
    assert scene.build().dt == pytest.approx(1 / 240)  # the original is untouched
    with pytest.raises(SceneError, match="'dt': must be > 0"):
        scene.with_world(dt=-1.0)
    with pytest.raises(SceneError, match="unknown key 'spin'"):
        scene.with_world(spin=1.0)


# ---------------------------------------------------------------------- built-ins
def test_builtins_are_listed_and_load():
    assert {"dzhanibekov", "thesis_example", "projectile"} <= set(rbd.scenes.names())
    assert rbd.scenes.DEFAULT == "dzhanibekov"
    for name in rbd.scenes.names():
        scene = rbd.scenes.get(name)
        assert scene.name == name and scene.summary and scene.seconds > 0
        assert len(scene.build()) >= 1
    with pytest.raises(SceneError, match="no built-in scene 'nope'; built-ins: bouncing_ball, "):
        rbd.scenes.get("nope")


def test_dzhanibekov_flips_when_the_description_says():
    scene = rbd.scenes.get("dzhanibekov")
    trajectory = rbd.simulate(scene.build(), 10.5)
    # the body y axis (spin axis) reverses its world direction at each flip
    spin_axis = Rotation.from_quat(trajectory.orientations[:, 0]).apply([0, 1, 0])
    flips = trajectory.times[np.flatnonzero(np.diff(np.sign(spin_axis[:, 1])))]
    assert len(flips) == 2
    np.testing.assert_allclose(flips, [3.04, 9.85], atol=0.03)


def test_thesis_example_pushes_the_second_box_for_one_second():
    scene = rbd.scenes.get("thesis_example")
    world = scene.build()
    assert world.names == ["box1", "box2"]
    np.testing.assert_allclose(world.bodies.mass, [10.0, 10.0])
    np.testing.assert_allclose(world.position(0), [2, 0, 0])
    # 1 rad about (-1, -2, 0)/sqrt(5)
    expected = Rotation.from_rotvec(np.array([-1.0, -2.0, 0.0]) / math.sqrt(5)).as_quat()
    np.testing.assert_allclose(world.orientation(1), expected, atol=1e-15)
    world.step(480)  # 2 s: the force (2, 0, 0) N lasted 1 s
    np.testing.assert_allclose(world.linear_momentum(1), [2, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(world.position(1), [0.1 + 0.2, 0, 0], rtol=1e-9)
    np.testing.assert_array_equal(world.position(0), [2, 0, 0])
    assert "contact" in scene.description


def test_projectile_drag_shortens_the_flight():
    scene = rbd.scenes.get("projectile")
    with_drag = rbd.simulate(scene.build(), 2.0)
    without = rbd.simulate(scene.with_world(quadratic_drag=0.0).build(), 2.0)
    t = without.times
    np.testing.assert_allclose(without.positions[:, 0, 2], 12.0 * t - 0.5 * 9.81 * t**2, atol=1e-9)
    assert with_drag.positions[:, 0, 2].max() < without.positions[:, 0, 2].max() - 0.1
    assert with_drag.positions[-1, 0, 0] < without.positions[-1, 0, 0] - 0.5


# ---------------------------------------------------------------------- faults, named
BOX = 'shape = { type = "box", extents = [1.0, 1.0, 1.0] }'
JOINT = '[[joint]]\nkind = "revolute"\nbody_a = "a"\nanchor = [0, 0, 0]\n'

FAULTS = {
    "unknown shape": (
        '[[body]]\nname = "a"\nshape = { type = "cone" }\n',
        ["body[0] 'a'", "field 'shape.type'", "unknown shape 'cone'", "box, cylinder"],
    ),
    "missing mesh file": (
        '[[body]]\nshape = { type = "mesh", path = "missing.obj" }\n',
        ["body[0] 'body0'", "field 'shape.path'", "mesh file not found", "missing.obj"],
    ),
    "negative dt": ("[world]\ndt = -0.01\n", ["[world]", "field 'dt'", "must be > 0", "-0.01"]),
    "zero dt": ("[world]\ndt = 0\n", ["[world]", "field 'dt'", "must be > 0"]),
    "string for a number": (
        f'[[body]]\n{BOX}\nmass = "heavy"\n',
        ["body[0]", "field 'mass'", "must be a number", "'heavy' (string)"],
    ),
    "boolean for a number": (
        f"[[body]]\n{BOX}\nfriction = true\n",
        ["field 'friction'", "must be a number", "True (boolean)"],
    ),
    "short vector": (
        f"[[body]]\n{BOX}\nposition = [1.0, 2.0]\n",
        ["field 'position'", "array of 3 numbers", "[1.0, 2.0]"],
    ),
    "string in a vector": (
        '[world]\ngravity = [0, 0, "down"]\n',
        ["[world]", "field 'gravity'", "must be a number", "'down'"],
    ),
    "float for an integer": (
        '[[body]]\nshape = { type = "icosphere", subdivisions = 1.5 }\n',
        ["field 'shape.subdivisions'", "must be an integer", "1.5"],
    ),
    "string for a boolean": (
        f'[[body]]\n{BOX}\nstatic = "yes"\n',
        ["field 'static'", "must be true or false", "'yes'"],
    ),
    "world is not a table": ("world = 3\n", ["top level", "field 'world'", "must be a table"]),
    "unknown top-level key": ("secs = 3\n", ["top level", "unknown key 'secs'", "'seconds'"]),
    "unknown world key": (
        "[world]\ngravty = [0, 0, -9.81]\n",
        ["[world]", "unknown key 'gravty'", "did you mean 'gravity'"],
    ),
    "unknown body key": (
        f"[[body]]\n{BOX}\nmas = 1.0\n",
        ["body[0]", "unknown key 'mas'", "did you mean 'mass'"],
    ),
    "unknown shape parameter": (
        '[[body]]\nshape = { type = "box", radius = 1.0 }\n',
        ["field 'shape'", "unknown box parameter 'radius'", "allowed: type, extents"],
    ),
    "unknown force key": (
        f"[[body]]\n{BOX}\n[[body.force]]\nforce = [1, 0, 0]\ntime = 1.0\n",
        ["body[0] 'body0' force[0]", "unknown key 'time'"],
    ),
    "unknown integrator": (
        '[world]\nintegrator = "rk5"\n',
        ["field 'integrator'", "unknown integrator 'rk5'", "rk4"],
    ),
    "negative drag": ("[world]\nangular_drag = -1\n", ["field 'angular_drag'", "must be >= 0"]),
    "mass and density": (
        f"[[body]]\n{BOX}\nmass = 1.0\ndensity = 2.0\n",
        ["body[0]", "give 'mass' or 'density', not both"],
    ),
    "negative mass": (f"[[body]]\n{BOX}\nmass = -1.0\n", ["field 'mass'", "must be > 0", "-1.0"]),
    "restitution above one": (
        f"[[body]]\n{BOX}\nrestitution = 1.5\n",
        ["field 'restitution'", "must lie in [0, 1]", "1.5"],
    ),
    "negative friction": (f"[[body]]\n{BOX}\nfriction = -0.1\n", ["field 'friction'", ">= 0"]),
    "zero quaternion": (
        f"[[body]]\n{BOX}\norientation = [0, 0, 0, 0]\n",
        ["field 'orientation'", "zero length"],
    ),
    "missing shape": ("[[body]]\nmass = 1.0\n", ["body[0] 'body0'", "missing the 'shape' table"]),
    "missing shape type": ("[[body]]\nshape = { radius = 1.0 }\n", ["field 'shape'", "'type'"]),
    "bad box extents": (
        '[[body]]\nshape = { type = "box", extents = [1.0, -1.0, 1.0] }\n',
        ["field 'shape'", "box extents must be positive"],
    ),
    "fat torus": (
        '[[body]]\nshape = { type = "torus", major_radius = 1.0, minor_radius = 1.0 }\n',
        ["field 'shape'", "minor_radius < major_radius"],
    ),
    "force without force": (
        f"[[body]]\n{BOX}\n[[body.force]]\nduration = 1.0\n",
        ["force[0]", "missing 'force'"],
    ),
    "zero duration": (
        f"[[body]]\n{BOX}\n[[body.force]]\nforce = [1, 0, 0]\nduration = 0.0\n",
        ["force[0]", "field 'duration'", "must be > 0"],
    ),
    "duplicate names": (
        f'[[body]]\nname = "a"\n{BOX}\n[[body]]\nname = "a"\n{BOX}\n',
        ["body[1] 'a'", "already used by body[0]"],
    ),
    "negative seconds": ("seconds = -2\n", ["top level", "field 'seconds'", "must be > 0"]),
    "invalid TOML": ("[world\ndt = 1\n", ["not valid TOML", "line 1"]),
    "one limit": (
        f'[[body]]\nname = "a"\n{BOX}\n{JOINT}limits = [1.0]\n',
        ["joint[0]", "field 'limits'", "must be [lower, upper]"],
    ),
    "limit not a number": (
        f'[[body]]\nname = "a"\n{BOX}\n{JOINT}limits = [nan, 1.0]\n',
        ["joint[0]", "field 'limits'", "must be numbers"],
    ),
    "unknown motor key": (
        f'[[body]]\nname = "a"\n{BOX}\n{JOINT}motor = {{ speed = 1.0 }}\n',
        ["joint[0]", "field 'motor'", "unknown motor key 'speed'", "velocity"],
    ),
    "motor value not a number": (
        f'[[body]]\nname = "a"\n{BOX}\n{JOINT}motor = {{ velocity = "fast" }}\n',
        ["joint[0]", "field 'motor.velocity'", "must be a number"],
    ),
}


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_faults_name_the_table_field_and_value(tmp_path, fault):
    text, expected = FAULTS[fault]
    path = write_scene(tmp_path, text, name="bad.toml")
    with pytest.raises(SceneError) as error:
        rbd.load_scene(path)
    message = str(error.value)
    assert message.startswith(str(path)), message
    for fragment in expected:
        assert fragment in message, f"{fragment!r} not in {message!r}"


def test_open_mesh_cannot_be_dynamic(tmp_path):
    trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]).export(tmp_path / "tri.obj")
    path = write_scene(tmp_path, '[[body]]\nshape = { type = "mesh", path = "tri.obj" }\n')
    with pytest.raises(SceneError, match=r"field 'shape': the mesh is not a closed.*static = true"):
        rbd.load_scene(path)


def test_unreadable_mesh_file_is_named(tmp_path):
    (tmp_path / "junk.stl").write_bytes(b"this is not an STL file")
    path = write_scene(tmp_path, '[[body]]\nshape = { type = "mesh", path = "junk.stl" }\n')
    with pytest.raises(SceneError, match=r"field 'shape.path'.*junk\.stl"):
        rbd.load_scene(path)


def test_missing_scene_file_is_named(tmp_path):
    with pytest.raises(SceneError, match=r"scene file not found: .*absent\.toml"):
        rbd.load_scene(tmp_path / "absent.toml")


def test_record_contacts_is_read_and_checked(tmp_path):
    body = '[[body]]\nshape = { type = "box" }\n'
    assert not rbd.load_scene(write_scene(tmp_path, body)).record_contacts
    assert rbd.load_scene(write_scene(tmp_path, "record_contacts = true\n" + body)).record_contacts
    with pytest.raises(SceneError, match="field 'record_contacts': must be true or false"):
        rbd.load_scene(write_scene(tmp_path, "record_contacts = 1\n" + body))


# ---------------------------------------------------------------------- collision built-ins
COLLISION_BUILTINS = (
    "bouncing_ball", "box_landing", "stack", "pyramid", "dominoes", "rain", "tori_demo"
)  # fmt: skip


def test_collision_builtins_are_shipped():
    assert set(COLLISION_BUILTINS) <= set(rbd.scenes.names())
    for name in COLLISION_BUILTINS:
        world = rbd.scenes.get(name).build()
        assert {"broad_phase", "narrow_phase"} <= set(world.stages), name


def test_bouncing_ball_apex_is_e_squared_of_the_drop():
    scene = rbd.scenes.get("bouncing_ball")
    world = scene.build()
    ball = world.names.index("ball")
    assert len(world.bodies.meshes[ball].faces) == 1280  # icosphere, 3 subdivisions
    trajectory = rbd.simulate(world, 1.5)
    lowest = trajectory.positions[:, ball, 2] - 0.5  # the ball's lowest point above the floor
    assert lowest[0] == pytest.approx(1.0)
    after_bounce = lowest[trajectory.times > 0.5]
    assert after_bounce.max() == pytest.approx(0.8**2, abs=0.02)


def test_box_lands_flat_and_rests_on_its_face():
    trajectory = rbd.simulate(rbd.scenes.get("box_landing").build(), 2.5)
    cube = trajectory.names.index("cube")
    # it bounces, comes down on its bottom face again and rests there, not on an edge; at
    # no frame does it sink more than 1 % of its edge into the floor
    assert trajectory.positions[-1, cube, 2] == pytest.approx(0.5, abs=0.01)
    assert trajectory.positions[:, cube, 2].min() >= 0.5 - 0.01
    turned = Rotation.from_quat(trajectory.orientations[:, cube]).magnitude()
    assert turned.max() < 0.1


def test_every_domino_falls():
    trajectory = rbd.simulate(rbd.scenes.get("dominoes").build(), 4.0, record_every=24)
    dominoes = [i for i, name in enumerate(trajectory.names) if name.startswith("domino")]
    assert len(dominoes) == 10
    # standing, a domino's centre is 1 m up; toppled against the next or flat, below 0.5 m
    assert np.all(trajectory.positions[-1, dominoes, 2] < 0.5)


def test_tori_demo_detects_without_responding():
    scene = rbd.scenes.get("tori_demo")
    assert scene.record_contacts and scene.world["contact_response"] is False
    world = scene.build()
    assert "contacts" not in world.stages  # detection only
    b = world.names.index("torus_b")
    assert len(world.bodies.meshes[b].faces) == 5000
    trajectory = rbd.simulate(world, 3.0, record_every=6, record_contacts=True)
    # B slides on its set path (constant velocity and spin), unperturbed by A
    np.testing.assert_allclose(trajectory.positions[:, b, 0], -3.0 + trajectory.times, atol=1e-9)
    np.testing.assert_allclose(world.linear_velocity(b), [1, 0, 0], atol=1e-12)
    counts = trajectory.contact_counts()
    x = trajectory.positions[:, b, 0]
    assert np.all(counts[x < -2.7] == 0)  # apart at the start
    assert np.all(counts[(x > -1.2) & (x < -0.8)] == 0)  # chain-linked but apart
    assert np.all(counts[(x > -0.4) & (x < 0.01)] > 0)  # cutting through A


def test_a_scene_file_with_a_byte_order_mark_loads(tmp_path):
    """Some Windows editors start UTF-8 files with a byte-order mark; it once failed at line
    1, column 1."""
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + b'[[body]]\nshape = { type = "box" }\n')
    assert len(rbd.load_scene(path).bodies) == 1


# ---------------------------------------------------------------------- jointed built-ins
def test_door_stops_dead_at_its_hinge_limit():
    """The door swings at 4.3 rad/s (1 degree per step) into its 100 degree limit: at no step
    past it by more than 0.6 degrees, and at rest within 0.01 degrees of it."""
    scene = rbd.scenes.get("door")
    world = scene.build()
    angles = []
    for _ in range(round(scene.seconds / world.dt)):
        world.step()
        angles.append(world.joints["position"][0])
    degrees = np.degrees(angles)
    assert degrees[0] == pytest.approx(np.degrees(4.3 * world.dt), rel=1e-3)  # 1 degree a step
    assert degrees.max() <= 100.0 + 0.6
    assert abs(degrees[-1] - 100.0) <= 0.01
    assert abs(world.joints["velocity"][0]) < 1e-9


def test_slider_motor_reaches_its_target_at_its_force_cap():
    """1 kg pushed with the motor's 2 N cap accelerates at 2 m/s^2: 99 % of the 1 m/s target
    at 0.495 s (within 1 %), and never more than 0.1 % over it."""
    world = rbd.scenes.get("slider").build()
    speeds = []
    for _ in range(round(1.0 / world.dt)):
        world.step()
        speeds.append(world.joints["velocity"][0])
    speeds = np.array(speeds)
    assert (np.argmax(speeds >= 0.99) + 1) * world.dt == pytest.approx(0.495, rel=0.01)
    assert speeds.max() <= 1.001
