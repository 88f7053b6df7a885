"""``tissuesim experiment``: the paper's §8.3 experiments into a results folder (tables, plots, report, JSON)."""

from __future__ import annotations

import argparse
import sys
import time

HELP = ("reproduce the paper's experiments (§8.3, Tables 1-5, Figs 12-15), or run the contact protocol against a "
        "converged reference, into a results folder")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    # Values are read as text and checked in run(), so a bad one is a one-line error (exit 1), not a usage dump.
    parser.add_argument("models", nargs="*", metavar="MODEL",
                        help="built-in model (cube, sphere, liver, steak), surface file or saved hybrid bundle; "
                             "default: the four built-in models")
    parser.add_argument("--protocol", default="paper", metavar="NAME",
                        help="paper: the paper's single-node load (Tables 1-5); contact: a pin-head patch of radius "
                             "R against a reference refined until it converges (default: paper)")
    parser.add_argument("--radii", nargs="+", metavar="MM",
                        help="contact protocol: patch radii in millimetres (default: 4 8)")
    parser.add_argument("--cache", metavar="DIR", help="contact protocol: folder caching the converged references "
                        "(default: $TISSUESIM_CACHE or the user cache folder)")
    parser.add_argument("--no-cache", action="store_true", help="contact protocol: recompute every reference, "
                        "those shipped with tissuesim included")
    parser.add_argument("--levels", metavar="COUNT",
                        help="contact protocol: last refinement level of the reference (default: 4; quick: 2; with a "
                             "finite-strain --material: 2)")
    parser.add_argument("--output", "-o", default="results", metavar="DIR",
                        help="results folder, created if absent (default: results)")
    parser.add_argument("--quick", action="store_true",
                        help="CI-sized smoke run: coarse models (400 vertices), forces 1 and 10 N, few timed steps")
    parser.add_argument("--forces", nargs="+", metavar="N", help="load magnitudes in newtons "
                        "(default: 0.5 1 2 5 10 20; with --quick: 1 10)")
    parser.add_argument("--loads", nargs="+", metavar="LOAD", help="tension and/or pressure (default: both)")
    parser.add_argument("--methods", nargs="+", metavar="METHOD",
                        help="solvers to compare; fem (the reference) is always run (default: all five)")
    parser.add_argument("--resolution", metavar="VERTICES",
                        help="surface vertices of the built-in models (default: the paper's Table-1 sizes)")
    parser.add_argument("--scale", default="1", metavar="FACTOR",
                        help="factor from a surface file's unit to metres, e.g. 0.01 for cm, applied to a built-in "
                             "model too (a bundle is in metres and not scaled; default: 1)")
    parser.add_argument("--repair", action="store_true",
                        help="fix what can be fixed safely in a surface file (e.g. inward faces) and say what changed")
    parser.add_argument("--steps", metavar="COUNT", help="timed steps per case and method (default: 30; quick: 5)")
    parser.add_argument("--material", default="linear", metavar="NAME",
                        help="linear (the paper's, default), corotated or neo-hookean: finite strain for every method "
                             "that has it, the fem reference (paper protocol) or the refined reference (contact "
                             "protocol) included")
    parser.add_argument("--no-plots", action="store_true", help="skip the radar plots")
    parser.add_argument("--quiet", "-q", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..errors import SolverError
    from ..experiments.output import check_output_folder, earlier_outputs, write_outputs
    from ..experiments.methods import protocol_methods
    from ..experiments.protocol import REFERENCE
    from ..experiments.inputs import check_model_files, check_model_specs, check_resolution
    from ..experiments.run import run_experiment
    from ..experiments.sweep_config import ExperimentConfig
    from ..fem.hyperelastic import check_material
    from ..mesh.models import MODELS

    output = check_output_folder(args.output)  # refuse a bad target before minutes of work
    if args.protocol not in PROTOCOLS:
        raise SolverError(f"unknown protocol {args.protocol!r}; choose one of {', '.join(PROTOCOLS)}")
    if args.protocol == "contact":
        return _run_contact(args, output)
    models = tuple(args.models) or tuple(MODELS)
    check_model_specs(models)
    options = {"models": models}
    if args.forces:
        options["forces"] = _distinct("--forces", [_number(value, "--forces", "newtons") for value in args.forces])
    if args.loads:
        options["loads"] = _distinct("--loads", args.loads)
    if args.methods:
        options["methods"] = tuple(dict.fromkeys([*args.methods, REFERENCE]))
        unknown = [m for m in args.methods if m not in protocol_methods()]
        if unknown:
            raise SolverError(f"unknown method {unknown[0]!r}; choose from {', '.join(protocol_methods())}")
    if args.resolution is not None:
        options["resolution"] = check_resolution(_number(args.resolution, "--resolution", "vertices", integer=True))
    options["scale"] = _number(args.scale, "--scale", "factor")
    options["repair"] = bool(args.repair)
    options["material"] = check_material(args.material)
    check_model_files(models, scale=options["scale"], repair=options["repair"])
    if args.steps is not None:
        options["timing_steps"] = int(_number(args.steps, "--steps", "steps", integer=True))
    config = ExperimentConfig.quick(**options) if args.quick else ExperimentConfig(**options)

    start = time.perf_counter()
    data = run_experiment(config, progress=not args.quiet)
    earlier = earlier_outputs(output)
    paths = write_outputs(data, output, plots=not args.no_plots)
    _say_replaced(output, earlier, paths)
    print(f"wrote {len(paths)} files to {output}/ ({', '.join(p.name for p in paths)}) in "
          f"{time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


PROTOCOLS = ("paper", "contact")


def _run_contact(args, output) -> int:
    from dataclasses import replace

    from ..errors import SolverError
    from ..experiments import contact_protocol
    from ..experiments.output import earlier_outputs, write_contact_outputs
    from ..experiments.reference import default_cache_dir
    from ..experiments.reference_cache import check_cache_dir
    from ..experiments.inputs import check_model_files, check_model_specs, check_resolution
    from ..fem.hyperelastic import check_material
    from ..mesh.models import MODELS

    check_model_specs(args.models)
    if args.cache is not None and not args.cache.strip():
        raise SolverError("--cache is empty; give the folder of the cached references, or --no-cache to recompute "
                          "them")
    options = dict(contact_protocol.QUICK) if args.quick else {}
    if args.models:
        scale = _number(args.scale, "--scale", "factor")
        check_model_files(args.models, scale=scale)
        options["models"] = tuple(args.models)
        options["scales"] = dict.fromkeys(args.models, scale)    # built-in models are scaled like files
    elif not args.quick:
        livers = contact_protocol.shared_livers()
        options["models"] = tuple(MODELS) + tuple(livers)
        options["scales"] = livers
    if args.forces:
        options["forces"] = _distinct("--forces", [_number(value, "--forces", "newtons") for value in args.forces])
    if args.loads:
        options["loads"] = _distinct("--loads", args.loads)
    if args.radii:
        options["radii_mm"] = _distinct("--radii", [_number(value, "--radii", "millimetres") for value in args.radii])
    if args.methods:
        options["methods"] = tuple(dict.fromkeys(args.methods))
    if args.resolution is not None:
        options["resolution"] = check_resolution(_number(args.resolution, "--resolution", "vertices", integer=True))
    options["material"] = check_material(args.material)
    settings = options.get("settings", contact_protocol.ContactConfig().settings)
    if args.levels is not None:
        options["settings"] = replace(settings, max_levels=int(_number(args.levels, "--levels", "levels",
                                                                       integer=True)))
    elif options["material"] != "linear":
        options["settings"] = replace(settings, max_levels=min(settings.max_levels, contact_protocol.FINITE_MAX_LEVELS))
    options["shipped"] = not args.no_cache
    options["cache_dir"] = None if args.no_cache else str(check_cache_dir(default_cache_dir() if args.cache is None
                                                                          else args.cache))
    start = time.perf_counter()
    data = contact_protocol.run_contact(contact_protocol.ContactConfig(**options), progress=not args.quiet)
    _refuse_empty(data)
    earlier = earlier_outputs(output)
    paths = write_contact_outputs(data, output)
    _say_replaced(output, earlier, paths)
    print(f"wrote {len(paths)} files to {output}/ ({', '.join(p.name for p in paths)}) in "
          f"{time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


def _refuse_empty(data: dict) -> None:
    """Refuse (SolverError) a contact run that measured nothing (every radius skipped on every model), naming the
    first skip's reason, instead of writing empty tables."""
    from ..errors import SolverError

    if data["records"]:
        return
    skips = [(name, radius, reason) for name, info in data["metadata"]["models"].items()
             for radius, reason in info.get("skipped", {}).items()]
    why = f" ({skips[0][0]}, R = {skips[0][1]} mm: {skips[0][2]})" if skips else ""
    raise SolverError(f"no contact radius fits the models, so the run measured nothing{why}; give smaller --radii "
                      "(nothing was written)")


def _say_replaced(output, earlier: set, written: list) -> None:
    """One line on stderr naming the files of an earlier run in ``output`` that this one replaced or removed."""
    from ..experiments.output import replacement_note

    note = replacement_note(output, earlier, written)
    if note:
        print(note, file=sys.stderr)


def _distinct(option: str, values: list) -> tuple:
    """``values`` as a tuple, or a SolverError naming the first repeated one: a repeated case would be measured twice
    and its records would collide."""
    from ..errors import SolverError

    repeated = [value for index, value in enumerate(values) if value in values[:index]]
    if repeated:
        shown = f"{repeated[0]:g}" if isinstance(repeated[0], float) else repeated[0]
        raise SolverError(f"{option} names {shown} more than once; give each value once")
    return tuple(values)


def _number(text: str, option: str, unit: str, *, integer: bool = False) -> float:
    from ..errors import SolverError

    try:
        value = float(text)
    except ValueError:
        raise SolverError(f"{option} takes numbers ({unit}), got {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")) or value <= 0 or (integer and value != int(value)):
        kind = "a positive whole number" if integer else "a positive finite number"
        raise SolverError(f"{option} takes {kind} ({unit}), got {text!r}")
    return value
