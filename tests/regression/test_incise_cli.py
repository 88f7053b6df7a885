"""``tissuesim incise``: the Fig 16 experiment writes cut surfaces, the table and the checks; the wound opens on the
position-based methods and stays closed on the embedded one; the fem reference is listed as refusing."""

import json

import meshio

from tissuesim.cli import main
from tissuesim.solvers import method_names


def test_incise_writes_surfaces_table_and_checks(tmp_path, capsys):
    out = tmp_path / "cut"
    cut = [m for m in method_names(cuts=True) if m != "hybrid"]       # the hybrid's cut: its own tests
    refused = method_names(cuts=False)
    code = main(["incise", "cube", "--resolution", "600", "--methods", *cut, *refused, "--output", str(out)])
    assert code == 0
    rows = {r["method"]: r for r in json.loads((out / "incision.json").read_text())}
    assert all("cannot be cut" in rows[method]["refused"] for method in refused)
    for method in cut:
        assert rows[method]["invariants"] == []
        assert rows[method]["vertices_added"] > 0
        vtu = meshio.read(out / f"cube_{method}.vtu")
        assert vtu.cells_dict["line"].shape[0] > 0            # the cut's edges, marked
        assert (out / f"cube_{method}.obj").stat().st_size > 0
    assert rows["pbd"]["gap_mm"] > 0.01
    # Both lips of the embedded surface interpolate the same tet with the same weights: round-off (~1e-14 mm) at
    # most, where the pbd wound opens by more than 0.01 mm.
    assert 0.0 <= rows["embedded"]["gap_mm"] <= 1e-9
    assert "| cube | pbd |" in (out / "incision.md").read_text()


def test_incise_unknown_method_is_one_line(tmp_path, capsys):
    assert main(["incise", "cube", "--methods", "scissors", "--output", str(tmp_path / "x")]) == 1
    err = capsys.readouterr().err
    assert "unknown method 'scissors'" in err and "Traceback" not in err


def test_incise_with_prestrain_gapes_without_force(tmp_path):
    out = tmp_path / "cut"
    assert main(["incise", "cube", "--resolution", "600", "--methods", "pbd", "embedded", "--prestrain", "0.05",
                 "--output", str(out)]) == 0
    rows = {r["method"]: r for r in json.loads((out / "incision.json").read_text())}
    median, largest = rows["pbd"]["unloaded_gap_mm"]
    assert 0.1 < median <= largest
    assert rows["embedded"]["unloaded_gap_mm"] is None and rows["embedded"]["prestrain"] == 0.0  # exact: the option
    assert "gap, no force" in (out / "incision.md").read_text()
    assert rows["pbd"]["beyond_linear"] == [] and "| small strain |" in (out / "incision.md").read_text()


def test_incise_bad_prestrain_is_one_line(tmp_path, capsys):
    assert main(["incise", "cube", "--prestrain", "0.9", "--output", str(tmp_path / "x")]) == 1
    err = capsys.readouterr().err
    assert "prestrain must lie in [0, 0.3]" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_incise_flags_answers_beyond_small_strain(tmp_path):
    # a coarse sphere pulled by 2 N (the default pull, sized to the model, stays in small strain)
    out = tmp_path / "cut"
    assert main(["incise", "sphere", "--resolution", "300", "--methods", "pbd", "--prestrain", "0.05",
                 "--pull", "2", "--output", str(out)]) == 0
    row = json.loads((out / "incision.json").read_text())[0]
    assert row["beyond_linear"] and "linear elasticity is not valid" in row["beyond_linear"][0]
    assert "**beyond small strain**" in (out / "incision.md").read_text()
