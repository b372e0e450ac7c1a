"""Study: contact step benchmarks (validation/bench_contacts.py) against pybullet."""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="contact_benchmarks",
    title="Performance: cube grids falling and at rest, against pybullet",
    suite="validation/bench_contacts.py",
    selections={
        "full": None,
        "quick": "not 1000",  # N = 10 and 100
        "tiny": "falling and not 100 and not awake",  # ours and pybullet falling, N = 10
    },
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.05},
    size_key="bodies",
    series_key=("engine", "phase"),
    size_label="cubes N",
    peer_series_keys=("phase",),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
