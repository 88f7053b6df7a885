"""Each method's error against the shipped converged finite-strain reference of the cube's pulls, linear beside
finite strain (the table of docs/finite-strain.md).

Relative RMSE (eq 26 over the reference's 50 samples, divided by the reference's RMS displacement) per pull force
and method, for material="linear" and the finite-strain material; the row "linear reference" is the linear answer
on the reference's own mesh against the finite one (what no small-strain method can beat). Also: each method's
error against the linear reference at the smallest load, the yardstick of the target (finite-strain error ≤
1.1× that). The hybrid's near field (W = 15 mm) is included with --near-field (its quadratic Newton takes minutes).
A method that has no finite-strain material (pbd: a surface has no volume) gets its linear row only, and its
finite-strain row says it is skipped and why.

    python benchmarks/finite_strain_errors.py [--material neo-hookean] [--near-field]
"""

from __future__ import annotations

import argparse

import numpy as np

from tissuesim import HybridMesh, make_solver, models
from tissuesim.experiments.finite_reference import load_finite_reference
from tissuesim.experiments.protocol import relative_rmse
from tissuesim.fem.hyperelastic import MATERIALS
from tissuesim.solvers.near_field import NEAR_FIELD_WINDOW
from tissuesim.solvers.registry import solver_class

METHODS = {"hybrid": ("hybrid", {}), "hybrid-quadratic": ("hybrid", {"element": "quadratic"}),
           "hybrid-near": ("hybrid", {"near_field": NEAR_FIELD_WINDOW}),
           "fem": ("fem", {}), "embedded": ("embedded", {}), "pbd": ("pbd", {})}


def errors_against(reference_field: dict, answers: dict, rest: np.ndarray, samples: np.ndarray) -> dict:
    """``{force: relative RMSE}`` of M_S ``answers`` ``{force: (n, 3) positions}`` against sample displacements."""
    errors = {}
    for force, positions in answers.items():
        target = rest.copy()
        target[samples] += reference_field[force]
        errors[force] = relative_rmse(positions, target, rest, samples)
    return errors


def parse(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--material", default="neo-hookean", choices=MATERIALS[1:],
                        help="the finite-strain material beside linear (default neo-hookean)")
    parser.add_argument("--near-field", action="store_true")
    return parser.parse_args(argv)


def rows(material: str, near_field: bool) -> list[tuple[str, str, dict, str, str | None]]:
    """The table's rows: ``(name, method, options, material, skipped)`` for each method (the near field with
    ``near_field``) and each of linear and ``material``; ``skipped`` says why a method that does not take that
    material has no answer (None where it has)."""
    table = []
    for name, (method, options) in METHODS.items():
        if name == "hybrid-near" and not near_field:
            continue
        for kind in ("linear", material):
            taken = solver_class(method).materials
            skipped = None if kind in taken else (f"skipped: the {method} method takes only "
                                                  f"{' or '.join(taken)}, it has no volume for finite strain")
            table.append((name, method, options, kind, skipped))
    return table


def main(argv=None) -> int:
    args = parse(argv)
    reference = load_finite_reference()
    hybrid = HybridMesh.build(models.model(reference.model))
    rest = hybrid.surface.vertices
    samples, node, radius = reference.samples, reference.load_node, 1e-3 * reference.radius_mm
    forces = reference.forces
    print(f"{reference.model}, pull over R = {reference.radius_mm:g} mm at node {node}; reference converged: "
          f"{reference.converged} (last change {max(reference.changes.values()):.3f})")
    print("relative RMSE against the finite-strain reference, per force [N]: " + "  ".join(f"{f:>6g}" for f in forces))
    linear_ref = errors_against(reference.displacements,
                                {f: _placed(rest, samples, reference.linear[f]) for f in forces}, rest, samples)
    print(f"  {'linear reference':28}" + "  ".join(f"{linear_ref[f]:6.3f}" for f in forces))
    for name, method, options, material, skipped in rows(args.material, args.near_field):
        label = f"  {name + ', ' + material:28}"
        if skipped:
            print(label + skipped)
            continue
        solver = make_solver(method, hybrid, material=material, **options)
        answers = {f: solver.solve_static(node, (0.0, 0.0, f), radius=radius) for f in forces}
        finite = errors_against(reference.displacements, answers, rest, samples)
        against_linear = errors_against(reference.linear, {forces[0]: answers[forces[0]]}, rest, samples)
        print(label + "  ".join(f"{finite[f]:6.3f}" for f in forces)
              + f"   (vs the linear reference at {forces[0]:g} N: {against_linear[forces[0]]:.3f})")
    return 0


def _placed(rest: np.ndarray, samples: np.ndarray, displacement: np.ndarray) -> np.ndarray:
    positions = rest.copy()
    positions[samples] += displacement
    return positions


if __name__ == "__main__":
    raise SystemExit(main())
