"""The validation campaign end to end, on its smallest scale: files, figures, data, resume,
local processes and a Dask LocalCluster."""

import json
import os
from pathlib import Path

import pytest

import validation.execution
from validation.__main__ import main
from validation.campaign import run_campaign
from validation.formatting import format_number
from validation.studies import STUDIES

REPO = Path(__file__).resolve().parents[1]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def quiet(*_args):
    pass


@pytest.fixture(scope="module")
def tiny_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("reports")
    outcome = run_campaign(out=out, scale="tiny", log=quiet)
    return out, outcome


def study_data(out, name):
    return json.loads((out / "data" / f"{name}.json").read_text(encoding="utf-8"))


def test_the_campaign_writes_every_report_file(tiny_report):
    out, outcome = tiny_report
    assert outcome.report == out / "report.md"
    for name in ("report.md", "report.html", "data/campaign.json"):
        assert (out / name).stat().st_size > 0, name
    for name in STUDIES:
        data = study_data(out, name)
        assert outcome.executed[name] == data["case_count"] == len(data["records"]) > 0
        assert len(list((out / "data" / "cases" / name).glob("*.json"))) == data["case_count"]
    campaign = json.loads((out / "data" / "campaign.json").read_text(encoding="utf-8"))
    environment = campaign["environment"]
    assert environment["libraries"]["numpy"] and environment["machine"]["logical_cores"] >= 1
    markdown = (out / "report.md").read_text(encoding="utf-8")
    # a copy outside git (e.g. from git archive) has no commit, and the report says so
    commit = environment["git"]["short"] or "a source tree outside git"
    assert commit in markdown and environment["machine"]["cpu"] in markdown


def test_figures_are_non_empty_pngs_embedded_in_the_html(tiny_report):
    out, _ = tiny_report
    files = [f["file"] for name in STUDIES for f in study_data(out, name)["figures"]]
    assert len(files) >= 6
    html = (out / "report.html").read_text(encoding="utf-8")
    markdown = (out / "report.md").read_text(encoding="utf-8")
    for file in files:
        png = (out / "figures" / file).read_bytes()
        assert png.startswith(PNG_SIGNATURE) and len(png) > 5000, file
        assert f"(figures/{file})" in markdown
    assert html.count('src="data:image/png;base64,') == len(files)


def test_the_report_shows_exactly_the_data(tiny_report):
    out, _ = tiny_report
    markdown = (out / "report.md").read_text(encoding="utf-8")
    for name in STUDIES:
        data = study_data(out, name)
        assert data["paragraphs"]
        for paragraph in data["paragraphs"]:
            assert paragraph in markdown
        for table in data["tables"]:
            for row in table["rows"]:
                cells = [str(cell).replace("|", "\\|") for cell in row]
                assert "| " + " | ".join(cells) + " |" in markdown


def test_headline_numbers_are_the_records_numbers(tiny_report):
    out, _ = tiny_report
    data = study_data(out, "integrators")
    rate = data["summary"]["headline_rate"]
    (rk4,) = [
        r["result"]
        for r in data["records"]
        if r["params"] == {"kind": "accuracy", "method": "rk4", "rate": rate, "seconds": 2.0}
    ]
    assert data["summary"]["headline"]["rk4"]["max_angle_error"] == rk4["max_angle_error"]
    text = " ".join(data["paragraphs"])
    assert f"RK4's largest orientation error is {format_number(rk4['max_angle_error'])} rad" in (
        text
    )
    assert rk4["max_angle_error"] < 1e-6  # RK4 at dt = 1/240 s over 2 s


def test_impact_handling_keeps_the_ball_out_of_the_floor_with_the_time_of_impact(tiny_report):
    out, _ = tiny_report
    data = study_data(out, "impact_handling")
    rows = {(r["scene"], r["mode"], r["rate"]): r for r in data["summary"]["rows"]}
    toi, bias = rows[("ball_e1", "toi", 60)], rows[("ball_e1", "bias", 60)]
    assert toi["max_penetration"] < bias["max_penetration"]
    assert toi["max_energy_error"] < 1e-6 < bias["max_energy_error"]
    assert all(r["ms_per_step"] > 0 for r in rows.values())


def test_lcp_study_measures_pgs_against_an_exact_reference(tiny_report):
    out, _ = tiny_report
    data = study_data(out, "lcp_vs_pgs")
    for record in data["records"]:
        result = record["result"]
        assert result["exact_fallbacks"] == 0 and result["exact_seconds"] > 0
        assert len(result["pgs"]) == 2 * len(record["params"]["iterations"])
        assert all(p["error"] >= 0 and p["seconds"] > 0 for p in result["pgs"])
    text = " ".join(data["paragraphs"])
    stack = data["summary"]["scenes"]["stack"]
    assert f"the exact solve takes {format_number(stack['exact_ms'])} ms" in text


@pytest.fixture(scope="module")
def joint_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("joint_reports")
    run_campaign(out=out, scale="tiny", only=["joint_benchmarks"], log=quiet)
    return out


def test_joint_study_times_every_engine_and_reads_every_gap(joint_report):
    data = study_data(joint_report, "joint_benchmarks")
    summary = data["summary"]
    speed = summary["speed"]
    assert {"ours_ball", "ours_hinge", "pybullet_p2p", "pybullet_multibody"} <= set(speed)
    for row in speed.values():
        assert len(row["ms_per_step"]) == data["records"][0]["params"]["repeats"]
    p2p = speed["pybullet_p2p"]["median_ms"]
    assert summary["ours_over_p2p"] == pytest.approx(speed["ours_ball"]["median_ms"] / p2p)
    for scene in ("chain", "heavy_chain"):
        rows = summary["accuracy"][scene]["settings"]
        assert {r["engine"] for r in rows} == {"ours", "pybullet_p2p"}
        for row in rows:
            assert row["max_gap"] >= 0 and row["median_ms"] > 0
        pybullet = [r for r in rows if r["engine"] == "pybullet_p2p"]
        assert [r["solver_iterations"] for r in pybullet] == [r["iterations"] for r in pybullet]
        assert summary["accuracy"][scene]["ours_auto"]["max_gap"] < 1e-6
    markdown = (joint_report / "report.md").read_text(encoding="utf-8")
    for paragraph in data["paragraphs"]:
        assert paragraph in markdown
    for table in data["tables"]:
        for row in table["rows"]:
            assert "| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" in markdown
    (figure,) = data["figures"]
    assert (joint_report / "figures" / figure["file"]).read_bytes().startswith(PNG_SIGNATURE)
    text = " ".join(data["paragraphs"])
    assert f"{format_number(summary['ours_over_p2p'])} times its time" in text


def _inside(value, bound):
    if isinstance(bound, list):
        return bound[0] <= value <= bound[1]
    return value <= bound


def test_stability_suite_rows_hold_ours_pybullet_and_the_verdict(tiny_report):
    out, _ = tiny_report
    data = study_data(out, "stability_suite")
    summary = data["summary"]
    cases = {row["case"] for row in summary["rows"]}
    assert {"tall_stack", "mass_ratio_stack", "long_run", "cube_1mm", "huge_scale"} <= cases
    for row in summary["rows"]:
        assert row["ours"] is not None and row["peers"]["pybullet"]["value"] is not None
        assert row["basis"].split(":")[0] in {"physics", "geometry", "numerics"}
        if row["construction"]:
            assert row["pass"] is None  # shown, never counted
        else:
            assert row["pass"] == _inside(row["ours"], row["bound"])
        for peer in row["peers"].values():
            if peer["value"] is not None and not peer["construction"]:
                assert peer["pass"] == _inside(peer["value"], peer["bound"])
    judged = [r for r in summary["rows"] if not r["construction"]]
    assert summary["judged_count"] == len(judged)
    assert summary["passing_count"] + len(summary["failing"]) == summary["judged_count"]
    # |L| is thesis_rbd's state: its rows hold by construction and are left out of the count
    momentum = [r for r in summary["rows"] if r["metric"] == "momentum_drift"]
    assert momentum and all(r["construction"] for r in momentum)
    assert summary["construction_count"] == len(momentum)
    (exact,) = [
        r["result"]["max_drift"]
        for r in data["records"]
        if r["params"]["case"] == "mass_ratio_stack" and r["params"]["engine"] == "ours_exact"
    ]
    assert summary["mass_ratio"]["ours_exact"] == exact
    # both pybullet configurations ran every contact case, and the report names them
    engines = {(r["params"]["case"], r["params"]["engine"]) for r in data["records"]}
    assert ("tall_stack", "pybullet") in engines and ("tall_stack", "pybullet_tuned") in engines
    markdown = (out / "report.md").read_text(encoding="utf-8")
    assert "pybullet (defaults)" in markdown and "tuned for restitution" in markdown
    assert "default solver" not in markdown


@pytest.mark.parametrize(
    "name", ["sap_benchmarks", "obbtree_benchmarks", "contact_benchmarks", "effects_benchmarks"]
)
def test_benchmark_suites_compare_with_their_peers(tiny_report, name):
    out, _ = tiny_report
    summary = study_data(out, name)["summary"]
    assert summary["comparison_count"] > 0
    for c in summary["comparisons"]:
        assert c["ratio"] == pytest.approx(c["peer_median"] / c["ours_median"])


def test_a_finished_campaign_runs_nothing_again(tiny_report, monkeypatch):
    out, first = tiny_report

    def refuse(*_args):
        raise AssertionError("a stored case was run again")

    monkeypatch.setattr(validation.execution, "execute_case", refuse)
    again = run_campaign(out=out, scale="tiny", log=quiet)
    assert sum(again.executed.values()) == 0
    assert again.cached == {name: first.executed[name] for name in STUDIES}


def test_an_interrupted_campaign_resumes_where_it_stopped(tmp_path):
    first = run_campaign(out=tmp_path, scale="tiny", only=["long_runs"], log=quiet)
    records = sorted((tmp_path / "data" / "cases" / "long_runs").glob("*.json"))
    for path in records[:3]:
        path.unlink()  # as if the run had stopped before these cases
    again = run_campaign(out=tmp_path, scale="tiny", only=["long_runs"], log=quiet)
    assert again.executed == {"long_runs": 3}
    assert again.cached == {"long_runs": first.executed["long_runs"] - 3}


def test_local_worker_processes(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", str(REPO))
    outcome = run_campaign(out=tmp_path, scale="tiny", only=["long_runs"], jobs=2, log=quiet)
    records = study_data(tmp_path, "long_runs")["records"]
    assert outcome.executed["long_runs"] == len(records) > 1


def test_command_line_refuses_unknown_studies(capsys):
    assert main(["--only", "no_such_study"]) == 2
    assert "no_such_study" in capsys.readouterr().err
    assert main(["--list"]) == 0


def test_dask_local_cluster(tmp_path, monkeypatch):
    distributed = pytest.importorskip(
        "dask.distributed",
        reason="dask.distributed is not installed: pip install 'thesis_rbd[validation]'",
    )
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        status = main(
            [
                "--tiny",
                "--only",
                "long_runs",
                "--out",
                str(tmp_path),
                "--scheduler",
                cluster.scheduler_address,
            ]
        )
    assert status == 0
    data = study_data(tmp_path, "long_runs")
    assert len(data["records"]) == data["case_count"] > 0
    assert (tmp_path / "report.md").is_file()


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (1000.0, "1000"),
        (0.12582, "0.126"),
        (2.0, "2"),
        (9.996, "10"),
        (3.31e-7, "3.31e-07"),
        (1e5, "1.00e+05"),
        (0.0, "0"),
        (None, "n/a"),
        (True, "yes"),
        (240, "240"),
    ],
)
def test_numbers_are_written_with_three_significant_digits(value, text):
    assert format_number(value) == text
