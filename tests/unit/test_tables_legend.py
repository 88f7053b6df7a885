"""``tables.md`` defines every column once, in its legend, and Table 1's size is the one `tissuesim build` prints."""

import re

import pytest
from test_experiments_outputs import synthetic_results

from tissuesim.experiments import tables

ROW_KEYS = {"Model", "Mesh", "Load", "Force"}  # the row's name, not a measured column


def legend_terms(text: str) -> set[str]:
    legend = text.split("Column legend:")[1].split("##")[0]
    terms = set()
    for bold in re.findall(r"\*\*(.+?)\*\*", legend):
        terms.update(term.replace(" (ms)", "") for term in bold.split(", "))
    return terms


def column_term(cell: str) -> str:
    """The legend's name for a header cell: a method's label is X, a ratio of two is A/B."""
    if cell.startswith("paper "):
        return "paper …"
    cell = re.sub(r"(Ours|PBD|MSM|Emb\.|FEM)(?=[ /]|$)", "X", cell)
    return "A/B" if cell.startswith("X/X") else cell


def header_cells(text: str) -> set[str]:
    lines = text.splitlines()
    return {cell.strip() for line, below in zip(lines, lines[1:]) if below.startswith("|---")
            for cell in line.strip("|").split("|")}


def test_every_column_of_tables_md_is_in_its_legend():
    text = tables.tables_markdown(synthetic_results(models=("cube", "liver", "bunny")))
    terms = legend_terms(text)
    cells = header_cells(text) - ROW_KEYS
    assert len(cells) > 30  # Table 1, the RMSE and time tables and the ratios were all read
    undefined = sorted(cell for cell in cells if column_term(cell) not in terms)
    assert not undefined, f"columns without a legend entry: {undefined}"


def test_the_legend_names_the_material_of_the_reference():
    data = synthetic_results()
    assert "FEM = fine-volume FEM (linear)" in tables.tables_markdown(data)
    data["metadata"]["options"]["material"] = "neo-hookean"
    assert "FEM = fine-volume FEM (neo-hookean)" in tables.tables_markdown(data)


def test_table1_size_is_defined_as_build_prints_it(capsys):
    from tissuesim.cli import main

    assert tables.SIZE_DEFINITION in tables.tables_markdown(synthetic_results())
    assert main(["build", "cube", "--resolution", "300", "--no-fine-volume"]) == 0
    assert f"size (kB): {tables.SIZE_DEFINITION}" in capsys.readouterr().err.splitlines()


def test_the_experiments_record_the_size_build_prints():
    from tissuesim.experiments.inputs import builtin_surface
    from tissuesim.experiments.sweep_records import ModelSamples, mesh_info
    from tissuesim.mesh.hybrid import HybridMesh
    from tissuesim.mesh.table1 import table1_row

    hybrid = HybridMesh.build(builtin_surface("cube", resolution=300), fine_volume=False)
    info = mesh_info(hybrid, "cube", ModelSamples.of("cube", hybrid), 0.0)
    row = table1_row(hybrid)
    assert info["surface"]["size_kB"] == pytest.approx(row["M_S"]["size_kb"], abs=0.05)
    assert info["volume"]["size_kB"] == pytest.approx(row["M_V"]["size_kb"], abs=0.05)


def test_the_headline_ratios_keep_their_columns_order():
    from tissuesim.experiments.tables import ratios

    # the paper's comparisons of accuracy, then its claims on time, the fine FEM's first (tables.md, report.md)
    assert list(ratios()) == ["Ours/PBD RMSE", "Ours/MSM RMSE", "Ours/Emb. RMSE", "FEM/Ours step", "Ours/PBD step"]
