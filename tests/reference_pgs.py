"""Slow reference for ``pgs.sweep_island``: projected Gauss-Seidel row by row, written from
the contact Jacobians with NumPy, for the fast kernel to agree with; and plain projected
Gauss-Seidel on a dense LCP, an iterative solver for Lemke's answers to agree with."""

import numpy as np


def nearest_in_polygon(point, radius, sides):
    """Nearest point to ``point`` (2,) in the regular polygon of circumradius ``radius`` with a
    vertex at angle 0: the point itself when inside, else the nearest of every edge's
    clamped projections."""
    if radius <= 0.0:
        return np.zeros(2)
    angles = 2 * np.pi * np.arange(sides + 1) / sides
    vertices = radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    edges = vertices[1:] - vertices[:-1]
    outside = edges[:, 0] * (point[1] - vertices[:-1, 1]) - edges[:, 1] * (
        point[0] - vertices[:-1, 0]
    )
    if np.all(outside >= 0):
        return np.array(point, float)
    s = np.clip(np.einsum("ij,ij->i", point - vertices[:-1], edges) / (edges**2).sum(1), 0, 1)
    candidates = vertices[:-1] + s[:, None] * edges
    return candidates[np.argmin(np.linalg.norm(candidates - point, axis=1))]


class ContactRows:
    """The rows of an island's contacts from their Jacobians: row velocities, impulses
    applied to the bodies (in place), and each contact's 3 x 3 block of J M^-1 J^T."""

    def __init__(self, contacts, bodies):
        self.body_a, self.body_b, self.arm_a, self.arm_b, self.basis = contacts
        self.velocity, self.angular_velocity, self.inverse_mass, self.inverse_inertia = bodies

    def jacobian(self, k, d):
        e = self.basis[k, d]
        return e, np.cross(self.arm_a[k], e), np.cross(self.arm_b[k], e)

    def row_velocity(self, k, d):
        e, ang_a, ang_b = self.jacobian(k, d)
        a, b = self.body_a[k], self.body_b[k]
        return (
            e @ (self.velocity[a] - self.velocity[b])
            + ang_a @ self.angular_velocity[a]
            - ang_b @ self.angular_velocity[b]
        )

    def apply(self, k, d, j):
        e, ang_a, ang_b = self.jacobian(k, d)
        a, b = self.body_a[k], self.body_b[k]
        self.velocity[a] += self.inverse_mass[a] * j * e
        self.velocity[b] -= self.inverse_mass[b] * j * e
        self.angular_velocity[a] += j * self.inverse_inertia[a] @ ang_a
        self.angular_velocity[b] -= j * self.inverse_inertia[b] @ ang_b

    def apply_all(self, impulse):
        """Every contact's impulses (c, 3) along its rows: a warm start."""
        for k in range(len(impulse)):
            for d in range(3):
                self.apply(k, d, impulse[k, d])

    def delassus(self, k):
        K = np.empty((3, 3))
        a, b = self.body_a[k], self.body_b[k]
        ii = self.inverse_inertia
        for d in range(3):
            e, ang_a, ang_b = self.jacobian(k, d)
            for f in range(3):
                g, gang_a, gang_b = self.jacobian(k, f)
                K[d, f] = (self.inverse_mass[a] + self.inverse_mass[b]) * e @ g
                K[d, f] += ang_a @ ii[a] @ gang_a + ang_b @ ii[b] @ gang_b
        return K


def reference_pgs(sweeps, sides, contacts, bias, friction, bodies, impulse):
    """``sweeps`` sweeps of PGS in place: the warm start ``impulse`` (c, 3) is applied, then
    each contact's normal row is solved exactly and its tangent rows take the isotropic step
    h = 1 / lambda_max(K_tt) followed by the projection onto the friction polygon."""
    rows = ContactRows(contacts, bodies)
    rows.apply_all(impulse)
    for _ in range(sweeps):
        for k in range(len(bias)):
            K = rows.delassus(k)
            if K[0, 0] <= 0.0:
                continue
            new_n = max(impulse[k, 0] - (rows.row_velocity(k, 0) + bias[k]) / K[0, 0], 0.0)
            rows.apply(k, 0, new_n - impulse[k, 0])
            impulse[k, 0] = new_n
            if friction[k] <= 0.0:
                continue
            h = 1.0 / np.linalg.eigvalsh(K[1:, 1:]).max()
            u_t = np.array([rows.row_velocity(k, 1), rows.row_velocity(k, 2)])
            t = nearest_in_polygon(impulse[k, 1:] - h * u_t, friction[k] * new_n, sides)
            for d in (1, 2):
                rows.apply(k, d, t[d - 1] - impulse[k, d])
            impulse[k, 1:] = t


def dense_projected_gauss_seidel(M, q, z, iterations):
    """Projected Gauss-Seidel sweeps on LCP(M, q), in place from the warm start ``z`` (n,):
    row i solves ``(M z + q)_i = 0`` for ``z_i`` and clamps it at zero (rows with a zero
    diagonal are skipped). Converges for a symmetric positive (semi-)definite ``M``.
    Returns the largest change of any z_i in the last sweep."""
    change = 0.0
    for _ in range(iterations):
        change = 0.0
        for i in range(len(q)):
            if M[i, i] <= 0.0:
                continue
            value = max(z[i] - (q[i] + M[i] @ z) / M[i, i], 0.0)
            change = max(change, abs(value - z[i]))
            z[i] = value
    return change
