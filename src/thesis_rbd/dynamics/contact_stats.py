"""What a contact solve counts, in one int64 array that the kernels fill: named indices.

``stats[ISLANDS]`` islands solved, ``stats[SWEEPS]`` PGS sweeps in all and ``stats[MAX_SWEEPS]``
of one island, ``stats[EXACT_ISLANDS]`` islands solved by Lemke's method,
``stats[UNCONVERGED]`` islands that did not converge (PGS at its sweep limit, or an exact solve
that fell back), and ``stats[BAD_BODY]`` the first body whose new state is not finite (-1:
none). The indices are module globals, so numba folds them into the kernels as constants.
"""

from __future__ import annotations

__all__ = [
    "BAD_BODY",
    "EXACT_ISLANDS",
    "ISLANDS",
    "MAX_SWEEPS",
    "STATS",
    "SWEEPS",
    "UNCONVERGED",
]

STATS = ("islands", "sweeps", "max_sweeps", "exact_islands", "unconverged", "bad_body")
ISLANDS, SWEEPS, MAX_SWEEPS, EXACT_ISLANDS, UNCONVERGED, BAD_BODY = range(len(STATS))
