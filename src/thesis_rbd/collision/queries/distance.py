"""Minimum distance between two triangle meshes and their closest points: :func:`distance`.

First the convex hulls (:mod:`.hull_distance`): two meshes are never closer than their hulls,
and where GJK over the hulls ends on features whose mesh triangles are as close as the hulls,
that triangle pair is the answer and no tree is descended. That settles most poses of meshes
facing each other with convex sides, at a few microseconds.

Otherwise the two OBBTrees are descended from the pair of roots. A pair of tree codes (node
or triangle, as in :mod:`.collide`) is split (the larger node, or the node facing a
triangle); each child pair gets a lower bound on the distance of anything below it: first
from the supports the nodes store along a grid of directions, projected on the line from the
split node's centre to the other side (:mod:`.support_distance`), which is close to the true
distance of two curved patches; where that does not prune the pair, also from the boxes
(:mod:`.box_distance`: separating-axis gaps, and the line through the box centres), which
bound overlapping and touching boxes better. A triangle pair is measured exactly at once
(:mod:`.triangle_distance`, after a cheap gap test), lowering the best distance found, and
the child of lesser bound goes on at once while nothing waiting comes before it. Pairs whose
bound is not below the best are dropped, on the way down and when they are taken up again,
and the search ends when nothing waits, or at once when two triangles intersect (distance
0). Pairs whose boxes may overlap (bound 0) wait on a stack that is emptied first, so a
colliding pose is searched as an overlap query would search it and an intersection ends the
search without sweeping every level. The others wait in a queue, least bound first, when the
hulls measured no triangle pair (they overlap: the meshes are interlocked or nearly
touching, where a bound found late would prune much that a depth-first search had already
opened), and on a stack, depth first, when they did (a search that starts from a near-
optimal bound visits about the boxes best first would, and a stack costs less to keep than a
queue).

All geometry is evaluated in A's mesh frame (B's boxes and triangles carried over by
``T_a^-1 T_b``); the closest points are mapped to the world at the end.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.packed import (
    box_frame,
    carry_box,
    child,
    corner_moved,
    half_extent,
    layout,
    node_size,
    pair_corners,
    support_values,
    tree_depth,
)
from thesis_rbd.collision.mesh.packed_support import support_weights
from thesis_rbd.collision.queries._query_args import (
    as_pose,
    as_pose_stack,
    call_normalised,
    inverse_pose,
    pose_at,
    pose_ok,
    raise_bad_pose,
    relative_pose,
    sealed,
    tree_array,
)
from thesis_rbd.collision.queries.box_distance import box_box_gap, triangle_box_gap
from thesis_rbd.collision.queries.hull_distance import hull_distance
from thesis_rbd.collision.queries.support_distance import child_gap, node_reach, triangle_reach
from thesis_rbd.collision.queries.triangle_distance import triangle_distance, triangle_gap

__all__ = ["DistanceResult", "distance", "mesh_distance"]


class DistanceResult:
    """Outcome of :func:`distance`.

    Attributes
    ----------
    distance : float, or (k,) float64 for a pose stack
        Least distance between the two meshes; 0.0 when they intersect (touching counts).
    points : (2, 3) float64, or (k, 2, 3)
        World points on A and on B that are ``distance`` apart (the same point, where the
        meshes intersect, when the distance is 0).
    faces : (2,) int64, or (k, 2)
        [face of A, face of B] holding those points.
    stats : dict
        ``bv_tests`` (box-box and triangle-box bounds computed; 0 where the hulls proved
        the distance) and ``tri_tests`` (triangle pairs measured); summed over the stack.
    """

    # Slotted, with the arrays built only when read, so that a query whose caller wants the
    # number alone costs no array allocation.
    __slots__ = ("_faces", "_points", "_raw", "distance")

    def __init__(self, distance, points, faces, raw):
        self.distance = distance
        self._points = points
        self._faces = faces
        self._raw = raw

    @property
    def points(self) -> np.ndarray:
        if self._points is None:
            r = self._raw
            self._points = np.array([[r[2], r[3], r[4]], [r[5], r[6], r[7]]])
        return self._points

    @property
    def faces(self) -> np.ndarray:
        if self._faces is None:
            self._faces = np.array([self._raw[8], self._raw[9]], dtype=np.int64)
        return self._faces

    @property
    def stats(self) -> dict:
        return {"bv_tests": int(self._raw[10]), "tri_tests": int(self._raw[11])}

    def __repr__(self) -> str:
        return f"DistanceResult(distance={self.distance})"


# ---------------------------------------------------------------- the two stacks
# One (capacity, 3) float64 array of rows (bound, x, y): the stack of pairs that may overlap
# (bound 0) grows down from its end, the other up from its start. The pushes and pops are
# written out in mesh_distance itself: helpers taking the array would cost reference counting
# on every call.


@njit
def _grown(stack, size, zeros):
    """The two stacks (``size`` rows from the start, ``zeros`` rows at the end) with twice
    the room."""
    capacity = stack.shape[0]
    bigger = np.empty((2 * capacity, 3))
    bigger[:size] = stack[:size]
    bigger[2 * capacity - zeros :] = stack[capacity - zeros :]
    return bigger


# ---------------------------------------------------------------- bounds on code pairs


@njit(allocates=False)
def _carried_triangle(P, L, t, M, tr):
    """Corners of triangle t of tree (P, L), mapped by ``x -> M x + tr`` into the mesh frame
    of the other tree."""
    return corner_moved(P, L, t, 0, M, tr), corner_moved(P, L, t, 1, M, tr), \
        corner_moved(P, L, t, 2, M, tr)  # fmt: skip


@njit(allocates=False)
def _in_box(P, L, k, w):
    """Point w of tree (P, L)'s mesh frame in the frame of its box k: ``R_k^T (w - c_k)``."""
    c = L[0] + k
    r = L[2] + 3 * k
    d0 = w[0] - P[c, 0]
    d1 = w[1] - P[c, 1]
    d2 = w[2] - P[c, 2]
    return (
        P[r, 0] * d0 + P[r + 1, 0] * d1 + P[r + 2, 0] * d2,
        P[r, 1] * d0 + P[r + 1, 1] * d1 + P[r + 2, 1] * d2,
        P[r, 2] * d0 + P[r + 1, 2] * d1 + P[r + 2, 2] * d2,
    )


@njit(allocates=False)
def _triangle_box_bound(P, L, k, w0, w1, w2, cutoff):
    """Lower bound on the distance of box k of tree (P, L) and the triangle of corners w0,
    w1, w2 (in that tree's mesh frame): :func:`.box_distance.triangle_box_gap`."""
    return triangle_box_gap(
        _in_box(P, L, k, w0), _in_box(P, L, k, w1), _in_box(P, L, k, w2), half_extent(P, L, k),
        cutoff,
    )  # fmt: skip


@njit(allocates=False)
def _centre(P, L, k):
    """Centre of box k of tree (P, L), in its mesh frame."""
    r = L[0] + k
    return (P[r, 0], P[r, 1], P[r, 2])


@njit(inline="always")
def _other_side(code, P, L, M, t, box, triangle, g, c, w0, w1, w2):
    """The side of a split that is not split, code ``code`` of tree (P, L), carried by
    ``x -> M x + t`` into the split side's frame: its box's axes g and centre c, or its
    triangle's corners w0, w1, w2, kept as they are where ``box`` or ``triangle`` says they
    were carried already. Returns (box, triangle, g, c, w0, w1, w2, anchor): what is carried
    now, and its reference point (the box's centre or the triangle's centroid)."""
    if code >= 0:
        if code != box:
            g, c = carry_box(code, P, L, M, t)
            box = code
        return box, triangle, g, c, w0, w1, w2, c
    if code != triangle:
        w0, w1, w2 = _carried_triangle(P, L, -code - 1, M, t)
        triangle = code
    return box, triangle, g, c, w0, w1, w2, _centroid(w0, w1, w2)


@njit(allocates=False)
def _centroid(w0, w1, w2):
    return (
        (w0[0] + w1[0] + w2[0]) / 3.0,
        (w0[1] + w1[1] + w2[1]) / 3.0,
        (w0[2] + w1[2] + w2[2]) / 3.0,
    )


@njit(allocates=False)
def _gap(x, y, Pa, La, Pb, Lb, Mab, tab):
    """Cheap lower bound on the distance of the triangle pair (x, y) (codes < 0)."""
    return triangle_gap(*pair_corners(-x - 1, -y - 1, Pa, La, Pb, Lb, Mab, tab))


@njit(allocates=False)
def _children(P, L, x):
    """The (one or two) child codes of node x: a classic tree's leaf has one, its triangle."""
    c0 = child(P, L, x, 0)
    c1 = child(P, L, x, 1)
    if c0 == c1:
        return c0, c0, 1
    return c0, c1, 2


@njit(separate=True)
def mesh_distance(Pa, Pb, Mab, tab):
    """Least distance between two packed trees, B placed in A's mesh frame by (Mab, tab).

    Parameters
    ----------
    Pa, Pb : (rows, 3) float64
        Packed trees (:mod:`..mesh.packed`).
    Mab, tab : tuple of 9 float, tuple of 3 float
        B's mesh frame in A's (row-major rotation and translation).

    Returns
    -------
    distance, point_a, point_b, face_a, face_b, bound_tests, triangle_tests
        Points are tuples in A's mesh frame.
    """
    La = layout(Pa)
    Lb = layout(Pb)
    Mba, tba = inverse_pose(Mab, tab)
    bound_tests = 0
    # The children pairs of one split (one or two): (x0, y0), (x1, y1), and their bounds.
    x0 = La[6]
    y0 = Lb[6]
    x1 = y1 = 0
    n_pending = 1
    if x0 < 0 and y0 < 0:
        # Two single triangles: no tree to descend.
        d, pa, pb = triangle_distance(*pair_corners(-x0 - 1, -y0 - 1, Pa, La, Pb, Lb, Mab, tab))
        return d, pa, pb, -x0 - 1, -y0 - 1, 0, 1
    # The hulls first: where they prove the distance, no tree is descended; elsewhere the
    # triangles they measured bound the search from the start.
    proved, best, best_a, best_b, face_a, face_b, triangle_tests = hull_distance(
        Pa, La, Pb, Lb, Mab, tab
    )
    if proved:
        return best, best_a, best_b, face_a, face_b, 0, triangle_tests
    Fa, sa = support_values(Pa, La)
    Fb, sb = support_values(Pb, Lb)
    supports = sa >= 0 and sb >= 0
    stack = np.empty((8 * (tree_depth(Pa) + tree_depth(Pb)) + 16, 3))
    capacity = stack.shape[0]
    size = 0
    zeros = 0
    # B's box last carried into A's frame (reused while the same B node meets A's children),
    # and A's box last carried into B's (while one A node meets B's children)
    carried = -1
    carried_a = -1
    ga = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    ca = (0.0, 0.0, 0.0)
    # least bound first while nothing bounds the search; depth first from a bound the hulls
    # measured (see the module docstring)
    ordered = best == math.inf
    # the triangle of A (code < 0) whose corners were last carried into B's frame, and of B
    # into A's (a node facing a triangle is split, so the triangle meets both children)
    carried_triangle_a = 0
    carried_triangle_b = 0
    wa0 = wa1 = wa2 = wb0 = wb1 = wb2 = (0.0, 0.0, 0.0)
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    c = (0.0, 0.0, 0.0)
    # The root pair is bounded as a split's children are: the other side carried first
    # (A's lone triangle into B's frame, or B's root into A's).
    split_b = x0 < 0
    if split_b:
        carried_a, carried_triangle_a, ga, ca, wa0, wa1, wa2, _ = _other_side(
            x0, Pa, La, Mba, tba, carried_a, carried_triangle_a, ga, ca, wa0, wa1, wa2
        )
    else:
        carried, carried_triangle_b, g, c, wb0, wb1, wb2, _ = _other_side(
            y0, Pb, Lb, Mab, tab, carried, carried_triangle_b, g, c, wb0, wb1, wb2
        )
    # the support bounds' line of the current split (none for the root pair)
    lined = False
    line = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    weights = support_weights(0.0, 0.0, 0.0)
    reach = 0.0
    # The search runs in the inner loop until it is done or its stacks have no room for a
    # split's two pushes; the array then grows out here (numba reference-counts an array
    # variable that a loop reassigns on every pass of that loop).
    searching = True
    while searching:
        searching = False
        while True:
            if size + zeros + 2 > capacity:
                searching = True
                break
            # Measure the triangle pairs first (lowering the best distance), then bound the rest.
            b0 = math.inf
            b1 = math.inf
            for k in range(n_pending):
                x = x0 if k == 0 else x1
                y = y0 if k == 0 else y1
                if x >= 0 or y >= 0:
                    continue
                if best < math.inf and _gap(x, y, Pa, La, Pb, Lb, Mab, tab) >= best:
                    continue
                triangle_tests += 1
                corners = pair_corners(-x - 1, -y - 1, Pa, La, Pb, Lb, Mab, tab)
                d, pa, pb = triangle_distance(*corners)
                if d < best:
                    best = d
                    best_a = pa
                    best_b = pb
                    face_a = -x - 1
                    face_b = -y - 1
            if best == 0.0:
                break
            for k in range(n_pending):
                x = x0 if k == 0 else x1
                y = y0 if k == 0 else y1
                if x < 0 and y < 0:
                    continue
                bound_tests += 1
                # The support bound first (on the split's centre line, see below); the box
                # bound only where it does not prune, and then the larger of the two.
                bound = -math.inf
                if lined and split_b:
                    bound = child_gap(Pb, Lb, Fb, sb, y, line, weights, reach)
                elif lined:
                    bound = child_gap(Pa, La, Fa, sa, x, line, weights, reach)
                if bound >= best:
                    pass
                elif x >= 0 and y >= 0 and split_b:
                    R, T = box_frame(y, Pb, Lb, ga, ca)
                    hx = half_extent(Pa, La, x)
                    bound = max(bound, box_box_gap(R, T, half_extent(Pb, Lb, y), hx, best))
                elif x >= 0 and y >= 0:
                    R, T = box_frame(x, Pa, La, g, c)
                    hx = half_extent(Pa, La, x)
                    bound = max(bound, box_box_gap(R, T, hx, half_extent(Pb, Lb, y), best))
                elif x < 0:
                    # a triangle of A facing a B box: its corners carried into B's frame
                    # (already, where it is the side not split)
                    if x != carried_triangle_a:
                        wa0, wa1, wa2 = _carried_triangle(Pa, La, -x - 1, Mba, tba)
                        carried_triangle_a = x
                    bound = max(bound, _triangle_box_bound(Pb, Lb, y, wa0, wa1, wa2, best))
                else:
                    if y != carried_triangle_b:
                        wb0, wb1, wb2 = _carried_triangle(Pb, Lb, -y - 1, Mab, tab)
                        carried_triangle_b = y
                    bound = max(bound, _triangle_box_bound(Pa, La, x, wb0, wb1, wb2, best))
                if k == 0:
                    b0 = bound
                else:
                    b1 = bound
            # Pairs that may overlap (bound 0) wait on a stack, searched first and depth
            # first, so an intersection ends the search early. The others wait in a queue,
            # least bound first, while no triangle pair bounds the search (``ordered``), and
            # on a stack, depth first, once one does. The nearer child goes on at once while
            # nothing waiting comes before it.
            nearest = 1 if b1 <= b0 else 0
            least = min(b0, b1)
            go_on = least < best and (
                least == 0.0 or (zeros == 0 and (not ordered or size == 0 or least <= stack[0, 0]))
            )
            for k in range(n_pending):
                bound = b0 if k == 0 else b1
                if bound >= best or (go_on and k == nearest):
                    continue
                if bound == 0.0:
                    row = capacity - 1 - zeros
                    zeros += 1
                else:
                    row = size
                    size += 1
                stack[row, 0] = bound
                stack[row, 1] = x0 if k == 0 else x1
                stack[row, 2] = y0 if k == 0 else y1
                # a queued row sifts up
                while (
                    ordered and 0.0 < bound and row > 0
                    and stack[row, 0] < stack[(row - 1) // 2, 0]
                ):  # fmt: skip
                    parent = (row - 1) // 2
                    for j in range(3):
                        stack[row, j], stack[parent, j] = stack[parent, j], stack[row, j]
                    row = parent
            if go_on:
                x = x0 if nearest == 0 else x1
                y = y0 if nearest == 0 else y1
            elif zeros > 0:
                zeros -= 1
                x = int(stack[capacity - 1 - zeros, 1])
                y = int(stack[capacity - 1 - zeros, 2])
            elif not ordered:
                while size > 0 and stack[size - 1, 0] >= best:
                    size -= 1
                if size == 0:
                    break
                size -= 1
                x = int(stack[size, 1])
                y = int(stack[size, 2])
            else:
                if size == 0 or stack[0, 0] >= best:
                    break
                x = int(stack[0, 1])
                y = int(stack[0, 2])
                size -= 1
                for j in range(3):
                    stack[0, j] = stack[size, j]
                row = 0
                while True:
                    first = row
                    for child_row in (2 * row + 1, 2 * row + 2):
                        if child_row < size and stack[child_row, 0] < stack[first, 0]:
                            first = child_row
                    if first == row:
                        break
                    for j in range(3):
                        stack[row, j], stack[first, j] = stack[first, j], stack[row, j]
                    row = first
            # Split the larger node (a node facing a triangle is split).
            split_b = x < 0 or (y >= 0 and node_size(Pb, Lb, y) > node_size(Pa, La, x))
            # The side that is not split, carried into the split side's frame once for both
            # children (and kept while it meets the next split's): a box's axes and centre,
            # or a triangle's corners; its reference point ``anchor`` there.
            if split_b:
                c0, c1, n_pending = _children(Pb, Lb, y)
                x0 = x1 = x
                y0 = c0
                y1 = c1
                carried_a, carried_triangle_a, ga, ca, wa0, wa1, wa2, anchor = _other_side(
                    x, Pa, La, Mba, tba, carried_a, carried_triangle_a, ga, ca, wa0, wa1, wa2
                )
                split_centre = _centre(Pb, Lb, y)
            else:
                c0, c1, n_pending = _children(Pa, La, x)
                x0 = c0
                x1 = c1
                y0 = y1 = y
                carried, carried_triangle_b, g, c, wb0, wb1, wb2, anchor = _other_side(
                    y, Pb, Lb, Mab, tab, carried, carried_triangle_b, g, c, wb0, wb1, wb2
                )
                split_centre = _centre(Pa, La, x)
            # The children's support bounds share one line, from the split node's centre to
            # the anchor (unit ``u`` in the split side's frame): the fixed side's reach back
            # along it is measured once (``reach``), and where each child's support is read
            # (``weights``) is the same for both.
            wx = anchor[0] - split_centre[0]
            wy = anchor[1] - split_centre[1]
            wz = anchor[2] - split_centre[2]
            length = math.sqrt(wx * wx + wy * wy + wz * wz)
            lined = supports and length > 0.0
            if lined:
                ux = wx / length
                uy = wy / length
                uz = wz / length
                line = (anchor[0], anchor[1], anchor[2], ux, uy, uz)
                weights = support_weights(ux, uy, uz)
                # u is in B's frame where B is split (Mab carries it into A's), else in
                # A's (Mab^T carries it into B's)
                if split_b and x >= 0:
                    reach = node_reach(Fa, sa, x, Mab, False, ux, uy, uz)
                elif split_b:
                    reach = triangle_reach(wa0, wa1, wa2, anchor, ux, uy, uz)
                elif y >= 0:
                    reach = node_reach(Fb, sb, y, Mab, True, ux, uy, uz)
                else:
                    reach = triangle_reach(wb0, wb1, wb2, anchor, ux, uy, uz)
        if searching:
            stack = _grown(stack, size, zeros)
            capacity = stack.shape[0]
    return best, best_a, best_b, face_a, face_b, bound_tests, triangle_tests


@njit
def _to_world(T, p):
    return (
        T[0, 0] * p[0] + T[0, 1] * p[1] + T[0, 2] * p[2] + T[0, 3],
        T[1, 0] * p[0] + T[1, 1] * p[1] + T[1, 2] * p[2] + T[1, 3],
        T[2, 0] * p[0] + T[2, 1] * p[1] + T[2, 2] * p[2] + T[2, 3],
    )


@sealed
@njit
def _distance_kernel(P_a, T_a, P_b, T_b):
    """One query: (status, d, point on A (3 floats), point on B (3), face A, face B, bound
    tests, triangle tests); status 1 or 2: T_a or T_b is not a rigid transform."""
    if not pose_ok(T_a):
        return 1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1, -1, 0, 0
    if not pose_ok(T_b):
        return 2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1, -1, 0, 0
    M, t = relative_pose(T_a, T_b)
    d, pa, pb, fa, fb, nb, nt = mesh_distance(P_a, P_b, M, t)
    xa = _to_world(T_a, pa)
    xb = _to_world(T_a, pb)
    return 0, d, xa[0], xa[1], xa[2], xb[0], xb[1], xb[2], fa, fb, nb, nt


@sealed
@njit
def _distance_stack_kernel(P_a, T_a, P_b, T_b):
    """Distances over pose stacks T_a (k_a, 4, 4) and T_b (k_b, 4, 4) checked by
    :func:`pose_stacks`, a stack of one broadcast against the other.

    Returns (distances (k,), points (k, 2, 3), faces (k, 2), bound tests, triangle tests).
    """
    k = max(T_a.shape[0], T_b.shape[0])
    distances = np.empty(k)
    points = np.empty((k, 2, 3))
    faces = np.empty((k, 2), dtype=np.int64)
    bound_tests = 0
    triangle_tests = 0
    for i in range(k):
        Ta = pose_at(T_a, i)
        Tb = pose_at(T_b, i)
        M, t = relative_pose(Ta, Tb)
        d, pa, pb, fa, fb, nb, nt = mesh_distance(P_a, P_b, M, t)
        distances[i] = d
        xa = _to_world(Ta, pa)
        xb = _to_world(Ta, pb)
        for j in range(3):
            points[i, 0, j] = xa[j]
            points[i, 1, j] = xb[j]
        faces[i, 0] = fa
        faces[i, 1] = fb
        bound_tests += nb
        triangle_tests += nt
    return distances, points, faces, bound_tests, triangle_tests


def _is_stack(T) -> bool:
    return np.ndim(T) == 3


def pose_stacks(tree_a, T_a, tree_b, T_b, names=("T_a", "T_b"), checked=True, hull=False):
    """Packed trees and (k, 4, 4) pose stacks for a stack kernel, or ValueError.

    A lone (4, 4) pose is a stack of one; two stacks must have the same length. ``names``
    are the pose arguments' names for the messages; ``checked`` as :func:`.as_pose_stack`;
    ``hull``: the trees' arrays with their hull blocks (the distance kernels).
    """
    P_a = tree_array(tree_a, "tree_a", hull)
    P_b = tree_array(tree_b, "tree_b", hull)
    S_a = as_pose_stack(T_a, names[0], checked)
    S_b = as_pose_stack(T_b, names[1], checked)
    if len(S_a) != len(S_b) and len(S_a) != 1 and len(S_b) != 1:
        raise ValueError(
            f"{names[0]} and {names[1]} stacks must have the same length (or one pose), got "
            f"{len(S_a)} and {len(S_b)}"
        )
    return P_a, S_a, P_b, S_b


def stacked_distances(tree_a, T_a, tree_b, T_b):
    """(distances (k,), points (k, 2, 3), faces (k, 2), bound tests, triangle tests)."""
    return call_normalised(
        _distance_stack_kernel, *pose_stacks(tree_a, T_a, tree_b, T_b, hull=True)
    )


def distance(tree_a, T_a, tree_b, T_b) -> DistanceResult:
    """Least distance between two triangle meshes, and the closest points and faces.

    Parameters
    ----------
    tree_a, tree_b : OBBTree
        The two meshes' trees.
    T_a, T_b : (4, 4) or (k, 4, 4) array_like of float
        Rigid transforms from each mesh frame to the world. Either may be a stack of k poses
        (a single pose is then used with every pose of the other stack); the result's
        fields then have a leading axis of length k.

    Returns
    -------
    DistanceResult
        ``distance`` is exact up to round-off (0.0 when the meshes intersect, exactly when
        :func:`thesis_rbd.collide` reports them colliding), ``points`` (2, 3) are world
        points on A and B that far apart, ``faces`` (2,) their faces.

    Raises
    ------
    ValueError
        If a tree is not an OBBTree, or a pose is not a finite rigid (4, 4) transform (or
        two stacks differ in length).
    """
    try:
        raw = _distance_kernel(tree_a._hull_packed, T_a, tree_b._hull_packed, T_b)
    except (TypeError, AttributeError):
        if _is_stack(T_a) or _is_stack(T_b):
            distances, points, faces, nb, nt = stacked_distances(tree_a, T_a, tree_b, T_b)
            return DistanceResult(distances, points, faces, (0,) * 10 + (nb, nt))
        P_a = tree_array(tree_a, "tree_a", hull=True)
        P_b = tree_array(tree_b, "tree_b", hull=True)
        raw = call_normalised(_distance_kernel, P_a, as_pose(T_a, "T_a"), P_b, as_pose(T_b, "T_b"))
    if raw[0]:
        if raw[0] == 1:
            raise_bad_pose(T_a, "T_a")
        raise_bad_pose(T_b, "T_b")
    return DistanceResult(raw[1], None, None, raw)
