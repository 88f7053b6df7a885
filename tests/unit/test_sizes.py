"""Units and sizes: an implausible size is warned of with the scale that fixes it, and the commands' default loads
scale with the model (lengths as L, forces as E L²) and leave every built-in and shared model in the small-strain
range, by the solvers' own warning."""

import warnings

import numpy as np
import pytest

from tissuesim.errors import TissuesimWarning
from tissuesim.experiments.protocol import LOAD_DIRECTIONS, load_node
from tissuesim.io import read_surface, write_surface
from tissuesim.mesh.hybrid import HybridMesh
from tissuesim.mesh.models import cube, model
from tissuesim.mesh.sizes import (DISPLACEMENT_CAP, fitted_force, load_defaults, model_size, size_warning,
                                  suggested_scale)
from tissuesim.solvers.registry import make_solver


def test_the_size_is_the_bounding_box_diagonal():
    assert model_size(cube(300).vertices) == pytest.approx(0.08 * np.sqrt(3.0), rel=1e-12)


@pytest.mark.parametrize("file_size, scale", [(2.78, 0.01), (55.5, 0.001), (9.2, 0.01), (0.2, 1.0), (150.0, 0.001)])
def test_the_suggested_scale_is_the_unit_that_makes_an_organ(file_size, scale):
    assert suggested_scale(file_size) == scale


def test_sizes_outside_5_mm_to_2_m_are_warned_of_naming_size_and_scale():
    points = cube(300).vertices
    assert size_warning(points) is None and size_warning(points * 14.0) is None        # 1.94 m: a torso
    large = size_warning(points * 100.0, source="cube.obj")
    assert "cube.obj is 13.9 m across after scale 1, larger than 2 m" in large
    assert "did you forget --scale" in large and "--scale 0.01 (a file in cm) would make it 13.9 cm across" in large
    small = size_warning(points * 0.01, scale=0.01)
    assert "1.39 mm across after scale 0.01, smaller than 5 mm" in small and "--scale 1 (a file in m)" in small


def test_a_surface_in_cm_read_as_metres_warns_and_read_in_cm_does_not(tmp_path):
    path = tmp_path / "organ.obj"
    write_surface(path, cube(300).with_vertices(cube(300).vertices * 100.0))     # an 8 cm cube written in cm
    with pytest.warns(TissuesimWarning, match=r"organ.obj is 13.9 m across .* --scale 0.01 \(a file in cm\)"):
        read_surface(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", TissuesimWarning)
        assert model_size(read_surface(path, scale=0.01).vertices) == pytest.approx(0.1386, rel=1e-3)


def test_default_lengths_scale_as_the_size_and_forces_as_e_times_size_squared():
    points = cube(300).vertices
    base = load_defaults(points)
    tenfold = load_defaults(10.0 * points)
    stiffer = load_defaults(points, youngs_modulus=4 * 5500.0)
    for length in ("radius", "stroke", "depth", "offset"):
        assert getattr(tenfold, length) == pytest.approx(10.0 * getattr(base, length), rel=5e-3)
    for force in ("force", "pull"):
        assert getattr(tenfold, force) == pytest.approx(100.0 * getattr(base, force), rel=5e-3)
        assert getattr(stiffer, force) == pytest.approx(4.0 * getattr(base, force), rel=5e-3)


def _worst_fraction(solver, node, force, radius) -> float:
    """Largest displacement over the model's size under ``force`` up and down, and whether the solver warned."""
    worst = 0.0
    for direction in LOAD_DIRECTIONS.values():
        solver.solve_static(node, force * np.asarray(direction), radius=radius)
        assert solver.last_solve.warning is None, solver.last_solve.warning
        worst = max(worst, solver.largest_displacement / solver.size)
    return worst


def test_the_defaults_alone_keep_every_built_in_model_in_small_strain(model_name):
    hybrid = HybridMesh.build(model(model_name, 700), fine_volume=False)
    solver = make_solver("hybrid", hybrid)
    loads = load_defaults(solver.rest_positions)
    node = load_node(solver.rest_positions, hybrid.surface.triangles)
    fitted, moved = fitted_force(solver, node, loads.force, LOAD_DIRECTIONS.values(), radius=loads.radius)
    assert fitted == loads.force and moved <= DISPLACEMENT_CAP      # the half-space estimate needs no lowering
    assert 0.003 < _worst_fraction(solver, node, loads.force, loads.radius) <= DISPLACEMENT_CAP   # visible, small


def test_the_2_cm_liver2_rocks_on_its_bottom_and_the_fitted_force_keeps_it_in_small_strain(meshes_dir):
    surface = read_surface(meshes_dir / "sofa" / "liver2.obj", scale=0.01)
    hybrid = HybridMesh.build(surface, fine_volume=False)
    solver = make_solver("hybrid", hybrid)
    loads = load_defaults(solver.rest_positions)
    node = load_node(solver.rest_positions, hybrid.surface.triangles)
    fitted, moved = fitted_force(solver, node, loads.force, LOAD_DIRECTIONS.values(), radius=loads.radius)
    assert moved > 0.1 and fitted < loads.force       # the estimate alone is beyond small strain here
    assert np.array_equal(solver.positions, solver.rest_positions)    # the trial left the solver at rest
    # a linear method: the lowered force moves it the cap, to the rounding of the force's three digits
    assert _worst_fraction(solver, node, fitted, loads.radius) == pytest.approx(DISPLACEMENT_CAP, rel=5e-3)


def test_a_coarse_mesh_gets_a_pin_head_over_a_few_nodes_and_a_stroke_across_a_few_edges():
    points = cube(300).vertices
    fine, coarse = load_defaults(points, edge_length=0.001), load_defaults(points, edge_length=0.012)
    assert fine.radius == pytest.approx(0.05 * model_size(points), rel=5e-3)
    assert fine.stroke == pytest.approx(0.15 * model_size(points), rel=5e-3)
    assert coarse.radius == pytest.approx(0.018, rel=1e-12) and coarse.stroke == pytest.approx(0.036, rel=1e-12)
    assert coarse.force > fine.force            # the same dent under a wider tip takes more force
    assert load_defaults(points, edge_length=0.05).stroke == pytest.approx(0.3 * model_size(points), rel=5e-3)
