"""Study: exact LCP (Lemke) against projected Gauss-Seidel iterations (issue 7, item 5).

Resting-contact scenes from :mod:`validation.studies.contact_scenes` (a ten-cube stack, a
three-row pyramid, the ten-cube mass-ratio stack from 1 to 100 kg) settle for ``SETTLE_STEPS``
steps with the exact solver and no sleeping. From that one state (a deep copy of the world per
solve) one more step is taken with ``contact_solver="exact"``, the reference, and with
``contact_solver="pgs"`` at each iteration count, both cold (no impulses carried over) and warm
(the impulses of the previous, exact, step). Per-contact impulses are not unique when a face
rests on a face (four corners carry any statically admissible split), but the velocities
after the solve are, so the error is read from them: the largest velocity change at a body's
bounding radius, ``|dv| + r |dw|``, against the reference, in units of g dt (the velocity
gravity adds in a step, which the contacts must take away). The cost is the contact stage's
time (``World.profile["contacts"]``) in that step, the least of ``repeats`` copies.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import new_axes, save_figure
from validation.section import Figure, Section, Table
from validation.studies import contact_scenes as scenes

NAME = "lcp_vs_pgs"
TITLE = "Exact LCP against projected Gauss-Seidel: contact error against time per solve"

RATE = 240
SETTLE_STEPS = 24
SCENES = {
    "stack": {"label": "10-cube stack", "color": "tab:blue"},
    "pyramid": {"label": "3-row pyramid", "color": "tab:green"},
    "mass_ratio": {"label": "mass-ratio stack, 1 to 100 kg", "color": "tab:red"},
}
WARM = (False, True)
ITERATIONS = {
    "full": (1, 2, 5, 10, 20, 50, 100, 200),
    "quick": (1, 5, 20, 100),
    "tiny": (1, 10),
}
REPEATS = {"full": 5, "quick": 3, "tiny": 1}
TARGET = 1e-2  # in g dt: the error a solve should stay within


def scene_spec(scene: str):
    """The scene description of ``scene``."""
    if scene == "stack":
        return scenes.cube_stack(10)
    if scene == "pyramid":
        return scenes.pyramid(3)
    return scenes.cube_stack(10, mass_ratio=100.0, offset=0.005)


def cases(scale: str) -> list[Case]:
    """One timed case per scene: the reference and every PGS setting from one settled state."""
    return [
        Case(
            NAME,
            {
                "scene": scene,
                "iterations": list(ITERATIONS[scale]),
                "repeats": REPEATS[scale],
                "settle_steps": SETTLE_STEPS,
                "rate": RATE,
            },
            timed=True,
        )
        for scene in SCENES
    ]


def _without_warm_start(state):
    """The world's step state (``world/step_state.py``) with no remembered impulses."""
    if not hasattr(state, "warm_keys"):
        raise RuntimeError("the world's step state no longer holds its warm start")
    return dataclasses.replace(
        state, warm_keys=np.zeros((0, 2), np.int64), warm_values=np.zeros((0, 6))
    )


def _solve(world, solver: str, iterations: int, warm: bool, repeats: int):
    """One step from a copy of ``world``: (linear velocities, angular velocities, contact
    stage seconds (least of ``repeats``), contact info)."""
    best = np.inf
    for _ in range(repeats):
        trial = copy.deepcopy(world)
        trial.contact_settings = dataclasses.replace(
            trial.contact_settings, solver=solver, iterations=iterations
        )
        if not warm:
            trial._state = _without_warm_start(trial._state)
        before = trial.profile["contacts"]["seconds"]
        trial.step()
        best = min(best, trial.profile["contacts"]["seconds"] - before)
    bodies = range(len(trial))
    v = np.array([trial.linear_velocity(i) for i in bodies])
    w = np.array([trial.angular_velocity(i) for i in bodies])
    return v, w, best, dict(trial.contact_info)


def run(params: dict) -> dict:
    """Settle the scene, then the reference step and every PGS step from the same state."""
    spec = scene_spec(params["scene"])
    dt = 1.0 / params["rate"]
    world = scenes.build_world(spec, dt, contact_solver="exact", sleeping=False)
    world.step(params["settle_steps"])
    dynamic = spec.dynamic()
    radius = np.array([0.5 * np.linalg.norm(spec.bodies[i].size) for i in dynamic])
    scale = spec.gravity * dt
    repeats = params["repeats"]
    _solve(world, "exact", 1, True, 1)  # load the kernels outside the timings
    v_ref, w_ref, exact_seconds, info = _solve(world, "exact", 1, True, repeats)
    contacts = len(world.contacts["depths"])

    def error(v, w):
        dv = np.linalg.norm(v[dynamic] - v_ref[dynamic], axis=1)
        dw = np.linalg.norm(w[dynamic] - w_ref[dynamic], axis=1)
        return float((dv + radius * dw).max() / scale)

    pgs = []
    for warm in WARM:
        for iterations in params["iterations"]:
            v, w, seconds, _ = _solve(world, "pgs", iterations, warm, repeats)
            pgs.append(
                {"warm": warm, "iterations": iterations, "seconds": seconds, "error": error(v, w)}
            )
    return {
        "contacts": contacts,
        "bodies": len(dynamic),
        "exact_seconds": exact_seconds,
        "exact_fallbacks": info.get("unconverged"),
        "pgs": pgs,
    }


def summarise(records: list[dict], figures_dir) -> Section:
    """Error against time per solve, one curve per scene and warm start; the table."""
    per_scene = {}
    for record in records:
        scene, r = record["params"]["scene"], record["result"]
        cold = [p for p in r["pgs"] if not p["warm"]]
        within = [p for p in cold if p["error"] <= TARGET]
        first = min(within, key=lambda p: p["iterations"], default=None)
        per_scene[scene] = {
            "label": SCENES[scene]["label"],
            "contacts": r["contacts"],
            "bodies": r["bodies"],
            "exact_ms": 1e3 * r["exact_seconds"],
            "exact_fallbacks": r["exact_fallbacks"],
            "pgs": r["pgs"],
            "cold_max_iterations": cold[-1],
            "cold_within_target": first,
            "time_ratio_at_target": None
            if first is None
            else r["exact_seconds"] / first["seconds"],
        }
    iterations = records[0]["params"]["iterations"]
    summary = {
        "rate": records[0]["params"]["rate"],
        "settle_steps": records[0]["params"]["settle_steps"],
        "iterations": iterations,
        "target": TARGET,
        "scenes": per_scene,
    }
    rows = []
    for s in per_scene.values():
        rows.append(
            [
                s["label"],
                str(s["contacts"]),
                "exact (Lemke)",
                "-",
                "0",
                format_number(s["exact_ms"]),
            ]
        )
        for p in s["pgs"]:
            rows.append(
                [
                    s["label"],
                    str(s["contacts"]),
                    "PGS, warm" if p["warm"] else "PGS, cold",
                    str(p["iterations"]),
                    format_number(p["error"]),
                    format_number(1e3 * p["seconds"]),
                ]
            )
    table = Table(
        caption="Velocity error after one solve (units of g dt) and contact-stage time",
        columns=["scene", "contacts", "solver", "iterations", "error (g dt)", "ms per solve"],
        rows=rows,
    )
    return Section(NAME, TITLE, summary, tables=[table], figures=[_figure(per_scene, figures_dir)])


def _figure(per_scene, figures_dir):
    fig, ax = new_axes(
        "Contact solve: error against time",
        "contact stage time per step (ms)",
        "velocity error after the solve (g dt)",
    )
    for scene, s in per_scene.items():
        color = SCENES[scene]["color"]
        for warm in WARM:
            points = [p for p in s["pgs"] if p["warm"] == warm]
            ax.plot(
                [1e3 * p["seconds"] for p in points],
                [max(p["error"], 1e-16) for p in points],
                color=color,
                marker="o" if not warm else "^",
                linestyle="-" if not warm else ":",
                label=f"{s['label']}, PGS {'warm' if warm else 'cold'}",
            )
        ax.axvline(s["exact_ms"], color=color, linewidth=1.0, linestyle="--")
    ax.axhline(TARGET, color="0.5", linewidth=0.8, linestyle=":")
    ax.legend(fontsize=7)
    file = f"{NAME}_pareto.png"
    save_figure(fig, figures_dir / file)
    return Figure(
        file,
        "PGS error against its time, one point per iteration count (cold: circles, warm: "
        "triangles); dashed verticals: the exact solver's time per scene (its error is 0 by "
        "definition); dotted: the target error; zeros drawn at 1e-16.",
    )
