"""The figure of docs/finite-strain.md: the cube under a 5 N pull over an 8 mm tip, linear against finite strain,
for the fine-volume FEM and the hybrid.

    python benchmarks/figure_finite_strain.py [--output docs/figures/finite_strain.png]
"""

from __future__ import annotations

import argparse

from tissuesim import HybridMesh, make_solver, models
from tissuesim.experiments.protocol import load_node
from tissuesim.viewer.figures import compose, render_panels

FORCE_N, RADIUS = 5.0, 0.008


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="docs/figures/finite_strain.png")
    args = parser.parse_args(argv)
    hybrid = HybridMesh.build(models.cube())
    rest, triangles = hybrid.surface.vertices, hybrid.surface.triangles
    node = load_node(rest, triangles)
    frames, captions = [], []
    for method in ("fem", "hybrid"):
        for material in ("linear", "neo-hookean"):
            solver = make_solver(method, hybrid, material=material)
            frames.append(solver.solve_static(node, (0.0, 0.0, FORCE_N), radius=RADIUS))
            captions.append(f"{method}, {material}")
    images, vmax = render_panels(rest, triangles, frames, markers=[node] * len(frames))
    compose(images, captions, f"cube, {FORCE_N:g} N pull over an {1e3 * RADIUS:g} mm tip: linear against finite "
            "strain (E = 5500 Pa, ν = 0.3)", vmax, args.output)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
