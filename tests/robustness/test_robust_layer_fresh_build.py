"""A solver built on a cut mesh (the viewer switching method, a saved bundle loaded again) has the rows of the solver
that made the cut.

The cutting solver gives a row with an end the cut made the body's thickness, β × M_S's edge length as built, and
the body's own edges β × their own length. A fresh build used to give every row its own length, so a cut's short
rows were thinner there (stiffnesses up to 24 % apart, wound openings 1.9x). The mesh now carries M_S's vertex count
and edge length as built in its ``info``, through ``save`` and ``load`` (a forged bundle's are refused at load), and
both paths read the same rule.
"""

import json

import numpy as np
import pytest

import tissuesim
from tissuesim.errors import BundleError
from tissuesim.experiments.wound import scripted_incision
from tissuesim.mesh import models
from tissuesim.mesh.hybrid import SURFACE_EDGE_KEY, SURFACE_VERTICES_KEY
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

#: the methods with a surface layer (stretch and bending rows with their compliances)
SURFACE_LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(), fine_volume=False)


def _keyed(pairs, values) -> dict:
    """{(i, j) with i < j: value} of the live rows (a retired row joins a node to itself)."""
    pairs = np.sort(np.asarray(pairs, dtype=np.int64), axis=1)
    live = pairs[:, 0] != pairs[:, 1]
    return dict(zip(map(tuple, pairs[live].tolist()), np.asarray(values)[live].tolist()))


def _layer_rows(solver) -> tuple[dict, dict]:
    c = solver.constraints
    return (_keyed(c.edges, solver.stretch_compliance), _keyed(c.bending[:, :2], solver.bend_compliance))


def _assert_same_rows(ours: dict, theirs: dict) -> None:
    assert ours.keys() == theirs.keys()
    keys = sorted(ours)
    # rtol 1e-9: the cut's rest lengths come from eq 19–23, a fresh build's from the rest positions (1e-9 apart)
    np.testing.assert_allclose([theirs[k] for k in keys], [ours[k] for k in keys], rtol=1e-9)


def _reloaded(hybrid, tmp_path):
    path = tmp_path / "cut.npz"
    hybrid.save(path)
    return tissuesim.HybridMesh.load(path)


@pytest.mark.parametrize("method", SURFACE_LAYER)
def test_a_fresh_layer_on_a_cut_mesh_has_the_cutting_solvers_compliances(cube, method, tmp_path):
    cutting = tissuesim.make_solver(method, cube)
    scripted_incision(cutting)
    ours = _layer_rows(cutting)
    for mesh in (cutting.hybrid, _reloaded(cutting.hybrid, tmp_path)):
        theirs = _layer_rows(tissuesim.make_solver(method, mesh))
        for kind in range(2):       # stretch rows, then hinges
            _assert_same_rows(ours[kind], theirs[kind])


def test_fresh_springs_on_a_cut_mesh_have_the_cutting_solvers_stiffnesses(cube, tmp_path):
    cutting = tissuesim.make_solver("mass-spring", cube)
    scripted_incision(cutting)
    live = cutting.springs[:, 0] != cutting.springs[:, 1]
    for mesh in (cutting.hybrid, _reloaded(cutting.hybrid, tmp_path)):
        fresh = tissuesim.make_solver("mass-spring", mesh)
        assert len(fresh.springs) == live.sum()
        # a stretch and a bending spring may share no key, so compare the sorted stiffnesses; rtol as above
        np.testing.assert_allclose(np.sort(fresh.stiffness), np.sort(cutting.stiffness[live]), rtol=1e-9)


def test_a_cut_mesh_keeps_the_body_as_built_through_save_and_load(cube, tmp_path):
    solver = tissuesim.make_solver("pbd", cube)
    scripted_incision(solver)
    loaded = _reloaded(solver.hybrid, tmp_path)
    assert loaded.surface.vertex_count > cube.surface.vertex_count
    assert loaded.info[SURFACE_VERTICES_KEY] == cube.surface.vertex_count
    assert loaded.info[SURFACE_EDGE_KEY] == cube.info[SURFACE_EDGE_KEY]
    assert loaded.built_edge_length == cube.built_edge_length


@pytest.mark.parametrize("key", [SURFACE_VERTICES_KEY, SURFACE_EDGE_KEY])
@pytest.mark.parametrize("value", ["x", True, -1, 0, None])
def test_a_bundle_whose_built_figures_are_no_numbers_is_refused_at_load(cube, tmp_path, key, value):
    path = tmp_path / "cube.npz"
    cube.save(path)
    with np.load(path) as stored:
        arrays = dict(stored)
    header = json.loads(arrays["header"].tobytes())
    header["info"][key] = value
    arrays["header"] = np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8)
    np.savez(path, **arrays)
    with pytest.raises(BundleError, match=f"info {key} is .*not a positive number"):
        tissuesim.HybridMesh.load(path)
