"""The protocol every instrument keeps, and the registry of instruments by kind.

A tool acts on one solver's surface. It is *pressed* at a point (the pin-head takes hold, the probe starts to push,
the grasper's jaws close, the scalpel cuts in), *moved* while pressed, and *released*. Its force is the one it puts
on the tissue [N], with one sign convention for every tool: a pin-head pulling up, a grasper lifting and a probe
pushed up into the tissue from below all give a force along +z. (Each tool's own ``force`` keeps its documented
meaning: the probe's and the grasper's are the reaction on the tool, the opposite.)

:func:`tool_class` makes a tool by kind, and a tool registered with :func:`register_tool` from outside the package
joins the kinds. The scene script reads every tool's force through the protocol; its schema, the simulator's
pointer tools and the haptic loop still name the built-in kinds.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..registry import Registry

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

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


# kind -> (module, class): imported on first use, as the methods' are.
_TOOLS = Registry("tool", Tool, {
    "pin-head": ("tissuesim.tools.pinhead", "PinHead"),
    "probe": ("tissuesim.tools.probe", "Probe"),
    "grasper": ("tissuesim.tools.grasper", "Grasper"),
    "scalpel": ("tissuesim.tools.scalpel", "Scalpel"),
}, attribute="kind")


def register_tool(kind: str) -> Callable[[type], type]:
    """Class decorator adding a :class:`Tool` subclass to the registry under ``kind``."""
    return _TOOLS.register(kind)


def unregister_tool(kind: str) -> None:
    """Remove a tool registered with :func:`register_tool`; the built-in tools stay."""
    _TOOLS.unregister(kind)


def tool_kinds() -> tuple[str, ...]:
    """The kinds :func:`tool_class` knows: the built-in tools, then those registered since."""
    return _TOOLS.names()


def tool_class(kind: str) -> type[Tool]:
    """The :class:`Tool` subclass of ``kind``."""
    return _TOOLS.get(kind)
