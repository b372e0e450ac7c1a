"""Fixed-base trees stepped in joint coordinates (``dynamics.articulated``), against answers
worked out independently: the discrete motion of a slider and a driven hinge in closed form,
the angular momentum no torque changes, and the maximal path (constraint rows held by
Newton's method, a different formulation of the same equations) where both converge."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import thesis_rbd as rbd
from thesis_rbd.dynamics.articulated import AUTO_SUBSTEPS
from thesis_rbd.scene import SceneError, parse_scene

G = 9.81
DT = 1 / 240


def _box(size=(0.1, 0.1, 0.4)):
    return rbd.shapes.box(size)


def test_a_slider_under_gravity_moves_as_semi_implicit_euler_exactly():
    """A block on a slider tilted 30 deg below the horizontal: a = g / 2 along it, and the
    kick-drift substeps of length h give qdot_N = N h a and q_N = h^2 a N (N + 1) / 2 after
    N of them (to round-off)."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    block = world.add_body(_box((0.2, 0.2, 0.2)), mass=3.0)
    axis = (np.cos(np.radians(30)), 0.0, -np.sin(np.radians(30)))
    world.add_joint("prismatic", block, None, anchor=(0, 0, 0), axis=axis)
    a, h = G / 2, DT / AUTO_SUBSTEPS
    for n in range(1, 121):
        world.step()
        joints, N = world.joints, n * AUTO_SUBSTEPS
        assert joints["velocity"][0] == pytest.approx(N * h * a, rel=1e-11)
        assert joints["position"][0] == pytest.approx(h**2 * a * N * (N + 1) / 2, rel=1e-11)
    assert world.joints["gap"][0] < 1e-12


def test_a_driven_damped_hinge_spins_up_as_its_implicit_recursion():
    """A rod on a vertical hinge (no gravity torque about it) driven by a set torque tau
    against joint damping d: each substep's kick is (I + h d) w+ = I w + h tau, so w follows
    that recursion exactly, and the joint reports the torque it was driven with."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    rod = world.add_body(_box((0.6, 0.05, 0.05)), mass=2.0, position=(0.3, 0, 0))
    tau, d = 0.7, 0.05
    world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(0, 0, 1), damping=d,
                    motor={"torque": tau})  # fmt: skip
    inertia = 2.0 * (0.6**2 + 0.05**2) / 12 + 2.0 * 0.3**2  # about the hinge
    w, h = 0.0, DT / AUTO_SUBSTEPS
    for _ in range(240):
        world.step()
        for _ in range(AUTO_SUBSTEPS):
            w = (inertia * w + h * tau) / (inertia + h * d)
        assert world.joints["velocity"][0] == pytest.approx(w, rel=1e-10)
    assert world.joints["motor_force"][0] == pytest.approx(tau, rel=1e-12)


def _spinning_arm(world):
    """A vertical base hinge at the origin carrying an upper arm, an elbow hinge across it
    and a forearm swinging under gravity, spun about the base."""
    upper = world.add_body(_box((0.5, 0.08, 0.08)), mass=2.0, position=(0.25, 0, 0))
    fore = world.add_body(_box((0.08, 0.08, 0.5)), mass=1.0, position=(0.5, 0, -0.25),
                          orientation=(0, np.sin(0.3), 0, np.cos(0.3)))  # fmt: skip
    world.add_joint("revolute", upper, None, anchor=(0, 0, 0), axis=(0, 0, 1))
    world.add_joint("revolute", fore, upper, anchor=(0.5, 0, 0), axis=(0, 1, 0))
    world.set_body_state(upper, angular_velocity=(0, 0, 3.0), velocity=(0, 0.75, 0))
    return upper, fore


def _angular_momentum_z(world):
    b = world.bodies
    n = b.count
    return float(np.sum(np.cross(b.position[:n], b.linear_momentum[:n])[:, 2]
                        + b.angular_momentum[:n, 2]))  # fmt: skip


@pytest.mark.parametrize("coordinates", ["auto", "maximal"])
def test_the_angular_momentum_about_a_vertical_base_hinge_is_kept(coordinates):
    """Gravity and the base hinge exert no torque about its vertical axis: the arm's angular
    momentum about it is kept to round-off over 10 s of a swinging, spinning elbow."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G), joint_coordinates=coordinates)
    _spinning_arm(world)
    world.step()  # the first step makes the set velocities the joints' own
    start = _angular_momentum_z(world)
    drift = 0.0
    for _ in range(2400):
        world.step()
        drift = max(drift, abs(_angular_momentum_z(world) - start))
    assert drift <= 1e-11 * abs(start)


def _tree(world):
    """A static post; a hinge to it; on that link a slider (its bodies given child first
    and parent first) and a second hinge; a weld on the slider's block. The links swing
    through each other (none collides): nothing but the joints acts on them."""

    def box(size, **kwargs):
        return world.add_body(_box(size), collidable=False, **kwargs)

    post = box((0.1, 0.1, 0.1), static=True, position=(0, 0, 1))
    arm = box((0.6, 0.06, 0.06), mass=1.5, position=(0.3, 0, 1))
    block = box((0.1, 0.1, 0.1), mass=0.5, position=(0.45, 0, 1))
    lamp = box((0.05, 0.05, 0.05), mass=0.2, position=(0.45, 0, 0.9))
    hand = box((0.05, 0.05, 0.3), mass=0.4, position=(0.6, 0, 0.85))
    world.add_joint("revolute", arm, post, anchor=(0, 0, 1), axis=(0, 1, 0.2), damping=0.05)
    world.add_joint("prismatic", arm, block, anchor=(0.45, 0, 1), axis=(1, 0, 0.3))
    world.add_joint("fixed", lamp, block, anchor=(0.45, 0, 0.95))
    world.add_joint("revolute", hand, arm, anchor=(0.6, 0, 1), axis=(1, 0.5, 0), damping=0.01)
    world.set_body_state(arm, angular_velocity=(0, 1.0, 0))
    return world


def _fall(coordinates, dt, seconds=0.5):
    world = _tree(rbd.World(dt=dt, gravity=(0, 0, -G), joint_coordinates=coordinates))
    world.step(round(seconds / dt))
    return world.joints


def test_a_tree_of_hinges_sliders_and_a_weld_converges_to_the_maximal_path():
    """The same tree stepped both ways: the paths differ at dt = 1/240 (different schemes),
    and at dt = 1/4800 both have converged to the same motion, joints held exactly."""
    coarse = _fall("auto", DT)["position"], _fall("maximal", DT)["position"]
    assert np.abs(coarse[0] - coarse[1]).max() > 1e-6  # the reduced path did run
    fine = _fall("auto", DT / 20), _fall("maximal", DT / 20)
    assert np.abs(fine[0]["position"] - fine[1]["position"]).max() <= 2e-3
    assert fine[0]["gap"].max() <= 1e-12 and fine[0]["angle_error"].max() <= 1e-12


def test_a_hinge_falling_onto_its_limit_rests_on_it():
    """A rod dropped onto its hinge's lower limit stops there (rigid and inelastic, as the
    maximal path's limit row) and never passes it."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    rod = world.add_body(_box((0.5, 0.05, 0.05)), mass=1.0, position=(0.25, 0, 0))
    world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(0, 1, 0),
                    limits=(-0.4, 0.4))  # fmt: skip
    lowest = np.inf
    for _ in range(480):
        world.step()
        lowest = min(lowest, -world.joints["position"][0])
    joints = world.joints
    assert -joints["position"][0] >= -0.4 - 1e-6  # y axis: falling turns it positively
    assert joints["position"][0] == pytest.approx(0.4, abs=1e-6)
    assert abs(joints["velocity"][0]) < 1e-9
    assert -lowest <= 0.4 + 1e-6


def test_what_only_the_maximal_path_holds_sends_the_step_there():
    """A velocity motor is held in maximal coordinates: with one on the tree, "auto" steps
    exactly as "maximal" does."""
    paths = []
    for coordinates in ("auto", "maximal"):
        world = _tree(rbd.World(dt=DT, gravity=(0, 0, -G), joint_coordinates=coordinates))
        world.set_motor(0, velocity=0.5, max_force=50.0)
        world.step(60)
        paths.append(world.bodies.position[: world.bodies.count].copy())
    assert np.array_equal(paths[0], paths[1])


def test_a_hanging_rod_at_rest_reports_its_weight_at_the_hinge():
    """A rod hanging at rest from a hinge: the world holds it up with m g, and no torque."""
    world = rbd.World(dt=DT, gravity=(0, 0, -G))
    rod = world.add_body(_box((0.05, 0.05, 0.5)), mass=2.0, position=(0, 0, -0.25))
    world.add_joint("revolute", rod, None, anchor=(0, 0, 0), axis=(1, 0, 0), damping=0.1)
    world.step(10)
    joints = world.joints
    assert joints["force"][0] == pytest.approx((0, 0, 2.0 * G), abs=1e-9)
    assert joints["torque"][0] == pytest.approx((0, 0, 0), abs=1e-9)


def test_an_unknown_joint_coordinates_is_refused():
    with pytest.raises(ValueError, match="joint_coordinates"):
        rbd.World(joint_coordinates="reduced")


_SCENE = """
[world]
gravity = [0.0, 0.0, -9.81]
joint_coordinates = {coordinates}

[[body]]
name = "rod"
shape = {{ type = "box", extents = [0.05, 0.05, 0.5] }}
mass = 1.0
position = [0.0, 0.25, 0.0]
orientation = [0.7071067811865476, 0.0, 0.0, 0.7071067811865476]

[[joint]]
kind = "revolute"
body_a = "rod"
anchor = [0.0, 0.0, 0.0]
axis = [1.0, 0.0, 0.0]
"""


def test_a_scene_file_chooses_the_joint_coordinates_and_a_bad_one_is_named():
    """``joint_coordinates`` in a scene's [world] reaches the world; an unknown value is
    refused naming the setting."""
    scene = parse_scene(_SCENE.format(coordinates='"maximal"'), "s", "s.toml", Path("."))
    assert scene.build().joint_coordinates == "maximal"
    with pytest.raises(SceneError, match="joint_coordinates"):
        parse_scene(_SCENE.format(coordinates='"reduced"'), "s", "s.toml", Path("."))
