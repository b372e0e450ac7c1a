"""Slow, independent oracles the campaign measures the library against.

The torque-free rigid body is integrated in its own frame: Euler's equations
``I dw/dt = (I w) x w`` plus the body-frame quaternion equation ``dq/dt = 1/2 q [w, 0]``, solved
by scipy's DOP853 at rtol 1e-12. That is a different formulation (body frame, angular velocity)
and a different solver (adaptive 8th order) from the library's world-frame (x, q, P, L) kernels,
so agreement is evidence, not a tautology. Quaternions are (x, y, z, w), as everywhere in
thesis_rbd.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

__all__ = ["REFERENCE_RTOL", "rotation_angle_between", "torque_free_reference"]

REFERENCE_RTOL = 1e-12


def _torque_free_rhs(_t, y, inertia, inv_inertia):
    """Time derivative of (w_body, q) for a body with no applied torque."""
    w = y[:3]
    x, yq, z, s = y[3:]
    dw = inv_inertia @ np.cross(inertia @ w, w)
    wx, wy, wz = w
    # q * [w, 0] with q = (x, y, z, s), scalar last
    dq = 0.5 * np.array(
        [
            s * wx + yq * wz - z * wy,
            s * wy + z * wx - x * wz,
            s * wz + x * wy - yq * wx,
            -x * wx - yq * wy - z * wz,
        ]
    )
    return np.concatenate([dw, dq])


def torque_free_reference(inertia_body, omega_body0, q0, times, rtol=REFERENCE_RTOL, atol=1e-14):
    """Body-frame angular velocity and orientation of a torque-free body at ``times``.

    Parameters
    ----------
    inertia_body : (3, 3) array_like
        Inertia tensor about the centre of mass, body frame.
    omega_body0 : (3,) array_like
        Initial angular velocity, body frame (equal to the world frame when ``q0`` is the
        identity).
    q0 : (4,) array_like
        Initial (x, y, z, w) orientation.
    times : (T,) array_like
        Increasing output times, starting at the initial time.
    rtol, atol : float
        DOP853 tolerances.

    Returns
    -------
    omega_body : (T, 3) float
        Angular velocity in the body frame.
    orientation : (T, 4) float
        Unit (x, y, z, w) quaternions.
    """
    inertia_body = np.asarray(inertia_body, dtype=np.float64)
    times = np.asarray(times, dtype=np.float64)
    solution = solve_ivp(
        _torque_free_rhs,
        (times[0], times[-1]),
        np.concatenate([np.asarray(omega_body0, float), np.asarray(q0, float)]),
        method="DOP853",
        t_eval=times,
        rtol=rtol,
        atol=atol,
        args=(inertia_body, np.linalg.inv(inertia_body)),
    )
    if not solution.success:
        raise RuntimeError(f"reference integration failed: {solution.message}")
    q = solution.y[3:].T
    return solution.y[:3].T, q / np.linalg.norm(q, axis=1, keepdims=True)


def rotation_angle_between(q1, q2):
    """Angle (rad) of the rotation taking each row of ``q1`` to the same row of ``q2``.

    Parameters
    ----------
    q1, q2 : (T, 4) array_like
        (x, y, z, w) quaternions.

    Returns
    -------
    angle : (T,) float
        In [0, pi].
    """
    return (Rotation.from_quat(q1).inv() * Rotation.from_quat(q2)).magnitude()
