"""A study made of one pytest-benchmark suite: ratio tables against peers, a scaling figure.

Instantiate :class:`BenchmarkSuiteStudy` in a study module and expose its members as the
module's ``NAME``, ``TITLE``, ``cases``, ``run`` and ``summarise`` (see
``free_flight_benchmarks.py``). The suite follows :mod:`validation.benchjson`'s convention:
peers carry ``extra_info["peer"]``; the scaling figure reads the problem size from
``extra_info[size_key]`` and names each curve by ``extra_info[series_key]`` (peers by their
peer name).
"""

from __future__ import annotations

from validation.benchjson import compare_with_peers, read_benchmarks, run_benchmark_suite
from validation.cases import Case
from validation.formatting import format_number
from validation.plotting import METHOD_STYLES, new_axes, save_figure
from validation.section import Figure, Section, Table

__all__ = ["BenchmarkSuiteStudy"]


class BenchmarkSuiteStudy:
    """One pytest-benchmark file as a campaign study.

    Parameters
    ----------
    name, title : str
        The study's ``NAME`` and ``TITLE``.
    suite : str
        Benchmark file, relative to the repository root.
    selections : dict
        ``{scale: -k expression or None}`` for "full", "quick" and "tiny".
    max_time : dict
        ``{scale: seconds}``: pytest-benchmark's --benchmark-max-time per benchmark.
    size_key : str
        ``extra_info`` key of the problem size (x axis of the scaling figure).
    series_key : str or tuple of str
        ``extra_info`` key(s) naming the curve a benchmark belongs to; a peer's curve is
        its peer name followed by the same keys' values.
    size_label : str
        x-axis label of the scaling figure.
    peer_series : dict, optional
        Peer name (``extra_info["peer"]`` when a string, else the test function's name) ->
        series key, so that a peer is drawn with its style from
        :data:`validation.plotting.METHOD_STYLES`.
    ours_prefix : str, optional
        Name put before our curves' series values (e.g. "SweepAndPrune"); none by default.
    peer_series_keys : tuple of str
        ``extra_info`` keys whose values follow a peer's name in its curve's name (e.g.
        ``("motion",)``); none by default.
    scaling_tests : tuple of str, optional
        Test functions drawn in the scaling figure; all by default.
    peer_setup : str
        How each peer is configured, in words (defaults, or what is tuned and why); the
        report states it beside the tables.
    """

    def __init__(
        self,
        name,
        title,
        suite,
        selections,
        max_time,
        size_key,
        series_key,
        size_label,
        peer_series=None,
        ours_prefix=None,
        peer_series_keys=(),
        scaling_tests=None,
        peer_setup="",
    ):
        self.NAME = name
        self.TITLE = title
        self.suite = suite
        self.selections = selections
        self.max_time = max_time
        self.size_key = size_key
        self.series_key = series_key
        self.size_label = size_label
        self.peer_series = dict(peer_series or {})
        self.series_keys = (series_key,) if isinstance(series_key, str) else tuple(series_key)
        self.ours_prefix = ours_prefix
        self.peer_series_keys = tuple(peer_series_keys)
        self.scaling_tests = None if scaling_tests is None else tuple(scaling_tests)
        self.peer_setup = peer_setup

    def cases(self, scale: str) -> list[Case]:
        """One timed case: the whole suite (or its ``scale`` subset) in one pytest run."""
        params = {
            "suite": self.suite,
            "select": self.selections[scale],
            "max_time": self.max_time[scale],
            "min_rounds": 5,
        }
        return [Case(self.NAME, params, timed=True)]

    def run(self, params: dict) -> dict:
        """Run the suite and keep the reduced benchmarks and pytest-benchmark's machine info."""
        data = run_benchmark_suite(
            params["suite"], params["select"], params["max_time"], params["min_rounds"]
        )
        machine = data.get("machine_info", {})
        return {
            "benchmarks": read_benchmarks(data),
            "datetime": data.get("datetime"),
            "machine_info": {k: machine.get(k) for k in ("node", "processor", "python_version")},
        }

    def _series(self, bench):
        """Curve name: ours by the series keys' values, a peer by its name plus
        ``peer_series_keys``' values."""
        info = bench["extra_info"]
        peer = info.get("peer")
        if peer:
            name = peer if isinstance(peer, str) else bench["test"]
            values = [self.peer_series.get(name, name)]
            values += [str(info[key]) for key in self.peer_series_keys if key in info]
        else:
            values = [str(info[key]) for key in self.series_keys if key in info]
            if self.ours_prefix:
                values.insert(0, self.ours_prefix)
        return " ".join(values) if values else bench["test"]

    def summarise(self, records: list[dict], figures_dir) -> Section:
        """Ratio table against the peers, a median-time table, and the scaling figure."""
        benchmarks = [b for r in records for b in r["result"]["benchmarks"]]
        comparisons = compare_with_peers(benchmarks)
        ratios = [c["ratio"] for c in comparisons]
        summary = {
            "suite": self.suite,
            "select": records[0]["params"]["select"],
            "benchmark_count": len(benchmarks),
            "comparisons": comparisons,
            "comparison_count": len(comparisons),
            "faster_count": sum(r > 1.0 for r in ratios),
            "min_ratio": min(ratios, default=None),
            "max_ratio": max(ratios, default=None),
            "peers": sorted({c["peer"] for c in comparisons}),
            "peer_setup": self.peer_setup,
            "medians": [
                {
                    "name": b["name"],
                    "group": b["group"],
                    "series": self._series(b),
                    "size": b["extra_info"].get(self.size_key),
                    "in_scaling_figure": self.scaling_tests is None
                    or b["test"] in self.scaling_tests,
                    "median": b["stats"]["median"],
                    "iqr": b["stats"].get("iqr"),
                    "rounds": b["stats"].get("rounds"),
                }
                for b in benchmarks
            ],
        }
        table = Table(
            caption=f"{self.suite}: ratio = peer median / our median (> 1: ours is faster)",
            columns=["group", "benchmark", "ours (us)", "peer", "peer (us)", "ratio"],
            rows=[
                [
                    str(c["group"]),
                    c["name"],
                    format_number(1e6 * c["ours_median"]),
                    c["peer"],
                    format_number(1e6 * c["peer_median"]),
                    format_number(c["ratio"]),
                ]
                for c in comparisons
            ],
        )
        figure = self._scaling_figure(summary["medians"], figures_dir)
        return Section(
            self.NAME,
            self.TITLE,
            summary,
            tables=[table],
            figures=[figure],
            template="benchmark_suite",
        )

    def _scaling_figure(self, medians, figures_dir):
        fig, ax = new_axes(f"Scaling: {self.suite}", self.size_label, "median time per call (s)")
        series = {}
        for m in medians:
            if m["size"] is not None and m["in_scaling_figure"]:
                series.setdefault(m["series"], []).append((m["size"], m["median"]))
        for key, points in series.items():
            points.sort()
            style = dict(METHOD_STYLES.get(key, {"marker": "o", "label": key}))
            ax.plot(*zip(*points, strict=True), **style)
        ax.legend(fontsize=8)
        file = f"{self.NAME}_scaling.png"
        save_figure(fig, figures_dir / file)
        return Figure(file, f"Median time per call against {self.size_label}, log-log.")
