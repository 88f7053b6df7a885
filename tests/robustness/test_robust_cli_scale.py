"""--scale: a factor that makes a model's size absurd is refused naming --scale (not as degenerate triangles), and
the compiled closest-point search refuses coordinates whose distances overflow instead of crashing."""

import subprocess
import sys
from pathlib import Path

import pytest

import tissuesim
from tissuesim import write_surface
from tissuesim.cli import main
from tissuesim.mesh import models

SRC = Path(tissuesim.__file__).resolve().parents[1]      # the package under test, for the child process


@pytest.mark.parametrize("command", [["build", "cube", "--no-fine-volume"], ["incise", "cube", "--methods", "pbd"]])
@pytest.mark.parametrize("scale", ["1e300", "1e200", "1e-200", "1e-6"])
def test_an_absurd_scale_of_a_built_in_is_refused_naming_the_option(command, scale, tmp_path, capsys):
    code = main([*command, "--resolution", "300", "--scale", scale, "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1].startswith(f"tissuesim {command[0]}: error: ") and "Traceback" not in err
    assert "--scale" in err[-1] and "between 1 µm and 100 m" in err[-1] and "--repair" not in err[-1]
    assert list(tmp_path.iterdir()) == []


def test_a_file_scaled_out_of_range_is_refused_naming_the_scale(tmp_path, capsys):
    path = tmp_path / "victim.obj"
    write_surface(path, models.cube(resolution=300))
    assert main(["build", str(path), "--scale", "1e300", "--no-fine-volume"]) == 1
    err = capsys.readouterr().err
    assert "after scale 1e+300" in err and "self-intersect" not in err and "degenerate" not in err
    assert main(["build", str(path), "--scale", "0.01", "--no-fine-volume"]) == 0   # 1.4 mm across: accepted


CRASH = """
from tissuesim.errors import MeshError
from tissuesim.mesh import models
from tissuesim.mesh.maps import closest_on_surface
s = models.cube(resolution=300)
huge = s.with_vertices(s.vertices * 1e300)
try:
    closest_on_surface(huge, 0.5 * huge.vertices[:2])
except MeshError as error:
    print("refused:", error)
"""


def test_the_closest_point_search_refuses_overflowing_coordinates_instead_of_crashing():
    done = subprocess.run([sys.executable, "-c", CRASH], capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(SRC), "PATH": ""})
    assert done.returncode == 0, (done.returncode, done.stderr[-500:])      # -11 was SIGSEGV
    assert done.stdout.startswith("refused: closest-point search: coordinates too large")
