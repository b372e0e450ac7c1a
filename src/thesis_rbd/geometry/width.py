"""The thickness of a mesh: the smallest width of its convex hull.

A body moving further than its thickness in one step may pass through something between two
discrete poses, so the tunnelling stage watches bodies by this length rather than by their
bounding radius: a 0.6 x 0.6 x 0.01 m plate has a bounding radius of 0.42 m but can pass
through a floor after moving only 1 cm.

The width of a convex polytope along a unit direction n is max(V n) - min(V n); over the
hull's face normals its least value is the exact minimum width whenever that is attained
face-to-vertex (boxes, plates, prisms, spheres tessellated finely) and an upper bound within a
small factor otherwise; the tunnelling stage samples at half this length, which covers it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

__all__ = ["hull_thickness"]


def hull_thickness(vertices: np.ndarray) -> float:
    """Least width of the convex hull of ``vertices`` over the hull's face normals.

    Parameters
    ----------
    vertices : (v, 3) float64
        Points in any frame (a width does not depend on it).

    Returns
    -------
    float
        The thickness (m); 0 for flat or degenerate point sets (a single triangle, a
        plane), which have no volume hull.
    """
    points = np.asarray(vertices, dtype=np.float64)
    try:
        hull = ConvexHull(points)
    except QhullError:
        return 0.0
    projections = points[hull.vertices] @ hull.equations[:, :3].T
    return float((projections.max(axis=0) - projections.min(axis=0)).min())
