"""Conjugate-gradient steps on a big island's active rows, between its Gauss-Seidel sweeps.

Projected Gauss-Seidel fixes each contact with its neighbours held still, so it removes an
error that is local quickly and one spread over a whole heap slowly: when a body settles
deeper into a pile, its weight has to move onto other contacts across the pile (a statically
indeterminate redistribution), and each sweep carries that load only one contact further.
Such an error lives on the rows that are active, the normal rows pushing (lambda_n > 0)
and the tangent rows of sticking contacts, where the contact problem is the linear system
A lambda = b of those rows alone (A = J M^-1 J^T); conjugate gradients solve that in far
fewer steps than sweeps take, because each of their steps acts on the whole island at once
(Silcowitz, Niebe and Erleben's subspace minimisation, 2010). The sweeps then sort out the
rows whose state the step changed (a normal impulse that would turn negative, a friction
impulse that leaves its cone): the step's answer is projected onto the feasible set before
it is applied.

Arrays: the contact rows of :func:`.pgs.build_rows` (c contacts), ``velocity`` and
``angular_velocity`` (n, 3), ``impulse`` (c, 3); :func:`subspace_step`'s scratch ``scale``,
``step``, ``residual``, ``direction``, ``product`` (c, 3) and ``delta_v``, ``delta_w`` (n, 3),
contents ignored.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.pgs import (
    _apply_three_rows,
    _row_velocity,
    apply_warm_start,
    project_onto_polygon,
    run_sweeps,
)

__all__ = ["SUBSPACE_CONTACTS", "subspace_step", "sweep_with_subspace_steps"]

# Islands of at least this many contacts get conjugate-gradient steps on their active rows
# after every ``SUBSPACE_EVERY`` sweeps, ``SUBSPACE_ITERATIONS`` steps each. On the
# resting-contact stages of three pours of 256 cubes (the same inputs solved each way) any of
# 12-24 sweeps and 6-10 steps took about a fifth less time than sweeps alone; more steps at a
# time cost more, as the projection of a long step undoes much of it.
SUBSPACE_CONTACTS = 64
SUBSPACE_EVERY = 16
SUBSPACE_ITERATIONS = 8
# The rows of one island are often dependent: two sticking contacts between the same bodies
# leave equal and opposite tangent impulses along the line through them without effect, and
# four corners on a face leave a self-balanced set of normal impulses. On such a null
# direction the bias (the normals' push-out) has no exact answer, and once CG has solved the
# rest, its next direction lies there, with a curvature of round-off and a step without
# bound. The steps stop when a direction's curvature, relative to its length in the
# preconditioner's metric (the Rayleigh quotient of the preconditioned rows, whose largest
# eigenvalues are of order one), falls below this: far below the spectrum of a stiff heap,
# far above round-off.
SUBSPACE_FLAT_CURVATURE = 1e-6


@njit(allocates=False)
def _island_velocity(k, d, basis, angular_a, angular_b, a, b, v, w):
    """u . e_d at contact k from velocities ``v``, ``w`` (n, 3) of bodies a and b."""
    return _row_velocity(
        k, d, basis, angular_a, angular_b, v[a, 0] - v[b, 0], v[a, 1] - v[b, 1],
        v[a, 2] - v[b, 2], w[a, 0], w[a, 1], w[a, 2], w[b, 0], w[b, 1], w[b, 2],
    )  # fmt: skip


@njit(allocates=False, separate=True)
def subspace_step(
    start, stop, cg_iterations, polygon, body_a, body_b, basis, angular_a, angular_b,
    response_a, response_b, normal_step, tangent_step, inverse_mass, bias, friction, velocity,
    angular_velocity, impulse, scale, step, residual, direction, product, delta_v, delta_w,
):  # fmt: skip
    """``cg_iterations`` preconditioned conjugate-gradient steps on the active rows of
    contacts ``start:stop``, applied to ``impulse`` and the velocities after projection.

    The active rows are the normal rows with lambda_n > 0 and a finite bias, and the tangent
    rows of such contacts whose friction impulse lies inside the polygon's inscribed circle;
    their residual is -(u_n + bias) and -u_t. The preconditioner is the rows' own step sizes
    (1 / K_nn, the friction step), Gauss-Seidel's diagonal. ``scale`` holds it (0 on the
    rows left out). The steps stop early on a direction of curvature near zero
    (``SUBSPACE_FLAT_CURVATURE``).
    """
    w = angular_velocity
    inscribed = 0.5 * math.hypot(polygon[0, 0] + polygon[1, 0], polygon[0, 1] + polygon[1, 1])
    fit = 0.0
    for k in range(start, stop):
        for d in range(3):
            scale[k, d] = 0.0
            step[k, d] = 0.0
            residual[k, d] = 0.0
            direction[k, d] = 0.0
        if normal_step[k] == 0.0 or impulse[k, 0] <= 0.0 or not math.isfinite(bias[k]):
            continue
        a, b = body_a[k], body_b[k]
        scale[k, 0] = normal_step[k]
        residual[k, 0] = -(_island_velocity(k, 0, basis, angular_a, angular_b, a, b, velocity, w)
                           + bias[k])  # fmt: skip
        bound = inscribed * friction[k] * impulse[k, 0]
        if friction[k] > 0.0 and math.hypot(impulse[k, 1], impulse[k, 2]) < bound:
            for d in (1, 2):
                scale[k, d] = tangent_step[k]
                residual[k, d] = -_island_velocity(
                    k, d, basis, angular_a, angular_b, a, b, velocity, w
                )
        for d in range(3):
            direction[k, d] = scale[k, d] * residual[k, d]
            fit += residual[k, d] * direction[k, d]
    for _ in range(cg_iterations):
        if fit == 0.0:
            break
        # product = A direction over the active rows: the direction's impulses applied to
        # zeroed velocity changes, then read back along each row
        for k in range(start, stop):
            a, b = body_a[k], body_b[k]
            for i in range(3):
                delta_v[a, i] = 0.0
                delta_v[b, i] = 0.0
                delta_w[a, i] = 0.0
                delta_w[b, i] = 0.0
        for k in range(start, stop):
            if scale[k, 0] != 0.0:
                _apply_three_rows(
                    k, body_a[k], body_b[k], direction[k, 0], direction[k, 1], direction[k, 2],
                    basis, response_a, response_b, inverse_mass, delta_v, delta_w,
                )  # fmt: skip
        curvature = 0.0
        length = 0.0
        for k in range(start, stop):
            a, b = body_a[k], body_b[k]
            for d in range(3):
                if scale[k, d] != 0.0:
                    product[k, d] = _island_velocity(
                        k, d, basis, angular_a, angular_b, a, b, delta_v, delta_w
                    )
                    curvature += direction[k, d] * product[k, d]
                    length += direction[k, d] * direction[k, d] / scale[k, d]
                else:
                    product[k, d] = 0.0
        if not curvature > SUBSPACE_FLAT_CURVATURE * length:
            break
        alpha = fit / curvature
        updated = 0.0
        for k in range(start, stop):
            for d in range(3):
                step[k, d] += alpha * direction[k, d]
                residual[k, d] -= alpha * product[k, d]
                updated += scale[k, d] * residual[k, d] * residual[k, d]
        beta = updated / fit
        fit = updated
        for k in range(start, stop):
            for d in range(3):
                direction[k, d] = scale[k, d] * residual[k, d] + beta * direction[k, d]
    # the step, projected onto the feasible impulses, applied
    for k in range(start, stop):
        if scale[k, 0] == 0.0:
            continue
        old_n, old_1, old_2 = impulse[k, 0], impulse[k, 1], impulse[k, 2]
        new_n = max(old_n + step[k, 0], 0.0)
        new_1, new_2 = old_1 + step[k, 1], old_2 + step[k, 2]
        if friction[k] > 0.0:
            new_1, new_2 = project_onto_polygon(new_1, new_2, friction[k] * new_n, polygon)
        impulse[k, 0], impulse[k, 1], impulse[k, 2] = new_n, new_1, new_2
        _apply_three_rows(
            k, body_a[k], body_b[k], new_n - old_n, new_1 - old_1, new_2 - old_2, basis,
            response_a, response_b, inverse_mass, velocity, w,
        )  # fmt: skip


@njit
def sweep_with_subspace_steps(
    s, e, iterations, tolerance, polygon, body_a, body_b, basis, rows, inverse_mass, bias,
    friction, v, w, impulse,
):  # fmt: skip
    """``pgs.sweep_island`` on contacts ``s:e`` (``rows`` from ``pgs.build_rows``) with
    conjugate-gradient steps on the active rows after every ``SUBSPACE_EVERY`` sweeps:
    (sweeps, converged)."""
    angular_a, angular_b, response_a, response_b, normal_step, tangent_step, coupling = rows
    c, n = body_a.shape[0], v.shape[0]
    scale, step, residual = np.empty((c, 3)), np.empty((c, 3)), np.empty((c, 3))
    direction, product = np.empty((c, 3)), np.empty((c, 3))
    delta_v, delta_w = np.empty((n, 3)), np.empty((n, 3))
    apply_warm_start(
        s, e, body_a, body_b, basis, response_a, response_b, inverse_mass, v, w, impulse
    )
    sweeps = 0
    while True:
        done, converged = run_sweeps(
            s, e, min(SUBSPACE_EVERY, iterations - sweeps), tolerance, polygon, body_a,
            body_b, basis, angular_a, angular_b, response_a, response_b, normal_step,
            tangent_step, coupling, inverse_mass, bias, friction, v, w, impulse,
        )  # fmt: skip
        sweeps += done
        if converged or sweeps >= iterations:
            return sweeps, converged
        subspace_step(
            s, e, SUBSPACE_ITERATIONS, polygon, body_a, body_b, basis, angular_a, angular_b,
            response_a, response_b, normal_step, tangent_step, inverse_mass, bias, friction, v, w,
            impulse, scale, step, residual, direction, product, delta_v, delta_w,
        )  # fmt: skip
