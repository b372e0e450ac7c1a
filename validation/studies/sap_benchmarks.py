"""Study: sweep-and-prune benchmarks (validation/bench_sap.py) against python-fcl and NumPy.

The full selection leaves out the incoherent scene at 100k boxes: python-fcl's manager takes
about a minute per frame there, which alone would exceed the campaign's time budget.
"""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="sap_benchmarks",
    title="Performance: sweep and prune against python-fcl's dynamic AABB tree and NumPy",
    suite="validation/bench_sap.py",
    selections={
        # -k matches substrings: "100000" also names no smaller size, "incoherent" contains
        # "coherent", so coherent scenes are selected as "not incoherent"
        "full": "not (incoherent and 100000)",
        "quick": "not fallback and not 100000 and (not 10000 or not incoherent)",
        "tiny": "not fallback and not 10000 and not incoherent",
    },
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.05},
    size_key="boxes",
    series_key="motion",
    size_label="boxes n",
    ours_prefix="SweepAndPrune",
    peer_series_keys=("motion",),
    scaling_tests=("test_sap_update", "test_fcl_manager", "test_numpy_sort_and_sweep"),
    peer_setup=(
        "python-fcl's DynamicAABBTreeCollisionManager runs at its defaults (new translations "
        "set, update, collide with a callback that records each pair); the NumPy peer is a "
        "vectorised sort-and-sweep on x written for this comparison."
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
