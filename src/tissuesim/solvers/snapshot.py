"""A solver's state put back exactly after work that must leave no trace: the haptic loop's static solves of a
grabbed region, a probe's press that is refused. Everything a step reads is kept, so the next step after
:meth:`Snapshot.restore` equals a twin's that never did the work."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .base import Solver


class Snapshot:
    """A solver's state (positions, velocities, loads, the finite-strain volume with what its iterations have learnt,
    and what its class names in :attr:`~.base.Solver.kept_arrays` and :attr:`~.base.Solver.kept_values`: the
    hybrid's warm start, what it reports), taken when made and put back by :meth:`restore`."""

    def __init__(self, solver: Solver):
        self.positions = solver.positions.copy()
        self.velocities = solver.velocities.copy()
        self.loads = solver.kept_loads()
        volume = getattr(solver, "volume_displacement", None)
        self.volume = None if volume is None else volume.copy()
        finite = getattr(solver, "finite", None)      # the finite-strain volume's quasi-Newton memory
        self.relax = None if finite is None else finite.relax_memory()
        self.arrays = {name: (getattr(solver, name), getattr(solver, name).copy()) for name in solver.kept_arrays}
        self.flags = {name: getattr(solver, name) for name in solver.kept_values}

    def restore(self, solver: Solver) -> None:
        solver.put_back_loads(self.loads)
        if self.volume is not None:
            solver.volume_displacement = self.volume
        if self.relax is not None:
            solver.finite.set_relax_memory(self.relax)
        for name, (array, values) in self.arrays.items():
            setattr(solver, name, array)    # the very array (others are views of it), which a window may have replaced
            array[...] = values
        for name, value in self.flags.items():
            setattr(solver, name, value)
        solver.positions[:] = self.positions
        solver.velocities[:] = self.velocities


@contextmanager
def refusal_restores(tool: object, *, solving: bool) -> Iterator[None]:
    """Put everything back as it was when the body raises: the ``tool``'s own attributes (a probe's, a grasper's,
    with its :class:`~.load_set.VertexLoads` record) and its solver's loads, and with ``solving`` (the body steps or
    solves) the solver's whole state (:class:`Snapshot`), so a refused call leaves no load acting and no vertex
    moved."""
    put_back = _keeper(tool, solving=solving)
    try:
        yield
    except BaseException:
        put_back()
        raise


@contextmanager
def leaves_no_trace(tool: object) -> Iterator[None]:
    """Put everything :func:`refusal_restores` keeps back after the body, whatever it does: work done to measure
    (a grasper's measuring moves), not to keep."""
    put_back = _keeper(tool, solving=True)
    try:
        yield
    finally:
        put_back()


def _keeper(tool, *, solving: bool):
    """Take what :func:`refusal_restores` keeps of ``tool`` and its solver now; returns the call that puts it
    back."""
    solver = tool.solver
    kept = {name: copy.copy(value) if isinstance(value, dict) else value for name, value in vars(tool).items()}
    kept_loads = {name: dict(value.by_node) for name, value in vars(tool).items() if hasattr(value, "by_node")}
    state = solver.snapshot() if solving else None
    loads = None if solving else solver.kept_loads()

    def put_back() -> None:
        if solving:
            state.restore(solver)
        else:
            solver.put_back_loads(loads)
        vars(tool).update(kept)
        for name, by_node in kept_loads.items():
            getattr(tool, name).by_node = by_node

    return put_back
