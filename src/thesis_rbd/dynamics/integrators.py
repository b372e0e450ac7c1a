"""Numerical integration of the rigid-body equations of motion (thesis 3.2-3.4).

The state of body i is y = (x, q, P, L) and its derivative

    dx/dt = v = P / M
    dq/dt = 1/2 [w, 0] q,          w = R I_body^-1 R^T L
    dP/dt = F(x, v)                (external force + drag)
    dL/dt = tau(q, w)              (point-force torques + angular drag)

Free bodies do not interact inside a step, so a multi-stage method on the whole system equals
the same method on each body alone: one fused kernel walks the bodies and keeps all stages of a
body in registers (tuples), allocating nothing. The quaternion is renormalised at the end of
every step; a projection of O(error) size keeps each method's order.

Methods: "verlet" (the default: velocity Verlet, kick-drift-kick, whose drift turns the body
with ``free_rotation.turn_freely``; order 2, symplectic for forces that do not depend on
velocity, and exact in kinetic energy and angular momentum for torque-free rotation at any
spin), and the thesis's explicit methods, which update q like any other state variable and so
let a body tumbling about an axis other than a principal one gain energy without bound:
"euler" (explicit, order 1), "symplectic_euler" (semi-implicit: momenta first, then positions
with the new velocities; order 1, with the bounded energy error of a symplectic method on
separable problems such as a mass on a spring or a ball in gravity), "midpoint" (order 2),
"rk4" (order 4).

In "verlet" the forces at the end of the step are evaluated at the momenta an Euler step
predicts (a constant force is integrated exactly; drag, which depends on velocity, to second
order): P1 = P0 + h/2 (F(q0, P0) + F(q1, P0 + h F(q0, P0))), likewise L.

Bodies the contact stage solved move with their final momenta: x += h v and q turned freely
by ``turn_freely`` with L held, so a contact step that changes no momentum keeps the kinetic
energy too.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.free_rotation import turn_freely
from thesis_rbd.spatial.quaternion import conjugate, derivative, normalize, rotate

__all__ = ["INTEGRATORS", "angular_velocity", "body_forces", "integrate_bodies"]

INTEGRATORS = {"euler": 0, "symplectic_euler": 1, "midpoint": 2, "rk4": 3, "verlet": 4}
VERLET = INTEGRATORS["verlet"]

# Each method's stages (rows: the values of INTEGRATORS): how many, the node of the next stage
# (stage s + 1 is evaluated at y0 + c h k_s), and the weights b_s of the update
# y0 + h / divisor * sum_s b_s k_s. Symplectic Euler uses its one stage for the momenta only.
_STAGES = np.array([1, 1, 2, 4])
_NEXT_NODE = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.5, 1.0]])
_WEIGHT = np.array(
    [[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [1.0, 2.0, 2.0, 1.0]]
)
_WEIGHT_DIVISOR = np.array([1.0, 1.0, 1.0, 6.0])
_ZERO3 = (0.0, 0.0, 0.0)
_ZERO4 = (0.0, 0.0, 0.0, 0.0)


@njit
def angular_velocity(q, L, inv_inertia):
    """w = R I_body^-1 R^T L for unit q (4-tuple), L (3-tuple) and I_body^-1 (3, 3): any
    world vector through the world-frame inverse inertia."""
    Lb = rotate(conjugate(q), L)
    wb = (
        inv_inertia[0, 0] * Lb[0] + inv_inertia[0, 1] * Lb[1] + inv_inertia[0, 2] * Lb[2],
        inv_inertia[1, 0] * Lb[0] + inv_inertia[1, 1] * Lb[1] + inv_inertia[1, 2] * Lb[2],
        inv_inertia[2, 0] * Lb[0] + inv_inertia[2, 1] * Lb[1] + inv_inertia[2, 2] * Lb[2],
    )
    return rotate(q, wb)


@njit
def _derivative(i, q, P, L, inv_mass, inv_inertia, force, drag, pf_start, pf_arm, pf_force):
    """(dx, dq, dP, dL) of body i at orientation q and momenta P, L (tuples)."""
    qn = normalize(q)
    v = (P[0] * inv_mass, P[1] * inv_mass, P[2] * inv_mass)
    w = angular_velocity(qn, L, inv_inertia)
    speed = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    c = drag[0] + drag[1] * speed
    F = (force[i, 0] - c * v[0], force[i, 1] - c * v[1], force[i, 2] - c * v[2])
    tx, ty, tz = -drag[2] * w[0], -drag[2] * w[1], -drag[2] * w[2]
    for k in range(pf_start[i], pf_start[i + 1]):
        r = rotate(qn, pf_arm[k])
        f = pf_force[k]
        tx += r[1] * f[2] - r[2] * f[1]
        ty += r[2] * f[0] - r[0] * f[2]
        tz += r[0] * f[1] - r[1] * f[0]
    return v, derivative(q, w), F, (tx, ty, tz)


@njit
def body_forces(i, q, P, L, inv_mass, inv_inertia, force, drag, pf_start, pf_arm, pf_force):
    """(F, tau) 3-tuples acting on body i in the state given by the rows q (4,), P, L (3,).

    The same force model as the integrators (external force, drag, point-force torques), for
    the contact stage, which needs the velocities the forces alone would give.
    """
    _, _, F, T = _derivative(
        i, (q[0], q[1], q[2], q[3]), (P[0], P[1], P[2]), (L[0], L[1], L[2]), inv_mass,
        inv_inertia, force, drag, pf_start, pf_arm, pf_force,
    )  # fmt: skip
    return F, T


@njit
def _add3(a, h, b):
    return (a[0] + h * b[0], a[1] + h * b[1], a[2] + h * b[2])


@njit
def _add4(a, h, b):
    return (a[0] + h * b[0], a[1] + h * b[1], a[2] + h * b[2], a[3] + h * b[3])


@njit
def _scale3(b, a):
    return (b * a[0], b * a[1], b * a[2])


@njit
def _scale4(b, a):
    return (b * a[0], b * a[1], b * a[2], b * a[3])


@njit(allocates=False, separate=True)
def integrate_bodies(
    method,
    dt,
    count,
    frozen,
    solved,
    position,
    orientation,
    linear_momentum,
    angular_momentum,
    inverse_mass,
    inverse_inertia_body,
    external_force,
    drag,
    pf_start,
    pf_arm,
    pf_force,
    save_start,
    start_position,
    start_orientation,
):
    """Advance every non-frozen body by one step of length dt, in place.

    Parameters
    ----------
    method : int
        A value of ``INTEGRATORS``.
    dt : float
        Step length (s).
    count : int
        Number of live bodies n (arrays may be longer).
    frozen : (>= n,) bool
        Bodies that do not move this step (static or asleep).
    solved : (>= n,) bool
        Bodies whose end-of-step momenta the contact stage already set (forces and contact
        impulses included): they move with those velocities, x += dt v and q turned by
        w dt, which is the position half of symplectic Euler; the others follow ``method``.
    position, linear_momentum, angular_momentum : (>= n, 3) float64
        x, P, L in the world frame; updated in place.
    orientation : (>= n, 4) float64
        q (x, y, z, w); updated in place and renormalised.
    inverse_mass : (>= n,) float64
    inverse_inertia_body : (>= n, 3, 3) float64
    external_force : (n, 3) float64
        State-independent force of the step (world frame).
    drag : (3,) float64
        Linear, quadratic and angular drag coefficients.
    pf_start, pf_arm, pf_force
        Point forces in CSR layout (see ``forces.PointForces``).
    save_start : bool
        Also write where each moved body started the step into ``start_position`` and
        ``start_orientation`` ((>= n, 3), (>= n, 4) float64): the collision stages sweep fast
        bodies from there. Saved here because x and q pass through registers anyway, so it
        costs no second pass over the bodies.

    Returns
    -------
    bad_body : int
        The first body whose new state is not finite, or whose orientation is no longer a
        unit quaternion (its norm overflowed), or -1 (checked here, where the state is in
        registers, so a step that goes wrong costs nothing to detect).
    """
    h = dt
    bad = -1
    # short local names keep the stage lines readable
    Fx, pfs, pfa, pff = external_force, pf_start, pf_arm, pf_force
    for i in range(count):
        if frozen[i]:
            continue
        im = inverse_mass[i]
        Ii = inverse_inertia_body[i]
        x0 = (position[i, 0], position[i, 1], position[i, 2])
        q0 = (orientation[i, 0], orientation[i, 1], orientation[i, 2], orientation[i, 3])
        P0 = (linear_momentum[i, 0], linear_momentum[i, 1], linear_momentum[i, 2])
        L0 = (angular_momentum[i, 0], angular_momentum[i, 1], angular_momentum[i, 2])
        if save_start:
            for k in range(3):
                start_position[i, k] = x0[k]
            for k in range(4):
                start_orientation[i, k] = q0[k]

        if solved[i]:  # momenta are final: move with them
            v = (P0[0] * im, P0[1] * im, P0[2] * im)
            x, q, P, L = _add3(x0, h, v), turn_freely(q0, L0, Ii, h), P0, L0
        elif method == VERLET:
            _, _, F0, T0 = _derivative(i, q0, P0, L0, im, Ii, Fx, drag, pfs, pfa, pff)
            P, L = _add3(P0, 0.5 * h, F0), _add3(L0, 0.5 * h, T0)
            v = (P[0] * im, P[1] * im, P[2] * im)
            x, q = _add3(x0, h, v), turn_freely(normalize(q0), L, Ii, h)
            # the end forces at the momenta an Euler step predicts
            Pe, Le = _add3(P0, h, F0), _add3(L0, h, T0)
            _, _, F1, T1 = _derivative(i, q, Pe, Le, im, Ii, Fx, drag, pfs, pfa, pff)
            P, L = _add3(P, 0.5 * h, F1), _add3(L, 0.5 * h, T1)
        else:
            # The explicit methods as stages of one loop, so the derivative is written (and
            # compiled) once: stage s is evaluated at y0 + c_s h k_(s-1) and weighted by b_s.
            stages = _STAGES[method]
            qs, Ps, Ls = q0, P0, L0
            sv, sq, sF, sT = _ZERO3, _ZERO4, _ZERO3, _ZERO3
            for s in range(stages):
                v, dq, F, T = _derivative(i, qs, Ps, Ls, im, Ii, Fx, drag, pfs, pfa, pff)
                b = _WEIGHT[method, s]
                if s == 0:
                    sv, sq, sF, sT = _scale3(b, v), _scale4(b, dq), _scale3(b, F), _scale3(b, T)
                elif b != 0.0:
                    sv, sq = _add3(sv, b, v), _add4(sq, b, dq)
                    sF, sT = _add3(sF, b, F), _add3(sT, b, T)
                if s + 1 < stages:
                    c = _NEXT_NODE[method, s] * h
                    qs, Ps, Ls = _add4(q0, c, dq), _add3(P0, c, F), _add3(L0, c, T)
            hb = h / _WEIGHT_DIVISOR[method]
            P, L = _add3(P0, hb, sF), _add3(L0, hb, sT)
            if method == 1:  # symplectic Euler: the configuration moves with the new momenta
                v = (P[0] * im, P[1] * im, P[2] * im)
                w = angular_velocity(normalize(q0), L, Ii)
                x, q = _add3(x0, h, v), _add4(q0, h, derivative(q0, w))
            else:
                x, q = _add3(x0, hb, sv), _add4(q0, hb, sq)

        q = normalize(q)
        for k in range(3):
            position[i, k] = x[k]
            linear_momentum[i, k] = P[k]
            angular_momentum[i, k] = L[k]
        for k in range(4):
            orientation[i, k] = q[k]
        # a quaternion whose square norm overflowed normalises to zero, finite but no rotation
        unit = 0.5 < q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] < 2.0
        if bad < 0 and not (
            unit
            and math.isfinite(x[0] + x[1] + x[2])
            and math.isfinite(P[0] + P[1] + P[2] + L[0] + L[1] + L[2])
        ):
            bad = i
    return bad
