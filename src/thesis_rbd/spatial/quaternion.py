"""Quaternion algebra in (x, y, z, w) order, scalar last (scipy, pybullet).

Two layers:

* scalar kernels (``mul``, ``rotate``, ``derivative``, ...) that take anything indexable of
  length 4 or 3 (an array row or a tuple) and return tuples, so that a hot loop allocates
  nothing;
* batch functions (``quat_multiply``, ``quat_rotate``, ...) over (n, 4) arrays for Python
  callers, which validate shapes and loop over rows in a kernel.

A unit quaternion q = (sin(t/2) u, cos(t/2)) rotates vectors by t about the unit axis u:
v' = q v q*, and evolves as dq/dt = 1/2 [w, 0] q for a world-frame angular velocity w
(thesis 3.3).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "conjugate",
    "derivative",
    "from_matrix",
    "mul",
    "normalize",
    "quat_conjugate",
    "quat_derivative",
    "quat_from_matrix",
    "quat_multiply",
    "quat_rotate",
    "quat_to_matrix",
    "rotate",
    "to_matrix_into",
]


# ---------------------------------------------------------------------------- scalar kernels
@njit
def mul(a, b):
    """Hamilton product a * b of two (x, y, z, w) quaternions, as a 4-tuple."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


@njit
def conjugate(q):
    """Conjugate (-x, -y, -z, w): the inverse of a unit quaternion."""
    return (-q[0], -q[1], -q[2], q[3])


@njit
def normalize(q):
    """q / |q| as a 4-tuple (q must not be zero)."""
    inv = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)


@njit
def rotate(q, v):
    """Rotate the 3-vector v by the unit quaternion q, as a 3-tuple.

    Uses v' = v + 2 w (u x v) + 2 u x (u x v) with q = (u, w): the expanded form of q v q*,
    15 multiplies and no intermediate quaternion.
    """
    ux, uy, uz, w = q[0], q[1], q[2], q[3]
    tx = 2.0 * (uy * v[2] - uz * v[1])
    ty = 2.0 * (uz * v[0] - ux * v[2])
    tz = 2.0 * (ux * v[1] - uy * v[0])
    return (
        v[0] + w * tx + (uy * tz - uz * ty),
        v[1] + w * ty + (uz * tx - ux * tz),
        v[2] + w * tz + (ux * ty - uy * tx),
    )


@njit
def derivative(q, omega):
    """dq/dt = 1/2 [omega, 0] * q for world-frame angular velocity omega, as a 4-tuple."""
    wx, wy, wz = omega[0], omega[1], omega[2]
    qx, qy, qz, qw = q[0], q[1], q[2], q[3]
    return (
        0.5 * (wx * qw + wy * qz - wz * qy),
        0.5 * (wy * qw - wx * qz + wz * qx),
        0.5 * (wz * qw + wx * qy - wy * qx),
        0.5 * (-wx * qx - wy * qy - wz * qz),
    )


@njit
def to_matrix(q):
    """Rows of the rotation matrix of unit quaternion q, as three 3-tuples."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return (
        (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)),
        (2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)),
        (2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)),
    )


@njit
def to_matrix_into(q, out):
    """Write the rotation matrix of unit quaternion q into ``out`` (3, 3)."""
    rows = to_matrix(q)
    for a in range(3):
        for b in range(3):
            out[a, b] = rows[a][b]


@njit
def from_matrix(m):
    """Unit quaternion (w >= 0) of a rotation matrix, by Shepperd's method, as a 4-tuple.

    The branch on the largest of trace and diagonal keeps the square root away from zero.
    """
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > m[0, 0] and trace > m[1, 1] and trace > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    elif m[0, 0] >= m[1, 1] and m[0, 0] >= m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif m[1, 1] >= m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
    if q[3] < 0.0:
        q = (-q[0], -q[1], -q[2], -q[3])
    return normalize(q)


# ---------------------------------------------------------------------------- batch kernels
@njit
def _multiply_rows(a, b, out):
    for i in range(a.shape[0]):
        r = mul(a[i], b[i])
        for k in range(4):
            out[i, k] = r[k]


@njit
def _rotate_rows(q, v, out):
    for i in range(q.shape[0]):
        r = rotate(q[i], v[i])
        for k in range(3):
            out[i, k] = r[k]


@njit
def _derivative_rows(q, omega, out):
    for i in range(q.shape[0]):
        r = derivative(q[i], omega[i])
        for k in range(4):
            out[i, k] = r[k]


@njit
def _to_matrix_rows(q, out):
    for i in range(q.shape[0]):
        to_matrix_into(q[i], out[i])


@njit
def _from_matrix_rows(m, out):
    for i in range(m.shape[0]):
        r = from_matrix(m[i])
        for k in range(4):
            out[i, k] = r[k]


def _rows(value, width: int, name: str) -> tuple[np.ndarray, bool]:
    """Return a C-contiguous float64 (n, width) view and whether the input was a single row."""
    array = np.asarray(value, dtype=np.float64)
    if array.shape[-1:] != (width,) or array.ndim not in (1, 2):
        raise ValueError(f"{name} must have shape ({width},) or (n, {width}), got {array.shape}")
    single = array.ndim == 1
    return np.ascontiguousarray(array.reshape(-1, width)), single


def _broadcast(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if len(a) == len(b):
        return a, b
    if len(a) == 1:
        return np.ascontiguousarray(np.broadcast_to(a, (len(b), a.shape[1]))), b
    if len(b) == 1:
        return a, np.ascontiguousarray(np.broadcast_to(b, (len(a), b.shape[1])))
    raise ValueError(f"cannot pair {len(a)} rows with {len(b)} rows")


def quat_multiply(a, b) -> np.ndarray:
    """Hamilton product a * b; (4,) or (n, 4) each, broadcasting a single row."""
    a, single_a = _rows(a, 4, "a")
    b, single_b = _rows(b, 4, "b")
    a, b = _broadcast(a, b)
    out = np.empty_like(a)
    _multiply_rows(a, b, out)
    return out[0] if single_a and single_b else out


def quat_conjugate(q) -> np.ndarray:
    """Conjugate (-x, -y, -z, w) of (4,) or (n, 4) quaternions."""
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def quat_rotate(q, v) -> np.ndarray:
    """Rotate vectors v (3,) or (n, 3) by unit quaternions q (4,) or (n, 4)."""
    q, single_q = _rows(q, 4, "q")
    v, single_v = _rows(v, 3, "v")
    if len(q) != len(v):
        if len(q) == 1:
            q = np.ascontiguousarray(np.broadcast_to(q, (len(v), 4)))
        elif len(v) == 1:
            v = np.ascontiguousarray(np.broadcast_to(v, (len(q), 3)))
        else:
            raise ValueError(f"cannot pair {len(q)} quaternions with {len(v)} vectors")
    out = np.empty((len(q), 3))
    _rotate_rows(q, v, out)
    return out[0] if single_q and single_v else out


def quat_derivative(q, omega) -> np.ndarray:
    """dq/dt = 1/2 [omega, 0] q for world-frame angular velocities omega (3,) or (n, 3)."""
    q, single_q = _rows(q, 4, "q")
    omega, single_w = _rows(omega, 3, "omega")
    if len(q) != len(omega):
        raise ValueError(f"cannot pair {len(q)} quaternions with {len(omega)} angular velocities")
    out = np.empty_like(q)
    _derivative_rows(q, omega, out)
    return out[0] if single_q and single_w else out


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrices (3, 3) or (n, 3, 3) of unit quaternions (4,) or (n, 4)."""
    q, single = _rows(q, 4, "q")
    out = np.empty((len(q), 3, 3))
    _to_matrix_rows(q, out)
    return out[0] if single else out


def quat_from_matrix(m) -> np.ndarray:
    """Unit quaternions (w >= 0) of rotation matrices (3, 3) or (n, 3, 3)."""
    m = np.asarray(m, dtype=np.float64)
    if m.shape[-2:] != (3, 3) or m.ndim not in (2, 3):
        raise ValueError(f"m must have shape (3, 3) or (n, 3, 3), got {m.shape}")
    single = m.ndim == 2
    m = np.ascontiguousarray(m.reshape(-1, 3, 3))
    out = np.empty((len(m), 4))
    _from_matrix_rows(m, out)
    return out[0] if single else out
