"""``tissuesim calibrate``: recompute the free scalar of hybrid, pbd and mass-spring against the fine FEM.

The calibration case is fixed (cube model, 1 N pressure on the load node, RMSE over 50 nodes; see
:mod:`tissuesim.solvers.calibration`). Prints one line per method and form; ``--write`` freezes the values in
:mod:`tissuesim.solvers.calibrated`. ``--bundle`` reuses a hybrid mesh saved by ``tissuesim build -o``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "recompute the calibrated free scalar of hybrid, pbd and mass-spring against the fine FEM (cube, 1 N)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--method", action="append", default=None,
                        help="method to calibrate (repeatable): hybrid, pbd, mass-spring; default all")
    parser.add_argument("--form", action="append", default=None,
                        help="form to calibrate (repeatable): pbd, xpbd (position-based methods); default all")
    parser.add_argument("--bundle", type=Path, default=None,
                        help="hybrid mesh bundle of the cube (from `tissuesim build cube -o FILE`) to skip the build")
    parser.add_argument("--write", action="store_true", help="rewrite tissuesim/solvers/calibrated.py")


def run(args: argparse.Namespace) -> int:
    from ..mesh import models
    from ..mesh.hybrid import HybridMesh
    from ..solvers.calibration import CALIBRATION_MODEL, PARAMETERS, calibrate, calibration_case, write_calibrated

    methods = args.method or list(PARAMETERS)
    unknown = [m for m in methods if m not in PARAMETERS]
    if unknown:
        from ..errors import SolverError

        raise SolverError(f"cannot calibrate {', '.join(unknown)}; choose from {', '.join(PARAMETERS)}")
    if args.bundle is not None:
        hybrid = HybridMesh.load(args.bundle)
    else:
        print(f"building the {CALIBRATION_MODEL} hybrid mesh", file=sys.stderr)
        hybrid = HybridMesh.build(models.model(CALIBRATION_MODEL), progress=True)
    case = calibration_case(hybrid)
    results = []
    for method in methods:
        for form in PARAMETERS[method]:
            if args.form and method != "mass-spring" and form not in args.form:
                continue
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
