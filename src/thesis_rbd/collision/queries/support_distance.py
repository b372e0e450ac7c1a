"""Lower bounds on the distance of two tree nodes from their supports on the centre line.

Two sets are at least ``d - h_A(u) - h_B(-u)`` apart, where ``d u`` (``|u| = 1``) runs from
a point of A to a point of B and ``h`` is each set's support function about that point: the
gap between their projections on ``u``. Taken on the line through two nodes' box centres
with the nodes' stored supports (:mod:`..mesh.packed_support`), it is close to the true
distance of two small or far-apart nodes, and it prunes most of the node pairs a box bound
(:mod:`.box_distance`) leaves open around the closest pair of two curved meshes.

A descent splits one node of a pair and bounds its children against the other side (a node
or a triangle). Both children are bounded on one line, from the split node's centre to the
other side's reference point (its box centre, or a triangle's centroid): any line gives a
valid bound, and sharing it measures the other side's reach along it once and finds where
the children's supports are read once (:func:`.packed_support.support_weights`), leaving
three stored values per child. A triangle's support is exact, from its corners.

The supports are taken about the nodes' centres, so every term is of the nodes' size; each
bound is lowered by ``1e-12`` of the terms it subtracts to cover their round-off.
"""

from __future__ import annotations

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.mesh.packed import corner
from thesis_rbd.collision.mesh.packed_support import support_along, support_at

__all__ = ["child_gap", "node_reach", "triangle_reach"]

# Relative allowance for the round-off of the stored supports and the bound's own terms
_MARGIN = 1e-12


@njit(inline="always")
def node_reach(F, start, k, M, transposed, ux, uy, uz):
    """How far node k of a tree reaches back from its centre along ``-u``, for ``u`` given
    in the other tree's frame: its support along ``-M u`` (``-M^T u`` if ``transposed``),
    M the row-major rotation between the two frames.

    Parameters
    ----------
    F : (2 m,) float32
        The node's packed tree read as float32; ``start`` its support block's index there.
    """
    if transposed:
        return support_along(
            F, start, k,
            -(M[0] * ux + M[3] * uy + M[6] * uz),
            -(M[1] * ux + M[4] * uy + M[7] * uz),
            -(M[2] * ux + M[5] * uy + M[8] * uz),
        )  # fmt: skip
    return support_along(
        F, start, k,
        -(M[0] * ux + M[1] * uy + M[2] * uz),
        -(M[3] * ux + M[4] * uy + M[5] * uz),
        -(M[6] * ux + M[7] * uy + M[8] * uz),
    )  # fmt: skip


@njit(inline="always")
def triangle_reach(w0, w1, w2, anchor, ux, uy, uz):
    """How far a triangle reaches back from ``anchor`` along ``-u``: the largest
    ``-u . (w - anchor)`` over its corners ``w0, w1, w2`` (tuples of 3 float)."""
    return max(
        ux * (anchor[0] - w0[0]) + uy * (anchor[1] - w0[1]) + uz * (anchor[2] - w0[2]),
        ux * (anchor[0] - w1[0]) + uy * (anchor[1] - w1[1]) + uz * (anchor[2] - w1[2]),
        ux * (anchor[0] - w2[0]) + uy * (anchor[1] - w2[1]) + uz * (anchor[2] - w2[2]),
    )


@njit(inline="always")
def child_gap(P, L, F, start, k, line, weights, reach):
    """Lower bound on the distance of code k of a tree (node or triangle) and the other side.

    Parameters
    ----------
    P, L : packed tree and its layout (:mod:`..mesh.packed`); ``F`` the same array read as
        float32, ``start`` its support block's index there (:func:`..mesh.packed.support_values`).
    k : int
        The child code (``k >= 0`` node, else triangle ``-k - 1``).
    line : tuple of 6 float
        The other side's reference point and the unit direction ``u`` toward it from the
        split node's centre, in this tree's mesh frame.
    weights : tuple
        :func:`.packed_support.support_weights` of ``u``.
    reach : float
        The other side's reach back from its reference point along ``-u``
        (:func:`triangle_reach`, or a node's support along ``-u``).
    """
    ax, ay, az, ux, uy, uz = line
    if k >= 0:
        r = L[0] + k
        ahead = ux * (ax - P[r, 0]) + uy * (ay - P[r, 1]) + uz * (az - P[r, 2])
        h = support_at(F, start, k, weights)
        return ahead - h - reach - _MARGIN * (abs(ahead) + abs(h) + abs(reach))
    v0 = corner(P, L, -k - 1, 0)
    v1 = corner(P, L, -k - 1, 1)
    v2 = corner(P, L, -k - 1, 2)
    ahead = min(
        ux * (ax - v0[0]) + uy * (ay - v0[1]) + uz * (az - v0[2]),
        ux * (ax - v1[0]) + uy * (ay - v1[1]) + uz * (az - v1[2]),
        ux * (ax - v2[0]) + uy * (ay - v2[1]) + uz * (az - v2[2]),
    )
    return ahead - reach - _MARGIN * (abs(ahead) + abs(reach))
