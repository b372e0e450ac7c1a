"""Time of impact: the one-call bisection against python-fcl.

``bisect_to_contact`` moves a group back along its ballistic path and bisects on the
detector's yes/no query. python-fcl, an independent intersection test, says whether the
bodies touch where the search leaves them and were apart one resolution step further back;
the poses and velocities left are those of the ballistic path at the time found.
"""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.touching import pairs_touch
from thesis_rbd.dynamics.free_rotation import turn_freely
from thesis_rbd.world.time_of_impact import HALVINGS, bisect_to_contact, group_contacts
from validation.fcl_adapter import fcl_collide, fcl_model, fcl_object

DT = 1.0 / 240.0
SHAPES = {
    "box": lambda size: rbd.shapes.box((size, 0.6 * size, 0.3 * size)),
    "icosphere": lambda size: rbd.shapes.icosphere(0.5 * size, 2),
    "cylinder": lambda size: rbd.shapes.cylinder(0.4 * size, size, 12),
    "torus": lambda size: scaled(rbd.shapes.torus(0.4, 0.15, 16, 8), size),  # a mesh pair
}


def scaled(mesh, size):
    """``mesh`` scaled by ``size`` (trimesh's torus built at 1 mm comes out open)."""
    return rbd.TriangleMesh(mesh.vertices * size, mesh.faces)


def pose_back(T0, x0, v, L, inverse_inertia_body, acceleration, s):
    """Mesh-to-world transform of a body whose transform is ``T0`` and centre of mass ``x0``
    at the end of the step, moved back by s along its ballistic path: the translation written
    out here, the torque-free turn ``turn_freely``'s (checked against an ODE solution in
    test_free_rotation.py), taken in one turn of -s from the end pose."""
    com_local = T0[:3, :3].T @ (x0 - T0[:3, 3])
    x = x0 - v * s + 0.5 * acceleration * s * s
    end = Rotation.from_matrix(T0[:3, :3]).as_quat()
    R = Rotation.from_quat(turn_freely(end, L, inverse_inertia_body, -s)).as_matrix()
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, x - R @ com_local
    return T


def falling_pair(shape, size, speed, spin, tilt, depth):
    """A convex body that flew into a static box this step, ending ``depth`` of its size
    below touching; returns (world, body, v, w, acceleration)."""
    world = rbd.World(gravity=(0.0, 0.0, -9.81), sleeping=False)
    world.add_body(rbd.shapes.box((20 * size, 20 * size, size)), static=True,
                   position=(0.0, 0.0, -0.5 * size))  # fmt: skip
    mesh = SHAPES[shape](size)
    rotation = Rotation.from_rotvec(tilt)
    lowest = (mesh.vertices @ rotation.as_matrix().T)[:, 2].min()
    centre = (mesh.vertices.mean(axis=0) @ rotation.as_matrix().T)[2]
    body = world.add_body(
        mesh, mass=1.0, orientation=rotation.as_quat(),
        position=(0.1 * size, -0.2 * size, centre - lowest - depth * size),
    )  # fmt: skip
    n = world.bodies.count
    v = np.zeros((n, 3))
    v[body] = (0.3 * speed, -0.2 * speed, -speed)
    w = np.zeros((n, 3))
    w[body] = spin
    acceleration = np.zeros((n, 3))
    acceleration[body] = world.gravity
    return world, body, v, w, acceleration


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    shape=st.sampled_from(sorted(SHAPES)),
    size=st.sampled_from([1e-3, 1.0, 50.0]),
    speed=st.floats(0.5, 20.0),
    spin=st.tuples(*[st.floats(-20.0, 20.0)] * 3),
    tilt=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    depth=st.floats(1e-4, 0.05),
)
def test_the_kernel_finds_the_moment_of_first_contact(shape, size, speed, spin, tilt, depth):
    """python-fcl, an independent intersection test, says the bodies touch where the
    search leaves them and were apart one resolution step further back (or touched already
    at the start of the step, when it went back all the way); the body's pose and velocity
    are those of its ballistic path at that time, written out apart from the kernel."""
    speed *= size  # sizes per second: the body moves by a comparable part of itself
    world, body, v, w, acceleration = falling_pair(
        shape, size, speed, np.array(spin), np.array(tilt), depth
    )
    detector, bodies = world._collision, world.bodies
    floor = fcl_object(fcl_model(world.bodies.meshes[0]), world.transform(0))
    model = fcl_model(world.bodies.meshes[body])
    T0, x0 = world.transform(body), world.position(body)

    # the world angular momentum of the spin w: R I_body R^T w
    R0 = T0[:3, :3]
    L = np.zeros_like(w)
    L[body] = R0 @ bodies.full("inertia_body")[body] @ R0.T @ w[body]
    Ii = bodies.full("inverse_inertia_body")

    def touch(s):
        pose = pose_back(T0, x0, v[body], L[body], Ii[body], acceleration[body], s)
        return fcl_collide(floor, fcl_object(model, pose), max_contacts=1)[0]

    v_kernel = v.copy()
    t = bisect_to_contact(
        np.array([body]), np.array([[0, body]]), np.zeros((0, 2), np.int64), np.zeros(0),
        v_kernel, L, Ii, acceleration, bodies.full("position"), bodies.full("orientation"), DT,
        bodies.full("center_of_mass_local"), detector.touch_inputs(world._state.convex_cache),
    )  # fmt: skip

    assert 0.0 < t <= DT  # every body ends inside the floor: some step back
    assert touch(t)
    if t < DT:
        assert not touch(t + DT / 2**HALVINGS)
    expected = pose_back(T0, x0, v[body], L[body], Ii[body], acceleration[body], t)
    np.testing.assert_allclose(world.transform(body), expected, rtol=0, atol=1e-12 * size)
    np.testing.assert_allclose(v_kernel[body], v[body] - acceleration[body] * t, rtol=1e-12)


def test_pairs_touch_asks_convex_and_mesh_pairs_alike():
    """A floor, a cube and a torus: the answer is whether any pair touches, whichever
    path the touching pair takes."""
    world = rbd.World()
    world.add_body(rbd.shapes.box((8.0, 8.0, 1.0)), static=True, position=(0, 0, -0.5))
    world.add_body(rbd.shapes.box((1.0, 1.0, 1.0)), mass=1.0, position=(-2.0, 0, 0.5))
    world.add_body(rbd.shapes.torus(0.6, 0.2, 24, 12), mass=1.0, position=(2.0, 0, 0.2))
    detector, bodies = world._collision, world.bodies
    pairs = np.array([[0, 1], [0, 2]])
    position = bodies.full("position")

    def touching():
        orientation, centre = bodies.full("orientation"), bodies.full("center_of_mass_local")
        inputs = detector.touch_inputs(world._state.convex_cache)
        return pairs_touch(pairs, position, orientation, centre, *inputs)

    assert touching()  # both rest on the floor
    position[1, 2] = 0.6  # the cube lifted: the torus (a mesh pair) still touches
    assert touching()
    position[2, 2] = 0.3  # both lifted
    assert not touching()
    position[1, 2] = 0.49  # the cube (a convex pair) pressed in
    assert touching()


@settings(max_examples=100, deadline=None)
@given(
    data=st.data(),
    body_count=st.integers(2, 12),
    contact_count=st.integers(0, 30),
)
def test_group_contacts_are_the_numpy_set_operations(data, body_count, contact_count):
    """The kernel's group members, contacts and distinct hit pairs against np.isin and
    np.unique(axis=0), the Python it replaced."""
    bodies = st.integers(0, body_count - 1)
    body_a = np.array(data.draw(st.lists(bodies, min_size=contact_count, max_size=contact_count)),
                      np.int64)  # fmt: skip
    body_b = np.array(data.draw(st.lists(bodies, min_size=contact_count, max_size=contact_count)),
                      np.int64)  # fmt: skip
    group = np.array(data.draw(st.lists(st.integers(-1, 2), min_size=body_count,
                                        max_size=body_count)), np.int64)  # fmt: skip
    hits = np.array(data.draw(st.lists(st.booleans(), min_size=contact_count,
                                       max_size=contact_count)), bool)  # fmt: skip
    for g in range(3):
        members, mine, pairs = group_contacts(group, g, body_a, body_b, hits)
        expected_members = np.flatnonzero(group == g)
        expected_mine = np.isin(body_a, expected_members) | np.isin(body_b, expected_members)
        searched = expected_mine & hits
        expected_pairs = np.unique(
            np.stack([body_a[searched], body_b[searched]], axis=1), axis=0
        ).reshape(-1, 2)
        np.testing.assert_array_equal(members, expected_members)
        np.testing.assert_array_equal(mine, expected_mine)
        np.testing.assert_array_equal(pairs, expected_pairs)
