"""Mass properties against analytic values and against trimesh on random convex hulls."""

import numpy as np
import pytest
import trimesh
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd


def test_box_is_exact():
    a, b, c = 1.0, 2.0, 3.0
    props = rbd.mass_properties(rbd.shapes.box((a, b, c)), density=2.0)
    m = 2.0 * a * b * c
    assert props.mass == pytest.approx(m, rel=1e-14)
    assert props.volume == pytest.approx(6.0, rel=1e-14)
    expected = m / 12 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    np.testing.assert_allclose(props.inertia, expected, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(props.center_of_mass, 0, atol=1e-14)


def test_rotated_translated_box_transforms_like_a_tensor():
    R = Rotation.from_euler("zyx", [0.4, -0.7, 1.2]).as_matrix()
    offset = np.array([1e3, -2e3, 5e2])  # far from the origin: tests the centred integration
    box = rbd.shapes.box((1.0, 2.0, 3.0))
    moved = rbd.TriangleMesh(box.vertices @ R.T + offset, box.faces)
    props = rbd.mass_properties(moved, mass=3.0)
    base = rbd.mass_properties(box, mass=3.0)
    np.testing.assert_allclose(props.center_of_mass, offset, rtol=1e-12)
    np.testing.assert_allclose(props.inertia, R @ base.inertia @ R.T, atol=1e-9)


def test_cylinder_converges_to_the_analytic_limit():
    r, h = 0.5, 2.0
    props = rbd.mass_properties(rbd.shapes.cylinder(r, h, 2048), density=1.0)
    volume = np.pi * r**2 * h
    assert props.volume == pytest.approx(volume, rel=1e-5)
    m = props.mass
    expected = np.diag([m * (3 * r**2 + h**2) / 12] * 2 + [m * r**2 / 2])
    np.testing.assert_allclose(props.inertia, expected, rtol=1e-5, atol=1e-12)


def test_capsule_converges_to_the_analytic_limit():
    """A cylinder of length h between hemispheres of radius r: V = pi r^2 (h + 4 r / 3);
    about its axis I = m_c r^2 / 2 + 2 m_s r^2 / 5 (cylinder and ball parts)."""
    r, h = 0.3, 1.0
    props = rbd.mass_properties(rbd.shapes.capsule(r, h, 256), density=1.0)
    cylinder, ball = np.pi * r**2 * h, 4.0 / 3.0 * np.pi * r**3
    assert props.volume == pytest.approx(cylinder + ball, rel=1e-3)
    axial = cylinder * r**2 / 2 + 2 * ball * r**2 / 5
    assert props.inertia[2, 2] == pytest.approx(axial, rel=2e-3)
    np.testing.assert_allclose(props.center_of_mass, 0, atol=1e-12)


def test_regular_prism_matches_its_polygon_formula():
    """An n-gon prism is exact: V = n/2 R^2 sin(2 pi/n) h."""
    n, r, h = 7, 0.8, 1.5
    props = rbd.mass_properties(rbd.shapes.cylinder(r, h, n))
    assert props.volume == pytest.approx(n / 2 * r**2 * np.sin(2 * np.pi / n) * h, rel=1e-13)


def test_torus_converges_to_the_analytic_limit():
    R, r = 1.0, 0.3
    props = rbd.mass_properties(rbd.shapes.torus(R, r, 400, 200), density=1.0)
    volume = 2 * np.pi**2 * R * r**2
    assert props.volume == pytest.approx(volume, rel=1e-3)
    m = props.mass
    i_axis = m * (R**2 + 3 * r**2 / 4)
    i_diameter = m * (R**2 / 2 + 5 * r**2 / 8)
    np.testing.assert_allclose(np.diag(props.inertia), [i_diameter, i_diameter, i_axis], rtol=1e-3)


@given(
    arrays(np.float64, (12, 3), elements=st.floats(-5, 5, allow_nan=False)),
    st.floats(0.1, 100.0),
)
def test_random_convex_hulls_agree_with_trimesh(points, density):
    # a solid only: flat or repeated point sets have no volume (and qhull rejects them)
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    assume(spread[-1] > 1e-3 * spread[0])
    hull = trimesh.convex.convex_hull(points)
    assume(hull.volume > 1e-6 and hull.is_watertight)
    props = rbd.mass_properties(rbd.TriangleMesh.from_trimesh(hull), density=density)
    hull.density = density
    assert props.volume == pytest.approx(hull.volume, rel=1e-9)
    assert props.mass == pytest.approx(hull.mass, rel=1e-9)
    np.testing.assert_allclose(
        props.center_of_mass, hull.center_mass, atol=1e-9 * np.ptp(points, axis=0).max()
    )
    inertia_scale = np.abs(hull.moment_inertia).max()
    np.testing.assert_allclose(props.inertia, hull.moment_inertia, atol=1e-9 * inertia_scale)


def test_open_flipped_and_bad_density_raise():
    box = rbd.shapes.box((1, 1, 1))
    open_box = rbd.TriangleMesh(box.vertices, box.faces[:-1])
    with pytest.raises(ValueError, match="open"):
        rbd.mass_properties(open_box)
    inward = rbd.TriangleMesh(box.vertices, box.faces[:, ::-1])
    with pytest.raises(ValueError, match="inward"):
        rbd.mass_properties(inward)
    mixed_faces = box.faces.copy()
    mixed_faces[0] = mixed_faces[0, ::-1]
    with pytest.raises(ValueError, match="inconsistently"):
        rbd.mass_properties(rbd.TriangleMesh(box.vertices, mixed_faces))
    for bad in (0.0, -1.0, np.nan, np.inf, "heavy"):
        with pytest.raises(ValueError, match="density"):
            rbd.mass_properties(box, density=bad)
        with pytest.raises(ValueError, match="mass"):
            rbd.mass_properties(box, mass=bad)
    with pytest.raises(ValueError, match="TriangleMesh"):
        rbd.mass_properties(box.vertices)


def test_principal_axes_diagonalise():
    R = Rotation.from_euler("xyz", [0.3, 0.2, 0.1]).as_matrix()
    box = rbd.shapes.box((1.0, 2.0, 3.0))
    props = rbd.mass_properties(rbd.TriangleMesh(box.vertices @ R.T, box.faces), mass=1.0)
    moments, axes = props.principal_axes()
    np.testing.assert_allclose(moments, [5 / 12, 10 / 12, 13 / 12], rtol=1e-12)
    np.testing.assert_allclose(axes.T @ props.inertia @ axes, np.diag(moments), atol=1e-12)
