"""How straight a straight stroke's wound is: the lips' deviation from the blade's trace, per model and angle.

    python benchmarks/wound_straightness.py [--method hybrid] [--models cube sphere liver steak]

For each built-in model and a 30 mm stroke across its top at 0°, 30° and 45° (the scripted incision of
``tissuesim.experiments.wound``, 15 moves), prints the RMS and largest distance of the lips (the new boundary's
vertices, at rest) to the rectangle the blade swept, in mean edge lengths of the uncut surface, the number of lips,
the wound's reach along the stroke (a fraction of its length) and the smallest triangle quality of the cut surface. Target: RMS ≤ 0.05, max ≤ 0.10, quality ≥ 0.1.
"""

from __future__ import annotations

import argparse

import numpy as np

import tissuesim
from tissuesim.experiments.wound import lip_deviation, scripted_incision
from tissuesim.mesh import models

ANGLES = (0.0, 30.0, 45.0)


def measure(method: str, names, angles=ANGLES) -> list[dict]:
    """One row per model and angle: ``{"model", "angle", "rms", "max", "lips", "quality"}``."""
    rows = []
    for name in names:
        hybrid = tissuesim.HybridMesh.build(models.model(name))
        surface = hybrid.surface
        edges = surface.edges
        edge = float(np.linalg.norm(surface.vertices[edges[:, 0]] - surface.vertices[edges[:, 1]], axis=1).mean())
        for angle in angles:
            solver = tissuesim.make_solver(method, hybrid)
            line = scripted_incision(solver, angle=angle)["line"]
            cut = solver.hybrid.surface
            rows.append({"model": name, "angle": angle, **lip_deviation(cut.vertices, cut.triangles, line,
                                                                         edge=edge)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="hybrid")
    parser.add_argument("--models", nargs="*", default=list(models.MODELS))
    args = parser.parse_args()
    print(f"method {args.method}; deviations in mean edge lengths (target RMS ≤ 0.05, max ≤ 0.10, quality ≥ 0.1)")
    print("| model | angle | RMS | max | lips | reach | min quality |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for row in measure(args.method, args.models):
        print(f"| {row['model']} | {row['angle']:.0f}° | {row['rms']:.3f} | {row['max']:.3f} | {row['lips']} | {row['reach']:.2f} | "
              f"{row['quality']:.3f} |")


if __name__ == "__main__":
    main()
