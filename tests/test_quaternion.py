"""Quaternion kernels against scipy's Rotation (the independent oracle), (x, y, z, w) order."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from thesis_rbd.spatial import (
    pose_from_transform,
    quat_conjugate,
    quat_derivative,
    quat_from_matrix,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
    transform_from_pose,
)

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
raw_quats = arrays(np.float64, (4,), elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-3)
vectors = arrays(np.float64, (3,), elements=finite)


def unit(q):
    return q / np.linalg.norm(q)


def same_rotation(q1, q2, atol=1e-12):
    """Quaternions q and -q are the same rotation."""
    return min(np.abs(q1 - q2).max(), np.abs(q1 + q2).max()) <= atol


@given(raw_quats, raw_quats)
def test_multiply_matches_scipy_composition(a, b):
    a, b = unit(a), unit(b)
    expected = (Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()
    assert same_rotation(quat_multiply(a, b), expected)


@given(raw_quats, vectors)
def test_rotate_matches_scipy(q, v):
    q = unit(q)
    np.testing.assert_allclose(
        quat_rotate(q, v), Rotation.from_quat(q).apply(v), atol=1e-12 * (1 + np.abs(v).max())
    )


@given(raw_quats)
def test_matrix_round_trip_matches_scipy(q):
    q = unit(q)
    R = quat_to_matrix(q)
    np.testing.assert_allclose(R, Rotation.from_quat(q).as_matrix(), atol=1e-13)
    back = quat_from_matrix(R)
    assert back[3] >= 0
    assert same_rotation(back, q, atol=1e-12)


@given(raw_quats)
def test_conjugate_is_inverse(q):
    q = unit(q)
    identity = quat_multiply(q, quat_conjugate(q))
    np.testing.assert_allclose(identity, [0, 0, 0, 1], atol=1e-14)


@settings(max_examples=50)
@given(raw_quats, vectors)
def test_derivative_matches_finite_difference_of_exact_rotation(q, omega):
    """q(t) = exp(t [w, 0] / 2) q0 for constant world w; compare dq/dt at t = 0."""
    q = unit(q)
    h = 1e-6

    def q_at(t):
        return (Rotation.from_rotvec(omega * t) * Rotation.from_quat(q)).as_quat()

    plus, minus = q_at(h), q_at(-h)
    # scipy picks a sign per quaternion; align both to q before differencing
    plus *= np.sign(plus @ q)
    minus *= np.sign(minus @ q)
    numeric = (plus - minus) / (2 * h)
    np.testing.assert_allclose(
        quat_derivative(q, omega), numeric, atol=1e-6 * (1 + np.abs(omega).max())
    )


def test_batch_shapes_and_broadcast():
    qs = Rotation.random(7, random_state=1).as_quat()
    vs = np.random.default_rng(2).normal(size=(7, 3))
    assert quat_rotate(qs, vs).shape == (7, 3)
    assert quat_rotate(qs[0], vs).shape == (7, 3)
    assert quat_multiply(qs, qs[1]).shape == (7, 4)
    assert quat_to_matrix(qs).shape == (7, 3, 3)
    assert quat_from_matrix(quat_to_matrix(qs)).shape == (7, 4)


@pytest.mark.parametrize(
    ("func", "args"),
    [
        (quat_rotate, (np.zeros(3), np.zeros(3))),
        (quat_multiply, (np.zeros((2, 4)), np.zeros((3, 4)))),
        (quat_to_matrix, (np.zeros((2, 5)),)),
        (quat_from_matrix, (np.zeros((4, 4)),)),
    ],
)
def test_bad_shapes_raise(func, args):
    with pytest.raises(ValueError, match=r"shape|pair"):
        func(*args)


def test_transform_round_trip():
    q = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_quat()
    T = transform_from_pose([1, 2, 3], q)
    position, orientation = pose_from_transform(T)
    np.testing.assert_allclose(position, [1, 2, 3])
    assert same_rotation(orientation, q)
    with pytest.raises(ValueError, match="zero length"):
        transform_from_pose([0, 0, 0], [0, 0, 0, 0])
