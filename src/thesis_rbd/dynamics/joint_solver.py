"""Jointed bodies: integrated by symplectic Euler and held together at the end of each
substep.

The integrator skips jointed bodies; the ``joints`` stage after it moves them instead. An
island that is a fixed-base tree of hinges, sliders and welds is stepped in joint coordinates
(``articulated``) wherever nothing else acts on it; every other island, and that one where
something else does, is stepped here in maximal coordinates, in
``substeps`` equal parts of the step (more where light links carry heavy loads: they vibrate
sideways at w ~ sqrt(3 T / (m l)), and the step must resolve that). Each substep of length h:

* momenta take the forces, P += h F and L += h tau (a body the contact stage solved already
  has its final momenta for the whole step), and the joints' motors, springs, dampers and
  friction act (``joint_motors``);
* positions follow the new momenta, x += h v, q turned freely with L held: symplectic Euler,
  whatever ``World.integrator`` says; the static and kinematic bodies the joints hold to are
  placed where they are at the substep's start and end (a kinematic one moves within the
  step, ``kinematic.place_partners``);
* every joint is put back together by Newton's method on all rows of its island at once, a
  SHAKE-type projection: the correction moves the bodies along M^-1 J^T dlam with the rows'
  directions J taken at the start of the substep, dlam solving K dlam = -C for the errors C
  where the bodies are now; every correction is fed back into the momenta as dlam / h, so
  the velocities are the substep's displacement over h (projecting positions alone loses
  (h w)^2 of the kinetic energy per step, and directions taken at the end of the substep
  lose energy too). Iterations stop once every row holds to 1e-10 of the joint's scale
  (1e-10 rad for angular rows; each iteration gains about two digits, and a tighter bound
  costs an iteration in four for gaps already a million times below any joint's
  tolerance). K = J M^-1 J^T is made and factorised once, where the substep begins
  (``joint_newton``), and serves the motors' solve there and every iterate here (they
  differ from it by the substep's turn); it is made again where a limit is reached or left
  on the way. A factor kept from one substep to the next converges too slowly to pay.

The Newton matrix is factorised as L U with rows of a vanishing pivot dropped
(``joint_tree``): block by block in linear time where the island is a tree, whole where it has
a closed loop, whose redundant rows (a four-bar linkage holds one constraint twice) are then
held by the others instead of making the solve singular.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.dynamics.articulated import AUTO_SUBSTEPS, step_articulated
from thesis_rbd.dynamics.free_rotation import turn_freely
from thesis_rbd.dynamics.integrators import body_forces
from thesis_rbd.dynamics.joint_motors import drive_joints
from thesis_rbd.dynamics.joint_newton import (
    factor,
    factor_at_start,
    island_rows,
    newton_scratch,
    newton_solve,
)
from thesis_rbd.dynamics.joint_rows import row_written
from thesis_rbd.dynamics.joint_set import ARM_A, BODY_A, SCALE
from thesis_rbd.dynamics.kinematic import joint_partners, place_partners
from thesis_rbd.spatial.quaternion import mul, normalize

__all__ = [
    "JOINT_ITERATIONS",
    "MOST_SUBSTEPS",
    "auto_substeps",
    "project_island",
    "step_jointed_bodies",
]

# Most Newton iterations per island and substep (two to four hold the rows to round-off).
JOINT_ITERATIONS = 8
# The largest h w (substep times the stiffest link's sideways frequency) the automatic
# substeps allow: the projection cannot follow a link whose h w nears 1 (a light chain under
# a heavy load diverges there). Half of that: a step the projection cannot hold is taken
# again in more substeps anyway, and a lower bound costs substeps every step for no gain in
# how well the joints hold (the 100-link chain holds to 5e-12 m at 0.4, 0.5 and 0.6).
_STIFF_STEP = 0.5
# Most substeps of a step.
MOST_SUBSTEPS = 64
# Rows hold once |C| is at most this fraction of the joint's scale (or in radians).
_TOLERANCE = 1e-10


@njit
def step_jointed_bodies(
    substeps, dt, count, frozen, solved, ints, floats, joint_start, island_joints, body_start,
    island_bodies, island_tree, neighbour_start, neighbour, fixed_base, parents, sides,
    substep_position, substep_orientation, position, orientation, linear_momentum,
    angular_momentum, inverse_mass, inverse_inertia_body, inertia_body, external_force, drag,
    pf_start, pf_arm, pf_force, save_start, start_position, start_orientation, impulse,
    kinematic_velocity, kinematic_angular_velocity,
):  # fmt: skip
    """Move the jointed bodies over the step, island by island (module docstring), in place.

    Parameters
    ----------
    substeps : int
        Equal parts the step is taken in (>= 1), or 0 for each island's own count
        (``auto_substeps``).
    frozen, solved : (>= n,) bool
        Static or asleep; momenta already final (set by the contact stage).
    ints, floats : (m, 3) int64, (m, JOINT_FLOATS) float64
        ``JointSet`` arrays.
    joint_start, island_joints, body_start, island_bodies, island_tree, neighbour_start, neighbour
        The joints and moving bodies of each island, and how its Newton matrix is solved
        (``JointSet.islands``).
    fixed_base, parents, sides : (k,) bool, (m,), (m,) int64
        The islands that may be stepped in joint coordinates (``articulated``), and each
        joint slot's parent and child there (``JointSet.islands``).
    substep_position, substep_orientation : (>= n, 3), (>= n, 4) float64
        Scratch: where each jointed body began the substep.
    save_start, start_position, start_orientation
        As ``integrate_bodies``: where each body began the step, for the collision stages.
    impulse : (m, 7) float64
        In: each joint's impulse on body a over the last step (the automatic substeps
        follow it); out: over this step (``project_island``, ``drive_joints``; column 6 is
        the motor's along the axis).
    kinematic_velocity, kinematic_angular_velocity : (>= n, 3) float64
        The velocities of the frozen bodies joints hold to (zero but for kinematic ones, which
        the kinematic stage has moved to the end of the step): each substep places them
        where they are at its start and end (``kinematic.place_partners``).
    Other parameters as ``integrate_bodies``.

    Returns
    -------
    int
        The first body whose state went non-finite, or -1.
    """
    for island in range(len(joint_start) - 1):
        joints = island_joints[joint_start[island] : joint_start[island + 1]]
        bodies = island_bodies[body_start[island] : body_start[island + 1]]
        if frozen[bodies[0]]:
            continue  # asleep: islands sleep whole
        for i in bodies:
            if save_start:
                for k in range(3):
                    start_position[i, k] = position[i, k]
                for k in range(4):
                    start_orientation[i, k] = orientation[i, k]
        first, last = joint_start[island], joint_start[island + 1]
        saved = _island_state(bodies, position, orientation, linear_momentum, angular_momentum)
        if fixed_base[island]:
            for j in joints:
                impulse[j, :] = 0.0
            parts = substeps if substeps > 0 else AUTO_SUBSTEPS
            if step_articulated(
                parts, dt, joints, parents[first:last], sides[first:last], ints, floats,
                solved, position, orientation, linear_momentum, angular_momentum, inverse_mass,
                inverse_inertia_body, inertia_body, external_force, drag, pf_start, pf_arm,
                pf_force, impulse, kinematic_velocity, kinematic_angular_velocity,
            ):  # fmt: skip
                bad = _first_non_finite(bodies, position, orientation, linear_momentum,
                                        angular_momentum)  # fmt: skip
                if bad >= 0:
                    return bad
                continue
            # something only the maximal path holds acts this step (a contact, a motor, a
            # limit): the island's step from where it began
            _restore_island(bodies, saved, position, orientation, linear_momentum,
                            angular_momentum)  # fmt: skip
        parts = substeps
        if substeps == 0:
            parts = auto_substeps(dt, joints, ints, floats, inverse_mass, impulse)
        tree = island_tree[island]
        scratch = newton_scratch(
            joints, bodies, ints, floats, neighbour_start[first : last + 1], neighbour, tree
        )
        partners, ends = joint_partners(joints, ints, frozen, position, orientation)
        while True:
            for j in joints:
                impulse[j, :] = 0.0
            held = _substeps(
                parts, dt / parts, joints, bodies, tree, ints, floats, frozen, solved,
                substep_position, substep_orientation, position, orientation, linear_momentum,
                angular_momentum, inverse_mass, inverse_inertia_body, external_force, drag,
                pf_start, pf_arm, pf_force, impulse, scratch, partners, ends, kinematic_velocity,
                kinematic_angular_velocity,
            )  # fmt: skip
            if held or substeps > 0 or parts >= MOST_SUBSTEPS:
                break
            # the projection could not follow the step's motion in so few substeps (the
            # whipping end of a falling chain turns faster within the step than it did at
            # its start): the island's step again, in twice as many
            _restore_island(bodies, saved, position, orientation, linear_momentum, angular_momentum)
            parts = min(2 * parts, MOST_SUBSTEPS)
        bad = _first_non_finite(bodies, position, orientation, linear_momentum, angular_momentum)
        if bad >= 0:
            return bad
    return -1


@njit(allocates=False)
def _first_non_finite(bodies, position, orientation, linear_momentum, angular_momentum):
    """The first of ``bodies`` whose state is not finite, or -1."""
    for i in bodies:
        if not math.isfinite(
            position[i, 0] + position[i, 1] + position[i, 2] + orientation[i, 3]
            + linear_momentum[i, 0] + angular_momentum[i, 0]
        ):  # fmt: skip
            return i
    return -1


@njit
def _substeps(
    parts, h, joints, bodies, tree, ints, floats, frozen, solved, substep_position,
    substep_orientation, position, orientation, linear_momentum, angular_momentum,
    inverse_mass, inverse_inertia_body, external_force, drag, pf_start, pf_arm, pf_force,
    impulse, scratch, partners, ends, kinematic_velocity, kinematic_angular_velocity,
):  # fmt: skip
    """The island's step in ``parts`` substeps of length h (module docstring), its frozen
    joint partners placed where they are at each substep's start and end (``partners``,
    ``ends``: ``kinematic.joint_partners``). Returns whether every projection held its rows
    and every body stayed finite."""
    held = True
    for part in range(parts):
        place_partners(
            partners, ends, (parts - part) * h, (parts - 1 - part) * h, kinematic_velocity,
            kinematic_angular_velocity, substep_position, substep_orientation, position,
            orientation,
        )  # fmt: skip
        for i in bodies:
            _kick(
                i, h, solved, substep_position, substep_orientation, position, orientation,
                linear_momentum, angular_momentum, inverse_mass, inverse_inertia_body,
                external_force, drag, pf_start, pf_arm, pf_force,
            )  # fmt: skip
        factor_at_start(joints, tree, ints, floats, frozen, position, orientation, inverse_mass,
                        inverse_inertia_body, scratch)  # fmt: skip
        drive_joints(
            h, joints, tree, ints, floats, frozen, position, orientation, linear_momentum,
            angular_momentum, inverse_mass, inverse_inertia_body, impulse, kinematic_velocity,
            kinematic_angular_velocity, scratch,
        )  # fmt: skip
        for i in bodies:
            _drift(i, h, position, orientation, linear_momentum, angular_momentum,
                   inverse_mass, inverse_inertia_body)  # fmt: skip
        held &= project_island(
            h, joints, bodies, tree, ints, floats, frozen, position, orientation,
            linear_momentum, angular_momentum, impulse, scratch,
        )  # fmt: skip
    for i in bodies:
        held &= math.isfinite(
            position[i, 0] + position[i, 1] + position[i, 2] + orientation[i, 3]
            + linear_momentum[i, 0] + angular_momentum[i, 0]
        )  # fmt: skip
    return held


@njit
def _island_state(bodies, position, orientation, linear_momentum, angular_momentum):
    """The island's bodies' (x, q, P, L), (b, 13): what a step taken again starts from."""
    saved = np.empty((len(bodies), 13))
    for local in range(len(bodies)):
        i = bodies[local]
        saved[local, 0:3] = position[i]
        saved[local, 3:7] = orientation[i]
        saved[local, 7:10] = linear_momentum[i]
        saved[local, 10:13] = angular_momentum[i]
    return saved


@njit
def _restore_island(bodies, saved, position, orientation, linear_momentum, angular_momentum):
    """``_island_state``'s inverse."""
    for local in range(len(bodies)):
        i = bodies[local]
        position[i] = saved[local, 0:3]
        orientation[i] = saved[local, 3:7]
        linear_momentum[i] = saved[local, 7:10]
        angular_momentum[i] = saved[local, 10:13]


@njit(allocates=False)
def _kick(
    i, h, solved, substep_position, substep_orientation, position, orientation,
    linear_momentum, angular_momentum, inverse_mass, inverse_inertia_body, external_force,
    drag, pf_start, pf_arm, pf_force,
):  # fmt: skip
    """The momentum half of a substep of symplectic Euler for body i (none for a body the
    contact stage solved); its pose kept in the scratch as where the substep began."""
    for k in range(3):
        substep_position[i, k] = position[i, k]
    for k in range(4):
        substep_orientation[i, k] = orientation[i, k]
    if not solved[i]:
        F, T = body_forces(
            i, orientation[i], linear_momentum[i], angular_momentum[i], inverse_mass[i],
            inverse_inertia_body[i], external_force, drag, pf_start, pf_arm, pf_force,
        )  # fmt: skip
        for k in range(3):
            linear_momentum[i, k] += h * F[k]
            angular_momentum[i, k] += h * T[k]


@njit(allocates=False)
def _drift(i, h, position, orientation, linear_momentum, angular_momentum, inverse_mass,
           inverse_inertia_body):  # fmt: skip
    """The position half: x += h v, q turned freely with L held."""
    im = inverse_mass[i]
    q = orientation[i]
    L = angular_momentum[i]
    turned = turn_freely((q[0], q[1], q[2], q[3]), (L[0], L[1], L[2]), inverse_inertia_body[i], h)
    for k in range(3):
        position[i, k] += h * im * linear_momentum[i, k]
    for k in range(4):
        orientation[i, k] = turned[k]


@njit
def auto_substeps(dt, joints, ints, floats, inverse_mass, impulse):
    """Substeps an island needs: a link of mass m and length l pulled with tension T swings
    sideways at w ~ sqrt(3 T / (m l)), and each substep must keep h w within
    ``_STIFF_STEP``. T is the joint's force over the last step; l is twice the anchor's
    distance from the body's centre (at least the body's scale). Motion that outruns this
    within the step (the whipping end of a falling chain) is caught by the projection
    failing to converge, and the island's step is taken again in more substeps
    (``step_jointed_bodies``)."""
    fastest = 0.0
    for j in joints:
        f = impulse[j]
        tension = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) / dt
        for side in range(2):
            body = ints[j, BODY_A + side]
            if body < 0 or inverse_mass[body] == 0.0:
                continue
            arm = floats[j, ARM_A + 3 * side : ARM_A + 3 * side + 3]
            length = max(2.0 * math.sqrt(arm[0] ** 2 + arm[1] ** 2 + arm[2] ** 2), floats[j, SCALE])
            fastest = max(fastest, math.sqrt(3.0 * tension * inverse_mass[body] / length))
    return min(max(math.ceil(dt * fastest / _STIFF_STEP), 1), MOST_SUBSTEPS)


@njit(allocates=False)
def project_island(
    dt, joints, bodies, tree, ints, floats, frozen, position, orientation, linear_momentum,
    angular_momentum, impulse, scratch,
):  # fmt: skip
    """Hold the ``joints`` of one island at the end of a substep of length dt (module
    docstring), in place.

    Parameters
    ----------
    dt : float
    joints : (j,) int64
        The island's joints, in elimination order.
    bodies : (b,) int64
        The island's moving bodies, increasing.
    tree : bool
        Whether the island is a tree (solved by ``joint_tree`` in time linear in its
        joints) or has a loop (solved densely).
    ints, floats : (m, 3) int64, (m, JOINT_FLOATS) float64
        ``JointSet`` arrays.
    frozen : (>= n,) bool
        Static or asleep bodies: immovable here.
    position, orientation, linear_momentum, angular_momentum
        Body arrays (``integrate_bodies``).
    impulse : (m, 6) float64
        Each joint's linear and angular impulse on body a (the latter about a's centre of
        mass), N s and N m s, world frame: this projection's are added.
    scratch : tuple
        ``joint_newton.newton_scratch`` of the island, as ``factor_at_start`` left it where
        the substep began: the rows' directions there (SHAKE), their responses and the
        Newton matrix.

    Returns
    -------
    bool
        Whether the rows hold to the tolerance (False: ``JOINT_ITERATIONS`` did not bring
        them there, or the state is not finite).
    """
    h = dt
    rows, current, row_joint, row_body, moved, _, _, step, spin, _, factored_rows = scratch
    size = rows.shape[0]
    held = False
    for _ in range(JOINT_ITERATIONS):
        # the errors where the bodies are now
        island_rows(joints, ints, floats, position, orientation, current, row_joint, True)
        worst = 0.0
        for k in range(size):
            j = row_joint[k]
            linear = rows[k, 0] != 0.0 or rows[k, 1] != 0.0 or rows[k, 2] != 0.0
            scale = floats[j, SCALE] if linear else 1.0
            worst = max(worst, abs(current[k, 9]) / scale)
            step[k] = -current[k, 9]
        if worst <= _TOLERANCE:
            held = True
            break
        # Newton on the impulses, with the matrix of the substep's start (the iterates move
        # by the substep's turn from it), made again where a limit was reached or left on
        # the way: its row then joins or leaves the matrix
        for k in range(size):
            if row_written(current, k) != factored_rows[k]:
                factor(tree, ints, scratch)
                break
        newton_solve(tree, scratch, step.reshape((size, 1)))
        # the rows' turns summed per body before any is applied: they cancel in large part
        # (a point row turns a light ball about its centre as much as its limit row turns
        # it back), which turning row by row would not do
        spin[:] = 0.0
        for k in range(size):
            lam = step[k]
            j = row_joint[k]
            for side in range(2):
                body = ints[j, BODY_A + side]
                if body < 0 or frozen[body]:
                    continue
                sign = 1.0 if side == 0 else -1.0
                local = row_body[k, side]
                for c in range(3):
                    spin[local, c] += lam * moved[k, 6 * side + 3 + c]
                    position[body, c] += lam * moved[k, 6 * side + c]
                    linear_momentum[body, c] += sign * rows[k, c] * lam / h
                    angular_momentum[body, c] += rows[k, 3 + 3 * side + c] * lam / h
            for c in range(3):
                impulse[j, c] += rows[k, c] * lam / h
                impulse[j, 3 + c] += rows[k, 3 + c] * lam / h
        for local in range(len(bodies)):
            _turn(orientation, bodies[local], spin[local])
    return held


@njit(allocates=False)
def _turn(orientation, body, theta):
    """Turn body's orientation by the world rotation vector theta (exactly)."""
    angle = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    if angle == 0.0:
        return
    s = math.sin(0.5 * angle) / angle
    turn = (s * theta[0], s * theta[1], s * theta[2], math.cos(0.5 * angle))
    q = orientation[body]
    turned = normalize(mul(turn, (q[0], q[1], q[2], q[3])))
    for c in range(4):
        orientation[body, c] = turned[c]
