"""The tutorial notebook runs as a reader runs it, top to bottom in a fresh kernel of this interpreter, and leaves
the ParaView series it promises: the drag's force is eq 24's, and the last frame holds the cut."""

import json
import sys
from pathlib import Path

import nbclient
import nbformat
import numpy as np
import pytest

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "tutorial.ipynb"


def test_the_notebook_is_stored_without_outputs():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code and all(not cell.outputs and cell.execution_count is None for cell in code)


def test_the_tutorial_runs_and_records_the_drag_and_the_cut(tmp_path, monkeypatch):
    from tissuesim.recording import read_recording

    # the notebook names the kernel python3: make that name start this interpreter (a python3 kernel of another
    # environment installed for the user would not import this tissuesim)
    spec = tmp_path / "jupyter" / "kernels" / "python3"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3", "language": "python"}))
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    monkeypatch.setenv("MPLBACKEND", "agg")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(notebook, kernel_name="python3", timeout=120,
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()                                  # raises CellExecutionError naming the cell that failed
    images = [output for cell in notebook.cells if cell.cell_type == "code" for output in cell.outputs
              if "image/png" in output.get("data", {})]
    assert len(images) == 1                           # the displacement plot
    printed = "".join(output.get("text", "") for cell in notebook.cells if cell.cell_type == "code"
                      for output in cell.outputs)
    assert "vertices added by the cut" in printed and "parsing switches" not in printed   # no TetGen chatter
    frames = read_recording(tmp_path / "tutorial.pvd")
    assert len(frames) >= 30                          # every drag frame moved the liver
    grabbed = np.flatnonzero(np.any(frames[-1].force, axis=1))
    assert len(grabbed) == 1
    assert frames[-1].force[grabbed[0]] == pytest.approx([50.0 * 0.01, 0.0, 0.0], abs=1e-12)  # eq 24: k × 10 mm
    assert frames[-1].displacement[grabbed[0], 0] > 0.001                                  # it follows the pull
    assert len(frames[-1].cut_edges) > 0 and len(frames[-1].positions) > len(frames[0].positions)  # and the cut
