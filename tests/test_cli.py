"""The thesis-rbd command line, in process (typer's runner) and as a subprocess."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from typer.testing import CliRunner

import thesis_rbd as rbd
from tests.viser_recording import node_values, recording
from thesis_rbd.cli import app

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def message_lines(output: str) -> list[str]:
    """The output's lines but the progress line of a first run's compiling."""
    return [
        line for line in output.strip().splitlines() if not line.startswith("thesis-rbd: compiling")
    ]


def files_in(folder):
    return sorted(p.name for p in Path(folder).iterdir())


def test_scenes_lists_each_builtin_on_one_line():
    result = invoke("scenes")
    assert result.exit_code == 0, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == len(rbd.scenes.names())
    for line, name in zip(lines, rbd.scenes.names(), strict=True):
        assert line.startswith(name + " ")
        assert rbd.scenes.get(name).summary in line
    assert "(default)" in lines[rbd.scenes.names().index("dzhanibekov")]


@pytest.mark.parametrize("name", rbd.scenes.names())
def test_each_builtin_runs_and_writes_its_outputs(tmp_path, name):
    out, page = tmp_path / "run.npz", tmp_path / "play.html"
    result = invoke("run", name, "--seconds", 0.5, "--out", out, "--html", page)
    assert result.exit_code == 0, result.output
    trajectory = rbd.Trajectory.load(out)
    assert trajectory.times[-1] == pytest.approx(0.5, abs=1e-9)
    assert trajectory.metadata["scene"] == name
    assert "window.__VISER_EMBED_DATA__" in page.read_text()
    # the summary: a line per stage that ran, with its share of the time
    assert "integrate" in result.output and "%" in result.output
    assert f"wrote {out}, {page}" in result.output


def test_run_without_a_scene_runs_the_default():
    result = invoke("run")
    assert result.exit_code == 0, result.output
    summary = [line for line in result.output.splitlines() if not line.startswith("thesis-rbd:")]
    assert summary[0].startswith("dzhanibekov: 1 body, 12 s simulated in 2880 steps")


def test_options_override_the_scene(tmp_path):
    out = tmp_path / "run.npz"
    result = invoke(
        "run", "projectile", "-s", 0.3, "--dt", 0.01, "--integrator", "euler",
        "--record-every", 5, "-o", out,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    trajectory = rbd.Trajectory.load(out)
    assert trajectory.metadata["dt"] == 0.01 and trajectory.metadata["integrator"] == "euler"
    assert len(trajectory) == 7  # 30 steps, a frame every 5 and the first


def test_quiet_and_verbose(tmp_path):
    quiet = invoke("run", "thesis_example", "-s", 0.1, "-q")
    assert quiet.exit_code == 0 and quiet.output == ""
    verbose = invoke("run", "thesis_example", "-s", 0.1, "-v")
    assert verbose.exit_code == 0
    assert "body[1] box2: box (12 faces), mass 10 kg, 1 applied force(s)" in verbose.output
    assert "stages: forces -> contacts -> integrate" in verbose.output


def test_a_scene_file_path_runs(tmp_path):
    scene = tmp_path / "drop.toml"
    scene.write_text('[world]\ngravity = [0, 0, -9.81]\n[[body]]\nshape = { type = "box" }\n')
    out = tmp_path / "drop.npz"
    result = invoke("run", scene, "-s", 0.2, "-o", out)
    assert result.exit_code == 0, result.output
    assert rbd.Trajectory.load(out).positions[-1, 0, 2] < 0


BAD_SCENES = {
    "unknown shape": ('[[body]]\nshape = { type = "cone" }\n', "unknown shape 'cone'"),
    "missing mesh file": (
        '[[body]]\nshape = { type = "mesh", path = "gone.stl" }\n',
        "mesh file not found",
    ),
    "negative dt": ("[world]\ndt = -0.5\n", "field 'dt': must be > 0, got -0.5"),
    "wrong type": (
        '[[body]]\nshape = { type = "box" }\nmass = "a lot"\n',
        "field 'mass': must be a number, got 'a lot' (string)",
    ),
    "unknown key": (
        '[[body]]\nshape = { type = "box" }\nvelocity = [1, 0, 0]\n',
        "unknown key 'velocity'",
    ),
    # sizes that would exhaust memory before any message (24 GB, then the kernel's kill)
    "huge icosphere": (
        '[[body]]\nshape = { type = "icosphere", subdivisions = 30 }\n',
        "an icosphere of subdivisions = 30 would have 2.31e+19 faces",
    ),
    "huge cylinder": (
        '[[body]]\nshape = { type = "cylinder", sections = 10000000000 }\n',
        "a cylinder of sections = 10000000000 would have 4e+10 faces",
    ),
    # mass properties that underflow (a ZeroDivisionError, then a singular matrix)
    "tiny box": (
        '[[body]]\nshape = { type = "box", extents = [1e-100, 1e-100, 1e-100] }\n',
        "density gives this body (1.73e-100 m across) mass properties that over- or underflow",
    ),
    "tiny mass": (
        '[[body]]\nshape = { type = "box" }\nmass = 1e-320\n',
        "mass gives this body (1.73 m across) mass properties that over- or underflow",
    ),
}


@pytest.mark.parametrize("fault", sorted(BAD_SCENES))
def test_bad_scene_exits_nonzero_with_one_message_and_no_output(tmp_path, fault):
    text, expected = BAD_SCENES[fault]
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    result = invoke("run", scene, "--out", tmp_path / "run.npz", "--html", tmp_path / "play.html")
    assert result.exit_code == 1
    assert expected in result.output
    (line,) = message_lines(result.output)
    assert line.startswith(f"thesis-rbd: error: {scene}:")
    assert "Traceback" not in result.output
    assert files_in(tmp_path) == ["bad.toml"]


@pytest.mark.parametrize(
    ("arguments", "expected"),
    [
        (["nonesuch"], "no scene file or built-in scene named 'nonesuch'; built-ins: bouncing_"),
        (["missing.toml"], "scene file not found: missing.toml"),
        (["--seconds", "0"], "--seconds must be a positive number"),
        (["--dt", "-1"], "--dt must be a positive number"),
        (["--integrator", "leapfrog"], "--integrator must be one of euler, midpoint, rk4"),
        (["--fps", "0", "--gif", "{tmp}/a.gif"], "--fps must be a positive number"),
        (["--html", "{tmp}/no/such/folder/play.html"], "folder"),
        (["--html", "{tmp}/same", "--out", "{tmp}/same"], "must name different files"),
        # runs whose frames or steps no machine holds, refused before the world is built
        (["--seconds", "1e6"], "takes 12.5 GiB, over the 4 GiB limit: record fewer frames"),
        (["--seconds", "1e300"], "seconds = 1e+300 at dt = 0.00416667 is 2.4e+302 steps"),
        (["--dt", "1e-300"], "is 1.2e+301 steps; a run takes at most 1e+10"),
        (["--memory-limit", "0"], "--memory-limit must be a positive number"),
    ],
)
def test_bad_options_exit_nonzero_without_output(tmp_path, arguments, expected):
    arguments = [a.replace("{tmp}", str(tmp_path)) for a in arguments]
    result = invoke("run", *arguments)
    assert result.exit_code == 1, result.output
    assert expected in result.output
    assert len(message_lines(result.output)) == 1
    assert "Traceback" not in result.output
    assert files_in(tmp_path) == []


def test_contacts_are_recorded_on_request_and_by_the_tori_demo(tmp_path):
    out, page = tmp_path / "run.npz", tmp_path / "play.html"
    asked = invoke("run", "bouncing_ball", "-s", 0.6, "--contacts", "-o", out, "--html", page)
    assert asked.exit_code == 0, asked.output
    trajectory = rbd.Trajectory.load(out)
    assert trajectory.has_contacts and trajectory.contact_counts().max() > 0
    assert f"({len(trajectory)} frames, {len(trajectory.contact_points)} contacts)" in asked.output
    shown = node_values(
        recording(page.read_text()), "SetSceneNodeVisibilityMessage", "/contacts/points", "visible"
    )
    assert any(visible for _, visible in shown)
    plain = invoke("run", "bouncing_ball", "-s", 0.1, "-o", out)
    assert plain.exit_code == 0 and not rbd.Trajectory.load(out).has_contacts
    # the tori demo records its contacts by default; --no-contacts turns that off
    tori = invoke("run", "tori_demo", "-s", 0.1, "-o", out)
    assert tori.exit_code == 0 and rbd.Trajectory.load(out).has_contacts
    quiet = invoke("run", "tori_demo", "-s", 0.1, "--no-contacts", "-o", out)
    assert quiet.exit_code == 0 and not rbd.Trajectory.load(out).has_contacts


def test_the_installed_command_has_no_validate():
    """The campaign lives in a checkout (python -m validation), not in the installed package."""
    result = invoke("validate")
    assert result.exit_code != 0
    assert "No such command" in result.output


def test_outputs_are_all_or_nothing(tmp_path, monkeypatch):
    import thesis_rbd.viz.html

    def fail(*args, **kwargs):
        raise OSError("no space left on device")

    monkeypatch.setattr(thesis_rbd.viz.html, "write_html", fail)
    result = invoke(
        "run", "projectile", "-s", 0.1, "--out", tmp_path / "a.npz", "--html", tmp_path / "a.html"
    )
    assert result.exit_code == 1
    assert "no space left on device" in result.output
    assert files_in(tmp_path) == []  # the trajectory was staged, then removed


def test_gif_and_play(tmp_path):
    pytest.importorskip("matplotlib")
    out, gif = tmp_path / "run.npz", tmp_path / "run.gif"
    result = invoke("run", "thesis_example", "-s", 0.2, "-o", out, "--gif", gif, "--fps", 10)
    assert result.exit_code == 0, result.output
    assert gif.read_bytes()[:6] == b"GIF89a"
    page = tmp_path / "again.html"
    replay = invoke("play", out, "--html", page)
    assert replay.exit_code == 0, replay.output
    assert "<title>thesis_example</title>" in page.read_text()
    assert recording(page.read_text())["durationSeconds"] == pytest.approx(0.2)
    nothing = invoke("play", out)
    assert nothing.exit_code == 1 and "give --html and/or --gif" in nothing.output
    missing = invoke("play", tmp_path / "absent.npz", "--html", tmp_path / "x.html")
    assert missing.exit_code == 1 and "trajectory file not found" in missing.output


def test_gif_without_matplotlib_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    result = invoke("run", "-s", 0.1, "--out", tmp_path / "a.npz", "--gif", tmp_path / "a.gif")
    assert result.exit_code == 1
    assert "needs matplotlib" in result.output and "pip install" in result.output
    assert files_in(tmp_path) == []


def test_html_without_viser_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "viser", None)  # import viser -> ImportError
    result = invoke("run", "-s", 0.1, "--out", tmp_path / "a.npz", "--html", tmp_path / "a.html")
    assert result.exit_code == 1
    assert "need viser" in result.output and "pip install viser" in result.output
    assert files_in(tmp_path) == []
    view = invoke("view", "projectile")
    assert view.exit_code == 1 and "pip install viser" in view.output


def test_view_of_a_scene_without_bodies_says_so(tmp_path):
    empty = tmp_path / "empty.toml"
    empty.write_text("[world]\ndt = 0.01\n")
    result = invoke("view", empty)
    assert result.exit_code == 1
    assert result.output.strip() == (
        "thesis-rbd: error: scene 'empty' has no bodies: there is nothing to view"
    )


def test_the_summary_keeps_compiling_apart_from_the_stages(monkeypatch):
    """A kernel compiled during the run's first step: its time is reported as compiling, and
    the stage table leaves that step out."""
    import numba

    from thesis_rbd.world import World

    assert invoke("run", "projectile", "-s", 0.25, "--dt", 0.01).exit_code == 0  # all loaded
    step = World.step
    compiled = []

    def step_that_compiles_once(world, n=1):
        if not compiled:
            fresh = numba.njit(lambda x: x + 1.0)  # a new function: numba must compile it
            compiled.append(fresh(1.0))
        step(world, n)

    monkeypatch.setattr(World, "step", step_that_compiles_once)
    result = invoke("run", "projectile", "-s", 0.25, "--dt", 0.01)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0].startswith("thesis-rbd: compiling kernels, first run only")
    assert lines[2].startswith("  compiling kernels, first run only: ")
    assert lines[2].endswith("for 1 kernel (numba caches them for later runs)")
    assert lines[3] == "  the stage times below leave out the 1 step during which kernels compiled"
    integrate = next(line for line in lines if line.strip().startswith("integrate"))
    assert integrate.split()[1] == "24"  # 25 steps, the one that compiled left out


def test_warmup_runs_every_part_and_leaves_nothing_to_compile():
    from thesis_rbd._numba.compile_log import CompileLog
    from thesis_rbd._numba.warmup import _collision_queries, warmup_tasks

    result = invoke("warmup")
    assert result.exit_code == 0, result.output
    for task in warmup_tasks():
        assert f"  {task.name}: " in result.output
    assert result.output.splitlines()[-1].startswith("warm-up: ") or "slowest kernels" in (
        result.output
    )
    # what full runs reach beyond the warm-up's first second was compiled too: the tori touch
    # only after 2.3 s, the dominoes topple one another until the end (the startup study checks
    # every scene, each in a fresh process)
    with CompileLog() as log:
        for name in ("tori_demo", "dominoes"):
            scene = rbd.scenes.get(name)
            rbd.simulate(scene.build(), scene.seconds, record_contacts=True)
        _collision_queries()
    assert log.records == []


# ---------------------------------------------------------------------- as a subprocess
def console_script():
    script = Path(sys.executable).parent / "thesis-rbd"
    return str(script) if script.exists() else shutil.which("thesis-rbd")


@pytest.fixture
def thesis_rbd_command():
    script = console_script()
    if script is None:
        pytest.skip("the thesis-rbd console script is not installed (pip install -e .)")
    return script


def run_command(*args, cwd):
    environment = {**os.environ, "COLUMNS": "100"}
    return subprocess.run(
        [*args], cwd=cwd, capture_output=True, text=True, timeout=120, env=environment
    )


def test_console_script_runs_a_builtin_and_lists_scenes(tmp_path, thesis_rbd_command):
    listing = run_command(thesis_rbd_command, "scenes", cwd=tmp_path)
    assert listing.returncode == 0, listing.stderr
    assert "dzhanibekov" in listing.stdout
    result = run_command(
        thesis_rbd_command, "run", "dzhanibekov", "--seconds", "12", "--out", "run.npz",
        "--html", "play.html", cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert files_in(tmp_path) == ["play.html", "run.npz"]


def test_console_script_keeps_the_collector_off_long_lived_objects(tmp_path):
    """The console script is ``cli.main``: the objects alive after its imports are frozen
    out of the cyclic collector, which stays enabled for what the run makes; the
    trajectory it writes loads whole."""
    from importlib.metadata import entry_points

    (entry,) = [e for e in entry_points(group="console_scripts") if e.name == "thesis-rbd"]
    assert entry.value == "thesis_rbd.cli:main"
    probe = textwrap.dedent(
        """
        import gc, sys
        from thesis_rbd import cli
        before = gc.get_freeze_count()
        try:
            cli.main(["run", "dzhanibekov", "--seconds", "0.5", "--out", "run.npz", "--quiet"])
        except SystemExit as finished:
            assert not finished.code, finished.code
        frozen = gc.get_freeze_count()
        print(before, frozen, gc.isenabled())
        """
    )
    result = run_command(sys.executable, "-c", probe, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    before, frozen, enabled = result.stdout.split()
    assert before == "0" and int(frozen) > 10_000 and enabled == "True"
    assert len(rbd.Trajectory.load(tmp_path / "run.npz").times) > 1


def test_console_script_reports_a_bad_scene_in_one_line(tmp_path, thesis_rbd_command):
    (tmp_path / "bad.toml").write_text(
        textwrap.dedent(
            """
            [[body]]
            shape = { type = "box" }
            spin = 3
            """
        )
    )
    result = run_command(
        thesis_rbd_command, "run", "bad.toml", "--out", "run.npz", "--html", "p.html", cwd=tmp_path
    )
    assert result.returncode == 1
    assert result.stdout == ""
    assert result.stderr.strip() == (
        "thesis-rbd: error: bad.toml: body[0] 'body0': unknown key 'spin'; allowed: name, shape, "
        "mass, density, position, orientation, linear_velocity, angular_velocity, restitution, "
        "friction, static, kinematic, collision_group, collision_mask, force, center_of_mass, "
        "inertia, shapes"
    )
    assert files_in(tmp_path) == ["bad.toml"]


def test_outputs_are_regular_files_only(tmp_path):
    """A symbolic link is written through to its file (the link stays); a FIFO, a folder and
    a link to a FIFO are refused before the run, with one line naming them, and nothing in
    the folder changes."""
    target = tmp_path / "target.npz"
    target.write_bytes(b"old")
    (tmp_path / "link.npz").symlink_to(target)
    result = invoke("run", "projectile", "--seconds", 0.05, "--out", tmp_path / "link.npz")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "link.npz").is_symlink()
    assert len(rbd.Trajectory.load(target).times) > 1
    assert files_in(tmp_path) == ["link.npz", "target.npz"]

    os.mkfifo(tmp_path / "pipe.npz")
    (tmp_path / "folder.npz").mkdir()
    (tmp_path / "to_pipe.npz").symlink_to(tmp_path / "pipe.npz")
    before = _unchanged(tmp_path)
    for name, kind in (("pipe.npz", "a FIFO"), ("folder.npz", "a folder"),
                       ("to_pipe.npz", "a FIFO")):  # fmt: skip
        result = invoke("run", "projectile", "--seconds", 0.05, "--out", tmp_path / name)
        assert result.exit_code == 1
        (line,) = result.output.strip().splitlines()
        assert f"{tmp_path / name}: it is {kind}" in line
    assert _unchanged(tmp_path) == before


def _unchanged(folder):
    """Each entry's kind, identity, size and modification and change times: what a write
    would alter (access times are left out: reading a link's target marks it read, and
    relatime does so once the clock has passed the link's creation second)."""
    return {
        p.name: (s.st_mode, s.st_ino, s.st_size, s.st_mtime_ns, s.st_ctime_ns)
        for p in folder.iterdir()
        for s in [p.lstat()]
    }


def test_sigterm_stops_a_run_and_leaves_no_partial_file(tmp_path, thesis_rbd_command):
    """SIGTERM mid-run ends the run as Ctrl-C would: one line, exit status 143 (128 +
    SIGTERM, as a shell reports a killed process), and no output or partial file. The signal
    is sent once the run has started (``--verbose`` prints the stages first)."""
    import signal
    import time

    process = subprocess.Popen(
        [thesis_rbd_command, "run", "rain", "--seconds", "600", "--out", "run.npz",
         "--html", "play.html", "--verbose"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    for line in process.stdout:
        if line.strip().startswith("stages:"):
            break
    time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 143
    assert stderr.strip().splitlines()[-1] == "thesis-rbd: stopped by SIGTERM; no output written"
    assert files_in(tmp_path) == []


def test_sigterm_while_an_output_is_written_removes_the_partial_file(tmp_path):
    """The signal raised inside an atomic write (as the handler raises it wherever the main
    thread is) removes the partial file and leaves the destination as it was."""
    import signal

    from thesis_rbd._atomic import atomic_path
    from thesis_rbd.cli import Stopped, _signals_stop_the_run

    destination = tmp_path / "run.npz"
    destination.write_bytes(b"kept")
    with pytest.raises(Stopped), _signals_stop_the_run(), atomic_path(destination) as partial:
        partial.write_bytes(b"half")
        os.kill(os.getpid(), signal.SIGTERM)
    assert files_in(tmp_path) == ["run.npz"]
    assert destination.read_bytes() == b"kept"
