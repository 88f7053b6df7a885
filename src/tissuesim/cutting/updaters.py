"""Which cut updater carries which solver method over a cut (:mod:`.solver_update`): the built-in methods' table,
and ``register_cut`` for a method of one's own. The updaters know nothing of this module, so it can import them."""

from __future__ import annotations

import numpy as np

from ..errors import SolverError

#: Methods registered with :func:`register_cut` (those of the user), beside the built-in ones.
_REGISTERED: dict[str, type] = {}


class RefuseFineFEM:
    """The fine-FEM reference cannot be cut: its volume would need re-tetrahedralizing."""

    reason = ("the fem reference cannot be cut: cutting its fine volume would need re-tetrahedralizing and "
              "re-factorizing K for every move (what the hybrid avoids); cut a hybrid, pbd, mass-spring or embedded "
              "solver")

    def __init__(self, solver):
        raise SolverError(self.reason)


def register_cut(name: str):
    """Class decorator: the cut updater (a :class:`~.solver_update.SolverCut`) of solver method ``name``."""

    def decorate(cls):
        _REGISTERED[name] = cls
        return cls

    return decorate


def _updaters() -> dict[str, type]:
    """Method name → updater class: the built-in methods', then the registered ones."""
    from .layer_update import EmbeddedCut, HybridCut, SurfaceLayerCut
    from .spring_update import MassSpringCut

    return {"pbd": SurfaceLayerCut, "hybrid": HybridCut, "embedded": EmbeddedCut, "mass-spring": MassSpringCut,
            "fem": RefuseFineFEM, **_REGISTERED}


def cut_updater(solver):
    """The updater bound to ``solver`` (created on first use and kept on the solver)."""
    updater = getattr(solver, "_cut_updater", None)
    if updater is None:
        name = getattr(solver, "name", type(solver).__name__)
        updaters = _updaters()
        if name not in updaters:
            raise SolverError(f"the {name} method does not support cutting; cut a hybrid, pbd, mass-spring or "
                              "embedded solver")
        updater = updaters[name](solver)
        solver._cut_updater = updater
    return updater


def refusal(name: str) -> str | None:
    """Why solver method ``name`` cannot be cut, or None if it can."""
    updaters = _updaters()
    if name not in updaters:
        return f"the {name} method does not support cutting"
    return getattr(updaters[name], "reason", None)


def anchored_nodes(solver) -> np.ndarray | None:
    """``(a,) int64`` the vertices that hold ``solver``'s surface in place (fixed, and the hybrid's control nodes):
    every piece of a cut surface must hold one (pass them to ``check_cut_invariants(anchored=...)``); None for a
    method that holds every vertex by its embedding (embedded), or that cannot be cut."""
    if refusal(getattr(solver, "name", "")) is not None:
        return None
    updater = cut_updater(solver)
    if updater.keeps_loose:
        return None
    return updater.held_nodes()
