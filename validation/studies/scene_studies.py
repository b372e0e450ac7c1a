"""Study: ``rbd.study`` on the pyramid and on a tumbling pile, and how it scales (issue 36).

The user's tool, run as a user runs it: ``rbd.study`` varies dt x contact solver x narrow
phase on the built-in ``pyramid`` (ten cubes settling into a standing pyramid) and ``rain``
(twelve mixed bodies tumbling into a pile), with seeds, against its default reference (a
quarter of the finest step, contacts solved 100 times tighter). Each scene's study runs three
times, alone on the machine: in one worker process, in two local worker processes, and on a
Dask ``LocalCluster`` of two single-threaded worker processes (started before the clock, as a
cluster is there before a study is sent to it). The tables must agree apart from their timing
columns; the wall time of each whole study gives the scaling efficiency from one worker to
two: T1 / (2 T2).

The recommendation's thresholds are set here, before the runs, from the bodies' sizes: the
pyramid's cubes are 1 m, and a settled pyramid should stand where its reference stands to a
millimetre; the pile's bodies are 0.5 to 0.8 m, and a pile, chaotic, can only be asked to
land its bodies within a tenth of a metre (or within the seed floor, the reference's own
spread).
"""

from __future__ import annotations

import json
import time

import thesis_rbd as rbd
from thesis_rbd.studies import TIMING_COLUMNS
from thesis_rbd.studies.page import accuracy_figure
from thesis_rbd.studies.table import StudyTable
from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import save_figure
from validation.section import Figure, Section, Table

NAME = "scene_studies"
TITLE = "Studies of your own scene: the pyramid and a tumbling pile, on one to two workers"

SCENES = ("pyramid", "rain")
WITHIN = {"pyramid": {"position": 1e-3}, "rain": {"position": 0.1}}
RUNNERS = ("one worker", "two workers", "Dask LocalCluster of two")
VARY = {
    "full": {
        "dt": [1 / 60, 1 / 120, 1 / 240],
        "contact_solver": ["pgs", "auto"],
        "narrow_phase": ["auto", "mesh"],
    },
    "quick": {"dt": [1 / 60, 1 / 240], "contact_solver": ["pgs", "auto"], "narrow_phase": ["auto"]},
    "tiny": {"dt": [1 / 60, 1 / 120]},
}
SEEDS = {"full": 5, "quick": 2, "tiny": 1}
WARM_UP_SECONDS = 0.05
SECONDS = {"full": None, "quick": 1.0, "tiny": 0.25}  # None: the scene's own (3 s, 4 s)


def cases(scale: str) -> list[Case]:
    """One timed case per scene and runner."""
    return [
        Case(
            NAME,
            {
                "scene": scene,
                "runner": runner,
                "vary": VARY[scale],
                "seeds": SEEDS[scale],
                "seconds": SECONDS[scale],
            },
            timed=True,
        )
        for scene in SCENES
        for runner in RUNNERS
    ]


def run(params: dict) -> dict:
    """The study of one scene by one runner: its rows, floors and wall time."""
    arguments = {
        "vary": params["vary"], "seeds": params["seeds"], "seconds": params["seconds"],
    }  # fmt: skip
    # numba's kernels for every variant compiled (or loaded into the disk cache) before the
    # clock: the timed studies' workers load them, as a user's second study would
    rbd.study(params["scene"], vary=params["vary"], seconds=WARM_UP_SECONDS, workers=1)
    if params["runner"].startswith("Dask"):
        from dask.distributed import LocalCluster

        with LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster:
            start = time.perf_counter()
            table = rbd.study(params["scene"], scheduler=cluster.scheduler_address, **arguments)
            wall = time.perf_counter() - start
    else:
        workers = 1 if params["runner"] == "one worker" else 2
        start = time.perf_counter()
        table = rbd.study(params["scene"], workers=workers, **arguments)
        wall = time.perf_counter() - start
    recommendation = table.recommend(WITHIN[params["scene"]])
    return {
        "wall_seconds": wall,
        "rows": json.loads(json.dumps(table.rows)),
        "varied": table.varied,
        "floors": table.floors,
        "recommendation": recommendation.sentence,
        "recommended": recommendation.settings,
    }


def _value(value) -> str:
    """A grid value as the report writes it: steps as 1/N s."""
    if isinstance(value, float) and value < 1:
        return f"1/{round(1 / value)}"
    return str(value)


def _without_timing(rows: list[dict]) -> str:
    return json.dumps([{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows])


def summarise(records: list[dict], figures_dir) -> Section:
    """Per scene: the variants' table and plot (two workers), the recommendation, whether
    the three runners' tables agree, and the scaling efficiency."""
    by_case = {(r["params"]["scene"], r["params"]["runner"]): r["result"] for r in records}
    summary, tables, figures = {}, [], []
    for scene in SCENES:
        results = [by_case[scene, runner] for runner in RUNNERS]
        one, two, dask = (r["wall_seconds"] for r in results)
        main = results[1]
        table = StudyTable(main["rows"], main["varied"], main["floors"])
        identical = len({_without_timing(r["rows"]) for r in results}) == 1
        summary[scene] = {
            "grid": " x ".join(
                f"{name} ({', '.join(_value(v) for v in values)})"
                for name, values in records[0]["params"]["vary"].items()
            ),
            "runs": len(main["rows"]),
            "variants": len(table.variants()),
            "seeds": records[0]["params"]["seeds"],
            "wall_one": one,
            "wall_two": two,
            "wall_dask": dask,
            "efficiency_two": one / (2 * two),
            "efficiency_dask": one / (2 * dask),
            "tables_identical": identical,
            "recommendation": main["recommendation"],
            "floors": {k: v for k, v in main["floors"].items() if v == v},
            "failed": sum(row["status"] != "ok" for row in main["rows"]),
        }
        figure = accuracy_figure(table)
        save_figure(figure, figures_dir / f"scene_study_{scene}.png")
        figures.append(
            Figure(
                f"scene_study_{scene}.png",
                f"{scene}: each variant's largest errors over the run (over its seeds) against "
                "its wall time per simulated second (two workers), with the Pareto front and "
                "the seed floor",
            )
        )
        rows = []
        front = {tuple(v["settings"].items()) for v in table.pareto_front("position_error")}
        for v in sorted(table.variants(), key=lambda v: v["wall_per_second"]):
            rows.append(
                [
                    ", ".join(
                        f"{k}={format_number(x) if isinstance(x, float) else x}"
                        for k, x in v["settings"].items()
                    ),
                    format_number(v["wall_per_second"]),
                    format_number(v["position_error"]),
                    format_number(v["orientation_error"]),
                    format_number(v["energy_error"]),
                    format_number(v["penetration"]),
                    "yes" if tuple(v["settings"].items()) in front else "",
                ]
            )
        tables.append(
            Table(
                caption=f"{scene}: variants, cheapest first (wall time per simulated second "
                "in two workers; errors the largest over the run and the seeds)",
                columns=[
                    "variant",
                    "wall s / s",
                    "position (m)",
                    "orientation (rad)",
                    "energy (J)",
                    "penetration (m)",
                    "Pareto",
                ],
                rows=rows,
            )
        )
    tables.append(
        Table(
            caption="Wall time of each whole study (s) and the scaling efficiency from one "
            "worker to two, T1 / (2 T2)",
            columns=[
                "scene",
                "one worker",
                "two workers",
                "LocalCluster of two",
                "efficiency (two)",
                "efficiency (LocalCluster)",
                "tables agree",
            ],
            rows=[
                [
                    scene,
                    format_number(s["wall_one"]),
                    format_number(s["wall_two"]),
                    format_number(s["wall_dask"]),
                    format_number(s["efficiency_two"]),
                    format_number(s["efficiency_dask"]),
                    "yes" if s["tables_identical"] else "NO",
                ]
                for scene, s in ((scene, summary[scene]) for scene in SCENES)
            ],
        )
    )
    return Section(NAME, TITLE, summary, tables=tables, figures=figures)
