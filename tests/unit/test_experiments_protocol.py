"""The experiment protocol: load cases, load node, sample nodes, metrics eq 25–26 against hand-computed cases."""

import numpy as np
import pytest

from tissuesim.errors import SolverError
from tissuesim.experiments import paper, protocol
from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_height


# ----------------------------------------------------------------------------------------------------- metrics
def test_displacements_eq25_hand_computed():
    rest = np.zeros((4, 3))
    moved = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, -2.0], [1.0, 2.0, 2.0], [9.0, 9.0, 9.0]])
    assert protocol.displacements(moved, rest, [0, 1, 2]) == pytest.approx([5.0, 2.0, 3.0])
    assert protocol.displacements(moved, rest, [2]) == pytest.approx([3.0])


def test_rmse_eq26_hand_computed():
    reference = np.zeros((3, 3))
    positions = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 1.0], [100.0, 0.0, 0.0]])
    # nodes 0 and 1: errors 5 and 1 -> sqrt((25 + 1) / 2) = sqrt(13)
    assert protocol.rmse(positions, reference, [0, 1]) == pytest.approx(np.sqrt(13.0))
    assert protocol.rmse(positions, reference, [2]) == pytest.approx(100.0)
    assert protocol.rmse(reference, reference, [0, 1, 2]) == 0.0  # exact: x − x is 0 in IEEE arithmetic


def test_relative_rmse_divides_by_reference_rms_displacement():
    rest = np.zeros((2, 3))
    reference = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 2.0]])  # RMS displacement 2
    positions = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])  # errors 1 and 1 -> RMSE 1
    assert protocol.rms_displacement(reference, rest, [0, 1]) == pytest.approx(2.0)
    assert protocol.relative_rmse(positions, reference, rest, [0, 1]) == pytest.approx(0.5)
    assert np.isnan(protocol.relative_rmse(positions, rest, rest, [0, 1]))  # reference at rest: undefined


@pytest.mark.parametrize("nodes", [[], [0, 5], [-1]])
def test_metrics_refuse_bad_nodes(nodes):
    with pytest.raises(SolverError, match="sample nodes"):
        protocol.rmse(np.zeros((3, 3)), np.zeros((3, 3)), nodes)


def test_metrics_refuse_mismatched_shapes():
    with pytest.raises(SolverError, match="differ in shape"):
        protocol.rmse(np.zeros((3, 3)), np.zeros((4, 3)), [0])


# ------------------------------------------------------------------------------------------------- samples
def test_sample_nodes_nearest_first_node_included_ties_by_index():
    # A line of points at x = 0, 1, -1, 2, -2 (indices 0..4); node 0 is the load node.
    points = np.array([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [2, 0, 0], [-2, 0, 0]], dtype=float)
    assert protocol.sample_nodes(points, 0, 1).tolist() == [0]
    assert protocol.sample_nodes(points, 0, 3).tolist() == [0, 1, 2]  # 1 and 2 tie: lower index first
    assert protocol.sample_nodes(points, 0, 5).tolist() == [0, 1, 2, 3, 4]
    assert protocol.sample_nodes(points, 3, 2).tolist() == [3, 1]


def test_sample_nodes_load_node_first_even_if_duplicated():
    points = np.array([[1, 1, 1], [0, 0, 0], [0, 0, 0]], dtype=float)
    assert protocol.sample_nodes(points, 2, 2).tolist() == [2, 1]


@pytest.mark.parametrize("node, count, match", [(5, 1, "outside"), (0, 0, "sample count"), (0, 6, "sample count")])
def test_sample_nodes_refuse_bad_arguments(node, count, match):
    with pytest.raises(SolverError, match=match):
        protocol.sample_nodes(np.zeros((5, 3)), node, count)


def test_sample_nodes_on_a_model_are_the_k_nearest():
    surface = models.sphere(300)
    node = protocol.load_node(surface.vertices, surface.triangles)
    chosen = protocol.sample_nodes(surface.vertices, node, protocol.RMSE_SAMPLES)
    distance = np.linalg.norm(surface.vertices - surface.vertices[node], axis=1)
    others = np.setdiff1d(np.arange(surface.vertex_count), chosen)
    assert len(set(chosen.tolist())) == protocol.RMSE_SAMPLES
    assert distance[chosen].max() <= distance[others].min()
    assert np.all(np.diff(distance[chosen]) >= 0)


# ----------------------------------------------------------------------------------------------- load node
def test_load_node_of_a_flat_top_is_the_node_at_its_centre():
    cube = models.cube(6 * 4 ** 2 + 2)  # 5 grid points per edge: a vertex at the top face's centre
    node = protocol.load_node(cube.vertices, cube.triangles)
    assert cube.vertices[node] == pytest.approx([0.0, 0.0, models.CUBE_EDGE], abs=1e-12)


def test_load_node_is_on_the_upper_surface_near_the_axis(model_name):
    surface = models.model(model_name, 600)
    node = protocol.load_node(surface.vertices, surface.triangles)
    lo, hi = surface.bounds
    centre = 0.5 * (lo[:2] + hi[:2])
    horizontal = np.linalg.norm(surface.vertices[:, :2] - centre, axis=1)
    # On the upper surface: above mid-height, and no node near the axis lies higher than one edge length above it.
    assert surface.vertices[node, 2] > 0.5 * (lo[2] + hi[2])
    edge = np.median(np.linalg.norm(np.diff(surface.vertices[surface.edges], axis=1)[:, 0], axis=1))
    near_axis = horizontal < 2 * edge
    assert surface.vertices[near_axis, 2].max() - surface.vertices[node, 2] < edge
    assert horizontal[node] < 1.5 * edge
    assert surface.vertices[node, 2] > bottom_height(surface.vertices)


def test_load_node_without_triangles_falls_back_to_top_centre():
    points = np.array([[0, 0, 0], [0, 0, 1], [0.5, 0, 1.2], [0.1, 0.0, 0.9]], dtype=float)
    # Bounding-box top centre is (0.25, 0, 1.2): nearest is index 2.
    assert protocol.load_node(points) == 2


# ------------------------------------------------------------------------------------------------ load cases
def test_load_cases_follow_the_papers_table_order():
    cases = protocol.load_cases()
    assert [(c.load, c.force_N) for c in cases[:2]] == [("tension", 0.5), ("tension", 1.0)]
    assert len(cases) == 12 and cases[6].load == "pressure"
    assert cases[0].vector.tolist() == [0.0, 0.0, 0.5]
    assert cases[-1].vector.tolist() == [0.0, 0.0, -20.0]
    assert protocol.load_cases([10, 1, 1], ["pressure"]) == [protocol.LoadCase("pressure", 1.0),
                                                             protocol.LoadCase("pressure", 10.0)]


@pytest.mark.parametrize("load, force", [("shear", 1.0), ("tension", 0.0), ("tension", float("nan"))])
def test_load_case_refuses_bad_input(load, force):
    with pytest.raises(SolverError):
        protocol.LoadCase(load, force)


# --------------------------------------------------------------------------------------- published figures
def test_published_tables_cover_every_case():
    for model in paper.MODELS:
        assert set(paper.RMSE_MM[model]) == {(c.load, c.force_N) for c in protocol.load_cases()}
        assert set(paper.TIME_MS[model]) == set(paper.RMSE_MM[model])
    # Spot checks against the paper's text.
    # exact: the published tables, stored as written
    assert paper.rmse_mm("liver", "tension", 20.0, "mass-spring") == 5.5188
    assert paper.rmse_mm("sphere", "pressure", 0.5, "hybrid") == 0.0281
    assert paper.time_ms("cube", "pressure", 20.0, "fem") == 14.9
    assert paper.time_ms("steak", "tension", 0.5, "mass-spring") is None
    assert paper.time_ms("steak", "tension", 0.5, "fem") == 16.8
    assert paper.rmse_mm("liver", "tension", 1.0, "embedded") is None


def test_published_ratio_means():
    # Every published RMSE ratio Ours/PBD lies between 0.2 and 0.5; the time overhead Ours/PBD about 1.6.
    for model in paper.MODELS:
        assert 0.2 < paper.mean_ratio(paper.RMSE_MM, model, "hybrid", "pbd") < 0.5
        assert 1.4 < paper.mean_ratio(paper.TIME_MS, model, "hybrid", "pbd") < 1.8
    assert paper.mean_ratio(paper.TIME_MS, "steak", "hybrid", "mass-spring") is None
