"""Every script in examples/ runs to the end (briefly) as a user would run it."""

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).parents[1] / "examples").glob("*.py"))


def test_examples_are_found():
    names = {path.stem for path in EXAMPLES}
    assert {"thesis_example", "dzhanibekov", "custom_mesh", "scene_file", "bouncing_ball"} <= names


@pytest.mark.parametrize("example", EXAMPLES, ids=[path.stem for path in EXAMPLES])
def test_example_runs(example, tmp_path):
    # examples take [SECONDS] and, if they write files, [FOLDER];
    # 1.5 s covers the thesis example's 1 s push. The limit allows a first run's compile (a
    # contact scene on an empty kernel cache takes about two minutes on two cores): which
    # kernels this worker's earlier tests left in its cache depends on the test order.
    result = subprocess.run(
        [sys.executable, str(example), "1.5", str(tmp_path)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, f"{example.name} failed:\n{result.stdout}\n{result.stderr}"
    assert result.stdout.strip(), f"{example.name} printed nothing"


def test_guide_code_blocks_run_in_order(tmp_path, monkeypatch):
    """docs/guide.md: its Python blocks run as one session, against its own TOML example."""
    import re

    import trimesh

    guide = (Path(__file__).parents[1] / "docs" / "guide.md").read_text()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box().export(tmp_path / "part.stl")
    floor = trimesh.Trimesh([[-5, -5, 0], [5, -5, 0], [0, 5, 0]], [[0, 1, 2]])
    floor.export(tmp_path / "meshes" / "floor.obj")
    (tmp_path / "scene.toml").write_text(re.findall(r"```toml\n(.*?)```", guide, re.S)[0])
    blocks = re.findall(r"```python\n(.*?)```", guide, re.S)
    assert len(blocks) >= 6
    namespace = {}
    for number, block in enumerate(blocks):
        exec(compile(block, f"guide.md python block {number}", "exec"), namespace)
    assert namespace["report"].colliding
    assert namespace["sap"].pairs.tolist() == [[0, 1]]
    assert (tmp_path / "run.npz").is_file()
