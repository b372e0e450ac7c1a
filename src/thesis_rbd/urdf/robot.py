"""A loaded URDF model's joint-space view: its bodies by link, its movable joints, their
state read and set, and motor targets or torques on them (pybullet's getJointState,
resetJointState and setJointMotorControl2). Joints are named by index (URDF order of the
movable joints) or by their URDF names."""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd.spatial.quaternion import quat_conjugate, quat_multiply, quat_rotate

__all__ = ["Robot"]


class Robot:
    """The bodies and movable joints ``load_urdf`` added to a world.

    Attributes
    ----------
    world : World
    name : str
        The URDF ``<robot name>``.
    bodies : dict of str to int
        The body index of every link; links welded into one body (fixed joints merged) map
        to the same index.
    joints : list of int
        World joint indices of the movable joints (revolute, continuous, prismatic, planar),
        in URDF order.
    joint_names : list of str
        Their URDF names, in the same order.
    effort_limits, velocity_limits : (k,) ndarray
        Each movable joint's URDF ``<limit effort velocity>`` (N m or N, rad/s or m/s); inf
        where the file gives none (or zero, which URDF uses for "not set").
    tree_joints : list of int
        Every world joint the model added (its fixed joints too), each after the joint that
        holds its parent link.
    mimics : dict of str to (str, float, float)
        Each URDF mimic joint's leader, multiplier and offset: a mimic joint is a movable
        joint of its own, whose position, rate and targets the methods here set from its
        leader's (``multiplier * leader + offset``; rates ``multiplier * leader``), whatever an
        array gives for it; a dict naming it is refused.

    Every method taking one value per joint takes an array in ``joint_names`` order, or a
    dict from joint names (or indices) to values that sets only those joints.
    """

    def __init__(
        self, world, name, bodies, joints, joint_names, effort_limits, velocity_limits,
        tree_joints, mimics=None, offsets=None,
    ):  # fmt: skip
        # each tree joint's child orientation relative to its parent's in the URDF's zero
        # configuration, where the model is loaded (q_child = q_parent q_rest)
        frames = world.joint_frames
        self._rest = {}
        for j in tree_joints:
            child, parent = frames["bodies"][j]
            if parent >= 0:
                self._rest[j] = quat_multiply(
                    quat_conjugate(world.orientation(parent)), world.orientation(child)
                )
        self.world = world
        self.name = name
        self.bodies = dict(bodies)
        self.joints = list(joints)
        self.joint_names = list(joint_names)
        self.effort_limits = np.asarray(effort_limits, dtype=float)
        self.velocity_limits = np.asarray(velocity_limits, dtype=float)
        self.tree_joints = list(tree_joints)
        self.mimics = dict(mimics or {})
        # each joint's URDF position where its world joint reads zero (a hinge whose limits
        # reach past +-pi has its world zero mid-range); the methods here speak URDF's terms
        self._offsets = np.zeros(len(self.joints)) if offsets is None else np.asarray(offsets)

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {len(self.bodies)} links, {len(self.joints)} joints)"

    def joint_index(self, joint) -> int:
        """The index (in ``joint_names`` order) of a movable joint given by name or index."""
        if isinstance(joint, str):
            if joint not in self.joint_names:
                raise ValueError(
                    f"robot {self.name!r} has no movable joint {joint!r}; its movable joints "
                    f"are {self.joint_names}"
                )
            return self.joint_names.index(joint)
        if isinstance(joint, (int, np.integer)) and 0 <= joint < len(self.joints):
            return int(joint)
        raise ValueError(
            f"a joint is a name in {self.joint_names} or an index below {len(self.joints)}, "
            f"got {joint!r}"
        )

    def _per_joint(self, values, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(indices, values) of a per-joint argument: all joints for an array, the named
        ones for a dict."""
        if isinstance(values, dict):
            indices = np.array([self.joint_index(k) for k in values], dtype=np.int64)
            values = np.array(list(values.values()), dtype=float)
            if len(set(indices.tolist())) != len(indices):
                raise ValueError(f"{name} names a joint twice")
        else:
            values = np.asarray(values, dtype=float)
            indices = np.arange(len(self.joints))
            if values.shape != (len(self.joints),):
                raise ValueError(
                    f"{name} must be {len(self.joints)} values (one per movable joint, in "
                    f"joint_names order) or a dict of joint names to values, got shape "
                    f"{values.shape}"
                )
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{name} must be finite, got {values.tolist()}")
        return indices, values

    def _followed(self, indices, values, offset: bool = True):
        """(indices, values) with each mimic joint set from its leader (``offset`` False for
        rates); a mimic joint named on its own is refused."""
        position = {int(i): float(v) for i, v in zip(indices, values, strict=True)}
        for mimic, (leader, multiplier, shift) in self.mimics.items():
            m, k = self.joint_index(mimic), self.joint_index(leader)
            if k in position:
                position[m] = multiplier * position[k] + (shift if offset else 0.0)
            elif m in position:
                raise ValueError(
                    f"joint {mimic!r} mimics {leader!r} ({multiplier:g} x {leader!r} + "
                    f"{shift:g}): set {leader!r} instead"
                )
        keys = sorted(position)
        return np.array(keys, dtype=np.int64), np.array([position[i] for i in keys])

    def joint_positions(self) -> np.ndarray:
        """(k,) each movable joint's angle (rad, in (-pi, pi], or within a turn of the
        middle of its limits where they reach past +-pi) or travel (m), in the URDF's terms
        (zero in its zero configuration); a planar joint's in-plane turn."""
        return self._readout("position") + self._offsets

    def joint_velocities(self) -> np.ndarray:
        """(k,) each movable joint's rate (rad/s or m/s)."""
        return self._readout("velocity")

    def _readout(self, key: str) -> np.ndarray:
        joints = self.world.joints
        values = joints[key][self.joints]
        # a planar joint (generic) reads its in-plane turn, the sixth of its axes
        generic = joints["kind"][self.joints] == "generic"
        axes = joints["axis_positions" if key == "position" else "axis_velocities"]
        values[generic] = axes[np.asarray(self.joints)[generic], 5]
        return values

    def _check_drivable(self, indices, what: str = "take no motor") -> None:
        kinds = self.world.joints["kind"][np.asarray(self.joints)[indices]]
        if np.any(kinds == "generic"):
            planar = [self.joint_names[i] for i, k in zip(indices, kinds, strict=True)
                      if k == "generic"]  # fmt: skip
            raise ValueError(f"planar joints {planar} {what} yet")

    def set_joint_positions(self, positions, velocities=None) -> None:
        """Put the joints at these positions (rad or m) and rates (rad/s or m/s; zero where
        not given), moving every link below them there at once: pybullet's resetJointState.

        The base keeps its pose and velocity; each link is placed from its parent's through
        its joint (its frame's rest orientation turned by the joint's angle, or moved along
        its axis), so every joint holds exactly, and it moves with its parent's velocity
        plus its joint's rate. Joints a dict leaves out keep their positions and rates.
        """
        indices, values = self._followed(*self._per_joint(positions, "positions"))
        self._check_drivable(indices, "cannot be set")
        q = self.joint_positions()
        rates = self.joint_velocities()
        q[indices] = values
        if velocities is None:
            rates[indices] = 0.0
        else:
            rate_indices, rate_values = self._followed(
                *self._per_joint(velocities, "velocities"), offset=False
            )
            self._check_drivable(rate_indices, "cannot be set")
            rates[rate_indices] = rate_values
        placed = _placed_links(self.world, self.tree_joints, self._rest, self.joints, q, rates)
        for body, pose in placed:
            self.world.set_body_state(body, *pose)

    def set_joint_targets(self, positions, velocities=None) -> None:
        """Hold every movable joint at a target position (rad or m) with a servo motor,
        capped by the joint's URDF effort (N m or N) and velocity (rad/s or m/s) limits:
        pybullet's POSITION_CONTROL, as a constraint rather than a gain. ``velocities``
        (rad/s or m/s, for the same joints, given as ``positions`` is; None: at rest) are the
        rates the targets move at: a trajectory's targets are then met where they will be,
        not a step late."""
        indices, positions = self._followed(*self._per_joint(positions, "positions"))
        rates = np.zeros(len(indices))
        if velocities is not None:
            given, values = self._followed(*self._per_joint(velocities, "velocities"), offset=False)
            if sorted(given) != sorted(indices):
                raise ValueError("velocities must name the same joints as positions")
            rates = np.array([dict(zip(given, values, strict=True))[i] for i in indices])
        self._check_drivable(indices)
        for i, q, v in zip(indices, positions, rates, strict=True):
            self.world.set_motor(
                self.joints[i], servo=float(q - self._offsets[i]), velocity=float(v),
                max_force=float(self.effort_limits[i]),
                max_velocity=float(self.velocity_limits[i]),
            )  # fmt: skip

    def set_joint_velocity_targets(self, velocities) -> None:
        """Drive every movable joint's rate towards a target (rad/s or m/s) within its URDF
        effort limit: pybullet's VELOCITY_CONTROL."""
        indices, velocities = self._followed(
            *self._per_joint(velocities, "velocities"), offset=False
        )
        self._check_drivable(indices)
        for i, v in zip(indices, velocities, strict=True):
            self.world.set_motor(
                self.joints[i], velocity=float(v), max_force=float(self.effort_limits[i])
            )

    def apply_joint_torques(self, torques) -> None:
        """Push every movable joint with a torque (N m) or force (N) about / along its axis,
        every step until changed: pybullet's TORQUE_CONTROL (not capped by the effort limit,
        as pybullet does not)."""
        indices, torques = self._per_joint(torques, "torques")
        self._check_drivable(indices)
        for i, t in zip(indices, torques, strict=True):
            self.world.set_motor(self.joints[i], torque=float(t))


def limit_or_inf(value) -> float:
    """A URDF effort or velocity limit as a motor cap: absent or zero (URDF's "not set")
    means uncapped."""
    return math.inf if value is None or not value > 0.0 else float(value)


def _placed_links(world, tree_joints, rest, movable, q, rates):
    """(body, (position, orientation, velocity, angular_velocity)) of each link below a
    joint, placed from its parent's pose and velocity through the joint at the URDF
    positions ``q`` and ``rates`` (one per ``movable`` joint; the fixed joints at zero) from
    its ``rest`` orientation relative to its parent, parents first."""
    frames = world.joint_frames
    joints = world.joints
    value = dict(zip(movable, q, strict=True))
    rate = dict(zip(movable, rates, strict=True))
    state = {}

    def current(body):
        if body not in state:
            state[body] = (
                world.position(body), world.orientation(body),
                world.linear_velocity(body), world.angular_velocity(body),
            )  # fmt: skip
        return state[body]

    placed = []
    for j in tree_joints:
        child, parent = frames["bodies"][j]
        if parent < 0:
            continue  # the base, welded to the world where it is
        x_p, q_p, v_p, w_p = current(parent)
        kind = joints["kind"][j]
        arm_child, arm_parent = frames["anchors"][j]
        axis = quat_rotate(q_p, frames["axes"][j][1])
        anchor = x_p + quat_rotate(q_p, arm_parent)
        turn = np.array([0.0, 0.0, 0.0, 1.0])
        travel = 0.0
        angle_rate = travel_rate = 0.0
        if kind == "revolute":
            half = 0.5 * value[j]
            turn = np.concatenate([np.sin(half) * axis, [np.cos(half)]])
            angle_rate = rate[j]
        elif kind == "prismatic":
            travel = value[j]
            travel_rate = rate[j]
        q_c = quat_multiply(turn, quat_multiply(q_p, rest[j]))
        x_c = anchor + travel * axis - quat_rotate(q_c, arm_child)
        w_c = w_p + angle_rate * axis
        v_c = (
            v_p + np.cross(w_p, x_c - x_p) + angle_rate * np.cross(axis, x_c - anchor)
            + travel_rate * axis
        )  # fmt: skip
        state[child] = (x_c, q_c, v_c, w_c)
        placed.append((int(child), state[child]))
    return placed
