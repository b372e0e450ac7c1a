"""Slow, independent oracles for rigid-body dynamics.

The torque-free body is integrated in its own frame (Euler's equations plus the body-frame
quaternion equation dq/dt = 1/2 q [w_b, 0]) by scipy's DOP853 at rtol 1e-12: a different
formulation and a different solver from the library's world-frame (x, q, P, L) kernels.
"""

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation


def _torque_free_rhs(_t, y, inertia, inv_inertia):
    w = y[:3]
    q = y[3:]
    dw = inv_inertia @ np.cross(inertia @ w, w)
    wx, wy, wz = w
    x, yq, z, s = q
    # q * [w, 0] in (x, y, z, w) order
    dq = 0.5 * np.array(
        [
            s * wx + yq * wz - z * wy,
            s * wy + z * wx - x * wz,
            s * wz + x * wy - yq * wx,
            -x * wx - yq * wy - z * wz,
        ]
    )
    return np.concatenate([dw, dq])


def torque_free_reference(inertia_body, omega_body0, q0, times, rtol=1e-12, atol=1e-14):
    """Body-frame angular velocity (T, 3) and orientation (T, 4) at ``times``.

    Parameters
    ----------
    inertia_body : (3, 3) float
        Inertia tensor in the body frame.
    omega_body0 : (3,) float
        Initial angular velocity in the body frame.
    q0 : (4,) float
        Initial (x, y, z, w) orientation.
    times : (T,) float
        Increasing output times starting at 0.
    """
    inertia_body = np.asarray(inertia_body, float)
    solution = solve_ivp(
        _torque_free_rhs,
        (times[0], times[-1]),
        np.concatenate([omega_body0, q0]),
        method="DOP853",
        t_eval=times,
        rtol=rtol,
        atol=atol,
        args=(inertia_body, np.linalg.inv(inertia_body)),
    )
    assert solution.success, solution.message
    q = solution.y[3:].T
    return solution.y[:3].T, q / np.linalg.norm(q, axis=1, keepdims=True)


def rotation_angle_between(q1, q2):
    """Angle (rad) of the rotation taking q1 to q2, rows of (T, 4) arrays."""
    relative = Rotation.from_quat(q1).inv() * Rotation.from_quat(q2)
    return relative.magnitude()


def sign_change_times(times, signal):
    """Times where ``signal`` crosses zero, by linear interpolation between samples."""
    s = np.asarray(signal)
    idx = np.flatnonzero(np.signbit(s[:-1]) != np.signbit(s[1:]))
    t0, t1, s0, s1 = times[idx], times[idx + 1], s[idx], s[idx + 1]
    return t0 - s0 * (t1 - t0) / (s1 - s0)
