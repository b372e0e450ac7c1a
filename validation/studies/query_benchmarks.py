"""Study: benchmarks of distance, pose batches, rays and per-call overhead (bench_queries.py)."""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="query_benchmarks",
    title="Performance: distance, pose batches, rays and per-call overhead against peers",
    suite="validation/bench_queries.py",
    selections={
        "full": None,
        "quick": "not lifted",
        "tiny": "overhead",
    },
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.05},
    size_key="triangles",
    series_key="group",
    size_label="triangles per mesh",
    peer_series_keys=("group",),
    # The per-call cost of a query with almost no work, against the mesh size (one triangle
    # for the distance, 5000 for the overlap query missing at the root).
    peer_setup=(
        "python-fcl and trimesh run at their defaults, one query per pose or one ray batch, on "
        "one thread (neither has a call for a stack of poses). collide_batch runs on numba's "
        "threads, at numba's default of one per core of the machine described above; "
        "distance_batch, the other queries and the per-call overheads run on one."
    ),
    scaling_tests=(
        "test_overhead_first",
        "test_fcl_overhead_first",
        "test_overhead_distance",
        "test_fcl_overhead_distance",
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
