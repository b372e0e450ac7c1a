"""Scene files with extreme values, through the installed command in a subprocess.

A generated set (hypothesis) of scenes whose fields hold extreme numbers, huge integers and
wrong types, each run by ``thesis-rbd run`` in a subprocess under a 4 GiB address-space limit:
every one ends within seconds either in a run (exit 0) or in exit 1 with one line naming the
scene file, and leaves no file behind.
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
        cwd=folder, capture_output=True, text=True, timeout=120, preexec_fn=_limit_memory,
    )  # fmt: skip
    assert "Traceback" not in result.stderr, text
    if result.returncode == 0:
        assert sorted(p.name for p in folder.iterdir()) == ["run.npz", "s.toml"]
        return
    assert result.returncode == 1, (text, result.stderr)
    (line,) = message_lines(result.stderr)
    assert line.startswith("thesis-rbd: error: s.toml: "), (text, line)
    assert sorted(p.name for p in folder.iterdir()) == ["s.toml"]
