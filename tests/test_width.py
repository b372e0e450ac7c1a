"""hull_thickness against analytic widths."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.geometry.width import hull_thickness


@given(
    st.tuples(*[st.floats(1e-3, 1e3)] * 3),
    st.integers(0, 2**32 - 1),
)
def test_box_thickness_is_its_smallest_edge_in_any_pose(extents, seed):
    vertices = np.array(rbd.shapes.box(extents).vertices)
    turned = Rotation.random(random_state=seed).apply(vertices) + 1e3
    assert hull_thickness(turned) == pytest.approx(min(extents), rel=1e-9)


def test_sphere_thickness_is_near_its_diameter():
    ball = rbd.shapes.icosphere(0.5, 3)
    # the flat faces of an icosphere sit slightly inside the sphere: within 1 %
    assert hull_thickness(ball.vertices) == pytest.approx(1.0, rel=1e-2)


def test_flat_point_sets_have_no_thickness():
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    assert hull_thickness(square) == 0.0
