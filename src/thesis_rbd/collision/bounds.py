"""World-space axis-aligned bounding boxes of posed meshes: the broad phase's input.

Each body's mesh has a fixed local box [lo, hi] in its mesh frame. Posed by the body's
rotation R and the mesh-to-world translation t = x - R c, the box's centre moves to
R (lo + hi)/2 + t and its half-extents become |R| (hi - lo)/2 (Arvo 1990): exact for the
local box, and at most sqrt(3) times too large for the mesh, with no per-vertex work.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd._jit import njit
from thesis_rbd.spatial.quaternion import to_matrix_into

__all__ = ["world_bounds"]


@njit
def world_bounds(
    count,
    local_lower,
    local_upper,
    center_of_mass_local,
    position,
    orientation,
    margin,
    lower,
    upper,
):
    """Write the world AABBs of the first ``count`` bodies into ``lower``, ``upper`` (n, 3).

    Parameters
    ----------
    count : int
        Number of bodies n.
    local_lower, local_upper : (>= n, 3) float64
        Mesh-frame bounding box of each body's mesh.
    center_of_mass_local : (>= n, 3) float64
        Centre of mass c in the mesh frame.
    position : (>= n, 3) float64
        World centre of mass x.
    orientation : (>= n, 4) float64
        (x, y, z, w) orientation.
    margin : (>= n,) float64
        Distance each box is grown by on every side (contact margin, swept motion).
    lower, upper : (n, 3) float64
        Output.
    """
    R = np.empty((3, 3))
    for i in range(count):
        to_matrix_into(orientation[i], R)
        for a in range(3):
            center = position[i, a]
            half = margin[i]
            for b in range(3):
                local_center = 0.5 * (local_lower[i, b] + local_upper[i, b])
                center += R[a, b] * (local_center - center_of_mass_local[i, b])
                half += abs(R[a, b]) * 0.5 * (local_upper[i, b] - local_lower[i, b])
            lower[i, a] = center - half
            upper[i, a] = center + half
