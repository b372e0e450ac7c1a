"""Projected Gauss-Seidel on flat contact rows: the iterative island solver.

Each contact k has three rows d = 0, 1, 2 along its frame (n, t1, t2). A row's Jacobian is
(e, r_a x e) on body a and (-e, -r_b x e) on body b; :func:`build_rows` stores, once per step,
what a sweep needs of it: the angular parts r x e and their images under the world inverse
inertia, I^-1 (r x e), so that a sweep reads the relative velocity and applies an impulse with
a handful of multiply-adds and no cross product or matrix product.

A sweep visits the contacts in order (sequential impulses):

* normal row: lambda_n <- max(0, lambda_n - (u_n + bias) / K_nn), the exact solve of that
  row with the others fixed;
* tangent rows, together: lambda_t <- P(lambda_t - h u_t), the projection onto the friction
  polygon of radius mu lambda_n with the scalar step h = 1 / lambda_max(K_tt). An isotropic
  step keeps the fixed point that of the contact problem (maximal dissipation); per-row steps
  would project in a skewed metric and converge to a different friction impulse.

A sweep is a chain of dependent arithmetic (each contact reads the velocities the one before
wrote), so its speed is the latency of that chain, not the number of operations. A contact's
three relative velocities are therefore read at once from the velocities before its update,
each as three short sums rather than one nine-term running sum; the tangent velocities then
add the normal update's share through the coupling K_tn (stored by :func:`build_rows`), and
the three impulses reach the bodies as one combined update. This is the same iteration as
updating row by row, in a different rounding.

Sweeps stop once a sweep changed no contact's velocity by more than its tolerance (each
row's update is the residual of its own condition, in velocity units: |delta lambda| K), so
"converged" means every condition holds to that velocity, not merely that PGS has slowed
down, as it does on a heavy body resting on a light one; or after ``iterations`` sweeps.
A warm-started resting island converges in one or two sweeps.

Arrays for c contacts and n bodies: ``basis`` (c, 3, 3) rows n, t1, t2; ``angular_a``,
``angular_b`` (c, 3, 3) rows r x e_d; ``response_a``, ``response_b`` (c, 3, 3) rows
I^-1 (r x e_d); ``coupling`` (c, 2) K_t1n, K_t2n; body velocities ``velocity``,
``angular_velocity`` (n, 3), world frame.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = [
    "apply_warm_start",
    "build_rows",
    "friction_polygon",
    "project_onto_polygon",
    "run_sweeps",
    "sweep_island",
]


@njit
def friction_polygon(sides):
    """(sides + 1, 2) vertices (cos, sin) of the regular polygon at angles 2 pi j / sides,
    the first repeated at the end, so edge j runs from row j to row j + 1."""
    table = np.empty((sides + 1, 2))
    for j in range(sides + 1):
        angle = 2.0 * math.pi * j / sides
        table[j, 0] = math.cos(angle)
        table[j, 1] = math.sin(angle)
    return table


@njit(allocates=False)
def _pseudo_angle(x, y):
    """A number in [0, 4) that increases with the angle of (x, y) over [0, 2 pi): its sector
    among the polygon's vertices without an arctangent (one division instead)."""
    if y >= 0.0:
        if x >= 0.0:
            return y / (x + y) if x + y > 0.0 else 0.0
        return 1.0 - x / (y - x)
    if x < 0.0:
        return 2.0 - y / (-x - y)
    return 3.0 + x / (x - y)


@njit(allocates=False)
def project_onto_polygon(x1, x2, radius, polygon):
    """Nearest point to (x1, x2) in the polygon ``polygon`` scaled to circumradius ``radius``."""
    if radius <= 0.0:
        return 0.0, 0.0
    # inside the inscribed circle (a sticking contact, the common case): no angle needed
    mid_x = 0.5 * (polygon[0, 0] + polygon[1, 0])
    mid_y = 0.5 * (polygon[0, 1] + polygon[1, 1])
    inner2 = radius * radius * (mid_x * mid_x + mid_y * mid_y)
    if x1 * x1 + x2 * x2 <= inner2:
        return x1, x2
    # sector j (vertex j at or before the point's angle, vertex j + 1 after it): a first
    # guess from the pseudo-angle, then exact comparisons with the vertices' pseudo-angles
    sides = polygon.shape[0] - 1
    angle = _pseudo_angle(x1, x2)
    j = min(int(angle * sides * 0.25), sides - 1)
    while j > 0 and angle < _pseudo_angle(polygon[j, 0], polygon[j, 1]):
        j -= 1
    while j < sides - 1 and angle >= _pseudo_angle(polygon[j + 1, 0], polygon[j + 1, 1]):
        j += 1
    p1, p2 = radius * polygon[j, 0], radius * polygon[j, 1]
    e1, e2 = radius * polygon[j + 1, 0] - p1, radius * polygon[j + 1, 1] - p2
    # inside when on the inner side of edge j (its outward normal is (e2, -e1))
    if (x1 - p1) * e2 - (x2 - p2) * e1 <= 0.0:
        return x1, x2
    s = ((x1 - p1) * e1 + (x2 - p2) * e2) / (e1 * e1 + e2 * e2)
    s = min(max(s, 0.0), 1.0)
    return p1 + s * e1, p2 + s * e2


@njit(separate=True)
def build_rows(body_a, body_b, arm_a, arm_b, basis, inverse_mass, inverse_inertia):
    """Angular Jacobian parts, their inertia images and the step sizes of every contact.

    Parameters
    ----------
    body_a, body_b : (c,) int64
    arm_a, arm_b : (c, 3) float64
        Contact point minus each body's centre of mass (world).
    basis : (c, 3, 3) float64
        Rows n, t1, t2.
    inverse_mass : (n,) float64
    inverse_inertia : (n, 3, 3) float64
        World-frame inverse inertia tensors.

    Returns
    -------
    angular_a, angular_b, response_a, response_b : (c, 3, 3) float64
        Rows r x e_d and I^-1 (r x e_d) for each body of each contact.
    normal_step : (c,) float64
        1 / K_nn (0 where the contact cannot move, e.g. two static bodies).
    tangent_step : (c,) float64
        1 / lambda_max(K_tt), the scalar friction step.
    coupling : (c, 2) float64
        K_t1n, K_t2n: the change of each tangent velocity per unit normal impulse.
    """
    c = body_a.shape[0]
    angular_a = np.empty((c, 3, 3))
    angular_b = np.empty((c, 3, 3))
    response_a = np.empty((c, 3, 3))
    response_b = np.empty((c, 3, 3))
    normal_step = np.zeros(c)
    tangent_step = np.zeros(c)
    coupling = np.empty((c, 2))
    K = np.empty((3, 3))
    for k in range(c):
        a, b = body_a[k], body_b[k]
        ra0, ra1, ra2 = arm_a[k, 0], arm_a[k, 1], arm_a[k, 2]
        rb0, rb1, rb2 = arm_b[k, 0], arm_b[k, 1], arm_b[k, 2]
        for d in range(3):
            e0, e1, e2 = basis[k, d, 0], basis[k, d, 1], basis[k, d, 2]
            ca0 = ra1 * e2 - ra2 * e1
            ca1 = ra2 * e0 - ra0 * e2
            ca2 = ra0 * e1 - ra1 * e0
            cb0 = rb1 * e2 - rb2 * e1
            cb1 = rb2 * e0 - rb0 * e2
            cb2 = rb0 * e1 - rb1 * e0
            angular_a[k, d, 0], angular_a[k, d, 1], angular_a[k, d, 2] = ca0, ca1, ca2
            angular_b[k, d, 0], angular_b[k, d, 1], angular_b[k, d, 2] = cb0, cb1, cb2
            for i in range(3):
                response_a[k, d, i] = (
                    inverse_inertia[a, i, 0] * ca0
                    + inverse_inertia[a, i, 1] * ca1
                    + inverse_inertia[a, i, 2] * ca2
                )
                response_b[k, d, i] = (
                    inverse_inertia[b, i, 0] * cb0
                    + inverse_inertia[b, i, 1] * cb1
                    + inverse_inertia[b, i, 2] * cb2
                )
        linear = inverse_mass[a] + inverse_mass[b]
        for d1 in range(3):
            for d2 in range(3):
                value = 0.0
                for i in range(3):
                    value += linear * basis[k, d1, i] * basis[k, d2, i]
                    value += angular_a[k, d1, i] * response_a[k, d2, i]
                    value += angular_b[k, d1, i] * response_b[k, d2, i]
                K[d1, d2] = value
        coupling[k, 0] = K[1, 0]
        coupling[k, 1] = K[2, 0]
        if K[0, 0] > 0.0:
            normal_step[k] = 1.0 / K[0, 0]
        half_trace = 0.5 * (K[1, 1] + K[2, 2])
        largest = half_trace + math.sqrt(max(0.25 * (K[1, 1] - K[2, 2]) ** 2 + K[1, 2] ** 2, 0.0))
        if largest > 0.0:
            tangent_step[k] = 1.0 / largest
    return angular_a, angular_b, response_a, response_b, normal_step, tangent_step, coupling


@njit(allocates=False)
def _row_velocity(k, d, basis, angular_a, angular_b, dv0, dv1, dv2, wa0, wa1, wa2, wb0, wb1, wb2):
    """u . e_d at contact k from the relative linear velocity dv = v_a - v_b and the angular
    velocities: three short sums (linear, a's turn, b's turn), not one running sum, so that
    the additions do not wait on each other."""
    linear = basis[k, d, 0] * dv0 + basis[k, d, 1] * dv1 + basis[k, d, 2] * dv2
    turn_a = angular_a[k, d, 0] * wa0 + angular_a[k, d, 1] * wa1 + angular_a[k, d, 2] * wa2
    turn_b = angular_b[k, d, 0] * wb0 + angular_b[k, d, 1] * wb1 + angular_b[k, d, 2] * wb2
    return linear + (turn_a - turn_b)


@njit(allocates=False)
def _apply_row(k, d, a, b, j, basis, response_a, response_b, inverse_mass, velocity, w):
    """Impulse j along e_d of contact k: +j on body a at its arm, -j on body b (the warm
    start, applied row by row before the sweeps)."""
    ma, mb = inverse_mass[a] * j, inverse_mass[b] * j
    for i in range(3):
        velocity[a, i] += ma * basis[k, d, i]
        velocity[b, i] -= mb * basis[k, d, i]
        w[a, i] += j * response_a[k, d, i]
        w[b, i] -= j * response_b[k, d, i]


@njit(allocates=False)
def _apply_three_rows(k, a, b, dn, d1, d2, basis, response_a, response_b, inverse_mass, v, w):
    """Impulses dn, d1, d2 along n, t1, t2 of contact k, in one update of both bodies."""
    ma, mb = inverse_mass[a], inverse_mass[b]
    for i in range(3):
        linear = dn * basis[k, 0, i] + d1 * basis[k, 1, i] + d2 * basis[k, 2, i]
        v[a, i] += ma * linear
        v[b, i] -= mb * linear
        w[a, i] += dn * response_a[k, 0, i] + d1 * response_a[k, 1, i] + d2 * response_a[k, 2, i]
        w[b, i] -= dn * response_b[k, 0, i] + d1 * response_b[k, 1, i] + d2 * response_b[k, 2, i]


@njit(allocates=False)
def apply_warm_start(
    start, stop, body_a, body_b, basis, response_a, response_b, inverse_mass, velocity,
    angular_velocity, impulse,
):  # fmt: skip
    """Apply the impulses ``impulse[start:stop]`` (the warm start) to the body velocities."""
    for k in range(start, stop):
        a, b = body_a[k], body_b[k]
        for d in range(3):
            if impulse[k, d] != 0.0:
                _apply_row(
                    k, d, a, b, impulse[k, d], basis, response_a, response_b, inverse_mass,
                    velocity, angular_velocity,
                )  # fmt: skip


@njit(allocates=False)
def sweep_island(
    start, stop, iterations, tolerance, polygon, body_a, body_b, basis, angular_a, angular_b,
    response_a, response_b, normal_step, tangent_step, coupling, inverse_mass, bias, friction,
    velocity, angular_velocity, impulse,
):  # fmt: skip
    """Projected Gauss-Seidel on contacts ``start:stop``, warm started from ``impulse``.

    The warm-start impulses are applied first (:func:`apply_warm_start`), then
    :func:`run_sweeps`. Body velocities and ``impulse`` (c, 3) (lambda_n, lambda_t1,
    lambda_t2) are updated in place.

    Returns
    -------
    sweeps : int
        Sweeps run.
    converged : bool
        Whether the last sweep changed no contact velocity by more than its tolerance.
    """
    apply_warm_start(
        start, stop, body_a, body_b, basis, response_a, response_b, inverse_mass, velocity,
        angular_velocity, impulse,
    )  # fmt: skip
    return run_sweeps(
        start, stop, iterations, tolerance, polygon, body_a, body_b, basis, angular_a,
        angular_b, response_a, response_b, normal_step, tangent_step, coupling, inverse_mass,
        bias, friction, velocity, angular_velocity, impulse,
    )  # fmt: skip


@njit(allocates=False, separate=True)
def run_sweeps(
    start, stop, iterations, tolerance, polygon, body_a, body_b, basis, angular_a, angular_b,
    response_a, response_b, normal_step, tangent_step, coupling, inverse_mass, bias, friction,
    velocity, angular_velocity, impulse,
):  # fmt: skip
    """Up to ``iterations`` projected Gauss-Seidel sweeps over contacts ``start:stop``, from
    the impulses ``impulse`` already applied to the velocities; stops once converged.

    The normal condition is u_n + bias >= 0 (a positive bias allows that much approach, a
    negative one demands separation). The rows are ``build_rows``'s. ``tolerance`` (c,) is
    each contact's velocity tolerance (m/s). Returns (sweeps run, converged) as
    :func:`sweep_island`.
    """
    w = angular_velocity
    for sweep in range(iterations):
        converged = True
        for k in range(start, stop):
            if normal_step[k] == 0.0:
                continue
            a, b = body_a[k], body_b[k]
            # element reads, not row views: a view of a row costs a reference count in and
            # out, which in this innermost loop is more than the arithmetic
            dv0 = velocity[a, 0] - velocity[b, 0]
            dv1 = velocity[a, 1] - velocity[b, 1]
            dv2 = velocity[a, 2] - velocity[b, 2]
            wa0, wa1, wa2 = w[a, 0], w[a, 1], w[a, 2]
            wb0, wb1, wb2 = w[b, 0], w[b, 1], w[b, 2]
            u_n = _row_velocity(
                k, 0, basis, angular_a, angular_b, dv0, dv1, dv2, wa0, wa1, wa2, wb0, wb1, wb2
            )
            old_n = impulse[k, 0]
            new_n = max(old_n - (u_n + bias[k]) * normal_step[k], 0.0)
            dn = new_n - old_n
            impulse[k, 0] = new_n
            converged &= abs(dn) <= tolerance[k] * normal_step[k]
            d1 = 0.0
            d2 = 0.0
            if friction[k] > 0.0:
                h = tangent_step[k]
                # the tangent velocities after the normal update: before it, plus its share
                u1 = _row_velocity(
                    k, 1, basis, angular_a, angular_b, dv0, dv1, dv2, wa0, wa1, wa2, wb0, wb1, wb2
                ) + dn * coupling[k, 0]  # fmt: skip
                u2 = _row_velocity(
                    k, 2, basis, angular_a, angular_b, dv0, dv1, dv2, wa0, wa1, wa2, wb0, wb1, wb2
                ) + dn * coupling[k, 1]  # fmt: skip
                old_1, old_2 = impulse[k, 1], impulse[k, 2]
                t1, t2 = project_onto_polygon(
                    old_1 - h * u1, old_2 - h * u2, friction[k] * new_n, polygon
                )
                d1, d2 = t1 - old_1, t2 - old_2
                impulse[k, 1], impulse[k, 2] = t1, t2
                converged &= max(abs(d1), abs(d2)) <= tolerance[k] * h
            if dn != 0.0 or d1 != 0.0 or d2 != 0.0:
                _apply_three_rows(
                    k, a, b, dn, d1, d2, basis, response_a, response_b, inverse_mass, velocity, w
                )
        if converged:
            return sweep + 1, True
    return iterations, False
