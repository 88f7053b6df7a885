"""Carry a solver over a cut: new mesh, state renumbered, masses, constraints edited locally (§7, second half).

One updater per method, found through a registry (``@register_cut("name")``); the ``fem`` reference is
registered as refusing, with the reason. After :meth:`SolverCut.apply` the solver holds the cut hybrid mesh
(``solver.hybrid``), its positions and velocities follow the new numbering (old vertices keep their indices, so
a held pin-head keeps its node), and stepping goes on without a reset.

What every surface method gets:

* **masses** stay the method's lumping (the body mass spread by lumped area): the cut only moves area between
  nodes, so the total is conserved (to round-off);
* **fixed** nodes: a new vertex is fixed when all its parents are (a duplicate of a fixed node stays fixed);
* **loose pieces**: a cut that joins an earlier opening may separate a piece of surface. A piece holding no
  prescribed node would drift, so the methods that prescribe nodes refuse such a cut (nothing is changed and
  the error says how many vertices the piece has); the embedded method keeps it (its embedding holds it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import SolverError
from ..loads import lumped_areas, triangle_areas
from .core import CutResult, cut_surface
from .remap import cut_hybrid, interpolate
from .rows import EdgeMap

_REGISTRY: dict[str, type] = {}


@dataclass(frozen=True)
class CutReport:
    """What one scalpel call did.

    Attributes:
        triangles_split: triangles of M_S split by this call.
        vertices_added: new M_S vertices (edge and facet points, duplicates).
        control_released: control nodes released (both copies of each).
        loose_vertices: vertices of pieces cut loose and kept by their embedding (embedded method only).
        seconds: wall time of the call [s].
    """

    triangles_split: int = 0
    vertices_added: int = 0
    control_released: int = 0
    loose_vertices: int = 0
    seconds: float = 0.0


def register_cut(name: str):
    """Class decorator: the cut updater of solver method ``name``."""

    def decorate(cls):
        _REGISTRY[name] = cls
        return cls

    return decorate


def cut_updater(solver) -> "SolverCut":
    """The updater bound to ``solver`` (created on first use and kept on the solver)."""
    updater = getattr(solver, "_cut_updater", None)
    if updater is None:
        _load_updaters()
        name = getattr(solver, "name", type(solver).__name__)
        if name not in _REGISTRY:
            raise SolverError(f"the {name} method does not support cutting; cut a hybrid, pbd, mass-spring or "
                              "embedded solver")
        updater = _REGISTRY[name](solver)
        solver._cut_updater = updater
    return updater


class SolverCut:
    """Base updater: the parts every surface method shares. Subclasses edit their own arrays."""

    #: whether a piece cut loose from every prescribed node is kept (by its embedding) instead of refused
    keeps_loose = False

    def __init__(self, solver):
        self.solver = solver
        triangles = solver.hybrid.surface.triangles
        self.edges = EdgeMap(triangles)
        self.closed = np.zeros((0, 2), dtype=np.int64)
        self.lumped = lumped_areas(solver.rest_positions, triangles)
        # The cuts as a graph over vertex identities (a duplicate is its original): a piece can only come loose
        # when a cut closes a cycle in it, so the O(m) component count runs only then.
        self.identity = np.arange(len(solver.rest_positions))
        self.cut_parent: dict[int, int] = {}
        self.cut_seen: set[tuple[int, int]] = set()

    def apply(self, sweep, *, snap: float) -> tuple[CutReport, int]:
        """Cut along ``sweep`` and carry the solver over: a report of what changed, and the vertex where the cut
        stopped (−1 if nothing was cut)."""
        start = time.perf_counter()
        s = self.solver
        result = cut_surface(s.rest_positions, s.positions, s.velocities, s.hybrid.surface.triangles, sweep,
                             snap=snap, closed=self.closed)
        if result is None:
            return CutReport(seconds=time.perf_counter() - start), -1
        n, m = len(s.rest_positions), len(s.hybrid.surface.triangles)
        originals = np.unique(result.copy_of[result.copy_of >= 0])
        released = originals[np.isin(originals, s.hybrid.control, kind="table")]
        fixed = _fixed_after(s.fixed, result, n)
        identity = np.concatenate([self.identity, np.arange(n, len(result.rest))])
        copies = np.flatnonzero(result.copy_of >= 0)
        identity[copies] = identity[result.copy_of[copies]]
        parent, seen, cycle = self._cut_graph(result, identity)
        loose = self._loose(result, n, self.held_nodes(result, fixed, released)) if cycle else 0
        old_triangles = s.hybrid.surface.triangles
        old_rows = result.changed[result.changed < m]
        old_content = np.array(old_triangles[old_rows], dtype=np.int64)
        self.edges.remove(old_rows, old_content)
        self.edges.add(result.changed, result.triangles[result.changed])
        self._update_lumped(result, old_rows, old_content, n)
        s.hybrid = cut_hybrid(s.hybrid, result, released)
        self._carry_state(result, n, fixed)
        self.update(result, n, old_triangles, old_content, released)
        self._reload()
        self.closed = result.closed
        self.identity, self.cut_parent, self.cut_seen = identity, parent, seen
        return CutReport(triangles_split=result.split_count, vertices_added=len(result.rest) - n,
                         control_released=int(released.size), loose_vertices=loose,
                         seconds=time.perf_counter() - start), result.end_vertex

    # ------------------------------------------------------------------------------------ shared steps
    def _carry_state(self, result: CutResult, n: int, fixed: np.ndarray) -> None:
        s = self.solver
        s.rest_positions = s.hybrid.surface.vertices
        s.state.positions = np.ascontiguousarray(result.positions)
        s.state.velocities = np.ascontiguousarray(result.velocities)
        forces = np.zeros_like(s.state.positions)
        forces[:n] = s.forces
        s.forces = forces
        s._previous = np.array(s.state.positions)
        s.fixed = fixed

    def _reload(self) -> None:
        """Contact patches are cached per node on the uncut surface: drop them and re-apply a held load, so a
        patch that now borders the cut loses the nodes across it."""
        s = self.solver
        s._patches.clear()
        s._lumped_areas = None
        if s._load_node >= 0:
            s.set_load(s._load_node, s._load_force.copy(), radius=s.load_radius)

    def _update_lumped(self, result, old_rows, old_content, n) -> None:
        """Lumped area (a third of each triangle per corner) edited for the changed triangles only."""
        lumped = np.zeros(len(result.rest))
        lumped[:n] = self.lumped
        old_area = triangle_areas(self.solver.rest_positions, old_content)
        np.add.at(lumped, old_content.ravel(), -np.repeat(old_area / 3.0, 3))
        new_content = result.triangles[result.changed]
        np.add.at(lumped, new_content.ravel(), np.repeat(triangle_areas(result.rest, new_content) / 3.0, 3))
        self.lumped = lumped

    def _cut_graph(self, result: CutResult, identity: np.ndarray):
        """The cut graph with this cut's edges added (new copies, the caller keeps them if the cut is applied),
        and whether one of them closed a cycle."""
        parent, seen, cycle = dict(self.cut_parent), set(self.cut_seen), False

        def find(v):
            parent.setdefault(v, v)
            while parent[v] != v:
                parent[v] = parent[parent[v]]
                v = parent[v]
            return v

        for u, v in identity[result.cut_edges].tolist():
            key = (u, v) if u < v else (v, u)
            if key in seen or u == v:
                continue
            seen.add(key)
            ru, rv = find(u), find(v)
            cycle |= ru == rv
            parent[ru] = rv
        return parent, seen, cycle

    def _loose(self, result: CutResult, n: int, held_nodes: np.ndarray) -> int:
        """Vertices of pieces without a prescribed node (0 if none); refuses unless :attr:`keeps_loose`."""
        tri = result.triangles.astype(np.int64)
        n = len(result.rest)
        rows = np.repeat(np.arange(len(tri)), 3)
        incidence = coo_matrix((np.ones(rows.size), (tri.ravel(), rows)), shape=(n, len(tri))).tocsr()
        count, label = connected_components(incidence @ incidence.T, directed=False)
        if count == 1:
            return 0
        held = np.zeros(count, dtype=bool)
        held[label[held_nodes]] = True
        loose = int(np.count_nonzero(~held[label]))
        if loose and not self.keeps_loose:
            raise SolverError(
                f"this cut would separate a piece of {loose} surface vertices from every prescribed node, and the "
                f"{self.solver.name} method would let it drift; the cut was not applied (cut elsewhere, or use "
                "the embedded method, which keeps such pieces)")
        return loose

    def held_nodes(self, result: CutResult, fixed: np.ndarray, released: np.ndarray) -> np.ndarray:
        """Vertices (new numbering) that hold a piece in place after ``result``: the fixed ones here."""
        return np.asarray(fixed, dtype=np.int64)

    def update(self, result, n, old_triangles, old_content, released) -> None:
        """Method-specific arrays (subclasses)."""
        raise NotImplementedError


def _fixed_after(fixed: np.ndarray, result: CutResult, n: int) -> np.ndarray:
    """``(k,) int32`` fixed vertices after a cut: a new vertex is fixed when all its parents are."""
    mask = np.zeros(n)
    mask[fixed] = 1.0
    return np.flatnonzero(interpolate(mask, result, n) >= 1.0 - 1e-12).astype(np.int32)


def lumped_masses(lumped_area: np.ndarray, total: float) -> np.ndarray:
    """``(n,) float64`` masses [kg]: ``total`` [kg] spread in proportion to ``lumped_area`` ``(n,)`` [m²]."""
    return total * lumped_area / lumped_area.sum()


@register_cut("fem")
class RefuseFineFEM:
    """The fine-FEM reference cannot be cut: its volume would need re-tetrahedralizing."""

    reason = ("the fem reference cannot be cut: cutting its fine volume would need re-tetrahedralizing and "
              "re-factorizing K for every move (what the hybrid avoids); cut a hybrid, pbd, mass-spring or embedded "
              "solver")

    def __init__(self, solver):
        raise SolverError(self.reason)


def refusal(name: str) -> str | None:
    """Why solver method ``name`` cannot be cut, or None if it can."""
    _load_updaters()
    if name not in _REGISTRY:
        return f"the {name} method does not support cutting"
    return getattr(_REGISTRY[name], "reason", None)


def _load_updaters() -> None:
    """Import the modules that register the updaters of the built-in methods."""
    from . import layer_update, spring_update  # noqa: F401
