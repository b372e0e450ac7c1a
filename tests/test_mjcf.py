"""load_mjcf against MuJoCo's own reading of the same files: every pybullet_data MJCF file
loads or is refused clearly, mass properties and poses are MuJoCo's compiled ones, a cart-pole
moves as MuJoCo's does, and what one world joint cannot hold is refused."""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import thesis_rbd as rbd

mujoco = pytest.importorskip("mujoco", reason="load_mjcf compiles through mujoco")


def _mjcf(name: str) -> Path:
    pybullet_data = pytest.importorskip("pybullet_data", reason="the models ship with it")
    return Path(pybullet_data.getDataPath()) / "mjcf" / name


def _all_files() -> list[Path]:
    pybullet_data = pytest.importorskip("pybullet_data", reason="the models ship with it")
    return sorted((Path(pybullet_data.getDataPath()) / "mjcf").glob("*.xml"))


def _load(world, path):
    """load_mjcf, checking that it warns exactly where the file has what is not modelled."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = rbd.load_mjcf(world, path)
    assert bool(caught) == _has_unmodelled(path)
    return robot


def _has_unmodelled(path) -> bool:
    """Actuators or armature: in pybullet_data's files, every file with another thing not
    modelled (damping on a joint made generic, light bodies) has actuators too."""
    model = mujoco.MjModel.from_xml_path(str(path))
    return bool(model.nu) or bool(np.any(model.dof_armature > 0))


def test_every_pybullet_data_mjcf_file_loads_or_is_refused_clearly():
    """Each file either loads, warning of what it has that is not modelled, and takes half a
    second of steps with finite state and joints held, or is refused with a ValueError
    naming the file, and the world is left as it was."""
    loaded, refused = [], {}
    for path in _all_files():
        world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
        world.add_body(rbd.shapes.box((0.1, 0.1, 0.1)), static=True, position=(50, 0, 0))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                rbd.load_mjcf(world, path)
            except ValueError as exc:
                assert str(path) in str(exc)
                assert world.bodies.count == 1 and len(world.joints["gap"]) == 0
                refused[path.name] = str(exc)
                continue
        assert bool(caught) == _has_unmodelled(path), path.name
        world.step(120)
        assert np.all(np.isfinite(world.positions)), path.name
        if len(world.joints["gap"]):
            assert np.abs(world.joints["gap"]).max() < 1e-6, path.name
        loaded.append(path.name)
    print(f"{len(loaded)} load: {loaded}")
    for name, message in refused.items():
        print(f"refused {name}: {message.splitlines()[0][-160:]}")
    # the files MuJoCo itself compiles all load, but the one with tendons
    compiled = [p.name for p in _all_files() if _compiles(p)]
    assert sorted(loaded) == sorted(n for n in compiled if n != "humanoid_symmetric_no_ground.xml")


def _compiles(path) -> bool:
    try:
        mujoco.MjModel.from_xml_path(str(path))
    except ValueError:
        return False
    return True


def test_the_humanoid_falls_and_comes_to_rest():
    """pybullet_data's humanoid (13 bodies, 21 hinges: the abdomen's, hips' and shoulders'
    about one point each, one generic joint; the ankles' about two points of each foot,
    joined through a light body), its torso free as pybullet loads it, dropped on its floor
    from where the file stands it: 4 s of falling and lying, every joint held within 1 mm,
    nothing non-finite, no body below the floor, and at the end at rest (kinetic energy
    below a thousandth of what the fall released). By MuJoCo's rule, the torso without a
    joint is welded to the world."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    welded = rbd.World()
    with pytest.warns(UserWarning, match="right_foot.*light bod"):
        hanging = rbd.load_mjcf(welded, _mjcf("humanoid.xml"))
    assert welded.bodies.static[hanging.bodies["torso"]]
    with pytest.warns(UserWarning, match="right_foot.*light bod"):
        robot = rbd.load_mjcf(world, _mjcf("humanoid.xml"), free_roots=True)
    assert sum(world.joints["kind"] == "generic") == 5  # abdomen z-y, two hips, two shoulders
    moving = np.flatnonzero(~world.bodies.static)
    start = world.potential_energy()
    gap = 0.0
    for _ in range(4 * 240):
        world.step()
        gap = max(gap, np.abs(world.joints["gap"]).max())
    released = start - world.potential_energy()
    print(f"humanoid: joint gap {gap:.3g} m, energy released {released:.3g} J, "
          f"kinetic at 4 s {world.kinetic_energy():.3g} J")  # fmt: skip
    assert np.all(np.isfinite(world.positions))
    assert gap < 1e-3
    assert world.positions[moving, 2].min() > 0.0
    assert released > 0.0 and world.kinetic_energy() < 1e-3 * released
    assert robot.bodies["torso"] in moving


def test_mass_properties_and_poses_are_mujocos():
    """The ant's bodies: mass, centre of mass and world inertia are MuJoCo's compiled ones
    (welded bodies summed: its torso is welded to the world, so each leg's hip link is the
    root of one body), and every body's frame is where MuJoCo's kinematics puts it."""
    path = _mjcf("ant.xml")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    world = rbd.World()
    robot = _load(world, path)
    for b in range(1, model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        body = robot.bodies[name]
        if world.bodies.static[body]:
            continue
        if model.body_jntnum[b] == 0:
            continue  # welded into its parent's body: summed below
        members = [b] + [
            c for c in range(b + 1, model.nbody)
            if model.body_parentid[c] == b and model.body_jntnum[c] == 0
        ]  # fmt: skip
        mass = sum(model.body_mass[m] for m in members)
        assert world.bodies.mass[body] == pytest.approx(mass, rel=1e-12)
        com = sum(model.body_mass[m] * data.xipos[m] for m in members) / mass
        np.testing.assert_allclose(world.positions[body], com, atol=1e-12)
        inertia = np.zeros((3, 3))
        for m in members:
            R = data.ximat[m].reshape(3, 3)
            r = data.xipos[m] - com
            inertia += R @ np.diag(model.body_inertia[m]) @ R.T
            inertia += model.body_mass[m] * (r @ r * np.eye(3) - np.outer(r, r))
        R = world.transform(body)[:3, :3]
        ours = R @ world.bodies.inertia_body[body] @ R.T
        np.testing.assert_allclose(ours, inertia, atol=1e-12)
        T = world.transform(body)
        np.testing.assert_allclose(T[:3, 3], data.xpos[b], atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], data.xmat[b].reshape(3, 3), atol=1e-12)


def test_a_cart_pole_moves_as_mujocos_does():
    """inverted_double_pendulum.xml (a cart on a damped slider, two hinged poles, no
    armature) tipped by 0.1 rad and released for 1 s at dt = 1/240: the joint positions'
    largest difference from MuJoCo's RK4 at dt / 16 (the reference) is at most twice that of
    MuJoCo's default Euler at dt (its own discretisation error)."""
    path = _mjcf("inverted_double_pendulum.xml")
    dt, seconds, start = 1 / 240, 1.0, np.array([0.0, 0.1, -0.05])
    steps = round(seconds / dt)

    def peer(integrator, substeps):
        model = mujoco.MjModel.from_xml_path(str(path))
        model.opt.integrator = integrator
        model.opt.timestep = dt / substeps
        data = mujoco.MjData(model)
        data.qpos[:] = start
        out = []
        for _ in range(steps):
            for _ in range(substeps):
                mujoco.mj_step(model, data)
            out.append(data.qpos.copy())
        return np.array(out)

    reference = peer(mujoco.mjtIntegrator.mjINT_RK4, 16)
    peer_error = np.abs(_wrapped(peer(mujoco.mjtIntegrator.mjINT_EULER, 1) - reference))
    peer_error = peer_error.max(axis=0)
    model = mujoco.MjModel.from_xml_path(str(path))
    world = rbd.World(dt=dt, gravity=tuple(model.opt.gravity))
    robot = _load(world, path)
    assert robot.joint_names == ["slider", "hinge", "hinge2"]
    robot.set_joint_positions(start)
    ours = []
    for _ in range(steps):
        world.step()
        ours.append(robot.joint_positions())
    # the poles swing through a full turn: angles compared the short way round
    ours_error = np.abs(_wrapped(np.array(ours) - reference)).max(axis=0)
    print("cart-pole, largest joint difference from MuJoCo RK4 at dt/16:")
    print("  ours at dt          ", np.round(ours_error, 5))
    print("  MuJoCo Euler at dt  ", np.round(peer_error, 5))
    assert np.all(ours_error <= 2.0 * peer_error)


def _wrapped(difference: np.ndarray) -> np.ndarray:
    """Joint differences (steps, 3) with the hinges' (columns 1, 2) taken into (-pi, pi]."""
    out = difference.copy()
    out[:, 1:] = (out[:, 1:] + math.pi) % (2 * math.pi) - math.pi
    return out


_TEMPLATE = """<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
<body name="base" pos="0 0 1"><geom type="box" size="0.1 0.1 0.1"/>
<body name="limb" pos="0 0 -0.3"><geom type="capsule" size="0.03 0.1"/>{joints}</body>
</body></worldbody></mujoco>"""


@pytest.mark.parametrize(
    ("joints", "message"),
    [
        (
            '<joint name="a" type="hinge" axis="1 0 0"/>'
            '<joint name="b" type="hinge" axis="1 1 0"/>',
            r"joint 'b'.s axis is slanted",
        ),
        ('<joint name="a" type="ball" limited="true" range="0 30"/>', "ball joint's limits"),
    ],
)
def test_joints_one_world_joint_cannot_hold_are_refused(tmp_path, joints, message):
    path = tmp_path / "model.xml"
    path.write_text(_TEMPLATE.format(joints=joints))
    world = rbd.World()
    with pytest.raises(ValueError, match=message):
        rbd.load_mjcf(world, path)
    assert world.bodies.count == 0


def test_hinges_about_two_points_are_joined_through_a_light_body(tmp_path):
    """Two hinges 5 cm apart on one body (as the humanoid's ankles): two hinges with a light
    body between them; set to hinge angles through the Robot, the body is where MuJoCo's
    kinematics puts it for the same angles, and the two bodies' mass is the file's."""
    joints = (
        '<joint name="a" type="hinge" axis="0 1 0" pos="0 0 0.1"/>'
        '<joint name="b" type="hinge" axis="1 0 0.5" pos="0 0 0.05"/>'
    )
    path = tmp_path / "ankle.xml"
    path.write_text(_TEMPLATE.format(joints=joints))
    world = rbd.World(dt=1 / 240, gravity=(0, 0, 0))
    with pytest.warns(UserWarning, match="limb.*2 points.*1 light bod"):
        robot = rbd.load_mjcf(world, path)
    assert robot.joint_names == ["a", "b"]
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    limb = robot.bodies["limb"]
    light = world.names.index("limb:0")
    mass = world.bodies.mass[limb] + world.bodies.mass[light]
    assert mass == pytest.approx(model.body_mass[model.nbody - 1], rel=1e-12)
    for angles in [(0.4, -0.3), (-1.0, 0.8)]:
        robot.set_joint_positions(np.array(angles))
        data.qpos[:] = angles
        mujoco.mj_kinematics(model, data)
        T = world.transform(limb)
        np.testing.assert_allclose(T[:3, 3], data.xpos[model.nbody - 1], atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], data.xmat[model.nbody - 1].reshape(3, 3),
                                   atol=1e-12)  # fmt: skip
        np.testing.assert_allclose(robot.joint_positions(), angles, atol=1e-12)


def test_hinges_about_one_point_are_one_generic_joint(tmp_path):
    """A hip's three hinges (x, then z, then y, as the humanoid's) about one point are one
    generic joint, its frame x, z and -y: set in MuJoCo to hinge angles (a, b, c), the limb's
    orientation reads back as the joint's turns (a, b, -c); turned past its y limit (20
    deg), one step puts it back on it, read as -20 deg about the frame's -y."""
    joints = (
        '<joint name="hx" type="hinge" axis="1 0 0" range="-25 5"/>'
        '<joint name="hz" type="hinge" axis="0 0 1" range="-60 35"/>'
        '<joint name="hy" type="hinge" axis="0 1 0" range="-110 20"/>'
    )
    path = tmp_path / "hip.xml"
    path.write_text(_TEMPLATE.format(joints=joints))
    world = rbd.World(dt=1 / 240, gravity=(0, 0, 0))
    robot = rbd.load_mjcf(world, path)
    assert robot.joint_names == []  # a generic joint is no single coordinate
    (joint,) = robot.tree_joints
    assert world.joints["kind"][joint] == "generic"
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    limb = robot.bodies["limb"]
    d = math.pi / 180
    for angles in [(-0.2, 0.3, -1.0), (0.05, -0.9, 0.3), (-20 * d, 10 * d, 30 * d)]:
        data.qpos[:] = angles
        mujoco.mj_kinematics(model, data)
        w, x, y, z = data.xquat[model.nbody - 1]
        world.set_body_state(limb, orientation=(x, y, z, w))
        turns = world.joints["axis_positions"][joint][3:]
        np.testing.assert_allclose(turns, (angles[0], angles[1], -angles[2]), atol=1e-12)
    world.step()
    assert world.joints["axis_positions"][joint][5] == pytest.approx(-20 * d, abs=1e-9)


def test_without_mujoco_the_message_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(ImportError, match="pip install mujoco"):
        rbd.load_mjcf(rbd.World(), _mjcf("hello_mjcf.xml"))
