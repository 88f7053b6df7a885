"""The sweep's results document: one record per model, load case and method, the models' mesh figures, the
solvers' parameters and the run's metadata."""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..mesh.table1 import ascii_size
from . import protocol
from .methods import protocol_methods
from .sweep_config import ExperimentConfig
from .sweep_measure import inverted_elements

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..solvers.base import Solver


@dataclass(frozen=True)
class ModelSamples:
    """A model as the protocol measures it: its report name, rest M_S positions, load node and sample nodes."""

    name: str
    rest: np.ndarray
    node: int
    plot_nodes: np.ndarray
    rmse_nodes: np.ndarray

    @classmethod
    def of(cls, name: str, hybrid: HybridMesh) -> "ModelSamples":
        rest = np.array(hybrid.surface.vertices, dtype=np.float64)
        node = protocol.load_node(rest, hybrid.surface.triangles)
        return cls(name, rest, node, protocol.sample_nodes(rest, node, min(protocol.PLOT_SAMPLES, len(rest))),
                   protocol.sample_nodes(rest, node, min(protocol.RMSE_SAMPLES, len(rest))))


def case_record(model: ModelSamples, case: protocol.LoadCase, method: str, measured: dict, positions: np.ndarray,
                target: np.ndarray, solver: Solver) -> dict:
    """The record of ``method``'s ``positions`` in ``case`` against the reference's ``target``, with the figures
    ``measured`` by :func:`.sweep_measure.measure`."""
    rest, rmse_nodes = model.rest, model.rmse_nodes
    return {
        "model": model.name, "load": case.load, "force_N": float(case.force_N), "method": method,
        "rmse_mm": 1e3 * protocol.rmse(positions, target, rmse_nodes),
        "relative_rmse": _finite_or_none(protocol.relative_rmse(positions, target, rest, rmse_nodes)),
        "step_ms": measured["step_ms"], "equilibrium_ms": measured["equilibrium_ms"],
        "equilibrium_steps": measured["equilibrium_steps"], "converged": measured["converged"],
        "displacements_mm": [float(d) for d in 1e3 * protocol.displacements(positions, rest, model.plot_nodes)],
        "max_displacement_mm": float(1e3 * np.linalg.norm(positions - rest, axis=1).max()),
        **inverted_elements(solver),
    }


def record_order(names: Iterable[str], loads: Iterable[str]) -> Callable[[dict], tuple]:
    """The sort key of the records: model and load in the order run, then force, then method as registered."""
    model_rank = {n: i for i, n in enumerate(names)}
    load_rank = {n: i for i, n in enumerate(loads)}
    method_rank = {n: i for i, n in enumerate(protocol_methods())}
    return lambda r: (model_rank[r["model"]], load_rank[r["load"]], r["force_N"], method_rank[r["method"]])


def _finite_or_none(value: float):
    return float(value) if np.isfinite(value) else None


def mesh_info(hybrid: HybridMesh, spec: str, model: ModelSamples, build_s: float) -> dict:
    """Table-1 figures of a model's meshes plus the protocol's nodes."""

    def sizes(mesh, cells):
        if mesh is None:
            return None
        points, elements = getattr(mesh, "vertices", None), getattr(mesh, cells)
        points = mesh.points if points is None else points
        # the one definition of Table 1's size (tables.SIZE_DEFINITION, as tissuesim build prints it)
        return {"nodes": int(len(points)), "elements": int(len(elements)),
                "size_kB": round(ascii_size(mesh) / 1000.0, 1)}

    rest, node, rmse_nodes = hybrid.surface.vertices, model.node, model.rmse_nodes
    return {
        "source": spec,
        "surface": sizes(hybrid.surface, "triangles"),
        "coarse_surface": sizes(hybrid.coarse_surface, "triangles"),
        "volume": sizes(hybrid.volume, "tets"),
        "fine_volume": sizes(hybrid.fine_volume, "tets"),
        "control_nodes": int(len(hybrid.control)),
        "fixed_nodes": int(len(protocol.fixed_nodes(rest))),
        "load_node": int(node),
        "load_node_position_m": [float(x) for x in rest[node]],
        "plot_samples": [int(i) for i in model.plot_nodes],
        "rmse_samples": [int(i) for i in rmse_nodes],
        "rmse_sample_radius_mm": float(1e3 * np.linalg.norm(rest[rmse_nodes] - rest[node], axis=1).max()),
        "size_m": float(np.linalg.norm(np.ptp(rest, axis=0))),
        "build_s": round(build_s, 3),
    }


def solver_parameters(method: str, solver: Solver) -> dict:
    """The scalar values a solver holds for its keyword options (calibrated values included)."""
    from ..solvers import solver_options

    values = {}
    for option in solver_options(method):
        value = getattr(solver, option, None)
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, (int, float, str, bool)):
            values[option] = value
    return values


def sweep_metadata(config: ExperimentConfig, model_info: dict) -> dict:
    """The document's metadata (wall time aside): versions, machine, date, options and the models' figures."""
    from .. import __version__

    packages = {}
    for name in ("numpy", "scipy", "numba", "tetgen", "meshio", "matplotlib"):
        try:
            packages[name] = __import__(name).__version__
        except Exception:  # a missing optional package is reported as absent, not fatal
            packages[name] = None
    options = asdict(config)
    options["models"] = list(config.models)
    return {
        "tissuesim": __version__,
        "python": platform.python_version(),
        "packages": packages,
        "machine": {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
                    "cpus": os.cpu_count()},
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "options": json.loads(json.dumps(options, default=list)),
        "models": model_info,
    }
