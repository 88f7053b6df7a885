"""A straight stroke leaves a straight wound: on every built-in model, at 0°, 30° and 45°, the lips (the new
boundary's vertices, at rest) lie within 0.05 (RMS) and 0.10 (largest) of a mean edge length of the rectangle the
blade swept, no triangle falls below quality 0.1, and the wound reaches along the stroke. Before the vertices near
the cut were moved onto it: RMS 0.07–0.16, largest 0.14–0.42 (benchmarks/wound_straightness.py)."""

import numpy as np
import pytest

import tissuesim
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.experiments.wound import lip_deviation, scripted_incision
from tissuesim.mesh import models


@pytest.fixture(scope="module")
def built():
    return {name: tissuesim.HybridMesh.build(models.model(name), fine_volume=False) for name in models.MODELS}


@pytest.mark.parametrize("angle", [0.0, 30.0, 45.0])
@pytest.mark.parametrize("name", sorted(models.MODELS))
def test_a_straight_stroke_leaves_a_straight_wound(built, name, angle):
    hybrid = built[name]
    surface = hybrid.surface
    edges = surface.edges
    edge = float(np.linalg.norm(surface.vertices[edges[:, 0]] - surface.vertices[edges[:, 1]], axis=1).mean())
    solver = tissuesim.make_solver("hybrid", hybrid)
    line = scripted_incision(solver, angle=angle)["line"]
    h = solver.hybrid
    result = lip_deviation(h.surface.vertices, h.surface.triangles, line, edge=edge)
    assert result["rms"] <= 0.05 and result["max"] <= 0.10, result
    assert result["quality"] >= 0.1, result
    assert result["reach"] >= 0.9, result                # the wound runs the stroke's length (30 mm)
    assert check_cut_invariants(h.surface.vertices, h.surface.triangles) == []
