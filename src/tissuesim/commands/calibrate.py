"""``tissuesim calibrate``: recompute the free scalar of hybrid, pbd and mass-spring against the fine FEM.

The calibration case is fixed (cube model, 1 N pressure on the load node, RMSE over 50 nodes; see
:mod:`tissuesim.experiments.calibration`). Prints one line per method and form; ``--write`` freezes the values in
:mod:`tissuesim.solvers.calibrated`. ``--bundle`` reuses a hybrid mesh saved by ``tissuesim build -o``; a bundle of
another model than the built-in cube is calibrated on with a notice saying so, and refused with ``--write``. An
unknown ``--method`` or ``--form``, or a selection with nothing to calibrate, is refused.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import SolverError

HELP = ("recompute the calibrated free scalar of hybrid, pbd and mass-spring against the refined FEM reference "
        "(cube, 1 N, contact radius 4 mm)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--method", action="append", default=None,
                        help="method to calibrate (repeatable): hybrid, pbd, mass-spring; default all")
    parser.add_argument("--form", action="append", default=None,
                        help="form to calibrate (repeatable): pbd, xpbd (position-based methods); default all")
    parser.add_argument("--bundle", type=Path, default=None,
                        help="hybrid mesh bundle of the cube (from `tissuesim build cube -o FILE`) to skip the build")
    parser.add_argument("--write", action="store_true", help="rewrite tissuesim/solvers/calibrated.py")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ..mesh import models
    from ..mesh.hybrid import HybridMesh
    from ..experiments.calibration import CALIBRATION_MODEL, calibrate, calibration_case, free_scalars, write_calibrated

    jobs = _jobs(args.method, args.form, free_scalars())
    cube = models.model(CALIBRATION_MODEL)
    if args.bundle is not None:
        hybrid = HybridMesh.load(args.bundle)
        on_cube = (np.array_equal(hybrid.surface.vertices, cube.vertices)
                   and np.array_equal(hybrid.surface.triangles, cube.triangles))
        if not on_cube and args.write:
            raise SolverError(f"{args.bundle} is not the built-in {CALIBRATION_MODEL}, the model the frozen values are "
                              f"calibrated on; build it with `tissuesim build {CALIBRATION_MODEL} -o FILE`, or drop "
                              "--write to calibrate on this model without freezing the values")
        source = f"the {CALIBRATION_MODEL} of {args.bundle}" if on_cube else (
            f"{args.bundle}, NOT the built-in {CALIBRATION_MODEL}: the values hold for that model only")
    else:
        print(f"building the {CALIBRATION_MODEL} hybrid mesh", file=sys.stderr)
        hybrid = HybridMesh.build(cube, progress=True)
        source = f"the built-in {CALIBRATION_MODEL}"
    print(f"calibrating on {source} ({hybrid.surface.vertex_count} vertices): 1 N of pressure through a 4 mm contact "
          "patch, against the refined FEM reference (computed once, then cached)", file=sys.stderr)
    case = calibration_case(hybrid)
    results = []
    for method, form in jobs:
        print(f"calibrating {method} ({form})", file=sys.stderr)
        r = calibrate(method, hybrid, form=form, case=case)
        results.append(r)
        print(f"{r.method:12s} {r.form:8s} {r.option} = {r.value:.6g}   RMSE {1e3 * r.rmse:.3f} mm "
              f"({100 * r.rmse / r.reference_rms:.1f} % of the reference's {1e3 * r.reference_rms:.3f} mm RMS) "
              f"in {r.evaluations} runs, {r.elapsed:.1f} s")
    if args.write:
        path = write_calibrated(results)
        print(f"wrote {path}", file=sys.stderr)
    return 0


def _jobs(methods, forms, parameters: dict) -> list[tuple[str, str]]:
    """The (method, form) pairs asked for; a SolverError for an unknown method or form, or an empty selection."""
    methods = methods or list(parameters)
    unknown = [m for m in methods if m not in parameters]
    if unknown:
        raise SolverError(f"cannot calibrate {', '.join(unknown)}; choose from {', '.join(parameters)}")
    offered = sorted({form for m in methods for form in parameters[m]})
    bad = [f for f in forms or () if f not in offered]
    if bad:
        raise SolverError(f"unknown --form {', '.join(bad)} for {', '.join(methods)}; choose from "
                          f"{', '.join(offered)}")
    # A method with a single form (mass-spring: springs) is calibrated whatever --form says.
    jobs = [(m, f) for m in methods for f in parameters[m]
            if not forms or f in forms or len(parameters[m]) == 1]
    if not jobs:
        raise SolverError("nothing to calibrate with these --method and --form options")
    return jobs
