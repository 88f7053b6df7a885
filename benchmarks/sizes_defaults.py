"""The commands' default loads before and after they were sized to the model (:mod:`tissuesim.mesh.sizes`): the
largest displacement over the model's size, on every built-in model and the shared organ meshes, with the hybrid
method held at its bottom tenth.

    PYTHONPATH=src python benchmarks/sizes_defaults.py [--figure docs/figures/sizes_defaults.png]

Per model: the deformation figure's load (before: 5 N on one node; after: the sized force over the sized pin-head,
lowered by ``fitted_force`` where the support lets the body rock), tension and pressure; and the incision figure's
opened wound (before: a 30 mm stroke 10 mm deep and 0.3 N on one node 5 mm beside it; after: the sized stroke,
depth, pull and offset), after the cut. Prints a table and draws the figure; asserts nothing. The shared meshes are
read from ``../shared/data/meshes`` beside the repository (or ``$TISSUESIM_SHARED/data/meshes``).
"""

from __future__ import annotations

import argparse
import os
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from tissuesim.errors import SolverError
from tissuesim.experiments.protocol import LOAD_DIRECTIONS, load_node
from tissuesim.experiments.wound import TOOL_HEIGHT, incision_line, open_wound, pull_node, scripted_incision
from tissuesim.io import read_surface
from tissuesim.mesh.hybrid import HybridMesh
from tissuesim.mesh.models import MODELS, model
from tissuesim.mesh.sizes import fitted_force, load_defaults
from tissuesim.solvers.registry import make_solver

SHARED = Path(os.environ.get("TISSUESIM_SHARED", Path(__file__).resolve().parents[1].parent / "shared"))
#: Shared meshes, their unit as a factor to metres (their README), and whether they need repair.
ORGANS = {"liver2": ("sofa/liver2.obj", 0.01, False), "liver-smooth": ("sofa/liver-smooth.obj", 0.01, True),
          "softbodyliver": ("softbodyliver/liver.obj", 0.01, False),
          "heart": ("sofa/coeur1_heart.obj", 0.001, True)}
BEFORE = {"force": 5.0, "radius": None, "stroke": 0.03, "depth": 0.01, "pull": 0.3, "offset": 0.005}


def surfaces():
    for name in MODELS:
        yield name, model(name)
    for name, (path, scale, repair) in ORGANS.items():
        yield name, read_surface(SHARED / "data" / "meshes" / path, scale=scale, repair=repair)


def deformation(hybrid, force: float, radius) -> float:
    """Largest displacement / size under ``force`` [N] at the figure's node, up and down."""
    solver = make_solver("hybrid", hybrid)
    node = load_node(solver.rest_positions, hybrid.surface.triangles)
    worst = 0.0
    for direction in LOAD_DIRECTIONS.values():
        solver.solve_static(node, force * np.asarray(direction), radius=radius)
        worst = max(worst, solver.largest_displacement / solver.size)
    return worst


def incision(hybrid, loads) -> float:
    """Largest displacement / size of the opened wound, or nan where the stroke does not fit the model."""
    solver = make_solver("hybrid", hybrid)
    try:
        line = scripted_incision(solver, length=loads["stroke"], depth=loads["depth"])["line"]
        open_wound(solver, line, force=loads["pull"], offset=loads["offset"])
    except SolverError:
        return float("nan")
    return solver.largest_displacement / solver.size


def sized(hybrid) -> dict:
    """The sized loads of ``hybrid``, the force and the pull fitted as render fits them."""
    surface = hybrid.surface
    loads = load_defaults(surface.vertices, edge_length=surface.mean_edge_length)
    solver = make_solver("hybrid", hybrid)
    node = load_node(surface.vertices, surface.triangles)
    force, _ = fitted_force(solver, node, loads.force, LOAD_DIRECTIONS.values(), radius=loads.radius)
    pulled = pull_node(surface.vertices, incision_line(surface.vertices, length=loads.stroke), offset=loads.offset)
    pull, _ = fitted_force(solver, pulled, loads.pull, [(0.0, 1.0, 0.0)])
    loads = replace(loads, force=force, pull=pull)
    return {"force": loads.force, "radius": loads.radius, "stroke": loads.stroke,
            "depth": TOOL_HEIGHT + loads.depth, "pull": loads.pull, "offset": loads.offset, "size": loads.size}


def measure() -> list[dict]:
    rows = []
    for name, surface in surfaces():
        hybrid = HybridMesh.build(surface, fine_volume=False)
        after = sized(hybrid)
        row = {"model": name, "size": after["size"], "after": after,
               "deformation": (deformation(hybrid, BEFORE["force"], None),
                               deformation(hybrid, after["force"], after["radius"])),
               "incision": (incision(hybrid, BEFORE), incision(hybrid, after))}
        print(f"| {name} | {100 * row['size']:.3g} cm | {after['force']:.3g} N over {1e3 * after['radius']:.3g} mm | "
              f"{row['deformation'][0]:.3g} → {row['deformation'][1]:.3g} | {1e3 * after['stroke']:.3g} mm, "
              f"{after['pull']:.3g} N | {row['incision'][0]:.3g} → {row['incision'][1]:.3g} |", flush=True)
        rows.append(row)
    return rows


def draw(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    x = np.arange(len(rows))
    for ax, key, title in zip(axes, ("deformation", "incision"),
                              ("deformation figure (tension and pressure)", "incision figure (opened wound)")):
        before = np.array([r[key][0] for r in rows])
        after = np.array([r[key][1] for r in rows])
        ax.bar(x - 0.2, np.where(np.isnan(before), 0, before), 0.4, label="before: fixed loads", color="#c44e52")
        ax.bar(x + 0.2, after, 0.4, label="after: sized to the model", color="#4c72b0")
        for i in np.flatnonzero(np.isnan(before)):
            ax.text(x[i] - 0.2, 2e-3, "stroke\ndoes not fit", ha="center", va="bottom", fontsize=7, rotation=90)
        ax.axhline(0.1, color="k", ls="--", lw=1, label="small-strain limit (0.1 of the size)")
        ax.set_yscale("log")
        ax.set_xticks(x, [f"{r['model']}\n{100 * r['size']:.3g} cm" for r in rows], fontsize=8, rotation=30)
        ax.set_title(title, fontsize=10)
        ax.set_ylim(1e-3, 1e3)
    axes[0].set_ylabel("largest displacement / model size")
    axes[1].legend(fontsize=8, loc="upper left")
    figure.suptitle("Default loads of render and incise, hybrid method, bottom tenth held, E = 5.5 kPa", fontsize=11)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figure", type=Path, default=Path("docs/figures/sizes_defaults.png"))
    args = parser.parse_args()
    warnings.simplefilter("ignore")         # the fixed loads are beyond small strain: that is what is measured
    print("| model | size | force (after) | deformation: |u|max / size, before → after | stroke, pull (after) | "
          "incision: |u|max / size, before → after |")
    print("|---|---|---|---|---|---|")
    rows = measure()
    draw(rows, args.figure)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
