"""The contact protocol: every method against a reference that converges, with metrics that cannot hide.

The paper's protocol loads one node, whose reference displacement diverges under refinement (a point load in 3-D
elasticity), so its RMSE is set by that one node and means little. Here the pin-head has a tip of radius R: the force
is spread over the M_S nodes within R of the load node (:func:`tissuesim.loads.contact_patch`), the same nodal forces
for every method (``solve_static(node, force, radius=R)``), and the reference is quadratic-tet FEM refined near the
contact until the sample displacements stop changing (:mod:`.reference`). The default cases' linear references ship
with the package (:mod:`.reference_cache`); any other is computed, with a bar and an estimate of its time, and cached.

Cases: tension (+z) and pressure (−z) at :data:`FORCES_N`, R in :data:`RADII_MM`, on the built-in models and the
two clean shared livers (cm, scaled to m). Load node and samples as the paper protocol (:mod:`.protocol`).

Metrics, each absolute [mm] and relative to the reference's RMS displacement over all samples:

* ``rmse``: eq 26 over all samples (50);
* ``rmse_outside``: eq 26 over the samples outside the contact patch (the patch taken on M_S at R);
* ``contact_error``: the error of the patch's mean displacement, |Σ w_i (x_i − x_ref,i)| over the patch nodes with
  their load shares w_i: how far the tip's footprint is from where it should be.

The free scalars of hybrid, pbd and mass-spring are calibrated on one case, :data:`CALIBRATION_CASE` (cube, pressure,
1 N, R = 4 mm); its row is labelled ``calibration`` and every other row ``held out``.

With a finite-strain ``material`` every method that has it runs with it, against the finite-strain reference of the
same levels (:mod:`.finite_contact`); a press beyond the stable dead-load range (mean pressure above μ over the
patch, :func:`tissuesim.solvers.finite_strain.check_dead_press`) is not run and is listed under
``beyond_stable_press`` with the largest stable load. Such presses need a rigid tip driven by displacement (:class:`tissuesim.Probe`).
"""

from __future__ import annotations

import datetime as _dt
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SolverError
from ..mesh import models as builtin_models
from ..solvers.near_field import NEAR_FIELD_WINDOW
from . import protocol
from .inputs import check_free_node, model_name
from .reference import RefinementSettings, contact_references
from .sweep_config import ExperimentConfig, load_model
from .sweep_measure import inverted_elements

FORCES_N = (0.5, 1.0, 2.0, 5.0, 10.0)
RADII_MM = (4.0, 8.0)
# The clean public livers of the shared mesh folder (path inside it, factor to metres).
SHARED_LIVERS = (("sofa/liver2.obj", 0.01), ("softbodyliver/liver.obj", 0.01))
# (model, load, force [N], R [mm]) on which the solvers' free scalars are fitted.
CALIBRATION_CASE = ("cube", "pressure", 1.0, 4.0)
SCHEMA = "tissuesim-contact/1"
# The reduced run of --quick: the coarse cube, one R, two forces, two reference levels.
#: The command line's refinement cap for a finite-strain reference (a Newton solve per load and level): the cube's
#: levels 0–2 take 35, 64 and 117 s on one core for five pulls up to 5 N over R = 4 mm (level 3 stalls near 2 N).
FINITE_MAX_LEVELS = 2
QUICK = dict(models=("cube",), resolution=400, forces=(1.0, 10.0), radii_mm=(8.0,), max_steps=500,
             settings=RefinementSettings(max_levels=2))

METRICS = ("rmse", "rmse_outside", "contact_error")
#: Measured options run as methods of their own: name -> (solver, options).
VARIANTS = {"hybrid-near": ("hybrid", {"near_field": NEAR_FIELD_WINDOW}),
            "hybrid-quadratic": ("hybrid", {"element": "quadratic"})}


@dataclass(frozen=True)
class ContactConfig:
    """What the contact protocol runs (keyword-only; defaults are the full protocol).

    Attributes:
        models: built-in names, or surface files / bundles; a file's factor to metres is in ``scales``.
        scales: ``{spec: factor to metres}`` for surface files and built-in models (default 1; a bundle is not
            scaled).
        forces: magnitudes [N]. loads: from :data:`protocol.LOADS`. radii_mm: patch radii R [mm].
        methods: solver names or :data:`VARIANTS` (default: every registered solver, then the variants).
        resolution: vertices of the built-in models (None: Table-1 size).
        max_steps: cap on one quasi-static solve's steps (unsettled solves are recorded, not fatal).
        settings: the reference's refinement settings.
        cache_dir: where converged references are cached (None: no cache).
        shipped: read the references shipped with the package where they were computed for exactly this case
            (:mod:`.reference_cache`); False: compute (or read from ``cache_dir``) every one.
        material: ``"linear"`` or a finite-strain material; the default methods are then those that have it, and a
            named method without it is refused. Each finite-strain load is a Newton solve per level, so the command
            line caps its refinement at :data:`FINITE_MAX_LEVELS` unless ``--levels`` says otherwise.
    """

    models: tuple = tuple(builtin_models.MODELS)
    scales: dict = field(default_factory=dict)
    forces: tuple = FORCES_N
    loads: tuple = protocol.LOADS
    radii_mm: tuple = RADII_MM
    methods: tuple | None = None
    resolution: int | None = None
    max_steps: int = 1000
    settings: RefinementSettings = field(default_factory=RefinementSettings)
    cache_dir: str | None = None
    shipped: bool = True
    material: str = "linear"

    def __post_init__(self):
        from ..fem.hyperelastic import check_material

        protocol.load_cases(self.forces, self.loads)  # validates forces and loads
        check_material(self.material)
        if not self.radii_mm or not all(np.isfinite(r) and r > 0 for r in self.radii_mm):
            raise SolverError(f"contact radii must be positive numbers of millimetres, got {self.radii_mm}")
        if self.methods is not None:
            from ..solvers import available_solvers

            known = (*available_solvers(), *VARIANTS)
            unknown = [m for m in self.methods if m not in known]
            if unknown or not self.methods:
                raise SolverError(f"unknown contact protocol method(s) {', '.join(map(repr, unknown)) or '(none)'}; "
                                  f"choose from {', '.join(known)}")
            lacking = [m for m in self.methods if self.material not in _method_class(m).materials]
            if lacking:
                raise SolverError(f"{', '.join(lacking)} {'has' if len(lacking) == 1 else 'have'} no {self.material} "
                                  f"material; choose among {', '.join(methods_with(self.material))}")


def shared_livers(folder: Path | str | None = None) -> dict:
    """``{path: scale}`` of the shared livers found in ``folder`` (default ``$TISSUESIM_SHARED/data/meshes``, else
    ``../shared/data/meshes`` from the working directory); missing ones are left out."""
    root = Path(folder) if folder else Path(os.environ.get("TISSUESIM_SHARED", "../shared")) / "data" / "meshes"
    return {str(root / rel): scale for rel, scale in SHARED_LIVERS if (root / rel).is_file()}


def run_contact(config: ContactConfig | None = None, *, progress: bool = True) -> dict:
    """Run the contact protocol; return its results document (JSON-ready)."""
    config = config or ContactConfig()
    start = time.perf_counter()
    methods = tuple(config.methods or methods_with(config.material))
    say = (lambda text: print(text, file=sys.stderr, flush=True)) if progress else (lambda text: None)
    records, info = [], {}
    for spec, name in zip(config.models, _names(config.models)):
        info[name] = _run_model(spec, name, methods, config, say, records, bar=progress)
    return {"schema": SCHEMA, "metadata": _metadata(config, methods, info, time.perf_counter() - start),
            "records": records}


@dataclass(frozen=True)
class _Site:
    """One model as its contact cases see it: its report name, rest M_S positions, load node, and its solvers
    (``methods`` in the order run, ``solvers`` by method)."""

    name: str
    rest: np.ndarray
    node: int
    methods: tuple
    solvers: dict


def _run_model(spec: str, name: str, methods: tuple, config: ContactConfig, say, records: list, *,
               bar: bool = False) -> dict:
    """Every method in every case of one model, appended to ``records``; return the model's metadata (references,
    skipped radii, presses beyond the stable range, references without a stable equilibrium)."""
    hybrid = load_model(spec, ExperimentConfig(models=(spec,), resolution=config.resolution,
                                               scale=config.scales.get(spec, 1.0)))
    rest = np.array(hybrid.surface.vertices, dtype=np.float64)
    node = protocol.load_node(rest, hybrid.surface.triangles)
    site = _Site(name, rest, node, methods, {m: _make_method(m, hybrid, config.material) for m in methods})
    first = site.solvers[methods[0]]
    check_free_node(first, node, name, role="the contact load at its top centre")
    patches, skipped = _patches(first, node, config.radii_mm, lambda line: say(f"{name}: {line}"))
    kept = list(patches)    # a skipped radius costs no reference
    say(f"{name}: reference for R = {', '.join(f'{r:g}' for r in kept) or 'none'} mm")
    cases = {r: _stable_cases(first, node, r, protocol.load_cases(config.forces, config.loads)) for r in kept}
    refs = _references(hybrid, node, kept, cases, config, lambda line: say(f"  {name} {line}"), bar=bar)
    info = _model_info(spec, hybrid, node, refs, kept, config.settings)
    if skipped:
        info["skipped"] = skipped
    beyond = [entry for r in kept for entry in cases[r][1]]
    if beyond:
        info["beyond_stable_press"] = beyond
    for radius_mm, ref in zip(kept, refs):
        records.extend(_radius_records(site, radius_mm, patches[radius_mm], ref, cases[radius_mm][0],
                                       config.max_steps, info))
        say(f"{name}: R = {radius_mm:g} mm done")
    return info


def _patches(solver, node: int, radii_mm, say) -> tuple[dict, dict]:
    """``(patches, skipped)``: the contact patch of each radius [mm], and why a radius has none."""
    patches, skipped = {}, {}
    for radius_mm in radii_mm:
        try:
            patches[radius_mm] = solver.contact_patch(node, 1e-3 * radius_mm)
        except SolverError as error:  # e.g. the patch reaches the support on a small model: say so, go on
            skipped[f"{radius_mm:g}"] = str(error)
            say(f"R = {radius_mm:g} mm skipped: {error}")
    return patches, skipped


def _radius_records(site: _Site, radius_mm: float, patch: tuple, ref, cases: list, max_steps: int,
                    info: dict) -> list[dict]:
    """The records of one radius's ``cases``; a case whose reference has no stable equilibrium goes into ``info``'s
    ``unstable_reference`` instead."""
    records = []
    for case in cases:
        try:
            reference = site.rest + ref.displacements(case.vector)
        except SolverError as error:   # no stable finite-strain equilibrium on the reference's mesh
            info.setdefault("unstable_reference", []).append(
                {"load": case.load, "force_N": float(case.force_N), "radius_mm": float(radius_mm),
                 "reason": str(error)})
            continue
        records += _case_records(site, case, radius_mm, patch, ref, reference, max_steps)
    return records


def _case_records(site: _Site, case: protocol.LoadCase, radius_mm: float, patch: tuple, ref, reference,
                  max_steps: int) -> list[dict]:
    """One record per method of one case: its three errors, or the error that stopped its solve."""
    records = []
    for method in site.methods:
        record = {"model": site.name, "load": case.load, "force_N": case.force_N,
                  "radius_mm": float(radius_mm), "method": method,
                  "role": role(site.name, case.load, case.force_N, radius_mm),
                  "reference_converged": ref.converged}
        try:
            positions, solve = _equilibrium(site.solvers[method], site.node, case.vector, 1e-3 * radius_mm, max_steps)
        except SolverError as error:  # a solver that refuses or blows up: recorded, the run goes on
            records.append({**record, **_no_metrics(), "converged": False, "error": str(error)})
            continue
        records.append({**record, **contact_metrics(positions, reference, site.rest, ref.samples, *patch), **solve})
    return records


def methods_with(material: str) -> tuple:
    """The registered methods and :data:`VARIANTS` that have ``material``."""
    from ..solvers import available_solvers

    return tuple(m for m in (*available_solvers(), *VARIANTS) if material in _method_class(m).materials)


def _method_class(method: str):
    from ..solvers import solver_class

    return solver_class(VARIANTS.get(method, (method, {}))[0])


def _make_method(method: str, hybrid, material: str):
    from ..solvers import make_solver

    solver, options = VARIANTS.get(method, (method, {}))
    return make_solver(solver, hybrid, **options, **({} if material == "linear" else {"material": material}))


def _stable_cases(solver, node: int, radius_mm: float, cases: list) -> tuple[list, list]:
    """``(kept, beyond)``: the ``cases`` ``solver``'s material can carry as dead loads over the patch of radius
    ``radius_mm``, and the others (one entry each, with the reason naming the largest stable load)."""
    from ..solvers.finite_strain import check_dead_press

    kept, beyond = [], []
    for case in cases:
        try:
            check_dead_press(solver, node, case.vector, 1e-3 * radius_mm)
        except SolverError as error:
            beyond.append({"load": case.load, "force_N": float(case.force_N), "radius_mm": float(radius_mm),
                           "reason": str(error).split(";")[0]})
            continue
        kept.append(case)
    return kept, beyond


def _references(hybrid, node: int, radii_mm: list, cases: dict, config: ContactConfig, say, *,
                bar: bool = False) -> list:
    """One reference per radius: the linear response, or the finite-strain fields of that radius's stable cases."""
    if not radii_mm:
        return []
    if config.material == "linear":
        return contact_references(hybrid, node, [1e-3 * r for r in radii_mm], settings=config.settings,
                                  cache_dir=config.cache_dir, progress=say, shipped=config.shipped, bar=bar)
    from .finite_contact import finite_contact_reference

    return [finite_contact_reference(hybrid, node, 1e-3 * r, [case.vector for case in cases[r][0]] or [(0, 0, 1.0)],
                                     material=config.material, settings=config.settings, cache_dir=config.cache_dir,
                                     progress=say, bar=bar) for r in radii_mm]


def _names(specs) -> list[str]:
    """Report names: a file's stem, prefixed with its folder where two models would share one (the shared
    softbodyliver/liver.obj beside the built-in liver)."""
    names = []
    for spec in specs:
        name = model_name(spec)
        if name in names or (spec != name and name in builtin_models.MODELS):
            name = f"{Path(spec).parent.name}-{name}"
        names.append(name)
    return names


def role(model: str, load: str, force_N: float, radius_mm: float) -> str:
    """``"calibration"`` for :data:`CALIBRATION_CASE`, else ``"held out"``."""
    return "calibration" if (model, load, float(force_N), float(radius_mm)) == CALIBRATION_CASE else "held out"


def contact_metrics(positions: np.ndarray, reference: np.ndarray, rest: np.ndarray, samples: np.ndarray | Sequence[int],
                    patch_nodes: np.ndarray | Sequence[int], patch_weights: np.ndarray) -> dict:
    """The three errors of one solve, absolute [mm] and relative to the reference's RMS displacement.

    Args:
        positions, reference, rest: ``(n, 3) float64`` a method's, the reference's and the rest M_S positions [m].
        samples: ``(k,) int`` the sample nodes. patch_nodes, patch_weights: the contact patch and its load shares.

    Returns:
        ``rmse_mm, rmse_outside_mm, contact_error_mm, reference_rms_mm`` and ``relative_*`` of the three errors;
        ``rmse_outside*`` is None when the patch covers every sample.
    """
    samples = np.asarray(samples, dtype=np.int64)
    patch_nodes = np.asarray(patch_nodes, dtype=np.int64)
    outside = samples[~np.isin(samples, patch_nodes)]
    scale = protocol.rms_displacement(reference, rest, samples)
    error = np.asarray(positions)[patch_nodes] - np.asarray(reference)[patch_nodes]
    values = {"rmse": protocol.rmse(positions, reference, samples),
              "rmse_outside": protocol.rmse(positions, reference, outside) if outside.size else None,
              "contact_error": float(np.linalg.norm(np.asarray(patch_weights) @ error))}
    out = {f"{key}_mm": None if value is None else 1e3 * value for key, value in values.items()}
    out.update({f"relative_{key}": None if value is None or scale == 0 else value / scale
                for key, value in values.items()})
    out["reference_rms_mm"] = 1e3 * scale
    return out


def _no_metrics() -> dict:
    keys = [f"{m}_mm" for m in METRICS] + [f"relative_{m}" for m in METRICS] + ["reference_rms_mm"]
    return {**dict.fromkeys(keys), "equilibrium_ms": None}


def _equilibrium(solver, node, force, radius, max_steps) -> tuple[np.ndarray, dict]:
    """Quasi-static positions of one solver, with its wall time; an unsettled solve keeps its last positions."""
    solver.reset()
    solver.last_solve = None
    start = time.perf_counter()
    positions = np.array(solver.solve_static(node, force, radius=radius, max_steps=max_steps, keep_unsettled=True))
    elapsed = 1e3 * (time.perf_counter() - start)
    report = solver.last_solve
    inverted = inverted_elements(solver)
    solver.reset()
    return positions, {"equilibrium_ms": elapsed, "converged": True if report is None else bool(report.converged),
                       **inverted}


def _model_info(spec, hybrid, node, refs, radii_mm, settings) -> dict:
    rest = hybrid.surface.vertices
    samples = refs[0].samples if refs else protocol.sample_nodes(rest, node, min(settings.samples, len(rest)))
    return {
        "source": spec, "surface_nodes": int(len(rest)), "load_node": int(node),
        "samples": [int(i) for i in samples],
        "sample_radius_mm": float(1e3 * np.linalg.norm(rest[samples] - rest[node], axis=1).max()),
        "references": {f"{r:g}": {"converged": ref.converged, "levels": [asdict(row) for row in ref.levels],
                                   "load_rule_floor": getattr(ref, "load_rule_floor", None)}
                       for r, ref in zip(radii_mm, refs)},
    }


def _metadata(config, methods, info, wall_s) -> dict:
    from .. import __version__

    return {"tissuesim": __version__, "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "cpus": os.cpu_count(), "wall_s": round(wall_s, 1), "methods": list(methods),
            "forces_N": [float(f) for f in config.forces], "loads": list(config.loads),
            "radii_mm": [float(r) for r in config.radii_mm], "calibration_case": list(CALIBRATION_CASE),
            "material": config.material,
            "refinement": asdict(config.settings), "models": info}
