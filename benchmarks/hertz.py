"""Hertz contact: a rigid sphere (R = 5 mm) pressed 0.05–0.5 mm into the indentation block (80 × 80 × 40 mm, its
top graded fine under the probe), every method against F = 4/3 · E/(1 − ν²) · √R · δ^{3/2}; a convergence in the
fine edge; the block's own bias (the same press on a block twice as large); and docs/figures/hertz.png.

    python benchmarks/hertz.py measure [--methods fem,hybrid] [--edges 0.5,0.25] [--split 2] [--output hertz.json]
    python benchmarks/hertz.py plot [--input hertz.json] [--figure docs/figures/hertz.png]

``measure`` appends its rows to the JSON file (run it in parts: one method and mesh at a time stays short); ``plot``
draws F(δ) at the finest mesh of each method on log axes, and F/F_Hertz against the fine edge, and prints the
Markdown table of docs/probe.md. Each press converges to a complementarity residual of 1e-3 δ.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from hertz_reference import (PROBE_RADIUS, block, hertz_force, layer_factor, press, quadratic_method,
                             refined_block)

import tissuesim

DEPTHS = (0.05e-3, 0.1e-3, 0.2e-3, 0.5e-3)          # [m]: δ/R ≤ 0.1
E, NU = 5500.0, 0.3
CONVERGENCE_DEPTH = 0.2e-3                           # [m]: a = 1 mm


def measure(methods: list[str], edges: list[float], output: Path, *, large: bool, control: float | None,
            split: int) -> None:
    rows = json.loads(output.read_text()) if output.exists() else []
    options = {"width": 0.16, "height": 0.08} if large else {}
    for edge in edges:
        if split:
            hybrid, edge = refined_block(edge, split), edge / 2**split
        else:
            hybrid = block(edge, control=control, **options)
        for method in methods:
            name = quadratic_method() if method == "fem-quadratic" else method
            label = method if control is None else f"{method} ({100 * control:g} % control)"
            label = f"{label}, volume split" if split else label
            solver = tissuesim.make_solver(name, hybrid, youngs_modulus=E, poisson_ratio=NU)
            for depth in DEPTHS:
                start = time.perf_counter()
                row = {"method": label, "fine_edge": edge, "block": "160x160x80" if large else "80x80x40",
                       "vertices": hybrid.surface.vertex_count, "control_nodes": int(hybrid.control.size),
                       "fine_volume_nodes": hybrid.fine_volume.node_count, "depth": depth,
                       "hertz": float(hertz_force(depth, radius=PROBE_RADIUS, youngs_modulus=E, poisson_ratio=NU))}
                try:
                    force, contacts, probe = press(solver, depth)
                except tissuesim.SolverError as error:      # a method that cannot hold the contact: say so
                    row.update(force=None, ratio=None, error=str(error), seconds=time.perf_counter() - start)
                    print(f"{label:14s} h {1e3 * edge:5.3f} mm  δ {1e3 * depth:4.2f} mm  {error}", flush=True)
                else:
                    row.update(force=force, ratio=force / row["hertz"], contacts=contacts,
                               iterations=probe.iterations, steps=probe.steps, seconds=time.perf_counter() - start)
                    print(f"{label:14s} h {1e3 * edge:5.3f} mm  δ {1e3 * depth:4.2f} mm  F/F_Hertz "
                          f"{row['ratio']:.4f}  {probe.iterations:2d} iterations {probe.steps:5d} steps  "
                          f"{row['seconds']:6.2f} s", flush=True)
                rows.append(row)
                output.write_text(json.dumps(rows, indent=1))


def plot(rows: list[dict], figure: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter

    # the figure shows each method as built by default; the table has the other blocks and M_V sizes too
    rows = [r for r in rows if r["block"] == "80x80x40" and r["ratio"] is not None and "control" not in r["method"]]
    split = [r for r in rows if "split" in r["method"]]
    rows = [r for r in rows if "split" not in r["method"]]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    depths = np.geomspace(min(DEPTHS), max(DEPTHS), 50)
    left.loglog(1e3 * depths, 1e3 * hertz_force(depths, radius=PROBE_RADIUS, youngs_modulus=E, poisson_ratio=NU),
                "k-", lw=2, label="Hertz")
    for method in methods:
        mine = [r for r in rows if r["method"] == method]
        finest = min(r["fine_edge"] for r in mine)
        mine = sorted((r for r in mine if r["fine_edge"] == finest), key=lambda r: r["depth"])
        left.loglog([1e3 * r["depth"] for r in mine], [1e3 * r["force"] for r in mine], "o--",
                    label=f"{method} (h = {1e3 * finest:g} mm)")
        at_a = sorted((r for r in rows if r["method"] == method and r["depth"] == CONVERGENCE_DEPTH),
                      key=lambda r: r["fine_edge"])
        right.semilogx([1e3 * r["fine_edge"] for r in at_a], [r["ratio"] for r in at_a], "o-", label=method)
    if split:
        finest = min(r["fine_edge"] for r in split)
        mine = sorted((r for r in split if r["fine_edge"] == finest), key=lambda r: r["depth"])
        left.loglog([1e3 * r["depth"] for r in mine], [1e3 * r["force"] for r in mine], "s:", color="tab:blue",
                    label=f"fem, volume split (h = {1e3 * finest:g} mm)")
        unsplit = [r for r in rows if r["method"] == "fem" and r["fine_edge"] == 2 * max(e["fine_edge"] for e in split)]
        at_a = sorted((r for r in split + unsplit if r["depth"] == CONVERGENCE_DEPTH), key=lambda r: r["fine_edge"])
        right.semilogx([1e3 * r["fine_edge"] for r in at_a], [r["ratio"] for r in at_a], "s:", color="tab:blue",
                       label="fem, volume split in 8 per halving")
    left.set(xlabel="depth δ [mm]", ylabel="force F [mN]",
             title=f"sphere R = {1e3 * PROBE_RADIUS:g} mm into the 80×80×40 mm block (E = {E:g} Pa, ν = {NU})")
    left.legend(fontsize=8)
    left.grid(True, which="both", alpha=0.3)
    right.axhspan(0.95, 1.05, color="green", alpha=0.15, label="±5 % (fem target)")
    right.axhspan(0.85, 1.15, color="orange", alpha=0.1, label="±15 % (hybrid target)")
    right.axhline(1.0, color="k", lw=1)
    right.axhline(layer_factor(CONVERGENCE_DEPTH, radius=PROBE_RADIUS, poisson_ratio=NU), color="k", lw=1, ls=":",
                  label="Hertz × bonded-layer factor (H = 36 mm)")
    right.set(xlabel="fine edge h under the probe [mm]", ylabel="F / F_Hertz at δ = 0.2 mm (a = 1 mm)",
              yscale="log",
              title="convergence in the mesh (δ = 0.2 mm)")
    right.legend(fontsize=8)
    right.grid(True, which="both", alpha=0.3)
    for axes in (left, right):                     # plain numbers on the log axes, not powers of ten
        for axis in (axes.xaxis, axes.yaxis):
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(FormatStrFormatter("%g"))
    right.set_xticks([1e3 * e for e in sorted({r["fine_edge"] for r in rows + split})])
    right.set_yticks([0.9, 1.0, 1.1, 1.2, 1.3, 1.5, 2.0, 2.5, 3.0])
    right.yaxis.set_minor_formatter(FormatStrFormatter(""))
    left.tick_params(which="minor", labelsize=7)
    left.set_xticks([1e3 * d for d in DEPTHS])
    left.xaxis.set_minor_formatter(FormatStrFormatter(""))
    fig.tight_layout()
    fig.savefig(figure, dpi=110)
    print(f"wrote {figure}")


def table(rows: list[dict]) -> str:
    lines = ["| method | block [mm] | fine edge h [mm] | M_S vertices | δ [mm] | a/h | F [mN] | F_Hertz [mN] | "
             "deviation | contacts | iterations | steps |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["ratio"] is None:
            lines.append(f"| {r['method']} | {r['block'].replace('x', '×')} | {1e3 * r['fine_edge']:g} | "
                         f"{r['vertices']} | {1e3 * r['depth']:g} | | | | did not converge | | | |")
            continue
        a = np.sqrt(PROBE_RADIUS * r["depth"])
        lines.append(f"| {r['method']} | {r['block'].replace('x', '×')} | {1e3 * r['fine_edge']:g} | {r['vertices']} "
                     f"| {1e3 * r['depth']:g} | {a / r['fine_edge']:.1f} | {1e3 * r['force']:.4g} | "
                     f"{1e3 * r['hertz']:.4g} | {100 * (r['ratio'] - 1):+.1f} % | {r['contacts']} | "
                     f"{r['iterations']} | {r['steps']} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("job", choices=["measure", "plot"])
    parser.add_argument("--methods", default="fem,fem-quadratic,hybrid,embedded,pbd")
    parser.add_argument("--edges", default="0.5,0.25", help="fine edges [mm]")
    parser.add_argument("--large", action="store_true", help="the block twice as large (its finite-size bias)")
    parser.add_argument("--control", type=float, help="control nodes as a fraction of M_S's vertices (default: "
                        "HybridMesh.build's)")
    parser.add_argument("--split", type=int, default=0, help="split the fine volume in 8 this many times (a true "
                        "refinement of volume and surface: the row's fine edge is the split one)")
    parser.add_argument("--output", "--input", dest="data", default="hertz.json")
    parser.add_argument("--figure", default="docs/figures/hertz.png")
    args = parser.parse_args(argv)
    data = Path(args.data)
    if args.job == "measure":
        measure(args.methods.split(","), [1e-3 * float(e) for e in args.edges.split(",")], data, large=args.large,
                control=args.control, split=args.split)
    else:
        rows = json.loads(data.read_text())
        plot(rows, Path(args.figure))
        print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
