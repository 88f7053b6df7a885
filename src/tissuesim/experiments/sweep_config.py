"""What the sweep runs: :class:`ExperimentConfig`, and the model a spec names (built-in, surface file or saved
bundle) loaded as the :class:`~tissuesim.mesh.hybrid.HybridMesh` it is measured on."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import SolverError
from ..fem.hyperelastic import check_material
from ..io import SURFACE_EXTENSIONS
from ..mesh import models as builtin_models
from . import protocol
from .methods import protocol_methods
from .inputs import builtin_surface, check_fine_volume, check_resolution

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh


# The reduced sweep of ``--quick``: coarser models, two forces (one small, one large deformation), fewer steps.
QUICK_RESOLUTION = 400
QUICK_FORCES_N = (1.0, 10.0)
QUICK_MAX_STEPS = 500


@dataclass(frozen=True)
class ExperimentConfig:
    """What to run. Keyword-only; every field has the paper's default.

    Attributes:
        models: built-in model names (cube, sphere, liver, steak), surface file paths, or saved bundle paths.
        forces: load magnitudes [N].
        loads: load kinds, from :data:`protocol.LOADS`.
        methods: solver names; must include :data:`protocol.REFERENCE` (``fem``) for the RMSE.
        resolution: surface vertices of the built-in models (None: the Table-1 size).
        scale: factor from a surface file's unit to metres (e.g. 0.01 for cm); a built-in model is scaled alike,
            a saved bundle (in metres) is not.
        repair: let :func:`tissuesim.read_surface` fix what it safely can in a surface file (e.g. inward faces).
        dt: time step of the timed steps [s]; None: each solver's own default (0.01 s, 100 Hz).
        warmup_steps: untimed steps before timing.
        timing_steps: timed steps per case and method (the median is reported).
        max_steps: cap on the steps of one quasi-static solve (10 s of simulated time at 0.01 s). A solver that
            has not settled by then is recorded with its last positions and ``converged: false`` rather than
            stopping the whole sweep; the report lists such cases.
        solver_options: per-method keyword options for ``make_solver`` (default: the calibrated defaults).
        material: ``"linear"`` (the paper's) or a finite-strain material (:data:`tissuesim.fem.hyperelastic.MATERIALS`)
            for every method that has it, the ``fem`` reference included; the others run as they are. With a
            finite-strain material a pressure case beyond the stable dead-load range
            (:func:`tissuesim.solvers.finite_strain.check_dead_press`) is not run; the model's metadata lists it
            under ``beyond_stable_press`` with the largest stable load.
        point_load_levels: refinement levels of the single-node load's reference measured per model to show that
            it diverges (:func:`.reference.point_load_divergence`); 0 skips it.
    """

    models: tuple = tuple(builtin_models.MODELS)
    forces: tuple = protocol.FORCES_N
    loads: tuple = protocol.LOADS
    methods: tuple = field(default_factory=protocol_methods)
    resolution: int | None = None
    scale: float = 1.0
    repair: bool = False
    dt: float | None = None
    warmup_steps: int = 5
    timing_steps: int = 30
    max_steps: int = 1000
    solver_options: dict = field(default_factory=dict)
    point_load_levels: int = 3
    material: str = "linear"

    def __post_init__(self):
        if not self.models:
            raise SolverError("no models given; name a built-in model (cube, sphere, liver, steak) or a mesh file")
        unknown = [m for m in self.methods if m not in protocol_methods()]
        if unknown:
            raise SolverError(f"unknown methods {', '.join(unknown)}; choose from {', '.join(protocol_methods())}")
        if protocol.REFERENCE not in self.methods:
            raise SolverError(f"methods must include the reference {protocol.REFERENCE!r} to compute the RMSE")
        bad_loads = [load for load in self.loads if load not in protocol.LOAD_DIRECTIONS]
        if bad_loads or not self.loads:
            raise SolverError(f"loads must be among {', '.join(protocol.LOADS)}, got {', '.join(self.loads) or 'none'}")
        protocol.load_cases(self.forces, self.loads)  # validates the forces
        if self.dt is not None and not (self.dt > 0 and np.isfinite(self.dt)):
            raise SolverError(f"dt must be a positive number of seconds, got {self.dt!r}")
        if self.max_steps < 1:
            raise SolverError(f"max_steps must be at least 1, got {self.max_steps}")
        check_material(self.material)
        if self.warmup_steps < 0 or self.timing_steps < 1:
            raise SolverError(f"need warmup_steps ≥ 0 and timing_steps ≥ 1, got {self.warmup_steps}, "
                              f"{self.timing_steps}")
        if not (self.scale > 0 and np.isfinite(self.scale)):
            raise SolverError(f"scale must be a positive factor to metres, got {self.scale!r}")
        if self.resolution is not None:
            check_resolution(self.resolution)

    @classmethod
    def quick(cls, **overrides: Any) -> "ExperimentConfig":
        """The CI-sized smoke sweep: resolution 400, forces 1 and 10 N, few timed steps, at most 500 steps a solve."""
        settings = dict(resolution=QUICK_RESOLUTION, forces=QUICK_FORCES_N, warmup_steps=2, timing_steps=5,
                        max_steps=QUICK_MAX_STEPS, point_load_levels=2)
        settings.update(overrides)
        return cls(**settings)


def load_model(spec: str, config: ExperimentConfig, *, progress: bool = False) -> HybridMesh:
    """The :class:`HybridMesh` (with fine volume) of a built-in name, a surface file, or a saved bundle."""
    from ..mesh.hybrid import HybridMesh

    if spec in builtin_models.MODELS:
        surface = builtin_surface(spec, resolution=config.resolution, scale=config.scale)
        return HybridMesh.build(surface, fine_volume=True, progress=progress)
    path = Path(spec)
    if not path.exists():
        raise FileNotFoundError(f"{spec!r} is neither a built-in model ({', '.join(builtin_models.MODELS)}) "
                                "nor an existing file")
    if path.suffix.lower() in SURFACE_EXTENSIONS:     # anything else given by path is a saved bundle
        from ..io import read_surface

        surface = read_surface(path, scale=config.scale, repair=config.repair)
        return HybridMesh.build(surface, fine_volume=True, progress=progress)
    hybrid = HybridMesh.load(path)
    check_fine_volume(hybrid, spec)
    return hybrid
