"""World AABBs of posed meshes contain every transformed vertex and are tight for boxes."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.collision.bounds import world_bounds


@given(st.integers(0, 10**6))
def test_bounds_contain_the_posed_mesh(seed):
    rng = np.random.default_rng(seed)
    mesh = rbd.shapes.torus(1.0, 0.3, 12, 8)
    world = rbd.World()
    for _ in range(3):
        world.add_body(
            mesh,
            mass=1.0,
            position=rng.normal(scale=10, size=3),
            orientation=Rotation.random(random_state=rng.integers(1 << 31)).as_quat(),
        )
    b = world.bodies
    n = len(world)
    lo = np.tile(mesh.bounds[0], (n, 1))
    hi = np.tile(mesh.bounds[1], (n, 1))
    margin = np.full(n, 0.01)
    lower, upper = np.empty((n, 3)), np.empty((n, 3))
    world_bounds(n, lo, hi, b.center_of_mass_local, b.position, b.orientation, margin, lower, upper)
    for i in range(n):
        T = world.transform(i)
        vertices = mesh.vertices @ T[:3, :3].T + T[:3, 3]
        assert np.all(vertices >= lower[i] + 0.01 - 1e-12)
        assert np.all(vertices <= upper[i] - 0.01 + 1e-12)


def test_axis_aligned_box_is_tight():
    box = rbd.shapes.box((1.0, 2.0, 3.0))
    world = rbd.World()
    world.add_body(box, mass=1.0, position=(5, 6, 7))
    b = world.bodies
    lower, upper = np.empty((1, 3)), np.empty((1, 3))
    world_bounds(
        1,
        box.bounds[:1],
        box.bounds[1:],
        b.center_of_mass_local,
        b.position,
        b.orientation,
        np.zeros(1),
        lower,
        upper,
    )
    np.testing.assert_allclose(lower[0], [4.5, 5, 5.5])
    np.testing.assert_allclose(upper[0], [5.5, 7, 8.5])
