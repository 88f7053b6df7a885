"""Picking up the scalpel loads the cut's compiled kernels with a cut of its own, and touches nothing of the
solver's."""

import numpy as np

import tissuesim
from tissuesim.cutting import warm
from tissuesim.mesh import models


def test_picking_up_the_scalpel_loads_the_cut_kernels_and_leaves_the_solver_as_it_was(monkeypatch):
    monkeypatch.setattr(warm, "_LOADED", False)
    solver = tissuesim.make_solver("pbd", tissuesim.HybridMesh.build(models.cube(200), fine_volume=False))
    solver.step()
    positions, triangles = solver.positions.copy(), np.array(solver.hybrid.surface.triangles)
    cuts = []
    plan = warm.CutSurface.plan
    monkeypatch.setattr(warm.CutSurface, "plan", lambda self, *a, **k: cuts.append(1) or plan(self, *a, **k))
    tissuesim.Scalpel(solver, depth=0.01).prepare()
    tissuesim.Scalpel(solver, depth=0.01).prepare()        # once per process
    assert warm._LOADED and cuts == [1]
    np.testing.assert_array_equal(solver.positions, positions)
    np.testing.assert_array_equal(solver.hybrid.surface.triangles, triangles)
