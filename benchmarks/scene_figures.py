"""Figures of the example scenes: each run as ``tissuesim run`` runs it, drawn at three moments of its run.

One PNG per scene in docs/figures/ (``scene_<name>.png``): the surface's displacement |u| [mm] colour-mapped at a
third, two thirds and the end of the run, the grasped node marked and the cut edges drawn red. Prints what
each run reported.

Run: python benchmarks/scene_figures.py [--output docs/figures]
"""

import argparse
from pathlib import Path

import numpy as np

from tissuesim.commands.view import scene_hybrid
from tissuesim.recording import border_edges
from tissuesim.scene import Simulation, read_scene
from tissuesim.viewer.figures import compose, render_panels

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCENES = ("probe_block", "hanging_sphere", "liver_retraction")


def scene_figure(name: str, output: Path) -> Path:
    loaded = read_scene(EXAMPLES / f"{name}.toml")
    simulation = Simulation(loaded, scene_hybrid(loaded, progress=False)[0])
    solver, steps = simulation.solver, simulation.steps
    moments = (steps // 3, 2 * steps // 3, steps)
    shots = []

    def shoot(now):
        step = int(round(now / simulation.dt))
        if step in moments:
            pins = [tool.tool.node for tool in simulation.tools if tool.kind == "pin-head" and tool.pressed]
            shots.append((now, solver.positions.copy(), np.array(solver.hybrid.surface.triangles),
                          pins[0] if pins else None))

    summary = simulation.run(on_step=shoot)
    print(f"{name}: " + "; ".join(summary.lines()))
    images, vmax = render_panels(solver.rest_positions, [t for _, _, t, _ in shots], [x for _, x, _, _ in shots],
                                 markers=[m for *_, m in shots], edges=[border_edges(t) for _, _, t, _ in shots])
    captions = [f"t = {time:.2f} s" for time, *_ in shots]
    title = f"{loaded.scene.title} ({loaded.scene.method.name}, {loaded.scene.material.preset or 'paper'} material)"
    return compose(images, captions, title, vmax, output / f"scene_{name}.png")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "figures")
    args = parser.parse_args()
    for name in SCENES:
        print(f"wrote {scene_figure(name, args.output)}")


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    main()
