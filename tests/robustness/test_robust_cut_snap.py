"""Sweep items F4, F6, F7: snap = 0 (and any snap too small to merge the cut's points) is refused up front, naming
the option and its range, so it never reaches the cut; the smallest snap accepted keeps the surface sound."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, SolverError, make_solver
from tissuesim.cutting import Sweep, cut_surface
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.cutting.sweep import MIN_SNAP
from tissuesim.mesh import models
from tissuesim.solvers import method_names

#: the methods the scalpel cuts
CUTTING = method_names(cuts=True)


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(), fine_volume=False)


@pytest.mark.parametrize("snap", [0, 0.0, 0.01, 0.05, 0.1])
def test_a_snap_too_small_to_merge_points_is_refused_naming_the_option(cube, snap):
    solver = make_solver("hybrid", cube)
    with pytest.raises(SolverError, match=r"snap option .*\[0\.15, 1/3\), got .*slivers .*zero-area triangles\); pass a snap"):
        Scalpel(solver, depth=0.02670576901311135, snap=snap)
    s = cube.surface
    sweep = Sweep.between([0.0, 0.0011, 0.081], [0.01, 0.0011, 0.081], [0.0, 0.0, -0.004])
    with pytest.raises(SolverError, match="snap option"):
        cut_surface(s.vertices, s.vertices, np.zeros_like(s.vertices), s.triangles, sweep, snap=snap)


@pytest.mark.parametrize("method", CUTTING)
def test_the_smallest_snap_cuts_the_sweeps_stroke_soundly(cube, method):
    """The sweep's F4 stroke (three short moves near a bottom edge of the cube), at the smallest snap accepted:
    every invariant holds, and the solver steps under a load."""
    solver = make_solver(method, cube)
    scalpel = Scalpel(solver, depth=0.02670576901311135, snap=MIN_SNAP)
    scalpel.press((0.0522298695348542, 0.024008386690354107, 0.002415514104806157))
    for point in [(0.0559393435340089, 0.02350821588467525, 0.004108875904606994),
                  (0.052147475382697275, 0.023424854083728776, 0.004391102871240467),
                  (0.048960465449036775, 0.023341492282782296, 0.00467332983787394)]:
        try:
            scalpel.move(point)
        except SolverError as error:         # a loose piece may be refused; nothing else may go wrong
            assert "would separate" in str(error)
    h = solver.hybrid
    assert h.info.get("cuts", 0) > 0
    assert check_cut_invariants(h.surface.vertices, h.surface.triangles, positions=solver.positions) == []
    solver.set_load(10, [0.0, 0.0, 0.3])
    solver.step()
    assert np.all(np.isfinite(solver.positions))


@pytest.mark.parametrize("method", CUTTING)
def test_random_strokes_at_the_smallest_snap_keep_every_invariant(cube, method):
    """The sweep's F7 found zero-area triangles, non-manifold vertices and zero rest lengths with snap = 0 on the
    embedded and mass-spring methods; at the smallest snap accepted, 20 random 12-move strokes on the top keep every
    invariant on every method that cuts (rng 7, whose strokes left a sliver of quality 0.0074 at snap 0.05 on the
    mass-spring method)."""
    rng = np.random.default_rng(7)
    top = cube.surface.vertices[:, 2].max()
    cuts = 0
    for _ in range(20):
        solver = make_solver(method, cube)
        scalpel = Scalpel(solver, depth=0.004 + 0.02 * rng.random(), snap=MIN_SNAP)
        tip = np.array([rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), top + 0.001])
        scalpel.press(tip, direction=[0, 0, -1])
        heading = rng.normal(size=2)
        for _ in range(12):
            heading = heading / np.linalg.norm(heading) + 0.5 * rng.normal(size=2)
            tip = tip + np.append(rng.uniform(0.3, 3) * 0.0027 * heading / np.linalg.norm(heading), 0.0)
            try:
                scalpel.move(tip)
            except SolverError as error:
                assert "would separate" in str(error)
                continue
            cuts += 1
            h = solver.hybrid
            assert check_cut_invariants(h.surface.vertices, h.surface.triangles) == []
    assert cuts > 200
