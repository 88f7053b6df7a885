"""Without polyscope or OpenGL: one line, and `render --if-available` lets `make run` go on (exit 0)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import tissuesim

# the child imports this very tissuesim, wherever the test runs from
ENV = {**os.environ, "PYTHONPATH": str(Path(tissuesim.__file__).resolve().parents[1])}

HIDE_POLYSCOPE = "import sys; sys.modules['polyscope'] = None; from tissuesim.cli import main; sys.exit(main({}))"


def run_cli(args, tmp_path):
    code = HIDE_POLYSCOPE.format(repr(args))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=ENV)


@pytest.mark.parametrize("flag, status", [(["--if-available"], 0), ([], 1)])
def test_render_without_opengl_says_so_in_one_line(tmp_path, flag, status):
    result = run_cli(["render", "cube", "--output", str(tmp_path / "out"), *flag], tmp_path)
    assert result.returncode == status
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "pip install polyscope" in lines[0] and "Traceback" not in result.stderr
    assert not (tmp_path / "out").exists()  # nothing half-written


def test_view_without_polyscope_names_what_to_install(tmp_path):
    result = run_cli(["view", "cube"], tmp_path)
    assert result.returncode == 1 and "pip install polyscope" in result.stderr and "Traceback" not in result.stderr
