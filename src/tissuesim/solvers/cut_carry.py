"""Carry a solver over a cut: new mesh, state renumbered, masses, constraints edited locally (§7, second half).

One updater per method: the solver class names it (:attr:`~tissuesim.solvers.base.Solver.cut_carrier`), so a
method absorbs a cut by that class alone and the cut on arrays (:mod:`tissuesim.cutting`) knows no solver. After
:meth:`SolverCut.apply` the solver holds the cut hybrid mesh (``solver.hybrid``), its positions and velocities
follow the new numbering (old vertices keep their indices, so a held pin-head keeps its node), and stepping goes on
without a reset.

What every surface method gets:

* **masses** stay the method's lumping (the body mass spread by lumped area): the cut only moves area between
  nodes, so the total is conserved (to round-off);
* **fixed** nodes: a new vertex is fixed when all its parents are (a duplicate of a fixed node stays fixed);
* **loose pieces**: a cut may separate a piece of surface (joining an earlier opening, or on a deformed surface).
  Every move checks the pieces it split on the new topology: a piece holding no prescribed node would drift, so
  the methods that prescribe nodes refuse such a cut (nothing is changed and the error says how many vertices the
  piece has); the embedded method keeps it (its embedding holds it) and reports it in ``loose_vertices``;
* **all or nothing**: a refused move changes nothing, and a move that fails while it is written is taken back
  (:class:`~.cut_undo.CutUndo`) and raised as a SolverError, so stepping and ``reset()`` go on.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..cutting.buffers import CutSurface
from ..cutting.edges import edge_owners, touched_edges
from ..cutting.invariants import unanchored_pieces
from ..cutting.remap import cut_hybrid
from ..cutting.result import CutResult
from ..cutting.warm import load_cut_kernels
from ..errors import SolverError, TissuesimError
from ..loads import lumped_areas, triangle_areas
from .cut_undo import CutUndo

if TYPE_CHECKING:
    from ..cutting.sweep import Sweep
    from .base import Solver

#: Vertices the local loose-piece search visits (plus 16 per vertex of the changed triangles) before it leaves the
#: question to the whole-surface count.
LOCAL_SEARCH = 256


@dataclass(frozen=True)
class CutReport:
    """What one scalpel call did.

    Attributes:
        triangles_split: triangles of M_S split by this call.
        vertices_added: new M_S vertices (edge and facet points, duplicates).
        control_released: control nodes released (both copies of each).
        loose_vertices: vertices this move cut loose from every prescribed node, kept by their embedding
            (embedded method only: the others refuse such a move); a vertex a move adds to a piece already loose
            comes loose with it, so the reports of a session add up to the loose vertices of its surface.
        seconds: wall time of the call [s].
    """

    triangles_split: int = 0
    vertices_added: int = 0
    control_released: int = 0
    loose_vertices: int = 0
    seconds: float = 0.0


class SolverCut:
    """Base updater: the parts every surface method shares. Subclasses edit their own arrays.

    Every per-vertex array a move extends lives in a capacity buffer (:class:`~tissuesim.cutting.buffers.Spare`),
    and a move writes only the rows of the new vertices and of the vertices whose triangles changed, so its cost
    grows with the triangles it splits, not with the mesh (see :mod:`tissuesim.cutting.buffers` for what sharing
    storage means for arrays held from before a cut)."""

    #: whether a piece cut loose from every prescribed node is kept (by its embedding) instead of refused
    keeps_loose = False
    #: whether the move being written moved vertices onto the cut, and whether any move did (see
    #: :meth:`local_masses`)
    _moved = False
    _rescaled = False

    def __init__(self, solver: Solver):
        self.solver = solver
        triangles = solver.hybrid.surface.triangles
        self.surface = CutSurface(solver.rest_positions, solver.positions, solver.velocities, triangles)
        self.spare = self.surface.spare
        self.closed = np.zeros((0, 2), dtype=np.int64)
        self.lumped = lumped_areas(solver.rest_positions, triangles)
        self.lumped_total = float(self.lumped.sum())        # conserved by every cut (area only moves)
        #: ``(n,) int64`` the original vertex of each vertex (a duplicate's is its original's)
        self.identity = np.arange(len(solver.rest_positions))
        #: vertices in pieces that no prescribed node holds (only a method that :attr:`keeps_loose` has any)
        self.loose_total = 0

    def prepare(self) -> None:
        """Get ready for a cut that is about to come (the scalpel is picked up or pressed): the cut's compiled
        kernels loaded (:mod:`.warm`); subclasses add their own."""
        load_cut_kernels()

    def apply(self, sweep: Sweep, *, snap: float, seeds: ArrayLike = ()) -> tuple[CutReport, int]:
        """Cut along ``sweep`` near the vertices ``seeds`` and carry the solver over: a report of what changed, and
        the vertex where the cut stopped (−1 if nothing was cut).

        A move is all or nothing: a refusal (a piece cut loose) or any error while it is written takes every change
        back; an error that is not a SolverError is raised as one."""
        start = time.perf_counter()
        s = self.solver
        self.surface.sync(s.state.positions, s.state.velocities)
        try:
            plan = self.surface.plan(sweep, snap=snap, closed=self.closed, seeds=seeds,
                                     movable=self.movable)     # writes nothing
        except TissuesimError:
            raise
        except Exception as error:
            raise SolverError(f"the cut could not be planned ({type(error).__name__}: {error}); nothing was "
                              "changed: move on, or report this as a bug with the move that caused it") from error
        if plan is None:
            return CutReport(seconds=time.perf_counter() - start), -1
        n = plan.old_count
        # the vertices on the cut: those duplicated, and those moved onto it
        originals = np.union1d(plan.new_copy_of[plan.new_copy_of >= 0], plan.moves.vertices)
        released = originals[members(originals, s.hybrid.control)]
        new_fixed = n + np.flatnonzero(np.sum(plan.weights * members(plan.parents, s.fixed), axis=1)
                                       >= 1.0 - 1e-12)
        undo = CutUndo(self, plan)
        try:
            result, loose_total = self._write(plan, sweep, released, new_fixed)
            undo.commit()
        except BaseException as error:           # an interrupt too: never leave a move half written
            undo.restore()
            if isinstance(error, SolverError) or not isinstance(error, Exception):     # a refusal, an interrupt
                raise
            raise SolverError(f"the cut failed while it was applied ({type(error).__name__}: {error}); it was "
                              "taken back and the solver is as before the move: move on, or report this as a bug "
                              "with the move that caused it") from error
        loose, self.loose_total = loose_total - self.loose_total, loose_total
        return CutReport(triangles_split=result.split_count, vertices_added=len(result.rest) - n,
                         control_released=int(released.size), loose_vertices=loose,
                         seconds=time.perf_counter() - start), result.end_vertex

    def _write(self, plan, sweep, released, new_fixed) -> tuple[CutResult, int]:
        """Apply ``plan``: the surface, the loose-piece test on it (a refusal raises, and the caller takes the
        surface back), the hybrid mesh, the state and the method's arrays; the result and the vertices now in
        pieces no prescribed node holds (:attr:`loose_total` after the move)."""
        s, n = self.solver, plan.old_count
        if not s.hybrid.info.get("cuts"):
            s.before_first_cut()
        new_identity = self._new_identity(plan)
        result = self.surface.apply(plan, sweep)
        self._moved = len(result.moved) > 0
        touched = self.touched(result)
        loose = self._loose(result, touched, new_fixed, released)
        self._update_lumped(result)
        s.hybrid = cut_hybrid(s.hybrid, result, released, self.spare)
        self._carry_state(result, new_fixed)
        self.update(result, n, released, touched)
        self._reload(result)
        self.closed = result.closed
        self.identity = self.spare.extend("identity", self.identity, new_identity)
        return result, loose

    # ------------------------------------------------------------------------------------ shared steps
    def _new_identity(self, plan) -> np.ndarray:
        """``(v,) int64`` the original vertex of each new vertex: itself for an inserted point, its original's
        for a copy."""
        n = plan.old_count
        identity = np.arange(n, n + len(plan.parents))
        copies = np.flatnonzero(plan.new_copy_of >= 0)
        of = plan.new_copy_of[copies]
        identity[copies] = np.where(of < n, self.identity[np.minimum(of, n - 1)], of)
        return identity

    def _carry_state(self, result: CutResult, new_fixed: np.ndarray) -> None:
        s, spare = self.solver, self.spare
        added = len(result.parents)
        s.rest_positions = s.hybrid.surface.vertices
        s.state.positions, s.state.velocities = result.positions, result.velocities
        s.forces = spare.extend("forces", s.forces, np.zeros((added, 3)))
        s.previous_positions = spare.extend("previous", s.previous_positions, result.positions[result.old_count:])
        if new_fixed.size:
            s.fixed = spare.extend("fixed", s.fixed, new_fixed.astype(s.fixed.dtype))
            # a copy of a fixed vertex is held where its original is (moved, with a moving base)
            s.fixed_positions = spare.extend("fixed_positions", s.fixed_positions, result.positions[new_fixed])

    def touched_edges(self, result: CutResult) -> tuple[np.ndarray, np.ndarray]:
        """``(keys (k, 2), owners (k, 2))``: the edges (lo < hi) of the triangles the cut changed, before and after
        it, and the rows holding each now (−1 for none; see :func:`~tissuesim.cutting.edges.edge_owners`)."""
        keys = touched_edges(result.replaced, result.triangles[result.changed])
        return keys, edge_owners(self.surface.fans, self.surface.triangles, keys)

    @staticmethod
    def touched(result: CutResult) -> np.ndarray:
        """``(k,) int64`` vertices whose triangles changed (their lumped areas did), the new ones included."""
        return np.unique(np.concatenate([result.replaced.ravel(), result.triangles[result.changed].ravel()]))

    def local_masses(self, touched: np.ndarray, mass_total: float) -> None:
        """The method's lumped masses (``mass_total`` [kg] by lumped area), rewritten at ``touched`` vertices. A
        vertex moved onto the cut on a curved surface changes the area a little: the touched vertices keep the mass
        they had, so the cut conserves the body's mass."""
        s = self.solver
        had = float(s.mass[touched[touched < len(s.mass)]].sum())
        s.mass = self.spare.extend("mass", s.mass, np.zeros(len(s.rest_positions) - len(s.mass)))
        s.mass[touched] = mass_total * self.lumped[touched] / self.lumped_total
        if self._moved or self._rescaled:
            s.mass[touched] *= had / s.mass[touched].sum()
            self._rescaled = True

    def _reload(self, result: CutResult) -> None:
        """Contact patches are cached per node and the cut changed the surface: drop them and carry every load over,
        through its own handle, its patch taking the cut's new vertices within its radius and its shares the new
        lumped areas. It is carried over locally: old vertices keep their rest positions, so a patch gains only new
        vertices (the whole-surface search of :meth:`contact_patch` would find the same nodes, in the same order, in
        O(n))."""
        s = self.solver
        s.patch_cache.clear()
        s.lumped_area_cache = self.lumped
        new = np.arange(result.old_count, len(result.rest))
        for load in s.loads:
            if load.radius is not None:
                near = new[np.linalg.norm(result.rest[new] - result.rest[load.node], axis=1) <= load.radius]
                if not np.isin(near, s.fixed).any():    # else the full search refuses the patch, saying why
                    nodes = np.concatenate([load.nodes, near])
                    s.remember_patch((load.node, load.radius), (nodes, self.lumped[nodes] / self.lumped[nodes].sum()))
            s.move_load(load, node=load.node)

    def _update_lumped(self, result) -> None:
        """Lumped area (a third of each triangle per corner) edited for the changed triangles only."""
        lumped = self.spare.extend("lumped", self.lumped, np.zeros(len(result.parents)))
        with result.rest_before_moves():
            old_area = triangle_areas(result.rest, result.replaced)
        np.add.at(lumped, result.replaced.ravel(), -np.repeat(old_area / 3.0, 3))
        new_content = result.triangles[result.changed]
        np.add.at(lumped, new_content.ravel(), np.repeat(triangle_areas(result.rest, new_content) / 3.0, 3))
        self.lumped = lumped

    def _loose(self, result: CutResult, touched: np.ndarray, new_fixed: np.ndarray, released: np.ndarray) -> int:
        """Vertices of the cut surface in pieces without a prescribed node (0 if none); refuses a piece this cut
        separates unless :attr:`keeps_loose`. Runs on every move, whatever the cut graph: a cut that begins or ends
        inside an edge an earlier move had cut closes a loop that no cut edge of its own closes.

        Every vertex of the cut surface is joined to a vertex of the changed triangles (``touched``) as before, so
        a piece came loose only if the touched vertices are no longer all joined, or if the move ``released`` the
        control nodes that held their piece. A search of a few rings from one of them (compiled, ~20 µs) usually
        reaches them all around the cut's tip (and, after a release, a held node); only when it does not are the
        pieces holding them counted over the whole surface (one compiled union-find, O(n + m))."""
        held = self._held(len(result.rest), new_fixed, released)
        if self.keeps_loose and self.loose_total:
            # a loose piece may grow or split under this cut: count every loose vertex, each once
            return unanchored_pieces(self.surface.triangles, len(result.rest), np.flatnonzero(held))[0]
        if self.surface.fans.joined(self.surface.triangles, len(result.rest), touched,
                                    budget=LOCAL_SEARCH + 16 * len(touched), held=held if released.size else None):
            return 0
        loose, pieces, first = unanchored_pieces(self.surface.triangles, len(result.rest), np.flatnonzero(held),
                                                 near=touched)
        if loose and not self.keeps_loose:
            which = "a piece" if pieces == 1 else f"{pieces} pieces"
            raise SolverError(
                f"this cut would separate {which} of {loose} surface vertices (first: {first}) from every "
                f"prescribed node, and the {self.solver.name} method would let it drift; the cut was not applied "
                "(cut elsewhere, or use the embedded method, which keeps such pieces)")
        return loose

    def _held(self, count: int, new_fixed: np.ndarray, released: np.ndarray) -> np.ndarray:
        """``(count,) bool`` whether each vertex holds its piece after this move (:meth:`held_nodes`), kept per
        move: the ``new_fixed`` vertices join, the ``released`` control nodes leave (O(k), no set operations over
        the mesh)."""
        mask = getattr(self, "held_mask", None)
        if mask is None:
            s = self.solver
            mask = np.zeros(len(s.rest_positions), dtype=bool)
            mask[self.held_nodes()] = True
        mask = self.spare.extend("held", mask, np.zeros(count - len(mask), dtype=bool))
        mask[new_fixed] = True
        mask[released] = False
        self.held_mask = mask
        return mask

    def movable(self, vertices: np.ndarray) -> np.ndarray:
        """``(k,) bool`` whether each of ``vertices`` may be moved onto a cut (:mod:`tissuesim.cutting.moves`): not
        a fixed or attached one (a ligament stays on the point it was built on), not under a load. A control node
        may: on the cut, it is released (§7)."""
        s = self.solver
        if getattr(self, "_fixed_of", None) is not s.fixed:     # sorted once per change of the fixed list
            self._fixed_of, self._fixed_sorted = s.fixed, SolverCut.held_nodes(self)    # fixed and attached, sorted
        loaded = [np.atleast_1d(np.asarray(n, dtype=np.int64)) for load in s.loads
                  for n in (load.node, load.nodes) if n is not None]
        return ~members(vertices, self._fixed_sorted) & ~np.isin(vertices, np.concatenate(loaded) if loaded else [])

    def held_nodes(self) -> np.ndarray:
        """``(a,) int64`` the vertices that hold a piece in place now: the solver's fixed ones and its attached ones
        (an elastic attachment holds its piece too)."""
        s = self.solver
        return np.unique(np.concatenate([np.asarray(s.fixed, dtype=np.int64), s.attached_nodes]))

    def update(self, result: CutResult, n: int, released: np.ndarray, touched: np.ndarray) -> None:
        """Method-specific arrays (subclasses); ``touched`` are the vertices whose triangles changed."""
        raise NotImplementedError


def members(values: np.ndarray, sorted_set: np.ndarray) -> np.ndarray:
    """``values.shape bool``: whether each value is in ``sorted_set`` (ascending), by binary search."""
    if len(sorted_set) == 0:
        return np.zeros(np.shape(values), dtype=bool)
    where = np.minimum(np.searchsorted(sorted_set, values), len(sorted_set) - 1)
    return sorted_set[where] == values


def cut_updater(solver: Solver) -> SolverCut:
    """The updater that carries ``solver`` over cuts (created on first use and kept on the solver): its class's
    :attr:`~tissuesim.solvers.base.Solver.cut_carrier`."""
    updater = solver.active_cut_updater
    if updater is None:
        reason = refusal(solver)
        if reason is not None:
            raise SolverError(reason)
        updater = carrier_class(type(solver))(solver)
        solver.active_cut_updater = updater
    return updater


def refusal(solver_or_class: Solver | type | str) -> str | None:
    """Why a solver (or its class, or its method's name) cannot be cut, or None if it can."""
    from .registry import solver_class

    cls = solver_class(solver_or_class) if isinstance(solver_or_class, str) else (
        solver_or_class if isinstance(solver_or_class, type) else type(solver_or_class))
    if cls.cut_carrier is None:
        return cls.cut_refusal or (f"the {cls.name} method does not support cutting; cut a hybrid, pbd, mass-spring "
                                   "or embedded solver")
    return None


def anchored_nodes(solver: Solver) -> np.ndarray | None:
    """``(a,) int64`` the vertices that hold ``solver``'s surface in place (fixed, and the hybrid's control nodes):
    every piece of a cut surface must hold one (pass them to ``check_cut_invariants(anchored=...)``); None for a
    method that holds every vertex by its embedding (embedded), or that cannot be cut."""
    if refusal(solver) is not None:
        return None
    updater = cut_updater(solver)
    if updater.keeps_loose:
        return None
    return updater.held_nodes()


def carrier_class(cls) -> type:
    """The :class:`SolverCut` subclass of solver class ``cls``: its ``cut_carrier``, a class or ``"module:Class"``
    (the built-in methods name theirs, which import the solver modules they carry)."""
    carrier = cls.cut_carrier
    if isinstance(carrier, str):
        from importlib import import_module

        module, name = carrier.split(":")
        carrier = getattr(import_module(module), name)
    return carrier
