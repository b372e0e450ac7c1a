"""Velocity-level contact response: restitution, non-penetration and Coulomb friction.

Every contact k joins body a (``body_a[k]``) and body b (``body_b[k]``) at a world point p_k
with unit normal n_k pointing from b towards a (the impulse +j n acts on a, -j n on b). The
relative velocity at the contact, u = (v_a + w_a x r_a) - (v_b + w_b x r_b), is read along
three directions (n, t1, t2), so each contact has three impulse components
lambda = (lambda_n, lambda_t1, lambda_t2). After the solve, with u- the velocity before:

* non-penetration with Newton's restitution (thesis 7.1), for all contacts at once:
  0 <= lambda_n  _|_  u_n+ + e u_n- >= 0   (e is dropped below ``bounce_threshold``, so
  slow contacts come to rest instead of chattering);
* Coulomb friction with a polyhedral cone (Stewart and Trinkle 1996; Anitescu and Potra 1997):
  the tangential impulse lies in the regular polygon with ``sides`` vertices at radius
  mu lambda_n, and among those it is the one that removes the most kinetic energy (maximal
  dissipation). With 8 sides the polygon is within 8 % of the round cone; 4 sides is the
  "friction pyramid" of most engines.

The two solvers answer exactly this problem:

* ``solve_exact``: the Stewart-Trinkle LCP in (lambda_n, beta, s) solved by Lemke's method;
  the answer to round-off, cubic in the number of contacts of an island;
* ``solve_pgs``: projected Gauss-Seidel in body-velocity form (sequential impulses): linear
  per sweep, converging to the same answer; the tangential step is a projection onto the
  polygon with a scalar step 1 / lambda_max(K_tt), which leaves the fixed point unchanged.

Arrays, for c contacts and n bodies, travel as two tuples:

    contacts = (body_a, body_b, arm_a, arm_b, basis)
        body_a, body_b (c,) int64; arm_a, arm_b (c, 3) contact point minus each body's
        centre of mass (world); basis (c, 3, 3) rows n, t1, t2;
    bodies = (velocity, angular_velocity, inverse_mass, inverse_inertia)
        velocity, angular_velocity (n, 3) world; inverse_mass (n,); inverse_inertia (n, 3, 3)
        world frame. Static bodies have zero inverses and are never moved.

and per contact bias (c,) and friction (c,). The normal condition is u_n+ + bias >= 0: a
negative bias demands separation (restitution e u_n-, or a penetration to push out), a positive
one allows that much approach (a resting contact sinking to its slop).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd.dynamics.lcp import lemke

__all__ = [
    "apply_restitution",
    "contact_basis",
    "delassus_matrix",
    "project_onto_polygon",
    "relative_velocity",
    "solve_exact",
    "solve_pgs",
]


@njit
def contact_basis(normals):
    """(c, 3, 3) orthonormal frames with rows (n, t1, t2), t1 x t2 = n.

    t1 is built against the world axis least aligned with n, so it is continuous in n away
    from the switch-over and never degenerate.
    """
    c = normals.shape[0]
    basis = np.empty((c, 3, 3))
    for k in range(c):
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        ax, ay, az = abs(nx), abs(ny), abs(nz)
        if ax <= ay and ax <= az:  # n x e_x
            tx, ty, tz = 0.0, nz, -ny
        elif ay <= az:  # n x e_y
            tx, ty, tz = -nz, 0.0, nx
        else:  # n x e_z
            tx, ty, tz = ny, -nx, 0.0
        inv = 1.0 / math.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx * inv, ty * inv, tz * inv
        basis[k, 0, 0], basis[k, 0, 1], basis[k, 0, 2] = nx, ny, nz
        basis[k, 1, 0], basis[k, 1, 1], basis[k, 1, 2] = tx, ty, tz
        basis[k, 2, 0] = ny * tz - nz * ty
        basis[k, 2, 1] = nz * tx - nx * tz
        basis[k, 2, 2] = nx * ty - ny * tx
    return basis


@njit(inline="always")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(inline="always")
def _matvec(m, v):
    return (
        m[0, 0] * v[0] + m[0, 1] * v[1] + m[0, 2] * v[2],
        m[1, 0] * v[0] + m[1, 1] * v[1] + m[1, 2] * v[2],
        m[2, 0] * v[0] + m[2, 1] * v[1] + m[2, 2] * v[2],
    )


@njit(inline="always")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(inline="always")
def relative_velocity(k, d, contacts, bodies):
    """u . e_d at contact k for direction d (0 normal, 1 and 2 tangents)."""
    body_a, body_b, arm_a, arm_b, basis = contacts
    velocity, angular_velocity = bodies[0], bodies[1]
    e = basis[k, d]
    a, b = body_a[k], body_b[k]
    wa = _cross(angular_velocity[a], arm_a[k])
    wb = _cross(angular_velocity[b], arm_b[k])
    return (
        e[0] * (velocity[a, 0] + wa[0] - velocity[b, 0] - wb[0])
        + e[1] * (velocity[a, 1] + wa[1] - velocity[b, 1] - wb[1])
        + e[2] * (velocity[a, 2] + wa[2] - velocity[b, 2] - wb[2])
    )


@njit(inline="always")
def _apply_impulse(k, d, j, contacts, bodies):
    """Impulse j along direction d of contact k: +j e_d on a at its arm, -j e_d on b."""
    body_a, body_b, arm_a, arm_b, basis = contacts
    velocity, angular_velocity, inverse_mass, inverse_inertia = bodies
    e = basis[k, d]
    a, b = body_a[k], body_b[k]
    ta = _matvec(inverse_inertia[a], _cross(arm_a[k], e))
    tb = _matvec(inverse_inertia[b], _cross(arm_b[k], e))
    for i in range(3):
        velocity[a, i] += inverse_mass[a] * j * e[i]
        velocity[b, i] -= inverse_mass[b] * j * e[i]
        angular_velocity[a, i] += j * ta[i]
        angular_velocity[b, i] -= j * tb[i]


@njit(inline="always")
def _effective_mass(k, d1, d2, contacts, bodies):
    """K[d1, d2] = J_d1 M^-1 J_d2^T for contact k (directions of the same contact)."""
    body_a, body_b, arm_a, arm_b, basis = contacts
    inverse_mass, inverse_inertia = bodies[2], bodies[3]
    a, b = body_a[k], body_b[k]
    e1, e2 = basis[k, d1], basis[k, d2]
    value = (inverse_mass[a] + inverse_mass[b]) * _dot(e1, e2)
    ca1, ca2 = _cross(arm_a[k], e1), _cross(arm_a[k], e2)
    cb1, cb2 = _cross(arm_b[k], e1), _cross(arm_b[k], e2)
    value += _dot(ca1, _matvec(inverse_inertia[a], ca2))
    value += _dot(cb1, _matvec(inverse_inertia[b], cb2))
    return value


@njit
def project_onto_polygon(x1, x2, radius, sides):
    """Nearest point to (x1, x2) in the regular polygon with vertices at angles 2 pi j / sides
    and circumradius ``radius`` (the polyhedral friction cone's slice)."""
    if radius <= 0.0:
        return 0.0, 0.0
    sector = 2.0 * math.pi / sides
    angle = math.atan2(x2, x1)
    if angle < 0.0:
        angle += 2.0 * math.pi
    j = min(int(angle / sector), sides - 1)
    mid = (j + 0.5) * sector
    inradius = radius * math.cos(0.5 * sector)
    if x1 * math.cos(mid) + x2 * math.sin(mid) <= inradius:
        return x1, x2
    p1, p2 = radius * math.cos(j * sector), radius * math.sin(j * sector)
    q1, q2 = radius * math.cos((j + 1) * sector), radius * math.sin((j + 1) * sector)
    e1, e2 = q1 - p1, q2 - p2
    s = ((x1 - p1) * e1 + (x2 - p2) * e2) / (e1 * e1 + e2 * e2)
    s = min(max(s, 0.0), 1.0)
    return p1 + s * e1, p2 + s * e2


@njit
def solve_pgs(iterations, sides, contacts, bias, friction, bodies, impulse, tolerance=1e-6):
    """Projected Gauss-Seidel (sequential impulses) on the contact problem, in place.

    Parameters
    ----------
    iterations : int
        Largest number of sweeps over the contacts.
    sides : int
        Sides of the friction polygon.
    contacts : tuple
        (body_a, body_b, arm_a, arm_b, basis), see the module docstring.
    bias : (c,) float64
        Normal bias of each contact: the solve makes u_n+ + bias >= 0.
    friction : (c,) float64
        Friction coefficient of each contact.
    bodies : tuple
        (velocity, angular_velocity, inverse_mass, inverse_inertia); the velocities are
        updated with every impulse applied.
    impulse : (c, 3) float64
        (lambda_n, lambda_t1, lambda_t2): the warm start, applied first, then the result.
    tolerance : float
        Sweeps stop early once no impulse changed by more than this fraction of the largest
        normal impulse (a resting pile converges in a few sweeps from its warm start).

    Returns
    -------
    change : float
        Largest impulse change of the last sweep.
    """
    c = contacts[0].shape[0]
    k_normal = np.empty(c)
    step_tangent = np.empty(c)
    for k in range(c):
        k_normal[k] = _effective_mass(k, 0, 0, contacts, bodies)
        k11 = _effective_mass(k, 1, 1, contacts, bodies)
        k22 = _effective_mass(k, 2, 2, contacts, bodies)
        k12 = _effective_mass(k, 1, 2, contacts, bodies)
        # largest eigenvalue of the symmetric 2x2 block: the safe scalar step is its inverse
        half_trace = 0.5 * (k11 + k22)
        largest = half_trace + math.sqrt(max(0.25 * (k11 - k22) ** 2 + k12 * k12, 0.0))
        step_tangent[k] = 1.0 / largest if largest > 0.0 else 0.0
        for d in range(3):
            if impulse[k, d] != 0.0:
                _apply_impulse(k, d, impulse[k, d], contacts, bodies)

    change = 0.0
    for _ in range(iterations):
        change = 0.0
        largest = 0.0
        for k in range(c):
            if k_normal[k] <= 0.0:
                continue
            u_n = relative_velocity(k, 0, contacts, bodies)
            new_n = max(impulse[k, 0] - (u_n + bias[k]) / k_normal[k], 0.0)
            delta = new_n - impulse[k, 0]
            if delta != 0.0:
                _apply_impulse(k, 0, delta, contacts, bodies)
                impulse[k, 0] = new_n
                change = max(change, abs(delta))
            if friction[k] <= 0.0:
                continue
            h = step_tangent[k]
            t1, t2 = project_onto_polygon(
                impulse[k, 1] - h * relative_velocity(k, 1, contacts, bodies),
                impulse[k, 2] - h * relative_velocity(k, 2, contacts, bodies),
                friction[k] * new_n,
                sides,
            )
            d1, d2 = t1 - impulse[k, 1], t2 - impulse[k, 2]
            if d1 != 0.0:
                _apply_impulse(k, 1, d1, contacts, bodies)
            if d2 != 0.0:
                _apply_impulse(k, 2, d2, contacts, bodies)
            impulse[k, 1], impulse[k, 2] = t1, t2
            change = max(change, abs(d1), abs(d2))
        for k in range(c):
            largest = max(largest, impulse[k, 0])
        if change <= tolerance * largest:
            break  # converged: a further sweep would move no impulse by more than that
    return change


@njit
def apply_restitution(contacts, bodies, impulse, restitution):
    """Poisson's restitution phase: add e_k times each contact's compression impulse.

    After the compression solve (bias 0: approach stopped), contact k receives a further
    normal impulse e_k lambda_n,k. For one contact this equals Newton's law u+ = -e u-;
    for simultaneous contacts on a spinning body it cannot create energy, which Newton's
    law applied at every contact at once can (a ball bouncing on two points of its
    polyhedral bottom gained 0.3 % per bounce that way).

    Parameters
    ----------
    contacts, bodies : tuples as in ``solve_pgs``
        The body velocities are updated.
    impulse : (c, 3) float64
        Compression impulses in; totals out.
    restitution : (c,) float64
        e of each contact (0 for contacts that do not bounce).
    """
    for k in range(impulse.shape[0]):
        extra = restitution[k] * impulse[k, 0]
        if extra > 0.0:
            _apply_impulse(k, 0, extra, contacts, bodies)
            impulse[k, 0] += extra


@njit
def delassus_matrix(contacts, bodies):
    """(3c, 3c) matrix A = J M^-1 J^T in contact space, rows (n, t1, t2) per contact.

    A[3k + d, 3l + f] is the change of u . e_d at contact k per unit impulse along e_f at
    contact l; non-zero only when the contacts share a movable body.
    """
    body_a, body_b, arm_a, arm_b, basis = contacts
    inverse_mass, inverse_inertia = bodies[2], bodies[3]
    c = body_a.shape[0]
    A = np.zeros((3 * c, 3 * c))
    for k in range(c):
        for l in range(c):
            for side_k in range(2):
                bk = body_a[k] if side_k == 0 else body_b[k]
                sk = 1.0 if side_k == 0 else -1.0
                arm_k = arm_a[k] if side_k == 0 else arm_b[k]
                for side_l in range(2):
                    bl = body_a[l] if side_l == 0 else body_b[l]
                    if bk != bl or inverse_mass[bk] == 0.0:  # static bodies add nothing
                        continue
                    sl = 1.0 if side_l == 0 else -1.0
                    arm_l = arm_a[l] if side_l == 0 else arm_b[l]
                    for d in range(3):
                        ek = basis[k, d]
                        ck = _cross(arm_k, ek)
                        for f in range(3):
                            el = basis[l, f]
                            cl = _cross(arm_l, el)
                            value = inverse_mass[bk] * _dot(ek, el) + _dot(
                                ck, _matvec(inverse_inertia[bk], cl)
                            )
                            A[3 * k + d, 3 * l + f] += sk * sl * value
    return A


@njit
def _stewart_trinkle_lcp(A, u, bias, friction, sides):
    """LCP(M, q) of the polyhedral-cone contact problem and the map back to (c, 3) impulses.

    Variables: lambda_n (c), then for each frictional contact beta (sides) and s (1). The
    tangential impulse is sum_j beta_j (cos theta_j, sin theta_j) in (t1, t2); s is the
    sliding speed, the multiplier of sum_j beta_j <= mu lambda_n.
    """
    c = friction.shape[0]
    frictional = 0
    for k in range(c):
        if friction[k] > 0.0:
            frictional += 1
    size = c + frictional * (sides + 1)
    # G maps LCP variables (lambda_n, beta) to contact-space impulses (3c)
    G = np.zeros((3 * c, size))
    beta_start = np.full(c, -1)
    column = c
    for k in range(c):
        G[3 * k, k] = 1.0
        if friction[k] > 0.0:
            beta_start[k] = column
            for j in range(sides):
                theta = 2.0 * math.pi * j / sides
                G[3 * k + 1, column + j] = math.cos(theta)
                G[3 * k + 2, column + j] = math.sin(theta)
            column += sides + 1
    M = G.T @ A @ G
    b = u.copy()
    for k in range(c):
        b[3 * k] += bias[k]
    q = G.T @ b
    for k in range(c):
        start = beta_start[k]
        if start < 0:
            continue
        s = start + sides
        for j in range(sides):
            M[start + j, s] = 1.0
            M[s, start + j] = -1.0
        M[s, k] = friction[k]
        M[s, s] = 0.0
        q[s] = 0.0
    return M, q, G


@njit
def _lcp_residual(M, q, z):
    """Largest violation of z >= 0, w = Mz + q >= 0 and z.w = 0, each relative to its scale.

    w is measured against the largest of |q|, |Mz| and 1e-4 (an absolute floor: when nothing
    approaches, q and Mz are round-off, 1e-13, and so is any violation); z against its own
    largest entry.
    """
    w = M @ z + q
    velocity_scale = 1e-4
    impulse_scale = 1e-300
    for i in range(q.shape[0]):
        velocity_scale = max(velocity_scale, abs(q[i]), abs(w[i] - q[i]))
        impulse_scale = max(impulse_scale, abs(z[i]))
    worst = 0.0
    for i in range(q.shape[0]):
        worst = max(
            worst,
            -z[i] / impulse_scale,
            -w[i] / velocity_scale,
            abs(z[i] * w[i]) / (impulse_scale * velocity_scale),
        )
    return worst


# Relative pivot tolerances for Lemke, tried in turn until one answer passes the check.
_PIVOT_TOLERANCES = (1e-7, 1e-5, 1e-10)


@njit
def solve_exact(sides, contacts, bias, friction, bodies, impulse, pgs_fallback_iterations=200):
    """Solve the contact problem exactly (Lemke on the Stewart-Trinkle LCP), in place.

    Same arguments as ``solve_pgs``; ``impulse`` is the warm start of the fallback only and is
    overwritten with the answer. The pivoting answer is checked against the LCP conditions
    and against the energy bound every exact answer obeys (``_dissipates``): if it misses
    them by more than 1e-6 relative at every pivot tolerance tried (the path
    ended on a ray with the artificial variable still positive, or round-off on a badly
    degenerate island), the island is solved by ``pgs_fallback_iterations`` PGS sweeps
    started from the best pivoting answer when that misses by less than 1e-2 (it is nearly
    right, and PGS alone converges slowly on a heavy-on-light stack), else from ``impulse``.

    Returns
    -------
    status : int
        0 solved exactly; 1 secondary ray, 2 pivot limit, 3 inaccurate (for all of
        these PGS was used).
    """
    c = contacts[0].shape[0]
    A = delassus_matrix(contacts, bodies)
    u = np.empty(3 * c)
    for k in range(c):
        for d in range(3):
            u[3 * k + d] = relative_velocity(k, d, contacts, bodies)
    M, q, G = _stewart_trinkle_lcp(A, u, bias, friction, sides)
    # Coplanar contacts make M singular and the path degenerate; a pivot a millionth of its
    # column's largest entry is round-off, and pivoting on it wrecks the tableau. The default
    # tolerance rejects those; the others are retries for the rare path it blocks.
    # Redundant contacts can also stop the path on a ray while the artificial variable is
    # already zero, and then the basis in hand is a solution: the LCP conditions are the
    # judge either way.
    best, best_residual, best_status = np.zeros(3 * c), np.inf, 3
    for pivot_tolerance in _PIVOT_TOLERANCES:
        z, status, _ = lemke(M, q, 0, pivot_tolerance)
        contact_impulse = G @ z
        residual = _lcp_residual(M, q, z)
        if not _dissipates(A, u, bias, contact_impulse):
            residual = max(residual, 1.0)  # an answer that adds energy is no answer
        if residual < best_residual:
            best, best_residual, best_status = contact_impulse, residual, status
        if residual <= 1e-6:
            break
    if best_residual <= 1e-6:
        _set_impulses(best, contacts, bodies, impulse)
        return 0
    if best_residual <= 1e-2:
        _to_contact_impulses(best, impulse)
    solve_pgs(pgs_fallback_iterations, sides, contacts, bias, friction, bodies, impulse)
    return 3 if best_status == 0 else best_status  # 3: the path ended, its answer was off


@njit
def _dissipates(A, u, bias, contact_impulse):
    """Whether the impulse changes the kinetic energy by no more than the bias allows.

    For any exact answer, with u+ = u + A lambda, the energy change is
    lambda . u+ - lambda A lambda / 2, and complementarity makes lambda . u+ equal to
    -sum lambda_n bias minus what sliding friction dissipates: so it never exceeds
    -sum lambda_n bias. A degenerate path can end on a basis whose impulses are huge and
    cancel in Mz (the tableau's checks pass to 1e-8 relative) yet spin a light box at
    1 rad/s between heavy ones; this is the check that catches it.
    """
    c = bias.shape[0]
    quadratic = contact_impulse @ (A @ contact_impulse)
    gain = contact_impulse @ u + 0.5 * quadratic
    for k in range(c):
        gain += contact_impulse[3 * k] * bias[k]
    return gain <= 1e-6 * quadratic + 1e-15


@njit
def _to_contact_impulses(contact_impulse, impulse):
    """(3c,) contact-space impulses into the (c, 3) rows (lambda_n, lambda_t1, lambda_t2)."""
    for k in range(impulse.shape[0]):
        for d in range(3):
            impulse[k, d] = contact_impulse[3 * k + d]


@njit
def _set_impulses(contact_impulse, contacts, bodies, impulse):
    """Store the (3c,) contact-space impulses in ``impulse`` and apply them to the bodies."""
    _to_contact_impulses(contact_impulse, impulse)
    for k in range(impulse.shape[0]):
        for d in range(3):
            if impulse[k, d] != 0.0:
                _apply_impulse(k, d, impulse[k, d], contacts, bodies)
