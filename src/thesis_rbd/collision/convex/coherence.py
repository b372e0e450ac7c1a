"""Last step's face axis of a resting pair, proved still the answer without a search.

A body resting on another keeps its axis of least penetration from step to step: the face
of one hull that the other's deepest vertex sits under. The search for that axis (EPA, or
the separating-axis test's scan of every face and edge pair) costs far more than checking
it, and this module checks it exactly.

Let n be a face of A (outward unit normal, plane n.x = d), b* the vertex of B deepest under
it (B's support along -n) and delta = d - n.b* its depth. If b* lies at least delta under
every face of A, the ball of radius delta about b* lies in A, so the ball of radius delta
about the origin lies in A - b*, a subset of the Minkowski difference M = A - B: every axis
penetrates by at least delta, and n penetrates by exactly delta. n is then the axis of least
penetration. Asking b* to lie deeper than delta + tie under every *other* face of A makes
every other face of A lose by more than the tie, so the separating-axis test (which keeps a
face of A unless beaten by more than the tie) would return this face too.

For a face of B the same holds with the roles swapped, with one more condition: the
separating-axis test prefers a face of A within the tie, so each face of A must lose by more
than the tie. A face of A at a distance s from the deepest vertex a* of A loses by at least
s (the ball about a* lies in B), so only the faces of A within the tie of a* (those around
it) need their separation computed.

Anything else (an edge pair last step, a pair apart, a vertex within the tie of another
face) goes to the full query.
"""

from __future__ import annotations

from thesis_rbd._numba.jit import njit
from thesis_rbd.collision.convex.gjk import mapped_support
from thesis_rbd.collision.convex.sat import FACE_A, FACE_B

__all__ = ["certify_face_axis"]


@njit(allocates=False)
def _deepest_under(H, row, h_other, M, c, start):
    """The vertex of hull ``h_other`` deepest under face plane ``row`` (of the reference
    hull; the other hull is mapped into its frame by x -> M x + c), climbing from its vertex
    ``start``: (depth, x, y, z, vertex), the point in the reference frame, the vertex's
    index in its hull."""
    planes = H.planes
    nx, ny, nz = planes[row, 0], planes[row, 1], planes[row, 2]
    x, y, z, local = mapped_support(H, h_other, M, c, -nx, -ny, -nz, start)
    return planes[row, 3] - (nx * x + ny * y + nz * z), x, y, z, local


@njit(allocates=False)
def _deep_under_other_faces(H, h_ref, face, x, y, z, depth):
    """Whether the point (x, y, z) (hull ``h_ref``'s frame) lies deeper than ``depth``
    under every face of ``h_ref`` but ``face``."""
    face_start, planes = H.face_start, H.planes
    f0 = face_start[h_ref]
    for row in range(f0, face_start[h_ref + 1]):
        if row - f0 == face:
            continue
        if planes[row, 3] - (planes[row, 0] * x + planes[row, 1] * y + planes[row, 2] * z) \
                <= depth:  # fmt: skip
            return False
    return True


@njit(allocates=False, separate=True)
def certify_face_axis(H, ha, hb, R, t, kind, face, start, tie, M, c):
    """Whether last step's face axis (``kind`` FACE_A or FACE_B, ``face``) is provably the
    separating-axis test's answer for hulls A and B now, and that answer.

    Parameters
    ----------
    H : tuple
        ``HullSet.arrays()`` unpacked.
    ha, hb : int
        The hulls; (R, t) maps B's frame into A's: x_A = R x_B + t.
    kind, face : int
        The cached feature.
    start : int
        A vertex of the other hull to climb from towards its deepest (last step's: the
        climb then ends where it starts); any index works, an invalid one means 0.
    tie : float
        As ``sat_query``: separations closer than this count as equal.
    M : (3, 3) float64, c : (3,) float64
        Scratch.

    Returns
    -------
    certified : bool
    separation : float
        Minus the penetration depth (< -tie when certified).
    ux, uy, uz : float
        The axis from A towards B, A's frame.
    vertex : int
        The other hull's vertex deepest under the face (B's for FACE_A, A's for FACE_B),
        its index in that hull; -1 when not certified.
    """
    face_start, planes = H.face_start, H.planes
    if kind == FACE_A:
        if face < 0 or face >= face_start[ha + 1] - face_start[ha]:
            return False, 0.0, 0.0, 0.0, 0.0, -1
        depth, x, y, z, vertex = _deepest_under(H, face_start[ha] + face, hb, R, t, start)
        if depth <= tie or not _deep_under_other_faces(H, ha, face, x, y, z, depth + tie):
            return False, 0.0, 0.0, 0.0, 0.0, -1
        row = face_start[ha] + face
        return True, -depth, planes[row, 0], planes[row, 1], planes[row, 2], vertex
    if kind != FACE_B or face < 0 or face >= face_start[hb + 1] - face_start[hb]:
        return False, 0.0, 0.0, 0.0, 0.0, -1
    # B's frame: x_B = R^T x_A - R^T t
    for i in range(3):
        c[i] = -(R[0, i] * t[0] + R[1, i] * t[1] + R[2, i] * t[2])
        for j in range(3):
            M[i, j] = R[j, i]
    row = face_start[hb] + face
    depth, x, y, z, vertex = _deepest_under(H, row, ha, M, c, start)
    if depth <= tie or not _deep_under_other_faces(H, hb, face, x, y, z, depth + tie):
        return False, 0.0, 0.0, 0.0, 0.0, -1
    # every face of A must lose by more than the tie: a face whose plane lies further than
    # the tie from A's deepest vertex does; the others are measured
    ax = R[0, 0] * x + R[0, 1] * y + R[0, 2] * z + t[0]
    ay = R[1, 0] * x + R[1, 1] * y + R[1, 2] * z + t[1]
    az = R[2, 0] * x + R[2, 1] * y + R[2, 2] * z + t[2]
    for g in range(face_start[ha + 1] - face_start[ha]):
        a_row = face_start[ha] + g
        clearance = planes[a_row, 3] - (
            planes[a_row, 0] * ax + planes[a_row, 1] * ay + planes[a_row, 2] * az
        )
        if clearance > tie:
            continue
        separation_g = -_deepest_under(H, a_row, hb, R, t, 0)[0]
        if separation_g >= -depth - tie:
            return False, 0.0, 0.0, 0.0, 0.0, -1
    ux = -(R[0, 0] * planes[row, 0] + R[0, 1] * planes[row, 1] + R[0, 2] * planes[row, 2])
    uy = -(R[1, 0] * planes[row, 0] + R[1, 1] * planes[row, 1] + R[1, 2] * planes[row, 2])
    uz = -(R[2, 0] * planes[row, 0] + R[2, 1] * planes[row, 1] + R[2, 2] * planes[row, 2])
    return True, -depth, ux, uy, uz, vertex
