"""Slow reference for ``subspace.subspace_step``: conjugate gradients on a dense matrix of
the active rows, built column by column from unit impulses with NumPy."""

import numpy as np

from tests.reference_pgs import ContactRows, nearest_in_polygon
from thesis_rbd.dynamics.subspace import SUBSPACE_FLAT_CURVATURE


def reference_subspace_step(
    iterations, sides, contacts, bias, friction, bodies, impulse, symmetrise=False
):
    """The step in place on ``impulse`` (c, 3), whose impulses the velocities in ``bodies``
    already hold: Jacobi-preconditioned CG on A x = r over the active rows (normal rows
    pushing with a finite bias; tangent rows of those inside the polygon's inscribed circle),
    r = -(u + bias along the normals), stopped on a direction whose curvature over its
    length in the preconditioner's metric is below ``SUBSPACE_FLAT_CURVATURE``; then the
    answer projected and applied. ``symmetrise`` replaces the matrix by (A + A^T) / 2, equal
    to it but for round-off, to show how much round-off the iteration amplifies."""
    rows = ContactRows(contacts, bodies)
    c = len(bias)
    inscribed = np.cos(np.pi / sides)
    active = np.zeros(3 * c, bool)
    for k in range(c):
        pushing = impulse[k, 0] > 0 and np.isfinite(bias[k]) and rows.delassus(k)[0, 0] > 0
        active[3 * k] = pushing
        sticking = np.hypot(*impulse[k, 1:]) < inscribed * friction[k] * impulse[k, 0]
        active[3 * k + 1 : 3 * k + 3] = pushing and friction[k] > 0 and sticking
    u = np.array([rows.row_velocity(k, d) for k in range(c) for d in range(3)])
    # A column by column: the row velocities a unit impulse along a row changes
    A = np.empty((3 * c, 3 * c))
    for j in range(3 * c):
        rows.apply(j // 3, j % 3, 1.0)
        A[:, j] = [rows.row_velocity(k, d) for k in range(c) for d in range(3)] - u
        rows.apply(j // 3, j % 3, -1.0)
    if symmetrise:
        A = 0.5 * (A + A.T)
    preconditioner = np.zeros(3 * c)
    for k in range(c):
        K = rows.delassus(k)
        preconditioner[3 * k] = 1.0 / K[0, 0] if active[3 * k] else 0.0
        if active[3 * k + 1]:
            preconditioner[3 * k + 1 : 3 * k + 3] = 1.0 / np.linalg.eigvalsh(K[1:, 1:]).max()
    target = u.copy()
    target[0::3] += np.where(np.isfinite(bias), bias, 0.0)  # the bias acts on the normal rows
    residual = np.where(active, -target, 0.0)
    x = np.zeros(3 * c)
    z = preconditioner * residual
    direction = z.copy()
    fit = residual @ z
    for _ in range(iterations):
        if fit == 0.0:
            break
        product = np.where(active, A @ direction, 0.0)
        curvature = direction @ product
        length = direction[active] ** 2 @ (1.0 / preconditioner[active])
        if not curvature > SUBSPACE_FLAT_CURVATURE * length:
            break
        alpha = fit / curvature
        x += alpha * direction
        residual -= alpha * product
        z = preconditioner * residual
        updated = residual @ z
        direction = z + (updated / fit) * direction
        fit = updated
    for k in range(c):
        if not active[3 * k]:
            continue
        new = impulse[k] + x[3 * k : 3 * k + 3]
        new[0] = max(new[0], 0.0)
        if friction[k] > 0:
            new[1:] = nearest_in_polygon(new[1:], friction[k] * new[0], sides)
        for d in range(3):
            rows.apply(k, d, new[d] - impulse[k, d])
        impulse[k] = new
