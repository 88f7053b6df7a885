"""The protocol every instrument keeps, and the registry of instruments by kind.

A tool acts on one solver's surface. It is *pressed* at a point (the pin-head takes hold, the probe starts to push,
the grasper's jaws close, the scalpel cuts in), *moved* while pressed, and *released*. Its force is the one it puts
on the tissue [N], with one sign convention for every tool: a pin-head pulling up, a grasper lifting and a probe
pushed up into the tissue from below all give a force along +z. (Each tool's own ``force`` keeps its documented
meaning: the probe's and the grasper's are the reaction on the tool, the opposite.)

The scene script, the viewer and the haptics make tools by kind through :func:`tool_class`; a tool registered with
:func:`register_tool` from outside the package joins them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from importlib import import_module
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..errors import SolverError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

# kind -> (module, class): imported on first use, as the solvers' registry does.
_BUILTIN = {
    "pin-head": ("tissuesim.tools.pinhead", "PinHead"),
    "probe": ("tissuesim.tools.probe", "Probe"),
    "grasper": ("tissuesim.tools.grasper", "Grasper"),
    "scalpel": ("tissuesim.tools.scalpel", "Scalpel"),
}
_REGISTRY: dict[str, type] = {}


class Tool(ABC):
    """An instrument on a solver's surface (see the module docstring).

    Attributes:
        solver: the :class:`~tissuesim.solvers.base.Solver` it acts on.
        kind: its name in scenes and in :func:`tool_class` (``"pin-head"``, ``"probe"``, ``"grasper"``,
            ``"scalpel"``).
        needs: what it needs of a solver, in words (the methods that take it are those that provide it).
    """

    kind: ClassVar[str] = "?"
    needs: ClassVar[str] = "loads on surface vertices"

    @abstractmethod
    def press(self, point: ArrayLike) -> object:
        """Engage the tissue at ``point`` ``(3,)`` [m]."""

    @abstractmethod
    def move(self, point: ArrayLike) -> object:
        """Carry the engaged tool to ``point`` ``(3,)`` [m] (a frame's worth of the tissue's answer)."""

    @abstractmethod
    def release(self) -> object:
        """Let go of the tissue."""

    @property
    @abstractmethod
    def engaged(self) -> bool:
        """Whether the tool acts on the tissue now."""

    @property
    def force_on_tissue(self) -> np.ndarray | None:
        """``(3,) float64`` [N] the force the tool puts on the tissue now, or None where it puts none (released,
        or a tool that only cuts)."""
        return None


def register_tool(kind: str) -> Callable[[type], type]:
    """Class decorator adding a :class:`Tool` subclass to the registry under ``kind``."""
    if not isinstance(kind, str) or not kind:
        raise SolverError(f"a tool is registered under a non-empty string kind, got {kind!r}")

    def decorate(cls: type) -> type:
        if not (isinstance(cls, type) and issubclass(cls, Tool)):
            raise SolverError(f"only Tool subclasses can be registered, got {cls!r}")
        cls.kind = kind
        _REGISTRY[kind] = cls
        return cls

    return decorate


def unregister_tool(kind: str) -> None:
    """Remove a tool registered with :func:`register_tool`; the built-in tools stay."""
    if kind in _BUILTIN:
        raise SolverError(f"{kind!r} is a built-in tool and cannot be unregistered")
    if kind not in _REGISTRY:
        raise SolverError(f"no tool {kind!r} is registered; registered: {', '.join(tool_kinds())}")
    del _REGISTRY[kind]


def tool_kinds() -> tuple[str, ...]:
    """The kinds :func:`tool_class` knows: the built-in tools, then those registered since."""
    return tuple(dict.fromkeys([*_BUILTIN, *_REGISTRY]))


def tool_class(kind: str) -> type[Tool]:
    """The :class:`Tool` subclass of ``kind``."""
    if kind not in _REGISTRY:
        if kind not in _BUILTIN:
            raise SolverError(f"unknown tool {kind!r}; choose one of {', '.join(tool_kinds())}")
        module, name = _BUILTIN[kind]
        _REGISTRY[kind] = getattr(import_module(module), name)
    return _REGISTRY[kind]
