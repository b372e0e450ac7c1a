"""Study: what deciding touching and flush faces exactly costs (issue 16's bound: at most 10 %).

The triangle-triangle and triangle-box tests branch on exact signs since issue 16 (filtered
orientation predicates with an exact fallback), and contacts of touching triangles are built
from those signs. The earlier float tests no longer exist in the package, so the comparison
is recorded by ``python -m validation.checkout_comparison`` from a checkout of the last commit
before them, which times both packages in one process, each query answered by one and then
the other (``validation/data/predicate_cost.json``: the commits, date and machine are in the
file and in the report). Timings of two separate runs on a shared machine differ by more
than the bound, which is why the comparison is interleaved and not re-measured per campaign.
"""

from __future__ import annotations

import json
from pathlib import Path

from validation.cases import Case
from validation.formatting import format_number
from validation.section import Section, Table

NAME = "predicate_cost"
TITLE = "Exact predicates: the cost of deciding touching faces exactly"

RECORDED = Path(__file__).resolve().parents[1] / "data" / "predicate_cost.json"
BOUND = 1.10  # the issue's: the tori benchmark and real-mesh timings slow by at most 10 %
# The workloads the bound judges: the common case (the real-mesh timings were random
# poses). Flush placements are where the exact fallback runs; their cost is shown, not judged.
JUDGED = ("tori path", "CAD-like parts, random poses")


def cases(scale: str) -> list[Case]:
    return [Case(NAME, {"recorded": RECORDED.name})]


def run(params: dict) -> dict:
    """The recorded comparison (empty when it has not been recorded)."""
    path = RECORDED.with_name(params["recorded"])
    return json.loads(path.read_text()) if path.exists() else {}


def summarise(records: list[dict], figures_dir) -> Section:
    recorded = records[0]["result"]
    rows, table = [], []
    for load, modes in recorded.get("workloads", {}).items():
        for mode in ("first", "all", "contacts"):
            timing = modes[mode]
            row = {
                "workload": load,
                "mode": mode,
                "queries": modes["queries"],
                "repeats": timing["repeats"],
                "judged": load in JUDGED,
                "ratio_min": timing["after"]["min_ms"] / timing["before"]["min_ms"],
                "ratio_median": timing["after"]["median_ms"] / timing["before"]["median_ms"],
                **{
                    f"{who}_{stat}": timing[who][f"{stat}_ms"]
                    for who in ("before", "after")
                    for stat in ("min", "median")
                },
            }
            rows.append(row)
            table.append(
                [load, mode, str(row["queries"]), str(row["repeats"])]
                + [
                    format_number(row[key])
                    for key in (
                        "before_min",
                        "after_min",
                        "ratio_min",
                        "before_median",
                        "after_median",
                        "ratio_median",
                    )
                ]
            )
    worst = max((max(r["ratio_min"], r["ratio_median"]) for r in rows if r["judged"]), default=None)
    exact = [max(r["ratio_min"], r["ratio_median"]) for r in rows if not r["judged"]]
    summary = {
        "recorded": bool(rows),
        "before_commit": recorded.get("before_commit", "not recorded"),
        "after_commit": recorded.get("after_commit", "not recorded"),
        "date": recorded.get("date", "n/a"),
        "machine": recorded.get("machine", "n/a"),
        "bound": BOUND,
        "rows": rows,
        "judged": list(JUDGED),
        "worst_ratio": worst,
        "worst_unjudged_ratio": max(exact, default=None),
        "within_bound": None if worst is None else bool(worst <= BOUND),
    }
    return Section(
        study=NAME,
        title=TITLE,
        summary=summary,
        tables=[
            Table(
                caption="Time of collide over each workload, before (float tests) and after "
                "(exact predicates), in ms: per query the minimum and the median of the "
                "interleaved repeats, summed over the queries",
                columns=[
                    "workload",
                    "mode",
                    "queries",
                    "repeats",
                    "before, min",
                    "after, min",
                    "after / before",
                    "before, median",
                    "after, median",
                    "after / before",
                ],
                rows=table,
            )
        ],
    )
