"""Study: the Dzhanibekov flip, a hard case for free rigid-body integrators.

The 1 x 2 x 3 box of mass 1 spins at 2 pi rad/s about its intermediate axis, perturbed by
1e-3 rad/s about the other two: the spin is unstable and the body flips over periodically.
The flip times are a sharp, physical observable: the component of the body's intermediate
axis along the (constant) angular momentum changes sign at each flip. Each method runs at a
few step rates; its flip times (linear interpolation between steps) are compared with those
of :func:`validation.oracles.torque_free_reference`. A flip the method misses, or an extra
one, is reported as such.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from validation.cases import Case
from validation.formatting import format_number
from validation.oracles import torque_free_reference
from validation.plotting import METHOD_STYLES, new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "dzhanibekov"
TITLE = "Hard case: the Dzhanibekov flip (intermediate-axis instability)"

EXTENTS = (1.0, 2.0, 3.0)
MASS = 1.0
OMEGA0 = (1e-3, 2.0 * math.pi, 1e-3)
METHODS = (
    "symplectic_euler", "midpoint", "rk4", "verlet", "pybullet_multibody", "pybullet_rigidbody",
)  # fmt: skip
FLIP_TIME_BOUND = 0.01  # s: largest flip-time error that passes
CURVE_POINTS = 601

RATES = {"full": (60, 120, 240, 480, 1000), "quick": (60, 240, 1000), "tiny": (240,)}
SECONDS = {"full": 30.0, "quick": 30.0, "tiny": 11.0}
FIGURE_RATE = 240


def cases(scale: str) -> list[Case]:
    """One accuracy case per method and step rate."""
    return [
        Case(NAME, {"method": m, "rate": r, "seconds": SECONDS[scale]})
        for m in METHODS
        for r in RATES[scale]
    ]


def _sign_change_times(times, signal):
    s = np.asarray(signal)
    index = np.flatnonzero(np.signbit(s[:-1]) != np.signbit(s[1:]))
    t0, t1, s0, s1 = times[index], times[index + 1], s[index], s[index + 1]
    return t0 - s0 * (t1 - t0) / (s1 - s0)


def _axis_along_momentum(method, rate, steps, inertia):
    """(steps+1,) cosine between the body's intermediate (y) axis and its angular momentum."""
    if method.startswith("pybullet_"):
        from validation.pybullet_free_body import PybulletBox

        kind = method.removeprefix("pybullet_")
        with PybulletBox(
            EXTENTS, MASS, np.diag(inertia), 1.0 / rate, kind, angular_velocity=OMEGA0
        ) as box:
            _, q, omega = box.record(steps)
        R = Rotation.from_quat(q).as_matrix()
        L = np.einsum("nij,jk,nlk,nl->ni", R, inertia, R, omega)
    else:
        import thesis_rbd as rbd

        world = rbd.World(dt=1.0 / rate, integrator=method)
        world.add_body(rbd.shapes.box(EXTENTS), mass=MASS, angular_velocity=OMEGA0)
        bodies = world.bodies
        q, L = np.empty((steps + 1, 4)), np.empty((steps + 1, 3))
        q[0], L[0] = bodies.orientation[0], bodies.angular_momentum[0]
        for k in range(1, steps + 1):
            world.step()
            q[k], L[k] = bodies.orientation[0], bodies.angular_momentum[0]
    axis = Rotation.from_quat(q).apply([0.0, 1.0, 0.0])
    return np.einsum("ni,ni->n", axis, L) / np.linalg.norm(L, axis=1)


def run(params: dict) -> dict:
    """Flip times of one method at one step rate, and the reference's."""
    import thesis_rbd as rbd

    method, rate, seconds = params["method"], params["rate"], params["seconds"]
    inertia = rbd.mass_properties(rbd.shapes.box(EXTENTS), mass=MASS).inertia
    steps = round(seconds * rate)
    times = np.arange(steps + 1) / rate
    signal = _axis_along_momentum(method, rate, steps, inertia)
    omega_ref, _ = torque_free_reference(inertia, OMEGA0, (0.0, 0.0, 0.0, 1.0), times)
    L_ref = omega_ref @ inertia  # body frame (inertia is symmetric)
    signal_ref = L_ref[:, 1] / np.linalg.norm(L_ref, axis=1)
    flips = _sign_change_times(times, signal)
    flips_ref = _sign_change_times(times, signal_ref)
    paired = min(len(flips), len(flips_ref))
    errors = np.abs(flips[:paired] - flips_ref[:paired])
    index = np.unique(np.linspace(0, steps, CURVE_POINTS).round().astype(int))
    return {
        "flip_times": flips.tolist(),
        "reference_flip_times": flips_ref.tolist(),
        "max_flip_time_error": float(errors.max()) if paired else None,
        "same_flip_count": len(flips) == len(flips_ref),
        "curve_time": times[index].tolist(),
        "curve_axis": signal[index].tolist(),
        "curve_reference_axis": signal_ref[index].tolist(),
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Flip-time table, pass/fail against the bound, and the flip curves."""
    results = {(r["params"]["method"], r["params"]["rate"]): r["result"] for r in records}
    rates = sorted({rate for _, rate in results})
    seconds = records[0]["params"]["seconds"]
    reference = results[(METHODS[-1], rates[-1])]["reference_flip_times"]
    rows = []
    for method in METHODS:
        for rate in rates:
            res = results[(method, rate)]
            error = res["max_flip_time_error"]
            passed = res["same_flip_count"] and error is not None and error <= FLIP_TIME_BOUND
            rows.append(
                {
                    "method": method,
                    "label": METHOD_STYLES[method]["label"],
                    "rate": rate,
                    "flip_count": len(res["flip_times"]),
                    "reference_flip_count": len(res["reference_flip_times"]),
                    "first_flip": res["flip_times"][0] if res["flip_times"] else None,
                    "first_flip_error": abs(res["flip_times"][0] - res["reference_flip_times"][0])
                    if res["flip_times"] and res["reference_flip_times"]
                    else None,
                    "max_flip_time_error": error,
                    "pass": passed,
                }
            )
    figure_rate = FIGURE_RATE if FIGURE_RATE in rates else rates[0]
    at_figure_rate = {r["method"]: r for r in rows if r["rate"] == figure_rate}
    summary = {
        "omega0": list(OMEGA0),
        "seconds": seconds,
        "rates": rates,
        "reference_flip_times": reference,
        "bound": FLIP_TIME_BOUND,
        "rows": rows,
        "figure_rate": figure_rate,
        "at_figure_rate": at_figure_rate,
        "passing": [r for r in rows if r["pass"]],
    }
    table = Table(
        caption=f"Flip times over {format_number(seconds)} s against the reference "
        f"(bound {format_number(FLIP_TIME_BOUND)} s)",
        columns=[
            "method",
            "dt (s)",
            "flips (reference)",
            "first flip (s)",
            "first-flip error (s)",
            "max flip-time error (s)",
            "pass",
        ],
        rows=[
            [
                r["label"],
                f"1/{r['rate']}",
                f"{r['flip_count']} ({r['reference_flip_count']})",
                format_number(r["first_flip"]),
                format_number(r["first_flip_error"]),
                format_number(r["max_flip_time_error"]),
                format_number(r["pass"]),
            ]
            for r in rows
        ],
    )
    figures = [
        _curves_figure(results, figure_rate, figures_dir),
        _error_figure(rows, figures_dir),
    ]
    return Section(NAME, TITLE, summary, tables=[table], figures=figures)


def _curves_figure(results, rate, figures_dir):
    fig, ax = new_axes(
        f"Dzhanibekov flips at dt = 1/{rate} s",
        "time (s)",
        "intermediate axis . L / |L|",
        xlog=False,
        ylog=False,
    )
    any_result = results[(METHODS[0], rate)]
    ax.plot(
        any_result["curve_time"],
        any_result["curve_reference_axis"],
        color="0.6",
        linewidth=4,
        alpha=0.5,
        label="reference (DOP853)",
    )
    for method in ("rk4", "verlet", "pybullet_multibody", "pybullet_rigidbody"):
        res = results[(method, rate)]
        style = dict(METHOD_STYLES[method], marker=None)
        ax.plot(res["curve_time"], res["curve_axis"], linewidth=1.2, **style)
    ax.legend(fontsize=8, loc="lower left")
    save_figure(fig, figures_dir / "dzhanibekov_flips.png")
    return Figure(
        "dzhanibekov_flips.png",
        f"Cosine between the intermediate axis and the angular momentum at dt = 1/{rate} s: "
        "each sign change is a flip.",
    )


def _error_figure(rows, figures_dir):
    fig, ax = new_axes("Dzhanibekov flip-time error", "time step dt (s)", "max flip-time error (s)")
    for method in METHODS:
        mine = [r for r in rows if r["method"] == method and r["max_flip_time_error"]]
        if mine:
            ax.plot(
                [1.0 / r["rate"] for r in mine],
                [r["max_flip_time_error"] for r in mine],
                **METHOD_STYLES[method],
            )
    ax.axhline(FLIP_TIME_BOUND, color="0.5", linewidth=0.8, linestyle=":")
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "dzhanibekov_error.png")
    return Figure(
        "dzhanibekov_error.png",
        "Largest flip-time error against the step (flips paired in order); dotted: the bound.",
    )
