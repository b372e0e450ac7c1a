"""The tori demo of thesis 5.4.1, generated: two 5000-triangle tori, one moving through the other.

Torus A (R = 1, r = 0.3, 50 x 50 sections) stays at the identity. Torus B, the same mesh, is stood
up in the xz-plane and wobbles (up to 0.35 rad about x and 0.25 rad about z, one full period over
the path) while its centre slides along x from -3 to +3 at y = 0.05. About two thirds of the 200
poses interpenetrate; around x = +-1 the rings are chain-linked but disjoint. Benchmarks, studies
and tests all read the scene from here, so it is the same everywhere and needs no data file.
"""

from __future__ import annotations

import numpy as np

import thesis_rbd as rbd

__all__ = ["POSE_COUNT", "tori_mesh", "tori_poses"]

POSE_COUNT = 200
MAJOR_RADIUS, MINOR_RADIUS, SECTIONS = 1.0, 0.3, 50
WOBBLE_X, WOBBLE_Z = 0.35, 0.25  # rad


def tori_mesh() -> rbd.TriangleMesh:
    """The demo's torus: 2500 vertices, 5000 triangles."""
    return rbd.shapes.torus(MAJOR_RADIUS, MINOR_RADIUS, SECTIONS, SECTIONS)


def tori_poses(count: int = POSE_COUNT) -> np.ndarray:
    """(count, 4, 4) poses of torus B along its path; torus A is at the identity.

    Pose k is R = Rz(a_z) Rx(pi/2 + a_x) with a_x = 0.35 sin(2 pi s), a_z = 0.25 sin(2 pi s),
    s = k / (count - 1), and centre (-3 + 6 s, 0.05, 0).
    """
    s = np.linspace(0.0, 1.0, count)
    phase = np.sin(2.0 * np.pi * s)
    ax = 0.5 * np.pi + WOBBLE_X * phase
    az = WOBBLE_Z * phase
    cx, sx, cz, sz = np.cos(ax), np.sin(ax), np.cos(az), np.sin(az)
    poses = np.zeros((count, 4, 4))
    # Rz(az) @ Rx(ax), written out
    poses[:, 0, 0] = cz
    poses[:, 0, 1] = -sz * cx
    poses[:, 0, 2] = sz * sx
    poses[:, 1, 0] = sz
    poses[:, 1, 1] = cz * cx
    poses[:, 1, 2] = -cz * sx
    poses[:, 2, 1] = sx
    poses[:, 2, 2] = cx
    poses[:, 0, 3] = -3.0 + 6.0 * s
    poses[:, 1, 3] = 0.05
    poses[:, 3, 3] = 1.0
    return poses
