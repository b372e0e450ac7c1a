"""Three-vectors as tuples of floats, for numba kernels.

Kernels in this package keep small vectors in registers as ``(x, y, z)`` tuples instead of
allocating (3,) arrays: a heap allocation per triangle test would cost more than the test.
LLVM inlines these helpers, so they cost nothing over hand-written scalar code.
"""

from __future__ import annotations

import math

from thesis_rbd._numba.jit import njit


@njit
def vec(a, i):
    """Row ``i`` of an (n, 3) array as a float64 tuple."""
    return (float(a[i, 0]), float(a[i, 1]), float(a[i, 2]))


@njit
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit
def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@njit
def lerp(a, b, t):
    """``a + t (b - a)``."""
    return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))


@njit
def matvec(R, v):
    """``R @ v`` for a (3, 3) array ``R`` and a tuple ``v``."""
    return (
        R[0, 0] * v[0] + R[0, 1] * v[1] + R[0, 2] * v[2],
        R[1, 0] * v[0] + R[1, 1] * v[1] + R[1, 2] * v[2],
        R[2, 0] * v[0] + R[2, 1] * v[1] + R[2, 2] * v[2],
    )
