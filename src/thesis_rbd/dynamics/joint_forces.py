"""The forces a joint exerts along its axis row that no one drives: a spring and a damper
pulling it towards a rest position, and Coulomb friction resisting its motion.

Each law gives the impulse along the joint's row (``joint_rows.axis_row``: a hinge's turning,
a slider's travel, a distance joint's length) for one substep of length h, from the row's
velocity v and effective mass m with the joint's own rows held (``joint_motors``, which
sweeps an island's joints Gauss-Seidel and calls these with the impulse each has already
applied in the substep):

* a spring of stiffness k and damper c towards position q0 is taken at the end of the
  substep (implicitly), lam = h (k (q0 - q) - (k h + c) v+) for the row's velocity v+ after
  the impulse, so that no stiffness or damping is too stiff for the step: the step damps the
  motion as well, by about h k / (2 m) per second, and a stiff spring's own ringing dies
  within a substep instead of growing. A position motor is the same law with a cap; a
  distance joint's spring pulls its length towards its rest length, and a hinge's or slider's
  viscous damping is the law with k = 0;
* friction of at most F (N, or N m about a hinge) takes the impulse that stops the row,
  clipped to F h: a velocity motor with target 0. A joint that the other forces push with
  less than F does not move at all; a moving one slows at F / m.
"""

from __future__ import annotations

from thesis_rbd._numba.jit import njit

__all__ = ["friction_impulse", "spring_impulse"]


@njit(allocates=False)
def spring_impulse(h, stiffness, damping, error, velocity, mass, applied):
    """The impulse a spring and damper add along a row, taken at the end of the substep.

    Parameters
    ----------
    h : float
        Substep (s).
    stiffness, damping : float
        k (N/m or N m/rad) and c (N s/m or N m s/rad), >= 0.
    error : float
        Rest position minus position (m or rad).
    velocity : float
        The row's velocity now (m/s or rad/s), with ``applied`` already in it.
    mass : float
        The row's effective mass (kg or kg m^2), > 0.
    applied : float
        What this spring has given along the row in the substep so far (N s or N m s).

    Returns
    -------
    float
        The impulse to add, so that the substep's total is h (k error - (k h + c) v+).
    """
    beta = h * (stiffness * h + damping)
    total = (h * stiffness * error - beta * velocity + beta * applied / mass) / (1.0 + beta / mass)
    return total - applied


@njit(allocates=False)
def friction_impulse(h, most, velocity, mass, applied):
    """The impulse Coulomb friction of at most ``most`` (N or N m) adds along a row: what
    stops it, the substep's total within most * h (other parameters as ``spring_impulse``)."""
    cap = most * h
    total = min(max(applied - mass * velocity, -cap), cap)
    return total - applied
