"""load_urdf against the files it reads: link mass properties against the URDF numbers (read
here with xml.etree), joints against pybullet's reading of the same file, a pendulum's period
against its closed form, a servo-held arm against its targets, and bad files refused."""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import thesis_rbd as rbd

pytest.importorskip("yourdfpy", reason="load_urdf parses through yourdfpy")


def _data(name: str) -> Path:
    pybullet_data = pytest.importorskip("pybullet_data", reason="the models ship with it")
    return Path(pybullet_data.getDataPath()) / name


def _rpy_matrix(rpy) -> np.ndarray:
    """URDF's rpy: fixed-axis roll about x, then pitch about y, then yaw about z."""
    r, p, y = rpy
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _urdf_inertials(path: Path) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """Each link's mass, centre of mass (3,) and inertia (3, 3) in its link frame, read with
    xml.etree: the oracle, independent of yourdfpy."""
    out = {}
    for link in ET.parse(path).getroot().iter("link"):
        inertial = link.find("inertial")
        origin = inertial.find("origin")
        xyz = np.zeros(3) if origin is None else np.fromstring(origin.get("xyz", "0 0 0"), sep=" ")
        rpy = np.zeros(3) if origin is None else np.fromstring(origin.get("rpy", "0 0 0"), sep=" ")
        a = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
        tensor = np.array([
            [a["ixx"], a["ixy"], a["ixz"]],
            [a["ixy"], a["iyy"], a["iyz"]],
            [a["ixz"], a["iyz"], a["izz"]],
        ])  # fmt: skip
        R = _rpy_matrix(rpy)
        out[link.get("name")] = (float(inertial.find("mass").get("value")), xyz, R @ tensor @ R.T)
    return out


def _pybullet_joints(path: Path) -> list[tuple[str, str]]:
    """(name, kind) of every joint as pybullet's getJointInfo reads the file, its kind in
    our names (pybullet reads a continuous joint as revolute, as load_urdf does)."""
    pybullet = pytest.importorskip("pybullet")
    kinds = {
        pybullet.JOINT_REVOLUTE: "revolute",
        pybullet.JOINT_PRISMATIC: "prismatic",
        pybullet.JOINT_FIXED: "fixed",
    }
    client = pybullet.connect(pybullet.DIRECT)
    try:
        robot = pybullet.loadURDF(str(path), physicsClientId=client)
        infos = [
            pybullet.getJointInfo(robot, j, physicsClientId=client)
            for j in range(pybullet.getNumJoints(robot, physicsClientId=client))
        ]
    finally:
        pybullet.disconnect(client)
    return [(info[1].decode(), kinds[info[2]]) for info in infos]


@pytest.mark.parametrize(
    ("name", "fixed_base"), [("kuka_iiwa/model.urdf", True), ("r2d2.urdf", False)]
)
def test_link_mass_properties_are_the_files(name, fixed_base):
    path = _data(name)
    world = rbd.World()
    robot = rbd.load_urdf(world, path, fixed_base=fixed_base, merge_fixed_links=False)
    b = world.bodies
    for link, (mass, center, inertia) in _urdf_inertials(path).items():
        body = robot.bodies[link]
        if mass == 0.0:  # the iiwa's base: a static body under a fixed base
            assert b.static[body]
            continue
        assert b.mass[body] == pytest.approx(mass, rel=1e-12)
        np.testing.assert_allclose(b.center_of_mass_local[body], center, atol=1e-12)
        np.testing.assert_allclose(b.inertia_body[body], inertia, rtol=1e-12, atol=1e-15)


def test_merged_links_sum_their_mass():
    path = _data("r2d2.urdf")
    world = rbd.World()
    robot = rbd.load_urdf(world, path)
    inertials = _urdf_inertials(path)
    base = robot.bodies["base_link"]
    welded = [link for link, body in robot.bodies.items() if body == base]
    assert sorted(welded) == ["base_link", "left_base", "left_leg", "right_base", "right_leg"]
    assert world.bodies.mass[base] == pytest.approx(sum(inertials[k][0] for k in welded))


@pytest.mark.parametrize("name", ["kuka_iiwa/model.urdf", "r2d2.urdf"])
def test_joints_are_pybullets(name):
    path = _data(name)
    theirs = _pybullet_joints(path)
    world = rbd.World()
    robot = rbd.load_urdf(world, path, fixed_base=True, merge_fixed_links=False)
    assert robot.joint_names == [n for n, kind in theirs if kind != "fixed"]
    # nothing merged, every URDF joint is a world joint, in the file's order as pybullet's
    # (r2d2's root, of mass 10, is also welded to the world by "fixed_base"; the iiwa's, of
    # mass 0, is a static body)
    joints = world.joints
    ours = [(n, str(k)) for n, k in zip(joints["name"], joints["kind"], strict=True)]
    assert [j for j in ours if j[0] != "fixed_base"] == theirs


PENDULUM = """<?xml version="1.0"?>
<robot name="pendulum">
  <link name="base"/>
  <link name="bob">
    <inertial>
      <origin xyz="0 0 -{l}" rpy="0.3 0.2 0.1"/>
      <mass value="{m}"/>
      <inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/>
    </inertial>
    <collision><origin xyz="0 0 -{l}"/><geometry><sphere radius="0.05"/></geometry></collision>
    <collision>
      <origin xyz="0 0 -{half}"/><geometry><cylinder radius="0.01" length="{l}"/></geometry>
    </collision>
  </link>
  <joint name="pivot" type="revolute">
    <parent link="base"/><child link="bob"/>
    <origin xyz="0 0 2"/>
    <axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/>
  </joint>
</robot>
"""


def test_pendulum_period(tmp_path):
    m, length, i, g = 2.0, 0.8, 0.01, 9.81
    path = tmp_path / "pendulum.urdf"
    path.write_text(PENDULUM.format(m=m, l=length, half=length / 2, i=i))
    dt = 1e-3
    world = rbd.World(dt=dt, gravity=(0, 0, -g))
    # the whole model tilted 0.05 rad about the hinge: the bob swings 0.05 rad either side of
    # hanging, where the joint reads -0.05 (the period grows by a^2 / 16, 1.6e-4, at that size)
    tilt = 0.05
    robot = rbd.load_urdf(
        world,
        path,
        fixed_base=True,
        base_orientation=(0, math.sin(tilt / 2), 0, math.cos(tilt / 2)),
    )
    assert world.bodies.static[robot.bodies["base"]]  # massless under a fixed base
    angles = []
    for _ in range(4000):
        world.step()
        angles.append(robot.joint_positions()[0])
    swing = np.array(angles) + tilt
    down = np.flatnonzero((swing[:-1] > 0) & (swing[1:] <= 0))
    crossings = (down + 1 + swing[down] / (swing[down] - swing[down + 1])) * dt
    period = np.diff(crossings).mean()
    expected = 2 * math.pi * math.sqrt((i + m * length**2) / (m * g * length))
    print(f"pendulum period {period:.6f} s, closed form {expected:.6f} s")
    assert abs(period / expected - 1) < 5e-3


def test_servo_targets_hold_the_iiwa():
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, _data("kuka_iiwa/model.urdf"), fixed_base=True)
    target = np.zeros(len(robot.joints))
    robot.set_joint_targets(target)
    world.step(240)
    error = np.abs(robot.joint_positions() - target).max()
    print(f"iiwa servo hold: largest joint error {error:.3g} rad after 1 s")
    assert error < 1e-3


def _settle_time(errors, tolerance):
    """Seconds (at 240 Hz) after which every joint stays within ``tolerance`` rad."""
    outside = np.flatnonzero(np.abs(errors).max(axis=1) > tolerance)
    return (outside.max() + 1) / 240 if len(outside) else 0.0


def test_position_control_settles_the_iiwa_on_a_distant_pose():
    """Servos capped by the URDF (300 N m, 10 rad/s) move the iiwa from its zero pose to one
    up to 1.2 rad away under gravity; pybullet's POSITION_CONTROL with the same caps (its
    default gains, link damping zeroed) is the peer. Each servo brakes for the arm beyond
    it: with only its own link in view, the shoulder overshot by 0.9 rad and still swung
    0.3 rad after 8 s."""
    pybullet = pytest.importorskip("pybullet")
    target = np.array([0.5, 0.4, -0.3, -1.2, 0.2, 0.8, 0.1])
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, _data("kuka_iiwa/model.urdf"), fixed_base=True)
    robot.set_joint_targets(target)
    ours = []
    for _ in range(3 * 240):
        world.step()
        ours.append(robot.joint_positions() - target)
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        pybullet.setTimeStep(1 / 240, physicsClientId=client)
        arm = pybullet.loadURDF(
            str(_data("kuka_iiwa/model.urdf")), useFixedBase=True,
            flags=pybullet.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client,
        )  # fmt: skip
        for j in range(len(target)):
            pybullet.changeDynamics(arm, j, linearDamping=0, angularDamping=0,
                                    physicsClientId=client)  # fmt: skip
            pybullet.setJointMotorControl2(
                arm, j, pybullet.POSITION_CONTROL, targetPosition=target[j], force=300,
                maxVelocity=10, physicsClientId=client,
            )  # fmt: skip
        peer = []
        for _ in range(3 * 240):
            pybullet.stepSimulation(physicsClientId=client)
            states = pybullet.getJointStates(arm, range(len(target)), physicsClientId=client)
            peer.append(np.array([s[0] for s in states]) - target)
    finally:
        pybullet.disconnect(client)
    ours_settle = _settle_time(np.array(ours), 0.01)
    peer_settle = _settle_time(np.array(peer), 0.01)
    print(f"iiwa position control settles within 0.01 rad after {ours_settle:.3f} s "
          f"(pybullet {peer_settle:.3f} s)")  # fmt: skip
    assert peer_settle < 1.0
    assert ours_settle < 2 * peer_settle
    assert np.abs(ours[-1]).max() < 1e-3


@pytest.mark.parametrize("name", ["kuka_iiwa/model.urdf", "r2d2.urdf"])
def test_set_joint_positions_places_the_links_as_pybullets_reset(name):
    """Random joint positions and rates set on the iiwa (revolute joints) and r2d2
    (continuous wheels and a prismatic gripper; fixed links kept apart): every link's
    centre of mass, velocity and angular velocity equal pybullet's getLinkState after
    resetJointState, the joints read back what was set and hold exactly."""
    pybullet = pytest.importorskip("pybullet")
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, _data(name), fixed_base=True, merge_fixed_links=False)
    rng = np.random.default_rng(5)
    q = rng.uniform(-1.0, 1.0, len(robot.joints)) * 0.5
    rates = rng.uniform(-1.0, 1.0, len(robot.joints))
    robot.set_joint_positions(q, rates)
    np.testing.assert_allclose(robot.joint_positions(), q, atol=1e-12)
    np.testing.assert_allclose(robot.joint_velocities(), rates, atol=1e-12)
    assert np.abs(world.joints["gap"]).max() < 1e-12
    assert np.abs(world.joints["angle_error"]).max() < 1e-12
    client = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(
            str(_data(name)), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )  # fmt: skip
        infos = [pybullet.getJointInfo(body, j, physicsClientId=client)
                 for j in range(pybullet.getNumJoints(body, physicsClientId=client))]  # fmt: skip
        by_name = {info[1].decode(): info[0] for info in infos}
        for k, joint in enumerate(robot.joint_names):
            pybullet.resetJointState(body, by_name[joint], q[k], rates[k],
                                     physicsClientId=client)  # fmt: skip
        compared = 0
        for info in infos:
            link = info[12].decode()
            state = pybullet.getLinkState(body, info[0], computeLinkVelocity=1,
                                          physicsClientId=client)  # fmt: skip
            b = robot.bodies[link]
            if world.bodies.static[b]:
                continue
            np.testing.assert_allclose(world.position(b), state[0], atol=1e-9)
            np.testing.assert_allclose(world.linear_velocity(b), state[6], atol=1e-9)
            np.testing.assert_allclose(world.angular_velocity(b), state[7], atol=1e-9)
            compared += 1
    finally:
        pybullet.disconnect(client)
    assert compared >= len(robot.joints)


def test_joints_are_set_and_driven_by_name():
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, _data("kuka_iiwa/model.urdf"), fixed_base=True)
    robot.set_joint_positions(np.full(7, 0.3))
    robot.set_joint_positions({"lbr_iiwa_joint_4": -0.5, 1: 0.1})
    np.testing.assert_allclose(robot.joint_positions(), [0.3, 0.1, 0.3, -0.5, 0.3, 0.3, 0.3],
                               atol=1e-12)  # fmt: skip
    assert robot.joint_index("lbr_iiwa_joint_7") == 6
    held = robot.joint_positions()
    robot.set_joint_targets(dict(zip(robot.joint_names, held, strict=True)))
    robot.set_joint_targets({"lbr_iiwa_joint_2": 0.2})  # the others keep their targets
    world.step(240)
    held[1] = 0.2
    np.testing.assert_allclose(robot.joint_positions(), held, atol=1e-3)
    with pytest.raises(ValueError, match="no movable joint 'elbow'"):
        robot.set_joint_positions({"elbow": 0.0})
    with pytest.raises(ValueError, match="must be 7 values"):
        robot.set_joint_positions([0.0, 1.0])
    with pytest.raises(ValueError, match="must be finite"):
        robot.set_joint_targets({"lbr_iiwa_joint_1": math.nan})
    with pytest.raises(ValueError, match="names a joint twice"):
        robot.set_joint_positions({"lbr_iiwa_joint_1": 0.0, 0: 1.0})


def test_target_velocities_let_the_iiwa_track_a_trajectory():
    """Every joint of the iiwa (gravity on, URDF caps) follows q0 + 0.2 sin(2 pi t), its
    targets given each step with and without their rates: without, each target is met a
    step late or later (the motion of a step is 0.2 x 2 pi / 240 = 5e-3 rad at most; the
    capped servos of the heavy joints lag more); with, where it will be: within half a
    step's motion, and five times closer."""
    q0 = np.array([0.3, 0.8, -0.4, -1.0, 0.5, 0.9, 0.2])
    dt = 1 / 240

    def worst(with_rates: bool) -> float:
        world = rbd.World(dt=dt, gravity=(0, 0, -9.81))
        robot = rbd.load_urdf(world, _data("kuka_iiwa/model.urdf"), fixed_base=True)
        robot.set_joint_positions(q0, velocities=np.full(7, 0.2 * 2 * math.pi))
        error = 0.0
        for k in range(240):
            t = k * dt
            rates = np.full(7, 0.2 * 2 * math.pi * math.cos(2 * math.pi * t))
            robot.set_joint_targets(q0 + 0.2 * math.sin(2 * math.pi * t),
                                    rates if with_rates else None)  # fmt: skip
            world.step()
            ahead = q0 + 0.2 * math.sin(2 * math.pi * (t + dt))
            error = max(error, np.abs(robot.joint_positions() - ahead).max())
        return error

    late, tracked = worst(False), worst(True)
    print(f"iiwa tracking: {late:.3g} rad a step late, {tracked:.3g} rad given the rates")
    assert late > 0.2 * 2 * math.pi * dt
    assert tracked < 0.5 * 0.2 * 2 * math.pi * dt and tracked < 0.2 * late
    robot = rbd.load_urdf(rbd.World(), _data("kuka_iiwa/model.urdf"), fixed_base=True)
    with pytest.raises(ValueError, match="same joints"):
        robot.set_joint_targets({"lbr_iiwa_joint_1": 0.1}, {"lbr_iiwa_joint_2": 0.0})


def test_links_are_drawn_with_their_visual_meshes(tmp_path):
    """Each iiwa link (fixed links merged: none here) is drawn with its <visual> mesh file
    read whole by trimesh (not the collision hull), placed by its origin in the body's frame;
    a visual file that cannot be read leaves its link drawn by its collision shape, with a
    warning naming it."""
    trimesh = pytest.importorskip("trimesh")
    path = _data("kuka_iiwa/model.urdf")
    world = rbd.World()
    robot = rbd.load_urdf(world, path, fixed_base=True, merge_fixed_links=False)
    for link in ET.parse(path).getroot().iter("link"):
        visual = link.find("visual")
        body = robot.bodies[link.get("name")]
        expected = trimesh.load(path.parent / visual.find("geometry/mesh").get("filename"),
                                force="mesh")  # fmt: skip
        origin = visual.find("origin")
        R = _rpy_matrix(np.fromstring(origin.get("rpy"), sep=" "))
        placed = expected.vertices @ R.T + np.fromstring(origin.get("xyz"), sep=" ")
        drawn = world.bodies.drawn[body]
        assert drawn is not world.bodies.meshes[body]
        # triangle by triangle (the mesh drops the files' unused vertices)
        np.testing.assert_allclose(drawn.vertices[drawn.faces], placed[expected.faces], atol=1e-12)
    text = path.read_text().replace("meshes/link_3.obj", "meshes/no_such_file.obj", 1)
    broken = tmp_path / "model.urdf"
    broken.write_text(text.replace('filename="meshes/', f'filename="{path.parent}/meshes/'))
    world = rbd.World()
    with pytest.warns(UserWarning, match="no_such_file.obj"):
        robot = rbd.load_urdf(world, broken, fixed_base=True)
    link = robot.bodies["lbr_iiwa_link_3"]
    assert world.bodies.drawn[link] is world.bodies.meshes[link]


def test_bullets_capsules_planes_and_spherical_joints_load():
    """pybullet_data's humanoid.urdf (Bullet's <capsule> and spherical joints) and
    plane_implicit.urdf (<plane>): a link of one capsule collides as a capsule of the file's
    radius and length (its volume within 3 % under the analytic one, the tessellation
    inscribed), the spherical joints are ball joints, and a box dropped on the plane comes
    to rest on it (its centre half its height above)."""
    path = _data("humanoid/humanoid.urdf")
    root = ET.fromstring(path.read_bytes().rstrip(b"\0"))
    world = rbd.World()
    robot = rbd.load_urdf(world, path, merge_fixed_links=False)
    spherical = [j.get("name") for j in root.iter("joint") if j.get("type") == "spherical"]
    kinds = dict(zip(world.joints["name"], world.joints["kind"], strict=True))
    assert spherical and all(kinds[name] == "spherical" for name in spherical)
    checked = 0
    for link in root.iter("link"):
        geometry = [c.find("geometry") for c in link.findall("collision")]
        if len(geometry) != 1 or geometry[0].find("capsule") is None:
            continue
        capsule = geometry[0].find("capsule")
        r, length = float(capsule.get("radius")), float(capsule.get("length"))
        exact = math.pi * r**2 * length + 4.0 / 3.0 * math.pi * r**3
        mesh = world.bodies.meshes[robot.bodies[link.get("name")]]
        volume = rbd.mass_properties(mesh).volume
        assert 0.97 * exact < volume < exact
        checked += 1
    assert checked >= 4
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    rbd.load_urdf(world, _data("plane_implicit.urdf"), fixed_base=True)
    box = world.add_body(rbd.shapes.box((0.2, 0.2, 0.2)), position=(0.3, -0.2, 0.5))
    world.step(480)
    assert world.positions[box] == pytest.approx((0.3, -0.2, 0.1), abs=1e-4)


def test_iiwa_joint_damping_against_pybullet_at_a_sixteenth_of_the_step():
    """The iiwa falls from a bent pose for 2 s with its URDF joint damping (0.5 N m s/rad),
    no control, at dt = 1/240. pybullet at dt / 16 is the reference (its links' damping
    zeroed, its default motors off); per joint, our largest angle difference from it is at
    most twice pybullet's own at dt (its discretisation error)."""
    pybullet = pytest.importorskip("pybullet")
    path = _data("kuka_iiwa/model.urdf")
    start = np.array([0.3, 0.8, -0.4, -1.0, 0.5, 0.9, 0.2])
    steps = 2 * 240
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, path, fixed_base=True)
    robot.set_joint_positions(start)
    ours = []
    for _ in range(steps):
        world.step()
        ours.append(robot.joint_positions())

    def peer(substeps):
        client = pybullet.connect(pybullet.DIRECT)
        try:
            pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
            pybullet.setTimeStep(1 / 240 / substeps, physicsClientId=client)
            arm = pybullet.loadURDF(str(path), useFixedBase=True, physicsClientId=client,
                                    flags=pybullet.URDF_USE_INERTIA_FROM_FILE)  # fmt: skip
            for j in range(7):
                pybullet.changeDynamics(arm, j, linearDamping=0, angularDamping=0,
                                        physicsClientId=client)  # fmt: skip
                pybullet.setJointMotorControl2(arm, j, pybullet.VELOCITY_CONTROL, force=0,
                                               physicsClientId=client)  # fmt: skip
                pybullet.resetJointState(arm, j, start[j], physicsClientId=client)
            out = []
            for _ in range(steps):
                for _ in range(substeps):
                    pybullet.stepSimulation(physicsClientId=client)
                states = pybullet.getJointStates(arm, range(7), physicsClientId=client)
                out.append([state[0] for state in states])
            return np.array(out)
        finally:
            pybullet.disconnect(client)

    reference = peer(16)
    ours_error = np.abs(np.array(ours) - reference).max(axis=0)
    peer_error = np.abs(peer(1) - reference).max(axis=0)
    print("iiwa damped fall, largest angle difference from pybullet at dt/16 (rad):")
    print("  ours at dt    ", np.round(ours_error, 4))
    print("  pybullet at dt", np.round(peer_error, 4))
    assert np.all(ours_error <= 2.0 * peer_error)


@pytest.mark.parametrize("name, height", [("franka_panda/panda.urdf", 0.5), ("r2d2.urdf", 1.0)])
def test_panda_and_r2d2_fall_onto_a_floor(name, height):
    """Free bases dropped on a floor: 2 s of contacts, joints held within 1 mm (the
    acceptance bound), nothing non-finite, no link's centre below the floor's top."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    world.add_body(rbd.shapes.box((10, 10, 0.2)), static=True, position=(0, 0, -0.1))
    robot = rbd.load_urdf(world, _data(name), base_position=(0, 0, height))
    gap = 0.0
    for _ in range(2 * 240):
        world.step()
        gap = max(gap, np.abs(world.joints["gap"]).max())
    print(f"{name}: largest joint gap over 2 s {gap:.3g} m")
    assert gap < 1e-3
    assert np.all(np.isfinite(world.positions))
    moving = [b for b in set(robot.bodies.values()) if not world.bodies.static[b]]
    assert min(world.positions[b, 2] for b in moving) > 0.0


def test_a_mimic_joint_follows_its_leader():
    """Panda's second finger mimics the first (multiplier 1): targets and resets given for
    the leader set it too, and a dict naming it alone is refused."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    robot = rbd.load_urdf(world, _data("franka_panda/panda.urdf"), fixed_base=True)
    assert robot.mimics["panda_finger_joint2"][0] == "panda_finger_joint1"
    robot.set_joint_positions({"panda_finger_joint1": 0.02})
    finger = robot.joint_index("panda_finger_joint2")
    assert robot.joint_positions()[finger] == pytest.approx(0.02, abs=1e-12)
    robot.set_joint_targets(robot.joint_positions() + np.where(np.arange(9) >= 7, 0.01, 0.0))
    world.step(240)
    assert robot.joint_positions()[finger] == pytest.approx(0.03, abs=1e-4)
    with pytest.raises(
        ValueError, match=r"mimics 'panda_finger_joint1'.*set 'panda_finger_joint1'"
    ):
        robot.set_joint_targets({"panda_finger_joint2": 0.0})


def test_a_hinge_whose_limits_reach_past_pi_reads_in_urdf_terms():
    """Panda's joint 6 turns from -0.0873 to 3.8223 rad: its world joint's zero is put
    mid-range (add_joint's ref), and the Robot reads and sets it in the file's terms; a
    servo asked past the upper limit stops at it."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, 0))
    robot = rbd.load_urdf(world, _data("franka_panda/panda.urdf"), fixed_base=True)
    six = robot.joint_index("panda_joint6")
    assert robot.joint_positions()[six] == pytest.approx(0.0, abs=1e-12)
    robot.set_joint_positions({"panda_joint6": 3.5})
    assert robot.joint_positions()[six] == pytest.approx(3.5, abs=1e-12)
    robot.set_joint_targets({"panda_joint6": 3.7})
    world.step(240)
    assert robot.joint_positions()[six] == pytest.approx(3.7, abs=1e-3)
    robot.set_joint_targets({"panda_joint6": 4.2})
    world.step(240)
    assert robot.joint_positions()[six] == pytest.approx(3.8223, abs=2e-3)


def test_inertia_from_the_shapes_loads_a_placeholder_tensor():
    """pybullet_data's random objects carry the placeholder inertia diag(1, 1, 0): refused
    as the file's, loaded with inertia="shapes" as the link's collision mesh taken solid at
    the file's mass (trimesh's moments of the same hull, scaled to that mass, the oracle)."""
    import trimesh

    path = _data("random_urdfs/143/143.urdf")
    with pytest.raises(ValueError, match=r"random_obj_143.*not positive definite"):
        rbd.load_urdf(rbd.World(), path)
    world = rbd.World()
    rbd.load_urdf(world, path, inertia="shapes")
    hull = trimesh.load(path.parent / "143.obj", force="mesh").convex_hull
    hull.apply_scale(0.015)
    expected = hull.moment_inertia * (0.1 / hull.volume)
    # principal moments: the body frame's axes need not be the mesh's
    principal = np.linalg.eigvalsh(world.bodies.inertia_body[0])
    np.testing.assert_allclose(principal, np.linalg.eigvalsh(expected), rtol=1e-6)
    with pytest.raises(ValueError, match="inertia must be 'file' or 'shapes'"):
        rbd.load_urdf(rbd.World(), path, inertia="cad")


TWO_LINKS = """<?xml version="1.0"?>
<robot name="bad">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="arm">
    {arm_inertial}
    <collision><geometry>{arm_geometry}</geometry></collision>
  </link>
  <joint name="elbow" type="revolute">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 0.2"/>
    <axis xyz="{axis}"/>{mimic}
    <limit lower="-1" upper="1" effort="5" velocity="1"/>
  </joint>
</robot>
"""
GOOD = {
    "arm_inertial": '<inertial><mass value="1"/>'
    '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>',
    "arm_geometry": '<box size="0.1 0.1 0.3"/>',
    "axis": "0 0 1",
    "mimic": "",
}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"arm_geometry": '<mesh filename="nowhere.stl"/>'}, "link 'arm': collision mesh"),
        ({"arm_inertial": ""}, "link 'arm' moves but has no mass"),
        ({"arm_inertial": GOOD["arm_inertial"].replace('"1"/>', '"-2"/>', 1)}, "link 'arm': mass"),
        (
            {"arm_inertial": GOOD["arm_inertial"].replace('izz="1"', 'izz="-1"')},
            "link 'arm': inertia is not positive definite",
        ),
        (
            {"arm_inertial": GOOD["arm_inertial"].replace('izz="1"', 'izz="3"')},
            "link 'arm': inertia violates the triangle inequality",
        ),
        ({"arm_geometry": '<plane normal="0 0 1"/>'}, "link 'arm': a plane belongs to a static"),
        ({"axis": "0 0 0"}, "joint 'elbow': axis"),
        ({"mimic": '<mimic joint="other"/>'}, "joint 'elbow' mimics 'other'"),
    ],
)
def test_bad_files_are_refused_and_leave_nothing(tmp_path, change, message):
    path = tmp_path / "bad.urdf"
    path.write_text(TWO_LINKS.format(**{**GOOD, **change}))
    world = rbd.World()
    with pytest.raises(ValueError, match=re.escape(message)):
        rbd.load_urdf(world, path)
    assert len(world) == 0 and len(world.joints["name"]) == 0


def test_the_good_two_link_file_loads(tmp_path):
    path = tmp_path / "good.urdf"
    path.write_text(TWO_LINKS.format(**GOOD))
    world = rbd.World()
    robot = rbd.load_urdf(world, path)
    assert robot.joint_names == ["elbow"] and len(world) == 2


def test_without_yourdfpy_the_error_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "yourdfpy", None)
    with pytest.raises(ImportError, match=r"pip install thesis_rbd\[urdf\]"):
        rbd.load_urdf(rbd.World(), tmp_path / "any.urdf")


def test_a_cylinder_lies_along_its_link_z_axis(tmp_path):
    path = tmp_path / "cylinder.urdf"
    path.write_text(
        TWO_LINKS.format(**{**GOOD, "arm_geometry": '<cylinder radius="0.05" length="0.6"/>'})
    )
    world = rbd.World()
    robot = rbd.load_urdf(world, path)
    # the body's mesh is in the arm's link frame: URDF's cylinder axis is that frame's z
    extents = np.ptp(world.bodies.meshes[robot.bodies["arm"]].vertices, axis=0)
    np.testing.assert_allclose(extents, (0.1, 0.1, 0.6), atol=1e-12)


def test_a_planar_joint_is_a_generic_joint_turning_about_the_urdf_axis(tmp_path):
    path = tmp_path / "planar.urdf"
    planar = TWO_LINKS.format(**GOOD).replace('type="revolute"', 'type="planar"')
    path.write_text(planar.replace('<axis xyz="0 0 1"/>', '<axis xyz="1 0 0"/>'))
    world = rbd.World(dt=1 / 240)
    robot = rbd.load_urdf(world, path, fixed_base=True)
    assert world.joints["kind"][robot.joints].tolist() == ["generic"]
    arm = robot.bodies["arm"]
    # a spin about the URDF axis (world x here) is the joint's in-plane turn
    world.bodies.angular_momentum[arm] = world.bodies.inertia_body[arm] @ (0.5, 0.0, 0.0)
    world.step(24)
    assert robot.joint_velocities()[0] == pytest.approx(0.5, rel=1e-6)
    assert robot.joint_positions()[0] == pytest.approx(0.05, rel=1e-6)
    with pytest.raises(ValueError, match="planar joints"):
        robot.set_joint_targets([0.0])


CHAIN = """<?xml version="1.0"?>
<robot name="chain">
  <link name="a">{body}</link>
  <link name="b">{body}</link>
  <link name="c">{body}</link>
  <joint name="ab" type="floating">
    <parent link="a"/><child link="b"/><origin xyz="0 0 0.15"/>
  </joint>
  <joint name="bc" type="floating">
    <parent link="b"/><child link="c"/><origin xyz="0 0 -0.3"/>
  </joint>
</robot>
"""
CUBE = (
    '<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" '
    'izz="0.01"/></inertial><collision><geometry><box size="0.2 0.2 0.2"/></geometry>'
    "</collision>"
)


@pytest.mark.parametrize(("self_collision", "touching"), [(False, set()), (True, {("a", "c")})])
def test_links_collide_only_with_self_collision_and_never_parent_with_child(
    tmp_path, self_collision, touching
):
    # floating joints hold nothing, so only the exclusions keep the overlapping cubes apart:
    # b overlaps a and c (its parent and child), c overlaps a (not a neighbour)
    path = tmp_path / "chain.urdf"
    path.write_text(CHAIN.format(body=CUBE))
    world = rbd.World(dt=1 / 240)
    robot = rbd.load_urdf(world, path, self_collision=self_collision)
    assert robot.joints == [] and len(world.joints["name"]) == 0
    world.step()
    names = {v: k for k, v in robot.bodies.items()}
    contacts = world.contacts
    pairs = {
        tuple(sorted((names[a], names[b])))
        for a, b in zip(contacts["body_a"], contacts["body_b"], strict=True)
    }
    assert pairs == touching


def test_a_massless_root_needs_a_fixed_base():
    world = rbd.World()
    with pytest.raises(ValueError, match=r"lbr_iiwa_link_0.*loads with fixed_base=True"):
        rbd.load_urdf(world, _data("kuka_iiwa/model.urdf"))
    assert len(world) == 0


def test_a_scene_loads_urdf_models_posed_and_held(tmp_path):
    """A [[urdf]] table loads the iiwa beside a scene's own body, in the pose its
    joint_positions give, its servos holding the targets its joint_targets give."""
    scene = tmp_path / "arm.toml"
    scene.write_text(
        f"""
[world]
dt = 0.004166666666666667
gravity = [0.0, 0.0, -9.81]

[[body]]
name = "floor"
shape = {{ type = "box", extents = [4.0, 4.0, 0.2] }}
position = [0.0, 0.0, -0.1]
static = true

[[urdf]]
path = "{_data("kuka_iiwa/model.urdf")}"
fixed_base = true
joint_positions = {{ lbr_iiwa_joint_2 = 0.5 }}
joint_targets = {{ lbr_iiwa_joint_2 = 0.5, lbr_iiwa_joint_4 = -1.0 }}
"""
    )
    world = rbd.load_scene(scene).build()
    assert world.bodies.count == 1 + 8
    second = world.joints["name"].index("lbr_iiwa_joint_2")
    assert world.joints["position"][second] == pytest.approx(0.5, abs=1e-12)
    world.step(240)
    fourth = world.joints["name"].index("lbr_iiwa_joint_4")
    assert world.joints["position"][second] == pytest.approx(0.5, abs=1e-3)
    assert world.joints["position"][fourth] == pytest.approx(-1.0, abs=1e-3)


@pytest.mark.parametrize(
    "table, message",
    [
        ("fixed_base = true", "urdf[0]: needs a 'path'"),
        ('path = "missing.urdf"', "urdf[0]: field 'path': no URDF file at"),
        ('path = "{robot}"\ninertia = "cad"', "urdf[0]: field 'inertia': must be 'file' or"),
        (
            'path = "{robot}"\nfixed_base = true\njoint_targets = {{ elbow = 1.0 }}',
            "urdf[0]: robot 'lbr_iiwa' has no movable joint 'elbow'",
        ),
        ('path = "{robot}"\nbase = 1', "urdf[0]: unknown key 'base'"),
    ],
)
def test_bad_urdf_tables_name_the_fault(tmp_path, table, message):
    scene = tmp_path / "bad.toml"
    scene.write_text("[[urdf]]\n" + table.format(robot=_data("kuka_iiwa/model.urdf")) + "\n")
    with pytest.raises(rbd.SceneError, match=re.escape(message)):
        rbd.load_scene(scene).build()


def test_the_cli_runs_a_urdf_file(tmp_path):
    """`thesis-rbd run robot.urdf`: the model alone, its base held, its joints falling."""
    from typer.testing import CliRunner

    from thesis_rbd.cli import app

    out = tmp_path / "run.npz"
    result = CliRunner().invoke(
        app, ["run", str(_data("kuka_iiwa/model.urdf")), "-s", "0.2", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    trajectory = rbd.Trajectory.load(out)
    assert "lbr_iiwa_link_7" in trajectory.names
    assert len(trajectory.joint_names) == 7
