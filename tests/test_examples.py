"""Every script in examples/ runs to the end (briefly) as a user would run it."""

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).parents[1] / "examples").glob("*.py"))


def test_examples_are_found():
    names = {path.stem for path in EXAMPLES}
    assert {"thesis_example", "dzhanibekov", "custom_mesh", "scene_file"} <= names


@pytest.mark.parametrize("example", EXAMPLES, ids=[path.stem for path in EXAMPLES])
def test_example_runs(example, tmp_path):
    # examples take [SECONDS] and, if they write files, [FOLDER]; 1.5 s covers the thesis example's 1 s push
    result = subprocess.run(
        [sys.executable, str(example), "1.5", str(tmp_path)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, f"{example.name} failed:\n{result.stdout}\n{result.stderr}"
    assert result.stdout.strip(), f"{example.name} printed nothing"
