"""``errors.png`` of the contact protocol: each method's relative RMSE per model and R beside the load rule floor.

One group of bars per model × R (median over its held-out rows, log scale), a black tick per group at the load rule
floor (the error an exact solve of the solvers' nodal forces would have), and a dashed line at 0.10. Matplotlib's
Agg backend: no display needed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .methods import colour, label, short_label

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: The absolute target drawn across the plot (relative RMSE).
TARGET = 0.10
LEGEND_COLUMN_IN = 3.3


def error_figure(data: dict) -> Figure:
    """A matplotlib Figure of the held-out medians per model × R and method (see the module docstring)."""
    from matplotlib.figure import Figure

    methods = [m for m in data["metadata"]["methods"]
               if any(r["method"] == m and r["relative_rmse"] is not None for r in data["records"])]
    groups = list(dict.fromkeys((r["model"], r["radius_mm"]) for r in data["records"]))
    width = max(6.0, 1.1 * len(groups) + 2.0)
    columns = max(1, min(4, int(width / LEGEND_COLUMN_IN)))  # a legend entry takes about LEGEND_COLUMN_IN inches
    rows = -(-(len(methods) + 2) // columns)
    figure = Figure(figsize=(width, 3.6 + 0.2 * rows), dpi=110)
    axes = figure.add_subplot()
    width = 0.8 / max(len(methods), 1)
    for k, method in enumerate(methods):
        medians = [_median(data, group, method) for group in groups]
        axes.bar(np.arange(len(groups)) - 0.4 + (k + 0.5) * width, medians, width,
                 color=colour(method), label=_label(method))
    floors = [data["metadata"]["models"][model]["references"].get(f"{radius:g}", {}).get("load_rule_floor")
              for model, radius in groups]
    shown = [(i, f) for i, f in enumerate(floors) if f]
    if shown:
        axes.hlines([f for _, f in shown], [i - 0.45 for i, _ in shown], [i + 0.45 for i, _ in shown],
                    colors="black", linewidth=2.0, label="load rule floor (an exact solve of the nodal forces)")
    axes.axhline(TARGET, color="black", linestyle="--", linewidth=0.8, label=f"target {TARGET:g}")
    axes.set_yscale("log")
    axes.set_xticks(np.arange(len(groups)), [f"{model}\nR {radius:g} mm" for model, radius in groups], fontsize=7)
    axes.set_ylabel("relative RMSE (median, held-out rows)")
    material = data["metadata"].get("material", "linear")
    converged = all(ref["converged"] for info in data["metadata"]["models"].values()
                    for ref in info["references"].values())
    details = [f"{material} reference" if material != "linear" else "", "" if converged else "not converged"]
    detail = ", ".join(d for d in details if d)
    axes.set_title("Contact protocol: error against the refined reference" + (f"\n({detail})" if detail else ""),
                   fontsize=10)
    axes.legend(fontsize=8, ncol=columns, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)
    figure.tight_layout()
    return figure


def _label(method: str) -> str:
    """The table's short label and what the bar is (the short labels alone do not say)."""
    short, meaning = short_label(method), label(method)
    return short if meaning == short else f"{short}: {meaning}"


def _median(data: dict, group, method) -> float:
    values = [r["relative_rmse"] for r in data["records"] if (r["model"], r["radius_mm"]) == group
              and r["method"] == method and r["role"] == "held out" and r["relative_rmse"] is not None]
    return float(np.median(values)) if values else np.nan
