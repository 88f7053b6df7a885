"""``tissuesim render [MODELS] --output DIR``: the paper's Fig 11 and Fig 16 as PNG files, drawn offscreen (EGL).

Per model: ``deformation_<model>.png`` (at rest, tension, pressure) and, where ``tissuesim.Scalpel`` is installed,
``incision_<model>.png`` (skipped with one line for a method that cannot be cut, such as fem). ``--report FILE``
adds (or replaces) a "Figures" section linking them, by paths relative to FILE (in ``<…>`` where a path holds a
space), in a Markdown report. ``--if-available`` turns "no OpenGL here" into one line on stderr and exit status 0, so
``make run`` goes on without figures on a machine that cannot draw.

Every argument is checked before any drawing (an unwritable ``--report``, ``--force 0``, a negative ``--radius``);
each file is written whole or not at all (written beside its target and renamed), so an interrupted run leaves no
truncated PNG or report.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

from .fixing import add_fix_argument

HELP = "render the paper's figures (Fig 11 deformation, Fig 16 incision) offscreen into PNG files"
SECTION = "## Figures"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("models", nargs="*", metavar="MODEL",
                        help="built-in model, surface file or hybrid bundle (default: the four built-in models)")
    parser.add_argument("--output", "-o", default="results", metavar="DIR",
                        help="folder for the PNG files, created if absent (default: results)")
    parser.add_argument("--method", default="hybrid", help="solver drawn (default: hybrid)")
    parser.add_argument("--force", type=float, default=None, metavar="N",
                        help="load of the deformation figure in newtons (default: sized to the model and its "
                             "material, so the figure stays in the small-strain range; printed)")
    parser.add_argument("--radius", type=float, default=None, metavar="MM",
                        help="spread the load over a pin-head contact patch of this radius in mm (default: 5 %% of "
                             "the model's size)")
    add_fix_argument(parser)
    parser.add_argument("--resolution", type=int, default=None, help="vertex count of the built-in models")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="factor from a surface file's unit to metres, applied to a built-in model too (a bundle "
                             "is in metres and not scaled)")
    parser.add_argument("--repair", action="store_true",
                        help="repair safe defects of a surface file (orientation, self-intersections) instead of "
                             "refusing them")
    parser.add_argument("--report", default=None, metavar="FILE.md",
                        help="add a Figures section linking the images to this Markdown report")
    parser.add_argument("--if-available", action="store_true",
                        help="where no OpenGL is available, say so in one line and exit 0")


def run(args: argparse.Namespace) -> int:
    from ..solvers.cut_carry import refusal
    from ..experiments.output import check_output_folder
    from ..experiments.inputs import check_model_specs, check_resolution
    from ..io import check_scale, remove_abandoned_partials
    from ..solvers.checks import positive_number
    from ..viewer.controller import scalpel_class
    from ..experiments.wound import TOOL_HEIGHT
    from ..viewer.figures import deformation_figure, incision_figure
    from .fixing import check_fix
    from ..viewer.gl import NoOpenGLError, polyscope
    from ..solvers.registry import solver_class

    # every argument is checked before any work; a value given is used as given, never replaced by a default
    solver_class(args.method)
    check_model_specs(args.models)
    check_scale(args.scale)
    if args.resolution is not None:
        check_resolution(args.resolution)
    force = None if args.force is None else positive_number("--force", args.force, "N")
    radius_mm = None if args.radius is None else positive_number("--radius", args.radius, "mm")
    check_fix(args.fix)
    report = None if args.report is None else check_report(args.report)
    output = check_output_folder(args.output)
    if output.is_dir():
        remove_abandoned_partials(output)     # images of a killed run, never renamed into place
    try:
        polyscope(headless=True)  # fail early, before any mesh is built
    except NoOpenGLError as error:
        if not args.if_available:
            raise
        print(f"tissuesim render: figures skipped: {error}", file=sys.stderr)
        return 0
    models = _load_models(args)     # every model read and checked before the first is drawn
    models = [(hybrid, name, *_sized(args, hybrid, name, force=force, radius_mm=radius_mm))
              for hybrid, name in models]
    cutting = _cutting(scalpel_class() is not None, refusal(args.method))
    created = not output.exists()
    output.mkdir(exist_ok=True)
    try:
        written = []
        for hybrid, name, fixed, loads in models:
            written.append(deformation_figure(hybrid, name, output / f"deformation_{name}.png", method=args.method,
                                              force=loads.force, radius=loads.radius, fixed=fixed))
            if cutting:
                written.append(incision_figure(hybrid, name, output / f"incision_{name}.png", method=args.method,
                                               force=loads.pull, fixed=fixed, length=loads.stroke,
                                               depth=TOOL_HEIGHT + loads.depth, offset=loads.offset))
            print(f"rendered {name}", file=sys.stderr)
    except BaseException:
        if created and not any(output.iterdir()):
            output.rmdir()          # a failed or interrupted first run leaves no empty folder behind
        raise
    if report is not None:
        link_figures(report, written)
    print(f"wrote {len(written)} figures to {output}/", file=sys.stderr)
    return 0


def _load_models(args) -> list:
    """``[(HybridMesh, name)]`` of the models to draw, each checked for the method (fem needs the fine volume)."""
    from ..experiments.inputs import check_fine_volume
    from ..mesh.models import MODELS
    from .view import load_hybrid

    models = []
    for spec in args.models or MODELS:
        hybrid, name = load_hybrid(spec, resolution=args.resolution, scale=args.scale, repair=args.repair,
                                   progress=False)
        if args.method == "fem":
            check_fine_volume(hybrid, spec)
        models.append((hybrid, name))
    return models


def _sized(args, hybrid, name: str, *, force: float | None, radius_mm: float | None) -> tuple:
    """``(fixed, LoadDefaults)`` of one model: the solvers' ``fixed`` option from ``--fix``, and the figures' loads
    and tool sizes, each given one used as given and the others sized to the model (:mod:`tissuesim.mesh.sizes`),
    said in one line."""
    from dataclasses import replace

    from ..experiments.inputs import check_free_node
    from ..experiments.protocol import LOAD_DIRECTIONS, load_node
    from ..experiments.wound import incision_line, pull_node
    from ..mesh.sizes import fitted_force, load_defaults
    from ..solvers.registry import make_solver
    from .fixing import fixed_option

    fixed, held = fixed_option(args.fix, hybrid.surface.vertices)
    solver = make_solver(args.method, hybrid, fixed=fixed)
    loads = load_defaults(solver.rest_positions, edge_length=hybrid.surface.mean_edge_length,
                          youngs_modulus=solver.youngs_modulus, poisson_ratio=solver.poisson_ratio)
    if radius_mm is not None:
        loads = replace(loads, radius=1e-3 * radius_mm)
    notes = []
    node = load_node(solver.rest_positions, hybrid.surface.triangles)
    check_free_node(solver, node, name, role="the figure's load at its top centre")
    if force is None:
        fitted, moved = fitted_force(solver, node, loads.force, LOAD_DIRECTIONS.values(), radius=loads.radius)
        notes += [] if fitted == loads.force else [_capped("force", loads.force, moved)]
        loads = replace(loads, force=fitted)
    else:
        loads = replace(loads, force=force)
    pulled = pull_node(solver.rest_positions, incision_line(solver.rest_positions, length=loads.stroke),
                       offset=loads.offset)
    if pulled not in solver.fixed:      # else the incision figure refuses the pull, saying why
        pull, moved = fitted_force(solver, pulled, loads.pull, [(0.0, 1.0, 0.0)])
        notes += [] if pull == loads.pull else [_capped("pull", loads.pull, moved)]
        loads = replace(loads, pull=pull)
    given = [f"--{option}" for option, value in (("force", force), ("radius", radius_mm)) if value is not None]
    print(f"tissuesim render: {name}: {held}; {loads.describe()}" + (f" ({', '.join(given)} as given)" if given
                                                                     else "") + "".join(f"; {n}" for n in notes),
          file=sys.stderr)
    return fixed, loads


def _capped(what: str, estimate: float, moved: float) -> str:
    from ..mesh.sizes import DISPLACEMENT_CAP

    return (f"the {what} lowered from {estimate:.3g} N, which moves this model {moved:.2g} of its size on its "
            f"support, to move it {DISPLACEMENT_CAP:g}")


def _cutting(installed: bool, refused: str | None) -> bool:
    """Whether to draw the incision figures; where not, say why in one line."""
    if not installed:
        print("tissuesim render: this installation has no tissuesim.Scalpel, incision figures skipped",
              file=sys.stderr)
    elif refused:
        print(f"tissuesim render: incision figures skipped: {refused}", file=sys.stderr)
    return installed and not refused


def check_report(text: str) -> Path:
    """``--report`` as a Path, refused before any drawing where the Figures section cannot be written to it: an empty
    path, a folder, a device, a missing folder, a place where no file can be created (tried for real), or a file that
    is not text."""
    from ..experiments.output import OutputError
    from ..mesh.bundle_check import temporary_prefix

    if not str(text).strip():
        raise OutputError("--report is empty; give the path of a Markdown file, e.g. --report results/report.md")
    report = Path(text)
    if report.is_dir():
        raise OutputError(f"--report {report} is a folder, not a Markdown file; give a file path, e.g. "
                          f"{report / 'report.md'}")
    if report.exists() and not report.is_file():
        raise OutputError(f"--report {report} is not a regular file (a device or pipe); give the path of a Markdown "
                          "file, e.g. --report results/report.md")
    if report.is_symlink():
        report = report.resolve()       # written through the link: its target's folder must take the new file
    if not report.parent.is_dir():
        raise OutputError(f"--report {report}: the folder {report.parent} does not exist; create it or give "
                          "another path")
    try:
        handle, probe = tempfile.mkstemp(prefix=temporary_prefix(report), dir=report.parent)
    except OSError as error:
        raise OutputError(f"cannot write --report {report}: {error.strerror or error} in {report.parent}; choose "
                          "another path or make that folder writable") from None
    os.close(handle)
    os.unlink(probe)
    if not report.exists():
        return report
    try:
        report.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise OutputError(f"cannot read --report {report} to add the Figures section to it: {error}; give a "
                          "Markdown file") from None
    return report


def link_figures(report: Path, figures: list[Path]) -> None:
    """Add or replace the Figures section of the Markdown ``report``, linking ``figures`` by paths relative to it
    (written whole or not at all, through a symbolic link to its target, keeping the file's mode). The section runs
    to the next heading of its level or higher; what follows it is kept."""
    from ..io import replaced_atomically

    text = report.read_text() if report.exists() else ""
    before, after = _around_section(text)
    links = "\n\n".join(f"![{f.stem}]({_destination(f, report.parent)})" for f in figures)
    section = (f"{SECTION}\n\nDrawn by `tissuesim render` (Fig 11: deformation; Fig 16: incision).\n\n{links}\n")
    with replaced_atomically(report) as partial:
        partial.write_text(f"{before}\n\n{section}" + (f"\n{after}" if after else ""))


def _around_section(text: str) -> tuple[str, str]:
    """The Markdown ``text`` before and after its Figures section (the whole text and "" where it has none)."""
    match = re.search(rf"^{re.escape(SECTION)}[ \t]*$", text, flags=re.MULTILINE)
    if match is None:
        return text.strip("\n"), ""
    following = re.search(r"^#{1,2}[ \t]", text[match.end():], flags=re.MULTILINE)
    after = "" if following is None else text[match.end() + following.start():]
    return text[:match.start()].strip("\n"), after


def _destination(path: Path, folder: Path) -> str:
    """A Markdown link destination for ``path`` relative to ``folder``: bare where it can be, else in ``<…>`` (a
    bare destination ends at a space and needs balanced parentheses)."""
    relative = Path(os.path.relpath(path.resolve(), folder.resolve())).as_posix()
    if not re.search(r"[\s()<>\\]", relative):
        return relative
    return "<" + re.sub(r"([<>\\])", r"\\\1", relative) + ">"
