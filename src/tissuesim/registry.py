"""A name → class registry: the built-in entries imported on first use (so one's missing dependency does not break
the others), others added by a class decorator and taken out again. The deformation methods
(:mod:`tissuesim.solvers.registry`) and the instruments (:mod:`tissuesim.tools.base`) each keep one."""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module

from .errors import SolverError


class Registry:
    """Names → subclasses of ``base``, each told its name in its ``attribute``.

    Args:
        what: what an entry is, in messages ("solver", "tool").
        base: the class every entry subclasses.
        builtin: name -> (module, class name) of the built-in entries, imported on first use.
        attribute: the class attribute that holds an entry's name (``name`` for a method, ``kind`` for a tool).
    """

    def __init__(self, what: str, base: type, builtin: dict[str, tuple[str, str]], *, attribute: str):
        self.what, self.base, self.attribute = what, base, attribute
        self._builtin = dict(builtin)
        self._added: dict[str, type] = {}

    def names(self) -> tuple[str, ...]:
        """The built-in names, then those registered since, in that order."""
        return tuple(dict.fromkeys([*self._builtin, *self._added]))

    def register(self, name: str) -> Callable[[type], type]:
        """Class decorator adding a subclass of ``base`` under ``name``."""
        if not isinstance(name, str) or not name:
            raise SolverError(f"a {self.what} is registered under a non-empty string name, got {name!r}")

        def decorate(cls: type) -> type:
            if not (isinstance(cls, type) and issubclass(cls, self.base)):
                raise SolverError(f"only {self.base.__name__} subclasses can be registered, got {cls!r}")
            setattr(cls, self.attribute, name)
            self._added[name] = cls
            return cls

        return decorate

    def unregister(self, name: str) -> None:
        """Take out an entry :meth:`register` added (a plug-in's, a test's); the built-in ones stay."""
        if name in self._builtin:
            raise SolverError(f"{name!r} is a built-in {self.what} and cannot be unregistered")
        if name not in self._added:
            raise SolverError(f"no {self.what} {name!r} is registered; registered: {', '.join(self.names())}")
        del self._added[name]

    def get(self, name: str) -> type:
        """The class registered as ``name``."""
        if not isinstance(name, str):
            raise SolverError(f"a {self.what} name is a string, one of {', '.join(self.names())}; got {name!r}")
        if name not in self._added:
            if name not in self._builtin:
                raise SolverError(f"unknown {self.what} {name!r}; choose one of {', '.join(self.names())}")
            module, cls = self._builtin[name]
            self._added[name] = getattr(import_module(module), cls)
        return self._added[name]
