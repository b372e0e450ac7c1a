"""Slow, independent oracles for the joints: constraint errors from rotation matrices (scipy),
sharing no code with ``dynamics.joint_rows``.

A joint is described here by what it holds in words: the two anchors at one point, the two
axes parallel, the relative orientation as it was, the anchor on a line, a length. Each
function takes the bodies' poses as (x (3,), R (3, 3)) and the joint's creation data in
world coordinates, and returns the violation as a vector; Jacobians are checked against
central differences of these.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def pose(position, quaternion):
    """(x, R) of a body from its position (3,) and (x, y, z, w) orientation."""
    return np.array(position, float), Rotation.from_quat(quaternion).as_matrix()


def attached(point, body_pose_at_creation, body_pose_now):
    """Where a point fixed to a body at creation is now (world)."""
    x0, R0 = body_pose_at_creation
    x1, R1 = body_pose_now
    return x1 + R1 @ R0.T @ (np.asarray(point) - x0)


def turned(direction, body_pose_at_creation, body_pose_now):
    """Where a direction fixed to a body at creation points now."""
    _, R0 = body_pose_at_creation
    _, R1 = body_pose_now
    return R1 @ R0.T @ np.asarray(direction)


def anchor_offset(anchor, a0, a1, b0, b1, anchor_b=None):
    """p_a - p_b: the joint's anchor carried by each body (b may be the world: b0 = b1)."""
    anchor_b = anchor if anchor_b is None else anchor_b
    return attached(anchor, a0, a1) - attached(anchor_b, b0, b1)


def relative_rotation_angle(a0, a1, b0, b1):
    """Angle (rad) of a's rotation relative to b since creation."""
    Ra = a1[1] @ a0[1].T
    Rb = b1[1] @ b0[1].T
    return Rotation.from_matrix(Rb.T @ Ra).magnitude()


def hinge_angle(axis, a0, a1, b0, b1):
    """Signed angle (rad) of a's rotation about +axis relative to b since creation (the
    relative rotation taken in the world frame of creation, where the axis was given)."""
    Ra = a1[1] @ a0[1].T
    Rb = b1[1] @ b0[1].T
    rotvec = Rotation.from_matrix(Rb.T @ Ra).as_rotvec()
    return float(rotvec @ np.asarray(axis))


def axis_misalignment(axis, a0, a1, b0, b1):
    """Angle (rad) between the hinge axis carried by a and by b."""
    ua, ub = turned(axis, a0, a1), turned(axis, b0, b1)
    return float(np.arctan2(np.linalg.norm(np.cross(ua, ub)), ua @ ub))


def off_line(anchor, axis, a0, a1, b0, b1):
    """Distance of a's anchor from b's line through the anchor along the axis."""
    offset = anchor_offset(anchor, a0, a1, b0, b1)
    u = turned(axis, b0, b1)
    return float(np.linalg.norm(offset - (offset @ u) * u))


def square_pair_error(axis_b, axis_a, a0, a1, b0, b1):
    """Angle (rad) from square between a direction carried by b and one carried by a (the
    pair a universal joint, or a generic joint with one turn locked, holds square)."""
    cosine = float(turned(axis_b, b0, b1) @ turned(axis_a, a0, a1))
    return abs(float(np.arcsin(np.clip(cosine, -1.0, 1.0))))
