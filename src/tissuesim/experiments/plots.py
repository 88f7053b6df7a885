"""Radar plots of the sample nodes' displacements, like the paper's Figs 12–15.

One PNG per model: a grid of polar subplots, rows = load kinds (tension, pressure), columns = forces. Each spoke is
one of the 10 sample nodes (nearest the load node first, spoke 1 = the load node itself); the radius is its
displacement d of eq 25 [mm]; one closed line per method. Matplotlib's Agg backend: no display needed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .tables import LABELS, cases_of, index, methods_of, models_of

STYLE = {  # method -> (colour, line style); the reference drawn thick and black, as the paper's FEM line
    "fem": ("black", "-", 2.2),
    "hybrid": ("tab:red", "-", 1.6),
    "pbd": ("tab:blue", "--", 1.3),
    "mass-spring": ("tab:green", "-.", 1.3),
    "embedded": ("tab:orange", ":", 1.5),
}


def radar_figure(data: dict, model: str):
    """A matplotlib Figure of ``model``'s radar grid (rows: loads, columns: forces)."""
    from matplotlib.figure import Figure  # a bare Figure renders with Agg: no display, no pyplot state

    cases = cases_of(data, model)
    loads = list(dict.fromkeys(load for load, _ in cases))
    forces = sorted({force for _, force in cases})
    records = index(data)
    methods = methods_of(data, model)
    figure = Figure(figsize=(2.9 * len(forces) + 0.8, 3.0 * len(loads) + 0.9), layout="constrained")
    axes = figure.subplots(len(loads), len(forces), subplot_kw={"projection": "polar"}, squeeze=False)
    handles = {}
    for row, load in enumerate(loads):
        for column, force in enumerate(forces):
            ax = axes[row, column]
            for method in methods:
                record = records.get((model, load, force, method))
                if record is None:
                    continue
                d = np.asarray(record["displacements_mm"], dtype=float)
                angles = np.linspace(0.0, 2.0 * np.pi, len(d), endpoint=False)
                colour, style, width = STYLE.get(method, ("grey", "-", 1.0))
                (line,) = ax.plot(np.append(angles, angles[0]), np.append(d, d[0]), color=colour, linestyle=style,
                                  linewidth=width, label=LABELS.get(method, method))
                handles[method] = line
                ax.set_xticks(angles)
                ax.set_xticklabels([str(i + 1) for i in range(len(d))], fontsize=7)
            ax.tick_params(axis="y", labelsize=6)
            ax.set_title(f"{load}, {force:g} N (d in mm)", fontsize=9)
    figure.legend([handles[m] for m in methods if m in handles], [LABELS.get(m, m) for m in methods if m in handles],
                  loc="outside lower center", ncols=len(handles), fontsize=9)
    figure.suptitle(f"{model}: displacement d (eq 25) of the 10 sample nodes nearest the load node", fontsize=11)
    return figure


def write_radar_plots(data: dict, folder: Path) -> list[Path]:
    """Write ``radar_<model>.png`` for every model of ``data`` into ``folder``; return the paths."""
    folder = Path(folder)
    paths = []
    for model in models_of(data):
        figure = radar_figure(data, model)
        path = folder / f"radar_{_safe(model)}.png"
        figure.savefig(path, dpi=110)
        paths.append(path)
    return paths


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
