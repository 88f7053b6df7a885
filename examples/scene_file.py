"""Run a scene file from Python: the model, material, method, supports, gravity and scripted tools of one TOML file
(``docs/scenes.md`` lists every key). ``tissuesim run scene.toml`` does the same from the command line.

Run: python examples/scene_file.py [examples/probe_block.toml] [--record run.pvd]
"""

import argparse
from pathlib import Path

import tissuesim
from tissuesim.commands.view import scene_hybrid
from tissuesim.recording import Recorder, solver_frame
from tissuesim.scene import Simulation

HERE = Path(__file__).resolve().parent


def run_scene(path, *, record=None):
    """Read the scene at ``path``, build its model (as ``tissuesim run`` does: a built-in model at the scene's
    resolution and scale, or its surface file) and run it; with ``record`` (a ``.pvd`` path), write every frame
    that moved to a ParaView series. Returns the :class:`~tissuesim.scene.Simulation` (its solver and tools, in
    their final state) and its :class:`~tissuesim.scene.RunSummary`."""
    loaded = tissuesim.read_scene(path)            # validated: a bad key raises SceneError naming it and the fix
    hybrid, _ = scene_hybrid(loaded, progress=False)
    simulation = Simulation(loaded, hybrid)
    if record is None:
        return simulation, simulation.run()
    with Recorder(record) as recorder:
        recorder.add(solver_frame(simulation.solver, 0.0))
        summary = simulation.run(on_step=lambda time: recorder.add(solver_frame(simulation.solver, time)))
    return simulation, summary


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default=HERE / "probe_block.toml", type=Path)
    parser.add_argument("--record", type=Path, help="write the run to this ParaView series (.pvd)")
    args = parser.parse_args()
    simulation, summary = run_scene(args.scene, record=args.record)
    print(simulation.scene_file.scene.title)
    print("\n".join(summary.lines()))


if __name__ == "__main__":
    main()
