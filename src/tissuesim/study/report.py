"""A study's summary: ``DIR/report.md`` with one line per method (cases, failures, relative RMSE) and, for each input
that the study varies, a plot of the relative RMSE (eq 26 over the reference's RMS) against it, one line per method
(the mean over the other inputs, the range as a band).

Written from the combined table alone, so it can be redrawn from any ``results.parquet``. Matplotlib's Agg backend:
no display needed.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from ..experiments.plots import line_of

#: Inputs a study may vary, each with its axis label (a numeric column of the table).
PARAMETERS = {"force_N": "force [N]", "youngs_modulus_Pa": "Young's modulus E [Pa]",
              "poisson_ratio": "Poisson's ratio ν", "radius_m": "tip radius [m]", "resolution": "surface vertices",
              "depth_m": "a probe's depth or a grasper's travel [m]"}


def write_report(rows: list[dict], folder: Path | str, *, title: str = "") -> Path:
    """Write ``folder/report.md`` and its plots ``folder/error_vs_<parameter>.png`` from the table's ``rows``; return
    the report's path."""
    folder = Path(folder)
    lines = [f"# {title or 'Study'}", "", "| method | cases | failed | relative RMSE: mean | max |",
             "|---|---|---|---|---|"]
    rows = [{**row, "label": _label(row)} for row in rows]
    for method, group in _by(rows, "label").items():
        errors = _errors(group)
        failed = sum(r["status"] == "failed" for r in group)
        mean, top = (f"{errors.mean():.3g}", f"{errors.max():.3g}") if errors.size else ("-", "-")
        lines.append(f"| {method} | {len(group)} | {failed} | {mean} | {top} |")
    for column, label in PARAMETERS.items():
        values = {r.get(column) for r in rows if r.get(column) is not None}
        if len(values) > 1 and any(r.get("relative_rmse") is not None for r in rows):
            name = f"error_vs_{column}.png"
            _plot(rows, column, label, folder / name)
            lines += ["", f"![relative RMSE against {label}]({name})"]
    failures = [r for r in rows if r["status"] == "failed"]
    if failures:
        lines += ["", "## Failed cases", ""] + [f"- `{r['case_id']}` {r['model']} {r['method']}: {r['error']}"
                                               for r in failures[:20]]
        lines += [f"- and {len(failures) - 20} more"] if len(failures) > 20 else []
    path = folder / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _label(row: dict) -> str:
    """The method's name, with its options where it has any (two variants of a method are two lines)."""
    return row["method"] if row.get("options", "{}") == "{}" else f"{row['method']} {row['options']}"


def _by(rows: list[dict], column: str) -> dict:
    groups = defaultdict(list)
    for row in rows:
        groups[row[column]].append(row)
    return dict(groups)


def _errors(rows: list[dict]) -> np.ndarray:
    values = [r.get("relative_rmse") for r in rows if r["status"] == "done"]
    return np.array([v for v in values if v is not None and np.isfinite(v)], dtype=np.float64)


def _plot(rows: list[dict], column: str, label: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.6, 3.4))
    for method, group in _by(rows, "label").items():
        points = sorted((value, _errors(g)) for value, g in _by(group, column).items() if value is not None)
        points = [(value, errors) for value, errors in points if errors.size]
        if not points:
            continue
        x = np.array([value for value, _ in points], dtype=np.float64)
        colour, style, width = line_of(method)     # a method with options is no method's name: grey
        ax.plot(x, [e.mean() for _, e in points], style, color=colour, lw=width, marker="o", ms=3, label=method)
        ax.fill_between(x, [e.min() for _, e in points], [e.max() for _, e in points], color=colour, alpha=0.15)
    ax.set_xlabel(label)
    ax.set_ylabel("relative RMSE (eq 26 / reference RMS)")
    ax.set_ylim(bottom=0.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.02, 0.5))     # beside the plot, clear of the lines
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
