"""A converged finite-strain reference for the contact protocol's pull cases, computed independently of the library.

The default cube, its load node and 50 sample nodes as the contact protocol (:mod:`tissuesim.experiments.protocol`),
the stable neo-Hookean energy (Smith, de Goes & Kim 2018) with E = 5500 Pa, ν = 0.3, on scikit-fem's quadratic
tets (the Newton solver of tests/validation/test_finite_strain_skfem.py, which is checked there against the analytic
uniaxial stretch). The meshes are the linear contact reference's levels (:mod:`tissuesim.experiments.reference`:
M_S refined around the contact, TetGen, its vertices the first nodes) and so are the load (a uniform dead traction
on the surface triangles whose centroid lies within R of the load node, R = 4 mm: the contact protocol's tip
radius, ``solve_static(node, f, radius=R)``) and the support (the nodes at or below the bottom height, midsides
included). Tension (+z) at :data:`FORCES_N`, each load reached from the previous one's answer.

Levels are refined until every load's sample displacements change by less than 2 % (RMS over the samples of
|u_ℓ − u_ℓ₋₁| over the RMS of |u_ℓ|), or until a level takes longer than the time budget. Each level also solves
the linear problem (the tangent at rest: Hooke's law with the same E, ν) with the same load on the same mesh.

Measured on 2 shared cores: levels 0–2 (8.8k–13k tets, 44k–63k dofs) in 3, 6 and 12 minutes, the change at level 2
4.3–5.3 % (the linear answer's own change there: 4.6 %), so the shipped reference stops there, unconverged by the
2 % criterion. Resumed at level 3 (24.5k tets, 115k dofs), 0.1–1 N converge but the 1 → 2 N path stalls near 1.9 N
(increments halved to 1/64 N, 20 minutes): the level is not stored.

Writes src/tissuesim/experiments/data/finite_strain_reference.json (read by
:mod:`tissuesim.experiments.finite_reference`). Run: python benchmarks/finite_strain_reference.py [--max-level 4]
"""

import argparse
import datetime as dt
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import skfem

from tissuesim.errors import SolverError
from tissuesim.experiments import protocol
from tissuesim.experiments.finite_reference import DATA_FILE, FORCES_N, RADIUS_MM, SCHEMA
from tissuesim.experiments.inputs import builtin_surface
from tissuesim.experiments.reference import RefinementSettings, _edge_length_at, _level_volume
from tissuesim.fem.factorise import factorise_spd
from tissuesim.mesh.regions import bottom_height, nodes_below

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from test_finite_strain_skfem import linear_stiffness, newton  # noqa: E402  (the validated solver)

E, NU = 5500.0, 0.3
TOLERANCE = 0.02
LEVEL_BUDGET_S = 480.0
MAX_INCREMENT_N = 0.5
# The 4-point rule of degree 2, as the library's quadratic tets: exact for the linear stiffness.
QUADRATURE_ORDER = 2


def level_problem(surface, node, radius, level, settings):
    """``(basis, unit_load (N,), fixed_dofs, tets)`` of one level: P2 vector basis on the level's volume, a 1 N
    uniform traction along +z on the patch's surface triangles, the support's dofs."""
    rest = np.asarray(surface.vertices, dtype=np.float64)
    _, volume, _ = _level_volume(surface, rest[node], radius, _edge_length_at(surface, node), level, settings)
    mesh = skfem.MeshTet(np.ascontiguousarray(volume.points.T), np.ascontiguousarray(volume.tets.T))
    element = skfem.ElementVector(skfem.ElementTetP2())
    basis = skfem.Basis(mesh, element, intorder=QUADRATURE_ORDER)
    boundary = mesh.boundary_facets()
    centroids = mesh.p[:, mesh.facets[:, boundary]].mean(axis=1).T
    patch = boundary[np.linalg.norm(centroids - rest[node], axis=1) <= radius]
    facets = skfem.FacetBasis(mesh, element, facets=patch)
    area = skfem.asm(skfem.Functional(lambda w: 1.0 + 0.0 * w.x[0]), facets)
    unit_load = skfem.asm(skfem.LinearForm(lambda v, w: v[2] / area), facets)
    fixed = nodes_below(basis.doflocs.T, bottom_height(rest))   # every dof located on the support, midsides too
    return basis, unit_load, fixed, len(volume.tets)


def spd_solver(dof_point, say):
    """``solve(K_ff, r_f)``: CHOLMOD in a nested-dissection order (``dof_point`` ``(f,)``: the point of each free
    dof), as the library's linear solves. Where the tangent is not positive definite (a large pull folds the rim
    of the patch on the way), its diagonal is raised by a factor until it is (Levenberg–Marquardt): the step stays
    a descent direction of the energy, and the answer is still the zero of the residual."""
    def solve(matrix, rhs):
        matrix, shift = matrix.tocsc(), 0.0
        while True:
            try:
                return factorise_spd(matrix + shift * sp.diags(matrix.diagonal()), dof_point).solve(rhs)
            except SolverError:
                shift = 1e-4 if shift == 0.0 else 10.0 * shift
                say(f"    tangent not positive definite: diagonal raised by {shift:g}")

    return solve


def solve_level(surface, node, samples, level, settings, say):
    """One level: ``{tets, dofs, seconds, finite: {F: (50, 3)}, linear: {F: (50, 3)}}``."""
    start = time.perf_counter()
    basis, unit_load, fixed, tets = level_problem(surface, node, 1e-3 * RADIUS_MM, level, settings)
    free = np.setdiff1d(np.arange(basis.N), fixed)
    solve = spd_solver(np.unique(basis.doflocs.T, axis=0, return_inverse=True)[1].ravel()[free], say)
    vertex_dofs = basis.nodal_dofs[:, samples].T     # M_S's vertices are the volume's first nodes
    say(f"level {level}: {tets} tets, {basis.N} dofs")
    stiffness = linear_stiffness(basis, E, NU)[free][:, free]
    unit = np.zeros(basis.N)
    unit[free] = solve(stiffness, unit_load[free])
    finite, linear, u, previous = {}, {}, basis.zeros(), 0.0
    for force in FORCES_N:
        t = time.perf_counter()
        # A path from the previous answer in increments of at most MAX_INCREMENT_N (a linear extrapolation as the
        # start measured slower: its first residual is larger than the previous answer's). An increment converges
        # in 5–7 iterations or not at all (then it is halved; 1 N increments were, from 1 N on, at levels 0–2).
        steps = int(np.ceil((force - previous) / MAX_INCREMENT_N - 1e-9))
        u = newton(basis, fixed, force * unit_load, E, NU, tolerance=1e-9, steps=steps, max_iterations=10,
                   initial=(u, previous * unit_load), solve=solve,
                   progress=lambda line: say(f"  {force:g} N: {line} ({time.perf_counter() - t:.0f} s)"))
        previous = force
        finite[force], linear[force] = u[vertex_dofs], force * unit[vertex_dofs]
        say(f"  {force:g} N: sample RMS {1e3 * rms(finite[force]):.3f} mm (linear {1e3 * rms(linear[force]):.3f})"
            f", {time.perf_counter() - t:.0f} s")
    return {"tets": tets, "dofs": int(basis.N), "seconds": time.perf_counter() - start, "finite": finite,
            "linear": linear}


def rms(values) -> float:
    return float(np.sqrt(np.mean(np.sum(np.asarray(values) ** 2, axis=1))))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-level", type=int, default=4)
    parser.add_argument("--output", type=Path, default=DATA_FILE)
    parser.add_argument("--resume", action="store_true",
                        help="go on from the last level stored in --output instead of level 0")
    args = parser.parse_args(argv)
    say = (lambda text: print(text, flush=True))
    surface = builtin_surface("cube")
    rest = np.asarray(surface.vertices, dtype=np.float64)
    node = protocol.load_node(rest, surface.triangles)
    samples = protocol.sample_nodes(rest, node, protocol.RMSE_SAMPLES)
    settings = RefinementSettings()
    levels, last = ([], None) if not args.resume else stored_levels(args.output)
    for level in range(len(levels), args.max_level + 1):
        result = solve_level(surface, node, samples, level, settings, say)
        change = None if last is None else {f: rms(result["finite"][f] - last["finite"][f]) / rms(result["finite"][f])
                                            for f in FORCES_N}
        levels.append({"level": level, "tets": result["tets"], "dofs": result["dofs"],
                       "seconds": round(result["seconds"], 1),
                       "change": None if change is None else {f"{f:g}": c for f, c in change.items()}})
        say(f"level {level} done in {result['seconds']:.0f} s; change "
            + ("–" if change is None else ", ".join(f"{f:g} N {100 * c:.2f} %" for f, c in change.items())))
        last = result
        write(args.output, node, samples, levels, last, surface.vertex_count)   # a level at a time: --resume
        if change is not None and max(change.values()) < TOLERANCE:
            break
        if result["seconds"] > LEVEL_BUDGET_S:
            say(f"level {level} took more than {LEVEL_BUDGET_S:.0f} s: stopped unconverged")
            break


def stored_levels(path):
    """``(levels, last)`` of a stored reference, ``last`` holding its samples' displacements as :func:`solve_level`."""
    document = json.loads(path.read_text())
    entries = document["forces"].values()
    last = {key: {e["force_N"]: np.asarray(e[name]) for e in entries}
            for key, name in (("finite", "displacements"), ("linear", "linear"))}
    return document["levels"], last


def write(path, node, samples, levels, last, vertex_count):
    change = levels[-1]["change"]
    document = {
        "schema": SCHEMA, "date": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "model": "cube", "surface_vertices": int(vertex_count), "load_node": int(node), "load": "tension",
        "radius_mm": RADIUS_MM, "youngs_modulus": E, "poisson_ratio": NU,
        "material": "stable neo-Hookean (Smith, de Goes & Kim 2018)", "element": "quadratic tets (scikit-fem P2)",
        "tolerance": TOLERANCE, "converged": change is not None and max(change.values()) < TOLERANCE,
        "samples": [int(i) for i in samples], "levels": levels,
        "forces": {f"{f:g}": {"force_N": f, "displacements": last["finite"][f].tolist(),
                              "linear": last["linear"][f].tolist(),
                              "change": None if change is None else change[f"{f:g}"]} for f in FORCES_N},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
