"""FEM benchmark: assembly vs scikit-fem, factorisation (ours vs the former SuperLU + minimum degree), and the
point-load fast path vs a full solve. A few minutes in all (TetGen meshes up to ~100k tets).

Prints figures and ratios; asserts nothing about time. Run: python benchmarks/bench_fem.py [--quick]
"""

import argparse
import time

import numpy as np
import scipy.sparse.linalg as spla
import tetgen

from tissuesim.fem.assembly import assemble_stiffness
from tissuesim.fem.factorise import factorise_spd
from tissuesim.fem.linear import LinearFEM
from tissuesim.fem.material import Material
from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_nodes
from tissuesim.mesh.tetmesh import TetMesh


def sphere_volume(target_tets: int) -> TetMesh:
    """TetGen quality mesh of the built-in sphere with a max-volume bound giving about ``target_tets`` tets."""
    surface = models.sphere(max(200, min(4000, target_tets // 6)))
    volume = abs(surface.signed_volume)
    a = 1.9 * volume / target_tets  # TetGen lands at about 0.55 × (volume / bound) tets with q1.4
    points, tets = tetgen.TetGen(surface.vertices, surface.triangles).tetrahedralize(switches=f"pq1.4a{a:.3e}Q")[:2]
    return TetMesh(points, tets)


def best(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return min(times), result


def assembly_vs_skfem(mesh: TetMesh, large: bool):
    """Assembly vs scikit-fem, our factorisation vs the former SuperLU + minimum degree, and scikit-fem's
    condense + solve. ``large``: scikit-fem's assembly timed once, the former SuperLU route and scikit-fem's solve
    (SuperLU with COLAMD) skipped — they take far longer than the rest of the benchmark at ~100k tets."""
    import skfem
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    material = Material()
    t_ours, k = best(lambda: assemble_stiffness(mesh, material))
    form = linear_elasticity(*lame_parameters(material.youngs_modulus, material.poisson_ratio))

    def theirs():
        basis = skfem.Basis(skfem.MeshTet(mesh.points.T, mesh.tets.T), skfem.ElementVector(skfem.ElementTetP1()))
        return skfem.asm(form, basis), basis

    t_skfem, (k_ref, basis) = best(theirs, repeat=1 if large else 3)
    fixed = bottom_nodes(mesh.points)
    t_fem, fem = best(lambda: LinearFEM(mesh, fixed=fixed), repeat=1)
    t_factor, _ = best(lambda: factorise_spd(fem.reduced_stiffness, fem.free_dofs // 3), repeat=1)
    t_solve, _ = best(lambda: fem.solve(np.tile([0.0, 0.0, -1e-4], (mesh.node_count, 1))))
    line = (
        f"{mesh.element_count:>8} tets {mesh.node_count:>7} nodes {fem.free_dofs.size:>7} dofs | assembly ours "
        f"{t_ours * 1e3:8.1f} ms  skfem {t_skfem * 1e3:8.1f} ms  ratio skfem/ours {t_skfem / t_ours:5.1f} | "
        f"LinearFEM build {t_fem:6.2f} s | factorise ({type(fem.factor).__name__.strip('_')}) {t_factor:6.2f} s | "
        f"back-substitution {t_solve * 1e3:7.2f} ms"
    )
    if large:
        print(line + " | former SuperLU + MMD and skfem solve: skipped", flush=True)
        return
    t_mmd, _ = best(
        lambda: spla.splu(fem.reduced_stiffness, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options={"SymmetricMode": True}), repeat=1)
    # scikit-fem's own route: condense + its default direct solver (SciPy spsolve, SuperLU with COLAMD).
    f = np.zeros(basis.N)
    f[basis.nodal_dofs[2]] = -1e-4
    dofs = basis.nodal_dofs[:, fixed].ravel()
    t_skfem_solve, _ = best(lambda: skfem.solve(*skfem.condense(k_ref, f, D=dofs)), repeat=1)
    print(
        line + f" | former SuperLU + MMD factorise {t_mmd:6.2f} s (ratio {t_mmd / t_factor:5.1f}) | skfem "
        f"condense+solve {t_skfem_solve:6.2f} s ratio skfem/(factorise+solve) "
        f"{t_skfem_solve / (t_factor + t_solve):5.1f}", flush=True
    )


def fast_path(mesh: TetMesh, steps: int = 2000):
    fem = LinearFEM(mesh, fixed=bottom_nodes(mesh.points))
    boundary = mesh.boundary_nodes
    top = boundary[np.argsort(mesh.points[boundary, 2])[-3:]]  # three coarse nodes under a pin-head
    load = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.3], [0.0, 0.0, 0.4]])
    out = np.zeros((boundary.size, 3))
    t = time.perf_counter()
    fem.point_load_response(top, load, output_nodes=boundary, out=out)  # first use: 3 back-substitutions
    t_first = time.perf_counter() - t
    t = time.perf_counter()
    for _ in range(steps):
        fem.point_load_response(top, load, output_nodes=boundary, out=out)
    t_fast = (time.perf_counter() - t) / steps
    forces = np.zeros((mesh.node_count, 3))
    forces[top] = load
    reps = max(5, steps // 20)
    t = time.perf_counter()
    for _ in range(reps):
        u = fem.solve(forces)
    t_full = (time.perf_counter() - t) / reps
    error = np.abs(u[boundary] - out).max() / np.abs(u).max()
    print(
        f"{mesh.element_count:>8} tets {mesh.node_count:>7} nodes {boundary.size:>6} surface (output) nodes | "
        f"fast path {t_fast * 1e6:8.1f} us/step  full solve {t_full * 1e6:9.1f} us/step  "
        f"ratio {t_full / t_fast:7.1f} | first use {t_first * 1e3:6.2f} ms | max rel diff {error:.1e}", flush=True
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small meshes only")
    args = parser.parse_args()
    sizes = [5_000, 20_000] if args.quick else [5_000, 20_000, 100_000]
    meshes = {s: sphere_volume(s) for s in sizes}
    print("== assembly and factorisation vs scikit-fem (TetGen sphere, fixed bottom) ==")
    for s in sizes:
        assembly_vs_skfem(meshes[s], large=s > 50_000)
    print("== fast path (3 loaded nodes, output = all boundary nodes) vs full back-substitution ==")
    for s in [1_500, *sizes]:
        fast_path(meshes.get(s) or sphere_volume(s))


if __name__ == "__main__":
    main()
