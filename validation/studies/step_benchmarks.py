"""Study: whole steps of resting and piled contact scenes (validation/bench_step.py) against
pybullet and MuJoCo."""

from __future__ import annotations

from validation.studies.benchmark_suite import BenchmarkSuiteStudy

_STUDY = BenchmarkSuiteStudy(
    name="step_benchmarks",
    title="Performance: whole steps of resting cubes, pyramids and a pile, against pybullet "
    "and MuJoCo",
    suite="validation/bench_step.py",
    selections={
        "full": None,
        "quick": "one_cube or ten_cubes or pyramid_15",
        "tiny": "one_cube and not mesh and not mujoco",
    },
    max_time={"full": 1.0, "quick": 0.2, "tiny": 0.05},
    size_key="bodies",
    series_key="engine",
    size_label="dynamic bodies",
    peer_setup=(
        "Every engine is built from one scene description (unit cubes of 1 kg, friction 0.5, "
        "240 Hz), settled untimed, then timed with every body awake: pybullet at its "
        "defaults with ACTIVATION_STATE_DISABLE_SLEEPING (damping 0, as in our scene), "
        "MuJoCo at its defaults (it does not sleep), ours with sleeping=False at its "
        "defaults (narrow_phase 'auto') and with narrow_phase 'mesh'."
    ),
)

NAME = _STUDY.NAME
TITLE = _STUDY.TITLE
cases = _STUDY.cases
run = _STUDY.run
summarise = _STUDY.summarise
