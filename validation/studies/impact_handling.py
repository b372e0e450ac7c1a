"""Study: time of impact against the velocity bias alone (issue 7, item 4).

``World(penetration="toi")`` steps a body that flew into something back to its time of impact,
solves the collision there and lets it travel the rest of the step; ``"bias"`` leaves it where
the step ended, solves the collision at the start of the next step and pushes the bodies apart
through the contact velocities. Each scene is run with both at a sweep of steps:

* ``ball_e0.5``, ``ball_e1``: a ball (icosphere, r = 0.5 m, 1 kg) dropped from 1 m onto a
  static floor, restitution 0.5 and 1;
* ``box``: a unit cube (1 kg, restitution 0.5) dropped flat from 1 m;
* ``fast_sphere``: a small sphere (r = 0.05 m, 0.1 kg, restitution 0.5) shot down at 20 m/s
  onto a 2 cm plate from 1 m (0.33 m, three diameters, per step at 60 Hz).

Metrics: the penetration is the largest depth of the body's lowest vertex below the top of its
support over the run (resting penetration within the slop included); the energy error is the largest
``|E_k / E_0 - e^(2k)|`` over the first three bounces, with E the kinetic plus potential energy
above the resting height read at the k-th apex, so a bounce that keeps the contact's
restitution exactly scores 0. The cost is the wall-clock time per step over the whole run (the
least of repeated runs, after an untimed impact has loaded the kernels).
"""

from __future__ import annotations

import time
from functools import cache

import numpy as np
from matplotlib.ticker import NullFormatter

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table

NAME = "impact_handling"
TITLE = "Time of impact against the velocity bias: penetration and energy against cost"

G = 9.81
MODES = ("toi", "bias")
MODE_LABELS = {"toi": "time of impact", "bias": "velocity bias"}
MODE_MARKERS = {"toi": "o", "bias": "s"}
SCENES = {
    "ball_e0.5": {"label": "ball, e = 0.5", "color": "tab:blue"},
    "ball_e1": {"label": "ball, e = 1", "color": "tab:green"},
    "box": {"label": "box landing flat, e = 0.5", "color": "tab:orange"},
    "fast_sphere": {"label": "fast small sphere at a plate", "color": "tab:red"},
}
BOUNCES = 3  # apexes scored per run
APEX_CLEARANCE = 1e-3  # m above rest: lower local maxima are resting jitter, not bounces
TRACE_RATE = 60  # the step rate whose height traces are kept for the figure

RATES = {
    "full": (60, 120, 240, 480, 1000),
    "quick": (60, 240, 1000),
    "tiny": (60, 240),
}
SECONDS = {"full": 2.5, "quick": 2.5, "tiny": 1.5}  # the fast sphere's apex is at 1.1 s
REPEATS = {"full": 2, "quick": 2, "tiny": 1}


def cases(scale: str) -> list[Case]:
    """One timed case per scene, penetration handling and step rate."""
    return [
        Case(
            NAME,
            {
                "scene": scene,
                "mode": mode,
                "rate": rate,
                "seconds": SECONDS[scale],
                "repeats": REPEATS[scale],
            },
            timed=True,
        )
        for scene in SCENES
        for mode in MODES
        for rate in RATES[scale]
    ]


def build_scene(scene: str, rate: int, mode: str):
    """The world of ``scene``; returns (world, body, restitution, support top z, mesh)."""
    import thesis_rbd as rbd

    world = rbd.World(dt=1.0 / rate, gravity=(0.0, 0.0, -G), penetration=mode)
    if scene == "fast_sphere":
        world.add_body(
            rbd.shapes.box((1.0, 1.0, 0.02)), static=True, position=(0, 0, -0.01), restitution=1.0
        )
        mesh = rbd.shapes.icosphere(0.05, 2)
        body = world.add_body(
            mesh, mass=0.1, position=(0, 0, 1.0), linear_velocity=(0, 0, -20.0), restitution=0.5
        )
        return world, body, 0.5, 0.0, mesh
    world.add_body(
        rbd.shapes.box((4.0, 4.0, 1.0)), static=True, position=(0, 0, -0.5), restitution=1.0
    )
    restitution = 1.0 if scene == "ball_e1" else 0.5
    mesh = rbd.shapes.box((1.0, 1.0, 1.0)) if scene == "box" else rbd.shapes.icosphere(0.5, 3)
    body = world.add_body(mesh, mass=1.0, position=(0, 0, 1.5), restitution=restitution)
    return world, body, restitution, 0.0, mesh


def _simulate(scene: str, rate: int, mode: str, seconds: float):
    world, body, restitution, top, mesh = build_scene(scene, rate, mode)
    vertices = mesh.vertices
    mass = 1.0 / world.bodies.inverse_mass[body]
    rest = top - vertices[:, 2].min()  # centre height when resting on its lowest vertex

    def energy():
        return world.kinetic_energy() + mass * G * (world.position(body)[2] - rest)

    steps = round(seconds * rate)
    heights, energies, depths = np.empty(steps), np.empty(steps), np.empty(steps)
    energy0 = energy()
    elapsed = 0.0
    for k in range(steps):
        start = time.perf_counter()
        world.step()
        elapsed += time.perf_counter() - start
        T = world.transform(body)
        depths[k] = top - (vertices @ T[2, :3] + T[2, 3]).min()
        heights[k] = world.position(body)[2] - rest
        energies[k] = energy()
    return {
        "elapsed": elapsed,
        "steps": steps,
        "heights": heights,
        "energies": energies,
        "depths": depths,
        "energy0": energy0,
        "restitution": restitution,
    }


@cache
def _load_kernels() -> None:
    """Run an impact both ways once per process, so no timed run pays for loading kernels."""
    for mode in MODES:
        _simulate("ball_e0.5", TRACE_RATE, mode, 0.6)


def run(params: dict) -> dict:
    """Run the scene ``repeats`` times; the accuracy is the last run's, the cost the least."""
    scene, mode, rate = params["scene"], params["mode"], params["rate"]
    _load_kernels()
    runs = [_simulate(scene, rate, mode, params["seconds"]) for _ in range(params["repeats"])]
    result = runs[-1]
    h = result["heights"]
    apex = np.flatnonzero((h[1:-1] > h[:-2]) & (h[1:-1] >= h[2:]) & (h[1:-1] > APEX_CLEARANCE))
    apex = apex[:BOUNCES] + 1
    e2 = result["restitution"] ** 2
    energy_errors = [
        abs(float(result["energies"][a] / result["energy0"]) - e2 ** (k + 1))
        for k, a in enumerate(apex)
    ]
    record = {
        "steps": result["steps"],
        "ms_per_step": 1e3 * min(r["elapsed"] for r in runs) / result["steps"],
        "samples_ms_per_step": [1e3 * r["elapsed"] / result["steps"] for r in runs],
        "max_penetration": float(max(result["depths"].max(), 0.0)),
        "bounces": len(apex),
        "energy_errors": energy_errors,
        "max_energy_error": max(energy_errors, default=None),
    }
    if rate == TRACE_RATE:
        record["trace_height"] = [float(x) for x in h]
    return record


def summarise(records: list[dict], figures_dir) -> Section:
    """Pareto figures (penetration, energy error against ms per step), height traces, table."""
    rows = []
    for record in records:
        p, r = record["params"], record["result"]
        rows.append(
            {
                "scene": p["scene"],
                "mode": p["mode"],
                "rate": p["rate"],
                "ms_per_step": r["ms_per_step"],
                "max_penetration": r["max_penetration"],
                "max_energy_error": r["max_energy_error"],
                "bounces": r["bounces"],
            }
        )
    rates = sorted({row["rate"] for row in rows})
    coarse = rates[0]

    def at(scene, mode, rate):
        return next(
            row for row in rows if (row["scene"], row["mode"], row["rate"]) == (scene, mode, rate)
        )

    per_scene = {}
    for scene in SCENES:
        toi, bias = at(scene, "toi", coarse), at(scene, "bias", coarse)
        per_scene[scene] = {
            "label": SCENES[scene]["label"],
            "toi": toi,
            "bias": bias,
            "cost_ratio": toi["ms_per_step"] / bias["ms_per_step"],
        }
    mean_cost = {
        mode: float(np.mean([row["ms_per_step"] for row in rows if row["mode"] == mode]))
        for mode in MODES
    }
    summary = {
        "rates": rates,
        "coarse_rate": coarse,
        "seconds": records[0]["params"]["seconds"],
        "bounces": BOUNCES,
        "rows": rows,
        "scenes": per_scene,
        "mean_ms_per_step": mean_cost,
        "mean_cost_ratio": mean_cost["toi"] / mean_cost["bias"],
        "toi_max_penetration": max(r["max_penetration"] for r in rows if r["mode"] == "toi"),
        "bias_max_penetration": max(r["max_penetration"] for r in rows if r["mode"] == "bias"),
    }
    figures = [
        _pareto(
            rows, "max_penetration", "largest penetration (m)", "penetration", 1e-7, figures_dir
        ),
        _pareto(
            rows,
            "max_energy_error",
            f"largest |E_k/E_0 - e^(2k)|, first {BOUNCES} bounces",
            "energy",
            1e-16,
            figures_dir,
        ),
        _trace_figure(records, figures_dir),
    ]
    table = Table(
        caption="Penetration, energy error and cost per scene, handling and step",
        columns=[
            "scene",
            "handling",
            "dt (s)",
            "max penetration (m)",
            "energy error",
            "bounces scored",
            "ms per step",
        ],
        rows=[
            [
                SCENES[row["scene"]]["label"],
                MODE_LABELS[row["mode"]],
                f"1/{row['rate']}",
                format_number(row["max_penetration"]),
                format_number(row["max_energy_error"]),
                str(row["bounces"]),
                format_number(row["ms_per_step"]),
            ]
            for row in rows
        ],
    )
    return Section(NAME, TITLE, summary, tables=[table], figures=figures)


def _pareto(rows, key, ylabel, tag, floor, figures_dir):
    fig, ax = new_axes(
        f"Impact handling: {tag} against cost", "wall-clock ms per step", ylabel, xlog=True
    )
    for scene, style in SCENES.items():
        for mode in MODES:
            points = sorted(
                (row["rate"], row["ms_per_step"], row[key])
                for row in rows
                if row["scene"] == scene and row["mode"] == mode and row[key] is not None
            )
            if not points:
                continue
            # exact zeros (no penetration at all) sit on a floor of the log axis
            y = [max(p[2], floor) for p in points]
            ax.plot(
                [p[1] for p in points],
                y,
                color=style["color"],
                marker=MODE_MARKERS[mode],
                linestyle="-" if mode == "toi" else "--",
                label=f"{style['label']}, {MODE_LABELS[mode]}",
            )
    ax.xaxis.set_minor_formatter(NullFormatter())  # a decade or less: minor labels collide
    ax.legend(fontsize=7)
    file = f"{NAME}_{tag}.png"
    save_figure(fig, figures_dir / file)
    return Figure(
        file,
        f"{ylabel[0].upper() + ylabel[1:]} against the cost of a step; each point one step "
        "rate, solid lines time of impact, dashed velocity bias (zeros drawn at "
        f"{format_number(floor)}).",
    )


def _trace_figure(records, figures_dir):
    fig, ax = new_axes(
        f"Height above rest at dt = 1/{TRACE_RATE} s", "time (s)", "height (m)", False, False
    )
    for record in records:
        p, r = record["params"], record["result"]
        if "trace_height" not in r or p["scene"] != "ball_e0.5":
            continue
        h = np.asarray(r["trace_height"])
        ax.plot(
            np.arange(1, len(h) + 1) / p["rate"],
            h,
            marker=MODE_MARKERS[p["mode"]],
            markersize=3,
            linestyle="-" if p["mode"] == "toi" else "--",
            label=f"ball, e = 0.5, {MODE_LABELS[p['mode']]}",
        )
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.legend(fontsize=8)
    file = f"{NAME}_trace.png"
    save_figure(fig, figures_dir / file)
    return Figure(
        file,
        f"The ball of e = 0.5 at dt = 1/{TRACE_RATE} s: centre height above its resting height "
        "after each step; below zero is penetration.",
    )
