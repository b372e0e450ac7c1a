"""Fixed-base trees of hinges, sliders and welds stepped in joint coordinates, by
Featherstone's articulated-body algorithm (Featherstone, "Rigid Body Dynamics Algorithms",
2008, ch. 7).

An island whose joints are revolute, prismatic or fixed, and which hangs from the ground (the
world or a static body) by one of them, has one joint coordinate per hinge or slider and no
other freedom. Where nothing but forces, set torques, joint damping and limits act on it (no
contact solved its bodies this step, no velocity, position or servo motor, no joint
friction, its ground standing still), the ``joints`` stage steps it here instead of holding
its maximal coordinates together (``joint_solver``); anything else sends that step to the
maximal path, from the same state. Both paths kick momenta and then drift positions, this
one in the joint positions q and their generalised momenta p = S^T h (S: a joint's motion per
unit rate, h: the spatial momentum of the links beyond it), the maximal path in the bodies'
poses and momenta. Each keeps the momenta no force changes (under gravity, an arm's angular
momentum about a vertical base hinge), which sets where a mechanism's free directions drift
to: integrating the rates instead (pybullet's multibody does) lets a limit's impact leave the
base turning at the wrong rate ever after.

Each substep of length h, from the bodies' state:

* q and p are read from the bodies' poses and momenta (a hinge's angle, a slider's travel;
  p = S^T h from the bodies' own momenta, so a velocity set on one link moves the mechanism
  as the maximal path's projection moves it);
* a kick: p+ = p + h (tau + S^T (f - v x* h)) for each joint's subtree's applied force f
  (the integrators' force model: external forces, drag, point forces), less its damping
  -h d qdot+ at the drift's rate qdot+ = M(q)^-1 p+ (implicit: no damping is too strong for
  the step, where a light wrist's explicit damping diverges once h d / I > 2). The velocity
  term v x* h is taken where the substep begins: taking it at qdot+ instead (symplectic
  Euler proper, by fixed-point passes) costs a pass and, on the iiwa's fall (report section
  25), strays further from the converged path. The articulated-body algorithm factors
  M + h D once and solves with it in two O(n) passes;
* a joint the drift would carry past a limit is held on it by an impulse along it, with
  the others' response to it exact (a projected Gauss-Seidel on the small matrix of the
  limited joints' columns of (M + h D)^-1): a limit holds rigidly and inelastically, as the
  maximal path's limit row does;
* a drift, q += h qdot+, places the links from the ground out (which puts every anchor back
  together exactly), and their velocities are those of p+ there, qdot = M(q+)^-1 p+.

Spatial vectors are Plücker coordinates in the world frame about an origin O at the root
link's centre of mass (world coordinates near the mechanism, so a robot far from the world's
origin loses no precision): a motion is (w, v_O), a force (n_O, f). Each joint's impulse over
the step (what its subtree's momentum gained less what the applied forces gave it) is added to
its impulses, so ``World.joints`` reads the forces the maximal path would report.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision._vec3 import cross, dot
from thesis_rbd.dynamics.contact_kinematics import world_tensor
from thesis_rbd.dynamics.integrators import angular_velocity, body_forces
from thesis_rbd.dynamics.joint_rows import (
    FIXED,
    PRISMATIC,
    REVOLUTE,
    body_pose,
    joint_readout,
    limit_band,
)
from thesis_rbd.dynamics.joint_set import (
    ARM_A,
    ARM_B,
    AXIS_B,
    BODY_A,
    BODY_B,
    DAMPING,
    FRICTION,
    KIND,
    LOWER,
    MOTOR,
    MOTOR_TARGET,
    NO_MOTOR,
    RELATIVE_ORIENTATION,
    TORQUE_MOTOR,
    UPPER,
)
from thesis_rbd.spatial.quaternion import conjugate, mul, normalize, rotate

__all__ = ["AUTO_SUBSTEPS", "step_articulated"]

# Columns of the per-joint scratch: position q and rate qdot as the bodies have them, the
# drift's rate, the generalised momentum p = S^T h (h: the subtree's spatial momentum), the
# right-hand side of a solve, the joint's force (dp/dt less its damping), the armature the
# solve adds (h d for the kick, 0 for the velocities), the algorithm's D, the limit's
# impulse, a unit vector to solve for, and a solve's result.
_Q, _QD, _RATE, _P, _RHS, _FORCE, _ARMATURE, _DIVISOR, _LIMIT, _UNIT, _SOLVED = range(11)
_COLUMNS = 11
# Substeps of a step where the world's joint_substeps is "auto". The scheme is first order,
# and a step in two parts halves its error for twice the (small) cost: what brings the
# cart-pole of MuJoCo's examples within twice MuJoCo's own error at dt = 1/240
# (tests/test_mjcf.py), where one part does not.
AUTO_SUBSTEPS = 2
# Most sweeps of the limits' projected Gauss-Seidel (their matrix is exact and small: one
# limit converges in one sweep, a few in tens).
_LIMIT_SWEEPS = 100


@njit
def step_articulated(
    parts, dt, joints, parents, sides, ints, floats, solved, position, orientation,
    linear_momentum, angular_momentum, inverse_mass, inverse_inertia_body, inertia_body,
    external_force, drag, pf_start, pf_arm, pf_force, impulse, kinematic_velocity,
    kinematic_angular_velocity,
):  # fmt: skip
    """Step one fixed-base tree island over dt in ``parts`` substeps (module docstring), in
    place, where it can be.

    Parameters
    ----------
    parts : int
        Substeps (>= 1).
    dt : float
        The step (s).
    joints : (j,) int64
        The island's joints in elimination order: every joint before its parent joint.
    parents : (j,) int64
        Each joint's parent joint, as a position in ``joints`` (-1: the joint to the ground).
    sides : (j,) int64
        Which of each joint's bodies is its child, farther from the ground: 0 for body a, 1
        for body b.
    ints, floats : ``JointSet`` arrays.
    solved : (>= n,) bool
        Bodies whose momenta the contact stage already set for the step.
    position ... pf_force
        The body arrays and the step's forces, as ``integrate_bodies`` takes them;
        ``inertia_body`` (>= n, 3, 3) is I_body.
    impulse : (m, 7) float64
        Each joint's impulses over the step on body a (``step_jointed_bodies``): added to.
    kinematic_velocity, kinematic_angular_velocity : (>= n, 3) float64
        A ground that moves (a kinematic body) sends the island to the maximal path.

    Returns
    -------
    bool
        Whether the island was stepped here. False: it needs the maximal path this step, and
        a substep may have been taken already (the caller puts the island's state back).
    """
    if not _drivable(joints, parents, sides, ints, floats, solved, kinematic_velocity,
                     kinematic_angular_velocity):  # fmt: skip
        return False
    n = len(joints)
    motion = np.empty((n, 6))  # S: the child's motion relative to its parent per unit rate
    rigid = np.empty((n, 6, 6))  # each child link's spatial inertia
    applied = np.empty((n, 6))  # the forces on its subtree
    velocity = np.empty((n, 6))  # its spatial velocity
    start = np.empty((n, 6))  # its subtree's spatial momentum where the substep begins
    momentum = np.empty((n, 6))  # ... where it ends
    inertia = np.empty((n, 6, 6))  # I^A: each subtree's articulated inertia
    response = np.empty((n, 6))  # U = I^A S
    pushed = np.empty((n, 6))  # a solve's scratch
    joint = np.empty((n, _COLUMNS))
    responses = np.empty((n, n))  # columns of (M + h D)^-1 for the joints at a limit
    engaged = np.empty(n, np.int64)  # those joints
    bounds = np.empty((n, 3))  # their bounds on the rate, sides, impulses
    rotation = np.empty((3, 3))
    h = dt / parts
    for _ in range(parts):
        root = _child(joints[n - 1], sides[n - 1], ints)
        origin = (position[root, 0], position[root, 1], position[root, 2])
        _read_joints(
            joints, sides, ints, floats, origin, position, orientation, linear_momentum,
            angular_momentum, inverse_mass, inverse_inertia_body, motion, joint,
        )  # fmt: skip
        _rigid_inertias(joints, sides, ints, origin, position, orientation, inertia_body,
                        inverse_mass, rigid, rotation)  # fmt: skip
        _applied_forces(
            joints, parents, sides, ints, origin, position, orientation, linear_momentum,
            angular_momentum, inverse_mass, inverse_inertia_body, external_force, drag,
            pf_start, pf_arm, pf_force, applied,
        )  # fmt: skip
        _velocities(joints, parents, motion, joint, _QD, velocity)
        _body_momenta(joints, parents, sides, ints, origin, position, linear_momentum,
                      angular_momentum, start)  # fmt: skip
        for e in range(n):
            j = joints[e]
            joint[e, _P] = _dot6(motion[e], start[e])
            joint[e, _ARMATURE] = h * floats[j, DAMPING] if ints[j, KIND] != FIXED else 0.0
        _factor(joints, parents, ints, motion, rigid, inertia, response, joint)
        # the kick: (M + h D) qdot+ = p + h f(q, qdot), the velocity terms at the rates the
        # substep begins with
        _joint_forces(joints, floats, motion, velocity, start, applied, joint)
        for e in range(n):
            joint[e, _RHS] = joint[e, _P] + h * joint[e, _FORCE]
        _solve(joints, parents, ints, motion, response, joint, _RHS, _RATE, pushed, velocity)
        _hold_limits(h, joints, parents, ints, floats, motion, response, joint, pushed,
                     velocity, responses, engaged, bounds)  # fmt: skip
        for e in range(n):
            j = joints[e]
            # the momentum after the kick: its forces, its damping at the drift's rate, and
            # the limit's impulse
            joint[e, _P] = joint[e, _RHS] - joint[e, _ARMATURE] * joint[e, _RATE] + joint[e, _LIMIT]
            joint[e, _Q] += h * joint[e, _RATE]
            if not _within_limits(ints[j, KIND], floats[j], joint[e, _Q]):
                return False
        _place_links(joints, sides, ints, floats, position, orientation, joint)
        # the rates of the new momenta where the links now are: qdot = M(q+)^-1 p+
        _read_motion(joints, sides, ints, floats, origin, position, orientation, motion)
        _rigid_inertias(joints, sides, ints, origin, position, orientation, inertia_body,
                        inverse_mass, rigid, rotation)  # fmt: skip
        for e in range(n):
            joint[e, _ARMATURE] = 0.0
        _factor(joints, parents, ints, motion, rigid, inertia, response, joint)
        _solve(joints, parents, ints, motion, response, joint, _P, _QD, pushed, velocity)
        _velocities(joints, parents, motion, joint, _QD, velocity)
        _link_momenta(joints, rigid, velocity, momentum)
        _set_momenta(joints, sides, ints, origin, position, momentum, linear_momentum,
                     angular_momentum)  # fmt: skip
        _sum_subtrees(joints, parents, momentum)
        _record_impulses(h, joints, sides, ints, floats, origin, position, start, momentum,
                         applied, impulse)  # fmt: skip
    return True


@njit(allocates=False)
def _drivable(joints, parents, sides, ints, floats, solved, kinematic_velocity,
              kinematic_angular_velocity):  # fmt: skip
    """Whether nothing but forces, set torques and damping act on the island this step, and
    its ground stands still."""
    for e in range(len(joints)):
        j = joints[e]
        f = floats[j]
        code = int(f[MOTOR])
        if code != NO_MOTOR and code != TORQUE_MOTOR:
            return False
        if f[FRICTION] > 0.0 or solved[_child(j, sides[e], ints)]:
            return False
        ground = _parent(j, sides[e], ints)
        if parents[e] < 0 and ground >= 0:
            for k in range(3):
                if kinematic_velocity[ground, k] != 0.0:
                    return False
                if kinematic_angular_velocity[ground, k] != 0.0:
                    return False
    return True


@njit(allocates=False)
def _child(j, side, ints):
    """Joint j's body farther from the ground."""
    return ints[j, BODY_A] if side == 0 else ints[j, BODY_B]


@njit(allocates=False)
def _parent(j, side, ints):
    """Joint j's body nearer the ground (-1: the world)."""
    return ints[j, BODY_B] if side == 0 else ints[j, BODY_A]


@njit(allocates=False)
def _offset(position, i, origin):
    """Body i's centre of mass relative to the origin."""
    return (position[i, 0] - origin[0], position[i, 1] - origin[1], position[i, 2] - origin[2])


@njit(allocates=False)
def _vector(f, start):
    return (f[start], f[start + 1], f[start + 2])


@njit(allocates=False)
def _torque(j, floats):
    """The set torque (N m) or force (N) along joint j's axis: its torque motor's, or 0."""
    return floats[j, MOTOR_TARGET] if int(floats[j, MOTOR]) == TORQUE_MOTOR else 0.0


@njit(allocates=False)
def _body_velocity(body, orientation, linear_momentum, angular_momentum, inverse_mass,
                   inverse_inertia_body):  # fmt: skip
    """(v, w) of a body's centre of mass (zero for the world and static bodies)."""
    if body < 0 or inverse_mass[body] == 0.0:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    P, L, q = linear_momentum[body], angular_momentum[body], orientation[body]
    im = inverse_mass[body]
    w = angular_velocity((q[0], q[1], q[2], q[3]), (L[0], L[1], L[2]), inverse_inertia_body[body])
    return (im * P[0], im * P[1], im * P[2]), w


@njit(allocates=False)
def _joint_motion(kind, side, f, xa, qa, xb, qb, origin, out):
    """Write S (6,) of a joint at the poses given: its child's spatial velocity relative to
    its parent's per unit rate (zero for a weld)."""
    sign = 1.0 if side == 0 else -1.0
    axis = rotate(qb, _vector(f, AXIS_B))
    for k in range(6):
        out[k] = 0.0
    if kind == REVOLUTE:  # a turn about the anchor, taken on the parent
        if side == 0:
            x, arm = xb, rotate(qb, _vector(f, ARM_B))
        else:
            x, arm = xa, rotate(qa, _vector(f, ARM_A))
        anchor = (x[0] + arm[0] - origin[0], x[1] + arm[1] - origin[1], x[2] + arm[2] - origin[2])
        moment = cross(anchor, axis)
        for k in range(3):
            out[k] = sign * axis[k]
            out[3 + k] = sign * moment[k]
    elif kind == PRISMATIC:
        for k in range(3):
            out[3 + k] = sign * axis[k]


@njit(allocates=False)
def _read_joints(joints, sides, ints, floats, origin, position, orientation, linear_momentum,
                 angular_momentum, inverse_mass, inverse_inertia_body, motion, joint):  # fmt: skip
    """Each joint's S, and its position and rate as its bodies have them."""
    for e in range(len(joints)):
        j = joints[e]
        a, b = ints[j, BODY_A], ints[j, BODY_B]
        xa, qa = body_pose(a, position, orientation)
        xb, qb = body_pose(b, position, orientation)
        va, wa = _body_velocity(a, orientation, linear_momentum, angular_momentum, inverse_mass,
                                inverse_inertia_body)  # fmt: skip
        vb, wb = _body_velocity(b, orientation, linear_momentum, angular_momentum, inverse_mass,
                                inverse_inertia_body)  # fmt: skip
        kind = ints[j, KIND]
        _joint_motion(kind, sides[e], floats[j], xa, qa, xb, qb, origin, motion[e])
        # a hinge's angle and rate, a slider's travel and speed (zero for a weld)
        readout = joint_readout(kind, floats[j], xa, qa, va, wa, xb, qb, vb, wb)
        joint[e, _Q], joint[e, _QD] = readout[0], readout[1]


@njit(allocates=False)
def _read_motion(joints, sides, ints, floats, origin, position, orientation, motion):
    """Each joint's S where its bodies are now."""
    for e in range(len(joints)):
        j = joints[e]
        xa, qa = body_pose(ints[j, BODY_A], position, orientation)
        xb, qb = body_pose(ints[j, BODY_B], position, orientation)
        _joint_motion(ints[j, KIND], sides[e], floats[j], xa, qa, xb, qb, origin, motion[e])


@njit(allocates=False)
def _velocities(joints, parents, motion, joint, column, velocity):
    """Every link's spatial velocity at the rates ``joint[:, column]``, from the ground out:
    v = v_parent + S qdot."""
    for e in range(len(joints) - 1, -1, -1):
        rate = joint[e, column]
        parent = parents[e]
        for k in range(6):
            velocity[e, k] = motion[e, k] * rate + (velocity[parent, k] if parent >= 0 else 0.0)


@njit(allocates=False)
def _rigid_inertias(joints, sides, ints, origin, position, orientation, inertia_body,
                    inverse_mass, rigid, rotation):  # fmt: skip
    """Each child link's spatial inertia about the origin (``rigid`` (n, 6, 6))."""
    for e in range(len(joints)):
        i = _child(joints[e], sides[e], ints)
        m = 1.0 / inverse_mass[i]
        r = _offset(position, i, origin)
        spatial = rigid[e]
        # [[I_c + m (r.r 1 - r r^T), m [r]x], [m [r]x^T, m 1]]
        world_tensor(orientation[i], inertia_body[i], rotation, spatial)
        rr = dot(r, r)
        skew = ((0.0, -r[2], r[1]), (r[2], 0.0, -r[0]), (-r[1], r[0], 0.0))
        for a in range(3):
            for c in range(3):
                spatial[a, c] += m * ((rr if a == c else 0.0) - r[a] * r[c])
                spatial[a, 3 + c] = m * skew[a][c]
                spatial[3 + a, c] = m * skew[c][a]
                spatial[3 + a, 3 + c] = m if a == c else 0.0


@njit(allocates=False)
def _applied_forces(joints, parents, sides, ints, origin, position, orientation, linear_momentum,
                    angular_momentum, inverse_mass, inverse_inertia_body, external_force, drag,
                    pf_start, pf_arm, pf_force, applied):  # fmt: skip
    """The forces on each joint's subtree, (n_O, f) summed over its links (the integrators'
    force model: external forces, drag, point forces)."""
    for e in range(len(joints)):
        i = _child(joints[e], sides[e], ints)
        F, T = body_forces(
            i, orientation[i], linear_momentum[i], angular_momentum[i], inverse_mass[i],
            inverse_inertia_body[i], external_force, drag, pf_start, pf_arm, pf_force,
        )  # fmt: skip
        r = _offset(position, i, origin)
        moment = cross(r, F)
        for k in range(3):
            applied[e, k] = T[k] + moment[k]
            applied[e, 3 + k] = F[k]
    _sum_subtrees(joints, parents, applied)


@njit(allocates=False)
def _sum_subtrees(joints, parents, values):
    """values[e] (n, 6) <- its sum over joint e's subtree (leaves in)."""
    for e in range(len(joints)):
        parent = parents[e]
        if parent >= 0:
            for k in range(6):
                values[parent, k] += values[e, k]


@njit(allocates=False)
def _body_momenta(joints, parents, sides, ints, origin, position, linear_momentum,
                  angular_momentum, momentum):  # fmt: skip
    """Each subtree's spatial momentum (n_O, p) as its bodies have it: p = S^T h is then the
    momentum the maximal path's projection would keep, where the bodies' velocities do not
    quite fit the joints (a velocity set on one link)."""
    for e in range(len(joints)):
        i = _child(joints[e], sides[e], ints)
        P, L = linear_momentum[i], angular_momentum[i]
        r = _offset(position, i, origin)
        moment = cross(r, (P[0], P[1], P[2]))
        for k in range(3):
            momentum[e, k] = L[k] + moment[k]
            momentum[e, 3 + k] = P[k]
    _sum_subtrees(joints, parents, momentum)


@njit(allocates=False)
def _link_momenta(joints, rigid, velocity, momentum):
    """Each link's own spatial momentum I v (n_O, p)."""
    for e in range(len(joints)):
        for a in range(6):
            total = 0.0
            for c in range(6):
                total += rigid[e, a, c] * velocity[e, c]
            momentum[e, a] = total


@njit(allocates=False)
def _joint_forces(joints, floats, motion, velocity, momentum, applied, joint):
    """Each joint's generalised force but its damping, dp/dt = tau + S^T (f - v x* h) for its
    subtree's applied force f and momentum h (S turns with the link at v, S' = v x S, and
    S'^T h = -S^T (v x* h)), into ``joint[:, _FORCE]``."""
    for e in range(len(joints)):
        v, h = velocity[e], momentum[e]
        w, vo = (v[0], v[1], v[2]), (v[3], v[4], v[5])
        n, p = (h[0], h[1], h[2]), (h[3], h[4], h[5])
        # v x* h = (w x n + v_O x p, w x p)
        spin, drift, turn = cross(w, n), cross(vo, p), cross(w, p)
        S, f = motion[e], applied[e]
        total = _torque(joints[e], floats)
        for k in range(3):
            total += S[k] * (f[k] - spin[k] - drift[k]) + S[3 + k] * (f[3 + k] - turn[k])
        joint[e, _FORCE] = total


@njit(allocates=False)
def _factor(joints, parents, ints, motion, rigid, inertia, response, joint):
    """The articulated-body algorithm's factor of M + diag(``joint[:, _ARMATURE]``): each
    subtree's articulated inertia I^A, U = I^A S and D = S^T U + armature, leaves in
    (I^A_parent gains I^A - U U^T / D)."""
    for e in range(len(joints)):
        for a in range(6):
            for c in range(6):
                inertia[e, a, c] = rigid[e, a, c]
    for e in range(len(joints)):
        S, IA, U = motion[e], inertia[e], response[e]
        moves = ints[joints[e], KIND] != FIXED
        for r in range(6):
            total = 0.0
            for c in range(6):
                total += IA[r, c] * S[c]
            U[r] = total if moves else 0.0
        D = _dot6(S, U) + joint[e, _ARMATURE] if moves else 1.0
        joint[e, _DIVISOR] = D
        parent = parents[e]
        if parent >= 0:
            for r in range(6):
                for k in range(6):
                    inertia[parent, r, k] += IA[r, k] - U[r] * U[k] / D


@njit(allocates=False)
def _solve(joints, parents, ints, motion, response, joint, column, target, pushed,
           accelerations):  # fmt: skip
    """``joint[:, target]`` <- (M + diag(armature))^-1 ``joint[:, column]``, with
    ``_factor``'s factor: the algorithm's two passes with the column as joint forces and no
    velocity (``pushed``, ``accelerations`` (n, 6): scratch)."""
    n = len(joints)
    for e in range(n):
        for r in range(6):
            pushed[e, r] = 0.0
    for e in range(n):  # leaves in: what reaches each joint from the forces below it
        u = joint[e, column] - _dot6(motion[e], pushed[e])
        joint[e, target] = u
        parent = parents[e]
        if parent >= 0:
            D = joint[e, _DIVISOR]
            for r in range(6):
                pushed[parent, r] += pushed[e, r] + response[e, r] * u / D
    for e in range(n - 1, -1, -1):
        parent = parents[e]
        a = accelerations[e]
        for r in range(6):
            a[r] = accelerations[parent, r] if parent >= 0 else 0.0
        x = 0.0
        if ints[joints[e], KIND] != FIXED:
            x = (joint[e, target] - _dot6(response[e], a)) / joint[e, _DIVISOR]
        joint[e, target] = x
        for r in range(6):
            a[r] += motion[e, r] * x


@njit(allocates=False)
def _hold_limits(h, joints, parents, ints, floats, motion, response, joint, pushed,
                 accelerations, responses, engaged, bounds):  # fmt: skip
    """Keep the joints the drift would carry past a limit on it (as the maximal path's limit
    rows do): impulses lam along them, pushing only away from the limit, with drift rates
    qdot+ + W lam for W = (M + h D)^-1 (columns by ``_solve``) that end the drift on the
    limit or inside it, by projected Gauss-Seidel on the small exact W. Adds W lam to
    ``joint[:, _RATE]`` and writes lam into ``joint[:, _LIMIT]``.

    ``pushed``, ``accelerations`` (n, 6), ``responses`` (n, n), ``engaged`` (n,) and
    ``bounds`` (n, 3) are scratch.
    """
    n = len(joints)
    count = 0
    for e in range(n):
        joint[e, _LIMIT] = 0.0
        j = joints[e]
        kind = ints[j, KIND]
        if kind == FIXED:
            continue
        f = floats[j]
        band = limit_band(kind, f)
        free = joint[e, _Q] + h * joint[e, _RATE]
        if free < f[LOWER] + band or free > f[UPPER] - band:
            engaged[count] = e
            count += 1
    if count == 0:
        return
    for c in range(count):
        _unit_solve(engaged[c], joints, parents, ints, motion, response, joint, pushed,
                    accelerations, responses[c])  # fmt: skip
    # each engaged joint's bound on its rate, its side (+1: a lower limit, lam >= 0), lam
    bound, side, lam = bounds[:, 0], bounds[:, 1], bounds[:, 2]
    scale = 0.0
    for c in range(count):
        e = engaged[c]
        f = floats[joints[e]]
        free = joint[e, _Q] + h * joint[e, _RATE]
        lower = abs(free - f[LOWER]) < abs(free - f[UPPER])
        side[c] = 1.0 if lower else -1.0
        lam[c] = 0.0
        bound[c] = ((f[LOWER] if lower else f[UPPER]) - joint[e, _Q]) / h
        scale = max(scale, abs(bound[c]), abs(joint[e, _RATE]))
    for _ in range(_LIMIT_SWEEPS):
        largest = 0.0
        for c in range(count):
            e = engaged[c]
            now = joint[e, _RATE]
            for d in range(count):
                now += responses[d, e] * lam[d]
            wanted = lam[c] + (bound[c] - now) / responses[c, e]
            wanted = max(wanted, 0.0) if side[c] > 0.0 else min(wanted, 0.0)
            largest = max(largest, abs(wanted - lam[c]) * responses[c, e])
            lam[c] = wanted
        if largest <= 1e-13 * scale:
            break
    for c in range(count):
        joint[engaged[c], _LIMIT] = lam[c]
        for e in range(n):
            joint[e, _RATE] += responses[c, e] * lam[c]


@njit(allocates=False)
def _unit_solve(k, joints, parents, ints, motion, response, joint, pushed, accelerations, out):
    """out (n,) <- column k of (M + diag(armature))^-1: the rates per unit impulse at joint
    k (``_solve`` of a unit vector in ``joint[:, _UNIT]``)."""
    for e in range(len(joints)):
        joint[e, _UNIT] = 1.0 if e == k else 0.0
    _solve(joints, parents, ints, motion, response, joint, _UNIT, _SOLVED, pushed,
           accelerations)  # fmt: skip
    for e in range(len(joints)):
        out[e] = joint[e, _SOLVED]


@njit(allocates=False)
def _dot6(u, v):
    total = 0.0
    for k in range(6):
        total += u[k] * v[k]
    return total


@njit(allocates=False)
def _place_links(joints, sides, ints, floats, position, orientation, joint):
    """Place every link from the ground out at its joint's position ``joint[:, _Q]``, its
    anchor on its parent's."""
    for e in range(len(joints) - 1, -1, -1):
        j = joints[e]
        f = floats[j]
        kind = ints[j, KIND]
        q = joint[e, _Q]
        relative = (f[RELATIVE_ORIENTATION], f[RELATIVE_ORIENTATION + 1],
                    f[RELATIVE_ORIENTATION + 2], f[RELATIVE_ORIENTATION + 3])  # fmt: skip
        axis_b = _vector(f, AXIS_B)
        if kind == REVOLUTE:  # conj(q_b) q_a = turn(axis_b, q) q_0 (joint_rows._hinge_angle)
            s = math.sin(0.5 * q)
            relative = mul((s * axis_b[0], s * axis_b[1], s * axis_b[2], math.cos(0.5 * q)),
                           relative)  # fmt: skip
        travel = q if kind == PRISMATIC else 0.0
        x, turn = body_pose(_parent(j, sides[e], ints), position, orientation)
        if sides[e] == 0:  # b is the parent: a's anchor on b's, moved along b's axis
            child = ints[j, BODY_A]
            placed = normalize(mul(turn, relative))
            arm, slide = rotate(turn, _vector(f, ARM_B)), rotate(turn, axis_b)
            own = rotate(placed, _vector(f, ARM_A))
        else:
            child = ints[j, BODY_B]
            placed = normalize(mul(turn, conjugate(relative)))
            arm, slide = rotate(turn, _vector(f, ARM_A)), rotate(placed, axis_b)
            own = rotate(placed, _vector(f, ARM_B))
            travel = -travel
        for k in range(3):
            position[child, k] = x[k] + arm[k] + travel * slide[k] - own[k]
        for k in range(4):
            orientation[child, k] = placed[k]


@njit(allocates=False)
def _set_momenta(joints, sides, ints, origin, position, momentum, linear_momentum,
                 angular_momentum):  # fmt: skip
    """Each link's momenta from its spatial momentum (n_O, p) (``_link_momenta``): P = p,
    L = n_O - r x p about its centre of mass."""
    for e in range(len(joints)):
        i = _child(joints[e], sides[e], ints)
        h = momentum[e]
        p = (h[3], h[4], h[5])
        moment = cross(_offset(position, i, origin), p)
        for k in range(3):
            linear_momentum[i, k] = p[k]
            angular_momentum[i, k] = h[k] - moment[k]


@njit(allocates=False)
def _record_impulses(h, joints, sides, ints, floats, origin, position, start, momentum,
                     applied, impulse):  # fmt: skip
    """Add each joint's impulse over the substep to its impulses on body a: what its subtree
    gained, less what the applied forces gave it (its parent gave the rest through the
    joint), as a force and a torque about a's centre of mass, and the set torque along the
    axis."""
    for e in range(len(joints)):
        j = joints[e]
        sign = 1.0 if sides[e] == 0 else -1.0
        n = (momentum[e, 0] - start[e, 0] - h * applied[e, 0],
             momentum[e, 1] - start[e, 1] - h * applied[e, 1],
             momentum[e, 2] - start[e, 2] - h * applied[e, 2])  # fmt: skip
        F = (momentum[e, 3] - start[e, 3] - h * applied[e, 3],
             momentum[e, 4] - start[e, 4] - h * applied[e, 4],
             momentum[e, 5] - start[e, 5] - h * applied[e, 5])  # fmt: skip
        a = ints[j, BODY_A]
        lever = cross(_offset(position, a, origin), F)
        for k in range(3):
            impulse[j, k] += sign * F[k]
            impulse[j, 3 + k] += sign * (n[k] - lever[k])
        impulse[j, 6] += h * _torque(j, floats)


@njit(allocates=False)
def _within_limits(kind, f, q):
    """Whether a joint at position q is within its limits (up to the band in which the
    maximal path's limit row leaves it, ``joint_rows.limit_band``)."""
    if kind == FIXED:
        return True
    band = limit_band(kind, f)
    return f[LOWER] - band <= q <= f[UPPER] + band
