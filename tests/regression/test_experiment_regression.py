"""The experiment on a small model: its numbers checked against an independent FEM where one exists, method ordering
by RMSE, stored reference numbers, and the quick CLI run writing every output.

Where the numbers come from:

* ``experiment_reference.json`` (beside this file) is this code's own output, written by::

      python -m tissuesim.experiments.run --write-reference tests/regression/experiment_reference.json

  last at commit 0df0c47 ("Regression reference and calibration test follow the quadratic reference and the new
  calibration"). Pinning a record to it detects a change, not an error.
* Independent checks, here: the ``fem`` reference (every M_S node, so every RMSE is measured against a checked
  reference), the ``embedded`` surface and the hybrid's control nodes are recomputed with scikit-fem on the same
  volumes, loads and supports (1e-9), and the embedding weights against the geometry (1e-12).
* No independent solver exists for the hybrid's free nodes, pbd or mass-spring. Their answers are checked as
  equilibria of their own energies, written independently of the solvers (the layer's constraint energy from the
  NumPy reference constraints, the springs' forces written out), and their physics in
  tests/validation/test_physical_consistency.py; the stored figures themselves are the code's own (regression).
* The paper's claim, the hybrid nearer the reference than every baseline, is asserted here against the fine linear
  FEM under the paper's single-node load, whose value at the load node grows without bound as the mesh refines
  (docs/experiments.md): it is a claim about this reference and this mesh, with a margin of 1.06 % over mass-spring
  (pressure, 1 N). Against the contact protocol's refined reference, see test_contact_claims (slow).
"""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.experiments import protocol
from tissuesim.experiments.methods import compared_methods, protocol_methods
from tissuesim.experiments.run import reference_config, reference_numbers, run_experiment
from tissuesim.experiments.schema import check_results
from tissuesim.experiments.sweep_config import load_model
from tissuesim.solvers import make_solver
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

REFERENCE_FILE = Path(__file__).with_name("experiment_reference.json")
# Relative tolerance on stored RMSE and displacements: the sweep is deterministic; this absorbs BLAS/SuperLU
# round-off and iterative solvers stopping one step apart on another machine.
RTOL = 2e-3
ATOL_MM = 1e-4


@pytest.fixture(scope="module")
def hybrid():
    config = reference_config()
    return load_model(config.models[0], config)


@pytest.fixture(scope="module")
def results(hybrid):
    config = reference_config()
    return run_experiment(config, progress=False, meshes={config.models[0]: hybrid})


def _by_case(results):
    table = {}
    for r in results["records"]:
        table.setdefault((r["load"], r["force_N"]), {})[r["method"]] = r
    return table


def test_results_follow_the_schema(results):
    check_results(results)
    cases = protocol.load_cases(reference_config().forces)
    assert len(results["records"]) == len(cases) * len(protocol_methods())
    assert all(len(record["displacements_mm"]) == protocol.PLOT_SAMPLES for record in results["records"])
    references = [record["rmse_mm"] for record in results["records"] if record["method"] == protocol.REFERENCE]
    # one reference record per case, each exact: the reference against itself, x − x = 0 in IEEE arithmetic
    assert references == [0.0] * len(cases)


def skfem_displacement(volume, forces, fixed):
    """``(n, 3)`` displacements [m] by scikit-fem's P1 elasticity (tests/validation/test_fem_skfem.py), E = 5500 Pa,
    ν = 0.3: the defaults of every solver here."""
    path = Path(__file__).resolve().parents[1] / "validation" / "test_fem_skfem.py"
    spec = importlib.util.spec_from_file_location("skfem_check", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.skfem_solution(volume, forces, fixed)[1]


def supported(volume_points, surface):
    """The support of every solver (docs/experiments.md): volume nodes at or below the bottom height of M_S."""
    from tissuesim.mesh.regions import bottom_height, nodes_below

    return nodes_below(volume_points, bottom_height(surface.vertices))


def _case_force(load, force):
    return force * np.asarray(protocol.LOAD_DIRECTIONS[load])


@pytest.fixture(scope="module")
def unit_cases(hybrid):
    """Per load kind, the scikit-fem answers to 1 N: fine volume, coarse volume (embedded) and the hybrid's load split
    onto M_V (§6.1). Every method here is linear in the force, so other forces scale these."""
    h, rest = hybrid, np.asarray(hybrid.surface.vertices)
    node = protocol.load_node(rest, h.surface.triangles)
    answers = {}
    for load in protocol.LOADS:
        f = _case_force(load, 1.0)
        fine = np.zeros((h.fine_volume.node_count, 3))
        fine[h.fine_surface_nodes[node]] = f
        embedded = np.zeros((h.volume.node_count, 3))
        np.add.at(embedded, h.volume.tets[h.embedding_tet[node]], h.embedding_barycentric[node][:, None] * f)
        split = np.zeros((h.volume.node_count, 3))
        corners = np.asarray(h.coarse_volume_nodes)[h.coarse_surface.triangles[h.coarse_triangle[node]]]
        np.add.at(split, corners, h.coarse_barycentric[node][:, None] * f)
        answers[load] = {name: skfem_displacement(volume, forces, supported(volume.points, h.surface))
                         for name, volume, forces in (("fine", h.fine_volume, fine), ("coarse", h.volume, embedded),
                                                      ("split", h.volume, split))}
    return node, answers


def test_embedding_weights_reproduce_the_surface(hybrid):
    h = hybrid
    corners = h.volume.points[h.volume.tets[h.embedding_tet]]
    mapped = np.einsum("ij,ijk->ik", h.embedding_barycentric, corners)
    size = np.ptp(h.surface.vertices, axis=0).max()
    assert np.abs(mapped - h.surface.vertices).max() <= 1e-12 * size      # round-off of a 4-term sum
    assert np.all(h.embedding_barycentric >= -1e-12)


def test_fem_and_embedded_records_equal_scikit_fem(results, hybrid, unit_cases):
    """The reference every RMSE is measured against, over every M_S node, and the embedded surface's samples.
    1e-9: two direct solves of the same linear system (test_fem_skfem.py measures ~1e-12)."""
    h, rest = hybrid, np.asarray(hybrid.surface.vertices)
    node, answers = unit_cases
    fine_solver = make_solver("fem", h)
    for (load, force), methods in _by_case(results).items():
        fine = force * answers[load]["fine"][h.fine_surface_nodes]
        positions = fine_solver.solve_static(node, _case_force(load, force))
        assert np.abs(positions - rest - fine).max() <= 1e-9 * np.abs(fine).max(), (load, force)
        samples = protocol.sample_nodes(rest, node, protocol.PLOT_SAMPLES)
        expected = 1e3 * np.linalg.norm(fine[samples], axis=1)
        np.testing.assert_allclose(methods["fem"]["displacements_mm"], expected, rtol=1e-9)
        coarse = force * answers[load]["coarse"]
        embedded = np.einsum("ij,ijk->ik", h.embedding_barycentric, coarse[h.volume.tets[h.embedding_tet]])
        np.testing.assert_allclose(methods["embedded"]["displacements_mm"],
                                   1e3 * np.linalg.norm(embedded[samples], axis=1), rtol=1e-9)
        # eq 26 over the RMSE samples, from the two scikit-fem answers alone
        rmse_samples = protocol.sample_nodes(rest, node, protocol.RMSE_SAMPLES)
        error = np.sqrt(np.mean(np.sum((embedded - fine)[rmse_samples] ** 2, axis=1)))
        assert methods["embedded"]["rmse_mm"] == pytest.approx(1e3 * error, rel=1e-9), (load, force)


def test_hybrid_control_nodes_equal_scikit_fem(hybrid, unit_cases):
    """§6.1–6.2: the load split over the coarse triangle's control nodes, M_V solved, the control nodes prescribed."""
    h, rest = hybrid, np.asarray(hybrid.surface.vertices)
    node, answers = unit_cases
    control = np.asarray(h.control)
    for load in protocol.LOADS:
        positions = make_solver("hybrid", h).solve_static(node, _case_force(load, 1.0))
        expected = answers[load]["split"][np.asarray(h.control_volume)]
        assert np.abs(positions[control] - rest[control] - expected).max() <= 1e-9 * np.abs(expected).max(), load


def layer_residual(solver, x) -> np.ndarray:
    """``(n, 3)`` [N]: the external forces plus the surface layer's internal forces at positions ``x``, from the NumPy
    reference constraints (checked against finite differences in test_layer_constraints.py); prescribed nodes 0."""
    from tissuesim.layer import constraints as C

    c, residual = solver.constraints, solver.forces.copy()
    for e, (i, j) in enumerate(c.edges):
        residual[[i, j]] -= (C.stretch_value(x[i], x[j], c.rest_length[e]) * C.stretch_gradient(x[i], x[j])
                             / solver.stretch_compliance[e])
    for k, hinge in enumerate(c.bending):
        angle = C.signed_bend_angle(*x[hinge]) - solver.constraints.rest_signed_angle[k]
        residual[hinge] -= angle * C.signed_bend_gradient(*x[hinge]) / solver.bend_compliance[k]
    residual[solver.prescribed] = 0.0
    return residual


@pytest.mark.parametrize("method", method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver)))
def test_layer_answers_are_the_linearised_equilibrium_of_the_constraint_energy(hybrid, method):
    """Where the stored figures of hybrid and pbd have no independent reference, their physics has one: the static
    answer solves the layer's constraint energy linearised at rest, so the residual of the full energy is of second
    order in the load: residual / load grows tenfold with a tenfold load (measured 10.03 / 9.97 for pbd / hybrid;
    third-order terms move it by far less than 2). A stiffness 10 % off leaves a first-order residual that brings the
    ratio to 1.1 / 6.2 (measured), so the band 8-12 tells them apart."""
    rest = np.asarray(hybrid.surface.vertices)
    node = protocol.load_node(rest, hybrid.surface.triangles)
    residuals = []
    for force in (0.01, 0.1):
        solver = make_solver(method, hybrid)
        x = solver.solve_static(node, [0.0, 0.0, -force])
        residuals.append(np.abs(layer_residual(solver, x)).max() / force)
    assert residuals[0] < 1e-2      # measured 9e-5 / 1.5e-3 of the load at 0.01 N
    assert 8.0 < residuals[1] / residuals[0] < 12.0


def test_mass_spring_answer_is_an_equilibrium_of_its_springs(hybrid):
    """The stored mass-spring figures are the settled state of its springs: the spring forces (k (|d| − L) along d,
    written out here) balance the load to the settling tolerance (measured 1e-7 of the load)."""
    rest = np.asarray(hybrid.surface.vertices)
    node = protocol.load_node(rest, hybrid.surface.triangles)
    for load in protocol.LOADS:
        solver = make_solver("mass-spring", hybrid)
        x = solver.solve_static(node, _case_force(load, 1.0))
        d = x[solver.springs[:, 1]] - x[solver.springs[:, 0]]
        length = np.linalg.norm(d, axis=1)
        tension = (solver.stiffness * (length - solver.rest_lengths) / length)[:, None] * d
        residual = solver.forces.copy()
        np.add.at(residual, solver.springs[:, 0], tension)
        np.add.at(residual, solver.springs[:, 1], -tension)
        residual[solver.fixed] = 0.0
        assert np.abs(residual).max() < 1e-4, load      # [N], against a 1 N load


def test_hybrid_beats_surface_only_pbd(results):
    """The hybrid is PBD's surface model with its control nodes held on the FEM solution: it must be closer to the
    reference than PBD in every case. (Against MSM, the paper's other claim, the outcome depends on calibration:
    it is reported in report.md and pinned by the stored ordering below, not asserted as a law.)"""
    for case, methods in _by_case(results).items():
        assert methods["hybrid"]["rmse_mm"] < methods["pbd"]["rmse_mm"], case


def test_ordering_of_methods_matches_the_stored_one(results):
    stored = json.loads(REFERENCE_FILE.read_text())
    expected = {}
    for r in stored["records"]:
        expected.setdefault((r["load"], r["force_N"]), []).append((r["rmse_mm"], r["method"]))
    for case, methods in _by_case(results).items():
        ours = [m for _, m in sorted((r["rmse_mm"], m) for m, r in methods.items())]
        assert ours == [m for _, m in sorted(expected[case])], case


def test_figures_match_the_stored_reference(results):
    stored = json.loads(REFERENCE_FILE.read_text())
    ours = reference_numbers(results)
    assert ours["config"] == stored["config"]
    expected = {(r["load"], r["force_N"], r["method"]): r for r in stored["records"]}
    assert len(expected) == len(ours["records"])
    for record in ours["records"]:
        key = (record["load"], record["force_N"], record["method"])
        reference = expected[key]
        assert record["rmse_mm"] == pytest.approx(reference["rmse_mm"], rel=RTOL, abs=ATOL_MM), key
        assert record["displacements_mm"] == pytest.approx(reference["displacements_mm"], rel=RTOL, abs=ATOL_MM), key


def test_quick_cli_run_writes_every_output(tmp_path, capsys):
    output = tmp_path / "results"
    code = main(["experiment", "cube", "--quick", "--forces", "2", "--output", str(output), "--quiet"])
    assert code == 0, capsys.readouterr().err
    names = sorted(p.name for p in output.iterdir())
    assert names == ["radar_cube.png", "report.md", "results.json", "tables.md"]
    data = json.loads((output / "results.json").read_text())
    check_results(data)
    assert {r["method"] for r in data["records"]} == set(protocol_methods())
    assert {(r["load"], r["force_N"]) for r in data["records"]} == {("tension", 2.0), ("pressure", 2.0)}
    assert "## Table 3" in (output / "tables.md").read_text()
    assert "Winner of each row" in (output / "report.md").read_text()


@pytest.mark.slow
def test_contact_claims(better_beyond_the_reference):
    """The paper's claim against the contact protocol's refined reference (quadratic tets, refined at the contact
    until the samples change by < 1 %; ~70 s from a cold cache): the cube at its Table-1 size, 1 N, both loads, tip
    radii 4 and 8 mm. The free scalars were calibrated on one of these cases (pressure, R = 4 mm); the other three
    are held out.

    Measured: the references converge (last changes 0.007 / 0.008); the hybrid's relative RMSE is 0.39 / 0.28 against
    embedded 0.55 / 0.43, mass-spring 0.58-0.59 / 0.46-0.47 and pbd 0.62 / 0.50 (R = 4 / 8 mm): it beats every
    baseline by 15x the reference's uncertainty or more. On the 400-vertex regression cube the same reference does not
    converge (changes 0.034-0.042) and the claim fails there: mass-spring is ahead at R = 8 mm under pressure (0.471
    against 0.489), and the lead on the embedded surface (0.045) is within twice the change. The fast sibling is
    test_hybrid_beats_surface_only_pbd (against the fine linear FEM)."""
    from tissuesim.experiments import contact_protocol
    from tissuesim.experiments.reference import default_cache_dir

    config = contact_protocol.ContactConfig(models=("cube",), forces=(1.0,), loads=protocol.LOADS, radii_mm=(4.0, 8.0),
                                   methods=compared_methods(),
                                   cache_dir=str(default_cache_dir()))
    run = contact_protocol.run_contact(config, progress=False)
    references = run["metadata"]["models"]["cube"]["references"]
    for radius in (4.0, 8.0):
        assert references[f"{radius:g}"]["converged"]
        errors = {(r["method"], r["load"]): r["relative_rmse"] for r in run["records"] if r["radius_mm"] == radius}
        change = references[f"{radius:g}"]["levels"][-1]["change"]
        for baseline in compared_methods()[1:]:
            better_beyond_the_reference(errors, "hybrid", baseline, change)
