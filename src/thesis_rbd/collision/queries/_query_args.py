"""Arguments of the collision queries: trees as packed buffers, poses checked inside kernels.

A query's Python wrapper hands its trees' packed arrays (:mod:`..mesh.packed`) and the poses as they
are to a *sealed* kernel (:func:`sealed`): one compiled version, for writable C-contiguous
float64 arrays, which checks inside that each pose is a finite rigid transform with the
criteria of :func:`thesis_rbd._validate.as_rigid_transform`. Arguments of any other type make
the call raise TypeError before any work; the wrapper then converts them with :func:`as_pose`
or :func:`as_pose_stack` (which raise the ValueError naming the argument) and calls again.
That keeps one compiled version per kernel and well under a microsecond of Python per query.
"""

from __future__ import annotations

import math

import numpy as np

from thesis_rbd._numba.jit import njit
from thesis_rbd._validate import RIGID_TOLERANCE, as_rigid_transform

__all__ = [
    "as_pose",
    "as_pose_stack",
    "call_normalised",
    "inverse_pose",
    "pose_at",
    "pose_ok",
    "relative_pose",
    "sealed",
    "tree_array",
]


def tree_array(tree, name: str, hull: bool = False) -> np.ndarray:
    """The packed query array of an OBBTree argument (with its hull block if ``hull``: the
    distance queries), or ValueError naming ``name``."""
    from thesis_rbd.collision.mesh.obbtree import OBBTree

    if not isinstance(tree, OBBTree):
        raise ValueError(f"{name} must be a thesis_rbd.OBBTree, got {type(tree).__name__}")
    return tree.query_array(hull)


def raise_bad_pose(T, name: str):
    """Raise the ValueError for a pose a kernel rejected (the validator names the fault)."""
    as_rigid_transform(T, name)
    raise ValueError(f"{name} is not a finite (4, 4) rigid transform")


def sealed(kernel):
    """Make a query kernel refuse to compile at call time (a decorator over ``njit``).

    A call whose argument types match no compiled version then raises TypeError at once, the
    wrapper's cue to normalise its arguments and call again through :func:`call_normalised`,
    instead of compiling a second version for, say, a read-only or Fortran-ordered pose.
    (``Dispatcher.disable_compile`` does the same but insists on a compiled version first;
    the kernels are compiled lazily, so the flag it sets is set directly.)
    """
    kernel._can_compile = False
    return kernel


def call_normalised(kernel, *args):
    """Call a sealed kernel with normalised arguments, compiling (or loading from the cache)
    its one version on first use."""
    if kernel.overloads:
        return kernel(*args)
    kernel._can_compile = True
    try:
        return kernel(*args)
    finally:
        kernel._can_compile = False


def as_pose(T, name: str) -> np.ndarray:
    """A fresh (4, 4) float64 rigid transform from ``T``, or ValueError naming ``name``."""
    return np.array(as_rigid_transform(T, name), dtype=np.float64, order="C")


def as_pose_stack(T, name: str, checked: bool = True) -> np.ndarray:
    """``T`` as a (k, 4, 4) float64 stack of rigid transforms for a kernel (a lone (4, 4) pose
    gives k = 1); copied only if it is not a writable, C-contiguous float64 array already.
    ``checked=False`` leaves the rigid-transform check of each pose to a kernel that makes
    it as it reads the pose (and calls this again with the check when one fails).

    Raises
    ------
    ValueError
        If ``T`` is not (4, 4) or (k, 4, 4) with k >= 1, or a pose is not a finite rigid
        transform (the message names ``name`` and the index of the first bad pose).
    """
    try:
        array = np.asarray(T, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(T).__name__}: {exc}") from exc
    shape = array.shape
    if array.ndim == 2:
        array = array[None]
    if array.ndim != 3 or array.shape[1:] != (4, 4):
        raise ValueError(f"{name} must have shape (4, 4) or (k, 4, 4), got {shape}")
    if len(array) == 0:
        raise ValueError(f"{name} must hold at least one pose, got shape {shape}")
    flags = array.flags
    stack = array if flags.c_contiguous and flags.writeable else np.array(array, order="C")
    bad = _first_bad_pose(stack) if checked else -1
    if bad >= 0:
        label = name if len(shape) == 2 else f"{name}[{bad}]"
        as_rigid_transform(stack[bad], label)
        raise ValueError(f"{label} is not a rigid transform")
    return stack


@njit
def _gram_ok(T, i, j, tol):
    """Whether columns i and j of T's rotation have the dot product of an orthonormal basis."""
    s = T[0, i] * T[0, j] + T[1, i] * T[1, j] + T[2, i] * T[2, j]
    return abs(s - (1.0 if i == j else 0.0)) <= tol


@njit
def pose_ok(T):
    """Whether ``T`` is a (4, 4) finite rigid transform (``as_rigid_transform``'s criteria).

    The criteria are and-ed without short-circuits: every pose a batch reads is checked, and
    one branch costs less than the sixteen a test per entry took (NaN fails every comparison).
    """
    if T.shape[0] != 4 or T.shape[1] != 4:
        return False
    ok = True
    for i in range(4):
        for j in range(4):
            ok &= math.isfinite(T[i, j])
    # np.allclose(T[3], (0, 0, 0, 1), atol=tol): |x - y| <= tol + 1e-5 |y|
    tol = RIGID_TOLERANCE
    ok &= (abs(T[3, 0]) <= tol) & (abs(T[3, 1]) <= tol) & (abs(T[3, 2]) <= tol)
    ok &= abs(T[3, 3] - 1.0) <= tol + 1e-5
    # R^T R = I: the dot products of column pairs, each pair once (the products commute).
    ok &= _gram_ok(T, 0, 0, tol) & _gram_ok(T, 1, 1, tol) & _gram_ok(T, 2, 2, tol)
    ok &= _gram_ok(T, 0, 1, tol) & _gram_ok(T, 0, 2, tol) & _gram_ok(T, 1, 2, tol)
    det = (
        T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1])
        - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
        + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0])
    )
    return ok & (det >= 0.0)


@njit
def pose_at(stack, i):
    """Pose i of a (k, 4, 4) stack, or its one pose for every i when k is 1 (broadcast)."""
    return stack[0] if stack.shape[0] == 1 else stack[i]


@njit
def _first_bad_pose(stack):
    for k in range(stack.shape[0]):
        if not pose_ok(stack[k]):
            return k
    return -1


@njit
def relative_pose(T_a, T_b):
    """``T_a^-1 T_b`` as (M, t): B's mesh frame in A's, M a row-major 9-tuple, t a 3-tuple."""
    M = (
        T_a[0, 0] * T_b[0, 0] + T_a[1, 0] * T_b[1, 0] + T_a[2, 0] * T_b[2, 0],
        T_a[0, 0] * T_b[0, 1] + T_a[1, 0] * T_b[1, 1] + T_a[2, 0] * T_b[2, 1],
        T_a[0, 0] * T_b[0, 2] + T_a[1, 0] * T_b[1, 2] + T_a[2, 0] * T_b[2, 2],
        T_a[0, 1] * T_b[0, 0] + T_a[1, 1] * T_b[1, 0] + T_a[2, 1] * T_b[2, 0],
        T_a[0, 1] * T_b[0, 1] + T_a[1, 1] * T_b[1, 1] + T_a[2, 1] * T_b[2, 1],
        T_a[0, 1] * T_b[0, 2] + T_a[1, 1] * T_b[1, 2] + T_a[2, 1] * T_b[2, 2],
        T_a[0, 2] * T_b[0, 0] + T_a[1, 2] * T_b[1, 0] + T_a[2, 2] * T_b[2, 0],
        T_a[0, 2] * T_b[0, 1] + T_a[1, 2] * T_b[1, 1] + T_a[2, 2] * T_b[2, 1],
        T_a[0, 2] * T_b[0, 2] + T_a[1, 2] * T_b[1, 2] + T_a[2, 2] * T_b[2, 2],
    )
    d0 = T_b[0, 3] - T_a[0, 3]
    d1 = T_b[1, 3] - T_a[1, 3]
    d2 = T_b[2, 3] - T_a[2, 3]
    t = (
        T_a[0, 0] * d0 + T_a[1, 0] * d1 + T_a[2, 0] * d2,
        T_a[0, 1] * d0 + T_a[1, 1] * d1 + T_a[2, 1] * d2,
        T_a[0, 2] * d0 + T_a[1, 2] * d1 + T_a[2, 2] * d2,
    )
    return M, t


@njit
def inverse_pose(M, t):
    """The inverse ``(M^T, -M^T t)`` of the rigid map ``x -> M x + t`` (M a row-major 9-tuple,
    t a 3-tuple), in the same form."""
    Mi = (M[0], M[3], M[6], M[1], M[4], M[7], M[2], M[5], M[8])
    ti = (
        -(Mi[0] * t[0] + Mi[1] * t[1] + Mi[2] * t[2]),
        -(Mi[3] * t[0] + Mi[4] * t[1] + Mi[5] * t[2]),
        -(Mi[6] * t[0] + Mi[7] * t[1] + Mi[8] * t[2]),
    )
    return Mi, ti
