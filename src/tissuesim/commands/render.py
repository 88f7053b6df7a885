"""``tissuesim render [MODELS] --output DIR``: the paper's Fig 11 and Fig 16 as PNG files, drawn offscreen (EGL).

Per model: ``deformation_<model>.png`` (at rest, tension, pressure) and, where ``tissuesim.Scalpel`` is installed,
``incision_<model>.png``. ``--report FILE`` adds (or replaces) a "Figures" section linking them in a Markdown
report. ``--if-available`` turns "no OpenGL here" into one line on stderr and exit status 0, so ``make run`` goes
on without figures on a machine that cannot draw.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "render the paper's figures (Fig 11 deformation, Fig 16 incision) offscreen into PNG files"
SECTION = "## Figures"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("models", nargs="*", metavar="MODEL",
                        help="built-in model, surface file or hybrid bundle (default: the four built-in models)")
    parser.add_argument("--output", "-o", type=Path, default=Path("results"), metavar="DIR",
                        help="folder for the PNG files, created if absent (default: results)")
    parser.add_argument("--method", default="hybrid", help="solver drawn (default: hybrid)")
    parser.add_argument("--force", type=float, default=None, metavar="N",
                        help="load of the deformation figure in newtons (default: 5)")
    parser.add_argument("--radius", type=float, default=None, metavar="MM",
                        help="spread the load over a pin-head contact patch of this radius in mm (default: one node, "
                             "as the experiments)")
    parser.add_argument("--resolution", type=int, default=None, help="vertex count of the built-in models")
    parser.add_argument("--scale", type=float, default=1.0, help="factor from a surface file's unit to metres")
    parser.add_argument("--report", type=Path, default=None, metavar="FILE.md",
                        help="add a Figures section linking the images to this Markdown report")
    parser.add_argument("--if-available", action="store_true",
                        help="where no OpenGL is available, say so in one line and exit 0")


def run(args: argparse.Namespace) -> int:
    from ..experiments.output import check_output_folder
    from ..mesh.models import MODELS
    from ..viewer.controller import scalpel_class
    from ..viewer.figures import FIGURE_FORCE, deformation_figure, incision_figure
    from ..viewer.gl import NoOpenGLError, polyscope
    from ..solvers.registry import solver_class
    from .view import load_hybrid

    solver_class(args.method)  # an unknown method is refused before any work
    try:
        polyscope(headless=True)  # fail early, before any mesh is built
    except NoOpenGLError as error:
        if not args.if_available:
            raise
        print(f"tissuesim render: figures skipped: {error}", file=sys.stderr)
        return 0
    check_output_folder(args.output).mkdir(exist_ok=True)
    cutting = scalpel_class() is not None
    if not cutting:
        print("tissuesim render: this installation has no tissuesim.Scalpel, incision figures skipped",
              file=sys.stderr)
    written = []
    for spec in args.models or MODELS:
        hybrid, name = load_hybrid(spec, resolution=args.resolution, scale=args.scale, progress=False)
        written.append(deformation_figure(hybrid, name, args.output / f"deformation_{name}.png", method=args.method,
                                          force=args.force or FIGURE_FORCE,
                                          radius=None if args.radius is None else 1e-3 * args.radius))
        if cutting:
            written.append(incision_figure(hybrid, name, args.output / f"incision_{name}.png", method=args.method))
        print(f"rendered {name}", file=sys.stderr)
    if args.report is not None:
        link_figures(args.report, written)
    print(f"wrote {len(written)} figures to {args.output}/", file=sys.stderr)
    return 0


def link_figures(report: Path, figures: list[Path]) -> None:
    """Add or replace the Figures section of the Markdown ``report``, linking ``figures`` relative to it."""
    text = report.read_text() if report.exists() else ""
    text = text.split(f"\n{SECTION}\n")[0].strip("\n")
    links = "\n\n".join(f"![{f.stem}]({_relative(f, report.parent)})" for f in figures)
    report.write_text(f"{text}\n\n{SECTION}\n\nDrawn by `tissuesim render` (Fig 11: deformation; Fig 16: incision)."
                      f"\n\n{links}\n")


def _relative(path: Path, folder: Path) -> str:
    try:
        return path.resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:
        return path.resolve().as_posix()
