"""Time of impact: the one-call bisection against a plain Python bisection.

``python_bisection`` below moves a group back along its ballistic path and asks the
detector's yes/no query at each halving, one call at a time; ``bisect_to_contact`` does the
same in one kernel call. The Python search is the reference: the kernel must leave the same
time and the same poses and velocities, to the bit, for convex pairs and mesh pairs alike.
"""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.touching import pairs_touch
from thesis_rbd.dynamics.ballistic import move_ballistic
from thesis_rbd.world.time_of_impact import HALVINGS, bisect_to_contact, group_contacts

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


def python_bisection(detector, bodies, members, pairs, v, w, acceleration, dt):
    """The reference search: back to the start of the step, then HALVINGS bisections on
    ``detector.intersects``, each move and each query a call of its own."""
    position, orientation = bodies.full("position"), bodies.full("orientation")
    at = 0.0

    def move_to(t):
        nonlocal at
        move_ballistic(members, at - t, v, w, acceleration, position, orientation)
        at = t

    move_to(dt)
    if detector.intersects(pairs):
        return dt
    inside, outside = 0.0, dt
    for _ in range(HALVINGS):
        middle = 0.5 * (inside + outside)
        move_to(middle)
        if detector.intersects(pairs):
            inside = middle
        else:
            outside = middle
    move_to(inside)
    return inside


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
def test_the_kernel_bisection_is_the_python_bisection(shape, size, speed, spin, tilt, depth):
    speed *= size  # sizes per second: the body moves by a comparable part of itself
    world, body, v, w, acceleration = falling_pair(
        shape, size, speed, np.array(spin), np.array(tilt), depth
    )
    detector, bodies = world._collision, world.bodies
    members = np.array([body])
    pairs = np.array([[0, body]])
    position, orientation = bodies.full("position"), bodies.full("orientation")
    start = position.copy(), orientation.copy()

    v_python = v.copy()
    t_python = python_bisection(detector, bodies, members, pairs, v_python, w, acceleration, DT)
    after_python = position.copy(), orientation.copy()

    position[:], orientation[:] = start
    v_kernel = v.copy()
    t_kernel = bisect_to_contact(
        members, pairs, v_kernel, w, acceleration, position, orientation, DT,
        bodies.full("center_of_mass_local"), detector.touch_inputs(),
    )  # fmt: skip

    assert t_kernel == t_python
    np.testing.assert_array_equal(position, after_python[0])
    np.testing.assert_array_equal(orientation, after_python[1])
    np.testing.assert_array_equal(v_kernel, v_python)
    assert 0.0 < t_kernel <= DT  # every pair starts inside the floor: some step back


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
        return pairs_touch(pairs, position, orientation, centre, *detector.touch_inputs())

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
    """The kernel's group members, contacts and distinct pairs against np.isin and
    np.unique(axis=0), the Python it replaced."""
    bodies = st.integers(0, body_count - 1)
    body_a = np.array(data.draw(st.lists(bodies, min_size=contact_count, max_size=contact_count)),
                      np.int64)  # fmt: skip
    body_b = np.array(data.draw(st.lists(bodies, min_size=contact_count, max_size=contact_count)),
                      np.int64)  # fmt: skip
    group = np.array(data.draw(st.lists(st.integers(-1, 2), min_size=body_count,
                                        max_size=body_count)), np.int64)  # fmt: skip
    for g in range(3):
        members, mine, pairs = group_contacts(group, g, body_a, body_b)
        expected_members = np.flatnonzero(group == g)
        expected_mine = np.isin(body_a, expected_members) | np.isin(body_b, expected_members)
        expected_pairs = np.unique(
            np.stack([body_a[expected_mine], body_b[expected_mine]], axis=1), axis=0
        ).reshape(-1, 2)
        np.testing.assert_array_equal(members, expected_members)
        np.testing.assert_array_equal(mine, expected_mine)
        np.testing.assert_array_equal(pairs, expected_pairs)
