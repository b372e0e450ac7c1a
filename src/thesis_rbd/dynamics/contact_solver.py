"""Velocity-level contact response: restitution, non-penetration and Coulomb friction.

Every contact k joins body a (``body_a[k]``) and body b (``body_b[k]``) at a world point p_k
with unit normal n_k pointing from b towards a (the impulse +j n acts on a, -j n on b). The
relative velocity at the contact, u = (v_a + w_a x r_a) - (v_b + w_b x r_b), is read along
three directions (n, t1, t2), so each contact has three impulse components
lambda = (lambda_n, lambda_t1, lambda_t2). After the solve, with u- the velocity before:

* non-penetration (thesis 7.1), for all contacts at once:
  0 <= lambda_n  _|_  u_n+ + bias >= 0  (restitution is applied afterwards, as Poisson's
  second phase, by the callers);
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
negative bias demands separation (a penetration to push out), a positive one allows that much
approach (a resting contact sinking to its slop).
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.lcp import lemke
from thesis_rbd.dynamics.pgs import build_rows, friction_polygon, sweep_island

__all__ = [
    "FALLBACK_SWEEPS",
    "REBOUND_EXACT_CONTACTS",
    "contact_basis",
    "delassus_matrix",
    "exact_contact_impulses",
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


@njit
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit
def _matvec(m, v):
    return (
        m[0, 0] * v[0] + m[0, 1] * v[1] + m[0, 2] * v[2],
        m[1, 0] * v[0] + m[1, 1] * v[1] + m[1, 2] * v[2],
        m[2, 0] * v[0] + m[2, 1] * v[1] + m[2, 2] * v[2],
    )


@njit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit
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


@njit
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


@njit
def solve_pgs(iterations, sides, contacts, bias, friction, bodies, impulse, tolerance):
    """Projected Gauss-Seidel on one island given as tuples (``pgs.sweep_island``), in place.

    ``contacts`` and ``bodies`` are the tuples of the module docstring, ``bias`` and
    ``friction`` (c,); ``impulse`` (c, 3) is the warm start and is overwritten with the answer.
    Returns whether the sweeps converged to the velocity ``tolerance`` (m/s).
    """
    body_a, body_b, arm_a, arm_b, basis = contacts
    velocity, angular_velocity, inverse_mass, inverse_inertia = bodies
    rows = build_rows(body_a, body_b, arm_a, arm_b, basis, inverse_mass, inverse_inertia)
    angular_a, angular_b, response_a, response_b, normal_step, tangent_step, coupling = rows
    _, converged = sweep_island(
        0, body_a.shape[0], iterations, np.full(body_a.shape[0], tolerance),
        friction_polygon(sides), body_a, body_b,
        basis, angular_a, angular_b, response_a, response_b, normal_step, tangent_step,
        coupling, inverse_mass, bias, friction, velocity, angular_velocity, impulse,
    )  # fmt: skip
    return converged


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


@njit(separate=True)
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
def _scaling(M, c, sides, friction):
    """Diagonal scaling S that makes the contact LCP dimensionless: M' = S M S, q' = S q.

    lambda and beta rows get 1 / sqrt(M_ii), so M'_ii = 1 whatever the masses (a 10 um cube's
    M is 1e12 times a 1 kg cube's); each sliding-speed row s gets the inverse of its first beta
    row's factor, so its couplings to lambda (mu) and to beta (1) stay O(1) too. Lemke's pivot
    tolerance and the answer's check then mean the same at every scale.
    """
    n = M.shape[0]
    S = np.ones(n)
    for i in range(n):
        if M[i, i] > 0.0:
            S[i] = 1.0 / math.sqrt(M[i, i])
    column = c
    for k in range(c):
        if friction[k] > 0.0:
            S[column + sides] = 1.0 / S[column]
            column += sides + 1
    return S


@njit
def _lcp_residual(M, q, z, velocity_floor):
    """Largest violation of z >= 0, w = Mz + q >= 0 and z.w = 0, each relative to its scale.

    w is measured against the largest of |q|, |Mz| and ``velocity_floor`` (when nothing
    approaches, q and Mz are round-off, and so is any violation: the floor is the island's own
    velocity scale); z against its own largest entry.
    """
    w = M @ z + q
    velocity_scale = velocity_floor
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


# PGS sweeps an island gets where Lemke's answer misses the LCP conditions (``solve_exact``).
FALLBACK_SWEEPS = 200
# The most contacts of a rebounding island that "auto" solves exactly when PGS has not
# converged (a row of 20 polyhedral balls touching face to face has 120): a rebound gives
# back e of the compression impulses and keeps the energy only if they are the answer.
REBOUND_EXACT_CONTACTS = 160

# Relative pivot tolerances for Lemke, tried in turn until one answer passes the check.
_PIVOT_TOLERANCES = (1e-7, 1e-5, 1e-10)


@njit(inline="always")
def exact_contact_impulses(sides, A, u, bias, friction, velocity_scale):
    """Lemke's answer to the contact problem of the Delassus matrix ``A`` (3c, 3c) and the
    contact velocities ``u`` (3c,) before the impulses, rows (n, t1, t2) per contact.

    The LCP is scaled to be dimensionless (``_scaling``) and each answer checked against the
    LCP conditions and the energy bound (``_dissipates``), at each pivot tolerance in turn
    until one passes.

    Returns
    -------
    impulse : (3c,) float64
        The best answer found, in contact space.
    residual : float
        Its largest relative violation (at most 1e-6: solved exactly).
    status : int
        Lemke's status for it (0: the path ended on a solution).
    """
    c = bias.shape[0]
    M, q, G = _stewart_trinkle_lcp(A, u, bias, friction, sides)
    S = _scaling(M, c, sides, friction)
    for i in range(M.shape[0]):
        q[i] *= S[i]
        for j in range(M.shape[0]):
            M[i, j] *= S[i] * S[j]
    velocity_floor = 0.0
    for k in range(c):
        velocity_floor = max(velocity_floor, velocity_scale * S[k])
    # Coplanar contacts make M singular and the path degenerate; a pivot a millionth of its
    # column's largest entry is round-off, and pivoting on it wrecks the tableau. The default
    # tolerance rejects those; the others are retries for the rare path it blocks.
    # Redundant contacts can also stop the path on a ray while the artificial variable is
    # already zero, and then the basis in hand is a solution: the LCP conditions are the
    # judge either way.
    best, best_residual, best_status = np.zeros(3 * c), np.inf, 3
    for pivot_tolerance in _PIVOT_TOLERANCES:
        z, status, _ = lemke(M, q, 0, pivot_tolerance)
        residual = _lcp_residual(M, q, z, velocity_floor)
        contact_impulse = G @ (S * z)
        if not _dissipates(A, u, bias, contact_impulse):
            residual = max(residual, 1.0)  # an answer that adds energy is no answer
        if residual < best_residual:
            best, best_residual, best_status = contact_impulse, residual, status
        if residual <= 1e-6:
            break
    return best, best_residual, best_status


@njit(separate=True)
def solve_exact(
    sides,
    contacts,
    bias,
    friction,
    bodies,
    impulse,
    velocity_scale,
    pgs_fallback_iterations=FALLBACK_SWEEPS,
):
    """Solve the contact problem exactly (Lemke on the Stewart-Trinkle LCP), in place.

    Same arguments as ``solve_pgs``, and ``velocity_scale``, the speed below which velocity
    errors of this island are round-off (the caller's slop per step, say); ``impulse`` is the
    warm start of the fallback only and is overwritten with the answer. The LCP is scaled to
    be dimensionless (``_scaling``). The pivoting answer is checked against the LCP
    conditions and against the energy bound every exact answer obeys (``_dissipates``): if it
    misses them by more than 1e-6 relative at every pivot tolerance tried (the path ended on a
    ray with the artificial variable still positive, or round-off on a badly degenerate
    island), the island is solved by ``pgs_fallback_iterations`` PGS sweeps started from the
    best pivoting answer when that misses by less than 1e-2 (it is nearly right, and PGS alone
    converges slowly on a heavy-on-light stack), else from ``impulse``.

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
    best, best_residual, best_status = exact_contact_impulses(
        sides, A, u, bias, friction, velocity_scale
    )
    if best_residual <= 1e-6:
        _set_impulses(best, contacts, bodies, impulse)
        return 0
    if best_residual <= 1e-2:
        _to_contact_impulses(best, impulse)
    solve_pgs(
        pgs_fallback_iterations, sides, contacts, bias, friction, bodies, impulse,
        1e-3 * velocity_scale,
    )  # fmt: skip
    return 3 if best_status == 0 else best_status  # 3: the path ended, its answer was off


@njit
def _dissipates(A, u, bias, contact_impulse):
    """Whether the impulse changes the kinetic energy by no more than the bias allows.

    For any exact answer, with u+ = u + A lambda, the energy change is
    lambda . u+ - lambda A lambda / 2, and complementarity makes lambda . u+ equal to
    -sum lambda_n bias minus what sliding friction dissipates: so it never exceeds
    -sum lambda_n bias. A degenerate path can end on a basis whose impulses are huge and
    cancel in Mz (the tableau's checks pass to 1e-8 relative) yet spin a light box at
    1 rad/s between heavy ones; this is the check that catches it. The allowance is relative
    to the energies involved, so it means the same for a 10 um part and a 100 m block.
    """
    c = bias.shape[0]
    quadratic = contact_impulse @ (A @ contact_impulse)
    work = contact_impulse @ u
    gain = work + 0.5 * quadratic
    biased = 0.0
    for k in range(c):
        gain += contact_impulse[3 * k] * bias[k]
        biased += abs(contact_impulse[3 * k] * bias[k])
    return gain <= 1e-6 * quadratic + 1e-12 * (abs(work) + biased)


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
