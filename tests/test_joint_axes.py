"""Universal and generic joints: six axes, each free, locked or limited.

Oracles: the kinds a generic joint generalises (a hinge, weld, ball and slider written as
generic joints move as those kinds do, limits included, with contacts); a body on a universal
joint against its reduced-coordinate Lagrangian equations integrated to 1e-11 (first-order
convergence of the error towards them); a planar joint's body against the discrete solution of
symplectic Euler in the plane; Cardan limits held without energy gained.
"""

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd

DT = 1 / 240
LOCKED3 = ("locked",) * 3


def _pendulum(kind, seconds=2.0, **joint):
    """A 1 kg box hung off-centre from the world by a joint, thrown spinning (in maximal
    coordinates, where a joint and the generic joint spelling it write their rows)."""
    world = rbd.World(dt=DT, gravity=(0.0, 0.0, -9.81), joint_coordinates="maximal")
    body = world.add_body(
        rbd.shapes.box((0.1, 0.1, 1.0)), mass=1.0, position=(0.3, 0.2, -0.5),
        angular_velocity=(0.5, 1.0, 2.0), linear_velocity=(0.3, 0.1, 0.0),
    )  # fmt: skip
    world.add_joint(kind, body, None, anchor=(0.3, 0.2, 0.0), **joint)
    states = []
    for _ in range(round(seconds / DT)):
        world.step()
        states.append(np.concatenate([world.bodies.position[0], world.bodies.orientation[0]]))
    return np.array(states), world


@pytest.mark.parametrize(
    ("kind", "own", "axes"),
    [
        ("revolute", {"axis": (1, 0, 0)}, (*LOCKED3, "free", "locked", "locked")),
        ("revolute", {"axis": (0, 1, 1), "limits": (-0.4, 0.3)},
         (*LOCKED3, (-0.4, 0.3), "locked", "locked")),
        ("fixed", {}, ("locked",) * 6),
        ("spherical", {}, (*LOCKED3, "free", "free", "free")),
        ("prismatic", {"axis": (0, 1, 0)}, ("free", *(("locked",) * 5))),
        ("prismatic", {"axis": (0, 1, 0), "limits": (-0.05, 0.02)},
         ((-0.05, 0.02), *(("locked",) * 5))),
    ],
)  # fmt: skip
def test_a_generic_joint_moves_as_the_kind_it_spells(kind, own, axes):
    """The same joint as a generic joint's axes: the same motion to 1e-9 m over 2 s (the two
    write different rows: a hinge's axes against b's perpendiculars, the generic joint's
    against its frame's)."""
    expected, _ = _pendulum(kind, **own)
    generic, world = _pendulum("generic", axis=own.get("axis", (0, 0, 1)), axes=axes)
    assert np.abs(generic - expected).max() < 1e-9
    assert world.joints["kind"][0] == "generic"


def test_generic_joints_with_contacts_move_as_the_kinds_they_spell():
    """The ragdoll (contacts, hinge limits and joints on one island) with its hinges, welds
    and free balls written as generic joints: the same motion to 0.1 mm (the island's contact
    solve is iterative, and the two spell the joints' rows differently)."""
    scene = rbd.scenes.get("ragdoll")

    def generic(joint):
        if joint.kind == "revolute":
            axes = (*LOCKED3, tuple(joint.limits), "locked", "locked")
        elif joint.kind == "fixed":
            axes = ("locked",) * 6
        else:
            return joint
        return dataclasses.replace(joint, kind="generic", limits=None, axes=axes)

    spelled = dataclasses.replace(scene, joints=tuple(generic(j) for j in scene.joints))
    assert sum(j.kind == "generic" for j in spelled.joints) >= 5
    a, b = scene.build(), spelled.build()
    touched = False
    for _ in range(int(1.2 / a.dt)):
        a.step()
        b.step()
        touched |= len(a.contacts["depths"]) > 0
        assert np.abs(a.bodies.position - b.bodies.position).max() < 1e-4
    assert touched


# A box on a universal joint at the origin turning about the world's x (fixed in the world)
# and its own y: COM off every axis so the two turns couple.
_MASS, _EXTENTS = 1.0, (0.1, 0.2, 0.8)
_COM = np.array([0.05, 0.1, -0.4])
_SPIN = np.array([1.5, -2.0, 0.0])  # in span(x, y): what the joint lets it turn about


def _universal_oracle(seconds):
    """Dense (alpha, beta) of the box's Lagrangian equations in its two Cardan angles."""
    ext = np.array(_EXTENTS)
    inertia = _MASS / 12 * np.diag([ext[1] ** 2 + ext[2] ** 2, ext[0] ** 2 + ext[2] ** 2,
                                    ext[0] ** 2 + ext[1] ** 2])  # fmt: skip

    def jacobian(q):
        turn_x = Rotation.from_rotvec([q[0], 0, 0]).as_matrix()
        R = turn_x @ Rotation.from_rotvec([0, q[1], 0]).as_matrix()
        r = R @ _COM
        wx, wy = np.array([1.0, 0, 0]), turn_x @ np.array([0, 1.0, 0])
        J = np.vstack([np.column_stack([np.cross(wx, r), np.cross(wy, r)]),
                       np.column_stack([wx, wy])])  # fmt: skip
        return J, R

    def mass_matrix(q):
        J, R = jacobian(q)
        D = np.zeros((6, 6))
        D[:3, :3] = _MASS * np.eye(3)
        D[3:, 3:] = R @ inertia @ R.T
        return J.T @ D @ J

    def potential(q):
        return _MASS * 9.81 * (jacobian(q)[1] @ _COM)[2]

    def rhs(_, y):
        q, rate = y[:2], y[2:]
        h = 1e-6
        dM = [(mass_matrix(q + h * e) - mass_matrix(q - h * e)) / (2 * h) for e in np.eye(2)]
        dV = [(potential(q + h * e) - potential(q - h * e)) / (2 * h) for e in np.eye(2)]
        forces = -sum(dM[k] * rate[k] for k in range(2)) @ rate
        forces += np.array([0.5 * rate @ dM[k] @ rate for k in range(2)]) - np.array(dV)
        return np.concatenate([rate, np.linalg.solve(mass_matrix(q), forces)])

    solution = solve_ivp(rhs, (0, seconds), [0, 0, *_SPIN[:2]], method="DOP853", rtol=1e-11,
                         atol=1e-12, dense_output=True)  # fmt: skip
    return lambda t: (solution.sol(t)[:2], jacobian(solution.sol(t)[:2])[1] @ _COM)


def _universal_errors(oracle, dt, seconds):
    """Largest COM distance (m) and Cardan angle difference (rad) from the oracle."""
    world = rbd.World(dt=dt, gravity=(0.0, 0.0, -9.81))
    body = world.add_body(
        rbd.shapes.box(_EXTENTS), mass=_MASS, position=_COM, angular_velocity=_SPIN,
        linear_velocity=np.cross(_SPIN, _COM),
    )  # fmt: skip
    world.add_joint("universal", body, None, anchor=(0, 0, 0), axis=((1, 0, 0), (0, 1, 0)))
    where = turned = 0.0
    for i in range(round(seconds / dt)):
        world.step()
        angles, com = oracle((i + 1) * dt)
        axes = world.joints["axis_positions"][0]
        where = max(where, float(np.linalg.norm(world.bodies.position[0] - com)))
        turned = max(turned, abs(axes[3] - angles[0]), abs(axes[4] - angles[1]), abs(axes[5]))
        assert np.abs(axes[:3]).max() < 1e-10
    assert world.joints["gap"][0] < 1e-10 and world.joints["angle_error"][0] < 1e-10
    return where, turned


def test_a_universal_joint_follows_its_lagrangian_equations():
    """The error against the reduced-coordinate equations halves with the step (symplectic
    Euler is first order) and is 1.3 mm at dt = 1/240 over 2 s of a swing of 0.7 rad."""
    oracle = _universal_oracle(2.0)
    coarse = _universal_errors(oracle, 1 / 240, 2.0)
    fine = _universal_errors(oracle, 1 / 960, 2.0)
    assert coarse[0] < 2e-3 and coarse[1] < 5e-3
    # first order: a quarter of the step, a quarter of the error (3.5 allows for the
    # second-order terms still present at dt = 1/240)
    assert coarse[0] / fine[0] > 3.5 and coarse[1] / fine[1] > 3.5


def test_a_planar_joint_moves_its_body_as_symplectic_euler_in_the_plane():
    """URDF's planar joint (travel in x and y, turn about z) with gravity across the plane
    and along it: the body's centre follows symplectic Euler's discrete parabola in the plane
    (x_n = x_0 + n h v + n (n + 1) / 2 h^2 g) and stays in it, and it turns about the normal
    by the free rotation's Cayley step, 2 atan(h w / 2) per step, to round-off."""
    world = rbd.World(dt=DT, gravity=(0.0, -9.81, -3.0))
    body = world.add_body(
        rbd.shapes.box((0.3, 0.2, 0.1)), mass=2.0, position=(0, 0, 1.0),
        linear_velocity=(1.0, 2.0, 0.0), angular_velocity=(0.0, 0.0, 3.0),
    )  # fmt: skip
    world.add_joint("generic", body, None, anchor=(0, 0, 1.0), axis=((1, 0, 0), (0, 1, 0)),
                    axes=("free", "free", "locked", "locked", "locked", "free"))  # fmt: skip
    steps = 480
    for _ in range(steps):
        world.step()
    n = np.array([steps, steps, 0.0])
    expected = (
        np.array([0, 0, 1.0])
        + n * DT * np.array([1.0, 2.0, 0])
        + (n * (n + 1) / 2 * DT**2 * np.array([0, -9.81, 0]))
    )
    assert np.abs(world.bodies.position[0] - expected).max() < 1e-9
    turn = Rotation.from_quat(world.bodies.orientation[0]).as_rotvec()
    angle = math.remainder(steps * 2 * math.atan(3.0 * DT / 2), 2 * math.pi)
    assert np.abs(turn - [0, 0, angle]).max() < 1e-9
    axes = world.joints["axis_positions"][0]
    assert axes[:2] == pytest.approx(expected[:2], abs=1e-9)
    assert axes[5] == pytest.approx(angle, abs=1e-9)
    # the joint holds the body against the 3 m/s^2 across the plane: 6 N along +z
    assert world.joints["force"][0] == pytest.approx([0, 0, 6.0], abs=1e-6)


def _thrown_on_generic(axes, steps=720):
    """A box on a generic joint at the origin thrown tumbling: (world, energy per step)."""
    world = rbd.World(dt=DT, gravity=(0.0, 0.0, -9.81))
    spin = np.array([6.0, -4.0, 3.0])
    com = np.array([0.05, 0.1, -0.4])
    body = world.add_body(rbd.shapes.box((0.1, 0.2, 0.8)), mass=1.0, position=com,
                          angular_velocity=spin, linear_velocity=np.cross(spin, com))  # fmt: skip
    world.add_joint("generic", body, None, anchor=(0, 0, 0), axes=axes)
    energy = [world.kinetic_energy() + world.potential_energy()]
    axis_positions = []
    for _ in range(steps):
        world.step()
        energy.append(world.kinetic_energy() + world.potential_energy())
        axis_positions.append(world.joints["axis_positions"][0].copy())
    return world, np.array(energy), np.array(axis_positions)


def test_cardan_limits_hold_without_energy_gained():
    """A box on a generic joint whose turns about x and y are limited (the middle one within
    a quarter turn) and about z free, thrown into its limits: every limit holds at every
    step, and the energy rises above its start by no more than the same box's on a free ball
    joint does (symplectic Euler's own swing of the energy, 0.028 J of 1.96 J here): the
    limits, inelastic, only take energy out."""
    limits = ((-0.3, 0.5), (-0.2, 0.25))
    world, energy, axes = _thrown_on_generic((*LOCKED3, *limits, "free"))
    _, free_energy, _ = _thrown_on_generic((*LOCKED3, "free", "free", "free"))
    for k in range(2):
        lower, upper = limits[k]
        turn = axes[:, 3 + k]
        assert lower - 1e-8 <= turn.min() and turn.max() <= upper + 1e-8
        assert turn.min() < lower + 1e-6 and turn.max() > upper - 1e-6  # both limits reached
    assert energy.max() - energy[0] <= free_energy.max() - free_energy[0]
    assert energy[-1] < 0.9 * energy[0]
    assert world.joints["gap"][0] < 1e-10


def test_axes_in_a_scene_file(tmp_path):
    path = tmp_path / "planar.toml"
    path.write_text(
        '[world]\ndt = 0.01\n[[body]]\nname = "puck"\nshape = { type = "box", extents = '
        '[0.2, 0.2, 0.1] }\nmass = 1.0\n[[joint]]\nkind = "generic"\nbody_a = "puck"\n'
        "anchor = [0.0, 0.0, 0.0]\naxis = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]\n"
        'axes = ["free", "free", "locked", "locked", "locked", [-0.5, 0.5]]\n'
        '[[joint]]\nkind = "universal"\nbody_a = "puck"\nanchor = [0.0, 0.0, 0.0]\n'
        "limits = [[-1.0, 1.0], [-0.5, 0.5]]\n"
    )
    world = rbd.load_scene(path).build()
    assert list(world.joints["kind"]) == ["generic", "universal"]
    bad = path.read_text().replace('"free", "free", "locked"', '"free", "loose", "locked"')
    path.write_text(bad)
    with pytest.raises(rbd.SceneError, match=r"axes\.1"):
        rbd.load_scene(path)


@pytest.mark.parametrize(
    ("kind", "arguments", "message"),
    [
        ("generic", {}, "needs axes"),
        ("generic", {"axes": ("free",) * 5}, "six entries"),
        ("generic", {"axes": ("free",) * 5 + ("loose",)}, r"axes\[5\] \(turn z\)"),
        ("generic", {"axes": ("free",) * 5 + ((0.2, 0.1),)}, "lower < upper"),
        ("generic", {"axes": ("free",) * 5 + ((0.0, 0.0),)}, "'locked' holds"),
        ("generic", {"axes": ("free",) * 3 + ("free", (-2.0, 0.5), "free")}, r"axes\[4\]"),
        ("generic", {"axes": ("free",) * 5 + ((-4.0, 0.5),)}, r"lie in \[-3.14159"),
        ("generic", {"axes": ("free",) * 6, "limits": (0, 1)}, "given in its axes"),
        ("universal", {"axes": ("free",) * 6}, "axes are fixed"),
        ("universal", {"limits": (0.0, 1.0)}, r"\(\(lower, upper\), \(lower, upper\)\)"),
        ("universal", {"limits": ((0, 1), (-2.0, 1.0))}, r"axes\[4\]"),
        ("universal", {"axis": ((1, 0, 0), (1, 1, 0))}, "square to each other"),
        ("universal", {"axis": ((1, 0, 0), (0, 0, 0))}, "zero length"),
        ("universal", {"axis": ((1, 0, 0), (0, 1, 0), (0, 0, 1))}, r"\(2, 3\)"),
        ("revolute", {"axis": ((1, 0, 0), (0, 1, 0))}, "axis"),
        ("revolute", {"axes": ("free",) * 6}, "axes are a generic joint's"),
        ("generic", {"axes": ("free",) * 6, "motor": {"torque": 1.0}}, "motor drives"),
    ],
)
def test_bad_axes_are_refused_with_the_axis_named(kind, arguments, message):
    world = rbd.World()
    body = world.add_body(rbd.shapes.box((1, 1, 1)), mass=1.0)
    with pytest.raises(ValueError, match=message):
        world.add_joint(kind, body, None, anchor=(0, 0, 0), **arguments)
    assert len(world.joints["kind"]) == 0
