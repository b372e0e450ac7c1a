"""Study: what accuracy costs in time for free rigid-body motion (issue 7, item 1).

A 1 x 2 x 3 box of mass 1 tumbles torque-free from w0 = (0.4, 2.0, -1.1) rad/s (an asymmetric
body, so its angular velocity wanders: Euler's equations are exercised, not just a constant
spin). Each integrator of the library, and pybullet as a peer, runs it for ``seconds`` at a
geometric sweep of step rates from 60 to 4000 Hz. The error is the largest orientation error
(rotation angle) along the run against :func:`validation.oracles.torque_free_reference`; the
cost is the wall-clock time per simulated second, the least of several repeats of the bare
step loop (no recording). Accuracy and timing are separate cases: accuracy cases may run in
parallel, timing cases run alone. A thin rod (1 x 1 x 20 cm) tumbling at 100 rad/s, at 240 Hz
for 1 s, shows what each method keeps of the kinetic energy where the body's inertia ratio is
large (the explicit methods turn the body by a rotation its spin does not conserve).
"""

from __future__ import annotations

import time
from functools import cache

import numpy as np
from scipy.spatial.transform import Rotation

from validation.cases import Case
from validation.formatting import format_number
from validation.oracles import REFERENCE_RTOL, rotation_angle_between, torque_free_reference
from validation.plotting import METHOD_STYLES, new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "integrators"
TITLE = "Integrators: accuracy against cost on the torque-free tumbling box"

EXTENTS = (1.0, 2.0, 3.0)
MASS = 1.0
OMEGA0 = (0.4, 2.0, -1.1)
LIBRARY_METHODS = ("euler", "symplectic_euler", "midpoint", "rk4", "verlet")
PYBULLET_METHODS = ("pybullet_multibody", "pybullet_rigidbody")
METHODS = LIBRARY_METHODS + PYBULLET_METHODS
HEADLINE_RATE = 240
ERROR_TARGET = 1e-3  # rad: the accuracy the cost comparison asks for
CURVE_POINTS = 101
ORDER_FIT_RANGE = (1e-11, 0.1)  # rad: above round-off, below saturation
# a thin rod (inertia ratio 1:200) tumbling at 100 rad/s, half of it about the long axis:
# where an explicit turn feeds energy into the spin about the long axis
ROD = (0.01, 0.01, 0.2)
ROD_SPIN = (70.0, 0.0, 70.0)

RATES = {
    "full": (60, 90, 120, 180, 240, 360, 480, 720, 1000, 1500, 2000, 3000, 4000),
    "quick": (60, 240, 1000, 4000),
    "tiny": (60, 240),
}
SECONDS = {"full": 10.0, "quick": 10.0, "tiny": 2.0}
REPEATS = {"full": 5, "quick": 3, "tiny": 1}


def cases(scale: str) -> list[Case]:
    """Accuracy and timing cases for every method and step rate of ``scale``, and the thin
    rod at the headline rate."""
    out = [
        Case(NAME, {"kind": "rod", "method": method, "rate": HEADLINE_RATE, "seconds": 1.0})
        for method in METHODS
    ]
    for method in METHODS:
        for rate in RATES[scale]:
            common = {"method": method, "rate": rate, "seconds": SECONDS[scale]}
            out.append(Case(NAME, {"kind": "accuracy", **common}))
            out.append(
                Case(NAME, {"kind": "timing", **common, "repeats": REPEATS[scale]}, timed=True)
            )
    return out


@cache
def _box(extents=EXTENTS):
    import thesis_rbd as rbd

    mesh = rbd.shapes.box(extents)
    inertia = rbd.mass_properties(mesh, mass=MASS).inertia
    return mesh, inertia


def _library_world(method: str, rate: int, extents=EXTENTS, omega=OMEGA0):
    import thesis_rbd as rbd

    mesh, _ = _box(extents)
    world = rbd.World(dt=1.0 / rate, integrator=method)
    world.add_body(mesh, mass=MASS, angular_velocity=omega)
    return world


def _pybullet_box(method: str, rate: int, extents=EXTENTS, omega=OMEGA0):
    from validation.pybullet_free_body import PybulletBox

    _, inertia = _box(extents)
    kind = method.removeprefix("pybullet_")
    return PybulletBox(extents, MASS, np.diag(inertia), 1.0 / rate, kind, angular_velocity=omega)


def _trajectory(method: str, rate: int, steps: int, extents=EXTENTS, omega=OMEGA0):
    """Orientations (steps+1, 4) and world angular momenta (steps+1, 3) along the run."""
    _, inertia = _box(extents)
    if method in LIBRARY_METHODS:
        world = _library_world(method, rate, extents, omega)
        bodies = world.bodies
        q = np.empty((steps + 1, 4))
        L = np.empty((steps + 1, 3))
        q[0], L[0] = bodies.orientation[0], bodies.angular_momentum[0]
        for k in range(1, steps + 1):
            world.step()
            q[k], L[k] = bodies.orientation[0], bodies.angular_momentum[0]
        return q, L
    with _pybullet_box(method, rate, extents, omega) as box:
        _, q, omega = box.record(steps)
    R = Rotation.from_quat(q).as_matrix()
    L = np.einsum("nij,jk,nlk,nl->ni", R, inertia, R, omega)
    return q, L


def _downsample(times, values):
    index = np.unique(np.linspace(0, len(times) - 1, CURVE_POINTS).round().astype(int))
    return [float(t) for t in times[index]], [float(v) for v in values[index]]


def _run_accuracy(method: str, rate: int, seconds: float) -> dict:
    _, inertia = _box()
    steps = round(seconds * rate)
    times = np.arange(steps + 1) / rate
    q, L = _trajectory(method, rate, steps)
    _, q_ref = torque_free_reference(inertia, OMEGA0, (0.0, 0.0, 0.0, 1.0), times)
    angle = rotation_angle_between(q, q_ref)
    L_body = Rotation.from_quat(q).inv().apply(L)
    energy = 0.5 * np.einsum("ni,ij,nj->n", L_body, np.linalg.inv(inertia), L_body)
    energy_drift = np.abs(energy / energy[0] - 1.0)
    momentum = np.linalg.norm(L, axis=1)
    momentum_drift = np.abs(momentum / momentum[0] - 1.0)
    curve_t, curve_energy = _downsample(times, energy_drift)
    _, curve_angle = _downsample(times, angle)
    return {
        "steps": steps,
        "max_angle_error": float(angle.max()),
        "final_angle_error": float(angle[-1]),
        "max_energy_drift": float(energy_drift.max()),
        "final_energy_drift": float(energy_drift[-1]),
        "max_momentum_drift": float(momentum_drift.max()),
        "curve_time": curve_t,
        "curve_energy_drift": curve_energy,
        "curve_angle_error": curve_angle,
    }


def _run_timing(method: str, rate: int, seconds: float, repeats: int) -> dict:
    steps = round(seconds * rate)
    samples = []
    if method in LIBRARY_METHODS:
        _library_world(method, rate).step(2)  # compile or load the kernels outside the timing
        for _ in range(repeats):
            world = _library_world(method, rate)
            start = time.perf_counter()
            world.step(steps)
            samples.append(time.perf_counter() - start)
    else:
        for _ in range(repeats):
            with _pybullet_box(method, rate) as box:
                samples.append(box.time_steps(steps))
    best = min(samples)
    return {
        "steps": steps,
        "samples": samples,
        "seconds_per_simulated_second": best / seconds,
        "microseconds_per_step": 1e6 * best / steps,
    }


def _run_rod(method: str, rate: int, seconds: float) -> dict:
    """The thin rod: the largest kinetic energy over the run relative to its start, and the
    largest relative change of |L|."""
    _, inertia = _box(ROD)
    steps = round(seconds * rate)
    q, L = _trajectory(method, rate, steps, ROD, ROD_SPIN)
    L_body = Rotation.from_quat(q).inv().apply(L)
    energy = 0.5 * np.einsum("ni,ij,nj->n", L_body, np.linalg.inv(inertia), L_body)
    momentum = np.linalg.norm(L, axis=1)
    return {
        "steps": steps,
        "max_energy_ratio": float(energy.max() / energy[0]),
        "max_energy_drift": float(np.abs(energy / energy[0] - 1.0).max()),
        "max_momentum_drift": float(np.abs(momentum / momentum[0] - 1.0).max()),
    }


def run(params: dict) -> dict:
    """One accuracy, timing or thin-rod case (see the module docstring)."""
    if params["kind"] == "rod":
        return _run_rod(params["method"], params["rate"], params["seconds"])
    if params["kind"] == "accuracy":
        return _run_accuracy(params["method"], params["rate"], params["seconds"])
    return _run_timing(params["method"], params["rate"], params["seconds"], params["repeats"])


def _convergence_order(dts, errors):
    """Least-squares slope of log(error) against log(dt) where the error lies in
    ``ORDER_FIT_RANGE`` (its asymptotic range); None with fewer than 2 such points."""
    dts, errors = np.asarray(dts), np.asarray(errors)
    keep = (errors > ORDER_FIT_RANGE[0]) & (errors < ORDER_FIT_RANGE[1])
    if keep.sum() < 2:
        return None
    return float(np.polyfit(np.log(dts[keep]), np.log(errors[keep]), 1)[0])


def summarise(records: list[dict], figures_dir) -> Section:
    """Pareto and convergence figures, energy drift, tables, and the cost of a target error."""
    accuracy, timing, rod = {}, {}, {}
    for record in records:
        p = record["params"]
        target = {"accuracy": accuracy, "timing": timing, "rod": rod}[p["kind"]]
        target[(p["method"], p["rate"])] = record["result"]
    rod_seconds = next(r["params"]["seconds"] for r in records if r["params"]["kind"] == "rod")
    rod = {method: result for (method, _), result in rod.items()}
    rates = sorted({rate for _, rate in accuracy})
    seconds = records[0]["params"]["seconds"]
    methods = {}
    for method in METHODS:
        points = [
            {
                "rate": rate,
                "dt": 1.0 / rate,
                "max_angle_error": accuracy[(method, rate)]["max_angle_error"],
                "max_energy_drift": accuracy[(method, rate)]["max_energy_drift"],
                "max_momentum_drift": accuracy[(method, rate)]["max_momentum_drift"],
                "seconds_per_simulated_second": timing[(method, rate)][
                    "seconds_per_simulated_second"
                ],
                "microseconds_per_step": timing[(method, rate)]["microseconds_per_step"],
            }
            for rate in rates
        ]
        reaching = [p for p in points if p["max_angle_error"] <= ERROR_TARGET]
        cheapest = min(reaching, key=lambda p: p["seconds_per_simulated_second"], default=None)
        methods[method] = {
            "label": METHOD_STYLES[method]["label"],
            "points": points,
            "order": _convergence_order(
                [p["dt"] for p in points], [p["max_angle_error"] for p in points]
            ),
            "cheapest_within_target": cheapest,
        }
    rk4_errors = [p["max_angle_error"] for p in methods["rk4"]["points"]]
    rk4_floor = min(rk4_errors)
    rk4_floor_rate = next(
        p["rate"] for p in methods["rk4"]["points"] if p["max_angle_error"] <= 2 * rk4_floor
    )
    headline_rate = HEADLINE_RATE if HEADLINE_RATE in rates else rates[len(rates) // 2]
    headline = {
        method: next(p for p in methods[method]["points"] if p["rate"] == headline_rate)
        for method in METHODS
    }
    summary = {
        "extents": list(EXTENTS),
        "mass": MASS,
        "omega0": list(OMEGA0),
        "seconds": seconds,
        "reference_rtol": REFERENCE_RTOL,
        "order_fit_range": list(ORDER_FIT_RANGE),
        "rates": rates,
        "error_target": ERROR_TARGET,
        "headline_rate": headline_rate,
        "headline": headline,
        "methods": methods,
        "rk4_floor": rk4_floor,
        "rk4_floor_rate": rk4_floor_rate,
        "rk4_vs_pybullet_error_ratio": headline["pybullet_multibody"]["max_angle_error"]
        / headline["rk4"]["max_angle_error"],
        "rk4_vs_pybullet_cost_ratio": headline["rk4"]["seconds_per_simulated_second"]
        / headline["pybullet_multibody"]["seconds_per_simulated_second"],
        "verlet_vs_rk4_cost_ratio": headline["verlet"]["seconds_per_simulated_second"]
        / headline["rk4"]["seconds_per_simulated_second"],
        "rod": {
            "extents": list(ROD),
            "omega": list(ROD_SPIN),
            "seconds": rod_seconds,
            "rate": HEADLINE_RATE,
            "methods": {m: {"label": METHOD_STYLES[m]["label"], **rod[m]} for m in METHODS},
        },
    }
    figures = [
        _pareto_figure(methods, seconds, rates, figures_dir),
        _convergence_figure(methods, seconds, figures_dir),
        _energy_figure(accuracy, headline_rate, figures_dir),
    ]
    return Section(
        study=NAME,
        title=TITLE,
        summary=summary,
        tables=[*_tables(methods, rates, headline_rate), _rod_table(summary["rod"])],
        figures=figures,
    )


def _tables(methods, rates, headline_rate):
    headline_rows = []
    for m in methods.values():
        p = next(p for p in m["points"] if p["rate"] == headline_rate)
        cheapest = m["cheapest_within_target"]
        headline_rows.append(
            [
                m["label"],
                format_number(p["max_angle_error"]),
                format_number(p["max_energy_drift"]),
                format_number(p["max_momentum_drift"]),
                format_number(p["microseconds_per_step"]),
                format_number(p["seconds_per_simulated_second"]),
                format_number(m["order"]),
                "none" if cheapest is None else f"1/{cheapest['rate']}",
                "n/a"
                if cheapest is None
                else format_number(cheapest["seconds_per_simulated_second"]),
            ]
        )
    error_rows = [
        [m["label"]] + [format_number(p["max_angle_error"]) for p in m["points"]]
        for m in methods.values()
    ]
    cost_rows = [
        [m["label"]] + [format_number(p["seconds_per_simulated_second"]) for p in m["points"]]
        for m in methods.values()
    ]
    rate_columns = [f"dt = 1/{rate}" for rate in rates]
    return [
        Table(
            caption=f"At dt = 1/{headline_rate} s, and the cheapest step reaching "
            f"{format_number(ERROR_TARGET)} rad",
            columns=[
                "method",
                "max angle error (rad)",
                "max energy drift",
                "max |L| drift",
                "us per step",
                "s per simulated s",
                "measured order",
                "largest dt within target",
                "its s per simulated s",
            ],
            rows=headline_rows,
        ),
        Table(
            caption="Max orientation error (rad) against the step",
            columns=["method", *rate_columns],
            rows=error_rows,
        ),
        Table(
            caption="Wall-clock seconds per simulated second against the step",
            columns=["method", *rate_columns],
            rows=cost_rows,
        ),
    ]


def _rod_table(rod):
    return Table(
        caption=f"A {' x '.join(format_number(100 * e) for e in rod['extents'])} cm rod "
        f"(1 kg) tumbling at ({', '.join(format_number(w) for w in rod['omega'])}) rad/s "
        f"for {format_number(rod['seconds'])} s at dt = 1/{rod['rate']} s: what each method "
        "keeps of its kinetic energy and angular momentum",
        columns=["method", "largest kinetic energy / start", "max energy drift", "max |L| drift"],
        rows=[
            [
                m["label"],
                format_number(m["max_energy_ratio"]),
                format_number(m["max_energy_drift"]),
                format_number(m["max_momentum_drift"]),
            ]
            for m in rod["methods"].values()
        ],
    )


def _plot_method(ax, method, x, y):
    style = dict(METHOD_STYLES[method])
    ax.plot(x, y, markersize=5, **style)


def _pareto_figure(methods, seconds, rates, figures_dir):
    fig, ax = new_axes(
        f"Accuracy against cost, torque-free box, {format_number(seconds)} s",
        "wall-clock seconds per simulated second",
        "max orientation error (rad)",
    )
    for method, m in methods.items():
        points = m["points"]
        _plot_method(
            ax,
            method,
            [p["seconds_per_simulated_second"] for p in points],
            [p["max_angle_error"] for p in points],
        )
    ax.axhline(ERROR_TARGET, color="0.5", linewidth=0.8, linestyle=":")
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "integrators_pareto.png")
    return Figure(
        "integrators_pareto.png",
        f"Error against cost: each point one step rate ({rates[0]} to {rates[-1]} Hz); lower "
        "left is better; dotted line: the error target.",
    )


def _convergence_figure(methods, seconds, figures_dir):
    fig, ax = new_axes(
        f"Convergence, torque-free box, {format_number(seconds)} s",
        "time step dt (s)",
        "max orientation error (rad)",
    )
    for method, m in methods.items():
        points = m["points"]
        _plot_method(ax, method, [p["dt"] for p in points], [p["max_angle_error"] for p in points])
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "integrators_convergence.png")
    return Figure(
        "integrators_convergence.png",
        "Error against the step: the slope is the order of the method.",
    )


def _energy_figure(accuracy, rate, figures_dir):
    fig, ax = new_axes(
        f"Kinetic energy drift at dt = 1/{rate} s", "time (s)", "|E(t)/E(0) - 1|", xlog=False
    )
    for method in METHODS:
        result = accuracy[(method, rate)]
        drift = np.maximum(result["curve_energy_drift"], 1e-17)  # exact zeros on a log axis
        style = dict(METHOD_STYLES[method], marker=None)
        ax.plot(result["curve_time"], drift, **style)
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "integrators_energy.png")
    return Figure(
        "integrators_energy.png",
        f"Relative kinetic energy error along the run at dt = 1/{rate} s (floored at 1e-17 "
        "for the log axis).",
    )
