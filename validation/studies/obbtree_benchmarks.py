"""Study: OBBTree narrow-phase benchmarks (validation/bench_obbtree.py) against python-fcl."""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="obbtree_benchmarks",
    title="Performance: OBBTree queries and builds against python-fcl",
    suite="validation/bench_obbtree.py",
    selections={
        "full": None,
        "quick": "not hull and not f32",  # triangle-fit float64 trees, fcl, scaling
        "tiny": "scaling and not 50 and not 72",  # scaling at 512 and 2048 triangles
    },
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.05},
    size_key="triangles",
    series_key="variant",
    size_label="triangles per torus",
    peer_series_keys=("mode",),
    scaling_tests=("test_scaling_all_pairs",),
    peer_setup=(
        "python-fcl runs at its defaults: one BVHModel (OBBRSS boxes) per mesh and "
        "fcl.collide with num_max_contacts 1 for 'first' and 100000 for 'all' and 'contacts' "
        "(enable_contact on for 'contacts')."
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
