"""Radar plots of the sample nodes' displacements, like the paper's Figs 12–15.

One PNG per model: a grid of radar subplots, rows = load kinds (tension, pressure), columns = forces. Each spoke is
one of the 10 sample nodes (nearest the load node first, spoke 1 = the load node itself); the radius is its
displacement d of eq 25 [mm]; one closed line per method. The rim is at most 3× the reference's largest d: a
method beyond it is drawn clipped at the rim and named under the subplot. Matplotlib's Agg backend: no display needed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .protocol import REFERENCE
from .tables import LABELS, cases_of, index, methods_of, models_of

# A method whose displacement exceeds this multiple of the reference's largest is drawn clipped at the rim.
CLIP_FACTOR = 3.0

STYLE = {  # method -> (colour, line style); the reference drawn thick and black, as the paper's FEM line
    "fem": ("black", "-", 2.2),
    "hybrid": ("tab:red", "-", 1.6),
    "pbd": ("tab:blue", "--", 1.3),
    "mass-spring": ("tab:green", "-.", 1.3),
    "embedded": ("tab:orange", ":", 1.5),
}


def radar_figure(data: dict, model: str):
    """A matplotlib Figure of ``model``'s radar grid (rows: loads, columns: forces).

    The radar is drawn on plain axes (rings, spokes and polygons) rather than matplotlib's polar projection,
    which renders about three times slower and would dominate a quick run.
    """
    from matplotlib.figure import Figure  # a bare Figure renders with Agg: no display, no pyplot state

    cases = cases_of(data, model)
    loads = list(dict.fromkeys(load for load, _ in cases))
    forces = sorted({force for _, force in cases})
    records = index(data)
    methods = methods_of(data, model)
    figure = Figure(figsize=(2.7 * len(forces) + 0.4, 2.9 * len(loads) + 0.8))
    axes = figure.subplots(len(loads), len(forces), squeeze=False)
    figure.subplots_adjust(left=0.01, right=0.99, bottom=0.09, top=0.88, wspace=0.08, hspace=0.25)
    handles = {}
    for row, load in enumerate(loads):
        for column, force in enumerate(forces):
            ax = axes[row, column]
            ax.set_aspect("equal")
            ax.axis("off")
            found = {m: records.get((model, load, force, m)) for m in methods}
            found = {m: np.asarray(r["displacements_mm"], dtype=float) for m, r in found.items() if r is not None}
            if found:
                handles.update(_draw_radar(ax, found, f"{load}, {force:g} N (d in mm)"))
    figure.legend([handles[m] for m in methods if m in handles], [LABELS.get(m, m) for m in methods if m in handles],
                  loc="lower center", ncols=max(1, len(handles)), fontsize=9, frameon=False)
    figure.suptitle(f"{model}: displacement d (eq 25) of the 10 sample nodes nearest the load node "
                    "(spoke 1 = load node)", fontsize=11)
    return figure


def _draw_radar(ax, found: dict, title: str) -> dict:
    """Draw one case's radar on ``ax``: ``found`` maps each method to its sample displacements [mm]; return
    ``{method: line}``."""
    from matplotlib.ticker import MaxNLocator

    count = max(len(d) for d in found.values())
    top = max(float(d.max()) for d in found.values()) or 1.0
    if REFERENCE in found and found[REFERENCE].max() > 0:
        # Keep the reference readable: a method far off it is clipped at the rim (and named) rather than
        # shrinking every other line to a dot.
        top = min(top, CLIP_FACTOR * float(found[REFERENCE].max()))
    clipped = [LABELS.get(m, m) for m, d in found.items() if d.max() > top * (1 + 1e-9)]
    ticks = [t for t in MaxNLocator(nbins=4).tick_values(0.0, top) if 0 < t]
    outer = ticks[-1] if ticks and ticks[-1] >= top else top
    angles = np.pi / 2 - np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)  # node 1 at the top
    _draw_grid(ax, ticks, outer, angles)
    handles = {}
    for method, d in found.items():
        r = np.minimum(np.append(d, d[0]), outer) / outer
        a = np.append(angles[: len(d)], angles[0])
        colour, style, width = STYLE.get(method, ("grey", "-", 1.0))
        (line,) = ax.plot(r * np.cos(a), r * np.sin(a), color=colour, linestyle=style, linewidth=width,
                          label=LABELS.get(method, method))
        handles[method] = line
    ax.set_xlim(-1.25, 1.25)
    ax.set_ylim(-1.45, 1.25)
    ax.set_title(title, fontsize=9)
    if clipped:
        ax.text(0.0, -1.3, f"clipped at rim: {', '.join(clipped)}", fontsize=6.5, ha="center", va="top", color="0.3")
    return handles


def _draw_grid(ax, ticks: list, outer: float, angles: np.ndarray) -> None:
    """The radar's rings at ``ticks`` (labelled, the outermost at ``outer``) and its numbered spokes."""
    ring = np.linspace(0.0, 2.0 * np.pi, 97)
    label_angle = np.pi / 2 - np.pi / len(angles)  # ring values between spokes 1 and 2, clear of both
    for t in ticks:
        ax.plot(t / outer * np.cos(ring), t / outer * np.sin(ring), color="0.85", linewidth=0.6, zorder=0)
        ax.text(t / outer * np.cos(label_angle), t / outer * np.sin(label_angle), f"{t:g}", fontsize=6,
                color="0.45", ha="center", va="center")
    for i, a in enumerate(angles):
        ax.plot([0.0, np.cos(a)], [0.0, np.sin(a)], color="0.85", linewidth=0.6, zorder=0)
        ax.text(1.13 * np.cos(a), 1.13 * np.sin(a), str(i + 1), fontsize=7, ha="center", va="center")


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
