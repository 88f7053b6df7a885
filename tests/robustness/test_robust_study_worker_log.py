"""A case that a Dask worker refuses is told once, in its row and the closing line, never as the worker's own
"Compute Failed" log with a traceback."""

from tissuesim.cli import main

STUDY = """
[[models]]
name = "cube"
resolution = 60
[[methods]]
name = "hybrid"
[loads]
kind = "probe"
radius = 1e-9
directions = [[0.0, 0.0, -1.0]]
depths = [0.001]
"""


def test_a_refused_case_on_a_worker_prints_no_traceback(tmp_path, capfd):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)       # a press 1 mm deep with a 1 nm probe: its core inside the body, refused
    status = main(["study", str(study), "--output", str(tmp_path / "out"), "--workers", "1", "--quiet"])
    out, err = capfd.readouterr()
    assert status == 1
    assert "0 cases done, 1 failed" in out
    assert "Traceback" not in err and "Compute Failed" not in err, err
