"""The one numba policy of the package.

Every kernel is compiled with ``cache=True`` so that a warm interpreter loads machine code from
``__pycache__`` instead of recompiling, and without ``fastmath``: the collision and contact
kernels rely on IEEE comparisons (NaN propagation, exact ties in the broad phase) and nothing
has been measured that would justify giving that up.
"""

from __future__ import annotations

import numba

__all__ = ["njit"]


def njit(func=None, **options):
    """``numba.njit`` with the package policy (``cache=True``, ``fastmath=False``).

    Usable bare (``@njit``) or with extra options (``@njit(inline="always")``).
    """
    options = {"cache": True, "fastmath": False, **options}
    if func is None:
        return numba.njit(**options)
    return numba.njit(**options)(func)
