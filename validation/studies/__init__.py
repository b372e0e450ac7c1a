"""The studies of the validation campaign, one module each, registered by name.

A study is a module with:

``NAME : str``
    Stable name (used in ``--only``, in file names and in case ids).
``TITLE : str``
    Section heading in the report.
``cases(scale: str) -> list[validation.cases.Case]``
    The work, for ``scale`` in ``{"full", "quick", "tiny"}`` ("tiny" is the test suite's
    smoke run). Each case is a small JSON-able dict of parameters; mark a case
    ``timed=True`` when its record holds wall-clock timings, so the campaign never runs it
    beside another case.
``run(params: dict) -> dict``
    Computes one case and returns a JSON-able record. It must be importable and picklable
    on a worker: no open files, no global state shared between cases.
``summarise(records: list[dict], figures_dir: pathlib.Path) -> validation.section.Section``
    Turns the records of the cases of this scale (in the order ``cases`` gave them) into
    the section's summary numbers, tables, figures (written into ``figures_dir``) and text
    (rendered from the summary by a template in ``validation/templates/``).

To add a study: write the module and append it to ``STUDIES`` below.
"""

from __future__ import annotations

from types import ModuleType

from validation.studies import (
    collision_modes,
    contact_benchmarks,
    contact_formulations,
    distance_paths,
    dzhanibekov,
    effects_benchmarks,
    fcl_crosscheck,
    free_flight_benchmarks,
    impact_handling,
    integrators,
    joint_benchmarks,
    lcp_vs_pgs,
    long_runs,
    narrow_phase_paths,
    obb_vs_aabb,
    obbtree_benchmarks,
    obbtree_variants,
    predicate_cost,
    query_benchmarks,
    query_costs,
    robot_benchmarks,
    sap_benchmarks,
    scene_studies,
    stability_suite,
    startup,
    step_benchmarks,
    urdf_survey,
)

__all__ = ["STUDIES", "get_study"]

STUDIES: dict[str, ModuleType] = {
    module.NAME: module
    for module in (
        integrators,
        dzhanibekov,
        long_runs,
        free_flight_benchmarks,
        effects_benchmarks,
        collision_modes,
        obbtree_variants,
        obb_vs_aabb,
        fcl_crosscheck,
        predicate_cost,
        impact_handling,
        lcp_vs_pgs,
        stability_suite,
        contact_formulations,
        obbtree_benchmarks,
        narrow_phase_paths,
        query_costs,
        distance_paths,
        query_benchmarks,
        sap_benchmarks,
        contact_benchmarks,
        step_benchmarks,
        joint_benchmarks,
        urdf_survey,
        robot_benchmarks,
        scene_studies,
        startup,
    )
}


def get_study(name: str) -> ModuleType:
    """The study module registered as ``name``; ValueError naming the known ones otherwise."""
    try:
        return STUDIES[name]
    except KeyError:
        raise ValueError(f"unknown study {name!r}; known: {', '.join(STUDIES)}") from None
