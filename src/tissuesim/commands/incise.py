"""``tissuesim incise [MODELS] --output DIR``: the paper's Fig 16 incision on every surface method.

For each model and method: a scripted incision across the top (:mod:`tissuesim.experiments.wound`), cut
progressively in 15 moves, then a small force beside the cut, solved to equilibrium. The stroke, its depth, the
force and its distance from the cut are sized to the model (:func:`tissuesim.mesh.sizes.load_defaults`: 0.15 of its
size long; the force lowered where the model's support lets it rock) and said in one line per model; ``--fix``
chooses the region held (default: the bottom tenth). Written to DIR:

* ``<model>_<method>.obj``: the cut surface at its deformed positions;
* ``<model>_<method>.vtu``: the same with the cut's edges as line cells (``cut`` = 1) and the displacement;
* ``incision.md``: the table of cut timings, vertices added, control nodes released, gap widths and the
  invariant checks; ``incision.json``: the same figures.

MODELS are built-in model names, surface files or saved hybrid bundles (``tissuesim build ... -o FILE.npz``). Every
argument is checked and every model read before the first cut: a bad one, or a model the incision does not fit,
is refused at once. DIR is written all or nothing (:mod:`tissuesim.experiments.output`): the results are staged on
its file system and moved in at the end, so an interrupted run leaves DIR as it was; a finished run replaces the files
of an earlier one (those its ``incision.json`` lists) as a whole and says in one line which; no other file in DIR is
touched.

With ``--prestrain ε`` the surface-layer methods (hybrid, pbd) carry a prestressed capsule
(:mod:`tissuesim.layer.prestress`): the table gives the gap of the wound with no force first, then with the force.

The fem reference cannot be cut (its volume would need re-tetrahedralizing); it is listed as refusing.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from .fixing import add_fix_argument

HELP = "cut each model's top with the scalpel (Fig 16) on every surface method; surfaces, gaps, timings, checks"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("models", nargs="*", metavar="MODEL",
                        help="built-in model (cube, sphere, liver, steak), surface file or hybrid bundle; default: the "
                             "four models")
    parser.add_argument("--output", "-o", default="incision", metavar="DIR",
                        help="folder for the surfaces and tables, created if absent (default: incision)")
    parser.add_argument("--methods", nargs="+", metavar="METHOD", default=None,
                        help="surface methods to cut (default: every method the scalpel cuts)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="factor from a surface file's unit to metres, applied to a built-in model too (a bundle "
                             "is in metres and not scaled)")
    parser.add_argument("--resolution", type=int, default=None,
                        help="vertex count of a built-in model (default: its Table-1 size)")
    parser.add_argument("--repair", action="store_true",
                        help="repair safe defects of a surface file (orientation, self-intersections) instead of "
                             "refusing them")
    add_fix_argument(parser)
    parser.add_argument("--pull", type=float, default=None, metavar="N",
                        help="force beside the incision that opens the wound, in newtons (default: sized to the "
                             "model, printed)")
    parser.add_argument("--prestrain", type=float, default=0.0, metavar="EPS",
                        help="in-plane prestrain of the surface (e.g. 0.05), so the wound gapes without force; "
                             "methods without a surface layer take none (default: 0)")


def run(args: argparse.Namespace) -> int:
    from ..errors import SolverError
    from ..experiments.output import (check_no_folder, check_output_folder, earlier_outputs, replacement_note,
                                      write_staged)
    from ..experiments.inputs import check_model_names
    from ..io import check_scale
    from ..mesh.hybrid import HybridMesh
    from ..mesh.models import MODELS
    from ..layer.prestress import check_prestrain
    from ..solvers.registry import available_solvers, method_names
    from ..solvers.checks import positive_number
    from .fixing import check_fix

    # every argument is checked, and every model read, before the first (minutes long) cut
    output = check_output_folder(args.output)
    cuttable = method_names(cuts=True)
    args.methods = list(cuttable) if args.methods is None else args.methods
    unknown = [m for m in args.methods if m not in available_solvers()]
    if unknown:
        raise SolverError(f"unknown method {unknown[0]!r}; choose from {', '.join(cuttable)}")
    prestrain = check_prestrain(args.prestrain)
    check_scale(args.scale)         # for bundles too, which it does not scale: a bad value is never ignored
    check_model_names(args.models)
    check_fix(args.fix)
    pull = None if args.pull is None else positive_number("--pull", args.pull, "N")
    sources = [_source(spec, scale=args.scale, resolution=args.resolution, repair=args.repair, fix=args.fix)
               for spec in args.models or list(MODELS)]
    names = ["incision.json", "incision.md", *(f"{name}_{method}.{ext}" for name, *_ in sources
                                               for method in args.methods for ext in ("obj", "vtu"))]
    check_no_folder(output, names)
    _check_inputs_kept(args.models, output, names)
    for *_, said in sources:        # once every model is checked: a refusal stays one line
        print(said, file=sys.stderr)
    rows, cuts = [], {}
    for name, source, fixed, loads, _ in sources:
        if not isinstance(source, HybridMesh):
            print(f"{name}: building the hybrid mesh", file=sys.stderr)
            source = HybridMesh.build(source, fine_volume=False)
        for method in args.methods:
            row, cut = _one(name, method, source, prestrain, fixed=fixed, loads=loads, pull=pull)
            rows.append(row)
            if cut is not None:
                cuts[f"{name}_{method}"] = cut
    earlier = earlier_outputs(output, ours=incision_files)
    written = write_staged(output, lambda staging: _fill(staging, rows, cuts), ours=incision_files)
    note = replacement_note(output, earlier, written)
    if note:
        print(note, file=sys.stderr)
    print(_table(rows))
    failed = [r for r in rows if r.get("invariants")]
    if failed:
        raise SolverError(f"{len(failed)} cut surfaces break an invariant (first: {failed[0]['model']} "
                          f"{failed[0]['method']}: {failed[0]['invariants'][0]}); see {output / 'incision.md'}")
    return 0


def _source(spec: str, *, scale: float, resolution, repair: bool, fix: str):
    """``(name, SurfaceMesh or HybridMesh, fixed, LoadDefaults, line)`` of a built-in model, a surface file or a
    saved bundle: the solvers' ``fixed`` option from ``--fix`` and the incision's sizes (:mod:`tissuesim.mesh.sizes`),
    checked to fit the incision, and the line that says them."""
    from ..experiments.inputs import model_name
    from ..io import SURFACE_EXTENSIONS
    from ..mesh.hybrid import HybridMesh
    from ..mesh.models import MODELS
    from ..mesh.sizes import load_defaults
    from .build import load_mesh
    from .fixing import fixed_option

    path = Path(spec)
    if spec not in MODELS and path.is_file() and path.suffix.lower() not in SURFACE_EXTENSIONS:
        source = HybridMesh.load(path)      # a bundle is in metres: --scale is for surface files
        surface = source.surface
    else:
        source = surface = load_mesh(spec, scale=scale, resolution=resolution, repair=repair)
    name = model_name(spec)
    fixed, held = fixed_option(fix, surface.vertices)
    loads = load_defaults(surface.vertices, edge_length=surface.mean_edge_length)
    _check_fits(name, surface, loads)
    return name, source, fixed, loads, f"tissuesim incise: {name}: {held}; {loads.describe()}"


def _check_inputs_kept(specs, output: Path, names: list[str]) -> None:
    """Refuse (SolverError) a run that would write one of its own input files (``cube data/cube_pbd.obj -o data``
    writes the cube's pbd surface to data/cube_pbd.obj)."""
    from ..errors import SolverError

    written = [output / name for name in names if (output / name).exists()]
    for spec in specs:
        clash = [path for path in written if Path(spec).is_file() and os.path.samefile(spec, path)]
        if clash:
            raise SolverError(f"the model file {spec} would be replaced by this run's {clash[0].name} in {output}; "
                              "give another --output or move the model file")


def _check_fits(name: str, surface, loads) -> None:
    """Refuse a model the scripted incision of ``loads`` (its stroke and depth) cannot start on, by the test
    :meth:`Scalpel.press` makes: the blade, pressed where the incision starts, must reach the surface."""
    from ..experiments.wound import TOOL_HEIGHT, incision_line
    from ..errors import SolverError
    from ..mesh.maps import closest_on_surface

    reach, stroke = TOOL_HEIGHT + loads.depth, loads.stroke
    vertices = surface.vertices
    start, _ = incision_line(vertices, length=stroke)
    triangle, weights = closest_on_surface(surface, start[None])
    distance = float(np.linalg.norm(weights[0] @ vertices[surface.triangles[triangle[0]]] - start))
    if distance <= reach:
        return
    length = float(np.ptp(vertices[:, 0]))
    where = (f"where the incision starts the surface is {1e2 * distance:.3g} cm from the blade, beyond its "
             f"{1e2 * reach:.3g} cm reach")
    if length < stroke:
        why = (f"the model is {1e2 * length:.3g} cm long along x, shorter than the incision, so {where}; give a "
               "longer model (a surface file in cm or mm needs --scale 0.01 or 0.001)")
    else:
        why = (f"the model is {1e2 * length:.3g} cm long along x, but its top is not flat there: "
               f"{1e2 * stroke / 2:.3g} cm from the top's centre along x, {where}; give a model with a broader "
               "top (the incision runs across it along x, centred)")
    raise SolverError(f"the scripted {1e2 * stroke:.3g} cm incision does not fit {name}: {why}")


def _one(model: str, method: str, hybrid, prestrain: float, *, fixed, loads,
         pull: float | None) -> tuple[dict, tuple | None]:
    """The table row of one model and method, and the cut surface to write: ``(positions (n, 3) [m], triangles
    (m, 3), displacements (n, 3) [m])``, or None where the method refuses to cut. ``fixed``: the solvers' option;
    ``loads``: the incision's :class:`~tissuesim.mesh.sizes.LoadDefaults` (its pull lowered where the model's
    support lets it rock, :func:`~tissuesim.mesh.sizes.fitted_force`); ``pull`` [N]: ``--pull``, used as given."""
    from ..cutting.invariants import check_cut_invariants
    from ..solvers.cut_carry import anchored_nodes, refusal
    from ..experiments.wound import TOOL_HEIGHT, incision_line, open_wound, pull_node, scripted_incision, \
        unloaded_openings
    from ..mesh.sizes import fitted_force
    from ..experiments.inputs import check_free_node
    from ..solvers import make_solver
    from ..solvers.registry import solver_options

    print(f"{model}: {method}", file=sys.stderr)
    if refusal(method):
        return {"model": model, "method": method, "refused": refusal(method)}, None
    prestressed = prestrain > 0.0 and "prestrain" in solver_options(method)
    solver = make_solver(method, hybrid, fixed=fixed, **({"prestrain": prestrain} if prestressed else {}))
    pulled = pull_node(solver.rest_positions, incision_line(solver.rest_positions, length=loads.stroke),
                       offset=loads.offset)
    check_free_node(solver, pulled, model, role="the pull beside the incision")
    if pull is None:
        pull, moved = fitted_force(solver, pulled, loads.pull, [(0.0, 1.0, 0.0)])
        if pull < loads.pull:
            print(f"tissuesim incise: {model}: {method}: the pull lowered from {loads.pull:.3g} N, which moves this "
                  f"model {moved:.2g} of its size on its support, to {pull:.3g} N", file=sys.stderr)
    run = scripted_incision(solver, length=loads.stroke, depth=TOOL_HEIGHT + loads.depth)
    unloaded = unloaded_openings(solver, run["line"]) if prestressed else None
    # a linear answer beyond linear validity is measured, not dropped, and says so in the table
    beyond = [solver.last_solve.warning] if prestressed and solver.last_solve.warning else []
    moves = [r for r in run["moves"][1:-1]]
    move_ms = np.array([1e3 * r.seconds for r in moves])
    mass = getattr(solver, "mass", None)
    total = None if mass is None else float(mass.sum())
    start = time.perf_counter()
    wound = open_wound(solver, run["line"], force=pull, offset=loads.offset)
    beyond += [solver.last_solve.warning] if solver.last_solve.warning else []
    cut = solver.hybrid.surface
    problems = check_cut_invariants(cut.vertices, cut.triangles, masses=getattr(solver, "mass", None),
                                    total_mass=total, anchored=anchored_nodes(solver))
    row = {"model": model, "method": method, "moves": len(moves), "move_ms_mean": float(move_ms.mean()),
           "move_ms_max": float(move_ms.max()), "triangles_split": sum(r.triangles_split for r in moves),
           "vertices_added": sum(r.vertices_added for r in moves),
           "control_released": sum(r.control_released for r in moves),
           "prestrain": prestrain if prestressed else 0.0, "stroke_mm": 1e3 * loads.stroke,
           "depth_mm": 1e3 * loads.depth, "pull_N": pull, "pull_offset_mm": 1e3 * loads.offset,
           "unloaded_gap_mm": None if unloaded is None or not unloaded.size else [1e3 * float(np.median(unloaded)),
                                                                                  1e3 * float(unloaded.max())],
           "gap_mm": 1e3 * wound["gap"],
           "settled": wound["settled"], "steps": wound["steps"], "solve_s": time.perf_counter() - start,
           "beyond_linear": list(dict.fromkeys(beyond)),
           "invariants": problems}
    return row, (np.array(solver.positions), cut.triangles.astype(np.int64), np.array(solver.displacements))


def incision_files(folder: Path) -> set[str]:
    """Names of the files an earlier incise run wrote into ``folder``, as its ``incision.json`` lists them (the
    index, the table and each cut model and method's OBJ and VTU); empty without a readable index of ours, so no
    other file is ever taken for one of ours."""
    from ..experiments.output import read_index

    rows = read_index(folder / "incision.json")
    if not isinstance(rows, list) or not all(isinstance(r, dict) and {"model", "method"} <= r.keys() for r in rows):
        return set()
    cut = {f"{r['model']}_{r['method']}.{ext}" for r in rows if "refused" not in r for ext in ("obj", "vtu")}
    return {"incision.json", "incision.md", *cut}


def _fill(staging: Path, rows: list, cuts: dict) -> None:
    for stem, cut in cuts.items():
        _write(staging, stem, *cut)
    (staging / "incision.json").write_text(json.dumps(rows, indent=1) + "\n")
    (staging / "incision.md").write_text(_table(rows))


def _write(output: Path, stem: str, positions, triangles, displacements) -> None:
    import meshio

    from ..io import write_surface
    from ..mesh.surface import SurfaceMesh

    write_surface(output / f"{stem}.obj", SurfaceMesh(positions, triangles))
    directed = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(directed, axis=0, return_counts=True)
    cut_edges = edges[counts == 1]
    mesh = meshio.Mesh(positions, [("triangle", triangles), ("line", cut_edges)],
                       point_data={"displacement": displacements},
                       cell_data={"cut": [np.zeros(len(triangles), dtype=np.int32),
                                          np.ones(len(cut_edges), dtype=np.int32)]})
    meshio.write(output / f"{stem}.vtu", mesh)


def _table(rows) -> str:
    lines = ["| model | method | moves | ms per move (mean / max) | triangles split | vertices added | "
             "control released | prestrain | gap, no force, median / max (mm) | gap (mm) | settled (steps) | "
             "invariants | linear validity |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|"]
    for r in rows:
        if "refused" in r:
            lines.append(f"| {r['model']} | {r['method']} | refused: {r['refused']} | | | | | | | | | | |")
            continue
        check = "all hold" if not r["invariants"] else "; ".join(r["invariants"])
        lines.append(f"| {r['model']} | {r['method']} | {r['moves']} | {r['move_ms_mean']:.1f} / "
                     f"{r['move_ms_max']:.1f} | {r['triangles_split']} | {r['vertices_added']} | "
                     f"{r['control_released']} | {r['prestrain']:g} | {_millimetres(r['unloaded_gap_mm'])} | "
                     f"{r['gap_mm']:.3f} | {'yes' if r['settled'] else 'no'} "
                     f"({r['steps']}) | {check} | {_validity(r['beyond_linear'])} |")
    return "\n".join(lines) + "\n"


def _millimetres(value) -> str:
    return "–" if value is None else " / ".join(f"{v:.3f}" for v in value)


def _validity(warnings) -> str:
    return "small strain" if not warnings else "**beyond small strain** (incision.json says where)"
