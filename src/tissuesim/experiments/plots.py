"""Radar plots of the sample nodes' displacements, like the paper's Figs 12–15.

One PNG per model: a grid of panels, rows = load kinds (tension, pressure), columns = forces. Each panel compares the
methods' displacement d (eq 25) of the 10 sample nodes nearest the load node, in two parts:

* a radar of nodes 2–10 (one spoke each, nearest first, node 2 at the top, clockwise), whose radius is d over the
  reference's RMS d over those nine nodes: the reference lies around ring 1 (drawn darker) and a method's distance
  from it reads as a fraction of the deformation, whatever the force or the model's size. The rings are the same in
  every panel of a figure and are labelled on a scale left of the rim, clear of the lines;
* the load node (node 1) apart, as bars on the same scale. A load on one node is a point load: the reference's d at
  that node grows without bound as its mesh is refined (the report's single-node table) while the other nodes' stay
  put, so on the radar it would set the scale and crowd every other line into the centre.

A panel's title gives the reference's RMS in mm, the absolute scale. A method beyond the rim (at most
:data:`RIM_MAX`) is drawn clipped at it and named under the radar. Matplotlib's Agg backend: no display needed.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .methods import OURS, colour, line_style, short_label
from .protocol import REFERENCE
from .tables import cases_of, index, methods_of, models_of

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: The largest rim [× the reference's RMS]: a method beyond it is drawn clipped at the rim and named.
RIM_MAX = 3.0



def line_of(method: str) -> tuple[str, str, float]:
    """(colour, line style, width [pt]) of a method's line: its card's, ours a little thicker and a dotted line
    thicker still to read as heavy; the reference drawn thick and black, as the paper's FEM line."""
    if method == REFERENCE:
        return "black", "-", 2.2
    style = line_style(method)
    return colour(method), style, 1.6 if method == OURS else 1.5 if style == ":" else 1.3

# Layout [inches]: a panel's column width, its radar's and its bars' heights, the gap between load rows.
PANEL_W, PANEL_TITLE_H, RADAR_H, BARS_H, ROW_GAP, LEGEND_H, MARGIN = 2.8, 0.4, 2.4, 0.95, 0.15, 0.45, 0.1
ROW_H = PANEL_TITLE_H + RADAR_H + BARS_H + ROW_GAP
TITLE_PT, SUBTITLE_PT = 11.0, 8.5
# The radar's data box (the rim has radius 1) and where the ring scale stands, left of the rim and its spoke labels.
RADAR_X, RADAR_Y, SCALE_X = (-1.75, 1.3), (-1.35, 1.25), -1.42

SUBTITLE = ("Radar: nodes 2–10, d over the reference's RMS d over them (ring 1, darker; rings labelled on the scale "
            "at the left). Bars: the load node (1) on the same scale; a point load, its reference d depends on the "
            "mesh (report.md).")


def relative_samples(found: dict) -> tuple[float, dict] | None:
    """The reference's RMS d over nodes 2..k [mm] and every method's d over it.

    Args:
        found: ``{method: (k,) float64}`` displacements d [mm] of the k sample nodes, load node first.

    Returns:
        ``(rms [mm], {method: (k,) float64 d / rms [1]})``, or None where the case has no reference or it moved none
        of nodes 2..k (nothing to scale by).
    """
    reference = found.get(REFERENCE)
    if reference is None or len(reference) < 2:
        return None
    rms = float(np.sqrt(np.mean(reference[1:] ** 2)))
    if not rms > 0:
        return None
    return rms, {method: d / rms for method, d in found.items()}


def radar_figure(data: dict, model: str) -> Figure:
    """A matplotlib Figure of ``model``'s panels (rows: loads, columns: forces; see the module docstring).

    The radar is drawn on plain axes (rings, spokes and polygons) rather than matplotlib's polar projection, which
    renders about three times slower and would dominate a quick run.
    """
    from matplotlib.figure import Figure  # a bare Figure renders with Agg: no display, no pyplot state

    cases = cases_of(data, model)
    loads = list(dict.fromkeys(load for load, _ in cases))
    forces = sorted({force for _, force in cases})
    methods = methods_of(data, model)
    panels = {case: _panel_data(data, model, case, methods) for case in ((load, f) for load in loads for f in forces)}
    scaled = [p for p in panels.values() if p is not None]
    rim = _rim(scaled)
    bars_top = 1.3 * max((max(r[0] for r in rel.values()) for _, rel in scaled), default=1.0)
    width = 2 * MARGIN + PANEL_W * len(forces)
    title, subtitle = _wrap(f"{model}: displacement d (eq 25) of the 10 sample nodes nearest the load node",
                            TITLE_PT, width), _wrap(SUBTITLE, SUBTITLE_PT, width)
    head = MARGIN + (len(title) * TITLE_PT + len(subtitle) * SUBTITLE_PT) * 1.35 / 72 + 0.15
    height = head + len(loads) * ROW_H + LEGEND_H
    figure = Figure(figsize=(width, height))
    figure.text(0.5, 1 - MARGIN / height, "\n".join(title), fontsize=TITLE_PT, ha="center", va="top")
    figure.text(0.5, 1 - (MARGIN + len(title) * TITLE_PT * 1.35 / 72) / height, "\n".join(subtitle),
                fontsize=SUBTITLE_PT, ha="center", va="top", color="0.25")
    handles = {}
    for row, load in enumerate(loads):
        top = head + row * ROW_H + PANEL_TITLE_H
        for column, force in enumerate(forces):
            left = MARGIN + column * PANEL_W
            radar = figure.add_axes(_box(left, top, PANEL_W, RADAR_H, width, height))
            bars = figure.add_axes(_box(left + 0.75, top + RADAR_H, PANEL_W - 1.0, BARS_H - 0.2, width, height))
            panel = panels[(load, force)]
            handles.update(_draw_panel(radar, bars, panel, f"{load}, {force:g} N", rim=rim, bars_top=bars_top,
                                       names=column == 0))
    shown = [m for m in methods if m in handles]
    figure.legend([handles[m] for m in shown], [short_label(m) for m in shown], loc="lower center",
                  ncols=max(1, len(shown)), fontsize=9, frameon=False)
    return figure


def _panel_data(data: dict, model: str, case: tuple, methods: list) -> tuple[float, dict] | None:
    records = index(data)
    found = {m: records.get((model, *case, m)) for m in methods}
    return relative_samples({m: np.asarray(r["displacements_mm"], dtype=float) for m, r in found.items()
                             if r is not None})


def _rim(scaled: list) -> float:
    """The figure's common rim [× RMS]: 1.25 × the reference's largest relative d of nodes 2..k, up to the next 0.5,
    at least 1.5 and at most RIM_MAX. Set by the reference, not by the method farthest off (which is drawn clipped
    and named), so one outlier does not crowd the other lines into the centre."""
    largest = max((float(rel[REFERENCE][1:].max()) for _, rel in scaled if len(rel[REFERENCE]) > 1), default=1.0)
    return float(min(RIM_MAX, max(1.5, np.ceil(1.25 * largest / 0.5) * 0.5)))


def _wrap(text: str, points: float, width_in: float) -> list[str]:
    """``text`` in lines that fit ``width_in`` inches at ``points`` (a character is about 0.55 em wide)."""
    return textwrap.wrap(text, width=max(20, int(0.92 * width_in * 72 / (0.55 * points))))


def _box(left: float, top: float, w: float, h: float, width: float, height: float) -> list[float]:
    """An axes rectangle in figure fractions from inches (``top`` measured down from the figure's top)."""
    return [left / width, 1 - (top + h) / height, w / width, h / height]


def _draw_panel(radar, bars, panel, title: str, *, rim: float, bars_top: float, names: bool) -> dict:
    """One case: the radar of nodes 2..k and the load node's bars; return ``{method: line}``."""
    radar.set_aspect("equal")
    radar.axis("off")
    radar.set_xlim(*RADAR_X)
    radar.set_ylim(*RADAR_Y)
    if panel is None:
        radar.set_title(f"{title}\n(no reference: not scaled)", fontsize=8.5)
        bars.axis("off")
        return {}
    rms, relative = panel
    radar.set_title(f"{title}\nreference RMS {rms:.3g} mm", fontsize=8.5)
    handles = _draw_radar(radar, {m: r[1:] for m, r in relative.items()}, rim)
    _draw_load_node(bars, {m: r[0] for m, r in relative.items()}, bars_top, names)
    return handles


def _draw_radar(ax, found: dict, rim: float) -> dict:
    """Draw ``found`` (``{method: (s,) d / RMS}`` of nodes 2..s+1) inside a rim at ``rim``; return
    ``{method: line}``."""
    count = max(len(d) for d in found.values())
    angles = np.pi / 2 - np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)  # node 2 at the top, clockwise
    _draw_grid(ax, rim, angles)
    handles = {}
    for method, d in found.items():
        r = np.minimum(np.append(d, d[0]), rim) / rim
        a = np.append(angles[: len(d)], angles[0])
        tint, style, width = line_of(method)
        (line,) = ax.plot(r * np.cos(a), r * np.sin(a), color=tint, linestyle=style, linewidth=width,
                          label=short_label(method))
        handles[method] = line
    clipped = [short_label(m) for m, d in found.items() if d.max() > rim * (1 + 1e-9)]
    if clipped:
        ax.text(0.0, -1.2, f"beyond the rim: {', '.join(clipped)}", fontsize=6.5, ha="center", va="top", color="0.3")
    return handles


def _draw_grid(ax, rim: float, angles: np.ndarray) -> None:
    """Rings every 0.5 (ring 1 darker), the spokes numbered from node 2, and the rings' scale left of the rim."""
    ring = np.linspace(0.0, 2.0 * np.pi, 97)
    values = np.arange(0.5, rim + 1e-9, 0.5)
    for t in values:
        major = abs(t - 1.0) < 1e-9
        ax.plot(t / rim * np.cos(ring), t / rim * np.sin(ring), color="0.55" if major else "0.85",
                linewidth=0.9 if major else 0.6, zorder=0)
    for i, a in enumerate(angles):
        ax.plot([0.0, np.cos(a)], [0.0, np.sin(a)], color="0.85", linewidth=0.6, zorder=0)
        ax.text(1.12 * np.cos(a), 1.12 * np.sin(a), str(i + 2), fontsize=7, ha="center", va="center")
    # The scale: a ruler from the centre's height to the rim's, outside every line (all lie within radius 1).
    ax.plot([SCALE_X, SCALE_X], [0.0, 1.0], color="0.45", linewidth=0.6)
    for t in values:
        ax.plot([SCALE_X - 0.04, SCALE_X], [t / rim, t / rim], color="0.45", linewidth=0.6)
        ax.text(SCALE_X - 0.07, t / rim, f"{t:g}", fontsize=6, color="0.3", ha="right", va="center",
                gid="ring-label")
    ax.text(SCALE_X, 1.1, "× RMS", fontsize=6, color="0.3", ha="center", va="bottom")


def _draw_load_node(ax, values: dict, top: float, names: bool) -> None:
    """Horizontal bars of each method's load-node d / RMS (``values``) on a scale from 0 to ``top``, drawn on plain
    axes with their own ticks (matplotlib's tick machinery took a third of a quick run's plotting)."""
    methods = list(values)
    y = np.arange(len(methods))[::-1].astype(float)
    ax.axis("off")
    ax.set_xlim(-0.02 * top, top)
    ax.set_ylim(-1.7, len(methods) + 0.3)
    ax.barh(y, [values[m] for m in methods], height=0.7, color=[line_of(m)[0] for m in methods])
    for yi, m in zip(y, methods):
        ax.text(values[m] + 0.02 * top, yi, f"{values[m]:.2g}", fontsize=5.5, va="center")
        if names:
            ax.text(-0.03 * top, yi, short_label(m), fontsize=6, ha="right", va="center")
    step = 1.0 if top <= 7 else float(np.ceil(top / 6))
    ticks = np.arange(0.0, top, step)
    ax.plot([0.0, top], [-0.5, -0.5], color="0.3", linewidth=0.6)
    ax.vlines(ticks, -0.65, -0.5, color="0.3", linewidth=0.6)
    for t in ticks:
        ax.text(t, -0.8, f"{t:g}", fontsize=6, ha="center", va="top")
    ax.text(0.5 * top, len(methods) - 0.4, "load node (1), d / RMS", fontsize=6.5, ha="center", va="bottom")


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
