"""``report.md`` of the contact protocol: the references' convergence tables, then per-method and per-case errors.

Print the per-method table of a finished run with::

    python -m tissuesim.experiments.contact_report results/contact/results.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from .methods import short_label
from .tables import finite_validity, fmt, markdown_table

METRIC_LABELS = {"rmse": "RMSE (all samples)", "rmse_outside": "RMSE (outside patch)",
                 "contact_error": "error at contact"}


def method_table(data: dict, *, role: str = "held out") -> str:
    """Markdown: per method, the median and largest relative error of each metric over the rows of ``role``."""
    rows = []
    for method in data["metadata"]["methods"]:
        records = [r for r in data["records"] if r["method"] == method and r["role"] == role]
        if not records:
            continue
        row = [short_label(method), str(len(records))]
        for metric in ("rmse", "rmse_outside", "contact_error"):
            values = [r[f"relative_{metric}"] for r in records if r[f"relative_{metric}"] is not None]
            row.append(f"{fmt(float(np.median(values)), 3)} / {fmt(max(values), 3)}" if values else "–")
        rmse = [r["rmse_mm"] for r in records if r["rmse_mm"] is not None]
        row.append(fmt(float(np.median(rmse)), 3) if rmse else "–")
        row.append(str(sum("error" in r for r in records)))
        rows.append(row)
    headers = ["Method", "Rows"] + [f"{METRIC_LABELS[m]}, median / max (rel.)" for m in METRIC_LABELS]
    return markdown_table(headers + ["RMSE median (mm)", "Failed"], rows)


def ratio_table(data: dict, *, embedded_ratio: float = 0.5, pbd_ratio: float = 0.3, absolute: float = 0.10) -> str:
    """Markdown: for each hybrid variant, over the held-out rows, its relative RMSE against Emb.'s and PBD's in the
    same row (median and largest ratio) and how many rows reach ≤ ``embedded_ratio`` × Emb., ≤ ``pbd_ratio`` ×
    PBD and ≤ ``absolute``, separately and all three at once."""
    by_case = {}
    for r in data["records"]:
        if r["role"] == "held out" and r["relative_rmse"] is not None:
            case = (r["model"], r["radius_mm"], r["load"], r["force_N"])
            by_case.setdefault(case, {})[r["method"]] = r["relative_rmse"]
    rows = []
    for method in ("hybrid", "hybrid-near", "hybrid-quadratic"):
        cases = [c for c in by_case.values() if {method, "embedded", "pbd"} <= set(c)]
        if not cases:
            continue
        to_emb = np.array([c[method] / c["embedded"] for c in cases])
        to_pbd = np.array([c[method] / c["pbd"] for c in cases])
        own = np.array([c[method] for c in cases])
        met = (to_emb <= embedded_ratio) & (to_pbd <= pbd_ratio) & (own <= absolute)
        rows.append([short_label(method), str(len(cases)),
                     f"{fmt(float(np.median(to_emb)), 3)} / {fmt(float(to_emb.max()), 3)}",
                     f"{fmt(float(np.median(to_pbd)), 3)} / {fmt(float(to_pbd.max()), 3)}",
                     str(int((to_emb <= embedded_ratio).sum())), str(int((to_pbd <= pbd_ratio).sum())),
                     str(int((own <= absolute).sum())), str(int(met.sum()))])
    return markdown_table(["Method", "Rows", "÷ Emb., median / max", "÷ PBD, median / max",
                           f"rows ≤ {embedded_ratio:g}× Emb.", f"rows ≤ {pbd_ratio:g}× PBD",
                           f"rows ≤ {absolute:g}", "rows meeting all three"], rows)


def _floor_lines(meta: dict) -> list[str]:
    """The range of the load rule floor per R (the error of an exact solve of the solvers' nodal forces)."""
    floors = {}
    for info in meta["models"].values():
        for radius, ref in info["references"].items():
            if ref.get("load_rule_floor") is not None:
                floors.setdefault(radius, []).append(ref["load_rule_floor"])
    if not floors:
        return []
    ranges = "; ".join(f"R = {radius} mm: {fmt(min(v), 3)}–{fmt(max(v), 3)}" for radius, v in floors.items())
    return [f"Load rule floor (relative RMSE of the exact response to the solvers' nodal forces against the "
            f"reference: the error a method solving its load exactly would have): {ranges}.", ""]


def case_table(data: dict) -> str:
    """Markdown: one row per model × R × load × force × method with the six figures and the row's role."""
    rows = []
    for r in data["records"]:
        rows.append([r["model"], f"{r['radius_mm']:g}", r["load"], f"{r['force_N']:g}",
                     short_label(r["method"]), r["role"],
                     *(f"{fmt(r[f'{m}_mm'], 3)} ({fmt(r[f'relative_{m}'], 3)})" for m in METRIC_LABELS),
                     "failed" if "error" in r else ("" if r["converged"] else "unsettled")])
    return markdown_table(["Model", "R (mm)", "Load", "Force (N)", "Method", "Row"]
                          + [f"{METRIC_LABELS[m]}, mm (rel.)" for m in METRIC_LABELS] + ["Note"], rows)


def convergence_table(levels: list) -> str:
    """Markdown of one reference's refinement: level, tets, local size, sample RMS, contact value, change."""
    rows = [[str(row["level"]), str(row["tets"]), fmt(row["contact_size_mm"], 3),
             "–" if row["grading"] is None else fmt(row["grading"], 3), fmt(row["sample_rms_mm"], 4),
             fmt(row["contact_mm"], 4), "–" if row["change"] is None else f"{100 * row['change']:.2f} %"]
            for row in levels]
    return markdown_table(["Level", "Tets", "h_c at contact (mm)", "Grading", "Sample RMS (mm/N)",
                           "Contact node (mm/N)", "Change"], rows)


def contact_report_markdown(data: dict) -> str:
    """The text of the contact protocol's ``report.md``."""
    meta = data["metadata"]
    material = meta.get("material", "linear")
    parts = _summary(meta, material) + ["## Errors per method (held-out rows)", "", method_table(data), ""]
    ratios = ratio_table(data)
    if ratios.count("\n") > 1:
        parts += ["## The hybrid against the embedded surface and PBD, row by row (held out)", "",
                  "Relative RMSE over all samples, divided by the other method's in the same row. Ours+NF is the "
                  "hybrid with its near field (`near_field`, docs/solvers.md).", "", ratios, "", *_floor_lines(meta)]
    if any(r["role"] == "calibration" for r in data["records"]):
        parts += ["## Errors per method (calibration row)", "", method_table(data, role="calibration"), ""]
    if material != "linear":
        parts += [f"## Validity of the {material} runs", ""] + [f"- {line}" for line in finite_validity(data)] + [""]
    parts += _reference_sections(meta, material) + _failure_notes(data)
    parts += ["## Every case", "", case_table(data), ""]
    return "\n".join(parts)


def _summary(meta: dict, material: str) -> list[str]:
    """The report's title and opening paragraphs: what was run, on which material, and which row calibrates."""
    settings = meta["refinement"]
    calibration = meta["calibration_case"]
    return [
        "# Contact protocol report",
        "",
        f"Models: {', '.join(meta['models'])}. Loads: {' and '.join(meta['loads'])} at "
        f"{', '.join(f'{f:g}' for f in meta['forces_N'])} N, contact radius R = "
        f"{', '.join(f'{r:g}' for r in meta['radii_mm'])} mm. Methods: "
        f"{', '.join(short_label(m) for m in meta['methods'])}. {meta['wall_s']:.0f} s on {meta['cpus']} CPUs, "
        f"{meta['date']}.",
        "",
        "Material: linear elasticity (small strain), for the methods and the reference." if material == "linear"
        else f"Material: {material} (finite strain), for every method that has it and for the reference.",
        "",
        f"Calibration row: {calibration[0]}, {calibration[1]}, {calibration[2]:g} N, R = {calibration[3]:g} mm; "
        "every other row is held out. Errors are relative to the reference's RMS displacement over the "
        f"{settings['samples']} samples.",
        "",
    ]


def _reference_sections(meta: dict, material: str) -> list[str]:
    """The references: how they were refined, then each one's convergence table and load rule floor, then the
    radii skipped."""
    settings = meta["refinement"]
    per = ("per unit force along −z" if material == "linear" else
           f"{material} quadratic-tet FEM (Newton) under each load; the table's displacements are per newton of the "
           "largest stable load (the response is not linear in the force), its change the largest over the loads")
    parts = ["## References", "",
             f"Refined until the sample displacements change by less than {100 * settings['tolerance']:g} % "
             f"between levels (at most level {settings['max_levels']}); {per}.", ""]
    for model, info in meta["models"].items():
        for radius, ref in info["references"].items():
            status = "converged" if ref["converged"] else (
                f"**not converged** (last change {100 * ref['levels'][-1]['change']:.2f} %)"
                if ref["levels"][-1]["change"] is not None else "**not converged**")
            parts += [f"### {model}, R = {radius} mm: {status}", "", convergence_table(ref["levels"]), ""]
            if ref.get("load_rule_floor") is not None:
                parts += [f"Load rule floor: {fmt(ref['load_rule_floor'], 3)} (relative RMSE of the exact response "
                          "to the solvers' nodal forces against this reference).", ""]
    for model, info in meta["models"].items():
        for radius, reason in info.get("skipped", {}).items():
            parts += [f"Skipped: {model}, R = {radius} mm: {reason}", ""]
    return parts


def _failure_notes(data: dict) -> list[str]:
    """How many solves failed (and the first one's error) and how many did not settle."""
    parts = []
    failed = [r for r in data["records"] if "error" in r]
    if failed:
        parts += [f"{len(failed)} solves failed and have no figures; the first: {failed[0]['method']} on "
                  f"{failed[0]['model']}, R = {failed[0]['radius_mm']:g} mm, {failed[0]['load']} "
                  f"{failed[0]['force_N']:g} N: {failed[0]['error']}", ""]
    unsettled = [r for r in data["records"] if not r["converged"] and "error" not in r]
    if unsettled:
        parts += [f"{len(unsettled)} solves did not settle within the step cap, or turned the mass-spring surface "
                  "inside out (which springs cannot undo), and are measured at their last positions (marked in the "
                  "table).", ""]
    return parts


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m tissuesim.experiments.contact_report RESULTS.json", file=sys.stderr)
        return 2
    try:
        data = json.loads(Path(argv[0]).read_text())
    except (OSError, ValueError) as error:
        print(f"error: cannot read {argv[0]}: {error}", file=sys.stderr)
        return 1
    print(method_table(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
