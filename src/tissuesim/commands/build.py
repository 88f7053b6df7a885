"""``tissuesim build MESH``: build the hybrid mesh of §5 and print its Table-1 row.

MESH is a surface file (OBJ, STL, PLY, OFF, VTK, VTU) or a built-in model name (cube, sphere, liver, steak).
The Table-1 row (Markdown, with header) goes to stdout; progress, a one-line build summary and what the size
columns measure (:data:`tissuesim.experiments.tables.SIZE_DEFINITION`, as in the experiments' ``tables.md``) go to
stderr.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..mesh.surface import SurfaceMesh

HELP = "build the hybrid mesh (M_S, M'_S, M_V, fine volume) from a surface file or model; print its Table-1 row"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mesh", metavar="MESH", help="surface file, or a built-in model: cube, sphere, liver, steak")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="factor from the file's unit to metres (0.01 for cm, 0.001 for mm), applied to a built-in "
                             "model too; default 1")
    parser.add_argument("--target-vertices", type=int, default=None, metavar="N",
                        help="vertex count of the coarse surface M'_S (default: 32%% of M_S's vertices)")
    parser.add_argument("--no-fine-volume", action="store_true",
                        help="skip the fine reference volume (TetGen on M_S itself)")
    parser.add_argument("--output", "-o", default=None, metavar="BUNDLE.npz",
                        help="save the hybrid mesh bundle here (checked before the build)")
    parser.add_argument("--repair", action="store_true",
                        help="repair safe surface defects (orientation, self-intersections) instead of refusing them")
    parser.add_argument("--resolution", type=int, default=None,
                        help="vertex count of a built-in model (default: its Table-1 size)")


def load_mesh(name: str, *, scale: float = 1.0, repair: bool = False,
              resolution: int | None = None) -> SurfaceMesh:
    """The surface named on the command line: a built-in model name (which wins over a file or folder of that name:
    write ``./cube`` for the file) scaled by ``scale`` like a file, or a surface file path."""
    from ..experiments.inputs import builtin_surface
    from ..mesh import models

    if name in models.MODELS:
        return builtin_surface(name, resolution=resolution, scale=scale)
    if not Path(name).exists() and not Path(name).suffix:
        raise FileNotFoundError(
            f"{name!r} is neither a built-in model ({', '.join(models.MODELS)}) nor an existing surface file")
    from ..io import read_surface

    return read_surface(name, scale=scale, repair=repair)


def run(args: argparse.Namespace) -> int:
    from ..experiments.tables import SIZE_DEFINITION
    from ..mesh.bundle_check import check_bundle_target
    from ..mesh.hybrid import HybridMesh
    from ..mesh.table1 import table1_markdown, table1_row

    if args.output is not None:
        # an unwritable target, or the input itself, is refused before the build, not after
        _check_not_input(args.mesh, check_bundle_target(args.output))
    print(f"reading {args.mesh}", file=sys.stderr)
    surface = load_mesh(args.mesh, scale=args.scale, repair=args.repair, resolution=args.resolution)
    start = time.perf_counter()
    hybrid = HybridMesh.build(surface, target_vertices=args.target_vertices, fine_volume=not args.no_fine_volume,
                              progress=True)
    seconds = time.perf_counter() - start
    report = hybrid.info["simplify"]
    print(f"built in {seconds:.2f} s: {report['rounds']} simplification rounds, {report['collapses']} collapses, "
          f"skipped {sum(report['rejected'].values())} ({_reasons(report['rejected'])})", file=sys.stderr)
    print(table1_markdown({Path(args.mesh).stem if Path(args.mesh).suffix else args.mesh: table1_row(hybrid)}))
    print(f"size (kB): {SIZE_DEFINITION}", file=sys.stderr)
    if args.output is not None:
        path = hybrid.save(args.output)
        print(f"saved {path}", file=sys.stderr)
    return 0


def _check_not_input(mesh: str, output: Path) -> None:
    """Refuse an ``-o`` that is the input surface file (the same file, through any link): saving would replace it."""
    from ..errors import BundleError

    if Path(mesh).is_file() and output.exists() and os.path.samefile(mesh, output):
        raise BundleError(f"-o {output} is the input surface {mesh} itself: saving the bundle would replace it; give "
                          "another path, e.g. -o " + str(output.with_suffix(".npz") if output.suffix != ".npz"
                                                        else output.with_name(f"{output.stem}_bundle.npz")))


def _reasons(rejected: dict) -> str:
    shown = [f"{reason} {count}" for reason, count in rejected.items() if count]
    return ", ".join(shown) if shown else "none"
