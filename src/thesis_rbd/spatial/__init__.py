"""Quaternions in (x, y, z, w) order and rigid transforms."""

from thesis_rbd.spatial.quaternion import (
    quat_conjugate,
    quat_derivative,
    quat_from_matrix,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
)
from thesis_rbd.spatial.transform import pose_from_transform, transform_from_pose

__all__ = [
    "pose_from_transform",
    "quat_conjugate",
    "quat_derivative",
    "quat_from_matrix",
    "quat_multiply",
    "quat_rotate",
    "quat_to_matrix",
    "transform_from_pose",
]
