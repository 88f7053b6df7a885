"""``tissuesim incise`` checks that every piece of the cut surface is held, not only the surface's shape."""

import json

import numpy as np

import tissuesim.cutting.invariants as invariants
from tissuesim.cli import main


def test_incise_reports_a_piece_that_no_held_node_holds(tmp_path, monkeypatch, capsys):
    """Had the cut freed a piece, the table must say so: here the held set is emptied, so every piece is loose."""
    checked = invariants.check_cut_invariants

    def nothing_held(*args, anchored=None, **kwargs):
        assert anchored is not None and len(anchored) > 0       # incise passes the solver's fixed and control nodes
        return checked(*args, anchored=np.zeros(0, dtype=np.int64), **kwargs)

    monkeypatch.setattr(invariants, "check_cut_invariants", nothing_held)
    out = tmp_path / "cut"
    assert main(["incise", "cube", "--resolution", "600", "--methods", "pbd", "--output", str(out)]) == 1
    assert "hold no anchored" in capsys.readouterr().err
    row = json.loads((out / "incision.json").read_text())[0]
    assert any("piece" in problem for problem in row["invariants"]), row["invariants"]
