"""Study: what a scene does not use costs nothing (validation/bench_effects.py, issue 6).

1000 far-apart bodies in free flight without gravity: the full step of a collidable scene
against the same bodies with only the integration stage (the peer, "integration alone")."""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="effects_benchmarks",
    title="Performance: a scene pays only for the stages it uses",
    suite="validation/bench_effects.py",
    selections={"full": None, "quick": None, "tiny": None},
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.02},
    size_key="bodies",
    series_key="bodies",
    size_label="bodies N",
    ours_prefix="full step, N =",
    peer_setup=(
        "The peer, 'integration alone', is the library itself: the same bodies added with "
        "collidable=False, whose only stage is integration."
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
