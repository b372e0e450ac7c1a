"""Bodies a URDF link can become: explicit mass properties and compound shapes.

Oracles: the one-mesh body each feature generalises (the same mass properties given
explicitly, a box given as two half-boxes), the analytic box formulas with the parallel-axis
theorem, and Euler's equations of a torque-free body integrated by scipy.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import examples
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.convex.hull_data import is_convex

EXTENTS = np.array([1.0, 2.0, 3.0])


def box_inertia(mass, extents):
    """Analytic inertia (3, 3) of a solid box about its centre, axes along its edges."""
    a, b, c = np.asarray(extents, dtype=float) ** 2
    return mass / 12.0 * np.diag([b + c, a + c, a + b])


def pose(rotation=None, translation=(0.0, 0.0, 0.0)):
    """(4, 4) rigid transform from a scipy rotation (None: identity) and a translation."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation.as_matrix()
    T[:3, 3] = translation
    return T


def placed(mesh, T):
    """``mesh`` with its vertices moved by the rigid transform ``T``."""
    return rbd.TriangleMesh(mesh.vertices @ T[:3, :3].T + T[:3, 3], mesh.faces)


# an irregular body: a box turned and moved off the mesh origin, so that its inertia in the
# mesh frame is a full tensor and its centre of mass is not the origin
TURN = Rotation.from_euler("xyz", [0.4, -0.7, 1.1])
TILTED = placed(rbd.shapes.box(EXTENTS), pose(TURN, (0.3, -0.2, 0.5)))


def tumbling_world(narrow_phase, **body):
    """A body thrown spinning onto a static floor, under gravity; returns (world, body)."""
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81), narrow_phase=narrow_phase)
    world.add_body(rbd.shapes.box((20, 20, 1)), static=True, position=(0, 0, -0.5))
    index = world.add_body(
        position=(0.0, 0.0, 2.5),
        linear_velocity=(0.5, 0.0, 0.0),
        angular_velocity=(1.0, 3.0, -2.0),
        restitution=0.3,
        friction=0.5,
        **body,
    )
    return world, index


def run(world, body, steps):
    """Positions and orientations of ``body`` after each of ``steps`` steps, (steps, 7)."""
    states = []
    for _ in range(steps):
        world.step()
        states.append(np.concatenate([world.position(body), world.orientation(body)]))
    return np.array(states)


# ---------------------------------------------------------------------- explicit properties
@pytest.mark.parametrize("narrow_phase", ["auto", "mesh"])
def test_a_mesh_s_own_properties_given_explicitly_move_it_bit_for_bit(narrow_phase):
    props = rbd.mass_properties(TILTED, mass=3.0)
    derived, a = tumbling_world(narrow_phase, mesh=TILTED, mass=3.0)
    explicit, b = tumbling_world(
        narrow_phase,
        mesh=TILTED,
        mass=3.0,
        center_of_mass=props.center_of_mass,
        inertia=props.inertia,
    )
    for field in ("mass", "inertia_body", "inverse_inertia_body", "center_of_mass_local"):
        np.testing.assert_array_equal(
            getattr(explicit.bodies, field), getattr(derived.bodies, field)
        )
    # 1.5 s: it lands, bounces and tumbles over on the floor
    np.testing.assert_array_equal(run(explicit, b, 360), run(derived, a, 360))
    assert explicit.position(b)[2] < 1.6  # it did reach the floor


def test_an_explicit_inertia_off_the_mesh_axes_follows_euler_s_equations():
    """Torque-free: L and the energy are kept, and the motion is scipy's solution of Euler's
    equations I w' = (I w) x w, R' = R [w]x in the body frame."""
    moments = np.array([1.0, 2.0, 2.5])
    axes = Rotation.from_euler("zyx", [0.3, 0.9, -0.5]).as_matrix()
    inertia = axes @ np.diag(moments) @ axes.T  # not aligned with the mesh's axes
    # collision geometry only: a box without its top face is open, and it need not be
    box = rbd.shapes.box((1, 1, 1))
    open_box = rbd.TriangleMesh(box.vertices, box.faces[box.face_normals[:, 2] < 0.5])
    assert not open_box.is_closed
    q0 = Rotation.from_euler("x", 0.2).as_quat()
    R0 = Rotation.from_quat(q0).as_matrix()
    # about the intermediate principal axis, 5 % off: it turns over after 2.4 s
    w0 = R0 @ axes @ [0.3, 6.0, 0.3]
    dt, steps = 1 / 240, 720
    results = {}
    for integrator in ("rk4", "verlet"):
        world = rbd.World(dt=dt, integrator=integrator)
        body = world.add_body(
            open_box,
            mass=2.0,
            center_of_mass=(0.1, 0.0, -0.2),
            inertia=inertia,
            orientation=q0,
            angular_velocity=w0,
        )
        L0, E0 = world.angular_momentum(body), world.kinetic_energy()
        samples = []
        for _ in range(steps):
            world.step()
            samples.append((world.orientation(body), world.angular_velocity(body)))
        results[integrator] = samples
        np.testing.assert_array_equal(world.angular_momentum(body), L0)
        if integrator == "verlet":
            assert world.kinetic_energy() == pytest.approx(E0, rel=1e-13)

    inverse = np.linalg.inv(inertia)

    def euler(_, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        hat = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([(R @ hat).ravel(), inverse @ np.cross(inertia @ w, w)])

    times = dt * np.arange(1, steps + 1)
    reference = solve_ivp(
        euler, (0, times[-1]), np.concatenate([R0.ravel(), R0.T @ w0]),
        method="DOP853", t_eval=times, rtol=1e-12, atol=1e-12,
    )  # fmt: skip
    R_ref = reference.y[:9].T.reshape(-1, 3, 3)
    w_ref = np.einsum("tij,tj->ti", R_ref, reference.y[9:].T)
    intermediate = reference.y[9:].T @ axes[:, 1]
    assert intermediate.min() < -2.0  # the flip happened: a hard case

    # rk4's error is far below its bound; verlet's is second order, (h |w|)^2 |w| t
    speed = np.linalg.norm(w0)
    for integrator, bound in (("rk4", 1e-6), ("verlet", (dt * speed) ** 2 * speed * times[-1])):
        R = Rotation.from_quat([q for q, _ in results[integrator]]).as_matrix()
        w = np.array([w for _, w in results[integrator]])
        assert np.abs(R - R_ref).max() < bound
        assert np.abs(w - w_ref).max() < bound * speed


def test_an_offset_centre_of_mass_is_the_point_the_body_turns_about():
    """With an explicit centre of mass c off the mesh's own, c is the body position and
    stays put while the body spins; the kinetic energy is that of the inertia about c."""
    c = np.array([0.4, -0.3, 0.2])
    inertia = box_inertia(2.0, EXTENTS)
    world = rbd.World(dt=1 / 240)
    body = world.add_body(
        rbd.shapes.box(EXTENTS),
        mass=2.0,
        center_of_mass=c,
        inertia=inertia,
        position=(1.0, 2.0, 3.0),
        angular_velocity=(0.0, 0.0, 2.0),
    )
    w = np.array([0.0, 0.0, 2.0])
    assert world.kinetic_energy() == pytest.approx(0.5 * w @ inertia @ w, rel=1e-14)
    world.step(100)
    np.testing.assert_allclose(world.transform(body) @ [*c, 1], [1, 2, 3, 1], atol=1e-14)
    # the mesh's own centre (its origin) went round c at radius |c_xy|
    origin = world.transform(body)[:3, 3]
    assert np.linalg.norm(origin[:2] - [1, 2]) == pytest.approx(np.linalg.norm(c[:2]), rel=1e-12)


# ---------------------------------------------------------------------- compound bodies
HALF_TURN = Rotation.from_euler("z", 90, degrees=True)


def half_boxes():
    """The 1 x 2 x 3 box as two 0.5 x 2 x 3 halves along x; the second is a 2 x 0.5 x 3 box
    turned a quarter about z, so that its pose's rotation is exercised."""
    return [
        (rbd.shapes.box((0.5, 2.0, 3.0)), pose(None, (-0.25, 0.0, 0.0))),
        (rbd.shapes.box((2.0, 0.5, 3.0)), pose(HALF_TURN, (0.25, 0.0, 0.0))),
    ]


def test_two_half_boxes_have_the_whole_box_s_mass_properties():
    shift = pose(TURN, (0.3, -0.2, 0.5))  # the whole compound off the mesh frame's axes
    shapes = [(mesh, shift @ T) for mesh, T in half_boxes()]
    world = rbd.World()
    by_mass = world.add_body(shapes=shapes, mass=6.0)
    by_density = world.add_body(shapes=shapes, density=1.0)  # volume 6
    R = TURN.as_matrix()
    for body in (by_mass, by_density):
        assert world.bodies.mass[body] == pytest.approx(6.0, rel=1e-14)
        np.testing.assert_allclose(
            world.bodies.center_of_mass_local[body], [0.3, -0.2, 0.5], atol=1e-14
        )
        np.testing.assert_allclose(
            world.bodies.inertia_body[body], R @ box_inertia(6.0, EXTENTS) @ R.T, atol=1e-13
        )


def test_unequal_parts_combine_by_the_parallel_axis_theorem():
    sizes = [np.array([1.0, 0.5, 0.5]), np.array([0.2, 0.2, 2.0])]
    turns = [Rotation.from_euler("z", 0.6), Rotation.from_euler("xy", [0.3, -1.2])]
    centres = [np.array([1.5, 0.0, 0.2]), np.array([-0.7, 0.4, -0.3])]
    density = 7.0
    world = rbd.World()
    body = world.add_body(
        shapes=[
            (rbd.shapes.box(s), pose(r, c)) for s, r, c in zip(sizes, turns, centres, strict=True)
        ],
        density=density,
    )
    masses = [density * np.prod(s) for s in sizes]
    m = sum(masses)
    c = sum(mi * ci for mi, ci in zip(masses, centres, strict=True)) / m
    inertia = np.zeros((3, 3))
    for mi, s, r, ci in zip(masses, sizes, turns, centres, strict=True):
        d = ci - c
        R = r.as_matrix()
        inertia += R @ box_inertia(mi, s) @ R.T + mi * (d @ d * np.eye(3) - np.outer(d, d))
    assert world.bodies.mass[body] == pytest.approx(m, rel=1e-14)
    np.testing.assert_allclose(world.bodies.center_of_mass_local[body], c, atol=1e-14)
    np.testing.assert_allclose(world.bodies.inertia_body[body], inertia, rtol=0, atol=1e-13 * m)
    # a fast body could pass through the thin part: the compound is as thin as it
    assert world.bodies.thickness[body] == pytest.approx(0.2, rel=1e-12)


def test_two_half_boxes_fly_and_land_as_the_whole_box():
    shapes = half_boxes()
    # free flight: the same motion to round-off (their inertias differ in the last bits)
    free = {}
    for key, body in (("whole", {"mesh": rbd.shapes.box(EXTENTS)}), ("halves", {"shapes": shapes})):
        world = rbd.World(dt=1 / 240)
        index = world.add_body(mass=6.0, angular_velocity=(0.1, 2.0, 0.1), **body)
        free[key] = run(world, index, 480)
    np.testing.assert_allclose(free["halves"], free["whole"], rtol=0, atol=1e-11)
    # landing on a floor through the OBBTree: the halves' bottom faces are the whole's, but the
    # compound is thinner, its contact slop a thousandth of 0.5 m, not of 1 m; the two may
    # meet the floor a step apart (at most a step's fall between them while they land) and
    # come to rest within the thinner slop of each other
    whole, a = tumbling_world("mesh", mesh=rbd.shapes.box(EXTENTS), mass=6.0)
    halves, b = tumbling_world("mesh", shapes=shapes, mass=6.0)
    path_whole, path_halves = run(whole, a, 360), run(halves, b, 360)
    assert whole.position(a)[2] < 0.6  # resting on a 2 x 3 face
    fall_speed = np.sqrt(2 * 9.81 * 2.5)
    gap = np.abs(path_halves[:, :3] - path_whole[:, :3]).max(axis=1)
    assert gap.max() < fall_speed / 240
    assert gap[-1] < 1e-3 * 0.5
    # each rests tilted by at most its slop across the face's shorter side (2 m); its turn
    # about the vertical is free, left by the bounce
    up_whole, up_halves = (
        Rotation.from_quat(path[-1, 3:]).inv().apply([0.0, 0.0, 1.0])
        for path in (path_whole, path_halves)
    )
    assert np.arccos(min(up_whole @ up_halves, 1.0)) < (1e-3 * 1.0 + 1e-3 * 0.5) / 2.0


def test_a_compound_of_several_parts_never_collides_as_one_hull():
    """Two half-boxes make a convex mesh (their union is the box), yet the compound goes
    through the OBBTree; one part alone, placed, may go the convex path."""
    shapes = half_boxes()
    world = rbd.World()
    compound = world.add_body(shapes=shapes)
    single = world.add_body(shapes=shapes[1:])
    assert is_convex(world.bodies.meshes[compound])
    assert world._collision.hull_of_body[compound] == -1
    assert world._collision.hull_of_body[single] >= 0


def test_a_small_box_falls_through_the_gap_between_two_parts():
    """Two pillars as one static compound: a cube dropped between them reaches the floor
    (one hull over both pillars would hold it on top)."""
    pillar = rbd.shapes.box((1.0, 1.0, 2.0))
    world = rbd.World(dt=1 / 240, gravity=(0, 0, -9.81))
    world.add_body(rbd.shapes.box((10, 10, 1)), static=True, position=(0, 0, -0.5))
    world.add_body(
        shapes=[(pillar, pose(None, (-1.0, 0, 1.0))), (pillar, pose(None, (1.0, 0, 1.0)))],
        static=True,
        position=(0.0, 0.0, 0.0),
    )
    cube = world.add_body(rbd.shapes.box((0.4, 0.4, 0.4)), mass=1.0, position=(0, 0, 2.5))
    world.step(480)
    assert world.position(cube)[2] == pytest.approx(0.2, abs=2e-3)


# ---------------------------------------------------------------------- bad input
BOX = rbd.shapes.box(EXTENTS)
GOOD = {"mass": 1.0, "center_of_mass": (0.0, 0.0, 0.0), "inertia": np.diag([1.0, 2.0, 2.5])}
OPEN = rbd.TriangleMesh(BOX.vertices, BOX.faces[:-2])


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({**GOOD, "inertia": [[1, 0.1, 0], [0, 2, 0], [0, 0, 2.5]]}, "not symmetric"),
        ({**GOOD, "inertia": np.diag([1.0, 2.0, -0.5])}, "not positive definite"),
        ({**GOOD, "inertia": np.zeros((3, 3))}, "not positive definite"),
        ({**GOOD, "inertia": np.diag([1.0, 1.0, 2.5])}, "triangle inequality"),
        ({**GOOD, "inertia": np.diag([1.0, np.nan, 2.0])}, "non-finite"),
        ({**GOOD, "inertia": np.diag([1.0, np.inf, 2.0])}, "non-finite"),
        ({**GOOD, "inertia": [1.0, 2.0, 2.5]}, r"shape \(3, 3\)"),
        ({**GOOD, "center_of_mass": (0.0, 0.0)}, r"center_of_mass must have shape \(3\)"),
        ({**GOOD, "center_of_mass": (0.0, np.inf, 0.0)}, "non-finite"),
        ({**GOOD, "mass": 0.0}, "mass must be finite and positive"),
        ({**GOOD, "mass": -2.0}, "mass must be finite and positive"),
        ({"center_of_mass": (0, 0, 0)}, "missing mass, inertia"),
        ({"center_of_mass": (0, 0, 0), "mass": 1.0}, "missing inertia"),
        ({"inertia": np.eye(3), "mass": 1.0}, "missing center_of_mass"),
        ({"inertia": np.eye(3), "center_of_mass": (0, 0, 0), "density": 2.0}, "not density"),
        ({**GOOD, "static": True}, "static or kinematic body takes no"),
        ({**GOOD, "kinematic": True}, "static or kinematic body takes no"),
        ({"mesh": OPEN}, "open"),
        ({"mesh": None}, "exactly one"),
        ({"shapes": [(BOX, np.eye(4))]}, "exactly one"),
        ({"mesh": None, "shapes": []}, "shapes is empty"),
        ({"mesh": None, "shapes": [BOX]}, r"shapes\[0\] must be a \(mesh, pose\) pair"),
        ({"mesh": None, "shapes": [(BOX.vertices, np.eye(4))]}, r"shapes\[0\] mesh must be"),
        ({"mesh": None, "shapes": [(BOX, np.eye(3))]}, r"shapes\[0\] pose must have shape"),
        ({"mesh": None, "shapes": [(BOX, np.eye(4)), (BOX, 2 * np.eye(4))]}, r"shapes\[1\] pose"),
        (
            {"mesh": None, "shapes": [(BOX, np.eye(4)), (OPEN, np.eye(4))]},
            r"shapes\[1\]: mesh is open",
        ),
    ],
)
def test_bad_mass_properties_and_shapes_are_refused_and_leave_the_world_as_it_was(
    arguments, message
):
    world = rbd.World(gravity=(0, 0, -9.81))
    world.add_body(BOX, mass=1.0)
    before = (world.bodies.count, list(world.stages), world.positions.copy())
    with pytest.raises(ValueError, match=message):
        world.add_body(**{"mesh": BOX, **arguments})
    assert (world.bodies.count, list(world.stages)) == before[:2]
    np.testing.assert_array_equal(world.positions, before[2])
    assert len(world.bodies.meshes) == len(world._collision.geometry_of_body) == 1


@settings(max_examples=examples(40), deadline=None)
@given(
    moments=st.lists(st.floats(-1.0, 4.0), min_size=3, max_size=3),
    angles=st.lists(st.floats(-np.pi, np.pi), min_size=3, max_size=3),
)
def test_an_inertia_is_taken_exactly_when_it_is_a_rigid_body_s(moments, angles):
    """Any turn of any three moments: refused as not positive definite, or as violating the
    triangle inequality, or else taken as given (symmetrised to round-off)."""
    lam = np.sort(moments)
    R = Rotation.from_euler("xyz", angles).as_matrix()
    inertia = R @ np.diag(moments) @ R.T
    world = rbd.World()
    scale = max(abs(lam).max(), 1e-300)
    if abs(lam[0]) <= 1e-9 * scale:
        return  # too near singular to say which side round-off puts it
    if lam[0] < 0:
        expected = "not positive definite"
    elif lam[2] - lam[0] - lam[1] > 1e-5 * lam[2]:
        expected = "triangle inequality"
    elif lam[2] - lam[0] - lam[1] > 1e-7 * lam[2]:
        return  # too near the tolerance to say which side round-off puts it
    else:
        expected = None
    if expected is None:
        body = world.add_body(BOX, mass=1.0, center_of_mass=(0, 0, 0), inertia=inertia)
        np.testing.assert_allclose(world.bodies.inertia_body[body], inertia, atol=1e-15 * scale)
    else:
        with pytest.raises(ValueError, match=expected):
            world.add_body(BOX, mass=1.0, center_of_mass=(0, 0, 0), inertia=inertia)
        assert world.bodies.count == 0


# ---------------------------------------------------------------------- scene files
SCENE = """
[[body]]
name = "halves"
mass = 6.0

[[body.shapes]]
shape = { type = "box", extents = [0.5, 2.0, 3.0] }
position = [-0.25, 0.0, 0.0]

[[body.shapes]]
shape = { type = "box", extents = [2.0, 0.5, 3.0] }
position = [0.25, 0.0, 0.0]
orientation = [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]

[[body]]
name = "link"
shape = { type = "box", extents = [1.0, 1.0, 1.0] }
mass = 2.0
center_of_mass = [0.1, 0.0, -0.2]
inertia = [[1.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 2.5]]
"""


def test_a_scene_file_gives_compounds_and_explicit_properties(tmp_path):
    path = tmp_path / "links.toml"
    path.write_text(SCENE)
    scene = rbd.load_scene(path)
    assert dict(scene.bodies[0].shape) == {"type": "compound", "parts": 2}
    world = scene.build()
    expected = rbd.World()
    expected.add_body(shapes=half_boxes(), mass=6.0)
    np.testing.assert_allclose(world.bodies.inertia_body[0], box_inertia(6.0, EXTENTS), atol=1e-13)
    np.testing.assert_allclose(
        world.bodies.meshes[0].vertices, expected.bodies.meshes[0].vertices, atol=1e-15
    )
    # the same parts as an array of inline tables
    inline = SCENE.split("[[body]]")[1].split("[[body.shapes]]")[0] + (
        'shapes = [{ shape = { type = "box", extents = [0.5, 2.0, 3.0] }, '
        "position = [-0.25, 0.0, 0.0] }, "
        '{ shape = { type = "box", extents = [2.0, 0.5, 3.0] }, position = [0.25, 0.0, 0.0], '
        "orientation = [0.0, 0.0, 0.7071067811865476, 0.7071067811865476] }]\n"
    )
    path.write_text("[[body]]" + inline)
    np.testing.assert_array_equal(
        rbd.load_scene(path).build().bodies.meshes[0].vertices, world.bodies.meshes[0].vertices
    )
    np.testing.assert_array_equal(world.bodies.center_of_mass_local[1], [0.1, 0.0, -0.2])
    np.testing.assert_array_equal(
        world.bodies.inertia_body[1], [[1.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 2.5]]
    )


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("mass = 2.0\ncenter", "center"), "missing mass"),
        (("[0.0, 0.0, 2.5]]", "[0.0, 0.0, 3.5]]"), "body\\[1\\] 'link': inertia violates"),
        (("[0.1, 2.0, 0.0]", "[0.1, 2.0]"), "field 'inertia': must be an array of 3 numbers"),
        (('name = "link"\n', 'name = "link"\nshapes = []\n'), "'shape' table or a compound's"),
        (('name = "halves"\n', 'name = "halves"\nshape = { type = "box" }\n'), "not both"),
        (('shape = { type = "box", extents = [1.0, 1.0, 1.0] }', "shapes = []"), "non-empty"),
        (("[[body.shapes]]\n", "[[body.shapes]]\nsize = 1\n"), "'shapes.0': unknown key 'size'"),
        (("[-0.25, 0.0, 0.0]", "[-0.25, 0.0]"), "field 'shapes.0.position'"),
    ],
)
def test_scene_faults_in_compounds_and_mass_properties_name_the_body(tmp_path, change, message):
    path = tmp_path / "links.toml"
    path.write_text(SCENE.replace(*change, 1))
    with pytest.raises(rbd.SceneError, match=message):
        rbd.load_scene(path).build()
