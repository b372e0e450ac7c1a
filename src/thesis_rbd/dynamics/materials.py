"""How two bodies' materials combine at a contact between them: one rule for every solver.

Restitution combines as the product (a perfectly inelastic body, e = 0, stops any bounce;
two elastic ones, e = 1, bounce fully), friction as the geometric mean (a frictionless body
slides on anything), as Bullet combines them by default.
"""

from __future__ import annotations

import math

from thesis_rbd._numba.jit import njit

__all__ = ["combined_friction", "combined_restitution"]


@njit(allocates=False)
def combined_restitution(restitution, a, b):
    """Restitution of a contact between bodies a and b, from ``restitution`` (n,)."""
    return restitution[a] * restitution[b]


@njit(allocates=False)
def combined_friction(friction, a, b):
    """Friction coefficient of a contact between bodies a and b, from ``friction`` (n,)."""
    return math.sqrt(friction[a] * friction[b])
