"""Run a scene file from Python: the model, material, method, supports, gravity and scripted tools of one TOML file
(``docs/scenes.md`` lists every key). ``tissuesim run scene.toml`` does the same from the command line.

Run: python examples/scene_file.py [examples/probe_block.toml] [--record run.pvd]
"""

import argparse
from pathlib import Path

import tissuesim
from tissuesim.recording import Recorder, solver_frame
from tissuesim.scene import Simulation

HERE = Path(__file__).resolve().parent


def scene_hybrid(loaded):
    """The hybrid mesh of a scene's model: a built-in model at its resolution, or a surface file (relative to the
    scene file) at its scale. The fine volume is built only for the fem method, the one that needs it."""
    model = loaded.scene.model
    if model.name is not None:
        surface = tissuesim.models.model(model.name, model.resolution)
    else:
        surface = tissuesim.read_surface(loaded.resolve(model.file), scale=model.scale, repair=model.repair)
    return tissuesim.HybridMesh.build(surface, fine_volume=loaded.scene.method.name == "fem")


def run_scene(path, *, record=None):
    """Read the scene at ``path``, build its model and run it; with ``record`` (a ``.pvd`` path), write every frame
    that moved to a ParaView series. Returns the :class:`~tissuesim.scene.Simulation` (its solver and tools, in
    their final state) and its :class:`~tissuesim.scene.RunSummary`."""
    loaded = tissuesim.read_scene(path)            # validated: a bad key raises SceneError naming it and the fix
    simulation = Simulation(loaded, scene_hybrid(loaded))
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
