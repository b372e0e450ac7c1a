"""Studies (``rbd.study``, ``thesis-rbd study``): the error measures against known answers,
the grid's checks, and the same table whoever runs it (this process, local workers, a Dask
cluster), through a killed worker and an interrupted study."""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.scene import parse_scene
from thesis_rbd.studies import TIMING_COLUMNS, StudyError
from thesis_rbd.studies.grid import parse_assignments, parse_value, parse_vary
from thesis_rbd.studies.run import reference_settings
from thesis_rbd.studies.sampling import sample_run, sampled_run

# A box with a square cross-section (I1 = I2) spinning off its axes, no gravity: torque-free
# precession, which has a closed form.
TOP = """
description = "A square box tumbling freely"
seconds = 2.0
[world]
dt = 0.01
[[body]]
name = "top"
shape = { type = "box", extents = [0.2, 0.2, 0.6] }
mass = 2.0
angular_velocity = [1.0, 0.5, 4.0]
"""


def top_scene(seconds: float = 2.0):
    return parse_scene(TOP.replace("seconds = 2.0", f"seconds = {seconds}"), "top", "test", Path())


def free_precession(world, times: np.ndarray) -> np.ndarray:
    """Orientations (T, 4) of the axisymmetric body of ``world`` (identity at t = 0): it
    turns about its constant world momentum L at |L| / I1 and, within, about its own
    symmetry axis at (1/I3 - 1/I1) L3, so R(t) = exp(t [L] / I1) exp(t c [e3])."""
    inertia = world.bodies.inertia_body[0]
    i1, i3 = inertia[0, 0], inertia[2, 2]
    momentum = world.bodies.angular_momentum[0]
    about_momentum = Rotation.from_rotvec(np.outer(times, momentum / i1))
    about_axis = Rotation.from_rotvec(np.outer(times, [0.0, 0.0, (1 / i3 - 1 / i1) * momentum[2]]))
    return (about_momentum * about_axis).as_quat()


def test_orientation_error_is_the_distance_from_free_precession_and_shows_each_order():
    scene = top_scene()
    dts = [1 / 30, 1 / 60, 1 / 120]
    table = rbd.study(
        scene,
        vary={"integrator": ["euler", "midpoint", "rk4"], "dt": dts},
        reference={"integrator": "rk4"},
        workers=1,
    )
    world = scene.build()
    errors = {}
    for row in table:
        samples = sampled_run(
            scene.with_world(integrator=row["integrator"], dt=row["dt"]), 2.0, 0, 1e-6
        )["samples"]
        exact = Rotation.from_quat(free_precession(world, samples.times))
        analytic = (Rotation.from_quat(samples.orientations[:, 0]).inv() * exact).magnitude().max()
        # the study measures against a run at a quarter of the finest step, not the closed
        # form: the two agree to within that run's own error (1.6e-10 rad at rk4)
        assert row["orientation_error"] == pytest.approx(analytic, rel=0.06, abs=1e-9)
        errors[row["integrator"], row["dt"]] = row["orientation_error"]
    for integrator, order in (("euler", 1), ("midpoint", 2), ("rk4", 4)):
        for coarse, fine in itertools.pairwise(dts):
            observed = math.log2(errors[integrator, coarse] / errors[integrator, fine])
            assert observed == pytest.approx(order, abs=0.3), (integrator, coarse)


def test_bouncing_ball_errors_against_the_e_squared_rule():
    """The ball of the built-in scene (restitution 0.8 on a floor of 1.0, dropped from 1 m)
    rises to 0.8^2 of its last height after each bounce: its position between bounces is a
    parabola, and its energy above the contact height falls by e^2 at each bounce."""
    scene = rbd.scenes.get("bouncing_ball")
    g, e, radius = 9.81, 0.8, 0.5
    table = rbd.study(scene, vary={"dt": [1 / 60, 1 / 120]}, seconds=2.5, workers=1)

    def height(times):
        speed, landing, heights = math.sqrt(2 * g * 1.0), math.sqrt(2 * 1.0 / g), []
        for t in times:
            if t <= landing:
                heights.append(1.5 - 0.5 * g * t * t)
                continue
            s, v = t - landing, e * speed
            while s > 2 * v / g:
                s, v = s - 2 * v / g, v * e
            heights.append(radius + v * s - 0.5 * g * s * s)
        return np.array(heights)

    settings = reference_settings(scene, [{"dt": 1 / 60}, {"dt": 1 / 120}], None)
    reference = sampled_run(scene.with_world(**settings), 2.5, 0, 1e-6)["samples"]
    reference_error = np.abs(reference.positions[:, 1, 2] - height(reference.times)).max()
    for row in table:
        samples = sampled_run(scene.with_world(dt=row["dt"]), 2.5, 0, 1e-6)["samples"]
        analytic = np.abs(samples.positions[:, 1, 2] - height(samples.times)).max()
        assert abs(row["position_error"] - analytic) <= reference_error + 1e-9
        assert reference_error < 0.5 * analytic  # the reference is the better of the two
    # energy above the resting height at each apex of the reference: e^2, e^4, ...
    z = reference.positions[:, 1, 2]
    apexes = [i for i in range(1, len(z) - 1) if z[i - 1] <= z[i] > z[i + 1]]
    above = (reference.energy - g * radius) / (reference.energy[0] - g * radius)
    assert len(apexes) >= 3
    np.testing.assert_allclose(above[apexes], e ** (2 * np.arange(1, len(apexes) + 1)), rtol=2e-3)


def test_sampled_energy_and_momenta_are_the_worlds_own_readouts_step_by_step():
    """The totals worked out after a run from the per-step copies (the fast path) against
    the world's own readouts taken after every step (the slow reference)."""
    scene = rbd.scenes.get("rain")
    samples, _, failure = sample_run(scene.build(), 0.5)
    world = scene.build()
    static = world.bodies.static
    for k in range(len(samples)):
        if k:
            world.step()
        b = world.bodies
        energy = world.kinetic_energy() + world.potential_energy()
        assert samples.energy[k] == pytest.approx(energy, rel=1e-12, abs=1e-12)
        momentum = b.linear_momentum[~static].sum(axis=0)
        np.testing.assert_allclose(samples.linear_momentum[k], momentum, rtol=1e-12, atol=1e-12)
        angular = sum(
            b.angular_momentum[i] + np.cross(b.position[i], b.linear_momentum[i])
            for i in range(len(world))
            if not static[i]
        )
        np.testing.assert_allclose(samples.angular_momentum[k], angular, rtol=1e-12, atol=1e-9)
        np.testing.assert_array_equal(samples.positions[k], b.position)
        assert samples.penetration[k] == world.deepest_penetration
    assert failure is None and len(samples) == 121


def test_momentum_is_measured_only_where_nothing_outside_acts():
    table = rbd.study(top_scene(0.5), vary={"dt": [1 / 60]}, workers=1)
    assert table["momentum_error"][0] < 1e-12 and table["angular_momentum_error"][0] < 1e-9
    ball = rbd.study("bouncing_ball", vary={"dt": [1 / 60]}, seconds=0.2, workers=1)
    assert np.isnan(ball["momentum_error"]).all()


def test_a_run_that_fails_is_recorded_with_its_error():
    table = rbd.study(top_scene(1.0), vary={"angular_drag": [0.0, 1000.0]}, workers=1)
    ok, failed = table.rows
    assert ok["status"] == "ok" and ok["failure"] == ""
    assert failed["status"] == "failed" and "non-finite" in failed["failure"]
    assert failed["steps"] < ok["steps"]
    assert table.recommend({"orientation": 1.0}).settings == {"angular_drag": 0.0}


def test_joint_substeps_are_a_setting_like_any_other():
    """The double pendulum at dt = 1/60: each doubling of the joint substeps about halves
    its error (the substep is first order in its length), against a reference finer than
    every substep (the default, dt / 4, would be the four-substep run itself)."""
    table = rbd.study(
        "double_pendulum", vary={"dt": [1 / 60], "joint_substeps": [1, 2, 4]}, seconds=1.0,
        reference={"dt": 1 / 1920}, workers=1,
    )  # fmt: skip
    errors = table["position_error"]
    assert list(table["joint_substeps"]) == [1, 2, 4] and set(table["status"]) == {"ok"}
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 1.6) & (ratios < 3.0)), errors


# ---------------------------------------------------------------------- the grid's checks
def test_command_line_values_are_read_as_numbers_names_and_flags():
    assert parse_value("1/240") == pytest.approx(1 / 240)
    assert parse_value("8") == 8 and isinstance(parse_value("8"), int)
    assert parse_value("1e-3") == 1e-3 and parse_value("true") is True
    assert parse_value("rk4") == "rk4"
    assert parse_vary("dt=1/60,1/120") == ("dt", [1 / 60, 1 / 120])
    assert parse_assignments("position=1e-3,energy=0.01", "--within") == {
        "position": 1e-3,
        "energy": 0.01,
    }
    with pytest.raises(StudyError, match="NAME=V1"):
        parse_vary("dt")
    with pytest.raises(StudyError, match="no value"):
        parse_vary("dt=")


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"vary": {}}, "varies nothing"),
        ({"vary": {"dt": []}}, "grid is empty"),
        ({"vary": {"timestep": [0.01]}}, "unknown setting 'timestep'"),
        ({"vary": {"integrator": ["leapfrog"]}}, "unknown integrator 'leapfrog'"),
        ({"vary": {"dt": [-0.01]}}, "dt"),
        ({"vary": {"dt": [0.01, 0.01]}}, "twice"),
        ({"vary": {"dt": 0.01}}, "must be a list"),
        ({"vary": {"dt": [0.01]}, "seeds": 0}, "seeds"),
        ({"vary": {"dt": [0.01]}, "seconds": math.inf}, "seconds"),
        ({"vary": {"dt": [0.01]}, "workers": 0}, "workers"),
        ({"vary": {"dt": [0.01]}, "within": {"speed": 1.0}}, "unknown measure 'speed'"),
        ({"vary": {"dt": [0.01]}, "within": {"position": -1.0}}, "positive"),
        ({"vary": {"dt": [0.01]}, "reference": {"solver": "pgs"}}, "reference: unknown setting"),
        ({"vary": {"dt": [0.01]}, "reference": {"contact_solver": "lu"}}, "reference"),
    ],
)
def test_bad_input_is_refused_before_anything_runs(tmp_path, arguments, message):
    with pytest.raises(StudyError, match=message):
        rbd.study(top_scene(), out=tmp_path / "study", **{"workers": 1, **arguments})
    assert not list(tmp_path.glob("study/runs/*")) and not list(tmp_path.glob("study/*.csv"))


def test_a_reference_that_fails_is_an_error_and_records_nothing(tmp_path):
    with pytest.raises(StudyError, match=r"reference run of seed 0 failed.*non-finite"):
        rbd.study(
            top_scene(0.5), vary={"dt": [0.01]}, reference={"angular_drag": 1000.0},
            out=tmp_path, workers=1,
        )  # fmt: skip
    assert not list(tmp_path.glob("runs/*")) and not (tmp_path / "results.csv").exists()


def test_pandas_and_dask_are_optional_with_a_clear_message(monkeypatch):
    import builtins

    table = rbd.study(top_scene(0.1), vary={"dt": [0.05]}, workers=1)
    real_import = builtins.__import__

    def without(*names):
        def refuse(name, *args, **kwargs):
            if name.split(".")[0] in names:
                raise ImportError(f"No module named {name!r}")
            return real_import(name, *args, **kwargs)

        return refuse

    monkeypatch.setattr(builtins, "__import__", without("pandas"))
    with pytest.raises(ImportError, match="pip install pandas"):
        table.to_pandas()
    monkeypatch.setattr(builtins, "__import__", without("dask", "distributed"))
    with pytest.raises(ImportError, match=r"pip install 'dask\[distributed\]'"):
        rbd.study(top_scene(0.1), vary={"dt": [0.05]}, scheduler="tcp://127.0.0.1:1")


def test_a_folder_of_another_study_is_not_mixed_with_this_one(tmp_path):
    rbd.study(top_scene(0.1), vary={"dt": [0.05]}, out=tmp_path, workers=1)
    with pytest.raises(StudyError, match=r"another study.*seconds"):
        rbd.study(top_scene(0.1), vary={"dt": [0.05]}, seconds=0.2, out=tmp_path, workers=1)
    table = rbd.study(top_scene(0.1), vary={"dt": [0.05]}, seconds=0.2, out=tmp_path, fresh=True)
    assert table["steps"][0] == 4


# ---------------------------------------------------------------------- who runs it
def _without_timing(table) -> list[dict]:
    return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in table]


def _same_tables(a, b) -> None:
    # numbers bit for bit: every run is deterministic whoever runs it
    assert json.dumps(_without_timing(a)) == json.dumps(_without_timing(b))


STUDY = {"vary": {"integrator": ["euler", "rk4"], "dt": [1 / 50, 1 / 100]}, "seeds": 2}


@pytest.fixture(scope="module")
def in_process():
    return rbd.study(top_scene(1.0), workers=1, **STUDY)


def test_two_local_workers_and_a_dask_cluster_make_the_same_table(in_process, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    local = rbd.study(top_scene(1.0), workers=2, out=tmp_path / "local", **STUDY)
    _same_tables(local, in_process)
    assert set(local["workers"]) == {2}
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        on_dask = rbd.study(top_scene(1.0), scheduler=cluster.scheduler_address, **STUDY)
        # a scene whose runs differ in their last bits with the number of BLAS threads (Dask
        # runs one per worker) and that amplifies it: one thread everywhere
        pyramid = {"vary": {"dt": [1 / 60], "narrow_phase": ["mesh"]}, "seeds": 3}
        pyramid_on_dask = rbd.study("pyramid", scheduler=cluster.scheduler_address, **pyramid)
    _same_tables(on_dask, in_process)
    _same_tables(pyramid_on_dask, rbd.study("pyramid", workers=1, **pyramid))
    assert len(in_process) == 8 and in_process.floors["orientation_error"] > 0


def _workers():
    """This process's local study workers (not multiprocessing's resource tracker)."""
    import psutil

    return [
        child
        for child in psutil.Process().children(recursive=True)
        if "spawn_main" in " ".join(child.cmdline())
    ]


@pytest.mark.skipif(sys.platform != "linux", reason="kills processes by signal")
def test_a_killed_worker_loses_no_run(in_process, tmp_path):
    """A worker killed mid-study: its runs go to a new worker, and the table is whole."""
    killed = []

    def kill_a_worker():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not killed:
            records = list((tmp_path / "runs").glob("[!.]*.json"))
            workers = _workers()
            if records and workers:
                workers[0].kill()
                killed.append(workers[0].pid)
            time.sleep(0.05)

    watcher = threading.Thread(target=kill_a_worker)
    watcher.start()
    # longer runs than the fixture's, so that the watcher finds workers at work
    slow = {**STUDY, "vary": {**STUDY["vary"], "dt": [1 / 2000, 1 / 4000]}}
    table = rbd.study(top_scene(1.0), workers=2, out=tmp_path, **slow)
    watcher.join()
    assert killed, "no worker was killed: the test did not test anything"
    again = rbd.study(top_scene(1.0), workers=1, **slow)
    _same_tables(table, again)


@pytest.mark.skipif(sys.platform != "linux", reason="kills processes by signal")
def test_a_lost_dask_worker_loses_no_run(tmp_path):
    """A Dask worker killed mid-study (a lost node): the scheduler gives its runs to the
    other worker (and to the one its nanny starts again), and the table is whole."""
    distributed = pytest.importorskip("dask.distributed")
    killed = []
    slow = {**STUDY, "vary": {**STUDY["vary"], "dt": [1 / 2000, 1 / 4000]}}
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        workers = _workers()  # the cluster's worker processes, started by its nannies

        def kill_a_worker():
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not killed:
                if list((tmp_path / "runs").glob("[!.]*.json")):
                    workers[0].kill()
                    killed.append(workers[0].pid)
                time.sleep(0.05)

        watcher = threading.Thread(target=kill_a_worker)
        watcher.start()
        table = rbd.study(top_scene(1.0), scheduler=cluster.scheduler_address, out=tmp_path, **slow)
        watcher.join()
    assert len(workers) == 2 and killed, "no worker was killed: the test did not test anything"
    _same_tables(table, rbd.study(top_scene(1.0), workers=1, **slow))


@pytest.mark.skipif(sys.platform != "linux", reason="kills processes by signal")
def test_an_interrupted_study_resumes_where_it_stopped(in_process, tmp_path):
    scene_file = tmp_path / "top.toml"
    scene_file.write_text(TOP.replace("seconds = 2.0", "seconds = 1.0"), encoding="utf-8")
    out = tmp_path / "study"
    command = [
        sys.executable, "-m", "thesis_rbd.cli", "study", str(scene_file), "--out", str(out),
        "--vary", "integrator=euler,rk4", "--vary", "dt=1/50,1/100", "--seeds", "2", "-j", "2",
        "--quiet",
    ]  # fmt: skip
    first = subprocess.Popen(command, start_new_session=True)
    deadline = time.monotonic() + 300
    while len(list(out.glob("runs/[!.]*.json"))) < 2 and time.monotonic() < deadline:
        if first.poll() is not None:
            break
        time.sleep(0.02)
    os.killpg(first.pid, signal.SIGKILL)  # the study and its workers, at once
    first.wait()
    finished = {path: path.stat().st_mtime_ns for path in out.glob("runs/[!.]*.json")}
    assert 2 <= len(finished) < 8 and not (out / "results.csv").exists()
    subprocess.run(command, check=True, timeout=300)
    # every earlier record kept as it was, each run recorded once, the table whole
    assert all(path.stat().st_mtime_ns == mtime for path, mtime in finished.items())
    assert len(list(out.glob("runs/[!.]*.json"))) == 8
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 9
    resumed = rbd.study(scene_file, out=out, workers=1, **STUDY)  # all recorded: runs nothing
    _same_tables(resumed, in_process)
    assert (out / "study.html").read_text().count("<svg") == 1


def test_the_command_line_writes_the_table_page_and_recommendation(tmp_path):
    result = subprocess.run(
        [
            sys.executable, "-m", "thesis_rbd.cli", "study", "bouncing_ball", "--out",
            str(tmp_path), "--vary", "dt=1/60,1/120", "--seconds", "0.5", "-j", "1",
            "--within", "position=1e-3",
        ],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    # the recommendation is the variant whose every seed is within the bound (or its floor)
    # and whose runs took least wall time per simulated second, as the table has them: the
    # timings, not the grid's order, decide
    variants = {}
    for row in csv.DictReader((tmp_path / "results.csv").open()):
        variants.setdefault(row["dt"], []).append(row)
    within = {
        dt: np.mean([float(r["wall_per_second"]) for r in rows])
        for dt, rows in variants.items()
        if all(
            float(r["position_error"]) <= max(1e-3, float(r["position_error_floor"])) for r in rows
        )
    }
    cheapest = min(within, key=within.get)
    assert f"cheapest within position <= 0.001 m: dt={float(cheapest):.4g}" in result.stdout
    header = (tmp_path / "results.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["dt", "seed", "status"] and "position_error_floor" in header
    assert "cheapest within" in (tmp_path / "study.html").read_text()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--vary", "dt=1/60", "--vary", "dt=1/120"], "two --vary"),
        (["--vary", "narrow_phase=gjk"], "narrow"),
        (["--vary", "dt=1/60", "--within", "position"], "--within takes NAME=VALUE"),
    ],
)
def test_the_command_line_refuses_bad_input_in_a_line(tmp_path, options, message):
    result = subprocess.run(
        [sys.executable, "-m", "thesis_rbd.cli", "study", "bouncing_ball", "--out",
         str(tmp_path / "s"), *options],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 1
    assert message in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "s").exists()


def test_a_script_without_a_main_guard_runs_a_study_on_workers(tmp_path):
    """Spawned workers do not run the calling script again (which would start a study in
    each of them)."""
    script = tmp_path / "my_study.py"
    script.write_text(
        "import thesis_rbd as rbd\n"
        "table = rbd.study('bouncing_ball', vary={'dt': [1/60, 1/120]}, seconds=0.2, workers=2)\n"
        "print('runs', len(table))\n",
        encoding="utf-8",
    )
    result = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "runs 2"


@pytest.mark.skipif(sys.platform != "linux", reason="interrupts by signal")
def test_ctrl_c_stops_a_study_in_a_line_and_the_same_command_resumes(tmp_path):
    scene_file = tmp_path / "top.toml"
    scene_file.write_text(TOP.replace("seconds = 2.0", "seconds = 1.0"), encoding="utf-8")
    out = tmp_path / "study"
    command = [
        sys.executable, "-m", "thesis_rbd.cli", "study", str(scene_file), "--out", str(out),
        "--vary", "integrator=euler,rk4", "--vary", "dt=1/2000,1/4000", "--seeds", "2",
        "-j", "2", "--quiet",
    ]  # fmt: skip
    # SIGINT as a terminal delivers it: a process started with it ignored (as a test runner's
    # worker may have left it, after a test of its own Ctrl-C handling) keeps ignoring it
    first = subprocess.Popen(
        command, start_new_session=True, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    deadline = time.monotonic() + 300
    while not list(out.glob("runs/[!.]*.json")) and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(first.pid, signal.SIGINT)  # what Ctrl-C sends: the study and its workers
    _, stderr = first.communicate(timeout=120)
    assert first.returncode == 130, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr
    subprocess.run(command, check=True, timeout=300)
    assert len(list(out.glob("runs/[!.]*.json"))) == 8
    assert len((out / "results.csv").read_text().splitlines()) == 9
