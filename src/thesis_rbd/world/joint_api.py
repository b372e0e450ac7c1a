"""The world's joints: adding them, excluding body pairs from collision, and reading out what
each joint is doing (``World`` inherits these; the solve is ``dynamics.joint_solver``)."""

from __future__ import annotations

import numpy as np

from thesis_rbd.dynamics.joint_rows import read_joints
from thesis_rbd.dynamics.joint_set import (
    ARM_A,
    ARM_B,
    AXIS_A,
    AXIS_B,
    BODY_A,
    BODY_B,
    JOINT_KINDS,
    KIND,
    KIND_NAMES,
)
from thesis_rbd.spatial.quaternion import quat_rotate, quat_to_matrix

__all__ = ["WorldJoints"]

_KIND_NAMES = np.array(KIND_NAMES)
# Kinds whose axis means something to someone looking at them: a hinge's and a slider's.
_AXIS_KINDS = np.array([JOINT_KINDS["revolute"], JOINT_KINDS["prismatic"]])


class WorldJoints:
    """Joint methods of ``World``: they read and change ``self.bodies``, ``self._joints``
    (``JointSet``), ``self._excluded`` (p, 2) and the joint stages' impulses, and plan the
    step again after a change."""

    def add_joint(
        self, kind: str, body_a: int, body_b: int | None, anchor, axis=(0.0, 0.0, 1.0),
        anchor_b=None, limits=None, motor=None, spring=None, damping: float = 0.0,
        friction: float = 0.0, collide: bool = False, name: str | None = None, axes=None,
        ref: float = 0.0,
    ) -> int:  # fmt: skip
        """Join two bodies (or a body and the world) and return the joint's index.

        Parameters
        ----------
        kind : {"spherical", "revolute", "fixed", "prismatic", "distance", "universal", \
"generic"}
            Ball joint, hinge about ``axis``, weld, slider along ``axis``, a distance
            joint between ``anchor`` and ``anchor_b`` (a rod holding them at their distance
            now, or with ``limits`` or a ``spring``, a rope or spring whose length is free
            within its limits), a universal joint (turning about ``axis[0]``, fixed in
            body_b, and ``axis[1]``, fixed in body_a), or a generic joint whose six ``axes``
            are each free, locked or limited.
        body_a : int
        body_b : int or None
            None joins body_a to the world.
        anchor : (3,) array_like
            World point where the bodies are joined, now (on body_a for a distance joint).
        axis : (3,) or (2, 3) array_like
            World direction of a hinge or slider, now; need not be unit length. A universal
            or generic joint's frame: two square directions (its x and y; z = x cross y),
            or one (x; y and z chosen square to it).
        anchor_b : (3,) array_like, optional
            A distance joint's point on body_b (world, now).
        limits : (lower, upper), optional
            Bounds of a hinge's angle (rad, within [-pi, pi]), a slider's travel (m) or a
            distance joint's length (m, 0 <= lower <= upper: a rope of length L is (0, L)),
            -inf / inf for none: a one-sided row that acts only where a limit is reached,
            held at the end of every substep (no overshoot, no bounce). A spherical joint's
            are (cone, twist_lo, twist_hi); a universal joint's ((lo, hi), (lo, hi)) of its
            turns about axis[0] and axis[1] (the second within [-pi/2, pi/2]).
        motor : dict, optional
            A hinge's or slider's motor, SI units: ``{"velocity": v, "max_force": f}`` drives
            its rate towards v (rad/s or m/s) with at most f (N m or N); ``{"torque": t}``
            pushes with t (N m or N) about / along +axis; ``{"position": q, "stiffness": k,
            "damping": c, "max_force": f}`` pulls towards q through a spring (N m/rad or
            N/m) and damper (N m s/rad or N s/m); ``{"servo": q, "velocity": v,
            "max_force": f, "max_velocity": w}`` holds q as a constraint within f and w, q
            moving at v (rad/s or m/s; 0 where left out: the servo then reaches q where it
            is, a trajectory's target a step late). Caps left out are unlimited.
        spring : dict, optional
            A distance joint's spring, ``{"stiffness": k, "damping": c, "rest_length": L}``
            (N/m, N s/m, m; damping 0 and the anchors' distance now where left out): a force
            k (L - length) - c rate along the anchors' line, taken implicitly (stable at any
            stiffness). A spring holds no rod: add ``limits`` to bound its length.
        damping : float
            A hinge's (N m s/rad) or slider's (N s/m) viscous damping: a torque or force of
            -damping times its rate, taken implicitly.
        friction : float
            A hinge's (N m) or slider's (N) Coulomb friction: at most this torque or force
            against its rate, enough to hold it still under less.
        collide : bool
            Whether body_a and body_b still collide with each other (False by default).
        name : str, optional
            "joint<i>" by default.
        axes : sequence of 6, optional
            A generic joint's travel along its frame's x, y and z, then its turns about
            them: each "free", "locked" (held at zero) or (lower, upper) limits (m, rad).
            Turns are Cardan angles (body_a relative to body_b is Rx(a) Ry(b) Rz(c) in the
            frame, Bullet's generic joint's convention): the middle one's limits lie within
            [-pi/2, pi/2]; a lone turn the others lock is a hinge's angle, within [-pi, pi].
            URDF's ``planar`` joint is ("free", "free", "locked", "locked", "locked",
            "free") about its normal as z; ``floating`` is six "free" (a free body).
        ref : float
            A hinge's angle now (rad, MuJoCo's ``ref``): its zero lies ``ref`` back about
            +axis, and its limits and targets count from there. A range of limits wider
            than the turn either side of zero allows (URDF's 0 to 3.8 rad) fits once its
            zero is put mid-range.

        Notes
        -----
        The joint holds the bodies as they are now: its position (a hinge's angle, a
        slider's travel) is zero now (a hinge's ``ref``) and counts body_a's motion relative
        to body_b about / along +axis, right-handed. Jointed bodies are integrated by
        symplectic Euler and held together at the end of every step
        (``dynamics.joint_solver``).
        """
        index = self._joints.add(
            kind, body_a, body_b, anchor, axis, anchor_b, collide, name, self.bodies,
            {"limits": limits, "axes": axes, "motor": motor, "spring": spring,
             "damping": damping, "friction": friction, "ref": ref},
        )  # fmt: skip
        joined = self._joints.ints[index, BODY_A : BODY_B + 1]
        self._sleep.wake(joined[joined >= 0])
        self._plan_stages()
        return index

    def set_motor(self, joint: int, **motor) -> None:
        """Change a joint's motor between steps (no arguments: switch it off); the keywords
        are those of ``add_joint``'s ``motor``."""
        self._joints.set_motor(joint, motor or None)
        joined = self._joints.ints[joint, BODY_A : BODY_B + 1]
        self._sleep.wake(joined[joined >= 0])
        self._plan_stages()

    def exclude_pair(self, body_a: int, body_b: int) -> None:
        """Never let these two bodies collide with each other."""
        a, b = self._check_body(body_a), self._check_body(body_b)
        if a == b:
            raise ValueError(f"exclude_pair needs two different bodies, got {a} twice")
        self._excluded = np.vstack([self._excluded, [min(a, b), max(a, b)]])
        self._plan_stages()

    @property
    def joints(self) -> dict:
        """What each joint is doing now, and did over the last step.

        Keys (m joints): ``name`` (list of str); ``kind`` (m,) str; ``body_a``, ``body_b``
        (m,) int64 (-1: the world); ``position`` and ``velocity`` (m,): a revolute joint's
        angle (rad, in (-pi, pi]) and rate, a prismatic joint's travel (m) and speed, a
        distance joint's length and rate (0 for the other kinds); ``gap`` (m,) how far the
        anchors are from where the joint holds them (m); ``angle_error`` (m,) how far the
        orientation is from what it holds (rad); ``force`` and ``torque`` (m, 3): what body_b
        (or the world) exerted on body_a over the last step, at the anchor, world frame (N,
        N m; the impulses of the step's projection and motor over dt); ``motor_force`` (m,)
        the motor's torque or force along the axis over the last step (N m or N);
        ``axis_positions`` and ``axis_velocities`` (m, 6): a universal or generic joint's
        travel along its frame's x, y, z (m) and Cardan turns about them (rad; a lone turn:
        its hinge angle), and their rates, NaN for the other kinds.
        """
        joints, b = self._joints, self.bodies
        ints = joints.ints
        # a kinematic body's velocity is the one set on it (zero for every other body)
        v = b.linear_momentum * b.inverse_mass[:, None] + b.kinematic_velocity
        R = quat_to_matrix(b.orientation).reshape(-1, 3, 3)
        L_body = np.einsum("nji,nj->ni", R, b.angular_momentum)
        w = np.einsum("nij,nj->ni", R, np.einsum("nij,nj->ni", b.inverse_inertia_body, L_body))
        w += b.kinematic_angular_velocity
        readout = read_joints(ints, joints.floats, b.position, b.orientation, v, w)
        impulse = self._joint_impulse[: len(joints)] / self.dt
        arm = quat_rotate(b.orientation[ints[:, BODY_A]], joints.floats[:, ARM_A : ARM_A + 3])
        force = impulse[:, :3]
        return {
            "name": list(joints.names),
            "kind": _KIND_NAMES[ints[:, KIND]],
            "body_a": ints[:, BODY_A].copy(),
            "body_b": ints[:, BODY_B].copy(),
            "position": readout[:, 0],
            "velocity": readout[:, 1],
            "gap": readout[:, 2],
            "angle_error": readout[:, 3],
            "force": force.copy(),
            "torque": impulse[:, 3:6] - np.cross(arm.reshape(-1, 3), force),
            "motor_force": impulse[:, 6].copy(),
            "axis_positions": readout[:, 4:10],
            "axis_velocities": readout[:, 10:16],
        }

    @property
    def joint_frames(self) -> dict:
        """Where each joint sits on its two bodies: fixed in their frames, so constant.

        Keys (m joints): ``names`` (list of str); ``bodies`` (m, 2) int64, body_a and body_b
        (-1: the world); ``anchors`` (m, 2, 3), the anchor on each body relative to its centre
        of mass in its body frame (the frame of ``orientations``; on the world, the world
        point), m; ``axes`` (m, 2, 3), a hinge's or slider's unit axis in the same frames,
        zero for the kinds without one. A side's world anchor is R(q) anchor + x with the
        body's current pose (x, q); the joint holds the two sides' anchors together (a
        slider's on its line, a rod's at its length).
        """
        joints = self._joints
        floats = joints.floats
        has_axis = np.isin(joints.ints[:, KIND], _AXIS_KINDS)[:, None, None]
        return {
            "names": list(joints.names),
            "bodies": joints.ints[:, BODY_A : BODY_B + 1].copy(),
            "anchors": np.stack([floats[:, ARM_A : ARM_A + 3], floats[:, ARM_B : ARM_B + 3]], 1),
            "axes": np.where(
                has_axis,
                np.stack([floats[:, AXIS_A : AXIS_A + 3], floats[:, AXIS_B : AXIS_B + 3]], 1),
                0.0,
            ),
        }
