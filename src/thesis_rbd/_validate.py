"""Input checks shared by every public entry point.

Public wrappers call these before any kernel runs, so bad input fails with a message that
names the argument and the fault, never deep inside numba.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "RIGID_TOLERANCE",
    "as_finite_array",
    "as_positive_scalar",
    "as_rigid_transform",
    "as_unit_quaternion",
]

# Default tolerance of :func:`as_rigid_transform` (also used by the collision kernels' own check).
RIGID_TOLERANCE = 1e-6


def as_finite_array(value, name: str, shape: tuple[int | None, ...]) -> np.ndarray:
    """Return ``value`` as a C-contiguous float64 array of the given shape, all finite.

    Parameters
    ----------
    value : array_like
        What the caller passed.
    name : str
        Argument name used in error messages.
    shape : tuple of int or None
        Expected shape; ``None`` matches any length along that axis.

    Raises
    ------
    ValueError
        On a wrong shape, a non-numeric dtype, or any NaN or infinity.
    """
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(value).__name__}: {exc}") from exc
    expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
    if array.ndim != len(shape) or any(
        s is not None and s != actual for s, actual in zip(shape, array.shape, strict=True)
    ):
        raise ValueError(f"{name} must have shape {expected}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        index = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
        raise ValueError(f"{name} holds a non-finite value {array[index]} at index {index}")
    return np.ascontiguousarray(array)


def as_positive_scalar(value, name: str) -> float:
    """Return ``value`` as a finite float > 0, or raise ValueError naming ``name``."""
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"{name} must be finite and positive, got {value!r}")
    return number


def as_unit_quaternion(value, name: str = "orientation") -> np.ndarray:
    """Return a normalised (x, y, z, w) quaternion; reject zero length and non-finite input."""
    q = as_finite_array(value, name, shape=(4,))
    # scaled by its largest component first: the sum of squares of components near 1e200
    # overflows to inf (and the quaternion became zero), and of components near 1e-200
    # underflows to zero
    largest = float(np.abs(q).max())
    if largest == 0.0:
        raise ValueError(f"{name} quaternion has zero length")
    scaled = q / largest
    norm = float(np.linalg.norm(scaled))
    if largest * norm < 1e-12:
        raise ValueError(f"{name} quaternion has zero length")
    return scaled / norm


def as_rigid_transform(value, name: str, tolerance: float = RIGID_TOLERANCE) -> np.ndarray:
    """Return ``value`` as a (4, 4) float64 rigid transform, or raise ValueError.

    A rigid transform has an orthonormal rotation block with determinant +1 (within
    ``tolerance``), any finite translation, and a last row of (0, 0, 0, 1).
    """
    T = as_finite_array(value, name, shape=(4, 4))
    if not np.allclose(T[3], (0.0, 0.0, 0.0, 1.0), atol=tolerance):
        raise ValueError(f"{name} is not a homogeneous transform: last row is {T[3].tolist()}")
    R = T[:3, :3]
    error = float(np.abs(R.T @ R - np.eye(3)).max())
    if error > tolerance or np.linalg.det(R) < 0:
        raise ValueError(
            f"{name} is not a rigid transform: rotation block is not orthonormal with det +1 "
            f"(|R^T R - I| = {error:.3g}, det = {np.linalg.det(R):.6g})"
        )
    return T
