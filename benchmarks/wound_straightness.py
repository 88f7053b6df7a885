"""How straight a straight stroke's wound is: the lips' deviation from the blade's trace, per model and angle.

    python benchmarks/wound_straightness.py [--method hybrid] [--models cube sphere liver steak] [--figure PNG]

For each built-in model and a 30 mm stroke across its top at 0°, 30° and 45° (the scripted incision of
``tissuesim.experiments.wound``, 15 moves), prints the RMS and largest distance of the lips (the new boundary's
vertices, at rest) to the rectangle the blade swept, in mean edge lengths of the uncut surface, the number of lips,
the wound's reach along the stroke (a fraction of its length) and the smallest triangle quality of the cut surface.
Target: RMS ≤ 0.05, max ≤ 0.10, quality ≥ 0.1.
"""

from __future__ import annotations

import argparse

import numpy as np

import tissuesim
from tissuesim.experiments.wound import lip_deviation, scripted_incision
from tissuesim.mesh import models

ANGLES = (0.0, 30.0, 45.0)


def measure(method: str, names, angles=ANGLES) -> list[dict]:
    """One row per model and angle: ``{"model", "angle", "rms", "max", "lips", "reach", "quality"}`` and the lips'
    ``"along"`` and ``"across"`` coordinates (fractions of the stroke, signed mean edge lengths)."""
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
            rows.append({"model": name, "angle": angle, **lip_deviation(cut.vertices, cut.triangles, line, edge=edge),
                         **_lips_in_stroke_frame(cut, line, edge)})
    return rows


def _lips_in_stroke_frame(cut, line, edge) -> dict:
    """The lips' place along the stroke [fraction of its length] and signed distance across it [mean edges]."""
    tri = np.asarray(cut.triangles, dtype=np.int64)
    edges, counts = np.unique(np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0, return_counts=True)
    lips = cut.vertices[np.unique(edges[counts == 1])]
    start, end = line
    u = end - start
    across = np.cross(u, [0.0, 0.0, 1.0])
    return {"along": (lips - start) @ u / (u @ u), "across": (lips - start) @ across / np.linalg.norm(across) / edge}


def figure(rows, path) -> None:
    """Each lip's distance across the trace against its place along the stroke, one panel per model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(row["model"] for row in rows))
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3.0), sharey=True, squeeze=False)
    for ax, name in zip(axes[0], names):
        for row, marker in zip([r for r in rows if r["model"] == name], "o^s"):
            ax.plot(row["along"], row["across"], marker, ms=4, alpha=0.8,
                    label=f"{row['angle']:.0f}°: RMS {row['rms']:.3f}, max {row['max']:.3f}")
        ax.axhspan(-0.1, 0.1, color="0.9", zorder=0)
        ax.axhline(0.0, color="0.4", lw=0.8)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("along the stroke (fraction)")
        ax.legend(fontsize=7, loc="lower center")
        ax.set_ylim(-0.5, 0.5)
    axes[0][0].set_ylabel("lip across the trace [mean edges]")
    fig.suptitle("Lips of a straight 30 mm stroke at 0°, 30°, 45° (grey: the ±0.1 edge target)", fontsize=10,
                 y=1.04)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="hybrid")
    parser.add_argument("--models", nargs="*", default=list(models.MODELS))
    parser.add_argument("--figure", default=None, help="write the lips' plot to this PNG")
    args = parser.parse_args()
    print(f"method {args.method}; deviations in mean edge lengths (target RMS ≤ 0.05, max ≤ 0.10, quality ≥ 0.1)")
    print("| model | angle | RMS | max | lips | reach | min quality |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    rows = measure(args.method, args.models)
    for row in rows:
        print(f"| {row['model']} | {row['angle']:.0f}° | {row['rms']:.3f} | {row['max']:.3f} | {row['lips']} | "
              f"{row['reach']:.2f} | "
              f"{row['quality']:.3f} |")
    if args.figure:
        figure(rows, args.figure)


if __name__ == "__main__":
    main()
