"""The incision figures of docs/incision.md: the wound of a straight stroke, opened by a pull and by a prestrain.

    python benchmarks/wound_figures.py [--output docs/figures] [--models cube liver steak]

Writes, per model:

* ``incision_<model>.png``: the Fig 16 incision (tissuesim.viewer.figures.incision_figure), closed and pulled open,
  with the wound's walls down to the blade's depth;
* ``wound_prestrain_<model>.png``: the same stroke in a surface prestrained by 5 % (``prestrain=0.05``), at rest
  after the cut: the wound gapes with no force; seen from above and close up. The openings (median and largest) are
  in the caption.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import tissuesim
from tissuesim.experiments.wound import INCISION_DEPTH, scripted_incision, unloaded_openings
from tissuesim.mesh import models
from tissuesim.viewer.figures import compose, incision_figure, render_panels

PRESTRAIN = 0.05


def prestrain_figure(hybrid, name: str, path, *, method: str = "hybrid") -> Path:
    """The stroke in a prestrained surface, closed (at the cut) and at its unloaded equilibrium."""
    from tissuesim.cutting.walls import wound_walls
    from tissuesim.mesh.coincident import coincident_pairs

    solver = tissuesim.make_solver(method, hybrid, prestrain=PRESTRAIN)
    line = scripted_incision(solver)["line"]
    closed = solver.positions.copy()
    openings = unloaded_openings(solver, line)
    triangles = solver.hybrid.surface.triangles
    frames = [closed, solver.positions.copy()]
    pairs = coincident_pairs(solver.rest_positions)
    walls = [wound_walls(x, triangles, pairs, INCISION_DEPTH) for x in frames]
    length = float(np.linalg.norm(line[1] - line[0]))
    focus = 0.5 * (line[0] + line[1]) + np.array([[-0.6, -0.4, -0.2], [0.6, 0.4, 0.1]]) * length
    images, vmax = render_panels(solver.rest_positions, triangles, frames, focus=focus, elevation=60.0, walls=walls)
    captions = ["closed, at the cut", f"opens {1e3 * np.median(openings):.1f} mm (median), "
                f"{1e3 * openings.max():.1f} (max)"]
    title = (f"{name}: {1e3 * length:.0f} mm stroke in a surface prestrained by {100 * PRESTRAIN:g} %, no force, "
             f"{method}")
    return compose(images, captions, title, vmax, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=Path("docs/figures"))
    parser.add_argument("--models", nargs="*", default=["cube", "liver", "steak"])
    args = parser.parse_args()
    args.output.mkdir(parents=True, exist_ok=True)
    for name in args.models:
        hybrid = tissuesim.HybridMesh.build(models.model(name))
        print(incision_figure(hybrid, name, args.output / f"incision_{name}.png"))
        print(prestrain_figure(hybrid, name, args.output / f"wound_prestrain_{name}.png"))


if __name__ == "__main__":
    main()
