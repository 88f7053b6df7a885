"""`tissuesim build` end to end: a model name, a shared file, a bundle, and a refused bad mesh."""

import numpy as np

from tissuesim.cli import main
from tissuesim.mesh.hybrid import HybridMesh

HEADER = "| model | M_S #node | M_S #elem | M_S size (kB) | M_V #node"


def test_build_model_prints_a_table1_row_and_saves_a_bundle(tmp_path, capsys):
    out = tmp_path / "cube.npz"
    assert main(["build", "cube", "--resolution", "300", "--output", str(out)]) == 0
    stdout, stderr = capsys.readouterr()
    lines = stdout.strip().splitlines()
    assert lines[0].startswith(HEADER) and len(lines) == 3
    cells = [c.strip() for c in lines[2].strip("|").split("|")]
    hybrid = HybridMesh.load(out)
    assert cells[0] == "cube"
    assert int(cells[1]) == hybrid.surface.vertex_count
    assert int(cells[4]) == hybrid.volume.node_count and int(cells[5]) == hybrid.volume.element_count
    assert int(cells[7]) == hybrid.fine_volume.node_count
    assert "simplify" in stderr and "saved" in stderr        # progress goes to stderr, not into the table


def test_build_shared_file_with_scale_and_target(meshes_dir, capsys):
    path = meshes_dir / "sofa" / "liver2.obj"
    assert main(["build", str(path), "--scale", "0.01", "--target-vertices", "300", "--no-fine-volume"]) == 0
    row = capsys.readouterr().out.strip().splitlines()[2]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[0] == "liver2" and cells[1] == "1170" and cells[7:] == ["-", "-", "-"]
    assert int(cells[4]) >= 300


def test_self_intersecting_mesh_gives_one_line_and_exit_1(meshes_dir, capsys):
    code = main(["build", str(meshes_dir / "sofa" / "liver-smooth.obj"), "--scale", "0.01"])
    stdout, stderr = capsys.readouterr()
    assert code == 1 and stdout == ""
    lines = [line for line in stderr.splitlines() if line.startswith("tissuesim build: error:")]
    assert len(lines) == 1 and "self-intersecting" in lines[0] and "Traceback" not in stderr


def test_missing_file_and_unknown_model_fail_cleanly(tmp_path, capsys):
    assert main(["build", str(tmp_path / "nothing.obj")]) == 1
    assert main(["build", "kidney"]) == 1
    stderr = capsys.readouterr().err
    assert stderr.count("tissuesim build: error:") == 2 and "Traceback" not in stderr


def test_an_unknown_model_name_lists_the_built_in_models(capsys):
    from tissuesim.cli import main

    assert main(["build", "kidney"]) == 1
    assert "neither a built-in model (cube, sphere, liver, steak) nor an existing surface file" in (
        capsys.readouterr().err)
