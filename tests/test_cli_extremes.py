"""Scene files with extreme values, through the installed command in a subprocess.

A generated set (hypothesis) of scenes whose fields hold extreme numbers, huge integers and
wrong types, each run by ``thesis-rbd run`` in a subprocess under a 4 GiB address-space limit:
every one ends either in a run (exit 0) or in exit 1 with one line naming the scene file, and
leaves no file behind. (Refusals take about a second; the generous timeouts are for the first
valid scene of a fresh checkout, which compiles its kernels.)
"""

from __future__ import annotations

import resource
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_cli import console_script, message_lines

EXTREMES = st.sampled_from(
    ["0", "-1", "1e-320", "1e-300", "1e-100", "1e100", "1e300", "inf", "nan", "-inf",
     "10000000000", "99999999999999999999", "true", '"x"', "[]", "[1, 2]", "{}"]
)  # fmt: skip
VECTORS = st.builds(lambda a, b, c: f"[{a}, {b}, {c}]", EXTREMES, EXTREMES, EXTREMES)
BODY_FIELDS = {
    "mass": EXTREMES,
    "density": EXTREMES,
    "position": VECTORS,
    "orientation": st.builds(lambda v, w: v[:-1] + f", {w}]", VECTORS, EXTREMES),
    "linear_velocity": VECTORS,
    "angular_velocity": VECTORS,
    "restitution": EXTREMES,
    "friction": EXTREMES,
}
SHAPES = st.one_of(
    st.builds(lambda v: f'{{ type = "box", extents = {v} }}', VECTORS),
    st.builds(
        lambda r, s: f'{{ type = "icosphere", radius = {r}, subdivisions = {s} }}',
        EXTREMES,
        EXTREMES,
    ),
    st.builds(lambda s: f'{{ type = "cylinder", sections = {s} }}', EXTREMES),
    st.builds(
        lambda a, b: f'{{ type = "torus", major_sections = {a}, minor_sections = {b} }}',
        EXTREMES,
        EXTREMES,
    ),
)
WORLD_FIELDS = {"dt": EXTREMES, "gravity": VECTORS}


@st.composite
def scenes(draw) -> str:
    lines = []
    if draw(st.booleans()):
        key = draw(st.sampled_from(sorted(WORLD_FIELDS)))
        lines += ["[world]", f"{key} = {draw(WORLD_FIELDS[key])}"]
    lines += ["[[body]]", f"shape = {draw(SHAPES)}"]
    for key in draw(st.lists(st.sampled_from(sorted(BODY_FIELDS)), max_size=2, unique=True)):
        lines.append(f"{key} = {draw(BODY_FIELDS[key])}")
    return "\n".join(lines) + "\n"


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (4 * 2**30, 4 * 2**30))


@pytest.mark.skipif(sys.platform == "win32", reason="address-space limits are POSIX")
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(text=scenes())
def test_extreme_scene_values_end_in_a_run_or_one_line(tmp_path_factory, text):
    thesis_rbd_command = console_script()
    if thesis_rbd_command is None:
        pytest.skip("the thesis-rbd console script is not installed (pip install -e .)")
    folder = tmp_path_factory.mktemp("scene")
    (folder / "s.toml").write_text(text)
    result = subprocess.run(
        [thesis_rbd_command, "run", "s.toml", "--seconds", "0.01", "--out", "run.npz",
         "--quiet"],
        cwd=folder, capture_output=True, text=True, timeout=900, preexec_fn=_limit_memory,
    )  # fmt: skip
    assert "Traceback" not in result.stderr, text
    if result.returncode == 0:
        assert sorted(p.name for p in folder.iterdir()) == ["run.npz", "s.toml"]
        return
    assert result.returncode == 1, (text, result.stderr)
    (line,) = message_lines(result.stderr)
    assert line.startswith("thesis-rbd: error: s.toml: "), (text, line)
    assert sorted(p.name for p in folder.iterdir()) == ["s.toml"]


BOX = '[[body]]\nshape = { type = "box" }\n'
# The cases issue 39 found, each once a traceback, a kill by the kernel or silent garbage.
CASES = {
    "icosphere of 30 subdivisions": (
        '[[body]]\nshape = { type = "icosphere", subdivisions = 30 }\n',
        [],
        "2.31e+19 faces",
    ),
    "cylinder of 1e10 sections": (
        '[[body]]\nshape = { type = "cylinder", sections = 10000000000 }\n',
        [],
        "4e+10 faces",
    ),
    "a million seconds recorded": (BOX, ["--seconds", "1e6"], "--record-every"),
    "1e300 seconds": (BOX, ["--seconds", "1e300"], "seconds = 1e+300"),
    "dt of 1e-300": ("[world]\ndt = 1e-300\n" + BOX, [], "dt = 1e-300 is"),
    "mass of 1e-320": (BOX + "mass = 1e-320\n", [], "mass gives this body"),
    "a 1e-100 m box": (
        '[[body]]\nshape = { type = "box", extents = [1e-100, 1e-100, 1e-100] }\n',
        [],
        "density gives this body (1.73e-100 m across)",
    ),
    "a truncated scene": ("[[body]]\nshape = { type = ", [], "s.toml"),
}


@pytest.mark.skipif(sys.platform == "win32", reason="address-space limits are POSIX")
@pytest.mark.parametrize("case", sorted(CASES))
def test_each_found_case_ends_in_one_line_under_a_memory_limit(tmp_path, case):
    text, arguments, expected = CASES[case]
    thesis_rbd_command = console_script()
    if thesis_rbd_command is None:
        pytest.skip("the thesis-rbd console script is not installed (pip install -e .)")
    (tmp_path / "s.toml").write_text(text)
    (tmp_path / "kept.npz").write_bytes(b"an earlier run")
    result = subprocess.run(
        [thesis_rbd_command, "run", "s.toml", "--out", "kept.npz", "--html", "p.html",
         "--quiet", *arguments],
        cwd=tmp_path, capture_output=True, text=True, timeout=900, preexec_fn=_limit_memory,
    )  # fmt: skip
    assert result.returncode == 1, result.stderr
    (line,) = message_lines(result.stderr)
    assert line.startswith("thesis-rbd: error: ") and expected in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.npz", "s.toml"]
    assert (tmp_path / "kept.npz").read_bytes() == b"an earlier run"


def test_play_on_malformed_run_files_ends_in_one_line(tmp_path):
    """Files with the format tag but fields of the wrong type once gave 42-line TypeErrors."""
    import numpy as np

    import thesis_rbd as rbd

    world = rbd.World()
    world.add_body(rbd.shapes.box())
    path = tmp_path / "run.npz"
    rbd.simulate(world, 0.05).save(path)
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    for field, value in (("metadata", np.array("[1, 2]")), ("names", np.array("body0")),
                         ("vertex_offsets", np.array([0.0, 8.0]))):  # fmt: skip
        np.savez(path, **{**arrays, field: value})
        thesis_rbd_command = console_script()
        if thesis_rbd_command is None:
            pytest.skip("the thesis-rbd console script is not installed (pip install -e .)")
        result = subprocess.run(
            [thesis_rbd_command, "play", "run.npz", "--html", "p.html"],
            cwd=tmp_path, capture_output=True, text=True, timeout=900,
            preexec_fn=_limit_memory,
        )  # fmt: skip
        assert result.returncode == 1
        (line,) = message_lines(result.stderr)
        assert line.startswith(f"thesis-rbd: error: run.npz: field {field!r}") or (
            field == "metadata" and "metadata must be a JSON object" in line
        ), line
        assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]
