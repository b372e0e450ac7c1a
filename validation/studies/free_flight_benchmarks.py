"""Study: free-flight step benchmarks (validation/bench_dynamics.py) against the NumPy peer."""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="free_flight_benchmarks",
    title="Performance: free-flight steps against a vectorised NumPy RK4",
    suite="validation/bench_dynamics.py",
    selections={
        "full": None,
        "quick": "not 1000",  # N = 10 and 100
        "tiny": "(rk4 or numpy_peer) and not 100",  # rk4 and the peer at N = 10
    },
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.05},
    size_key="bodies",
    series_key="integrator",
    size_label="bodies N",
    peer_series={"test_free_flight_step_numpy_peer": "numpy_peer"},
    peer_setup=(
        "The peer is a vectorised NumPy RK4 of the same equations, written for this "
        "comparison (it agrees with the kernel to round-off over one step)."
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
