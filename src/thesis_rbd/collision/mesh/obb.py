"""Oriented bounding boxes: fitting (thesis 4.5.1) and the 15-axis overlap test (4.5.2).

An OBB is stored as a centre ``c`` (3,), a rotation ``R`` (3, 3) whose *columns* are the box
axes, and half-extents ``h`` (3,), all in the mesh frame: a point ``x`` is inside when
``|R.T @ (x - c)| <= h`` componentwise.

Fitting (Gottschalk, Lin & Manocha 1996): the axes are the eigenvectors of the area-weighted
covariance of a set of triangles,

    C_jk = sum_i A_i / (12 A_H) (9 c_j c_k + p_j p_k + q_j q_k + r_j r_k) - cH_j cH_k,

taken either over the triangles of the node's convex hull (Gottschalk's choice, thesis 4.5.1)
or over the node's own triangles (RAPID's cheaper choice). Because the sums are additive, each
triangle's contribution is computed once (:func:`triangle_moments`) and a node only sums its
range. Eigenvectors come from a cyclic Jacobi iteration on the 3x3 matrix
(:func:`symmetric_eigenvectors`), which is an order of magnitude cheaper per node than a LAPACK
call from numba.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit

__all__ = ["SAT_EPSILON", "obb_disjoint", "symmetric_eigenvectors", "triangle_moments"]

# Added to |R_ij| in the overlap test, as in RAPID: when two box edges are nearly parallel
# their cross product is nearly zero and both sides of the axis inequality are rounding noise,
# which could report a false separation. The epsilon makes every projected radius slightly
# larger, so the test stays conservative (it may report overlap for boxes ~1e-6 apart, never
# a separation of overlapping boxes). It also covers float32 node storage, whose rotations are
# orthonormal only to ~6e-8.
SAT_EPSILON = 1e-6


def triangle_moments(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-triangle area, area-weighted centroid and second moment (vectorised).

    Parameters
    ----------
    triangles : (m, 3, 3) float
        Corners of each triangle (rows p, q, r), in the mesh frame.

    Returns
    -------
    area : (m,) float64
        Triangle areas A_i.
    weighted_centroid : (m, 3) float64
        A_i * c_i, with c_i the centroid.
    weighted_moment : (m, 3, 3) float64
        A_i / 12 * (9 c c^T + p p^T + q q^T + r r^T): summed over a set and divided by the
        set's area it gives the second moment whose centred form is the covariance above.
    """
    tri = np.asarray(triangles, dtype=np.float64)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    centroid = tri.mean(axis=1)
    outer = 9.0 * centroid[:, :, None] * centroid[:, None, :]
    outer += np.einsum("mvi,mvj->mij", tri, tri)
    return area, area[:, None] * centroid, (area / 12.0)[:, None, None] * outer


@njit
def symmetric_eigenvectors(C):
    """Eigenvectors of a symmetric 3x3 matrix by cyclic Jacobi rotations.

    Parameters
    ----------
    C : (3, 3) float64
        Symmetric matrix (only read).

    Returns
    -------
    (3, 3) float64
        Right-handed orthonormal matrix whose columns are the eigenvectors, ordered by
        decreasing eigenvalue (so column 0 is the direction of largest spread).
    """
    a = C.copy()
    v = np.eye(3)
    for _sweep in range(50):
        off = a[0, 1] * a[0, 1] + a[0, 2] * a[0, 2] + a[1, 2] * a[1, 2]
        diag = a[0, 0] * a[0, 0] + a[1, 1] * a[1, 1] + a[2, 2] * a[2, 2]
        if off <= 1e-30 * diag or off == 0.0:
            break
        for p in range(2):
            for q in range(p + 1, 3):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                # a <- J^T a J with J the rotation in the (p, q) plane.
                for k in range(3):
                    akp = a[k, p]
                    akq = a[k, q]
                    a[k, p] = c * akp - s * akq
                    a[k, q] = s * akp + c * akq
                for k in range(3):
                    apk = a[p, k]
                    aqk = a[q, k]
                    a[p, k] = c * apk - s * aqk
                    a[q, k] = s * apk + c * aqk
                for k in range(3):
                    vkp = v[k, p]
                    vkq = v[k, q]
                    v[k, p] = c * vkp - s * vkq
                    v[k, q] = s * vkp + c * vkq
    # Sort by decreasing eigenvalue.
    order = np.argsort(-np.array([a[0, 0], a[1, 1], a[2, 2]]))
    out = np.empty((3, 3))
    for j in range(3):
        for k in range(3):
            out[k, j] = v[k, order[j]]
    # Right-handed: third axis = first x second (also re-orthogonalises rounding).
    out[0, 2] = out[1, 0] * out[2, 1] - out[2, 0] * out[1, 1]
    out[1, 2] = out[2, 0] * out[0, 1] - out[0, 0] * out[2, 1]
    out[2, 2] = out[0, 0] * out[1, 1] - out[1, 0] * out[0, 1]
    return out


@njit
def obb_disjoint(R, T, a, b):
    """Gottschalk's 15-axis separating-axis test for two OBBs.

    Parameters
    ----------
    R : tuple of 9 float
        Row-major rotation of box B's axes expressed in box A's frame (``A.T @ B``).
    T : tuple of 3 float
        Centre of B minus centre of A, in box A's frame.
    a, b : tuple of 3 float
        Half-extents of A and B.

    Returns
    -------
    bool
        True if some axis separates the boxes (they are disjoint); False if they overlap
        (closed boxes; touching counts as overlap, and overlap is reported up to
        ``SAT_EPSILON`` times the box sizes).
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    e = SAT_EPSILON
    q00 = abs(r00) + e
    q01 = abs(r01) + e
    q02 = abs(r02) + e
    q10 = abs(r10) + e
    q11 = abs(r11) + e
    q12 = abs(r12) + e
    q20 = abs(r20) + e
    q21 = abs(r21) + e
    q22 = abs(r22) + e
    t0, t1, t2 = T
    a0, a1, a2 = a
    b0, b1, b2 = b

    # A's face axes.
    if abs(t0) > a0 + b0 * q00 + b1 * q01 + b2 * q02:
        return True
    if abs(t1) > a1 + b0 * q10 + b1 * q11 + b2 * q12:
        return True
    if abs(t2) > a2 + b0 * q20 + b1 * q21 + b2 * q22:
        return True
    # B's face axes.
    if abs(t0 * r00 + t1 * r10 + t2 * r20) > b0 + a0 * q00 + a1 * q10 + a2 * q20:
        return True
    if abs(t0 * r01 + t1 * r11 + t2 * r21) > b1 + a0 * q01 + a1 * q11 + a2 * q21:
        return True
    if abs(t0 * r02 + t1 * r12 + t2 * r22) > b2 + a0 * q02 + a1 * q12 + a2 * q22:
        return True
    # Edge-edge axes A_i x B_j.
    if abs(t2 * r10 - t1 * r20) > a1 * q20 + a2 * q10 + b1 * q02 + b2 * q01:
        return True
    if abs(t2 * r11 - t1 * r21) > a1 * q21 + a2 * q11 + b0 * q02 + b2 * q00:
        return True
    if abs(t2 * r12 - t1 * r22) > a1 * q22 + a2 * q12 + b0 * q01 + b1 * q00:
        return True
    if abs(t0 * r20 - t2 * r00) > a0 * q20 + a2 * q00 + b1 * q12 + b2 * q11:
        return True
    if abs(t0 * r21 - t2 * r01) > a0 * q21 + a2 * q01 + b0 * q12 + b2 * q10:
        return True
    if abs(t0 * r22 - t2 * r02) > a0 * q22 + a2 * q02 + b0 * q11 + b1 * q10:
        return True
    if abs(t1 * r00 - t0 * r10) > a0 * q10 + a1 * q00 + b1 * q22 + b2 * q21:
        return True
    if abs(t1 * r01 - t0 * r11) > a0 * q11 + a1 * q01 + b0 * q22 + b2 * q20:
        return True
    if abs(t1 * r02 - t0 * r12) > a0 * q12 + a1 * q02 + b0 * q21 + b1 * q20:
        return True
    return False
