"""A study's results: one row per run (variant and seed), its Pareto front and recommendation.

The table is plain Python (rows of dicts, columns as numpy arrays) so that a study needs no
pandas; :meth:`StudyTable.to_pandas` hands it to pandas where that is installed.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from thesis_rbd.studies.measures import MEASURES, UNITS

__all__ = [
    "TIMING_COLUMNS",
    "Recommendation",
    "StudyTable",
    "checked_thresholds",
    "format_value",
    "measure_name",
]

# Columns that depend on the machine and the workers beside the run, not on the simulation:
# the rest of the table is the same whoever ran it.
TIMING_COLUMNS = ("wall_seconds", "wall_per_second", "workers", "workers_per_core", "host")


def measure_name(name: str) -> str:
    """A measure's column from its column name or short name (``position`` ->
    ``position_error``).

    Raises
    ------
    ValueError
        Naming the measures there are.
    """
    for candidate in (name, f"{name}_error"):
        if candidate in MEASURES:
            return candidate
    short = [m.removesuffix("_error") for m in MEASURES]
    raise ValueError(f"unknown measure {name!r}; measures: {', '.join(short)}")


def checked_thresholds(within: Mapping[str, float]) -> dict[str, float]:
    """``within`` with each measure's column name (``position`` -> ``position_error``).

    Raises
    ------
    ValueError
        If it names an unknown measure, a threshold is not a positive number, or it is empty.
    """
    thresholds = {}
    for name, value in within.items():
        measure = measure_name(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise ValueError(f"the threshold of {name} must be a positive number, got {value!r}")
        thresholds[measure] = float(value)
    if not thresholds:
        raise ValueError("a recommendation needs at least one threshold (--within)")
    return thresholds


@dataclass(frozen=True)
class Recommendation:
    """The cheapest variant within thresholds.

    Attributes
    ----------
    settings : dict or None
        The variant's settings; None if no variant is within the thresholds.
    wall_per_second : float
        Its mean wall time per simulated second over its seeds (s/s).
    sentence : str
        The recommendation in one line, as the page and the command line print it.
    """

    settings: dict | None
    wall_per_second: float
    sentence: str


class StudyTable:
    """The rows of a study.

    Parameters
    ----------
    rows : list of dict
        One per run: the varied settings (named as varied), ``seed``, ``status`` ("ok" or
        "failed"), ``failure`` (the error of a failed run, else ""), ``steps``, the timing
        columns (``TIMING_COLUMNS``: ``wall_seconds`` spent stepping, ``wall_per_second``
        of simulated time, ``workers`` beside it and ``workers_per_core``, ``host``), the
        error columns (``measures.MEASURES``) and, for each, ``<measure>_floor``: the
        reference's own seed spread.
    varied : list of str
        The varied settings' names, in the order of the grid.
    floors : dict
        The seed spread of each measure (0 with one seed).
    """

    def __init__(self, rows: list[dict], varied: Sequence[str], floors: Mapping[str, float]):
        self.rows = rows
        self.varied = list(varied)
        self.floors = dict(floors)
        self.columns = [
            *self.varied, "seed", "status", "failure", "steps", *TIMING_COLUMNS, *MEASURES,
            *(f"{m}_floor" for m in MEASURES),
        ]  # fmt: skip

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, column: str) -> np.ndarray:
        """One column over the rows."""
        if column not in self.columns:
            raise KeyError(f"no column {column!r}; columns: {', '.join(self.columns)}")
        return np.array([row[column] for row in self.rows])

    def __repr__(self) -> str:
        return f"StudyTable({len(self.rows)} runs of {', '.join(self.varied)})"

    def to_pandas(self):
        """The table as a pandas DataFrame (pandas is an optional dependency)."""
        try:
            import pandas
        except ImportError as exc:
            raise ImportError("StudyTable.to_pandas needs pandas: pip install pandas") from exc
        return pandas.DataFrame(self.rows, columns=self.columns)

    def to_parquet(self, path) -> None:
        """Write the table as a Parquet file (needs pandas and pyarrow, optional)."""
        frame = self.to_pandas()
        try:
            frame.to_parquet(path)
        except ImportError as exc:
            raise ImportError("StudyTable.to_parquet needs pyarrow: pip install pyarrow") from exc

    def to_csv(self) -> str:
        """The table as CSV text, one row per run, columns as :attr:`columns`."""
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=self.columns, lineterminator="\n")
        writer.writeheader()
        for row in self.rows:
            writer.writerow({key: _csv_value(row[key]) for key in self.columns})
        return buffer.getvalue()

    # ------------------------------------------------------------------ per variant
    def variants(self) -> list[dict]:
        """One entry per variant (its seeds together): ``settings``, ``wall_per_second``
        (mean over seeds), each measure's largest value over seeds, and ``failed`` (how
        many of its seeds failed)."""
        grouped: dict[tuple, list[dict]] = {}
        for row in self.rows:
            grouped.setdefault(tuple(row[name] for name in self.varied), []).append(row)
        variants = []
        for key, rows in grouped.items():
            entry = {
                "settings": dict(zip(self.varied, key, strict=True)),
                "wall_per_second": float(np.mean([r["wall_per_second"] for r in rows])),
                "failed": sum(r["status"] != "ok" for r in rows),
            }
            for measure in MEASURES:
                values = [r[measure] for r in rows if not math.isnan(r[measure])]
                entry[measure] = max(values) if values else math.nan
            variants.append(entry)
        return variants

    def pareto_front(self, measure: str = "position_error") -> list[dict]:
        """The variants no other variant beats in both time and ``measure``, cheapest
        first (failed variants excluded)."""
        measure = measure_name(measure)
        candidates = [v for v in self.variants() if not v["failed"] and not math.isnan(v[measure])]
        candidates.sort(key=lambda v: (v["wall_per_second"], v[measure]))
        front, best = [], math.inf
        for variant in candidates:
            if variant[measure] < best:
                front.append(variant)
                best = variant[measure]
        return front

    def recommend(self, within: Mapping[str, float]) -> Recommendation:
        """The cheapest variant whose every seed finished and whose errors are within
        ``within`` (a threshold per measure, in its units). An error at or below the
        measure's seed floor passes whatever the threshold: below it no setting can be told
        from the reference.

        Raises
        ------
        ValueError
            If ``within`` names an unknown measure or a threshold is not a positive number.
        """
        thresholds = checked_thresholds(within)
        passing = [
            v
            for v in self.variants()
            if not v["failed"]
            and all(
                not math.isnan(v[m]) and v[m] <= max(limit, self.floors.get(m, 0.0))
                for m, limit in thresholds.items()
            )
        ]
        limits = ", ".join(
            f"{m.removesuffix('_error')} <= {v:g} {UNITS[m]}" for m, v in thresholds.items()
        )
        if not passing:
            return Recommendation(None, math.nan, f"no variant is within {limits}")
        best = min(passing, key=lambda v: v["wall_per_second"])
        settings = ", ".join(f"{k}={format_value(v)}" for k, v in best["settings"].items())
        return Recommendation(
            best["settings"],
            best["wall_per_second"],
            f"cheapest within {limits}: {settings} "
            f"({best['wall_per_second']:.3g} s of wall time per simulated second)",
        )


def _csv_value(value):
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(float(value))
    return value


def format_value(value, digits: int = 4) -> str:
    """A setting's or a measure's value in a few digits (a name as it is; NaN as "")."""
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.{digits}g}"
    return str(value)
