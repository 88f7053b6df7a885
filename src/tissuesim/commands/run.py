"""``tissuesim run SCENE.toml``: a scene file simulated headless, its tools following their scripted paths.

The scene is validated whole before the mesh is built (each bad key named, with the fix); the run shows its
progress, then says what it did: the steps, each tool's force at the end and the largest displacement.
``--record FILE.pvd`` records every step that moved something as a ParaView series, written under a temporary name
and put in place at the end (an old recording of that name survives a failed or interrupted run).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .view import add_confine_argument

HELP = "simulate a scene file headless (its tools follow their scripted paths); --record FILE.pvd records it"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", type=Path, metavar="SCENE.toml", help="the scene file (see docs/scenes.md)")
    parser.add_argument("--record", type=Path, default=None, metavar="FILE.pvd",
                        help="record the run as a ParaView series (FILE.pvd + FILE_frames/; a frame at the start "
                             "and after every step that moved something)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_confine_argument(parser, "scene")


def run(args: argparse.Namespace) -> int:
    from ..recording import Recorder, check_target, solver_frame, tools_of
    from ..scene import Simulation, read_scene
    from ..scene.script import acting
    from ..scene.build import check_method, material_options
    from .view import scene_hybrid

    loaded = read_scene(args.scene, confine=args.confine)
    check_method(loaded)           # every key of the scene is checked before minutes of mesh building
    material_options(loaded)
    record = None if args.record is None else check_target(args.record)
    hybrid, name = scene_hybrid(loaded, progress=not args.quiet)
    simulation = Simulation(loaded, hybrid)
    scene = loaded.scene
    print(f"{scene.title or loaded.path.name}: {name}, {hybrid.surface.vertex_count} surface nodes, method "
          f"{scene.method.name}, {len(simulation.tools)} tools, {simulation.steps} steps of {scene.run.dt:g} s",
          file=sys.stderr)
    if record is None:
        summary = simulation.run(progress=not args.quiet)
    else:
        def frame(now: float):       # the surface, and the scripted tools where they act (a replay draws them)
            solver = simulation.solver
            pins, probes, depth, graspers = acting(simulation.tools, solver.positions)
            return solver_frame(solver, now, tools=tools_of(pins, probes, depth, graspers=graspers))

        with Recorder(record) as recorder:
            recorder.add(frame(0.0))
            summary = simulation.run(progress=not args.quiet, on_step=lambda now: recorder.add(frame(now)))
    for line in summary.lines():
        print(line)
    if record is not None:
        print(f"recorded {recorder.frame_count} frames to {record}")
    return 0

