"""The name → class registry of deformation methods: built-ins imported on first use, users' own by ``@register``."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..errors import SolverError
from ..registry import Registry
from .base import Solver

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh

# name -> (module, class): imported on first use, so one method's missing dependency does not break the others.
_METHODS = Registry("solver", Solver, {
    "hybrid": ("tissuesim.solvers.hybrid", "HybridSolver"),
    "pbd": ("tissuesim.solvers.pbd", "PBDSolver"),
    "mass-spring": ("tissuesim.solvers.mass_spring", "MassSpringSolver"),
    "embedded": ("tissuesim.solvers.embedded", "EmbeddedSolver"),
    "fem": ("tissuesim.solvers.fine_fem", "FineFEMSolver"),
}, attribute="name")


def register(name: str) -> Callable[[type], type]:
    """Class decorator adding a :class:`Solver` subclass to the registry under ``name``."""
    return _METHODS.register(name)


def unregister(name: str) -> None:
    """Remove a method registered with :func:`register` (a plug-in's, a test's); the built-in methods stay."""
    _METHODS.unregister(name)


def available_solvers() -> tuple[str, ...]:
    """Names accepted by :func:`make_solver`: the built-in methods, then those registered since, in that order."""
    return _METHODS.names()


def method_names(*, in_paper: bool | None = None, cuts: bool | None = None, material: str | None = None,
                 where: Callable[[type], bool] | None = None) -> tuple[str, ...]:
    """The registered methods (in :func:`available_solvers`' order) whose card matches every filter given:
    ``in_paper`` (one of the paper's compared methods, :attr:`Solver.in_paper`), ``cuts`` (the scalpel can cut it:
    it has a :attr:`Solver.cut_carrier`), ``material`` (it accepts that ``material`` option) and ``where`` (a test
    of the class, e.g. ``lambda cls: cls.gravity_caveat is None``). Every list of methods in the package is one of
    these, so a method registered anywhere joins them all."""
    names = []
    for name in available_solvers():
        cls = solver_class(name)
        if in_paper is not None and cls.in_paper != in_paper:
            continue
        if cuts is not None and (cls.cut_carrier is not None) != cuts:
            continue
        if material is not None and material not in cls.materials:
            continue
        if where is not None and not where(cls):
            continue
        names.append(name)
    return tuple(names)


def solver_class(name: str) -> type:
    """The :class:`Solver` subclass registered as ``name``."""
    return _METHODS.get(name)


def solver_options(name: str) -> dict[str, object]:
    """Keyword options of solver ``name`` and their defaults (None: calibrated or derived)."""
    cls = solver_class(name)
    options = {}
    for klass in reversed(cls.__mro__):
        if klass is object or "__init__" not in vars(klass):
            continue
        for p in inspect.signature(klass.__init__).parameters.values():
            if p.kind is p.KEYWORD_ONLY:
                options[p.name] = p.default
    return options


def make_solver(name: str, hybrid_mesh: HybridMesh, **options: object) -> Solver:
    """A solver of method ``name`` (hybrid, pbd, mass-spring, embedded, fem) over ``hybrid_mesh``.

    ``options`` are the keyword options of that method (see each class); an unknown option is a SolverError
    that lists the accepted ones.
    """
    cls = solver_class(name)
    accepted = solver_options(name)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise SolverError(
            f"unknown option(s) {', '.join(map(repr, unknown))} for solver {name!r}; accepted: "
            f"{', '.join(sorted(accepted))}"
        )
    return cls(hybrid_mesh, **options)
