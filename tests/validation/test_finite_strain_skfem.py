"""Finite strain against an independent implementation: the stable neo-Hookean energy (Smith, de Goes & Kim 2018)
written with scikit-fem's own forms and solved by Newton, checked against the analytic uniaxial stretch, then used
as the yardstick of the library's nonlinear FEM on identical meshes.

The energy, with the Lamé constants λ_L, μ_L of (E, ν):
  Ψ(F) = μ/2 (I_C − 3) + λ/2 (J − α)² − μ/2 log(I_C + 1),  μ = 4/3 μ_L,  λ = λ_L + 5/6 μ_L,  α = 1 + 3μ/(4λ);
  P = μ (1 − 1/(I_C + 1)) F + λ (J − α) cof F.
Nothing here comes from tissuesim except the meshes and the solver under test.
"""

import numpy as np
import pytest
import scipy.optimize
import scipy.sparse.linalg as spla
import tetgen

# scikit-fem is a test dependency (the ".[test]" extra): a missing one fails here, it is never skipped.
import skfem
from skfem.helpers import ddot, det, grad, identity, inv, mul, transpose

from tissuesim.errors import SolverError
from tissuesim.experiments import contact_protocol, protocol
from tissuesim.experiments.finite_reference import FORCES_N, load_finite_reference
from tissuesim.experiments.inputs import builtin_surface
from tissuesim.fem.nonlinear import NonlinearFEM
from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_nodes
from tissuesim.mesh.tetmesh import TetMesh

E, NU = 5500.0, 0.3


def neo_hookean_constants(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float, float]:
    """``(μ, λ, α)`` [Pa, Pa, -] of the stable neo-Hookean energy for Young's modulus [Pa] and Poisson's ratio."""
    mu_l = youngs_modulus / (2.0 * (1.0 + poisson_ratio))
    lam_l = youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio))
    mu, lam = 4.0 / 3.0 * mu_l, lam_l + 5.0 / 6.0 * mu_l
    return mu, lam, 1.0 + 0.75 * mu / lam


def _kinematics(w):
    """F = I + ∇u, its invariants, cof F and F⁻ᵀ at the quadrature points."""
    f = identity(grad(w["u"])) + grad(w["u"])
    j, i_c = det(f), ddot(f, f)
    inv_t = transpose(inv(f))
    return f, j, i_c, j * inv_t, inv_t


@skfem.Functional
def _energy(w):
    _, j, i_c, _, _ = _kinematics(w)
    return (0.5 * w.mu * (i_c - 3.0) + 0.5 * w.lam * (j - w.alpha) ** 2 - 0.5 * w.mu * np.log(i_c + 1.0))


@skfem.LinearForm
def _residual(v, w):
    f, j, i_c, cof, _ = _kinematics(w)
    stress = w.mu * (1.0 - 1.0 / (i_c + 1.0)) * f + w.lam * (j - w.alpha) * cof
    return ddot(stress, grad(v))


@skfem.BilinearForm
def _tangent(du, v, w):
    """dP[∇δu] : ∇v, with d cof F[δF] = tr(F⁻¹ δF) cof F − cof F δFᵀ F⁻ᵀ; the state's fields come from
    :func:`_tangent_fields`, so that they are computed once per assembly, not once per pair of basis functions."""
    f, cof, inv_t = w.F, w.cof, w.inv_t
    d_f, g = grad(du), grad(v)
    d_cof = ddot(inv_t, d_f) * cof - mul(mul(cof, transpose(d_f)), inv_t)
    return (w.shear * ddot(d_f, g) + w.stiffening * ddot(f, d_f) * ddot(f, g)
            + w.lam * ddot(cof, d_f) * ddot(cof, g) + w.volumetric * ddot(d_cof, g))


def _tangent_fields(basis, u, mu, lam, alpha) -> dict:
    """The state-dependent fields of :func:`_tangent` at the quadrature points of ``basis`` for the dofs ``u``."""
    f, j, i_c, cof, inv_t = _kinematics({"u": basis.interpolate(u)})
    return dict(F=f, cof=cof, inv_t=inv_t, shear=mu * (1.0 - 1.0 / (i_c + 1.0)),
                stiffening=2.0 * mu / (i_c + 1.0) ** 2, volumetric=lam * (j - alpha), lam=lam)


def assemble_tangent(basis, u, youngs_modulus: float, poisson_ratio: float):
    """The tangent stiffness ∂r/∂u [N/m] ``(N, N)`` CSR at the dofs ``u`` ``(N,)`` [m]."""
    return skfem.asm(_tangent, basis, **_tangent_fields(basis, u, *neo_hookean_constants(youngs_modulus,
                                                                                            poisson_ratio)))


def linear_stiffness(basis, youngs_modulus: float, poisson_ratio: float):
    """K at rest [N/m] ``(N, N)`` CSR: the tangent at u = 0, which is Hooke's law with (E, ν) by construction."""
    return assemble_tangent(basis, basis.zeros(), youngs_modulus, poisson_ratio)


def newton(basis, fixed_dofs, load, youngs_modulus, poisson_ratio, *, tolerance=1e-10, max_iterations=15,
           steps=1, initial=None, solve=None, progress=None):
    """Equilibrium of the stable neo-Hookean body under the dead nodal load ``load`` ``(N,)`` [N] (skfem dofs) with
    ``fixed_dofs`` at zero: ``(N,)`` displacement [m].

    Newton with an energy line search (Armijo, halving), the load applied in ``steps`` equal increments from
    ``initial`` = ``(u, its load)`` (default: rest, no load); an increment that does not converge is halved (at most
    8 times). Converged when the free residual's norm is at most ``tolerance`` × the load's. ``solve(K_ff, r_f) ->
    (f,)`` solves the linear systems (default SuperLU).
    """
    mu, lam, alpha = neo_hookean_constants(youngs_modulus, poisson_ratio)
    params = dict(mu=mu, lam=lam, alpha=alpha)
    free = np.setdiff1d(np.arange(basis.N), fixed_dofs)
    solve = solve or (lambda k, r: spla.spsolve(k.tocsc(), r))
    u, start = (basis.zeros(), np.zeros_like(load)) if initial is None else (initial[0].copy(), initial[1])
    scale = np.linalg.norm(load[free])

    def loading(fraction):
        return start + fraction * (load - start)

    def total(u, fraction):
        return skfem.asm(_energy, basis, u=basis.interpolate(u), **params) - loading(fraction) @ u

    reached, increment = 0.0, 1.0 / steps
    while reached < 1.0 - 1e-12:
        fraction = min(1.0, reached + increment)
        trial = _newton_increment(basis, free, loading(fraction), fraction, u, params, total, scale, tolerance,
                                  max_iterations, solve)
        if trial is None:
            increment *= 0.5
            if increment < 1.0 / (steps * 2 ** 8):
                raise RuntimeError(f"Newton failed at load fraction {fraction:.4g}")
            continue
        u, reached = trial, fraction
        if progress is not None:
            progress(f"load fraction {reached:.4g}")
    return u


def _newton_increment(basis, free, load, fraction, u, params, total, scale, tolerance, max_iterations, solve):
    """Newton under ``load`` (at ``fraction`` of the path) from ``u``; the converged displacement, or None."""
    u = u.copy()
    for _ in range(max_iterations):
        state = basis.interpolate(u)
        residual = skfem.asm(_residual, basis, u=state, **params) - load
        if np.linalg.norm(residual[free]) <= tolerance * scale:
            return u
        tangent = skfem.asm(_tangent, basis, **_tangent_fields(basis, u, **params))
        step = np.zeros_like(u)
        step[free] = solve(tangent[free][:, free], -residual[free])
        if not np.all(np.isfinite(step)):
            return None
        slope, before, length = residual @ step, total(u, fraction), 1.0
        while length > 1e-4:
            after = total(u + length * step, fraction)
            # Near convergence the energies differ by round-off only: a full Newton step is then taken.
            if np.isfinite(after) and (after <= before + 1e-4 * length * slope or abs(slope) < 1e-14 * abs(before)):
                break
            length *= 0.5
        else:
            return None
        u += length * step
    return None


def p1_basis(points, tets):
    return skfem.Basis(skfem.MeshTet(np.asarray(points, float).T, np.asarray(tets, np.int64).T),
                       skfem.ElementVector(skfem.ElementTetP1()))


def skfem_neo_hookean(points, tets, fixed_nodes, nodal_forces, youngs_modulus, poisson_ratio, **options):
    """``(n, 3) float64`` displacement [m] of the P1-tet body ``points`` ``(n, 3)`` [m], ``tets`` ``(m, 4)`` under
    dead ``nodal_forces`` ``(n, 3)`` [N], ``fixed_nodes`` ``(k,)`` held at rest; options go to :func:`newton`."""
    basis = p1_basis(points, tets)
    order = basis.nodal_dofs.T.ravel()   # our dof 3 i + c is skfem dof order[3 i + c]
    load = np.zeros(basis.N)
    load[order] = np.asarray(nodal_forces, dtype=np.float64).ravel()
    u = newton(basis, basis.nodal_dofs[:, np.asarray(fixed_nodes)].ravel(), load, youngs_modulus, poisson_ratio,
               **options)
    return u[order].reshape(-1, 3)


# --- homogeneous uniaxial tension against the analytic stretch ---------------------------------------------------

def uniaxial_stretches(traction: float, youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """``(axial s, lateral a)`` of F = diag(a, a, s) under the nominal axial traction [Pa] with free lateral faces:
    P_33 = t and P_11 = 0 (a > 0) of the energy above (J = a² s, I_C = 2a² + s², cof F = diag(a s, a s, a²))."""
    mu, lam, alpha = neo_hookean_constants(youngs_modulus, poisson_ratio)

    def equations(x):
        a, s = x
        j, i_c = a * a * s, 2 * a * a + s * s
        shear = mu * (1.0 - 1.0 / (i_c + 1.0))
        # P_11 / a: the root a = 0 of P_11 itself is not a deformation.
        return [(shear + lam * (j - alpha) * s) / mu, (shear * s + lam * (j - alpha) * a * a - traction) / mu]

    guess = 1.0 + traction / youngs_modulus
    solution = scipy.optimize.root(equations, [1.0 - poisson_ratio * (guess - 1.0), guess], tol=1e-13)
    # The equations are scaled by μ: a residual of 1e-12 puts the stretches within ~1e-12 of the root.
    assert np.abs(equations(solution.x)).max() <= 1e-12
    return float(solution.x[1]), float(solution.x[0])


@pytest.mark.parametrize("traction", [-0.2 * E, 0.05 * E, 0.5 * E, 2.0 * E])
def test_uniaxial_tension_equals_the_analytic_stretch(traction):
    side = 0.02   # a 2 cm block, refined so that rollers and the traction load many nodes
    mesh = skfem.MeshTet.init_tensor(*(np.linspace(0.0, side, 4),) * 3)
    basis = skfem.Basis(mesh, skfem.ElementVector(skfem.ElementTetP1()))
    # Rollers: each of the faces x = 0, y = 0, z = 0 holds only its normal component.
    fixed = np.concatenate([basis.get_dofs(lambda x, c=c: np.isclose(x[c], 0.0)).nodal[f"u^{c + 1}"]
                            for c in range(3)])
    top = skfem.FacetBasis(mesh, basis.elem, facets=mesh.facets_satisfying(lambda x: np.isclose(x[2], side)))
    # A uniform dead traction as nodal forces: for P1 triangles the consistent load, a third of each area per node.
    load = skfem.asm(skfem.LinearForm(lambda v, w: traction * v[2]), top)
    u = newton(basis, fixed, load, E, NU)
    axial, lateral = uniaxial_stretches(traction, E, NU)
    points = mesh.p.T
    deformed = points + u[basis.nodal_dofs.T]
    expected = points * [lateral, lateral, axial]
    # The homogeneous field is in the P1 space, so the FE answer is exact up to the Newton tolerance (1e-10).
    assert np.abs(deformed - expected).max() <= 1e-6 * side * max(abs(axial - 1.0), abs(lateral - 1.0))


def test_small_traction_gives_hookes_law():
    # The energy linearises to Hooke's law with (E, ν): strain t/E axially, −ν t/E laterally, to first order.
    traction = 1e-4 * E
    axial, lateral = uniaxial_stretches(traction, E, NU)
    # Second-order terms are (t/E)² ~ 1e-8 against first-order terms of 1e-4: a relative 1e-3 bounds them.
    assert axial - 1.0 == pytest.approx(traction / E, rel=1e-3)
    assert lateral - 1.0 == pytest.approx(-NU * traction / E, rel=1e-3)


# --- the library's nonlinear FEM on identical meshes -------------------------------------------------------------

def cube_mesh(resolution: int = 150, switches: str = "pq1.4Q") -> TetMesh:
    surface = models.cube(resolution)
    points, tets = tetgen.TetGen(surface.vertices, surface.triangles).tetrahedralize(switches=switches)[:2]
    return TetMesh(points, tets)


def patch_load(mesh: TetMesh, total_newtons: float, radius: float) -> np.ndarray:
    """``(n, 3)`` [N]: ``total_newtons`` along +z shared equally by the top nodes within ``radius`` of the top
    centre (a pin-head-like patch)."""
    points = mesh.points
    top = np.isclose(points[:, 2], points[:, 2].max())
    centre = np.array([*0.5 * (points[:, :2].min(axis=0) + points[:, :2].max(axis=0)), points[:, 2].max()])
    patch = np.flatnonzero(top & (np.linalg.norm(points - centre, axis=1) <= radius))
    forces = np.zeros((mesh.node_count, 3))
    forces[patch, 2] = total_newtons / len(patch)
    return forces


# 0.5 N moves the patch by about 2 mm, 5 N by about 24 mm (30 % of the 8 cm cube).
@pytest.mark.parametrize("newtons", [0.5, 5.0])
def test_library_neo_hookean_equals_scikit_fem(newtons):
    mesh = cube_mesh()
    fixed = bottom_nodes(mesh.points)
    forces = patch_load(mesh, newtons, radius=0.012)
    expected = skfem_neo_hookean(mesh.points, mesh.tets, fixed, forces, E, NU, steps=4)
    fem = NonlinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=fixed, material="neo-hookean")
    u = fem.solve(forces)
    # Both solve the same discrete equations to a tight residual: they agree to 1e-6 of the largest displacement.
    assert np.abs(u - expected).max() <= 1e-6 * np.abs(expected).max()


def test_large_load_is_not_linear():
    # The reference solver itself: at 5 N over a 12 mm patch the answer is far from linear (so the comparison above
    # compares finite strain, not a linear answer twice), and at 0.05 N it is linear to first order.
    mesh = cube_mesh()
    fixed = bottom_nodes(mesh.points)
    basis = p1_basis(mesh.points, mesh.tets)
    order = basis.nodal_dofs.T.ravel()
    k = linear_stiffness(basis, E, NU)
    free = np.setdiff1d(np.arange(basis.N), basis.nodal_dofs[:, fixed].ravel())
    differences = []
    for newtons in (0.05, 5.0):
        forces = patch_load(mesh, newtons, radius=0.012)
        u = skfem_neo_hookean(mesh.points, mesh.tets, fixed, forces, E, NU, steps=4)
        load, linear = np.zeros(basis.N), np.zeros(basis.N)
        load[order] = forces.ravel()
        linear[free] = spla.spsolve(k[free][:, free].tocsc(), load[free])
        linear = linear[order].reshape(-1, 3)
        differences.append(np.linalg.norm(u - linear) / np.linalg.norm(linear))
    # 0.05 N moves the patch by 0.2 mm, 2 % of its radius: the nonlinear part is of that order (bound 5 %); 5 N
    # moves it by 24 mm, twice its radius: bound 10 %.
    assert differences[0] < 0.05 and differences[1] > 0.10


def test_tangent_at_rest_is_scikit_fems_linear_elasticity():
    # The energy's constants are chosen so that it linearises to Hooke's law with (E, ν): the tangent at u = 0
    # equals scikit-fem's own linear elasticity form, to round-off (entries ~1e3 N/m, summed over a few tets).
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = cube_mesh()
    basis = p1_basis(mesh.points, mesh.tets)
    expected = skfem.asm(linear_elasticity(*lame_parameters(E, NU)), basis)
    assert abs(linear_stiffness(basis, E, NU) - expected).max() <= 1e-12 * abs(expected).max()


# --- the shipped finite-strain contact reference ----------------------------------------------------------------

def test_shipped_reference_matches_the_contact_protocol():
    reference = load_finite_reference()
    surface = builtin_surface("cube")
    node = protocol.load_node(surface.vertices, surface.triangles)
    # The same model, load node, samples and radius as the contact protocol's cases (assigned values: exact).
    assert reference.model == "cube" and reference.load_node == node
    assert reference.radius_mm in contact_protocol.RADII_MM
    assert np.array_equal(reference.samples, protocol.sample_nodes(surface.vertices, node, protocol.RMSE_SAMPLES))
    assert reference.forces == FORCES_N
    assert (reference.youngs_modulus, reference.poisson_ratio) == (E, NU)
    # Converged means every load's last change is below the tolerance, and the levels say the same.
    assert reference.converged == all(c is not None and c < reference.tolerance for c in reference.changes.values())
    assert len(reference.levels) >= 2    # a change needs two levels
    assert reference.levels[-1]["change"] == {f"{f:g}": c for f, c in reference.changes.items()}


def test_shipped_reference_is_physical():
    reference = load_finite_reference()
    lifts = [reference.displacements[f][0, 2] for f in reference.forces]
    assert np.all(np.diff(lifts) > 0) and lifts[0] > 0     # a pull lifts the load node, more for more force
    for force in reference.forces:
        # The linear answer is linear in the force: the stored ones are one solution scaled (round-off of the JSON
        # text, which keeps 17 digits).
        scaled = reference.linear[force] / force
        assert np.abs(scaled - reference.linear[0.1] / 0.1).max() <= 1e-12 * np.abs(scaled).max()
    # Finite strain departs from linear with the strain near the patch: 0.1 N is a mean traction of 0.7 μ over the
    # 4 mm patch, strains of tens of % at its rim, so a difference of several % (bound 10 %); 5 N is 35 μ, more than
    # 10 %; and the difference grows with the force.
    difference = {f: relative_difference(reference.displacements[f], reference.linear[f]) for f in reference.forces}
    assert difference[0.1] < 0.10 and difference[5.0] > 0.10
    assert np.all(np.diff([difference[f] for f in reference.forces]) > 0)


def relative_difference(values, reference) -> float:
    """RMS over the samples of |values − reference| over the RMS of |reference| (the protocol's relative RMSE)."""
    return float(np.sqrt(np.sum((values - reference) ** 2) / np.sum(reference ** 2)))


def test_missing_or_foreign_reference_is_refused(tmp_path):
    missing = tmp_path / "finite_strain_reference.json"
    with pytest.raises(SolverError, match="is missing.*finite_strain_reference.py"):
        load_finite_reference(missing)
    missing.write_text('{"schema": "tissuesim-contact/1"}')
    with pytest.raises(SolverError, match="schema 'tissuesim-contact/1'"):
        load_finite_reference(missing)


@pytest.mark.slow
def test_reference_problem_is_the_linear_contact_references():
    # The generator's mesh, support and load at level 0 (the default fine volume) are those of the linear contact
    # reference: its linear answer equals the library's quadratic tets under the same traction, to solver round-off.
    import importlib.util
    from pathlib import Path

    from tissuesim.experiments.reference import RefinementSettings
    from tissuesim.fem.quadratic import QuadraticFEM
    from tissuesim.mesh.regions import bottom_height, nodes_below

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "finite_strain_reference.py"
    spec = importlib.util.spec_from_file_location("finite_strain_reference", path)
    generator = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generator)
    surface = builtin_surface("cube")
    node = protocol.load_node(surface.vertices, surface.triangles)
    radius = 1e-3 * generator.RADIUS_MM
    basis, unit_load, fixed, _ = generator.level_problem(surface, node, radius, 0, RefinementSettings())
    free = np.setdiff1d(np.arange(basis.N), fixed)
    u = np.zeros(basis.N)
    u[free] = spla.spsolve(linear_stiffness(basis, E, NU)[free][:, free].tocsc(), unit_load[free])
    mesh = TetMesh(basis.mesh.p.T, basis.mesh.t.T)
    height = bottom_height(surface.vertices)
    fem = QuadraticFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=lambda points: nodes_below(points, height))
    triangles = basis.mesh.facets[:, basis.mesh.boundary_facets()].T
    centroids = mesh.points[triangles].mean(axis=1)
    triangles = triangles[np.linalg.norm(centroids - surface.vertices[node], axis=1) <= radius]
    areas = 0.5 * np.linalg.norm(np.cross(*(mesh.points[triangles[:, k]] - mesh.points[triangles[:, 0]]
                                            for k in (1, 2))), axis=1)
    forces = np.zeros((fem.node_count, 3))
    forces[:, 2] = fem.traction_weights(triangles, areas / areas.sum())
    expected = fem.solve(forces)[: mesh.node_count]
    ours = u[basis.nodal_dofs.T]
    # Two direct solves of the same SPD system (condition ~1e8): agreement to 1e-8 of the largest displacement.
    assert np.abs(ours - expected).max() <= 1e-8 * np.abs(expected).max()
