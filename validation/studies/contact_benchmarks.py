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
    peer_setup=(
        "pybullet runs without its #3094 restitution tuning (nothing bounces here) and with "
        "damping 0, as in our scene. Like is compared with like: falling, both engines at "
        "their defaults; at rest and asleep, ours at its defaults against pybullet with "
        "sleeping enabled (ACTIVATION_STATE_ENABLE_SLEEPING; its multibodies never sleep by "
        "default); at rest and awake, ours with sleeping=False against pybullet's defaults."
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
