"""How contacts are resolved, and the tolerances that scale with the bodies and the step.

No tolerance of the contact stages is an absolute length or speed: a 10 um part and a 100 m
block behave alike. Each contact derives its own from the smaller of its two dynamic bodies'
thicknesses (the least width of the body's hull; a static body does not count, so a 1 mm
cube on a 40 m floor gets the cube's tolerances) and from the step:

* slop = ``SLOP_FRACTION`` x thickness: the penetration a resting contact is held at.
  Contacts are found by overlap, so a contact at zero depth would flicker in and out of
  existence on round-off; one held a thousandth of the body deep is found every step.
* penetration beyond the slop is removed through the velocities, ``BAUMGARTE`` of it per step
  (an impulse at the contact point, so momentum and angular momentum are untouched);
  a contact shallower than the slop may sink towards it at the same rate;
* PGS sweeps stop once every contact's velocity is right to ``tolerance`` x slop / dt,
  or, if that is looser, to ``tolerance`` x the fastest contact-point speed of
  its island before the step's forces (so the g dt the forces add each step does not count).
  A resting island has no such speed and is held to the slop's tolerance, which keeps a stack
  from creeping; a tumbling heap is solved to a thousandth of its own motion instead of to a
  millionth of its bodies' size per step, which Gauss-Seidel reaches only after hundreds of
  sweeps on a heap.
* bounce threshold = 2 |du_n| + ``BOUNCE_SLOP_SPEED`` x slop / dt, where du_n is the change of
  the contact's normal velocity that the step's forces alone cause: a contact approaching
  slower than that is the resting contact of a body that just gained g dt, not an impact.

Contact solvers are "auto" (projected Gauss-Seidel; an island that has not converged after
``iterations`` sweeps and has at most ``EXACT_CONTACTS`` contacts is solved exactly by
Lemke's method, which is what keeps a heavy body on a light one), "pgs" (never exact) and
"exact" (Lemke on every island).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "BAUMGARTE",
    "BOUNCE_SLOP_SPEED",
    "EXACT_CONTACTS",
    "SLOP_FRACTION",
    "ContactSettings",
]

SLOP_FRACTION = 1e-3
BAUMGARTE = 0.2
BOUNCE_SLOP_SPEED = 0.1
EXACT_CONTACTS = 16
# Sweeps stop once every contact's velocity is right to this fraction of its slop per step
# (the position error it leaves is a thousandth of the slop per step), or, if looser, to this
# fraction of the fastest contact-point speed of its island before the step's forces (an
# island in motion is solved to a thousandth of its motion).
PGS_TOLERANCE = 1e-3

SOLVERS = ("auto", "pgs", "exact")
PENETRATION = ("toi", "bias")

# Positions in the settings array the kernels take (one array is one argument to pass).
DT, SLOP, BIAS_RATE, BOUNCE_SPEED, TOLERANCE, ITERATIONS, SOLVER, EXACT_LIMIT = range(8)
RELATIVE_TOLERANCE = 8


@dataclass(frozen=True)
class ContactSettings:
    """How contacts are resolved.

    Attributes
    ----------
    solver : {"auto", "pgs", "exact"}
        See the module docstring.
    iterations : int
        Largest number of projected Gauss-Seidel sweeps per island and step (they stop
        earlier once converged). A tall stack solved unwarmed takes a few hundred sweeps;
        a cap below that leaves it unconverged step after step, and an unconverged solve
        amplifies round-off (the stability suite's stack far from the origin).
    friction_sides : int
        Sides of the polygon approximating the friction cone (>= 3).
    tolerance : float
        PGS sweeps stop once every contact's velocity is right to this fraction of its
        slop per step, or of its island's fastest contact-point speed (see the module
        docstring); in (0, 1). A study's reference run tightens it.
    penetration : {"toi", "bias"}
        "toi": a body in free flight that ends its step inside another is stepped back to
        its time of impact, collides there and travels on (a bounce keeps its energy);
        "bias": it is left where it ended and pushed out by the velocity bias over the next
        steps.
    """

    solver: str = "auto"
    iterations: int = 300
    friction_sides: int = 8
    penetration: str = "toi"
    tolerance: float = PGS_TOLERANCE

    def __post_init__(self):
        if self.solver not in SOLVERS:
            raise ValueError(f"unknown contact solver {self.solver!r}; choose one of {SOLVERS}")
        if self.penetration not in PENETRATION:
            raise ValueError(
                f"unknown penetration handling {self.penetration!r}; choose one of {PENETRATION}"
            )
        if int(self.iterations) != self.iterations or self.iterations < 1:
            raise ValueError(f"iterations must be an integer >= 1, got {self.iterations!r}")
        if int(self.friction_sides) != self.friction_sides or self.friction_sides < 3:
            raise ValueError(f"friction_sides must be an integer >= 3, got {self.friction_sides!r}")
        if not (isinstance(self.tolerance, (int, float)) and 0 < self.tolerance < 1):
            raise ValueError(f"contact_tolerance must be in (0, 1), got {self.tolerance!r}")

    def as_array(self, dt: float) -> np.ndarray:
        """The settings as the float64 array the contact kernels read (indices above)."""
        values = np.empty(9)
        values[DT] = dt
        values[SLOP] = SLOP_FRACTION
        values[BIAS_RATE] = BAUMGARTE
        values[BOUNCE_SPEED] = BOUNCE_SLOP_SPEED
        values[TOLERANCE] = self.tolerance
        values[ITERATIONS] = self.iterations
        values[SOLVER] = SOLVERS.index(self.solver)
        values[EXACT_LIMIT] = EXACT_CONTACTS
        values[RELATIVE_TOLERANCE] = self.tolerance
        return values
