"""The constraint rows of a joint, and what a joint reads out: its position, velocity, gap and
angular error.

A row is one scalar constraint C(x_a, q_a, x_b, q_b) = 0 with its Jacobian: moving body a by
dx_a and turning it by the small world rotation dtheta_a (and b likewise) changes C by

    dC = lin . dx_a + ang_a . dtheta_a - lin . dx_b + ang_b . dtheta_b

so an impulse ``lam`` along the row gives body a the momentum ``lin lam`` and angular
momentum ``ang_a lam`` (about its centre of mass), and body b ``-lin lam`` and
``ang_b lam``: equal and opposite at the point the row acts, which is why joint impulses
conserve the total linear and angular momentum. Rows of each kind (``joint_set``):

* anchors together: C = (p_a - p_b) . e_k for the world axes e_k, where p = x + R arm;
  lin = e_k, ang_a = r_a x e_k, ang_b = -(r_b x e_k) with r = R arm;
* axes parallel (revolute): C = a_a . n_b and a_a . m_b for a's axis and b's two
  perpendiculars; ang_a = a_a x n_b = -ang_b;
* orientation held (fixed, prismatic): C = theta_k, the world rotation vector that takes a's
  orientation at zero, q_b q_rel0, to its orientation q_a; ang_a = e_k = -ang_b;
* on b's line (prismatic): C = (p_a - p_b) . n_b and . m_b, acting at p_a on both bodies
  (b's perpendiculars turn with b): ang_b = -((p_a - x_b) x n_b);
* at the rod's length (distance): C = |p_a - p_b| - length along d = (p_a - p_b) / |.|;
  lin = d, ang_a = r_a x d, ang_b = -(r_b x d);
* a universal or generic joint's locked axes (``joint_set``): travel along b's axis d as
  a line row; all three turns as the orientation rows, two as a hinge's rows about the
  free turn's axis, one as C = u . v for the Cardan pair it holds square (u fixed in b, v
  in a: b's x and a's y for z, b's x and a's z for y, b's y and a's z for x), ang_a =
  v x u = -ang_b; a limited axis as a limit row on its travel or Cardan angle, whose rate
  is omega_rel . u_k for the dual basis u_k of (x_b, y', z_a) (y' the middle axis);
* within limits (a limited hinge, slider or distance joint, its last row): C = position -
  the limit it is beyond, along the axis (a hinge: ang_a = axis = -ang_b; a slider: as a line
  row along the axis; a distance joint: as a rod's row). A limit acts only where it is
  reached: within them the row is written as zero where ``active_limits_only`` asks, and the
  solve drops it. A rope is a distance joint with an upper limit and no rod row.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.integrators import angular_velocity
from thesis_rbd.dynamics.joint_set import (
    ARM_A,
    ARM_B,
    AXIS_A,
    AXIS_B,
    AXIS_LOWER,
    AXIS_UPPER,
    BINORMAL_B,
    BODY_A,
    CONE,
    FREE_LENGTH,
    JOINT_KINDS,
    LENGTH,
    LOWER,
    NORMAL_B,
    RELATIVE_ORIENTATION,
    SCALE,
    UPPER,
)
from thesis_rbd.spatial.quaternion import conjugate, mul, rotate

__all__ = [
    "axis_row",
    "axis_state",
    "body_pose",
    "cone_angle",
    "coupling_block",
    "coupling_matrix",
    "equality_row_count",
    "frame_axis_row",
    "has_axes",
    "joint_frames",
    "joint_readout",
    "joint_row_count",
    "joint_rows",
    "limit_band",
    "read_joints",
    "row_responses",
    "row_written",
    "write_row",
]

SPHERICAL = JOINT_KINDS["spherical"]
REVOLUTE = JOINT_KINDS["revolute"]
FIXED = JOINT_KINDS["fixed"]
PRISMATIC = JOINT_KINDS["prismatic"]
DISTANCE = JOINT_KINDS["distance"]
UNIVERSAL = JOINT_KINDS["universal"]
GENERIC = JOINT_KINDS["generic"]
# Equality rows of each kind, by code (a limited joint has one more; a universal or generic
# joint's count is its locked axes').
ROWS_OF_KIND = (3, 5, 6, 5, 1, 0)
# How each axis of a universal or generic joint moves.
FREE, LOCKED, LIMITED = 0, 1, 2
# A limit row acts where its joint is beyond its limit or within this of it (rad, or the
# joint's scale for travel and lengths). Within it, its error reads as zero: the row keeps
# the projection's later, smaller corrections from moving the joint along it, instead of
# leaving the Newton matrix at one iterate (or substep) and joining it again at the next,
# which made the matrix again on most substeps of an arm resting on a limit. The band is far
# below any motion a step resolves, and a joint leaving its limit leaves it at its own rate
# (``_beyond``)
_AT_LIMIT = 1e-6


@njit(allocates=False)
def has_axes(kind):
    """Whether a joint of this kind holds each of six axes free, locked or limited."""
    return kind == UNIVERSAL or kind == GENERIC


@njit(allocates=False)
def axis_state(f, k):
    """``FREE``, ``LOCKED`` or ``LIMITED``: how axis k (0-2 travel, 3-5 turns) moves."""
    lower, upper = f[AXIS_LOWER + k], f[AXIS_UPPER + k]
    if lower == 0.0 and upper == 0.0:
        return LOCKED
    if lower == -math.inf and upper == math.inf:
        return FREE
    return LIMITED


@njit(allocates=False)
def _axes_in(f, state, first):
    """How many of the three axes from ``first`` are in ``state``."""
    return (
        (axis_state(f, first) == state) + (axis_state(f, first + 1) == state)
        + (axis_state(f, first + 2) == state)
    )  # fmt: skip


@njit(allocates=False)
def equality_row_count(kind, f):
    """A joint's equality rows: its kind's, or a universal or generic joint's locked axes."""
    if has_axes(kind):
        return _axes_in(f, LOCKED, 0) + _axes_in(f, LOCKED, 3)
    return ROWS_OF_KIND[kind]


@njit(allocates=False)
def joint_row_count(kind, f):
    """Rows of a joint: its kind's, one for a spherical joint's cone if it has one, and one
    for its limits if it has any (a universal or generic joint: one per axis not free)."""
    if has_axes(kind):
        return 6 - _axes_in(f, FREE, 0) - _axes_in(f, FREE, 3)
    limited = f[LOWER] > -math.inf or f[UPPER] < math.inf
    return ROWS_OF_KIND[kind] + (1 if f[CONE] < math.inf else 0) + (1 if limited else 0)


@njit(allocates=False)
def _cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@njit(allocates=False)
def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@njit(allocates=False)
def _vector(f, start):
    return (f[start], f[start + 1], f[start + 2])


@njit(allocates=False)
def write_row(rows, k, lin, ang_a, ang_b, error):
    """Row k of ``rows`` (r, 10): lin (3), ang_a (3), ang_b (3), error."""
    for i in range(3):
        rows[k, i] = lin[i]
        rows[k, 3 + i] = ang_a[i]
        rows[k, 6 + i] = ang_b[i]
    rows[k, 9] = error


@njit(allocates=False)
def body_pose(body, position, orientation):
    """(x, q) tuples of a body (-1: the world, at the origin unturned)."""
    if body < 0:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
    x, q = position[body], orientation[body]
    return (x[0], x[1], x[2]), (q[0], q[1], q[2], q[3])


@njit(allocates=False)
def _frames(f, xa, qa, xb, qb):
    """World arms r_a, r_b, anchors' offset p_a - p_b."""
    ra = rotate(qa, _vector(f, ARM_A))
    rb = rotate(qb, _vector(f, ARM_B))
    gap = (xa[0] + ra[0] - xb[0] - rb[0], xa[1] + ra[1] - xb[1] - rb[1],
           xa[2] + ra[2] - xb[2] - rb[2])  # fmt: skip
    return ra, rb, gap


@njit(allocates=False)
def _orientation_error(f, qa, qb):
    """World rotation vector from a's orientation at zero (q_b q_rel0) to q_a."""
    q0 = (f[RELATIVE_ORIENTATION], f[RELATIVE_ORIENTATION + 1], f[RELATIVE_ORIENTATION + 2],
          f[RELATIVE_ORIENTATION + 3])  # fmt: skip
    e = mul(qa, conjugate(mul(qb, q0)))
    s = 2.0 if e[3] >= 0.0 else -2.0
    return (s * e[0], s * e[1], s * e[2])


@njit(allocates=False)
def joint_rows(kind, f, xa, qa, xb, qb, rows, first, active_limits_only):
    """Write the rows of one joint at the poses given into ``rows[first:]``.

    Parameters
    ----------
    kind : int
        A code of ``JOINT_KINDS``.
    f : (JOINT_FLOATS,) float64
        The joint's row of ``JointSet.floats``.
    xa, qa, xb, qb : tuples
        Centres of mass and (x, y, z, w) orientations of bodies a and b (the world: origin
        and identity).
    rows : (r, 10) float64
        Out: lin, ang_a, ang_b, error per row (module docstring).
    first : int
    active_limits_only : bool
        Write the limit row as zero unless a limit is passed (the rows of the poses being
        corrected); False writes its direction always (the rows of the start of a substep,
        which give the corrections their direction).

    Returns
    -------
    int
        The number of rows written.
    """
    ra, rb, gap = _frames(f, xa, qa, xb, qb)
    zero = (0.0, 0.0, 0.0)
    k = first
    if has_axes(kind):
        return _axis_rows(f, xa, qa, xb, qb, ra, gap, rows, first, active_limits_only)
    if kind == DISTANCE:
        lin, ang_a, ang_b, length = _along_line(ra, rb, gap)
        write_row(rows, k, lin, ang_a, ang_b, length - f[LENGTH])
        return 1
    if kind == PRISMATIC:
        # b's line through its anchor: the offset across it, acting at p_a on both bodies
        arm = (xa[0] + ra[0] - xb[0], xa[1] + ra[1] - xb[1], xa[2] + ra[2] - xb[2])
        for column in (NORMAL_B, BINORMAL_B):
            d = rotate(qb, _vector(f, column))
            across = _cross(arm, d)
            write_row(rows, k, d, _cross(ra, d), (-across[0], -across[1], -across[2]),
                   _dot(gap, d))  # fmt: skip
            k += 1
    elif kind != FREE_LENGTH:  # a rope's or spring's only row is its limit's
        for axis in range(3):
            d = (1.0 if axis == 0 else 0.0, 1.0 if axis == 1 else 0.0, 1.0 if axis == 2 else 0.0)
            rbn = _cross(rb, d)
            write_row(rows, k, d, _cross(ra, d), (-rbn[0], -rbn[1], -rbn[2]), gap[axis])
            k += 1
    if kind == REVOLUTE:
        a = rotate(qa, _vector(f, AXIS_A))
        for column in (NORMAL_B, BINORMAL_B):
            n = rotate(qb, _vector(f, column))
            t = _cross(a, n)
            write_row(rows, k, zero, t, (-t[0], -t[1], -t[2]), _dot(a, n))
            k += 1
    elif kind == FIXED or kind == PRISMATIC:
        theta = _orientation_error(f, qa, qb)
        for axis in range(3):
            e = (1.0 if axis == 0 else 0.0, 1.0 if axis == 1 else 0.0, 1.0 if axis == 2 else 0.0)
            write_row(rows, k, zero, e, (-e[0], -e[1], -e[2]), theta[axis])
            k += 1
    if f[CONE] < math.inf:
        n, angle = cone_angle(f, qa, qb)
        beyond = angle - f[CONE]
        if active_limits_only and beyond < -_AT_LIMIT:
            write_row(rows, k, zero, zero, zero, 0.0)
        else:
            write_row(rows, k, zero, n, (-n[0], -n[1], -n[2]), max(beyond, 0.0))
        k += 1
    if f[LOWER] > -math.inf or f[UPPER] < math.inf:
        _limit_row(kind, f, xa, qa, xb, qb, ra, rb, gap, rows, k, active_limits_only)
        k += 1
    return k - first


@njit(allocates=False)
def joint_frames(f, qa, qb):
    """World axes of a universal or generic joint's frame on body b (x_b, y_b, z_b) and on
    body a (x_a, y_a, z_a): b's frame carried by a since creation, when the two coincided."""
    carried = mul(qa, conjugate(_relative(f)))
    b = (rotate(qb, _vector(f, AXIS_B)), rotate(qb, _vector(f, NORMAL_B)),
         rotate(qb, _vector(f, BINORMAL_B)))  # fmt: skip
    a = (rotate(carried, _vector(f, AXIS_B)), rotate(carried, _vector(f, NORMAL_B)),
         rotate(carried, _vector(f, BINORMAL_B)))  # fmt: skip
    return b, a


@njit(allocates=False)
def _relative(f):
    return (f[RELATIVE_ORIENTATION], f[RELATIVE_ORIENTATION + 1], f[RELATIVE_ORIENTATION + 2],
            f[RELATIVE_ORIENTATION + 3])  # fmt: skip


@njit(allocates=False)
def _square_pair(fb, fa, locked):
    """(u, v) of the one locked turn of a joint whose other two turn (module docstring)."""
    if locked == 2:
        return fb[0], fa[1]
    if locked == 1:
        return fb[0], fa[2]
    return fb[1], fa[2]


@njit(allocates=False)
def _axis_rows(f, xa, qa, xb, qb, ra, gap, rows, first, active_limits_only):
    """The rows of a universal or generic joint (module docstring): its locked travels, its
    locked turns, then a limit row per limited axis. Returns how many."""
    fb, fa = joint_frames(f, qa, qb)
    arm = (xa[0] + ra[0] - xb[0], xa[1] + ra[1] - xb[1], xa[2] + ra[2] - xb[2])
    zero = (0.0, 0.0, 0.0)
    k = first
    for axis in range(3):
        if axis_state(f, axis) == LOCKED:
            d = fb[axis]
            across = _cross(arm, d)
            write_row(rows, k, d, _cross(ra, d), (-across[0], -across[1], -across[2]),
                      _dot(gap, d))  # fmt: skip
            k += 1
    locked = _axes_in(f, LOCKED, 3)
    if locked == 3:
        theta = _orientation_error(f, qa, qb)
        for axis in range(3):
            e = (1.0 if axis == 0 else 0.0, 1.0 if axis == 1 else 0.0, 1.0 if axis == 2 else 0.0)
            write_row(rows, k, zero, e, (-e[0], -e[1], -e[2]), theta[axis])
            k += 1
    elif locked == 2:
        turn = _lone_turn(f)
        a = fa[turn]
        for other in range(3):
            if other != turn:
                t = _cross(a, fb[other])
                write_row(rows, k, zero, t, (-t[0], -t[1], -t[2]), _dot(a, fb[other]))
                k += 1
    elif locked == 1:
        held = 0 if axis_state(f, 3) == LOCKED else (1 if axis_state(f, 4) == LOCKED else 2)
        u, v = _square_pair(fb, fa, held)
        t = _cross(v, u)
        write_row(rows, k, zero, t, (-t[0], -t[1], -t[2]), _dot(u, v))
        k += 1
    for axis in range(6):
        if axis_state(f, axis) != LIMITED:
            continue
        lin, ang_a, ang_b, position = _frame_axis(f, axis, qa, qb, fb, fa, ra, arm, gap)
        near = _AT_LIMIT * (f[SCALE] if axis < 3 else 1.0)
        at, beyond = _beyond(position, f[AXIS_LOWER + axis], f[AXIS_UPPER + axis], near)
        if active_limits_only and not at:
            write_row(rows, k, zero, zero, zero, 0.0)
        else:
            write_row(rows, k, lin, ang_a, ang_b, beyond)
        k += 1
    return k - first


@njit(allocates=False)
def _lone_turn(f):
    """The turn (0-2) a joint that locks the other two leaves."""
    for turn in range(3):
        if axis_state(f, 3 + turn) != LOCKED:
            return turn
    return 0


@njit(allocates=False)
def frame_axis_row(f, axis, xa, qa, xb, qb):
    """(lin, ang_a, ang_b, position) of axis ``axis`` (0-2 travel, 3-5 turns) of a universal
    or generic joint: the row that moves the joint along it, and where it is (module
    docstring)."""
    ra, _, gap = _frames(f, xa, qa, xb, qb)
    fb, fa = joint_frames(f, qa, qb)
    arm = (xa[0] + ra[0] - xb[0], xa[1] + ra[1] - xb[1], xa[2] + ra[2] - xb[2])
    return _frame_axis(f, axis, qa, qb, fb, fa, ra, arm, gap)


@njit(allocates=False)
def _frame_axis(f, axis, qa, qb, fb, fa, ra, arm, gap):
    """``frame_axis_row`` from the joint's frames and arms."""
    if axis < 3:
        d = fb[axis]
        across = _cross(arm, d)
        return d, _cross(ra, d), (-across[0], -across[1], -across[2]), _dot(gap, d)
    turn = axis - 3
    if _axes_in(f, LOCKED, 3) == 2:
        # a lone turn: a hinge's angle about its axis, the full turn round
        d = fb[turn]
        e = mul(mul(conjugate(qb), qa), conjugate(_relative(f)))
        angle = _wrapped(2.0 * math.atan2(_dot(e, _vector(f, (AXIS_B, NORMAL_B, BINORMAL_B)[turn])),
                                          e[3]))  # fmt: skip
        return (0.0, 0.0, 0.0), d, (-d[0], -d[1], -d[2]), angle
    # Cardan angles: R_rel = Rx(alpha) Ry(beta) Rz(gamma), M_ij = fb[i] . fa[j]
    x, z = fb[0], fa[2]
    middle = _cross(z, x)
    c = math.sqrt(_dot(middle, middle))  # cos(beta) >= 0
    if c == 0.0:  # gimbal lock: alpha and gamma turn about one axis
        d = fb[turn]
        return (0.0, 0.0, 0.0), d, (-d[0], -d[1], -d[2]), 0.0
    y = (middle[0] / c, middle[1] / c, middle[2] / c)
    if turn == 0:
        u = _cross(y, z)
        angle = math.atan2(-_dot(fb[1], z), _dot(fb[2], z))
    elif turn == 1:
        u = (y[0] * c, y[1] * c, y[2] * c)
        angle = math.atan2(_dot(x, z), c)
    else:
        u = _cross(x, y)
        angle = math.atan2(-_dot(x, fa[1]), _dot(x, fa[0]))
    u = (u[0] / c, u[1] / c, u[2] / c)
    return (0.0, 0.0, 0.0), u, (-u[0], -u[1], -u[2]), angle


@njit(allocates=False)
def _wrapped(angle):
    """An angle in (-pi, pi]."""
    if angle > math.pi:
        return angle - 2.0 * math.pi
    if angle <= -math.pi:
        return angle + 2.0 * math.pi
    return angle


@njit(allocates=False)
def _along_line(ra, rb, gap):
    """(lin, ang_a, ang_b, length) of the anchors' distance: the row that moves them apart
    along their line (+x where they coincide), and how far apart they are."""
    length = math.sqrt(_dot(gap, gap))
    d = (1.0, 0.0, 0.0) if length == 0.0 else (gap[0] / length, gap[1] / length,
                                              gap[2] / length)  # fmt: skip
    rbn = _cross(rb, d)
    return d, _cross(ra, d), (-rbn[0], -rbn[1], -rbn[2]), length


@njit(allocates=False)
def limit_band(kind, f):
    """How near its limit a joint's position counts as on it (``_AT_LIMIT`` in radians for an
    angle, of the joint's scale for a travel or a length)."""
    return _AT_LIMIT * (1.0 if kind == REVOLUTE or kind == SPHERICAL else f[SCALE])


@njit(allocates=False)
def _limit_row(kind, f, xa, qa, xb, qb, ra, rb, gap, rows, k, active_limits_only):
    """The limit row of a hinge, slider or distance joint (module docstring)."""
    lin, ang_a, ang_b, position = _along_axis(kind, f, xa, qa, xb, qb, ra, rb, gap)
    at, beyond = _beyond(position, f[LOWER], f[UPPER], limit_band(kind, f))
    if active_limits_only and not at:
        zero = (0.0, 0.0, 0.0)
        write_row(rows, k, zero, zero, zero, 0.0)
    else:
        write_row(rows, k, lin, ang_a, ang_b, beyond)


@njit(allocates=False)
def _beyond(position, lower, upper, near):
    """(at, beyond) of a position against its limits: how far beyond the nearer one it is
    (0 within them), and whether it is at or beyond one, to within ``near``: a row the
    projection held at its limit reads as a hair beyond it or a hair within from one
    iterate, or substep, to the next, and must not leave the Newton matrix and join it
    again each time."""
    if position - lower < 0.5 * (upper - lower):
        return position - lower <= near, min(position - lower, 0.0)
    return upper - position <= near, max(position - upper, 0.0)


@njit(allocates=False)
def _along_axis(kind, f, xa, qa, xb, qb, ra, rb, gap):
    """(lin, ang_a, ang_b, position) of a hinge's angle, a slider's travel or a distance
    joint's length: the row that moves the joint along its axis, and where it is."""
    if kind == DISTANCE or kind == FREE_LENGTH:
        return _along_line(ra, rb, gap)
    axis = rotate(qb, _vector(f, AXIS_B))
    if kind == REVOLUTE:
        return (0.0, 0.0, 0.0), axis, (-axis[0], -axis[1], -axis[2]), _hinge_angle(f, qa, qb)
    if kind == SPHERICAL:
        t, twist = _twist(f, qa, qb, axis)
        return (0.0, 0.0, 0.0), t, (-t[0], -t[1], -t[2]), twist
    arm = (xa[0] + ra[0] - xb[0], xa[1] + ra[1] - xb[1], xa[2] + ra[2] - xb[2])
    across = _cross(arm, axis)
    return axis, _cross(ra, axis), (-across[0], -across[1], -across[2]), _dot(gap, axis)


@njit(allocates=False)
def axis_row(kind, f, xa, qa, xb, qb):
    """(lin, ang_a, ang_b, position) of a hinge's, slider's or distance joint's motion along
    its axis (the row its motor, spring, damping and friction act along), and the joint's
    position."""
    ra, rb, gap = _frames(f, xa, qa, xb, qb)
    return _along_axis(kind, f, xa, qa, xb, qb, ra, rb, gap)


@njit(allocates=False)
def cone_angle(f, qa, qb):
    """(n, angle): the angle (rad, in [0, pi]) between the axis fixed in body a and the axis
    fixed in body b, and the unit world direction n about which turning a by dphi (and b by
    dphi_b) opens it by n . (dphi - dphi_b) (any unit vector where the axes are parallel)."""
    a = rotate(qa, _vector(f, AXIS_A))
    b = rotate(qb, _vector(f, AXIS_B))
    c = _cross(b, a)
    sine = math.sqrt(_dot(c, c))
    angle = math.atan2(sine, _dot(a, b))
    if sine == 0.0:
        return rotate(qb, _vector(f, NORMAL_B)), angle
    return (c[0] / sine, c[1] / sine, c[2] / sine), angle


@njit(allocates=False)
def _twist(f, qa, qb, axis):
    """(t, twist): a spherical joint's twist, body a's turn about b's axis ``axis`` (world)
    since creation in the swing-twist split of the relative rotation E = q_a conj(q_b q_0),
    2 atan2(E_v . axis, E_w) in (-pi, pi]; and its gradient t, d twist = t . (dphi_a -
    dphi_b) for world turns dphi of the bodies (turning both alike leaves it)."""
    q0 = (f[RELATIVE_ORIENTATION], f[RELATIVE_ORIENTATION + 1], f[RELATIVE_ORIENTATION + 2],
          f[RELATIVE_ORIENTATION + 3])  # fmt: skip
    e = mul(qa, conjugate(mul(qb, q0)))
    v = (e[0], e[1], e[2])
    s, c = _dot(v, axis), e[3]
    # E' = (dphi / 2, 1) E: ds = dphi . (c axis + v x axis) / 2 and dc = -dphi . v / 2
    across = _cross(v, axis)
    norm = s * s + c * c
    if norm == 0.0:  # a half turn about an axis across b's: the twist is undefined
        return (0.0, 0.0, 0.0), 0.0
    t = (
        (c * (c * axis[0] + across[0]) + s * v[0]) / norm,
        (c * (c * axis[1] + across[1]) + s * v[1]) / norm,
        (c * (c * axis[2] + across[2]) + s * v[2]) / norm,
    )
    twist = 2.0 * math.atan2(s, c)
    if twist > math.pi:
        twist -= 2.0 * math.pi
    elif twist <= -math.pi:
        twist += 2.0 * math.pi
    return t, twist


@njit(allocates=False)
def _hinge_angle(f, qa, qb):
    """Body a's angle about +axis relative to b since creation, in (-pi, pi]."""
    q0 = (f[RELATIVE_ORIENTATION], f[RELATIVE_ORIENTATION + 1], f[RELATIVE_ORIENTATION + 2],
          f[RELATIVE_ORIENTATION + 3])  # fmt: skip
    e = mul(mul(conjugate(qb), qa), conjugate(q0))
    angle = 2.0 * math.atan2(_dot(e, _vector(f, AXIS_B)), e[3])
    if angle > math.pi:
        return angle - 2.0 * math.pi
    if angle <= -math.pi:
        return angle + 2.0 * math.pi
    return angle


@njit(allocates=False)
def joint_readout(kind, f, xa, qa, va, wa, xb, qb, vb, wb):
    """A joint's position, velocity, gap (m) and angular error (rad) at the state given.

    Position and velocity are a revolute joint's angle (rad, in (-pi, pi]) and rate, a
    prismatic joint's travel and speed, a distance joint's length and rate, all of body a
    relative to body b about / along +axis; zero for the other kinds (a universal or
    generic joint's axes are read by ``frame_axis_row``). Gap is how far the
    joint is from holding its position rows (a rope's or spring's: how far its length is
    beyond its limits), angular error how far from its angular rows.
    """
    ra, _, gap = _frames(f, xa, qa, xb, qb)
    if has_axes(kind):
        return 0.0, 0.0, _axes_gap(f, qb, gap), _axes_angle_error(f, qa, qb)
    axis_b = rotate(qb, _vector(f, AXIS_B))
    # velocity of a's anchor relative to the point of b under it
    arm_b = (xa[0] + ra[0] - xb[0], xa[1] + ra[1] - xb[1], xa[2] + ra[2] - xb[2])
    ua, ub = _cross(wa, ra), _cross(wb, arm_b)
    relative = (va[0] + ua[0] - vb[0] - ub[0], va[1] + ua[1] - vb[1] - ub[1],
                va[2] + ua[2] - vb[2] - ub[2])  # fmt: skip
    position = velocity = angle_error = 0.0
    gap_length = math.sqrt(_dot(gap, gap))
    distance = gap_length
    if kind == DISTANCE or kind == FREE_LENGTH:
        position = gap_length
        if kind == DISTANCE:
            distance = abs(gap_length - f[LENGTH])
        else:
            distance = max(f[LOWER] - gap_length, gap_length - f[UPPER], 0.0)
        if gap_length > 0.0:
            velocity = _dot(relative, gap) / gap_length
    elif kind == PRISMATIC:
        position = _dot(gap, axis_b)
        velocity = _dot(relative, axis_b) + _dot(gap, _cross(wb, axis_b))
        across = (gap[0] - position * axis_b[0], gap[1] - position * axis_b[1],
                  gap[2] - position * axis_b[2])  # fmt: skip
        distance = math.sqrt(_dot(across, across))
    if kind == REVOLUTE:
        position = _hinge_angle(f, qa, qb)
        velocity = _dot((wa[0] - wb[0], wa[1] - wb[1], wa[2] - wb[2]), axis_b)
        a = rotate(qa, _vector(f, AXIS_A))
        c = _cross(a, axis_b)
        angle_error = math.atan2(math.sqrt(_dot(c, c)), _dot(a, axis_b))
    elif kind == FIXED or kind == PRISMATIC:
        theta = _orientation_error(f, qa, qb)
        half = 0.5 * math.sqrt(_dot(theta, theta))
        angle_error = 2.0 * math.asin(min(half, 1.0))
    return position, velocity, distance, angle_error


@njit(allocates=False)
def _axes_gap(f, qb, gap):
    """How far a universal or generic joint's anchors are from its locked travels (m)."""
    total = 0.0
    for axis in range(3):
        if axis_state(f, axis) == LOCKED:
            d = rotate(qb, _vector(f, (AXIS_B, NORMAL_B, BINORMAL_B)[axis]))
            total += _dot(gap, d) ** 2
    return math.sqrt(total)


@njit(allocates=False)
def _axes_angle_error(f, qa, qb):
    """How far (rad) a universal or generic joint's orientation is from its locked turns: the
    relative turn (all three locked), the free turn's axes' angle (two), or the Cardan
    pair's angle from square (one)."""
    locked = _axes_in(f, LOCKED, 3)
    if locked == 0:
        return 0.0
    if locked == 3:
        theta = _orientation_error(f, qa, qb)
        return 2.0 * math.asin(min(0.5 * math.sqrt(_dot(theta, theta)), 1.0))
    fb, fa = joint_frames(f, qa, qb)
    if locked == 2:
        turn = _lone_turn(f)
        c = _cross(fa[turn], fb[turn])
        return math.atan2(math.sqrt(_dot(c, c)), _dot(fa[turn], fb[turn]))
    held = 0 if axis_state(f, 3) == LOCKED else (1 if axis_state(f, 4) == LOCKED else 2)
    u, v = _square_pair(fb, fa, held)
    return abs(math.asin(max(-1.0, min(_dot(u, v), 1.0))))


@njit
def read_joints(ints, floats, position, orientation, velocity, angular_velocity):
    """(m, 16) float64: ``joint_readout`` of every joint (``JointSet`` arrays ``ints``,
    ``floats``) in columns 0-3, then a universal or generic joint's six axes' positions and
    rates (``frame_axis_row``; NaN for the other kinds), from the bodies' (>= n, 3)
    positions, (>= n, 4) orientations and (>= n, 3) world velocities and angular
    velocities."""
    out = np.full((len(ints), 16), np.nan)
    zero, identity = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
    for j in range(len(ints)):
        a, b = ints[j, 1], ints[j, 2]
        xa, qa, va, wa = _state(a, position, orientation, velocity, angular_velocity)
        xb, qb, vb, wb = zero, identity, zero, zero
        if b >= 0:
            xb, qb, vb, wb = _state(b, position, orientation, velocity, angular_velocity)
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = joint_readout(
            ints[j, 0], floats[j], xa, qa, va, wa, xb, qb, vb, wb
        )
        if has_axes(ints[j, 0]):
            for axis in range(6):
                lin, ang_a, ang_b, where = frame_axis_row(floats[j], axis, xa, qa, xb, qb)
                out[j, 4 + axis] = where
                out[j, 10 + axis] = (
                    _dot(lin, va) - _dot(lin, vb) + _dot(ang_a, wa) + _dot(ang_b, wb)
                )
    return out


@njit(allocates=False)
def _state(body, position, orientation, velocity, angular_velocity):
    q = orientation[body]
    return (
        _vector(position[body], 0),
        (q[0], q[1], q[2], q[3]),
        _vector(velocity[body], 0),
        _vector(angular_velocity[body], 0),
    )


@njit(allocates=False)
def row_responses(rows, row_joint, count, ints, frozen, orientation, inverse_mass,
                  inverse_inertia_body, moved):  # fmt: skip
    """M^-1 J^T of rows[:count] (row k of joint row_joint[k]) into moved (c, 12): the
    (dx, dtheta) of body a, then of body b, per unit impulse along the row (zero for the
    world and frozen bodies), inverse inertias at the orientations given."""
    for k in range(count):
        j = row_joint[k]
        for side in range(2):
            body = ints[j, BODY_A + side]
            if body < 0 or frozen[body]:
                for c in range(6):
                    moved[k, 6 * side + c] = 0.0
                continue
            q = orientation[body]
            sign = 1.0 if side == 0 else -1.0
            a = rows[k, 3 + 3 * side : 6 + 3 * side]
            turn = angular_velocity(
                (q[0], q[1], q[2], q[3]), (a[0], a[1], a[2]), inverse_inertia_body[body]
            )
            for c in range(3):
                moved[k, 6 * side + c] = sign * inverse_mass[body] * rows[k, c]
                moved[k, 6 * side + 3 + c] = turn[c]


@njit(allocates=False)
def coupling_block(ints, row_joint, rows, moved, first_i, count_i, first_k, count_k, block):
    """block[:count_i, :count_k] <- J_i M^-1 J_k^T for the ``count_i`` rows of one joint from
    ``first_i`` against the ``count_k`` rows of one joint from ``first_k`` (``moved`` from
    ``row_responses``), over the bodies the two joints share, matched once per block."""
    ji, jk = row_joint[first_i], row_joint[first_k]
    for i in range(count_i):
        for k in range(count_k):
            block[i, k] = 0.0
    for side_i in range(2):
        body = ints[ji, BODY_A + side_i]
        if body < 0:
            continue
        sign = 1.0 if side_i == 0 else -1.0
        for side_k in range(2):
            if ints[jk, BODY_A + side_k] != body:
                continue
            # indexed in place, not through row views: this is the Newton matrix's inner loop
            lin, ang, to = 6 * side_k, 6 * side_k + 3, 3 + 3 * side_i
            for i in range(count_i):
                r = first_i + i
                for k in range(count_k):
                    m = first_k + k
                    total = 0.0
                    for c in range(3):
                        total += sign * rows[r, c] * moved[m, lin + c]
                        total += rows[r, to + c] * moved[m, ang + c]
                    block[i, k] += total


@njit(allocates=False)
def coupling_matrix(ints, row_joint, rows, moved, size, K):
    """K[:size, :size] <- J M^-1 J^T of rows[:size] (each joint's rows consecutive), block by
    block (``coupling_block``)."""
    i = 0
    while i < size:
        count_i = _joint_run(row_joint, i, size)
        k = 0
        while k < size:
            count_k = _joint_run(row_joint, k, size)
            coupling_block(ints, row_joint, rows, moved, i, count_i, k, count_k,
                           K[i : i + count_i, k : k + count_k])  # fmt: skip
            k += count_k
        i += count_i


@njit(allocates=False)
def _joint_run(row_joint, first, size):
    """How many rows from ``first`` belong to its joint."""
    end = first + 1
    while end < size and row_joint[end] == row_joint[first]:
        end += 1
    return end - first


@njit
def row_written(rows, k):
    """Whether row k acts (a limit row not reached is written as zero)."""
    for c in range(9):
        if rows[k, c] != 0.0:
            return True
    return False
