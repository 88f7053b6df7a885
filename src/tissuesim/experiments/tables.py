"""The paper's Tables 1–5 as Markdown, our figures beside the published ones, from a results document.

Column names follow the paper: "Ours" is the ``hybrid`` method, "MSM" is ``mass-spring``, "FEM" the fine-volume
reference; "Emb." is the embedded-surface baseline the paper does not have. Ratios: Ours/PBD and Ours/MSM of the
RMSE (below 1: the hybrid is more accurate), Ours/PBD and FEM/Ours of the per-step time (FEM/Ours above 1: the
hybrid is faster than the fine FEM). Ratio summaries are medians over load cases of the per-case ratios (one
diverged case must not swamp a model's summary), for ours and the paper's alike. Every column is defined once, in
the legend at the top of ``tables.md`` (:func:`column_legend`); Table 1's size is :data:`SIZE_DEFINITION`, as
``tissuesim build`` prints it.
"""

from __future__ import annotations

import math

import numpy as np

from . import paper
from .methods import OURS, compared_methods, ordered, paper_methods, short_label
from .protocol import REFERENCE

#: What Table 1's "size (kB)" is, here, in ``tissuesim build`` and in the README: the paper's Table 1 gives sizes in
#: kB without saying of what; a file's size is what a reader can check, and these land in the paper's range.
SIZE_DEFINITION = ("the mesh written as an ASCII file, in kB of 1000 bytes: OBJ for M_S (`v x y z` with %.8g "
                   "coordinates in metres, `f a b c`), TetGen `.node` + `.ele` for a volume")



def ratios() -> dict[str, tuple[str, str, str]]:
    """name -> (quantity, numerator method, denominator method): the ratios of the closing summary. Ours' RMSE over
    every other compared method's; the step ratios the paper claims (:data:`.paper.STEP_CLAIMS`)."""
    accuracy = {f"{short_label(OURS)}/{short_label(m)} RMSE": ("rmse", OURS, m)
                for m in compared_methods() if m != OURS}
    # the summary gives the fine FEM's claim first, the time table (:func:`time_table`) the paper's column order
    steps = {f"{short_label(a)}/{short_label(b)} step": ("time", a, b) for a, b in reversed(paper.STEP_CLAIMS)}
    return {**accuracy, **steps}


def index(data: dict) -> dict:
    """``{(model, load, force_N, method): record}`` of a results document."""
    return {(r["model"], r["load"], float(r["force_N"]), r["method"]): r for r in data["records"]}


def models_of(data: dict) -> list[str]:
    return list(dict.fromkeys(r["model"] for r in data["records"]))


def cases_of(data: dict, model: str) -> list[tuple[str, float]]:
    return list(dict.fromkeys((r["load"], float(r["force_N"])) for r in data["records"] if r["model"] == model))


def methods_of(data: dict, model: str) -> list[str]:
    present = {r["method"] for r in data["records"] if r["model"] == model}
    return ordered(m for m in present if m in (*compared_methods(), REFERENCE))


def measured_ratio(data: dict, model: str, quantity: str, numerator: str, denominator: str) -> float | None:
    """Median over ``model``'s cases of ``numerator/denominator`` of ``rmse_mm`` or ``step_ms`` (None if absent)."""
    field = "rmse_mm" if quantity == "rmse" else "step_ms"
    records = index(data)
    ratios = []
    for load, force in cases_of(data, model):
        top, bottom = records.get((model, load, force, numerator)), records.get((model, load, force, denominator))
        if top and bottom and bottom[field] > 0:
            ratios.append(top[field] / bottom[field])
    return float(np.median(ratios)) if ratios else None


def published_ratio(model: str, quantity: str, numerator: str, denominator: str) -> float | None:
    table = paper.RMSE_MM if quantity == "rmse" else paper.TIME_MS
    return paper.median_ratio(table, model, numerator, denominator)


def ratio_summary(data: dict) -> dict:
    """``{model: {ratio name: (ours, paper or None)}}`` for the ratios of :func:`ratios`."""
    return {model: {name: (measured_ratio(data, model, *spec), published_ratio(model, *spec))
                    for name, spec in ratios().items()} for model in models_of(data)}


# --------------------------------------------------------------------------------------------------- Markdown
def fmt(value: float | None, digits: int = 4) -> str:
    """A number for a table cell: ``digits`` significant figures, "–" when missing."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}g}"


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def table1(data: dict) -> str:
    """Table 1: mesh sizes (nodes, elements, in-memory size), ours beside the paper's."""
    rows = []
    for model in models_of(data):
        info = data["metadata"]["models"][model]
        published = paper.TABLE1.get(model, {})
        for mesh, label in (("surface", "fine surface M_S"), ("volume", "coarse volume M_V"),
                            ("fine_volume", "fine volume (FEM)")):
            ours = info.get(mesh) or {}
            theirs = published.get(mesh, (None, None, None))
            rows.append([model, label, fmt(ours.get("nodes"), 6), fmt(ours.get("elements"), 6),
                         fmt(ours.get("size_kB"), 4), fmt(theirs[0], 6), fmt(theirs[1], 6), fmt(theirs[2], 6)])
    return markdown_table(["Model", "Mesh", "#node", "#elem", "size (kB)", "paper #node", "paper #elem",
                           "paper size (kB)"], rows)


def rmse_table(data: dict, model: str) -> str:
    """Table 2/3 for one model: RMSE [mm] of each method against FEM, relative RMSE, published figures, ratios."""
    records = index(data)
    methods = [m for m in methods_of(data, model) if m != REFERENCE]
    published = paper_methods()
    others = [m for m in published if m != OURS]
    ours = short_label(OURS)
    header = (["Load", "Force"] + [f"{short_label(m)} (mm)" for m in methods]
              + [f"{short_label(m)} rel." for m in methods] + [f"paper {short_label(m)}" for m in published]
              + [name for m in others for name in (f"{ours}/{short_label(m)}", f"paper {ours}/{short_label(m)}")]
              + ["best"])
    rows = []
    for load, force in cases_of(data, model):
        got = {m: records.get((model, load, force, m)) for m in methods}
        rmse = {m: (r["rmse_mm"] if r else None) for m, r in got.items()}
        pub = {m: paper.rmse_mm(model, load, force, m) for m in published}
        best = min((m for m in methods if rmse[m] is not None), key=lambda m: rmse[m], default=None)
        rows.append([load, f"{force:g} N"] + [fmt(rmse[m]) for m in methods]
                    + [fmt(got[m]["relative_rmse"] if got[m] else None, 3) for m in methods]
                    + [fmt(pub[m]) for m in published]
                    + [fmt(_div(a.get(OURS), a.get(m)), 3) for m in others for a in (rmse, pub)]
                    + [short_label(best) if best else "–"])
    return markdown_table(header, rows)


def time_table(data: dict, model: str) -> str:
    """Table 4/5 for one model: per-step time [ms] of each method, equilibrium time, published figures, ratios."""
    records = index(data)
    methods = methods_of(data, model)
    published = (*paper_methods(), REFERENCE)
    claims = paper.STEP_CLAIMS
    header = (["Load", "Force"] + [f"{short_label(m)} step" for m in methods]
              + [f"paper {short_label(m)}" for m in published]
              + [name for a, b in claims for name in (f"{short_label(a)}/{short_label(b)}",
                                                      f"paper {short_label(a)}/{short_label(b)}")]
              + [f"{short_label(m)} equil." for m in methods])
    rows = []
    for load, force in cases_of(data, model):
        got = {m: records.get((model, load, force, m)) for m in methods}
        step = {m: (r["step_ms"] if r else None) for m, r in got.items()}
        pub = {m: paper.time_ms(model, load, force, m) for m in published}
        rows.append([load, f"{force:g} N"] + [fmt(step[m], 3) for m in methods]
                    + [fmt(pub[m], 3) for m in published]
                    + [fmt(_div(t.get(a), t.get(b)), 3) for a, b in claims for t in (step, pub)]
                    + [fmt(got[m]["equilibrium_ms"] if got[m] else None, 3) for m in methods])
    return markdown_table(header, rows)


def ratio_table(data: dict) -> str:
    """The headline ratios per model, ours beside the paper's."""
    summary = ratio_summary(data)
    names = ratios()
    header = ["Model"] + [f"{name} ({who})" for name in names for who in ("ours", "paper")]
    rows = [[model] + [fmt(v, 3) for name in names for v in summary[model][name]] for model in summary]
    return markdown_table(header, rows)


def tables_markdown(data: dict) -> str:
    """The whole ``tables.md``: Table 1, the RMSE tables (2, 3), the time tables (4, 5), extra models, ratios."""
    models = models_of(data)
    meta = data["metadata"]
    options = meta["options"]
    parts = [
        "# The paper's Tables 1–5, reproduced",
        "",
        f"tissuesim {meta['tissuesim']}, {meta['date']}, {meta['machine']['processor']} "
        f"({meta['machine']['cpus']} CPUs), Python {meta['python']}. Forces "
        f"{', '.join(f'{f:g}' for f in options['forces'])} N.",
        "",
        "Column legend:",
        "",
        *column_legend(meta),
        "",
        "## Headline ratios (medians over load cases)",
        "",
        ratio_table(data),
        "",
        "## Table 1: models",
        "",
        "The paper does not say what its size column measures; ours is the file size defined in the legend.",
        "",
        table1(data),
    ]
    for number, title, table, kind in ((2, "RMSE on the real mesh models (mm)", paper.RMSE_TABLE, rmse_table),
                                       (3, "RMSE on the shape models (mm)", paper.RMSE_TABLE, rmse_table),
                                       (4, "Time on the shape models (ms)", paper.TIME_TABLE, time_table),
                                       (5, "Time on the real mesh models (ms)", paper.TIME_TABLE, time_table)):
        members = [m for m in models if table.get(m) == number]
        if not members:
            continue
        parts += ["", f"## Table {number}: {title}"]
        for model in members:
            parts += ["", f"### {model}", "", kind(data, model)]
    extra = [m for m in models if m not in paper.RMSE_TABLE]
    for model in extra:
        parts += ["", f"## Additional model: {model}", "", "### RMSE (mm)", "", rmse_table(data, model), "",
                  "### Time (ms)", "", time_table(data, model)]
    parts += ["", "## Notes on the published tables", ""] + [f"- {note}" for note in paper.NOTES]
    return "\n".join(parts) + "\n"


def column_legend(meta: dict) -> list[str]:
    """The Markdown bullets defining every column of ``tables.md`` (``meta``: the results document's metadata)."""
    options = meta["options"]
    material = options.get("material", "linear")
    return [
        f"- **Methods**: Ours = hybrid (§6), PBD = surface-only PBD, MSM = mass-spring, Emb. = embedded surface (not "
        f"in the paper), FEM = fine-volume FEM ({material}), the reference.",
        "- **#node, #elem**: the mesh's nodes and elements (triangles for M_S, tetrahedra for a volume); "
        f"**size (kB)**: {SIZE_DEFINITION}.",
        "- **X (mm)**: method X's RMSE against FEM (eq 26) over the 50 surface nodes nearest the load node; "
        "**X rel.**: that RMSE over the reference's RMS displacement over the same nodes (0.1 = 10 % of the "
        "deformation).",
        f"- **X step (ms)**: median wall time of one `step(dt)` under the load, over {options['timing_steps']} steps "
        f"after {options['warmup_steps']} warm-up steps; **X equil. (ms)**: wall time of the static solve to "
        "equilibrium (`solve_static`).",
        "- **A/B**: A's figure over B's in the same row (RMSE: below 1, Ours is more accurate; FEM/Ours step: above "
        "1, Ours is faster); **best**: the method with the lowest RMSE in the row.",
        "- **paper …**: the published figure (– where the paper has none).",
    ]


def _div(a, b):
    return a / b if a is not None and b not in (None, 0) else None


def finite_validity(data: dict) -> list[str]:
    """Per model: inverted elements of the finite-strain solves, and the presses beyond the stable dead-load range
    that were not run."""
    lines = []
    for model in dict.fromkeys([*models_of(data), *data["metadata"]["models"]]):   # a model may have no solve left
        records = [r for r in data["records"] if r["model"] == model and "inverted_elements" in r]
        inverted = [r for r in records if r["inverted_elements"]]
        if records:
            lines.append(f"{model}: no finite-strain solve inverted an element ({len(records)} solves)" if not inverted
                         else f"{model}: {len(inverted)} of {len(records)} finite-strain solves inverted elements "
                         "(worst: " + ", ".join(f"{r['method']} {r['load']} {r['force_N']:g} N: "
                                                f"{r['inverted_elements']}" for r in inverted[:3]) + ")")
        beyond = data["metadata"]["models"].get(model, {}).get("beyond_stable_press", [])
        if beyond:
            lines.append(f"{model}: {len(beyond)} pressure cases not run, beyond the stable dead-load range: "
                         + ", ".join(f"{b['force_N']:g} N" + (f" at R = {b['radius_mm']:g} mm" if "radius_mm" in b
                                                               else "") for b in beyond)
                         + f" ({beyond[0]['reason']}); a press that large is a contact driven by displacement (a "
                         "rigid tip), not by a fixed force")
        for entry in data["metadata"]["models"].get(model, {}).get("unstable_reference", []):
            lines.append(f"{model}: {entry['load']} {entry['force_N']:g} N at R = {entry['radius_mm']:g} mm not "
                         f"compared: {entry['reason']}")
    lines.append("Finite strain holds at any strain; contact of the surface with itself is not detected, so a fold "
                 "that would touch passes through itself.")
    return lines
