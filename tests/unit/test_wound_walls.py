"""The wound's walls (cutting/walls.py): from each lip down to the blade's depth, meeting at the wound's floor,
facing into the wound."""

import numpy as np
import pytest

import tissuesim
from tissuesim.cutting.walls import wound_walls
from tissuesim.experiments.wound import open_wound, scripted_incision
from tissuesim.mesh import models
from tissuesim.mesh.coincident import coincident_pairs

DEPTH = 0.01


@pytest.fixture(scope="module")
def wound():
    """The cube's scripted incision (a 30 mm stroke along x at y = 1.1 mm), closed and pulled open (+y)."""
    solver = tissuesim.make_solver("hybrid", tissuesim.HybridMesh.build(models.cube(), fine_volume=False))
    line = scripted_incision(solver)["line"]
    closed = solver.positions.copy()
    open_wound(solver, line, force=0.3)
    return solver, closed, line


def test_an_uncut_surface_has_no_walls():
    surface = models.cube(resolution=100)
    points, faces = wound_walls(surface.vertices, surface.triangles, np.zeros((0, 2), dtype=np.int64), DEPTH)
    assert points.shape == (0, 3) and faces.shape == (0, 3) and faces.dtype == np.int32


def test_the_walls_of_a_closed_wound_hang_to_the_blade_depth_under_the_lips(wound):
    solver, closed, _ = wound
    pairs = coincident_pairs(solver.rest_positions)
    points, faces = wound_walls(closed, solver.hybrid.surface.triangles, pairs, DEPTH)
    assert faces.dtype == np.int32 and points.dtype == np.float64 and faces.size
    top = points[:, 2].max()
    assert np.allclose(top, closed[pairs.ravel(), 2], rtol=0.0, atol=1e-12)         # the lips, on the flat top
    lowest = points[faces.ravel(), 2].min()
    assert lowest == pytest.approx(top - DEPTH, abs=1e-12)
    # every wall point is a lip or lies straight under one at the blade's depth (the top's normal is z)
    below = points[:, 2] < top - 1e-9
    assert np.allclose(points[below, 2], top - DEPTH, rtol=0.0, atol=1e-12)
    lips = points[~below]
    assert np.min(np.linalg.norm(points[below, None, :2] - lips[None, :, :2], axis=2), axis=1).max() < 1e-12


def test_the_walls_of_an_opened_wound_meet_at_its_floor_continue_the_surface_into_it(wound):
    solver, _, _ = wound
    pairs = coincident_pairs(solver.rest_positions)
    x = solver.positions
    points, faces = wound_walls(x, solver.hybrid.surface.triangles, pairs, DEPTH)
    p = points[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.linalg.norm(normal, axis=1) > 0.0)
    # the two lips of a pair share one bottom corner: a face's lowest point is one of as many as there are pairs
    lowest = np.unique(faces[np.arange(len(faces)), np.argmin(p[:, :, 2], axis=1)])
    assert len(lowest) == len(np.unique(pairs[:, 0]))
    # each lip edge a → b (in its triangle's winding) is a wall face's edge b → a: the walls continue the surface's
    # orientation, so they face out of the tissue, into the wound
    triangles = np.asarray(solver.hybrid.surface.triangles, dtype=np.int64)
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    codes = set((directed[:, 0] * len(x) + directed[:, 1]).tolist())
    border = [(a, b) for a, b in directed.tolist() if b * len(x) + a not in codes]
    at = {tuple(x[v]): v for v in np.unique(border)}
    ids = np.array([[at.get(tuple(q), -1) for q in tri] for tri in p])
    walls = {(u, v) for row in ids.tolist() for u, v in zip(row, row[1:] + row[:1]) if u >= 0 and v >= 0}
    assert all((b, a) in walls for a, b in border)
