"""A loaded URDF model's joint-space view: its bodies by link, its movable joints, their
state, and motor targets or torques on them (pybullet's getJointState and
setJointMotorControl2)."""

from __future__ import annotations

import math

import numpy as np

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
    """

    def __init__(self, world, name, bodies, joints, joint_names, effort_limits, velocity_limits):
        self.world = world
        self.name = name
        self.bodies = dict(bodies)
        self.joints = list(joints)
        self.joint_names = list(joint_names)
        self.effort_limits = np.asarray(effort_limits, dtype=float)
        self.velocity_limits = np.asarray(velocity_limits, dtype=float)

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {len(self.bodies)} links, {len(self.joints)} joints)"

    def _per_joint(self, values, name: str) -> np.ndarray:
        values = np.asarray(values, dtype=float)
        if values.shape != (len(self.joints),) or not np.all(np.isfinite(values)):
            raise ValueError(
                f"{name} must be {len(self.joints)} finite values (one per movable joint, in "
                f"joint_names order), got shape {values.shape}"
            )
        return values

    def joint_positions(self) -> np.ndarray:
        """(k,) each movable joint's angle (rad, in (-pi, pi]) or travel (m) from where it
        was loaded (the URDF zero configuration); a planar joint's in-plane turn."""
        return self._readout("position")

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

    def _check_drivable(self) -> None:
        kinds = self.world.joints["kind"][self.joints]
        if np.any(kinds == "generic"):
            planar = [n for n, k in zip(self.joint_names, kinds, strict=True) if k == "generic"]
            raise ValueError(f"planar joints {planar} take no motor yet")

    def set_joint_targets(self, positions) -> None:
        """Hold every movable joint at a target position (rad or m) with a servo motor,
        capped by the joint's URDF effort (N m or N) and velocity (rad/s or m/s) limits:
        pybullet's POSITION_CONTROL, as a constraint rather than a gain."""
        positions = self._per_joint(positions, "positions")
        self._check_drivable()
        for j, q, f, w in zip(
            self.joints, positions, self.effort_limits, self.velocity_limits, strict=True
        ):
            self.world.set_motor(j, servo=float(q), max_force=float(f), max_velocity=float(w))

    def set_joint_velocity_targets(self, velocities) -> None:
        """Drive every movable joint's rate towards a target (rad/s or m/s) within its URDF
        effort limit: pybullet's VELOCITY_CONTROL."""
        velocities = self._per_joint(velocities, "velocities")
        self._check_drivable()
        for j, v, f in zip(self.joints, velocities, self.effort_limits, strict=True):
            self.world.set_motor(j, velocity=float(v), max_force=float(f))

    def apply_joint_torques(self, torques) -> None:
        """Push every movable joint with a torque (N m) or force (N) about / along its axis,
        every step until changed: pybullet's TORQUE_CONTROL (not capped by the effort limit,
        as pybullet does not)."""
        torques = self._per_joint(torques, "torques")
        self._check_drivable()
        for j, t in zip(self.joints, torques, strict=True):
            self.world.set_motor(j, torque=float(t))


def limit_or_inf(value) -> float:
    """A URDF effort or velocity limit as a motor cap: absent or zero (URDF's "not set")
    means uncapped."""
    return math.inf if value is None or not value > 0.0 else float(value)
