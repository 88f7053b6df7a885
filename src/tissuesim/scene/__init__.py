"""Scene files: one TOML file describes a model, its material, method, supports, gravity and tools.

    loaded = read_scene("examples/probe_block.toml")      # validated; SceneError names each bad key and the fix
    simulation = Simulation(loaded, hybrid)                # the solver and the scripted tools on it
    summary = simulation.run()

The hybrid mesh of ``loaded.scene.model`` is built by the caller (``tissuesim run`` and ``tissuesim view`` build
it as for a model on their command line). ``docs/scenes.md`` documents every key.
"""

from .build import make_scene_solver, material_options, solver_options
from .load import SceneError, SceneFile, parse_scene, read_scene
from .simulation import RunSummary, Simulation

__all__ = ["RunSummary", "SceneError", "SceneFile", "Simulation", "make_scene_solver", "material_options",
           "parse_scene", "read_scene", "solver_options"]
