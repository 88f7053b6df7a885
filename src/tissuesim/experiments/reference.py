"""A reference that converges: quadratic-tet FEM on volumes refined level by level near the contact.

A load on one node is a point load, singular in 3-D elasticity: the fine FEM's value at that node grows as 1/h under
refinement and never converges. A pin-head's contact patch of radius R (:func:`tissuesim.loads.contact_patch`) is a
traction of finite density, whose displacement field has a limit. This module computes that limit at the M_S nodes:

* **Level ℓ mesh.** A size field: ``h_c = h0 · 2^-ℓ`` within the largest patch radius of the contact node, growing
  with slope ``g_ℓ = grading · grading_ratio^ℓ`` beyond it (h0: the mean M_S edge length at the contact node), so
  every surface size near the samples shrinks from level to level. M_S is refined to it by conforming longest-edge
  bisection (:func:`tissuesim.mesh.refine.refine_surface`; every M_S vertex stays a node, bit for bit, and the
  surface keeps its shape); TetGen fills the result with the default fine volume's quality switches (``Y``: the
  refined surface is the boundary, so M_S's vertices are the volume's first nodes), which grade the interior from
  the refined surface inward. Level 0 is the default fine volume itself (the ``fem`` solver's mesh). A fixed
  grading would leave the farther samples at a fixed error (measured: a 1 % change between levels while the values
  still drift by several %), hence the shrinking slope.
* **Element.** Quadratic (10-node) tets (:mod:`tissuesim.fem.quadratic`) by default: linear ones kept drifting by
  1–2 % per level through the slowly refining interior (``element="linear"`` keeps them).
* **Load.** A uniform traction (force / patch area) on the level's surface triangles whose centroid lies within R of
  the contact node, resolved ever finer; with linear tets, the solvers' contact patch rule on the level's nodes
  (at level 0 exactly the solvers' nodal forces). ``radius=None`` is the single-node load (diverging).
* **The solvers' load, too.** On quadratic tets each level also solves for the load the solvers are given: the
  nodal forces of :func:`tissuesim.loads.contact_patch` on M_S, each node's share as a traction linear over M_S's
  triangles (density share / lumped area at the node, carried to the refined vertices by averaging the ends of each
  split edge), which lumps back to exactly those forces; on the level the reference stops at. The difference
  between the two responses is the **load rule floor** (:attr:`ContactReference.load_rule_floor`): the error that
  a method solving its load exactly would still have against the reference. A method below it is nearer the
  uniform traction than its own load is, through errors that happen to compensate.
* **Support.** As every solver's fine FEM: the volume nodes at or below the bottom height of M_S are fixed.
* **Stop.** When the displacements of the sample nodes change by less than ``tolerance`` between two levels:
  RMS over the samples of |u_ℓ − u_ℓ₋₁| divided by the RMS of |u_ℓ| (a vector change, not a change of the RMS), for
  a unit force along each axis; the largest of the three.

Linear elasticity makes the response linear in the force: the result is the M_S displacement per unit force along
each axis, ``(n, 3, 3)`` [m/N], and any force is ``response @ f``. Converged references are cached on disk keyed by
the mesh (hash of M_S, its positions to the nanometre), the node, R, the material and the refinement settings, so a
rerun reads them in milliseconds; the contact protocol's own references ship with the package under the same keys
(:mod:`.reference_cache`).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Iterable
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..loads import contact_radius, triangle_areas
from ..mesh.refine import refine_surface
from ..mesh.regions import bottom_height, nodes_below
from ..mesh.tetrahedralize import FINE_SWITCHES, tetrahedralize
from . import protocol
from .reference_cache import load_entry, load_shipped, save_entry
from .reference_data import ContactReference, LevelRow, RefinementSettings, format_row
from .reference_progress import LevelProgress

if TYPE_CHECKING:
    from ..fem.quadratic import QuadraticFEM
    from ..mesh.hybrid import HybridMesh
    from ..mesh.surface import SurfaceMesh
    from ..mesh.tetmesh import TetMesh

# Bump when the computation changes, so stale cache entries (and shipped references) are never read.
CACHE_FORMAT = 4

__all__ = ["ContactReference", "LevelRow", "RefinementSettings", "contact_reference", "contact_references",
           "default_cache_dir", "point_load_divergence", "refinement_levels"]


def default_cache_dir() -> Path:
    """Where references are cached: ``$TISSUESIM_CACHE``, else ``$XDG_CACHE_HOME/tissuesim``, else ~/.cache/tissuesim."""
    if os.environ.get("TISSUESIM_CACHE"):
        return Path(os.environ["TISSUESIM_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "tissuesim" / "references"


def contact_reference(mesh: HybridMesh | SurfaceMesh, node: int, radius: float | None, *,
                      youngs_modulus: float = 5500.0, poisson_ratio: float = 0.3,
                      settings: RefinementSettings | None = None, cache_dir: Path | str | None = None,
                      progress: Callable[[str], None] | None = None, shipped: bool = False) -> ContactReference:
    """The reference response of the M_S nodes to a unit force per axis on the contact patch of ``node``.

    Args:
        mesh: a :class:`~tissuesim.mesh.hybrid.HybridMesh` (its M_S is used) or a closed
            :class:`~tissuesim.mesh.surface.SurfaceMesh`.
        node: the contact M_S vertex.
        radius: patch radius R [m], or None for the single-node load (which does not converge).
        youngs_modulus, poisson_ratio: the material [Pa], [-] (the solvers' defaults).
        settings: refinement settings (default :class:`RefinementSettings`).
        cache_dir: folder of the on-disk cache; None: no cache.
        progress: optional callable receiving one line of text per level computed.
        shipped: read the reference shipped with the package for exactly these parameters, if there is one.
    """
    return contact_references(mesh, node, (radius,), youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                              settings=settings, cache_dir=cache_dir, progress=progress, shipped=shipped)[0]


def contact_references(mesh: HybridMesh | SurfaceMesh, node: int, radii: Iterable[float | None], *,
                       youngs_modulus: float = 5500.0, poisson_ratio: float = 0.3,
                       settings: RefinementSettings | None = None, cache_dir: Path | str | None = None,
                       progress: Callable[[str], None] | None = None, shipped: bool = False,
                       bar: bool = False) -> list:
    """:func:`contact_reference` for several radii on one shared sequence of meshes (refined around the largest
    patch), until every radius has converged; cached per radius. Returns one :class:`ContactReference` per radius.

    ``shipped``: read a reference shipped with the package under the same key before the cache (the contact
    protocol's own cases; :data:`.reference_cache.SHIPPED_DIR`). ``bar``: while computing, a progress bar over the
    levels with an estimate of their time on stderr (:class:`.reference_progress.LevelProgress`), beside the lines
    sent to ``progress``."""
    surface = getattr(mesh, "surface", mesh)
    settings = settings or RefinementSettings()
    node = int(node)
    if not 0 <= node < surface.vertex_count:
        raise SolverError(f"contact node {node} is outside the surface's vertices 0..{surface.vertex_count - 1}")
    radii = [None if r is None else contact_radius(r) for r in radii]
    keys = [_cache_key(surface, node, r, youngs_modulus, poisson_ratio, settings) for r in radii]
    cached = [(load_shipped(key, settings) if shipped else None) or load_entry(cache_dir, key, settings)
              for key in keys]
    missing = [i for i, ref in enumerate(cached) if ref is None]
    if missing:
        tracker = LevelProgress(progress, settings.max_levels, bar=bar)
        try:
            computed = _compute(surface, node, [radii[i] for i in missing], youngs_modulus, poisson_ratio, settings,
                                tracker, stop=True)
        finally:
            tracker.close()
        for i, ref in zip(missing, computed):
            cached[i] = ref
            save_entry(cache_dir, keys[i], ref)
    return cached


def refinement_levels(mesh: HybridMesh | SurfaceMesh, node: int, radius: float | None, *, levels: int,
                      youngs_modulus: float = 5500.0, poisson_ratio: float = 0.3,
                      settings: RefinementSettings | None = None,
                      progress: Callable[[str], None] | None = None) -> ContactReference:
    """Levels 0..``levels`` computed whatever the change (no stop, no cache): to show how a load *diverges*."""
    surface = getattr(mesh, "surface", mesh)
    settings = settings or RefinementSettings()
    settings = RefinementSettings(**{**asdict(settings), "max_levels": int(levels)})
    radius = None if radius is None else contact_radius(radius)
    return _compute(surface, int(node), [radius], youngs_modulus, poisson_ratio, settings,
                    LevelProgress(progress, settings.max_levels), stop=False)[0]


def point_load_divergence(mesh: HybridMesh | SurfaceMesh, node: int, *, levels: int = 3, youngs_modulus: float = 5500.0,
                          poisson_ratio: float = 0.3) -> list[dict]:
    """The paper protocol's single-node load under refinement: one dict per level (``level, tets,
    contact_size_mm, contact_mm, others_rms_mm`` per newton along −z), on the solvers' linear tets. The loaded node's
    value grows without bound (as 1/h in the limit) while the other samples' RMS settles."""
    reference = refinement_levels(mesh, node, None, levels=levels, youngs_modulus=youngs_modulus,
                                  poisson_ratio=poisson_ratio, settings=RefinementSettings(element="linear"))
    keys = ("level", "tets", "contact_size_mm", "contact_mm", "others_rms_mm")
    return [{key: getattr(row, key) for key in keys} for row in reference.levels]


# --- the refinement loop ---------------------------------------------------------------------------------------

def _compute(surface, node, radii, youngs_modulus, poisson_ratio, settings, progress, *, stop: bool) -> list:
    rest = np.asarray(surface.vertices, dtype=np.float64)
    samples = protocol.sample_nodes(rest, node, min(settings.samples, len(rest)))
    height = bottom_height(rest)
    h0 = _edge_length_at(surface, node)
    core = max((r for r in radii if r is not None), default=0.0)
    previous = [None] * len(radii)
    nodal = [None] * len(radii)
    solve_nodal = None
    tables = [[] for _ in radii]
    done = [False] * len(radii)
    for level in range(settings.max_levels + 1):
        level_mesh = _level_volume(surface, rest[node], core, h0, level, settings)
        if level_mesh is None:
            progress.say(f"level {level} would exceed {settings.max_surface_vertices} surface vertices; stopped")
            break
        refined, volume, parents = level_mesh
        progress.level_meshed(level, len(volume.tets))
        solve, solve_nodal = _level_solver(volume, refined, surface, parents, rest[node], height, youngs_modulus,
                                           poisson_ratio, settings)
        for k, radius in enumerate(radii):
            if done[k]:
                continue
            response = solve(node, radius)     # M_S's vertices are the volume's first nodes (TetGen's Y)
            change = None if previous[k] is None else _relative_change(response, previous[k], samples)
            previous[k] = response
            row = level_row(level, volume, h0, settings, samples, -response[:, :, 2], node, change)  # 1 N, −z
            tables[k].append(row)
            progress.say(f"R = {_radius_text(radius)}: " + format_row(row))
            if stop and change is not None and level >= settings.min_levels and change < settings.tolerance:
                done[k] = True
                nodal[k] = solve_nodal(node, radius)   # on the level the reference stops at
        progress.level_solved()
        if stop and all(done):
            break
    for k, radius in enumerate(radii):
        if not done[k] and solve_nodal is not None:    # unconverged or not stopping: on the last level computed
            nodal[k] = solve_nodal(node, radius)
    return [ContactReference(node, radius, previous[k], samples, tuple(tables[k]),
                             bool(tables[k][-1].change is not None and tables[k][-1].change < settings.tolerance),
                             float(youngs_modulus), float(poisson_ratio), settings, nodal[k])
            for k, radius in enumerate(radii)]


def _level_solver(volume, refined, surface, parents, centre, height, youngs_modulus, poisson_ratio, settings):
    """``(solve, solve_nodal)``, each ``(node, radius) -> (n, 3, 3)``: the M_S nodes' response to a unit force per
    axis on the contact patch (or on the node alone, radius None), and to the solvers' nodal forces (module
    docstring; None on linear tets), for the settings' element."""
    n = surface.vertex_count
    nodal_weights = None
    if settings.element == "linear":
        from ..fem.linear import LinearFEM
        from ..loads import contact_patch

        fem = LinearFEM(volume, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                        fixed=nodes_below(volume.points, height))

        def weights(node, radius):
            nodes, shares = contact_patch(refined.vertices, refined.triangles, node, radius)
            w = np.zeros(fem.node_count)
            w[nodes] = shares
            return w
    else:
        from ..fem.quadratic import QuadraticFEM

        fem = QuadraticFEM(volume, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                           fixed=lambda points: nodes_below(points, height))

        def weights(node, radius):
            if radius is None:
                return np.eye(1, fem.node_count, node).ravel()
            return patch_traction(fem, refined, centre, node, radius)

        def nodal_weights(node, radius):
            density = _nodal_density(surface, parents, node, radius)
            loaded = np.any(density[refined.triangles] != 0.0, axis=1)
            triangles = np.asarray(refined.triangles, dtype=np.int64)[loaded]
            return fem.linear_traction_weights(triangles, density[triangles])

    def respond(w):
        response = np.empty((n, 3, 3))
        forces = np.zeros((fem.node_count, 3))
        for axis in range(3):
            forces[:] = 0.0
            forces[:, axis] = w
            response[:, :, axis] = fem.solve(forces)[:n]
        return response

    def solve(node, radius):
        return respond(weights(node, radius))

    def solve_nodal(node, radius):
        return None if nodal_weights is None else respond(nodal_weights(node, radius))

    return solve, solve_nodal


def patch_traction(fem: QuadraticFEM, refined: SurfaceMesh, centre: np.ndarray, node: int, radius: float) -> np.ndarray:
    """``(N,) float64`` nodal weights on a quadratic-tet model ``fem`` (:class:`~tissuesim.fem.quadratic.QuadraticFEM`)
    of a unit force spread as a uniform traction over the ``refined`` surface's triangles whose centroid lies within
    ``radius`` [m] of ``centre`` (those around ``node`` where none does)."""
    triangles = refined.triangles[np.linalg.norm(refined.vertices[refined.triangles].mean(axis=1) - centre,
                                                 axis=1) <= radius]
    if len(triangles) == 0:
        triangles = refined.triangles[np.any(refined.triangles == node, axis=1)]
    areas = triangle_areas(refined.vertices, triangles)
    return fem.traction_weights(triangles, areas / areas.sum())


def _nodal_density(surface, parents, node, radius) -> np.ndarray:
    """``(n + k,)`` [1/m²] the solvers' nodal shares of a unit force as traction densities at M_S's vertices
    (share / lumped area), then at the refined vertices (the mean of the split edge's ends, in creation order)."""
    from ..loads import contact_patch, lumped_areas

    nodes, shares = contact_patch(surface.vertices, surface.triangles, node, radius)
    density = np.zeros(surface.vertex_count + len(parents))
    density[nodes] = shares / lumped_areas(surface.vertices, surface.triangles)[nodes]
    n = surface.vertex_count
    for k, (a, b) in enumerate(parents.tolist()):
        density[n + k] = 0.5 * (density[a] + density[b])
    return density


def _level_volume(surface, centre, core, h0, level, settings):
    """``(surface, volume)`` of a level: M_S refined around ``centre``, then TetGen (with a volume bound if set);
    None when the refined surface exceeds the settings' vertex bound."""
    if level == 0:
        return surface, tetrahedralize(surface, switches=FINE_SWITCHES)[0], np.zeros((0, 2), dtype=np.int64)
    refined, parents = refine_surface(surface, lambda points: level_size(points, centre, core, h0, level, settings),
                                      parents=True)
    if refined.vertex_count > settings.max_surface_vertices:
        return None
    if settings.interior_ratio is None:
        return refined, tetrahedralize(refined, switches=FINE_SWITCHES)[0], parents
    interior = h0 * settings.interior_ratio ** level
    max_volume = interior ** 3 / (6.0 * np.sqrt(2.0))  # a regular tet of edge `interior`
    return refined, tetrahedralize(refined, switches=f"{FINE_SWITCHES}a{max_volume:.6e}")[0], parents


def level_size(points: np.ndarray, centre: np.ndarray, core: float, h0: float, level: int,
               settings: RefinementSettings) -> np.ndarray:
    """``(k,)`` target edge length [m] of level ``level`` at ``points`` ``(k, 3)`` [m]: h_c inside the core radius,
    growing with slope g_ℓ beyond it."""
    distance = np.linalg.norm(points - centre, axis=1)
    slope = settings.grading * settings.grading_ratio ** level
    return h0 * 0.5 ** level + slope * np.maximum(0.0, distance - core)


def _edge_length_at(surface, node) -> float:
    edges = surface.edges
    at = (edges[:, 0] == node) | (edges[:, 1] == node)
    vertices = surface.vertices
    return float(np.linalg.norm(vertices[edges[at, 0]] - vertices[edges[at, 1]], axis=1).mean())


def _relative_change(response, previous, samples) -> float:
    change = 0.0
    for axis in range(3):
        now, before = response[samples, :, axis], previous[samples, :, axis]
        scale = np.sqrt(np.mean(np.sum(now * now, axis=1)))
        if scale > 0:
            change = max(change, float(np.sqrt(np.mean(np.sum((now - before) ** 2, axis=1))) / scale))
    return change


def level_row(level: int, volume: TetMesh, h0: float, settings: RefinementSettings, samples: np.ndarray,
              down: np.ndarray, node: int, change: float | None) -> LevelRow:
    """The :class:`LevelRow` of a level whose M_S displacement per newton [m/N] is ``down`` ``(n, 3)``."""
    return LevelRow(
        level=level, tets=int(len(volume.tets)), nodes=int(volume.node_count),
        contact_size_mm=1e3 * h0 * 0.5 ** level,
        grading=None if level == 0 else settings.grading * settings.grading_ratio ** level,
        sample_rms_mm=1e3 * float(np.sqrt(np.mean(np.sum(down[samples] ** 2, axis=1)))),
        contact_mm=1e3 * float(np.linalg.norm(down[node])),
        others_rms_mm=1e3 * float(np.sqrt(np.mean(np.sum(down[samples[1:]] ** 2, axis=1)))), change=change)


def _radius_text(radius) -> str:
    return "none (single node)" if radius is None else f"{1e3 * radius:g} mm"


# --- the on-disk cache -----------------------------------------------------------------------------------------

def _cache_key(surface, node, radius, youngs_modulus, poisson_ratio, settings) -> str:
    digest = hashlib.sha256()
    # To the nanometre (-0.0 made 0.0): a last-bit difference in a model's positions between two machines' maths
    # libraries changes no reference, and must not miss a shipped one.
    digest.update(np.ascontiguousarray(np.round(surface.vertices, 9) + 0.0, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(surface.triangles, dtype=np.int64).tobytes())
    digest.update(json.dumps({"format": CACHE_FORMAT, "node": int(node), "radius": radius,
                              "E": float(youngs_modulus), "nu": float(poisson_ratio), "switches": FINE_SWITCHES,
                              "settings": asdict(settings)}, sort_keys=True).encode())
    return digest.hexdigest()[:32]
