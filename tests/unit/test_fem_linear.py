"""LinearFEM: boundary-condition checks, full solve, and the cached-column fast path for point loads."""

import sys

import numpy as np
import pytest

from tissuesim.errors import BoundaryConditionError, MeshError, SolverError
from tissuesim.fem.linear import LinearFEM
from tissuesim.mesh.regions import bottom_nodes
from tissuesim.mesh.tetmesh import TetMesh, structured_box

RNG = np.random.default_rng(3)


@pytest.fixture(scope="module")
def box():
    return structured_box((0.04, 0.03, 0.02), (4, 3, 2))


@pytest.fixture(scope="module")
def fem(box):
    return LinearFEM(box, fixed=bottom_nodes(box.points))


def test_solve_balances_loads_and_keeps_supports(fem, box):
    forces = RNG.normal(size=(box.node_count, 3)) * 1e-2
    free = ~fem.fixed_dofs
    forces[~free] = 0.0
    u = fem.solve(forces)
    assert u.shape == (box.node_count, 3)
    assert np.all(u[fem.fixed_dofs] == 0.0)  # exact: assigned
    r = fem.reactions(u)
    np.testing.assert_allclose(r[free], forces[free], atol=1e-12 * np.abs(forces).max())
    # Global equilibrium: support reactions carry the whole applied load.
    np.testing.assert_allclose(r[~free.all(axis=1)].sum(axis=0), -forces.sum(axis=0), rtol=1e-9)


def test_fast_path_equals_full_solve(fem, box):
    top = np.flatnonzero(box.points[:, 2] > 0.0199)
    load_nodes = top[[0, 5, 9]]
    load_forces = RNG.normal(size=(3, 3))
    forces = np.zeros((box.node_count, 3))
    forces[load_nodes] = load_forces
    full = fem.solve(forces)
    out_nodes = RNG.permutation(box.node_count)[:40]
    fast = fem.point_load_response(load_nodes, load_forces, output_nodes=out_nodes)
    assert np.abs(fast - full[out_nodes]).max() <= 1e-12 * np.abs(full).max()
    assert set(load_nodes) <= set(fem.cached_nodes)
    # Writing into a caller's buffer gives the same numbers (and reuses it).
    buffer = np.full((out_nodes.size, 3), np.nan)
    again = fem.point_load_response(load_nodes, load_forces, output_nodes=out_nodes, out=buffer)
    assert again is buffer and np.array_equal(buffer, fast)  # exact: the same buffer


def test_a_patch_response_is_exact_from_its_first_call_and_learns_a_direction_per_call(box, monkeypatch):
    from tissuesim.fem import linear

    fem = LinearFEM(box, fixed=bottom_nodes(box.points))
    top = np.flatnonzero(box.points[:, 2] > 0.0199)
    fixed = int(np.flatnonzero(fem.fixed_dofs.all(axis=1))[0])
    nodes = np.concatenate([top[:6], top[:2], [fixed]])        # repeats add up; a held node's share moves nothing
    weights = RNG.uniform(0.05, 0.3, size=nodes.size)
    out_nodes = RNG.permutation(box.node_count)[:40]
    out = np.full((out_nodes.size, 3), np.nan)
    solves = []
    solve = fem.factor.solve
    monkeypatch.setattr(fem.factor, "solve", lambda rhs: solves.append(rhs.shape) or solve(rhs))

    def full(force):
        forces = np.zeros((box.node_count, 3))
        np.add.at(forces, nodes, weights[:, None] * force)
        forces[fem.fixed_dofs] = 0.0
        return fem.solve(forces)[out_nodes]

    drag = [np.array([0.3, -0.2, 1.1]), np.array([0.3, -0.2, 1.1]), np.array([-0.5, 0.4, 0.2]), RNG.normal(size=3)]
    for k, force in enumerate(drag):
        assert fem.patch_response(nodes, weights, force, output_nodes=out_nodes, out=out) is out
        expected = full(force)
        assert np.abs(out - expected).max() <= 1e-12 * np.abs(expected).max()
        # one single-column solve per call until three directions are known, then none (the fem.solve above
        # is the check's own, counted too)
        assert solves.count((fem.free_dofs.size,)) == 2 * (k + 1) - (k == 3)
    monkeypatch.setattr(linear, "PATCH_CACHE_BYTES", 0)       # the fewest kept: PATCH_CACHE
    for k in range(linear.PATCH_CACHE):                        # other patches push the first one out
        fem.patch_response(top[k:k + 3], np.ones(3), drag[0], output_nodes=out_nodes, out=out)
    before = len(solves)
    fem.patch_response(nodes, weights, drag[0], output_nodes=out_nodes, out=out)
    assert len(solves) == before + 1
    with pytest.raises(SolverError, match="weights must be"):
        fem.patch_response(nodes[:3], weights[:2], drag[0], output_nodes=out_nodes, out=out)


def test_load_on_a_fixed_node_moves_nothing(fem, box):
    fixed = int(np.flatnonzero(fem.fixed_dofs.all(axis=1))[0])
    u = fem.point_load_response([fixed], [[1.0, 2.0, 3.0]], output_nodes=np.arange(box.node_count))
    assert np.all(u == 0.0)  # exact: a held node's load is dropped, and K⁻¹ 0 is 0 to the bit


def test_influence_is_cached_and_read_only(fem):
    g = fem.influence(30)
    assert g is fem.influence(30) and not g.flags.writeable and g.shape == (fem.node_count, 3, 3)
    # Maxwell–Betti reciprocity: K⁻¹ is symmetric, so G_j[i] = G_i[j]ᵀ.
    np.testing.assert_allclose(fem.influence(31)[30], g[31].T, rtol=1e-10, atol=1e-14)
    fem.precompute([1, 2, 30])
    assert {1, 2, 30} <= set(fem.cached_nodes)
    fem.clear_cache()
    assert fem.cached_nodes.size == 0


def test_dof_mask_allows_roller_supports(box):
    # Roller on the bottom (z only) plus two corner pins: statically determinate, exact for a uniform lift.
    mask = np.zeros((box.node_count, 3), dtype=bool)
    bottom = box.points[:, 2] == 0.0
    mask[bottom, 2] = True
    mask[0, :] = True
    corner = int(np.flatnonzero(bottom & (box.points[:, 1] == 0.0) & (box.points[:, 0] > 0.0399))[0])
    mask[corner, 1] = True
    fem = LinearFEM(box, fixed=mask)
    assert fem.free_dofs.size == 3 * box.node_count - mask.sum()
    node_mask = LinearFEM(box, fixed=bottom)
    assert node_mask.fixed_dofs[bottom].all() and not node_mask.fixed_dofs[~bottom].any()


@pytest.mark.parametrize(
    "fixed, words",
    [
        (None, "no fixed node"),
        (np.array([], dtype=np.int64), "no fixed node"),
        (np.array([0, 10_000]), "outside"),
        (np.array([0.0, 1.0]), "integer"),
        (np.array([5]), "single fixed node"),
        (np.array([0, 1, 2]), "collinear"),  # three nodes on the grid's z line at x = y = 0
    ],
)
def test_refuses_supports_that_leave_rigid_modes(box, fixed, words):
    with pytest.raises(BoundaryConditionError, match=words):
        LinearFEM(box, fixed=fixed)


def test_refuses_an_unsupported_piece():
    a = structured_box((1.0, 1.0, 1.0), (1, 1, 1))
    b = structured_box((1.0, 1.0, 1.0), (1, 1, 1), origin=(3.0, 0.0, 0.0))
    two = TetMesh(np.vstack([a.points, b.points]), np.vstack([a.tets, b.tets + a.node_count]))
    with pytest.raises(BoundaryConditionError, match="piece of the mesh"):
        LinearFEM(two, fixed=np.arange(4))  # only the first cube is held
    LinearFEM(two, fixed=np.r_[np.arange(4), a.node_count + np.arange(4)])


def test_refuses_orphan_nodes():
    a = structured_box((1.0, 1.0, 1.0), (1, 1, 1))
    orphan = TetMesh(np.vstack([a.points, [[5.0, 5.0, 5.0]]]), a.tets)
    with pytest.raises(MeshError, match="belong to no tet.*8"):
        LinearFEM(orphan, fixed=np.arange(4))


def test_refuses_bad_forces_and_nodes(fem, box):
    with pytest.raises(SolverError, match="shape"):
        fem.solve(np.zeros((box.node_count, 2)))
    bad = np.zeros((box.node_count, 3))
    bad[7, 1] = np.nan
    with pytest.raises(SolverError, match="non-finite.*7"):
        fem.solve(bad)
    with pytest.raises(SolverError, match="outside"):
        fem.point_load_response([box.node_count], [[0, 0, 1.0]], output_nodes=[0])
    with pytest.raises(SolverError, match="load_forces"):
        fem.point_load_response([1, 2], [[0, 0, 1.0]], output_nodes=[0])
    with pytest.raises(SolverError, match="out must"):
        fem.point_load_response([1], [[0, 0, 1.0]], output_nodes=[0, 1], out=np.zeros((3, 3)))


@pytest.mark.parametrize("route", ["cholmod+metis", "cholmod+amd", "superlu+metis", "superlu+mmd"])
def test_every_factorisation_route_matches_a_plain_sparse_solve(box, route, monkeypatch):
    """CHOLMOD (cvxopt) or SuperLU, with METIS nested dissection (pymetis) or the solver's own ordering when that
    optional package is missing: all give the plain sparse solve, multi-RHS included, and refuse a non-SPD K_ff."""
    import scipy.sparse.linalg as spla

    from tissuesim.fem.factorise import factorise_spd

    solver, ordering = route.split("+")
    if solver == "cholmod":
        import cvxopt  # noqa: F401  (a test dependency: missing, this fails instead of skipping)
    else:
        monkeypatch.setitem(sys.modules, "cvxopt", None)  # import fails: the SuperLU fallback
    if ordering == "metis":
        import pymetis  # noqa: F401  (a dependency of the library)
    else:
        monkeypatch.setitem(sys.modules, "pymetis", None)
    fem = LinearFEM(box, fixed=np.flatnonzero(box.points[:, 0] < 1e-9))
    forces = RNG.normal(size=(box.node_count, 3))
    expected = spla.spsolve(fem.reduced_stiffness, forces.ravel()[fem.free_dofs])
    u = fem.solve(forces)
    assert np.abs(u.ravel()[fem.free_dofs] - expected).max() <= 1e-12 * np.abs(expected).max()
    rhs = RNG.normal(size=(fem.free_dofs.size, 4))
    factor = factorise_spd(fem.reduced_stiffness, fem.free_dofs // 3)
    expected = spla.spsolve(fem.reduced_stiffness, rhs)
    assert np.abs(factor.solve(rhs) - expected).max() <= 1e-12 * np.abs(expected).max()
    with pytest.raises(SolverError, match="not positive definite"):
        factorise_spd(-fem.reduced_stiffness, fem.free_dofs // 3)
