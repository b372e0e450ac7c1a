"""CAD-like parts with flat faces, thin walls, slivers and zero-area faces, and flush placements.

Real scenes put parts face to face: stacked, packed, side by side. These parts (a box, a thin
plate, an L-bracket, a hexagonal prism, a cylinder, a plate with a sliver triangle, a box
carrying zero-area faces) are the exact-predicate tests' real-mesh set
(``tests/test_flush_meshes.py``) and the workload of the predicate cost comparison
(:mod:`validation.checkout_comparison`). :func:`placement` puts a copy of a part flush
against one of its faces, or a given fraction of its size into or away from it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd

__all__ = ["PARTS", "extruded", "placement"]


def extruded(polygon, height, fan_from=0):
    """Prism over a simple polygon (counter-clockwise (k, 2)), capped by a triangle fan from
    vertex ``fan_from`` (the polygon must be star-shaped from it)."""
    polygon = np.asarray(polygon, float)
    k = len(polygon)
    vertices = np.vstack(
        [np.column_stack([polygon, np.zeros(k)]), np.column_stack([polygon, np.full(k, height)])]
    )
    order = [(fan_from + i) % k for i in range(k)]
    faces = []
    for i in range(1, k - 1):
        a, b, c = order[0], order[i], order[i + 1]
        faces.append((k + a, k + b, k + c))  # top, counter-clockwise from above
        faces.append((a, c, b))  # bottom, reversed
    for i in range(k):
        j = (i + 1) % k
        faces += [(i, j, k + j), (i, k + j, k + i)]
    return rbd.TriangleMesh(vertices, faces)


def _hexagon(radius):
    angles = np.arange(6) * np.pi / 3
    return np.column_stack([np.cos(angles), np.sin(angles)]) * radius


def _with_zero_area_faces(mesh):
    """The mesh plus faces real files carry: a segment along each edge of face 0 (through a
    vertex at the edge's midpoint), a repeated-vertex face and a point face."""
    V = np.asarray(mesh.vertices)
    F = np.asarray(mesh.faces)
    a, b, c = F[0]
    mids = 0.5 * (V[[a, b, c]] + V[[b, c, a]])
    n = len(V)
    extra = [(a, n, b), (b, n + 1, c), (c, n + 2, a), (a, a, b), (c, c, c)]
    return rbd.TriangleMesh(np.vstack([V, mids]), np.vstack([F, extra]))


PARTS = {
    "box": rbd.shapes.box((1.0, 0.5, 0.25)),
    "plate": rbd.shapes.box((1.0, 0.75, 1.0 / 64)),
    "L_bracket": extruded(
        [(0, 0), (2, 0), (2, 0.5), (0.5, 0.5), (0.5, 2), (0, 2)], 0.25, fan_from=3
    ),
    "hex_prism": extruded(_hexagon(0.5), 0.3),
    "cylinder": rbd.shapes.cylinder(0.3, 0.5, 12),
    # CAD tessellations leave slivers: a vertex 1e-13 off a straight edge makes a cap
    # triangle of height 1e-13 and a wall kinked by as much.
    "sliver_plate": extruded([(0, 0), (0.5, -1e-13), (1, 0), (1, 1), (0, 1)], 0.125),
    "box_with_zero_area_faces": _with_zero_area_faces(rbd.shapes.box((1.0, 0.5, 0.25))),
}


def placement(mesh, axis, gap, turn, seed=0):
    """Poses (T_a, T_b): B flush against A's face at the top of ``axis`` (shifted sideways by
    an eighth of the part along the next axis), moved by ``gap`` times the part's size."""
    lo, hi = mesh.bounds
    offset = np.zeros(3)
    offset[axis] = (hi[axis] - lo[axis]) + gap * mesh.scale
    side = (axis + 1) % 3
    offset[side] = (hi[side] - lo[side]) / 8.0
    M = np.eye(4)
    M[:3, 3] = offset
    rng = np.random.default_rng(seed)
    if turn == "about_normal":
        # Turn B about the contact normal through the middle of A's face: the faces stay
        # exactly coplanar (the rotation leaves that coordinate untouched).
        centre = 0.5 * (lo + hi)
        R = np.eye(4)
        R[:3, :3] = Rotation.from_rotvec(0.4 * np.eye(3)[axis]).as_matrix()
        to_centre, back = np.eye(4), np.eye(4)
        to_centre[:3, 3] = -centre
        back[:3, 3] = centre
        M = M @ back @ R @ to_centre
    T_a = np.eye(4)
    if turn == "whole":
        T_a[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        T_a[:3, 3] = rng.normal(size=3)
    return T_a, T_a @ M
