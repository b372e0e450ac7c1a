"""Study: the stability suite, hard cases with a metric, a pass/fail bound and pybullet beside us.

Contact cases are scenes from :mod:`validation.studies.contact_scenes`, built the same way in
thesis_rbd and in pybullet, stepped at 240 Hz. pybullet runs each of them twice (see
:mod:`validation.pybullet_contact`): at its defaults, and tuned for restitution as its issue
#3094 advises, so that where the tuning helps it shows:

* ``tall_stack``: ten 1 kg unit cubes in a column (library defaults: PGS, sleeping);
* ``mass_ratio_stack``: ten cubes, 1 kg at the bottom to 100 kg at the top (geometric),
  shifted sideways by up to 5 mm, ours kept awake: with the exact solver and with PGS;
* ``pyramid``: four rows of unit cubes, each resting on two below; ``pyramid_15``: fifteen
  rows, kept awake (it must stand: drift under 5 mm);
* ``card_house``: two 2 cm plates leaning against each other at 20 degrees, friction 0.6;
* ``thin_plate``: a 1 cm plate falling flat at 30 m/s (0.125 m, 12 thicknesses, per step);
* ``elastic_pile``: thirteen frictionless balls of restitution 1 in two layers on a floor of
  restitution 1;
* ``far_from_origin``: the ten-cube stack standing at (1e5, 1e5) m, compared step by step
  with the same stack at the origin;
* ``huge_scale``: a 1 km cube resting on a floor (metrics relative to the edge);
* the scale cases of issue 12, each with the library's defaults, sleeping and kept awake, and
  beside pybullet and MuJoCo (when installed) at their defaults; bodies start exactly
  touching, density 2000, on a static floor 40 body sizes wide: ``cube_10um``, ``cube_1mm``,
  ``cube_1m``, ``cube_100m`` at rest (drift and penetration within 1 % of the edge, 5 % at
  10 um), ``ball_2mm``, ``stack_2mm`` (five 2 mm cubes, 2 %), ``plate_20um_flat`` and
  ``plate_20um_tilted`` (20 um plates dropped flat and at 30 degrees come to rest on the
  floor) and ``heavy_on_light`` (100 kg on 1 kg, 1 mm); the mass-ratio stack also runs with
  the defaults.

The hard cases a new user meets in the first hour (issue 33), each beside pybullet in both
configurations and MuJoCo at its defaults (which does not carry restitution over: its
contacts are soft):

* ``struck_row``: zero gravity, a 0.1 m box at 2 m/s into five touching ones, e = 0.5: no
  energy gained, momentum kept, and the far end at least as fast as the mean velocity P / M
  (bodies of a row end ordered by speed);
* ``wall_slide``: a 0.1 m box sliding at 20 m/s on a frictionless floor into a 1 cm wall;
* ``touching_pair_strike``: zero gravity, two touching unit cubes at 300 m/s into a third;
* ``plate_column``: ten 1 mm plates dropped 1 mm apart, which must end stacked in order;
* ``dropped_rod``: a 1 x 1 x 20 cm rod dropped from 1 m, e = 0, no friction: no energy gain;
* ``drifting_pair``: zero gravity, two cubes drifting at 1 mm/s with sleeping on: momentum
  kept (a body in free flight must not fall asleep).

Free-flight cases use a 1 x 2 x 3 m box of 1 kg (ours at its defaults against pybullet's
default btMultiBody, damping 0):

* ``high_spin``: 50 rad/s about the intermediate axis, slightly off it (it flips), 10 s;
* ``long_run``: the tumbling box of the integrators study for 10^6 steps of 1/240 s (quick
  10^5);
* ``spinning_rod``: a 1 x 1 x 20 cm rod (inertia ratio 1:200) at 100 rad/s, half of it about
  the long axis, 10 s.

Metrics, all over the whole run: drift, the largest displacement of a dynamic body from where
it started; momentum drift, the largest change of the total momentum relative to its start
(zero gravity only); the case's own measures named above; deviation, the largest difference
of a body's position from the same run at the
origin (offset removed); penetration, the deepest contact reported by the engine after any
step (thesis_rbd: ``World.contacts["depths"]``; pybullet: the most negative contact distance
of ``getContactPoints``); final height, the top body's centre at the end; final speed, the
largest body speed at the end; energy gain, the largest rise of kinetic plus potential energy
over its value at the start (the energy above the floor); energy and |L| drift, relative
changes of a free body's kinetic energy and angular momentum.

Where the bounds come from. Every bound is a :class:`Bound` that names its basis; none is
derived from a setting of either engine (a slop, a sleep threshold, a solver tolerance):

* physics: a conserved quantity (energy with e = 1 and no friction, or in torque-free
  motion; |L| in torque-free motion) may change by at most a stated small fraction;
* geometry: bodies that physics holds at rest may move, or sink into each other, by at most
  ``TOLERANCE`` (1 %) of their size: drift against the body's size, penetration against the
  thinner body's thickness. One fraction for every case and scale, of the order of the
  penetration common engines accept at metre scale (Box2D's linear slop is 5 mm), and
  scale-free, so that the 1 mm and the 1 km cube are judged alike;
* numerics: a stack far from the origin may differ from the same stack at the origin by one
  rounding of its position per step (steps times the ulp of its coordinates).

A bound an engine meets whatever it does is shown as "by construction" and left out of that
engine's pass count: thesis_rbd integrates (x, q, P, L), so torque-free steps leave |L|
unchanged exactly. To add a hard case, add an entry to ``CASES`` (a scene factory, the
engines, and metrics with their bounds); the runs, tables and counts follow from it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table
from validation.studies import contact_scenes as scenes

NAME = "stability_suite"
TITLE = "Stability suite: hard cases, bounds, and pybullet beside us"

RATE = 240
FREE_BOX = (1.0, 2.0, 3.0)
TUMBLE = (0.4, 2.0, -1.1)
HIGH_SPIN = (0.05, 50.0, 0.05)  # about y, the intermediate axis of the 1 x 2 x 3 box
ROD = (0.01, 0.01, 0.2)  # 1:200 inertia ratio
ROD_SPIN = (70.0, 0.0, 70.0)  # rad/s, half about the long axis
CHECKPOINTS = 100
TOLERANCE = 0.01  # geometry bounds: the fraction of a body's size it may move or sink
FAR = 1e5  # m, the far-from-origin stack's x and y

ENGINES = {
    "ours": {"label": "thesis_rbd (defaults)", "options": {}},
    "ours_awake": {"label": "thesis_rbd (defaults), awake", "options": {"sleeping": False}},
    "ours_exact": {
        "label": "thesis_rbd, exact solver, awake",
        "options": {"contact_solver": "exact", "sleeping": False},
    },
    "ours_pgs": {
        "label": "thesis_rbd, PGS, awake",
        "options": {"contact_solver": "pgs", "sleeping": False},
    },
    # every pair through the OBBTree path, as before convex bodies had their own (issue 11)
    "ours_mesh": {"label": "thesis_rbd, mesh narrow phase", "options": {"narrow_phase": "mesh"}},
    "pybullet": {"label": "pybullet (defaults)", "configuration": "defaults"},
    "pybullet_tuned": {
        "label": "pybullet (tuned for restitution, #3094)",
        "configuration": "restitution",
    },
    "mujoco": {"label": "MuJoCo (defaults)", "mujoco": True},
}
CONTACT_PEERS = ("pybullet", "pybullet_tuned")


def _mujoco_installed() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


# MuJoCo (optional) beside pybullet at its defaults on the cases of resting contact at scale
RESTING_PEERS = ("pybullet", "mujoco") if _mujoco_installed() else ("pybullet",)
# the peers' columns of the table: MuJoCo's where it ran
TABLE_PEERS = (*CONTACT_PEERS, "mujoco") if _mujoco_installed() else CONTACT_PEERS
FREE_PEERS = ("pybullet",)
# the hard cases of issue 33 have every peer beside them
HARD_PEERS = TABLE_PEERS


@dataclass(frozen=True)
class Bound:
    """A pass/fail requirement on one metric and where its number comes from.

    Parameters
    ----------
    limit : float, (low, high) tuple, or callable
        Upper bound, closed interval, or a function of the run's result dict returning
        either (a bound that depends on the run, e.g. on its number of steps).
    basis : str
        Where the number comes from: "physics: ...", "geometry: ..." or "numerics: ...".
    construction : tuple of str
        Engines that meet the bound whatever happens (shown as "by construction", not
        counted).
    """

    limit: float | tuple | Callable
    basis: str
    construction: tuple = ()

    def resolve(self, result: dict | None):
        """The limit for one run (None when the run is missing)."""
        if callable(self.limit):
            return None if result is None else self.limit(result)
        return self.limit


def _share_of(length: float, what: str) -> Bound:
    """A geometry bound: ``TOLERANCE`` of ``length`` (m), the size of a body held at rest
    (for drift) or the thickness of the thinner body (for penetration), named by ``what``."""
    return Bound(TOLERANCE * length, f"geometry: {100 * TOLERANCE:g} % of {what}")


def _rounding_bound(result: dict) -> float:
    """One rounding of the position per step at the far stack's coordinates (|x| ~ FAR)."""
    return result["steps"] * math.ulp(FAR)


def _fraction_of_edge(share: float, what: str = "the edge") -> Bound:
    """A geometry bound on a metric already divided by the body's size: ``share`` of it."""
    return Bound(share, f"geometry: {100 * share:g} % of {what}")


CUBE_EDGE = "the 1 m cube edge"
_WALL = "the wall's 1 cm thickness"
_NO_ENERGY_ADDED = Bound(
    1e-3, "physics: a collision cannot add kinetic energy; 0.1 % of it allowed"
)
_MOMENTUM_KEPT = Bound(1e-6, "physics: nothing outside acts, so momentum is kept; 1e-6 allowed")


def _torque_free(energy: float, momentum: float) -> tuple:
    """The metrics of a torque-free case: the relative drifts of the kinetic energy and of
    |L|, which may change by ``energy`` and ``momentum`` (|L| unchanged by construction in
    thesis_rbd, which integrates L itself)."""
    return (
        (
            "energy_drift",
            "kinetic energy drift, relative",
            Bound(
                energy,
                f"physics: torque-free motion conserves energy; {format_number(energy)} allowed",
            ),
        ),
        (
            "momentum_drift",
            "|L| drift, relative",
            Bound(
                momentum,
                f"physics: torque-free motion conserves L; {format_number(momentum)} allowed",
                construction=("ours",),
            ),
        ),
    )


def _far_end_share(trace: dict, spec) -> float:
    """The row's far end's final velocity along the row over the mean velocity P / M."""
    masses = np.array([spec.bodies[i].mass for i in spec.dynamic()])
    mean = trace["momentum"][0, 0] / masses.sum()
    return float(trace["final_velocities"][-1, 0] / mean)


def _row_overlap(trace: dict, edge: float) -> float:
    """The largest overlap along x of consecutive cubes of ``edge`` in a row (m)."""
    x = trace["positions"][:, :, 0]
    return float((x[:, :-1] + edge - x[:, 1:]).max())


def _stack_error(trace: dict, thickness: float) -> float:
    """How far the plates of a column end from lying in order one on another (m)."""
    z = trace["positions"][-1, :, 2]
    return float(np.abs(z - thickness * (0.5 + np.arange(len(z)))).max())


# name -> label; scene factory (or "free"); our engines; the peers; the length scale (m)
# metrics are divided by (1 for absolute metrics); the metrics as (key, label, Bound).
CASES = {
    "tall_stack": {
        "label": "tall stack, 10 cubes",
        "scene": lambda: scenes.cube_stack(10),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "metrics": (
            ("max_drift", "largest cube drift (m)", _share_of(1.0, CUBE_EDGE)),
            ("max_penetration", "penetration (m)", _share_of(1.0, CUBE_EDGE)),
        ),
    },
    "mass_ratio_stack": {
        "label": "mass-ratio stack, 1 to 100 kg, +-5 mm",
        "scene": lambda: scenes.cube_stack(10, mass_ratio=100.0, offset=0.005),
        "engines": ("ours", "ours_exact", "ours_pgs"),
        "peers": CONTACT_PEERS,
        "metrics": (
            ("max_drift", "largest cube drift (m)", _share_of(1.0, CUBE_EDGE)),
            ("max_penetration", "penetration (m)", _share_of(1.0, CUBE_EDGE)),
        ),
    },
    "pyramid": {
        "label": "pyramid, 4 rows",
        "scene": lambda: scenes.pyramid(4),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "metrics": (
            ("max_drift", "largest cube drift (m)", _share_of(1.0, CUBE_EDGE)),
            ("max_penetration", "penetration (m)", _share_of(1.0, CUBE_EDGE)),
        ),
    },
    "pyramid_15": {
        "label": "pyramid, 15 rows, awake",
        "scene": lambda: scenes.pyramid(15),
        "engines": ("ours_awake",),
        "peers": RESTING_PEERS,
        "metrics": (
            (
                "max_drift",
                "largest cube drift (m)",
                Bound(5e-3, "geometry: 0.5 % of the 1 m cube edge: the pyramid stands"),
            ),
            ("max_penetration", "penetration (m)", _share_of(1.0, CUBE_EDGE)),
        ),
    },
    "card_house": {
        "label": "card house, two plates leaning at 20 deg",
        "scene": lambda: scenes.card_house(20.0),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "metrics": (
            (
                "max_drift",
                "largest plate drift (m)",
                _share_of(1.0, "the plates' 1 m height"),
            ),
            (
                "max_penetration",
                "penetration (m)",
                _share_of(0.02, "the plates' 2 cm thickness"),
            ),
        ),
    },
    "thin_plate": {
        "label": "thin plate, 1 cm, at 30 m/s",
        "scene": lambda: scenes.thin_plate(30.0, 0.01),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "metrics": (
            (
                "final_height",
                "plate centre height at the end (m)",
                Bound(
                    (0.0, 0.01),
                    "geometry: between the floor's top and one plate thickness above it "
                    "(below: it went into or through the floor; above: it did not land)",
                ),
            ),
            (
                "max_penetration",
                "penetration (m)",
                _share_of(0.01, "the plate's 1 cm thickness"),
            ),
        ),
    },
    "elastic_pile": {
        "label": "e = 1 pile, 13 balls",
        "scene": lambda: scenes.elastic_pile(),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "metrics": (
            (
                "energy_gain",
                "energy gain, relative",
                Bound(
                    1e-3,
                    "physics: e = 1 without friction conserves energy, and nothing may "
                    "add any; 0.1 % of it allowed",
                ),
            ),
            (
                "max_penetration",
                "penetration (m)",
                _share_of(0.5, "the balls' 0.5 m diameter"),
            ),
        ),
    },
    "far_from_origin": {
        "label": "10-cube stack at (1e5, 1e5) m",
        "scene": lambda: scenes.cube_stack(10, origin=(FAR, FAR)),
        "reference": lambda: scenes.cube_stack(10),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "metrics": (
            (
                "deviation",
                "largest deviation from the run at the origin (m)",
                Bound(
                    _rounding_bound,
                    "numerics: one rounding of the position per step, steps x ulp(|x|)",
                ),
            ),
            ("max_penetration", "penetration (m)", _share_of(1.0, CUBE_EDGE)),
        ),
    },
    "huge_scale": {
        "label": "1 km cube at rest",
        "scene": lambda: scenes.cube_stack(1, edge=1e3),
        "engines": ("ours",),
        "peers": CONTACT_PEERS,
        "length": 1e3,
        "metrics": (
            ("max_drift", "drift / edge", _share_of(1.0, "the edge")),
            ("max_penetration", "penetration / edge", _share_of(1.0, "the edge")),
        ),
    },
    **{
        f"cube_{name.replace(' ', '')}": {
            "label": f"{name} cube at rest",
            "scene": lambda edge=edge: scenes.scale_column(edge),
            "engines": ("ours", "ours_awake"),
            "peers": RESTING_PEERS,
            "length": edge,
            "metrics": (
                ("max_drift", "drift / edge", _fraction_of_edge(share)),
                ("max_penetration", "penetration / edge", _fraction_of_edge(share)),
            ),
        }
        for name, edge, share in (
            ("10 um", 1e-5, 0.05),
            ("1 mm", 1e-3, TOLERANCE),
            ("1 m", 1.0, TOLERANCE),
            ("100 m", 100.0, TOLERANCE),
        )
    },
    "ball_2mm": {
        "label": "2 mm ball at rest",
        "scene": lambda: scenes.scale_ball(2e-3),
        "engines": ("ours", "ours_awake"),
        "peers": RESTING_PEERS,
        "length": 2e-3,
        "metrics": (
            ("max_drift", "drift / diameter", _fraction_of_edge(TOLERANCE, "the diameter")),
            (
                "max_penetration",
                "penetration / diameter",
                _fraction_of_edge(TOLERANCE, "the diameter"),
            ),
        ),
    },
    "stack_2mm": {
        "label": "stack of five 2 mm cubes",
        "scene": lambda: scenes.scale_column(2e-3, count=5),
        "engines": ("ours", "ours_awake"),
        "peers": RESTING_PEERS,
        "length": 2e-3,
        "metrics": (
            ("max_drift", "largest drift / edge", _fraction_of_edge(0.02)),
            ("max_penetration", "penetration / edge", _fraction_of_edge(0.02)),
        ),
    },
    **{
        f"plate_20um_{name}": {
            "label": f"20 um plate dropped {name}",
            "scene": lambda tilt=tilt: scenes.dropped_plate(20e-6, tilt),
            "engines": ("ours", "ours_awake"),
            "peers": RESTING_PEERS,
            "metrics": (
                (
                    "final_height",
                    "plate centre height at the end (m)",
                    Bound(
                        (0.0, 20e-6),
                        "geometry: resting on the floor, between its top and one plate "
                        "thickness above it",
                    ),
                ),
            ),
        }
        for name, tilt in (("flat", 0.0), ("tilted", 30.0))
    },
    "heavy_on_light": {
        "label": "100 kg cube on a 1 kg cube",
        "scene": lambda: scenes.heavy_on_light(),
        "engines": ("ours", "ours_awake"),
        "peers": RESTING_PEERS,
        "metrics": (
            (
                "max_drift",
                "largest cube drift (m)",
                Bound(1e-3, "geometry: 0.1 % of the 1 m edge: the light cube gives no way"),
            ),
            ("max_penetration", "penetration (m)", _share_of(1.0, CUBE_EDGE)),
        ),
    },
    "struck_row": {
        "label": "box at 2 m/s into 5 touching boxes, zero g, e = 0.5",
        "scene": lambda: scenes.struck_row(5, 2.0, 0.5),
        "engines": ("ours",),
        "peers": HARD_PEERS,
        "measure": lambda trace, spec: {"far_end_share": _far_end_share(trace, spec)},
        "metrics": (
            ("energy_gain", "kinetic energy gain, relative", _NO_ENERGY_ADDED),
            ("linear_momentum_drift", "linear momentum drift, relative", _MOMENTUM_KEPT),
            (
                "far_end_share",
                "far end's final speed / (P / M)",
                Bound(
                    (1.0 - TOLERANCE, math.inf),
                    "physics: bodies of a row end ordered by speed, so the far end moves at "
                    "least at the mean velocity P / M; 1 % allowed",
                ),
            ),
            ("max_penetration", "penetration (m)", _share_of(0.1, "the boxes' 10 cm edge")),
        ),
    },
    "wall_slide": {
        "label": "box sliding at 20 m/s into a 1 cm wall",
        "scene": lambda: scenes.wall_slide(20.0, 0.01),
        "engines": ("ours",),
        "peers": HARD_PEERS,
        # the box's front face beyond the wall's near face (the box is the last body)
        "measure": lambda trace, spec: {
            "max_crossing": float(trace["positions"][:, -1, 0].max() + 0.05 - (1.0 - 0.005))
        },
        "metrics": (
            ("max_crossing", "box front beyond the wall face (m)", _share_of(0.01, _WALL)),
            ("max_penetration", "penetration (m)", _share_of(0.01, _WALL)),
        ),
    },
    "touching_pair_strike": {
        "label": "two touching cubes at 300 m/s into a third, zero g",
        "scene": lambda: scenes.touching_pair_strike(300.0),
        "engines": ("ours",),
        "peers": HARD_PEERS,
        "measure": lambda trace, spec: {"max_overlap": _row_overlap(trace, 1.0)},
        "metrics": (
            ("max_overlap", "largest overlap along the row (m)", _share_of(1.0, CUBE_EDGE)),
            ("energy_gain", "kinetic energy gain, relative", _NO_ENERGY_ADDED),
            ("linear_momentum_drift", "linear momentum drift, relative", _MOMENTUM_KEPT),
        ),
    },
    "plate_column": {
        "label": "ten 1 mm plates dropped 1 mm apart",
        "scene": lambda: scenes.plate_column(10),
        "engines": ("ours",),
        "peers": HARD_PEERS,
        "measure": lambda trace, spec: {"order_error": _stack_error(trace, 1e-3)},
        "metrics": (
            (
                "order_error",
                "largest final height error of a plate (m)",
                _share_of(1e-3, "the plates' 1 mm thickness: the stack ends in order"),
            ),
            ("max_penetration", "penetration (m)", _share_of(1e-3, "the 1 mm plate")),
        ),
    },
    "dropped_rod": {
        "label": "1 x 1 x 20 cm rod dropped, e = 0, no friction",
        "scene": lambda: scenes.dropped_rod(0),
        "engines": ("ours",),
        "peers": HARD_PEERS,
        "metrics": (
            (
                "energy_gain",
                "energy gain, relative",
                Bound(
                    1e-3,
                    "physics: without restitution or friction nothing adds energy; 0.1 % "
                    "of it allowed",
                ),
            ),
            ("max_penetration", "penetration (m)", _share_of(0.01, "the rod's 1 cm width")),
        ),
    },
    "drifting_pair": {
        "label": "two cubes drifting at 1 mm/s for 10 s, zero g, sleeping on",
        "scene": lambda: scenes.drifting_pair(1e-3),
        "seconds": 10.0,
        "engines": ("ours",),
        "peers": HARD_PEERS,
        "metrics": (("linear_momentum_drift", "linear momentum drift, relative", _MOMENTUM_KEPT),),
    },
    "spinning_rod": {
        "label": "1 x 1 x 20 cm rod tumbling at 100 rad/s",
        "scene": "free",
        "extents": ROD,
        "omega": ROD_SPIN,
        "engines": ("ours",),
        "peers": FREE_PEERS,
        "metrics": _torque_free(1e-6, 1e-9),
    },
    "high_spin": {
        "label": "high spin, 50 rad/s near the intermediate axis",
        "scene": "free",
        "omega": HIGH_SPIN,
        "engines": ("ours",),
        "peers": FREE_PEERS,
        "metrics": _torque_free(1e-3, 1e-6),
    },
    "long_run": {
        "label": "long run, tumbling box",
        "scene": "free",
        "omega": TUMBLE,
        "engines": ("ours",),
        "peers": FREE_PEERS,
        "metrics": _torque_free(1e-6, 1e-9),
    },
}

# the default narrow phase ("auto") has the mesh path beside it on every scene compared
# with a peer
for _spec in CASES.values():
    if _spec["scene"] != "free" and _spec["peers"]:
        _spec["engines"] = (*_spec["engines"], "ours_mesh")
MESH = "ours_mesh"

SECONDS = {"full": 4.0, "quick": 2.0, "tiny": 0.1}
FREE_SECONDS = {"full": 10.0, "quick": 10.0, "tiny": 1.0}
LONG_STEPS = {"full": 1_000_000, "quick": 100_000, "tiny": 2_000}


def cases(scale: str) -> list[Case]:
    """One accuracy case per hard case and engine (ours and the peers)."""
    out = []
    for name, spec in CASES.items():
        for engine in (*spec["engines"], *spec["peers"]):
            params = {"case": name, "engine": engine, "rate": RATE}
            if name == "long_run":
                params["steps"] = LONG_STEPS[scale]
            elif spec["scene"] == "free":
                params["seconds"] = FREE_SECONDS[scale]
            else:
                # a case may need longer than the others to show its fault (a body that falls
                # asleep in mid-flight does so after a few seconds still)
                params["seconds"] = max(SECONDS[scale], spec.get("seconds", 0.0))
            out.append(Case(NAME, params))
    return out


# ----------------------------------------------------------------------------- contact cases
def _box_inertia(mass, extents):
    a, b, c = extents
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def _pybullet_energy(spec, scene, dynamic):
    """Kinetic plus potential energy of pybullet's dynamic bodies."""
    total = 0.0
    for i in dynamic:
        body = spec.bodies[i]
        v, w = scene.velocity(i), scene.angular_velocity(i)
        R = Rotation.from_quat(scene.orientation(i)).as_matrix()
        if body.shape == "box":
            inertia = _box_inertia(body.mass, body.size)
        else:
            inertia = np.full(3, 0.4 * body.mass * body.size[0] ** 2)
        w_body = R.T @ w
        total += 0.5 * body.mass * v @ v + 0.5 * w_body @ (inertia * w_body)
        total += body.mass * spec.gravity * scene.position(i)[2]
    return total


def _trace(spec, engine: str, steps: int, dt: float) -> dict:
    """Step ``spec`` in ``engine``: dynamic bodies' positions (steps + 1, n, 3), the deepest
    contact after each step (steps,), the energy and the total momentum (steps + 1,) and
    (steps + 1, 3), final velocities (n, 3) and speeds (n,)."""
    dynamic = spec.dynamic()
    masses = np.array([spec.bodies[i].mass for i in dynamic])
    if "configuration" in ENGINES[engine] or "mujoco" in ENGINES[engine]:
        if "mujoco" in ENGINES[engine]:
            scene = scenes.build_mujoco(spec, dt)
        else:
            scene = scenes.build_pybullet(spec, dt, ENGINES[engine]["configuration"])

        def positions():
            return np.array([scene.position(i) for i in dynamic])

        def velocities():
            return np.array([scene.velocity(i) for i in dynamic])

        def energy():
            return _pybullet_energy(spec, scene, dynamic)

        def penetration():
            return scene.max_penetration()

        step, close = scene.step, scene.close
    else:
        world = scenes.build_world(spec, dt, **ENGINES[engine]["options"])

        def positions():
            return world.positions[dynamic].copy()

        def velocities():
            return np.array([world.linear_velocity(i) for i in dynamic])

        def energy():
            return world.kinetic_energy() + world.potential_energy()

        def penetration():
            return float(world.contacts["depths"].max(initial=0.0))

        step, close = world.step, lambda: None

    trace = {
        "positions": np.empty((steps + 1, len(dynamic), 3)),
        "penetration": np.empty(steps),
        "energy": np.empty(steps + 1),
        "momentum": np.empty((steps + 1, 3)),
    }
    trace["positions"][0], trace["energy"][0] = positions(), energy()
    trace["momentum"][0] = masses @ velocities()
    for k in range(steps):
        step()
        trace["positions"][k + 1] = positions()
        trace["penetration"][k] = penetration()
        trace["energy"][k + 1] = energy()
        trace["momentum"][k + 1] = masses @ velocities()
    trace["final_velocities"] = velocities()
    trace["speeds"] = np.linalg.norm(trace["final_velocities"], axis=1)
    close()
    return trace


def _run_contact(name: str, engine: str, seconds: float, rate: int) -> dict:
    case = CASES[name]
    spec = case["scene"]()
    dynamic = spec.dynamic()
    top = int(np.argmax([spec.bodies[i].position[2] for i in dynamic]))
    steps = round(seconds * rate)
    try:
        trace = _trace(spec, engine, steps, 1.0 / rate)
    except ValueError as refusal:
        if "mujoco" not in ENGINES[engine]:
            raise
        # MuJoCo refuses bodies whose mass or inertia is below its mjMINVAL (a 10 um cube)
        return {"refused": str(refusal).splitlines()[0]}
    x = trace["positions"]
    moved = np.linalg.norm(x - x[0], axis=2)
    # the floor's top is at z = 0, so the energy is what the bodies could release: > 0
    energy0 = trace["energy"][0]
    result = {
        "steps": steps,
        "max_drift": float(moved.max()),
        "max_penetration": float(trace["penetration"].max(initial=0.0)),
        "final_speed": float(trace["speeds"].max()),
        "energy_gain": float((trace["energy"] - energy0).max() / energy0),
        "final_height": float(x[-1, top, 2]),
    }
    momentum0 = np.linalg.norm(trace["momentum"][0])
    if spec.gravity == 0.0 and momentum0 > 0.0:
        drift = np.linalg.norm(trace["momentum"] - trace["momentum"][0], axis=1).max()
        result["linear_momentum_drift"] = float(drift / momentum0)
    if "measure" in case:
        result.update(case["measure"](trace, spec))
    if "reference" in case:
        # the same scene at the origin: what the offset alone changes
        near = _trace(case["reference"](), engine, steps, 1.0 / rate)["positions"]
        offset = x[0] - near[0]
        result["deviation"] = float(np.abs(x - offset - near).max())
    return result


# ----------------------------------------------------------------------------- free cases
def _free_box(extents):
    import thesis_rbd as rbd

    mesh = rbd.shapes.box(extents)
    return mesh, rbd.mass_properties(mesh, mass=1.0).inertia


def _run_free(engine: str, extents, omega0, steps: int, rate: int) -> dict:
    """Kinetic energy and |L| relative drift at checkpoints along a torque-free run of a box
    of ``extents`` (m, 1 kg)."""
    import thesis_rbd as rbd

    mesh, inertia = _free_box(extents)
    chunk = max(steps // CHECKPOINTS, 1)
    if "configuration" in ENGINES[engine]:
        from validation.pybullet_free_body import PybulletBox

        box = PybulletBox(extents, 1.0, np.diag(inertia), 1.0 / rate, angular_velocity=omega0)

        def advance(n):
            box.time_steps(n)

        def energy_and_momentum():
            _, q, w = box.state()
            R = Rotation.from_quat(q).as_matrix()
            L = R @ inertia @ R.T @ w
            return 0.5 * w @ L, np.linalg.norm(L)

        close = box.close
    else:
        world = rbd.World(dt=1.0 / rate)
        body = world.add_body(mesh, mass=1.0, angular_velocity=omega0)

        def advance(n):
            world.step(n)

        def energy_and_momentum():
            return world.kinetic_energy(), np.linalg.norm(world.angular_momentum(body))

        def close():
            return None

    E0, L0 = energy_and_momentum()
    done, at, energy_drift, momentum_drift = 0, [], [], []
    while done < steps:
        n = min(chunk, steps - done)
        advance(n)
        done += n
        E, L = energy_and_momentum()
        at.append(done)
        energy_drift.append(abs(E / E0 - 1.0))
        momentum_drift.append(abs(L / L0 - 1.0))
    close()
    return {
        "steps": steps,
        "step": at,
        "energy_drift_curve": energy_drift,
        "momentum_drift_curve": momentum_drift,
        "energy_drift": max(energy_drift),
        "momentum_drift": max(momentum_drift),
    }


def run(params: dict) -> dict:
    """One hard case in one engine (see the module docstring)."""
    name, engine, rate = params["case"], params["engine"], params["rate"]
    spec = CASES[name]
    if spec["scene"] == "free":
        steps = params["steps"] if "steps" in params else round(params["seconds"] * rate)
        return _run_free(engine, spec.get("extents", FREE_BOX), spec["omega"], steps, rate)
    return _run_contact(name, engine, params["seconds"], rate)


# ----------------------------------------------------------------------------- summary
def _passes(value, limit) -> bool | None:
    if value is None or limit is None:
        return None
    if isinstance(limit, tuple | list):
        return bool(limit[0] <= value <= limit[1])
    return bool(value <= limit)


def _bound_text(limit) -> str:
    if limit is None:
        return "n/a"
    if isinstance(limit, tuple | list):
        return f"in [{format_number(limit[0])}, {format_number(limit[1])}]"
    return f"<= {format_number(limit)}"


def _verdict(passed: bool | None, construction: bool = False) -> str:
    if construction:
        return "by construction"
    return "n/a" if passed is None else "pass" if passed else "FAIL"


def _count(rows: list[dict], key: str) -> dict:
    """Rows judged (by construction excluded) and rows passed, of one engine column."""
    judged = [r for r in rows if r[key] is not None]
    return {"judged": len(judged), "passed": sum(bool(r[key]) for r in judged)}


def summarise(records: list[dict], figures_dir) -> Section:
    """The pass/fail table (ours and both pybullet configurations side by side), where each
    bound comes from, and the drift figures."""
    refused = [
        {"case_label": CASES[r["params"]["case"]]["label"], "engine": r["params"]["engine"],
         "engine_label": ENGINES[r["params"]["engine"]]["label"], "reason": r["result"]["refused"]}
        for r in records
        if "refused" in r["result"]
    ]  # fmt: skip
    results = {
        (r["params"]["case"], r["params"]["engine"]): r["result"]
        for r in records
        if "refused" not in r["result"]
    }
    rows = []
    for name, spec in CASES.items():
        length = spec.get("length", 1.0)
        relative = {"max_drift", "max_penetration"} if length != 1.0 else set()
        for key, label, bound in spec["metrics"]:
            divisor = length if key in relative else 1.0

            def value(engine, key=key, divisor=divisor, name=name):
                result = results.get((name, engine))
                return None if result is None else result[key] / divisor

            def limit(engine, bound=bound, name=name):
                return bound.resolve(results.get((name, engine)))

            peers = {}
            for peer in TABLE_PEERS:
                v = value(peer) if peer in spec["peers"] else None
                peers[peer] = {
                    "value": v,
                    "bound": limit(peer),
                    "pass": _passes(v, limit(peer)),
                    "construction": peer in bound.construction,
                }
            for engine in spec["engines"]:
                v = value(engine)
                construction = engine in bound.construction
                passed = _passes(v, limit(engine))
                rows.append(
                    {
                        "case": name,
                        "case_label": spec["label"],
                        "engine": engine,
                        "engine_label": ENGINES[engine]["label"],
                        "metric": key,
                        "metric_label": label,
                        "bound": limit(engine),
                        "bound_text": _bound_text(limit(engine)),
                        "basis": bound.basis,
                        "ours": v,
                        "construction": construction,
                        # None: not judged (met by construction)
                        "pass": None if construction else passed,
                        "peers": peers,
                    }
                )
    # the mesh path is shown beside the defaults and counted apart from them
    mesh_rows = [r for r in rows if r["engine"] == MESH]
    mesh_failing = [r for r in mesh_rows if r["pass"] is False]
    rows = [r for r in rows if r["engine"] != MESH]
    failing = [r for r in rows if r["pass"] is False]
    # one peer figure per case and metric, however many of our settings sit beside it
    per_metric = list({(r["case"], r["metric"]): r for r in rows}.values())
    peer_counts = {}
    for peer in TABLE_PEERS:
        measured = [
            {"pass": None if r["peers"][peer]["construction"] else r["peers"][peer]["pass"]}
            for r in per_metric
            if r["peers"][peer]["value"] is not None
        ]
        peer_counts[peer] = _count(measured, "pass")
    tuned_helps = [
        {"case_label": r["case_label"], "metric_label": r["metric_label"]}
        for r in per_metric
        if r["peers"]["pybullet_tuned"]["pass"] and r["peers"]["pybullet"]["pass"] is False
    ]
    ours_count = _count(rows, "pass")
    summary = {
        "rate": RATE,
        "tolerance": TOLERANCE,
        "rows": rows,
        "row_count": len(rows),
        "judged_count": ours_count["judged"],
        "passing_count": ours_count["passed"],
        "construction_count": sum(r["construction"] for r in rows),
        "failing": failing,
        "mesh_count": _count(mesh_rows, "pass"),
        "mesh_failing": mesh_failing,
        "mesh_rows": mesh_rows,
        "peer_counts": peer_counts,
        "peer_labels": {peer: ENGINES[peer]["label"] for peer in TABLE_PEERS},
        "refused": refused,
        "tuned_helps": tuned_helps,
        "seconds": next(
            r["params"]["seconds"]
            for r in records
            if "seconds" in r["params"] and CASES[r["params"]["case"]]["scene"] != "free"
        ),
        "free_seconds": next(
            r["params"]["seconds"] for r in records if r["params"]["case"] == "high_spin"
        ),
        "long_steps": results[("long_run", "ours")]["steps"],
        "mass_ratio": {
            engine: results[("mass_ratio_stack", engine)]["max_drift"]
            for engine in (*CASES["mass_ratio_stack"]["engines"], *CONTACT_PEERS)
        },
    }
    peer_columns = []
    for peer in TABLE_PEERS:
        peer_columns += [ENGINES[peer]["label"], "pass"]
    table = Table(
        caption="Hard cases: each metric over the whole run, its bound, ours, pybullet's in "
        "both configurations and MuJoCo's at its defaults where it ran",
        columns=["case", "thesis_rbd setting", "metric", "bound", "ours", "pass", *peer_columns],
        rows=[
            [
                r["case_label"],
                r["engine_label"],
                r["metric_label"],
                r["bound_text"],
                format_number(r["ours"]),
                _verdict(r["pass"], r["construction"]),
                *[
                    cell
                    for peer in TABLE_PEERS
                    for cell in (
                        format_number(r["peers"][peer]["value"]),
                        _verdict(r["peers"][peer]["pass"], r["peers"][peer]["construction"]),
                    )
                ],
            ]
            for r in rows
        ],
    )
    sources = Table(
        caption="Where each bound comes from (none from a setting of either engine)",
        columns=["case", "metric", "bound", "basis"],
        rows=[
            [r["case_label"], r["metric_label"], r["bound_text"], r["basis"]] for r in per_metric
        ],
    )
    # each case's first setting (the defaults, awake where the case keeps bodies awake)
    defaults = {
        (r["case"], r["metric"]): r["ours"]
        for r in rows
        if r["engine"] == CASES[r["case"]]["engines"][0]
    }
    mesh_table = Table(
        caption="The scenes compared with a peer, with every pair through the OBBTree path "
        '(narrow_phase="mesh") beside the defaults (narrow_phase="auto": convex pairs by the '
        "convex path)",
        columns=["case", "metric", "bound", "defaults", "mesh narrow phase", "pass"],
        rows=[
            [
                r["case_label"],
                r["metric_label"],
                r["bound_text"],
                format_number(defaults.get((r["case"], r["metric"]))),
                format_number(r["ours"]),
                _verdict(r["pass"], r["construction"]),
            ]
            for r in mesh_rows
        ],
    )
    figures = [_drift_figure(results, figures_dir), _free_figure(results, figures_dir)]
    return Section(NAME, TITLE, summary, tables=[table, sources, mesh_table], figures=figures)


def _drift_figure(results, figures_dir):
    fig, ax = new_axes(
        "Contact cases: largest drift, ours and pybullet",
        "case",
        "largest body drift over the run / length scale",
        xlog=False,
    )
    names = [n for n, spec in CASES.items() if spec["scene"] != "free"]
    x = np.arange(len(names))
    engines = [e for e in ENGINES if any((n, e) in results for n in names)]
    width = 0.8 / len(engines)
    for k, engine in enumerate(engines):
        heights = [
            max(results[(n, engine)]["max_drift"] / CASES[n].get("length", 1.0), 1e-12)
            if (n, engine) in results
            # a missing bar: the engine does not run this case
            else np.nan
            for n in names
        ]
        shift = (k - (len(engines) - 1) / 2) * width
        ax.bar(x + shift, heights, width, label=ENGINES[engine]["label"])
    ax.set_xticks(x, names, rotation=35, ha="right", fontsize=8)
    ax.axhline(TOLERANCE, color="0.4", linewidth=0.8, linestyle=":")
    ax.legend(fontsize=7)
    file = f"{NAME}_drift.png"
    save_figure(fig, figures_dir / file)
    return Figure(
        file,
        "Largest displacement of any dynamic body over the run divided by the case's length "
        "scale (1 m; the edge for the 1 mm and 1 km cubes), per contact case and engine (log "
        "scale, floored at 1e-12; dotted: 1 %).",
    )


def _free_figure(results, figures_dir):
    fig, ax = new_axes(
        "Free cases: kinetic energy drift", "step", "|E/E0 - 1| (floored at 1e-17)", True, True
    )
    for name, style in (("high_spin", "-"), ("long_run", "--"), ("spinning_rod", ":")):
        for engine, color in (("ours", "tab:blue"), ("pybullet", "black")):
            result = results[(name, engine)]
            ax.plot(
                result["step"],
                np.maximum(result["energy_drift_curve"], 1e-17),
                linestyle=style,
                color=color,
                label=f"{CASES[name]['label']}, {ENGINES[engine]['label']}",
            )
    ax.legend(fontsize=7)
    file = f"{NAME}_free.png"
    save_figure(fig, figures_dir / file)
    return Figure(
        file,
        "Relative kinetic-energy drift along the high-spin run, the long run and the spinning "
        "rod, ours at its defaults against pybullet's btMultiBody (defaults, damping 0).",
    )
