"""The package's levels as a picture (docs/architecture.md): one row per level of the import contract in
pyproject.toml, top to bottom, each module a box; a module imports only from the rows below its own.

    python benchmarks/architecture_figure.py [--output docs/figures/architecture.png]
"""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: What each level is for, beside its row.
ROLES = {
    "cli": "the command line", "commands": "one module per sub-command", "viewer": "the interactive simulator",
    "study": "parameter studies (Dask)", "experiments": "the paper's and the contact protocols, haptics, scenes",
    "tools": "the instruments, each a Tool; where recordings go",
    "solvers": "the methods: one module each, with its card", "cutting": "the cut on arrays, the surface layer",
    "fem": "finite elements, files", "mesh": "meshes, loads",
    "compile_notice": "kernel compiles announced, the registries of names",
    "errors": "errors, the kernel cache",
}


def levels() -> list[list[str]]:
    """The layers of the import contract, top first, each a list of its modules."""
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    layers = next(c for c in contracts if c["type"] == "layers")["layers"]
    return [[name.strip() for name in layer.split("|")] for layer in layers]


def figure(rows: list[list[str]]):
    fig, ax = plt.subplots(figsize=(10.0, 0.55 * len(rows) + 0.9))
    ax.set_xlim(0.0, 10.0)
    ax.set_ylim(-0.6, len(rows) + 0.2)
    ax.axis("off")
    for level, modules in enumerate(rows):
        y = len(rows) - 1 - level
        width = 5.6 / len(modules)
        for k, module in enumerate(modules):
            x = 0.2 + k * width
            highlight = module in ("solvers", "tools")
            ax.add_patch(plt.Rectangle((x + 0.04, y + 0.08), width - 0.08, 0.72, linewidth=0.8,
                                       facecolor="#f4c7c3" if highlight else "#dde7f3", edgecolor="0.35"))
            ax.text(x + width / 2, y + 0.44, module, ha="center", va="center", fontsize=8.5, family="monospace")
        ax.text(6.0, y + 0.44, ROLES.get(modules[0], ""), ha="left", va="center", fontsize=8.5, color="0.25")
    ax.annotate("", xy=(5.95, 0.1), xytext=(5.95, len(rows) - 0.2),
                arrowprops={"arrowstyle": "->", "color": "0.4", "linewidth": 1.0})
    ax.text(0.2, -0.45, "A module imports only from the rows below its own (import-linter's contract, checked in "
            "the tests); modules of one row are independent.", fontsize=8, color="0.25")
    fig.tight_layout()
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=ROOT / "docs" / "figures" / "architecture.png")
    args = parser.parse_args(argv)
    figure(levels()).savefig(args.output, dpi=130)
    print(args.output)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
