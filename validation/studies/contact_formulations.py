"""Study: contact solved after the positions move (before issue 12) against before they move.

The same resting and stacking cases as the stability suite (density 2000, bodies exactly
touching, 240 Hz, 4 s), run by the library as it is and compared with the results the earlier
formulation gave, recorded from the last commit that had it by
``python -m validation.formulation_before`` (``validation/data/contact_formulation_before.json``;
the commit, date and machine are in the file and in the report). The earlier step integrated
every body first and repaired contacts afterwards, with absolute tolerances (0.1 mm slop,
0.1 m/s bounce threshold); the present one resolves contact before anything moves, with
tolerances relative to the bodies and the step.

Per case: the largest drift of a body and the deepest contact over the run, relative to the
body's size, against the stability suite's bound for the case; and the wall time per step
(the earlier figures were measured on the date recorded, the present ones in this run, so
compare them as orders of magnitude: what accuracy costs in time).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from validation.cases import Case
from validation.formatting import format_number
from validation.section import Section, Table
from validation.studies import stability_suite as suite

NAME = "contact_formulations"
TITLE = "Contact before the positions move against after: accuracy and time, per scene"

RATE = 240
SECONDS = {"full": 4.0, "quick": 2.0, "tiny": 0.1}
BEFORE = Path(__file__).resolve().parents[1] / "data" / "contact_formulation_before.json"
# the suite's cases that show the formulation: each scale, the stacks and the mass ratios
CASES = (
    "cube_10um",
    "cube_1mm",
    "cube_1m",
    "cube_100m",
    "ball_2mm",
    "stack_2mm",
    "plate_20um_flat",
    "plate_20um_tilted",
    "heavy_on_light",
    "tall_stack",
    "mass_ratio_stack",
    "pyramid_15",
)


def case_keys() -> list[tuple[str, str]]:
    """(case, engine) pairs: each case with the library's defaults, awake where the suite
    keeps it awake."""
    keys = []
    for name in CASES:
        engines = suite.CASES[name]["engines"]
        keys.append((name, "ours" if "ours" in engines else engines[0]))
    return keys


def cases(scale: str) -> list[Case]:
    return [
        Case(NAME, {"case": name, "engine": engine, "seconds": SECONDS[scale]}, timed=True)
        for name, engine in case_keys()
    ]


def run(params: dict) -> dict:
    """One case with the package as imported; wall time per step included."""
    seconds = params.get("seconds", SECONDS["full"])
    start = time.perf_counter()
    result = suite._run_contact(params["case"], params["engine"], seconds, RATE)
    result["seconds_per_step"] = (time.perf_counter() - start) / round(seconds * RATE)
    return result


def _relative(result: dict | None, key: str, length: float) -> float | None:
    return None if result is None or key not in result else result[key] / length


def summarise(records: list[dict], figures_dir) -> Section:
    before = json.loads(BEFORE.read_text()) if BEFORE.exists() else {"records": {}}
    rows, table = [], []
    for record in records:
        name, engine = record["params"]["case"], record["params"]["engine"]
        spec = suite.CASES[name]
        length = spec.get("length", 1.0)
        bounds = {key: bound for key, _, bound in spec["metrics"]}
        old = before["records"].get(f"{name}/{engine}")
        new = record["result"]
        row = {"case": name, "label": spec["label"]}
        for key in ("max_drift", "max_penetration"):
            bound = bounds.get(key)
            limit = None if bound is None else bound.resolve(new)
            scale = length if length != 1.0 else 1.0
            for label, result in (("before", old), ("now", new)):
                value = _relative(result, key, scale)
                row[f"{key}_{label}"] = value
                row[f"{key}_{label}_pass"] = (
                    None if value is None or limit is None else bool(value <= limit)
                )
            row[f"{key}_bound"] = limit
        row["ms_before"] = None if old is None else 1e3 * old["seconds_per_step"]
        row["ms_now"] = 1e3 * new["seconds_per_step"]
        rows.append(row)

        def cell(value, passed=None):
            text = "n/a" if value is None else format_number(value)
            return text if passed is None else f"{text} ({'pass' if passed else 'FAIL'})"

        table.append(
            [
                spec["label"],
                cell(row["max_drift_before"], row["max_drift_before_pass"]),
                cell(row["max_drift_now"], row["max_drift_now_pass"]),
                cell(row["max_penetration_before"], row["max_penetration_before_pass"]),
                cell(row["max_penetration_now"], row["max_penetration_now_pass"]),
                cell(row["ms_before"]),
                cell(row["ms_now"]),
            ]
        )
    passes = {
        label: sum(
            bool(r[f"{key}_{label}_pass"]) for r in rows for key in ("max_drift", "max_penetration")
        )
        for label in ("before", "now")
    }
    judged = sum(
        r[f"{key}_now_pass"] is not None for r in rows for key in ("max_drift", "max_penetration")
    )
    summary = {
        "before_commit": before.get("commit", "not recorded"),
        "before_date": before.get("date", "n/a"),
        "before_machine": before.get("machine", "n/a"),
        "rows": rows,
        "passes": passes,
        "judged": judged,
    }
    return Section(
        study=NAME,
        title=TITLE,
        summary=summary,
        tables=[
            Table(
                caption="Drift and penetration over the run (relative to the body's size where "
                "the case is a scale case, else in m), with the stability suite's bound; wall "
                "time per step, before (recorded) and now (this run)",
                columns=[
                    "case",
                    "drift before",
                    "drift now",
                    "penetration before",
                    "penetration now",
                    "ms/step before",
                    "ms/step now",
                ],
                rows=table,
            )
        ],
    )
