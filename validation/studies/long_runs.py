"""Study: stability over long runs and far from the origin (issue 7, stability suite starter).

High spin: the 1 x 2 x 3 box of mass 1 spins at w0 = (30, 0, 40) rad/s (50 rad/s, 0.21 rad per
step at dt = 1/240) for 10^6 steps (quick: 10^5) with each integrator; the quaternion norm,
the kinetic energy and the world angular momentum are sampled 100 times along the run. A
torque-free body keeps its energy and angular momentum exactly, so any change of energy is
the integrator's drift, judged against a bound (physics: conserved; 0.1 % allowed). The
quaternion norm and L are shown but not judged: every integrator renormalises q after each
step and carries L as state, so both hold by construction.

Far from the origin: the same tumbling motion as the integrators study, with a constant
linear velocity, starts at (d, d, d) for growing d; the position error against the exact
x0 + v t and the orientation error against the reference measure what float64 coordinates
cost far away. The bound is one rounding of the position per step: steps * ulp(|x|).
"""

from __future__ import annotations

import math

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.oracles import rotation_angle_between, torque_free_reference
from validation.plotting import METHOD_STYLES, new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "long_runs"
TITLE = "Stability: long runs at high spin, bodies far from the origin"

EXTENTS = (1.0, 2.0, 3.0)
MASS = 1.0
RATE = 240
SPIN = (30.0, 0.0, 40.0)
TUMBLE = (0.4, 2.0, -1.1)
LINEAR_VELOCITY = (1.0, -2.0, 0.5)
CHECKPOINTS = 100
INTEGRATORS = ("euler", "symplectic_euler", "midpoint", "rk4", "verlet")
FAR_METHODS = ("rk4", "pybullet_multibody")

# Pass/fail bound of the high-spin run: torque-free motion conserves kinetic energy (physics);
# the relative drift at the end may be at most this, for every integrator.
ENERGY_BOUND = 1e-3

STEPS = {"full": 1_000_000, "quick": 100_000, "tiny": 10_000}
OFFSETS = {
    "full": (0.0, 1e3, 1e6, 1e9),
    "quick": (0.0, 1e3, 1e6),
    "tiny": (0.0, 1e6),
}
FAR_SECONDS = {"full": 10.0, "quick": 10.0, "tiny": 2.0}


def cases(scale: str) -> list[Case]:
    """High-spin cases per integrator and far-from-origin cases per method and offset."""
    out = [
        Case(NAME, {"kind": "high_spin", "method": m, "steps": STEPS[scale], "rate": RATE})
        for m in INTEGRATORS
    ]
    out += [
        Case(
            NAME,
            {
                "kind": "far",
                "method": m,
                "offset": d,
                "seconds": FAR_SECONDS[scale],
                "rate": RATE,
            },
        )
        for m in FAR_METHODS
        for d in OFFSETS[scale]
    ]
    return out


def _box():
    import thesis_rbd as rbd

    mesh = rbd.shapes.box(EXTENTS)
    return mesh, rbd.mass_properties(mesh, mass=MASS).inertia


def _run_high_spin(method: str, steps: int, rate: int) -> dict:
    import thesis_rbd as rbd

    mesh, _ = _box()
    world = rbd.World(dt=1.0 / rate, integrator=method)
    body = world.add_body(mesh, mass=MASS, angular_velocity=SPIN)
    E0 = world.kinetic_energy()
    L0 = world.angular_momentum(body)
    chunk = steps // CHECKPOINTS
    done, step_at, norm_error, energy_drift, momentum_drift = 0, [], [], [], []
    while done < steps:
        n = min(chunk, steps - done)
        world.step(n)
        done += n
        step_at.append(done)
        norm_error.append(abs(float(np.linalg.norm(world.orientation(body))) - 1.0))
        energy_drift.append(abs(world.kinetic_energy() / E0 - 1.0))
        momentum_drift.append(float(np.linalg.norm(world.angular_momentum(body) - L0)))
    return {
        "steps": steps,
        "step": step_at,
        "norm_error": norm_error,
        "energy_drift": energy_drift,
        "momentum_change": momentum_drift,
        "max_norm_error": max(norm_error),
        "final_energy_drift": energy_drift[-1],
        "max_momentum_change": max(momentum_drift),
    }


def _trajectory_far(method: str, offset: float, steps: int, rate: int):
    """Positions (steps+1, 3) and orientations (steps+1, 4) along the run."""
    mesh, inertia = _box()
    x0 = (offset, offset, offset)
    if method == "pybullet_multibody":
        from validation.pybullet_free_body import PybulletBox

        with PybulletBox(
            EXTENTS,
            MASS,
            np.diag(inertia),
            1.0 / rate,
            "multibody",
            position=x0,
            linear_velocity=LINEAR_VELOCITY,
            angular_velocity=TUMBLE,
        ) as box:
            x, q, _ = box.record(steps)
        return x, q
    import thesis_rbd as rbd

    world = rbd.World(dt=1.0 / rate, integrator=method)
    world.add_body(
        mesh, mass=MASS, position=x0, linear_velocity=LINEAR_VELOCITY, angular_velocity=TUMBLE
    )
    bodies = world.bodies
    x, q = np.empty((steps + 1, 3)), np.empty((steps + 1, 4))
    x[0], q[0] = bodies.position[0], bodies.orientation[0]
    for k in range(1, steps + 1):
        world.step()
        x[k], q[k] = bodies.position[0], bodies.orientation[0]
    return x, q


def _run_far(method: str, offset: float, seconds: float, rate: int) -> dict:
    _, inertia = _box()
    steps = round(seconds * rate)
    times = np.arange(steps + 1) / rate
    x, q = _trajectory_far(method, offset, steps, rate)
    displacement = x - np.array([offset] * 3)  # exact: x and x0 are within a factor of 2
    position_error = np.abs(displacement - times[:, None] * np.array(LINEAR_VELOCITY)).max()
    _, q_ref = torque_free_reference(inertia, TUMBLE, (0.0, 0.0, 0.0, 1.0), times)
    largest = float(np.abs(x).max())
    return {
        "steps": steps,
        "max_position_error": float(position_error),
        "max_angle_error": float(rotation_angle_between(q, q_ref).max()),
        "position_bound": steps * math.ulp(largest) if largest > 0 else 0.0,
    }


def run(params: dict) -> dict:
    """One high-spin or far-from-origin case (see the module docstring)."""
    if params["kind"] == "high_spin":
        return _run_high_spin(params["method"], params["steps"], params["rate"])
    return _run_far(params["method"], params["offset"], params["seconds"], params["rate"])


def summarise(records: list[dict], figures_dir) -> Section:
    """Pass/fail tables and drift figures."""
    spin = {
        r["params"]["method"]: r["result"] for r in records if r["params"]["kind"] == "high_spin"
    }
    far = [r for r in records if r["params"]["kind"] == "far"]
    steps = next(iter(spin.values()))["steps"]
    high_spin = {}
    for method, result in spin.items():
        high_spin[method] = {
            "label": METHOD_STYLES[method]["label"],
            "max_norm_error": result["max_norm_error"],
            "final_energy_drift": result["final_energy_drift"],
            "energy_bound": ENERGY_BOUND,
            "energy_pass": result["final_energy_drift"] <= ENERGY_BOUND,
            "max_momentum_change": result["max_momentum_change"],
        }
    far_rows = []
    for r in far:
        res = r["result"]
        far_rows.append(
            {
                "method": r["params"]["method"],
                "label": METHOD_STYLES[r["params"]["method"]]["label"],
                "offset": r["params"]["offset"],
                "max_position_error": res["max_position_error"],
                "position_bound": res["position_bound"],
                "position_pass": res["max_position_error"] <= max(res["position_bound"], 1e-12),
                "max_angle_error": res["max_angle_error"],
            }
        )
    at_origin = {row["method"]: row["max_angle_error"] for row in far_rows if row["offset"] == 0}
    for row in far_rows:
        row["angle_error_change_from_origin"] = row["max_angle_error"] - at_origin.get(
            row["method"], math.nan
        )
    summary = {
        "spin": list(SPIN),
        "spin_rate": float(np.linalg.norm(SPIN)),
        "rate": RATE,
        "steps": steps,
        "simulated_seconds": steps / RATE,
        "energy_bound": ENERGY_BOUND,
        "high_spin": high_spin,
        "far_seconds": far[0]["params"]["seconds"] if far else None,
        "far": far_rows,
        "library_far_all_pass": all(r["position_pass"] for r in far_rows if r["method"] == "rk4"),
    }
    tables = [
        Table(
            caption=f"High spin ({format_number(summary['spin_rate'])} rad/s), {steps} steps "
            f"at dt = 1/{RATE} s",
            columns=[
                "integrator",
                "max | |q| - 1 | (by construction)",
                "final energy drift",
                "energy bound",
                "pass",
                "max |L - L0| (by construction)",
            ],
            rows=[
                [
                    v["label"],
                    format_number(v["max_norm_error"]),
                    format_number(v["final_energy_drift"]),
                    format_number(v["energy_bound"]),
                    format_number(v["energy_pass"]),
                    format_number(v["max_momentum_change"]),
                ]
                for v in high_spin.values()
            ],
        ),
        Table(
            caption="Far from the origin: the tumbling box starting at (d, d, d)",
            columns=[
                "method",
                "d (m)",
                "max position error (m)",
                "bound steps*ulp(|x|) (m)",
                "pass",
                "max angle error (rad)",
                "change from d = 0 (rad)",
            ],
            rows=[
                [
                    row["label"],
                    format_number(row["offset"]),
                    format_number(row["max_position_error"]),
                    format_number(row["position_bound"]),
                    format_number(row["position_pass"]),
                    format_number(row["max_angle_error"]),
                    format_number(row["angle_error_change_from_origin"]),
                ]
                for row in far_rows
            ],
        ),
    ]
    figures = [_spin_figure(spin, figures_dir), _far_figure(far_rows, figures_dir)]
    return Section(NAME, TITLE, summary, tables=tables, figures=figures)


def _spin_figure(spin, figures_dir):
    fig, ax = new_axes(
        f"High spin: drift over {next(iter(spin.values()))['steps']} steps",
        "steps",
        "relative energy drift (solid), | |q| - 1 | (dotted)",
    )
    for method, result in spin.items():
        style = dict(METHOD_STYLES[method], marker=None)
        ax.plot(result["step"], np.maximum(result["energy_drift"], 1e-17), **style)
        style.pop("label")
        style["linestyle"] = ":"
        ax.plot(result["step"], np.maximum(result["norm_error"], 1e-17), **style)
    ax.axhline(ENERGY_BOUND, color="0.5", linewidth=0.8, linestyle="-.")
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "long_runs_high_spin.png")
    return Figure(
        "long_runs_high_spin.png",
        "Kinetic-energy drift and quaternion-norm error along the run (floored at 1e-17 for "
        "the log axis); dash-dotted line: the energy bound.",
    )


def _far_figure(rows, figures_dir):
    fig, ax = new_axes(
        "Far from the origin: position error", "distance from the origin d (m)", "error (m)"
    )
    for method in FAR_METHODS:
        mine = [r for r in rows if r["method"] == method and r["offset"] > 0]
        if not mine:
            continue
        ax.plot(
            [r["offset"] for r in mine],
            [max(r["max_position_error"], 1e-17) for r in mine],
            **METHOD_STYLES[method],
        )
    bounds = sorted((r["offset"], r["position_bound"]) for r in rows if r["offset"] > 0)
    if bounds:
        ax.plot(*zip(*bounds, strict=True), color="0.5", linestyle=":", label="steps * ulp(|x|)")
    ax.legend(fontsize=8)
    save_figure(fig, figures_dir / "long_runs_far.png")
    return Figure(
        "long_runs_far.png",
        "Largest position error against the exact x0 + v t, against the distance from the "
        "origin; dotted: one rounding per step.",
    )
