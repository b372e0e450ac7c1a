"""Rigid transforms: 4x4 homogeneous matrices (trimesh convention) from and to (x, q) poses."""

from __future__ import annotations

import numpy as np

from thesis_rbd._validate import as_finite_array, as_unit_quaternion
from thesis_rbd.spatial.quaternion import quat_from_matrix, quat_to_matrix

__all__ = ["pose_from_transform", "transform_from_pose"]


def transform_from_pose(position, orientation) -> np.ndarray:
    """(4, 4) rigid transform of a position (3,) and an (x, y, z, w) orientation (4,)."""
    position = as_finite_array(position, "position", shape=(3,))
    q = as_unit_quaternion(orientation)
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(q)
    T[:3, 3] = position
    return T


def pose_from_transform(T) -> tuple[np.ndarray, np.ndarray]:
    """Position (3,) and (x, y, z, w) orientation (4,) of a (4, 4) rigid transform."""
    T = as_finite_array(T, "T", shape=(4, 4))
    return T[:3, 3].copy(), quat_from_matrix(T[:3, :3])
