"""``tissuesim view [MODEL]``: the interactive simulator in a polyscope window: the grasper (the tissue goes where
the jaws go, the force is the output), the paper's pin-head (§8.2), the probe and the scalpel (§8.4).

MODEL is a built-in model (default: liver), a surface file, a saved hybrid bundle or a scene file (``.toml``, see
``docs/scenes.md``): a scene sets the model, material, method, supports and gravity, and its first pin-head's
stiffness and radius, its first probe's and first grasper's radius and its first scalpel's depth, and its scripted tools play in the
window until the user's own press takes over (:mod:`tissuesim.viewer.playback`). ``--fix REGION`` holds another region
than the bottom tenth (:mod:`.fixing`). ``--record FILE.pvd`` records the session for ParaView (a frame whenever
something moved); ``--replay FILE.pvd`` plays a recording back instead of simulating.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from ..solvers.checks import ELEMENTS
from .fixing import DEFAULT_FIX, add_fix_argument, check_fix, fixed_option

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..scene.load import SceneFile

HELP = "open the interactive simulator: grasp and drag the tissue, cut with the scalpel (needs a display)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", nargs="?", default="liver", metavar="MODEL",
                        help="built-in model (cube, sphere, liver, steak), surface file, hybrid bundle or scene "
                             "file (.toml) (default: liver)")
    parser.add_argument("--method", default="hybrid", help="solver at start (switchable in the panel; default hybrid)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="factor from a surface file's unit to metres (0.01 for cm); default 1")
    parser.add_argument("--repair", action="store_true", help="repair safe defects of a surface file")
    parser.add_argument("--resolution", type=int, default=None, help="vertex count of a built-in model")
    parser.add_argument("--stiffness", type=float, default=None, metavar="K",
                        help="pin-head k [N/m] on one node (default: sized to the model and E, over a tip of 5 %% of "
                             "its size)")
    parser.add_argument("--prestrain", type=float, default=0.0, metavar="EPS",
                        help="in-plane prestrain of the surface, so that a cut gapes by itself (hybrid, pbd; "
                             "default 0)")
    parser.add_argument("--near-field", type=float, default=None, metavar="MM",
                        help="the hybrid's near field: M_S nodes within MM millimetres of the contact follow quadratic "
                             "tets on the fine volume (e.g. 15; default off)")
    parser.add_argument("--element", default="linear", choices=ELEMENTS,
                        help="the hybrid's M_V elements: linear (the paper's, default) or quadratic (as accurate as "
                             "the fine FEM; slower to build)")
    add_fix_argument(parser)
    parser.add_argument("--record", type=Path, default=None, metavar="FILE.pvd",
                        help="record the session as a ParaView series (FILE.pvd + FILE_frames/; a frame whenever "
                             "something moved; an old recording of that name is replaced at the end)")
    parser.add_argument("--replay", type=Path, default=None, metavar="FILE.pvd", help="play a recording back")
    add_confine_argument(parser, "scene")


def add_confine_argument(parser: argparse.ArgumentParser, kind: str) -> None:
    parser.add_argument("--confine", action="store_true",
                        help=f"refuse a file named in the {kind} file that lies outside its folder (links followed), "
                             f"as a service running others' {kind} files needs; default: any path is read")


def load_hybrid(spec: str, *, resolution: int | None = None, scale: float = 1.0, repair: bool = False,
                progress: bool = True) -> tuple[HybridMesh, str]:
    """The hybrid mesh of a built-in model name or a surface file (built with the fine volume, so every method
    runs), or a saved bundle as it is (without a fine volume the fem method is refused, saying why); and its name."""
    from ..experiments.inputs import model_name
    from ..experiments.sweep_config import ExperimentConfig, load_model
    from ..mesh.hybrid import HybridMesh

    if is_bundle(spec):
        return HybridMesh.load(Path(spec)), Path(spec).stem
    config = ExperimentConfig(models=(spec,), resolution=resolution, scale=scale, repair=repair)
    return load_model(spec, config, progress=progress), model_name(spec)


def prepare_kernels() -> None:
    """Before the window opens, compile every kernel a session can use (:func:`tissuesim.warmup.ensure_warm`: once
    per install), so that no grab, switch, press or cut waits on compilation later."""
    from ..warmup import ensure_warm

    if ensure_warm(progress=True):
        print("the kernels are ready: no interaction will wait on compilation", file=sys.stderr)


def is_bundle(spec: str) -> bool:
    """Whether ``spec`` names a saved hybrid bundle (loaded as it is) rather than a model to build. A built-in name
    wins over a file of that name, as in every command (``./cube`` names the file)."""
    from ..io import SURFACE_EXTENSIONS
    from ..mesh.models import MODELS

    path = Path(spec)
    return spec not in MODELS and path.is_file() and path.suffix.lower() not in SURFACE_EXTENSIONS


def announce_mesh(spec: str) -> None:
    """Say on stderr what comes before the window: a bundle is loaded, a model is built (that takes a while)."""
    print(f"{'loading the hybrid bundle' if is_bundle(spec) else 'building the hybrid mesh of'} {spec}",
          file=sys.stderr)


def scene_hybrid(loaded: SceneFile, *, progress: bool = True) -> tuple[HybridMesh, str]:
    """The hybrid mesh of a scene's model (built as :func:`load_hybrid` builds a model named on the command line)
    and its name."""
    model = loaded.scene.model
    spec = model.name if model.name is not None else str(loaded.resolve(model.file, key="model.file"))
    announce_mesh(spec)
    return load_hybrid(spec, resolution=model.resolution, scale=model.scale, repair=model.repair, progress=progress)


def run(args: argparse.Namespace) -> int:
    from ..recording import check_target, read_recording
    from ..solvers.checks import positive_number
    from ..viewer.app import ViewerApp
    from ..viewer.replay import ReplayApp
    from ..viewer.controller import Controller, scalpel_class
    from ..viewer.settings import DEFAULT_STIFFNESS, Settings, checked_settings, sized_defaults
    from ..viewer.gl import polyscope
    from ..viewer.tools import ProbeTool

    if args.replay is not None:
        frames = read_recording(args.replay, progress=True)  # a damaged recording is named before a window opens
        polyscope(headless=False)
        ReplayApp(frames, title=args.replay.name).run()
        return 0
    if args.model.lower().endswith(".toml"):
        return _run_scene(args)
    # every argument is checked before minutes of mesh building; a given value is never replaced by a default
    stiffness = DEFAULT_STIFFNESS if args.stiffness is None else positive_number("--stiffness", args.stiffness, "N/m")
    near_field = None if args.near_field is None else 1e-3 * positive_number("--near-field", args.near_field, "mm")
    settings = checked_settings(Settings(method=args.method, stiffness=stiffness, prestrain=args.prestrain,
                                         near_field=near_field, element=args.element))
    check_fix(args.fix)
    record = None if args.record is None else check_target(args.record)
    polyscope(headless=False)  # no display, no driver: say so before minutes of mesh building
    prepare_kernels()
    announce_mesh(args.model)
    hybrid, name = load_hybrid(args.model, resolution=args.resolution, scale=args.scale, repair=args.repair)
    fixed, held = fixed_option(args.fix, hybrid.surface.vertices)
    print(held, file=sys.stderr)
    sized = sized_defaults(hybrid.surface.vertices, edge_length=hybrid.surface.mean_edge_length,
                           youngs_modulus=settings.youngs_modulus, poisson_ratio=settings.poisson_ratio)
    if args.stiffness is None:      # a given --stiffness is the user's own tool: its tip stays one node
        settings = replace(settings, stiffness=sized.stiffness, radius=sized.radius)
        print(f"tools: {sized.line}; --stiffness sets k", file=sys.stderr)
    scalpel = scalpel_class()
    controller = Controller(hybrid, settings=settings, solver_options=None if fixed is None else {"fixed": fixed},
                            scalpel_factory=None if scalpel is None else partial(scalpel, depth=sized.depth),
                            mode="grasper")
    controller.probe = ProbeTool(radius=max(sized.radius, controller.probe.radius))
    app = ViewerApp(controller, title=f"{name}: {hybrid.surface.vertex_count} M_S nodes", record=record)
    try:
        app.run()
    finally:  # also on Ctrl-C or SIGTERM, which keep what was recorded (see ViewerApp.run)
        if app.recorded is not None:  # the last recording (the panel may have started others)
            print(f"recorded {app.recorded}", file=sys.stderr)
    return 0


#: Options of this command that a scene file sets itself, with their defaults (a changed one is refused).
SCENE_SETS = {"method": "hybrid", "scale": 1.0, "repair": False, "resolution": None, "stiffness": None,
              "prestrain": 0.0, "near_field": None, "element": "linear", "fix": DEFAULT_FIX}


def _run_scene(args: argparse.Namespace) -> int:
    """The simulator on a scene file: its model, material, method, supports and gravity, and its first pin-head."""
    from ..recording import check_target
    from ..scene import SceneError, read_scene, solver_options
    from ..scene.build import check_method, material_options
    from ..viewer.app import ViewerApp
    from ..viewer.controller import Controller
    from ..viewer.gl import polyscope

    given = [name for name, default in SCENE_SETS.items() if getattr(args, name) != default]
    if given:
        raise SceneError(f"--{given[0].replace('_', '-')} is set by the scene file {args.model}; remove it from the "
                         "command line (or change the scene)")
    loaded = read_scene(args.model, confine=args.confine)
    check_method(loaded)
    material_options(loaded)
    record = None if args.record is None else check_target(args.record)
    polyscope(headless=False)  # no display, no driver: say so before minutes of mesh building
    prepare_kernels()
    hybrid, name = scene_hybrid(loaded, progress=True)
    options = solver_options(loaded, hybrid)
    settings = _scene_settings(loaded, options)
    extra = {key: value for key, value in options.items() if key not in SETTINGS_FIELDS}
    from ..viewer.playback import ScenePlayback

    controller = Controller(hybrid, settings=settings, solver_options=extra, scalpel_factory=_scene_scalpel(loaded),
                            playback=ScenePlayback(loaded), mode="grasper")
    _scene_probe(loaded, controller)
    _scene_grasper(loaded, controller)
    title = loaded.scene.title or f"{name}: {hybrid.surface.vertex_count} M_S nodes"
    app = ViewerApp(controller, title=title, record=record)
    try:
        app.run()
    finally:
        if app.recorded is not None:
            print(f"recorded {app.recorded}", file=sys.stderr)
    return 0


#: The solver options the viewer's Settings hold (the panel changes them live); a scene's others go to the
#: controller's solver_options.
SETTINGS_FIELDS = ("youngs_modulus", "poisson_ratio", "material", "dt", "iterations", "prestrain", "near_field",
                   "element")


def _scene_settings(loaded, options: dict):
    """The viewer's Settings from a scene's solver ``options`` and its first pin-head (stiffness, radius)."""
    from ..viewer.settings import DEFAULT_STIFFNESS, Settings, checked_settings

    pin = _first(loaded, "pin-head")
    fields = {key: options[key] for key in SETTINGS_FIELDS if key in options}
    return checked_settings(Settings(method=loaded.scene.method.name,
                                     stiffness=DEFAULT_STIFFNESS if pin is None else pin.stiffness,
                                     radius=None if pin is None else pin.radius, **fields))


def _first(loaded, kind: str):
    """The scene's first tool of ``kind``, or None."""
    return next((tool for tool in loaded.scene.tools if tool.kind == kind), None)


def _scene_scalpel(loaded):
    """The controller's scalpel factory for the scene's first scalpel with a depth, else None (the default)."""
    spec = _first(loaded, "scalpel")
    if spec is None or spec.depth is None:
        return None
    from ..tools.scalpel import Scalpel

    return lambda solver: Scalpel(solver, depth=spec.depth)


def _scene_probe(loaded, controller) -> None:
    """The simulator's probe takes the radius of the scene's first probe."""
    from ..viewer.tools import ProbeTool

    spec = _first(loaded, "probe")
    if spec is not None:
        controller.probe = ProbeTool(radius=spec.radius)


def _scene_grasper(loaded, controller) -> None:
    """The simulator's grasper takes the reach of the scene's first grasper."""
    from ..viewer.tools import GrasperTool

    spec = _first(loaded, "grasper")
    if spec is not None:
        controller.grasper = GrasperTool(radius=spec.radius)
