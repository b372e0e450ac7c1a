"""``study.html``: a study's accuracy-against-time plot, its Pareto fronts, its recommendation
and its table, in one self-contained page (the plot is inline SVG).

The plot needs matplotlib (the ``viz`` extra); without it the page says so and keeps the
rest.
"""

from __future__ import annotations

import html
import io
import math
from string import Template

from thesis_rbd.studies.measures import UNITS
from thesis_rbd.studies.table import Recommendation, StudyTable, format_value

__all__ = ["PLOTTED", "accuracy_figure", "study_page"]

PLOTTED = ("position_error", "orientation_error", "energy_error", "penetration")

_PAGE = Template("""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Study of $scene</title>
<style>
body { font-family: sans-serif; max-width: 72em; margin: 2em auto; padding: 0 1em; }
table { border-collapse: collapse; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f4f4f4; } .front { font-weight: bold; } .failed { color: #b00; }
.recommendation { font-size: 1.1em; padding: 0.6em; background: #eef6ee; }
</style></head><body>
<h1>Study of $scene</h1>
<p>$description</p>
<p class="recommendation">$recommendation</p>
$figure
<h2>Variants</h2>
<p>Each error is the largest over the run and over the seeds; in brackets, the floor: how far
the reference's own perturbed seeds stray from it (below it, no setting can be told from the
reference). Bold rows are on the Pareto front of position error against time.</p>
$variants
<p>One row per run: <a href="results.csv">results.csv</a>.</p>
</body></html>
""")


def _number(value, digits: int = 3) -> str:
    return html.escape(format_value(value, digits))


def accuracy_figure(table: StudyTable):
    """The variants' errors against their wall time per simulated second, one panel per
    measure of ``PLOTTED``, log-log, with each measure's Pareto front and seed floor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    variants = [v for v in table.variants() if not v["failed"]]
    figure, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    for axis, measure in zip(axes.flat, PLOTTED, strict=True):
        points = [v for v in variants if v[measure] > 0 and not math.isnan(v[measure])]
        axis.loglog(
            [v["wall_per_second"] for v in points], [v[measure] for v in points], "o",
            color="tab:blue", alpha=0.6, label="variant",
        )  # fmt: skip
        front = [v for v in table.pareto_front(measure) if v[measure] > 0]
        if front:
            axis.loglog(
                [v["wall_per_second"] for v in front], [v[measure] for v in front], "-o",
                color="tab:orange", label="Pareto front",
            )  # fmt: skip
        for v in front:  # only the front is labelled: the page's table names every variant
            axis.annotate(
                ", ".join(_number(x, 2) for x in v["settings"].values()),
                (v["wall_per_second"], v[measure]),
                fontsize=7, xytext=(4, 4), textcoords="offset points",
            )  # fmt: skip
        floor = table.floors.get(measure, math.nan)
        if floor > 0:
            axis.axhline(floor, color="grey", linestyle="--", label="seed floor")
        axis.xaxis.set_minor_formatter(NullFormatter())
        axis.set_xlabel("wall time per simulated second (s/s)")
        axis.set_ylabel(f"{measure.replace('_', ' ')} ({UNITS[measure]})")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    figure.suptitle("settings: " + ", ".join(table.varied), fontsize=9)
    figure.tight_layout()
    return figure


def _figure_svg(table: StudyTable) -> str:
    try:
        figure = accuracy_figure(table)
    except ImportError:
        return "<p>(The plot needs matplotlib: pip install 'thesis_rbd[viz]'.)</p>"
    import matplotlib.pyplot as plt

    buffer = io.StringIO()
    figure.savefig(buffer, format="svg")
    plt.close(figure)
    svg = buffer.getvalue()
    return svg[svg.index("<svg") :]


def _variants_table(table: StudyTable) -> str:
    front = {tuple(v["settings"].items()) for v in table.pareto_front("position_error")}
    head = [*table.varied, "wall time / simulated s", *(m.replace("_", " ") for m in PLOTTED)]
    rows = ["<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr>"]
    for v in table.variants():
        cells = [_number(x, 4) for x in v["settings"].values()]
        cells.append(_number(v["wall_per_second"]))
        for measure in PLOTTED:
            floor = table.floors.get(measure, math.nan)
            shown = _number(v[measure])
            if floor > 0:
                shown += f" ({_number(floor, 2)})"
            cells.append(shown)
        kind = "failed" if v["failed"] else "front" if tuple(v["settings"].items()) in front else ""
        rows.append(f'<tr class="{kind}">' + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return "<table>" + "\n".join(rows) + "</table>"


def study_page(
    table: StudyTable, scene: str, description: str, recommendation: Recommendation | None
) -> str:
    """The page's HTML.

    Parameters
    ----------
    table : StudyTable
    scene : str
        The scene's name.
    description : str
        What was run (span, seeds, reference), one paragraph of plain text.
    recommendation : Recommendation, optional
        None when no thresholds were given.
    """
    sentence = (
        "Give thresholds (--within position=1e-3,...) for a recommendation."
        if recommendation is None
        else recommendation.sentence
    )
    return _PAGE.substitute(
        scene=html.escape(scene),
        description=html.escape(description),
        recommendation=html.escape(sentence),
        figure=_figure_svg(table),
        variants=_variants_table(table),
    )
