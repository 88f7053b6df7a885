"""The loads a solver holds: any number of forces on the surface, each spread over its own contact patch
(:mod:`.contact`), each a :class:`Load` handle that is moved, changed or removed alone. Their sum is the solver's
``forces``, so tools that act together (two pin-heads, a probe beside a grasper) add up where the model is linear.

A mixin of :class:`~tissuesim.solvers.base.Solver`, which holds ``forces`` ``(n, 3)`` [N] and the list ``_loads``,
and is told of every change through ``_on_load_changed``. ``set_load`` / ``clear_load`` keep their meaning: one load
replacing all the others, none.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SolverError
from .checks import check_force

if TYPE_CHECKING:
    from .base import Solver

#: :meth:`LoadSet.move_load`'s default: keep the load's radius.
KEEP = object()


@dataclass(eq=False)
class Load:
    """One force on the surface: a handle from :meth:`LoadSet.add_load` (change it through the solver).

    Attributes:
        node: the M_S vertex the force is centred on.
        force: ``(3,) float64`` the total force [N].
        radius: the contact patch's radius R [m], or None (the node alone).
        nodes: ``(k,) int64`` the patch's vertices, ``node`` first (read-only).
        shares: ``(k,) float64`` their shares of the force, summing to 1 (read-only).
    """

    node: int
    force: np.ndarray
    radius: float | None
    nodes: np.ndarray
    shares: np.ndarray


class LoadSet:
    """The loads of a solver (see the module docstring)."""

    @property
    def loads(self) -> tuple[Load, ...]:
        """The loads acting now, in the order they were added."""
        return tuple(self._loads)

    @property
    def load(self) -> tuple[int, np.ndarray] | None:
        """``(node, total force (3,) N)`` of the one load acting, or None; a SolverError when several act (read
        :attr:`loads`)."""
        load = self._single_load()
        return None if load is None else (load.node, load.force.copy())

    @property
    def load_radius(self) -> float | None:
        """The contact radius [m] of the one load acting (None: none, or a single-node load)."""
        load = self._single_load()
        return None if load is None else load.radius

    @property
    def load_nodes(self) -> np.ndarray:
        """``(k,) int64`` the vertices carrying the loads, each load's patch in turn (a vertex under two patches
        twice)."""
        return np.concatenate([load.nodes for load in self._loads]) if self._loads else np.zeros(0, dtype=np.int64)

    @property
    def load_shares(self) -> np.ndarray:
        """``(k,) float64`` each of :attr:`load_nodes`' share of its own load's force."""
        return np.concatenate([load.shares for load in self._loads]) if self._loads else np.zeros(0)

    def add_load(self, node: int, force: ArrayLike, *, radius: float | None = None) -> Load:
        """Add ``force`` ``(3,)`` [N] at M_S vertex ``node`` beside the loads already acting; returns its handle.

        ``radius`` None loads that node alone; a radius R [m] spreads the force area-weighted over the M_S nodes
        within R of it at rest (:func:`tissuesim.loads.contact_patch`). A load on a fixed node is refused
        (BoundaryConditionError: all of it would vanish into the support), and so is a patch that reaches the fixed
        region (SolverError: part of it would); a refused load changes nothing."""
        load = self._checked_load(node, force, radius)
        self._admit(load)
        self._loads.append(load)
        self._refresh_forces(load.nodes)
        self._on_load_changed()
        return load

    def move_load(self, load: Load, *, node: int | None = None, force: ArrayLike | None = None,
                  radius: float | None | object = KEEP) -> None:
        """Change a load of this solver: its ``node``, ``force`` ``(3,)`` [N] or ``radius`` [m] (None: one node);
        what is not given stays. Refused as :meth:`add_load` refuses, changing nothing."""
        self._check_held(load)
        moved = self._checked_load(load.node if node is None else node, load.force if force is None else force,
                                   load.radius if radius is KEEP else radius)
        rows = np.union1d(load.nodes, moved.nodes)
        load.node, load.force, load.radius, load.nodes, load.shares = (
            moved.node, moved.force, moved.radius, moved.nodes, moved.shares)
        self._refresh_forces(rows)
        self._on_load_changed()

    def remove_load(self, load: Load) -> None:
        """Withdraw one load of this solver; the others act on."""
        self._check_held(load)
        self._loads.remove(load)
        self._refresh_forces(load.nodes)
        self._on_load_changed()

    def set_load(self, node: int, force: ArrayLike, *, radius: float | None = None) -> Load:
        """Apply ``force`` ``(3,)`` [N] at M_S vertex ``node`` (:meth:`add_load`), replacing every load acting;
        returns its handle. A refused load changes nothing."""
        load = self._checked_load(node, force, radius)
        rows = np.union1d(self.load_nodes, load.nodes)
        self._loads = [load]
        self._refresh_forces(rows)
        self._on_load_changed()
        return load

    def clear_load(self) -> None:
        """Withdraw every load."""
        if self._loads:
            self._withdraw_load()
            self._on_load_changed()

    def kept_loads(self) -> list[tuple]:
        """A record of the loads acting: ``(handle, node, force, radius, nodes, shares)`` each, for
        :meth:`put_back_loads`."""
        return [(load, load.node, load.force, load.radius, load.nodes, load.shares) for load in self._loads]

    def put_back_loads(self, kept: list) -> None:
        """The loads of a :meth:`kept_loads` record acting again, as they were, through the same handles."""
        rows = np.union1d(self.load_nodes, np.concatenate([k[4] for k in kept]) if kept else np.zeros(0, int))
        for load, *values in kept:
            load.node, load.force, load.radius, load.nodes, load.shares = values
        self._loads = [k[0] for k in kept]
        self._refresh_forces(rows.astype(np.int64))
        self._on_load_changed()

    def _withdraw_load(self) -> None:
        rows = self.load_nodes
        self._loads = []
        self.forces[rows] = 0.0

    def _checked_load(self, node, force, radius) -> Load:
        node = self._check_node(node)
        force = check_force(force).copy()       # the load's own: the caller may reuse its array
        nodes, shares = self.contact_patch(node, radius)
        return Load(node, force, None if radius is None else float(radius), nodes, shares)

    def _admit(self, load: Load) -> None:
        """Refuse (SolverError) a load that cannot act beside the ones acting; by default every one can."""

    def _check_held(self, load) -> None:
        if not any(load is held for held in self._loads):
            raise SolverError("that load does not act on this solver (removed, or another solver's); use a handle "
                              "from this solver's add_load or set_load, or solver.loads")

    def _single_load(self) -> Load | None:
        if len(self._loads) > 1:
            raise SolverError(f"{len(self._loads)} loads act on this solver; read them from solver.loads")
        return self._loads[0] if self._loads else None

    def _refresh_forces(self, rows: np.ndarray) -> None:
        """``forces`` at the vertices ``rows`` ``(k,)`` from every load acting (elsewhere they did not change).

        One pass over all the loads' nodes at once: a probe holds a load per vertex it pushes and changes them one by
        one, and a pass per load made each change cost O(loads) NumPy calls (83 % of a contact update)."""
        self.forces[rows] = 0.0
        if not self._loads:
            return
        nodes = np.concatenate([load.nodes for load in self._loads])
        nodal = np.concatenate([load.shares[:, None] * load.force[None, :] for load in self._loads])
        at = np.isin(nodes, rows)
        np.add.at(self.forces, nodes[at], nodal[at])


class ToolLoad:
    """A tool's own load on a solver (a pin-head's, a haptic device's): applied and moved as the tool acts and
    withdrawn when it lets go, beside any other load. A reset, or a :meth:`~LoadSet.set_load` elsewhere, withdraws
    it; the next :meth:`apply` adds it again."""

    def __init__(self, solver: Solver):
        self.solver = solver
        self._load: Load | None = None

    @property
    def acting(self) -> bool:
        return self._load is not None and any(self._load is load for load in self.solver.loads)

    def apply(self, node: int, force: ArrayLike, *, radius: float | None) -> None:
        """The tool's load at ``node``: ``force`` ``(3,)`` [N] over a patch of ``radius`` [m] (None: one node)."""
        if self.acting:
            self.solver.move_load(self._load, node=node, force=force, radius=radius)
        else:
            self._load = self.solver.add_load(node, force, radius=radius)

    def withdraw(self) -> None:
        if self.acting:
            self.solver.remove_load(self._load)
        self._load = None

    @property
    def force(self) -> np.ndarray:
        """``(3,) float64`` [N] the load's force while it acts, else zero."""
        return np.array(self._load.force, dtype=np.float64) if self.acting else np.zeros(3)


class VertexLoads:
    """A tool's own loads on a solver, one per surface vertex (a probe's contacts, a grasper's held patch): set all
    at once from arrays, each a :class:`Load` of its own beside any other tool's. A reset, or a
    :meth:`~LoadSet.set_load` elsewhere, withdraws them; they are then forgotten, never re-applied unasked.

    Attributes:
        by_node: ``{vertex: Load}`` the loads acting (read it after :meth:`forget_withdrawn`).
    """

    def __init__(self, solver: Solver):
        self.solver = solver
        self.by_node: dict[int, Load] = {}

    def forget_withdrawn(self) -> None:
        """Drop the handles of loads that no longer act (a reset or ``set_load`` elsewhere withdrew them)."""
        acting = {id(load) for load in self.solver.loads}
        self.by_node = {node: load for node, load in self.by_node.items() if id(load) in acting}

    def set(self, nodes: np.ndarray, forces: np.ndarray) -> None:
        """``forces`` ``(k, 3)`` [N] on ``nodes`` ``(k,)``, and no load of this tool elsewhere."""
        solver = self.solver
        self.forget_withdrawn()
        keep = set(int(i) for i in nodes)
        for node in [i for i in self.by_node if i not in keep]:
            solver.remove_load(self.by_node.pop(node))
        for node, force in zip(nodes, forces):
            node = int(node)
            if node in self.by_node:
                solver.move_load(self.by_node[node], force=force)
            else:
                self.by_node[node] = solver.add_load(node, force)

    def at(self, nodes: np.ndarray) -> np.ndarray:
        """``(k, 3) float64`` this tool's force [N] on each of ``nodes`` ``(k,)`` now (zero where it has none)."""
        self.forget_withdrawn()
        return np.array([self.by_node[int(i)].force if int(i) in self.by_node else np.zeros(3)
                         for i in nodes]).reshape(-1, 3)

    def total(self) -> np.ndarray:
        """``(3,) float64`` the sum of this tool's forces on the tissue [N]."""
        self.forget_withdrawn()
        return sum((load.force for load in self.by_node.values()), np.zeros(3))
