"""tissuesim: accurate, real-time soft-tissue surface deformation and incision (hybrid FEM + PBD).

Public API (imported lazily, so ``import tissuesim`` stays fast and Numba kernels compile only when used)::

    surface = tissuesim.read_surface("liver.obj", scale=0.01)        # or tissuesim.models.liver()
    hybrid = tissuesim.HybridMesh.build(surface)                      # M_S + M'_S + M_V + maps (§5)
    solver = tissuesim.make_solver("hybrid", hybrid)                  # or "pbd", "mass-spring", "embedded", "fem"
    positions = solver.solve_static(node, [0.0, 0.0, 1.0])            # (n, 3) surface positions [m]
    probe = tissuesim.Probe(solver, radius=0.005); probe.press_static(centre)   # a rigid sphere pressing
    grasper = tissuesim.Grasper(solver, radius=0.004); grasper.grab(point); grasper.move_to(point + lift)
    scene = tissuesim.read_scene("examples/hanging_sphere.toml")      # a whole scene from one TOML file
"""

from importlib import import_module

from . import compile_notice as _compile_notice
from . import numba_cache as _numba_cache

__version__ = "0.1.0"

# Before any kernel is compiled or loaded: processes started together share one on-disk cache, and a first run
# says that it compiles (about 20 s) rather than sit silent.
_numba_cache.install()
_compile_notice.install()

# public name -> module that defines it
_EXPORTS = {
    "SurfaceMesh": "tissuesim.mesh.surface",
    "TetMesh": "tissuesim.mesh.tetmesh",
    "HybridMesh": "tissuesim.mesh.hybrid",
    "read_surface": "tissuesim.io",
    "write_surface": "tissuesim.io",
    "validate_surface": "tissuesim.mesh.validate",
    "repair_surface": "tissuesim.mesh.repair",
    "Material": "tissuesim.fem.material",
    "LinearFEM": "tissuesim.fem.linear",
    "QuadraticFEM": "tissuesim.fem.quadratic",
    "NonlinearFEM": "tissuesim.fem.nonlinear",
    "QuadraticNonlinearFEM": "tissuesim.fem.nonlinear_quadratic",
    "make_solver": "tissuesim.solvers",
    "available_solvers": "tissuesim.solvers",
    "register": "tissuesim.solvers",
    "Solver": "tissuesim.solvers",
    "State": "tissuesim.solvers",
    "SolveReport": "tissuesim.solvers",
    "PinHead": "tissuesim.tools.pinhead",
    "Probe": "tissuesim.tools.probe",
    "Grasper": "tissuesim.tools.grasper",
    "Attachment": "tissuesim.solvers.attachments",
    "fixed_region": "tissuesim.mesh.regions",
    "preset": "tissuesim.fem.presets",
    "read_scene": "tissuesim.scene",
    "Scalpel": "tissuesim.tools.scalpel",
    "HapticLoop": "tissuesim.haptics",
    "TissuesimError": "tissuesim.errors",
    "MeshError": "tissuesim.errors",
    "MaterialError": "tissuesim.errors",
    "BoundaryConditionError": "tissuesim.errors",
    "SolverError": "tissuesim.errors",
    "InversionError": "tissuesim.errors",
    "BundleError": "tissuesim.errors",
}
_SUBMODULES = {"models": "tissuesim.mesh.models"}

__all__ = sorted([*_EXPORTS, *_SUBMODULES, "__version__"])


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    if name in _SUBMODULES:
        return import_module(_SUBMODULES[name])
    raise AttributeError(f"module 'tissuesim' has no attribute {name!r}")


def __dir__():
    return __all__
