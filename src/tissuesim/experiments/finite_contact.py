"""A finite-strain reference for the contact protocol: the stable equilibrium, under each of the protocol's loads, on
the same refined quadratic-tet levels as the linear reference (:mod:`.reference`).

* **Levels, load, support** as the linear reference's: M_S refined around the contact, TetGen, quadratic tets; a
  uniform dead traction on the refined surface's triangles within R of the load node
  (:func:`.reference.patch_traction`); the nodes at or below the bottom height fixed.
* **Solve.** :class:`~tissuesim.fem.nonlinear_quadratic.QuadraticNonlinearFEM` (Newton with the consistent tangent, line
  search, load stepping), checked against scikit-fem's own Newton on identical meshes and against the exact
  uniaxial stretch (tests/validation/test_finite_strain_skfem.py). The loads of one direction are reached in turn,
  each from the previous one's answer.
* **Stop.** As the linear reference: when the sample displacements change by less than the tolerance between two
  levels, now for every load (the largest change). A finite-strain response is not linear in the force, so each
  load is a solve of its own and the reference holds one field per load.
* **Stable loads only.** A load for which a level finds no stable equilibrium is left out from that level on
  (:attr:`FiniteContactReference.unstable`); the protocol does not run a press beyond the stable dead-load range
  at all (:func:`tissuesim.solvers.finite_strain.check_dead_press`).

Cached like the linear references, keyed by the mesh, node, R, the material, the loads and the settings.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..loads import contact_radius
from ..mesh.regions import bottom_height, nodes_below
from ..mesh.tetrahedralize import FINE_SWITCHES
from . import protocol
from .reference import (CACHE_FORMAT, LevelRow, RefinementSettings, _edge_length_at, _level_volume,
                        format_row, level_row, patch_traction)
from .reference_cache import read_arrays, write_arrays
from .reference_progress import LevelProgress

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..mesh.hybrid import HybridMesh
    from ..mesh.surface import SurfaceMesh

__all__ = ["FiniteContactReference", "finite_contact_reference"]


@dataclass(frozen=True)
class FiniteContactReference:
    """The finite-strain reference of one contact.

    Attributes:
        node: the contact M_S node. radius: patch radius R [m]. material: the finite-strain material.
        forces: ``(k, 3) float64`` the loads [N] solved, each spread over the patch.
        fields: ``(k, n, 3) float64`` the M_S displacements [m] under each load (NaN where it is unstable).
        samples: ``(s,) int64`` the compared M_S nodes (nearest the contact first).
        levels: the convergence table, one :class:`~.reference.LevelRow` per level; its displacements are per
            newton of the largest stable load (a secant compliance, since the response is not linear), its change
            the largest over the loads.
        converged: whether the last change fell below the tolerance.
        unstable: ``(k,) bool`` the loads with no stable equilibrium on the last level.
    """

    node: int
    radius: float
    material: str
    forces: np.ndarray
    fields: np.ndarray
    samples: np.ndarray
    levels: tuple
    converged: bool
    unstable: np.ndarray
    youngs_modulus: float
    poisson_ratio: float

    def displacements(self, force: np.ndarray | Sequence[float]) -> np.ndarray:
        """``(n, 3) float64`` M_S displacements [m] under ``force`` ``(3,)`` [N], one of :attr:`forces`; SolverError
        for a load not solved or without a stable equilibrium."""
        match = np.flatnonzero(np.all(np.isclose(self.forces, np.asarray(force, dtype=np.float64), rtol=1e-12,
                                                 atol=1e-12), axis=1))
        if match.size == 0:
            raise SolverError(f"the finite-strain reference has no load {np.asarray(force).tolist()} N; it solved "
                              f"{self.forces.tolist()}")
        if self.unstable[match[0]]:
            raise SolverError(f"the finite-strain reference found no stable equilibrium under "
                              f"{np.asarray(force).tolist()} N")
        return self.fields[match[0]]


def finite_contact_reference(mesh: HybridMesh | SurfaceMesh, node: int, radius: float,
                             forces: ArrayLike, *, material: str = "neo-hookean",
                             youngs_modulus: float = 5500.0, poisson_ratio: float = 0.3,
                             settings: RefinementSettings | None = None, cache_dir: Path | str | None = None,
                             progress: Callable[[str], None] | None = None,
                             bar: bool = False) -> FiniteContactReference:
    """The finite-strain equilibrium of the M_S nodes under each of ``forces`` ``(k, 3)`` [N], spread over the
    contact patch of ``node`` with radius ``radius`` [m], refined until it converges (module docstring).

    Args:
        mesh: a :class:`~tissuesim.mesh.hybrid.HybridMesh` (its M_S is used) or a closed surface mesh.
        material: ``"corotated"`` or ``"neo-hookean"``. youngs_modulus, poisson_ratio: E [Pa], ν [-].
        settings: refinement settings (default :class:`~.reference.RefinementSettings`).
        cache_dir: folder of the on-disk cache; None: no cache.
        progress: optional callable receiving one line of text per load and level.
        bar: while computing, a bar over the levels with an estimate of their time
            (:class:`.reference_progress.LevelProgress`).
    """
    from ..fem.hyperelastic import check_material

    surface = getattr(mesh, "surface", mesh)
    settings = settings or RefinementSettings()
    material, node, radius = check_material(material), int(node), contact_radius(radius)
    if material == "linear":
        raise SolverError("the finite-strain reference needs a finite-strain material (corotated or neo-hookean); "
                          "the linear one is tissuesim.experiments.reference.contact_reference")
    if not 0 <= node < surface.vertex_count:
        raise SolverError(f"contact node {node} is outside the surface's vertices 0..{surface.vertex_count - 1}")
    forces = np.asarray(forces, dtype=np.float64).reshape(-1, 3)
    if not len(forces) or not np.all(np.isfinite(forces)) or not np.all(np.linalg.norm(forces, axis=1) > 0):
        raise SolverError(f"the finite-strain reference needs nonzero finite loads (k, 3) [N], got {forces.tolist()}")
    key = _cache_key(surface, node, radius, material, forces, youngs_modulus, poisson_ratio, settings)
    cached = _load(cache_dir, key)
    if cached is not None:
        return cached
    tracker = LevelProgress(progress, settings.max_levels, bar=bar)
    try:
        reference = _compute(surface, node, radius, forces, material, youngs_modulus, poisson_ratio, settings,
                             tracker)
    finally:
        tracker.close()
    write_arrays(cache_dir, key, {"node": node, "radius": radius, "material": material,
                                  "converged": reference.converged, "E": youngs_modulus, "nu": poisson_ratio,
                                  "levels": [asdict(row) for row in reference.levels]},
                 forces=reference.forces, fields=reference.fields, samples=reference.samples,
                 unstable=reference.unstable)
    return reference


def _compute(surface, node, radius, forces, material, youngs_modulus, poisson_ratio, settings, progress):
    rest = np.asarray(surface.vertices, dtype=np.float64)
    samples = protocol.sample_nodes(rest, node, min(settings.samples, len(rest)))
    h0 = _edge_length_at(surface, node)
    previous, rows = None, []
    for level in range(settings.max_levels + 1):
        level_mesh = _level_volume(surface, rest[node], radius, h0, level, settings)
        if level_mesh is None:
            progress.say(f"level {level} would exceed {settings.max_surface_vertices} surface vertices; stopped")
            break
        refined, volume, _ = level_mesh
        progress.level_meshed(level, len(volume.tets))
        fields = _solve_level(volume, refined, surface.vertex_count, rest, node, radius, forces, material,
                              youngs_modulus, poisson_ratio, progress.say)
        progress.level_solved()
        change = None if previous is None else _largest_change(fields, previous, samples)
        previous = fields
        rows.append(_row(level, volume, h0, settings, samples, fields, forces, node, change))
        progress.say(f"R = {1e3 * radius:g} mm, {material}: " + format_row(rows[-1]))
        if change is not None and level >= settings.min_levels and change < settings.tolerance:
            break
    if previous is None:
        raise SolverError(f"no refinement level fits within {settings.max_surface_vertices} surface vertices; raise "
                          "max_surface_vertices")
    last = rows[-1].change
    return FiniteContactReference(node, radius, material, forces, previous, samples, tuple(rows),
                                  bool(last is not None and last < settings.tolerance),
                                  np.isnan(previous).any(axis=(1, 2)), float(youngs_modulus), float(poisson_ratio))


def _solve_level(volume, refined, n, rest, node, radius, forces, material, youngs_modulus, poisson_ratio, say):
    """``(k, n, 3)`` M_S displacements [m] of one level under each load (NaN rows where none is stable): the loads
    of one direction in order of size, each from the last stable answer."""
    from ..fem.nonlinear import UnstableLoadError
    from ..fem.nonlinear_quadratic import QuadraticNonlinearFEM

    height = bottom_height(rest)
    fem = QuadraticNonlinearFEM(volume, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                                fixed=lambda points: nodes_below(points, height), material=material)
    weights = patch_traction(fem.linear, refined, rest[node], node, radius)[:, None]
    fields = np.full((len(forces), n, 3), np.nan)
    magnitudes = np.linalg.norm(forces, axis=1)
    directions = forces / magnitudes[:, None]
    for order in _paths(directions, magnitudes):
        u = None
        for k in order:
            start = time.perf_counter()
            try:
                u = fem.solve(weights * forces[k], initial=u)
            except UnstableLoadError:
                say(f"  {magnitudes[k]:g} N: no stable equilibrium on this level; larger loads of this direction "
                    "are left out too")
                break
            fields[k] = u[:n]     # M_S's vertices are the volume's first nodes (TetGen's Y)
            say(f"  {forces[k].tolist()} N: {fem.last_iterations} Newton iterations, "
                f"{time.perf_counter() - start:.1f} s")
    return fields


def _paths(directions, magnitudes) -> list:
    """The load indices grouped by direction, each group in order of size."""
    groups: list[list[int]] = []
    for k in np.argsort(magnitudes, kind="stable").tolist():
        for group in groups:
            if np.allclose(directions[group[0]], directions[k], atol=1e-12):
                group.append(k)
                break
        else:
            groups.append([k])
    return groups


def _largest_change(fields, previous, samples) -> float:
    """The largest over the loads of RMS |u_ℓ − u_ℓ₋₁| over the samples divided by the RMS of |u_ℓ| (a load
    unstable on either level is left out)."""
    change = 0.0
    for now, before in zip(fields[:, samples], previous[:, samples]):
        if np.isnan(now).any() or np.isnan(before).any():
            continue
        scale = np.sqrt(np.mean(np.sum(now * now, axis=1)))
        if scale > 0:
            change = max(change, float(np.sqrt(np.mean(np.sum((now - before) ** 2, axis=1))) / scale))
    return change


def _row(level, volume, h0, settings, samples, fields, forces, node, change) -> LevelRow:
    stable = np.flatnonzero(~np.isnan(fields).any(axis=(1, 2)))
    if stable.size == 0:
        secant = np.full(fields.shape[1:], np.nan)
    else:
        k = stable[np.argmax(np.linalg.norm(forces[stable], axis=1))]
        secant = fields[k] / np.linalg.norm(forces[k])
    return level_row(level, volume, h0, settings, samples, secant, node, change)


def _load(cache_dir, key) -> FiniteContactReference | None:
    entry = read_arrays(cache_dir, key)
    if entry is None:
        return None
    meta, data = entry
    try:
        return FiniteContactReference(
            int(meta["node"]), float(meta["radius"]), str(meta["material"]), data["forces"], data["fields"],
            data["samples"], tuple(LevelRow(**row) for row in meta["levels"]), bool(meta["converged"]),
            data["unstable"].astype(bool), float(meta["E"]), float(meta["nu"]))
    except (KeyError, TypeError, ValueError):
        return None       # a foreign or damaged entry is recomputed


def _cache_key(surface, node, radius, material, forces, youngs_modulus, poisson_ratio, settings) -> str:
    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(surface.vertices, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(surface.triangles, dtype=np.int64).tobytes())
    digest.update(np.ascontiguousarray(forces, dtype=np.float64).tobytes())
    digest.update(json.dumps({"format": CACHE_FORMAT, "kind": "finite", "node": node, "radius": radius,
                              "material": material, "E": float(youngs_modulus), "nu": float(poisson_ratio),
                              "switches": FINE_SWITCHES, "settings": asdict(settings)}, sort_keys=True).encode())
    return digest.hexdigest()[:32]
