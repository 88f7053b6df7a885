"""The paper's largest load, 20 N on one node, at the built-in models' default (Table 1) resolution.

Linear FEM moves the loaded node by more than the model's own height there, so the hybrid's control nodes drag the
surface through itself; the hybrid must still settle to finite positions.
"""

import numpy as np
import pytest

from tissuesim import HybridMesh, make_solver
from tissuesim.experiments import protocol
from tissuesim.mesh import models


@pytest.fixture(scope="module", params=sorted(models.MODELS))
def hybrid(request):
    return HybridMesh.build(models.model(request.param), fine_volume=True)


@pytest.mark.parametrize("force", [20.0, -20.0], ids=["tension", "pressure"])
def test_hybrid_settles_under_20_newtons(hybrid, force):
    rest = hybrid.surface.vertices
    node = protocol.load_node(rest, hybrid.surface.triangles)
    solver = make_solver("hybrid", hybrid)
    positions = solver.solve_static(node, [0.0, 0.0, force], max_steps=1000)
    assert solver.last_solve.converged
    assert np.all(np.isfinite(positions))
    # The loaded node goes the way of the force, not as far as the fine FEM reference takes it (that reference's
    # point-load spike is mesh-size bound, and the coarse volume does not have it), but a good part of the way:
    # measured 0.25-0.44 of it at 20 N.
    lift = positions[node, 2] - rest[node, 2]
    reference = make_solver("fem", hybrid).solve_static(node, [0.0, 0.0, force])
    reference_lift = reference[node, 2] - rest[node, 2]
    assert np.sign(lift) == np.sign(force)
    assert 0.2 < lift / reference_lift < 1.0
