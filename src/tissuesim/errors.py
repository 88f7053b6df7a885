"""Exceptions raised for bad input.

Every message names the defect, where it is (counts, first indices) and what to do about it, so the CLI can print
it as one line and exit non-zero.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterable
from pathlib import Path

_PACKAGE = str(Path(__file__).resolve().parent)


class TissuesimError(Exception):
    """Base class of every error this package raises on purpose."""


class MeshError(TissuesimError, ValueError):
    """A mesh is malformed: bad shapes, out-of-range indices, or a geometric/topological defect."""


class MaterialError(TissuesimError, ValueError):
    """Material parameters are outside the range linear elasticity accepts."""


class BoundaryConditionError(TissuesimError, ValueError):
    """Fixed-node selection is empty, out of range, or leaves the body free to move rigidly."""


class SolverError(TissuesimError, ValueError):
    """A solver was asked something it cannot do (unknown name, bad time step, bad node or force)."""


class InversionError(SolverError):
    """A method's surface turned inside out under a load it cannot come back from (the mass-spring model)."""


class BundleError(TissuesimError, ValueError):
    """A saved hybrid-mesh bundle is unreadable or was written by an incompatible version."""


class TissuesimWarning(UserWarning):
    """A result this package computed is outside the range where its model is trustworthy (e.g. locking)."""


def warn(message: str) -> None:
    """Issue a :class:`TissuesimWarning` that points at the caller's line outside this package (however deep in
    the package it was raised), so a user sees which of their calls it concerns."""
    level, frame = 2, sys._getframe(1)     # stacklevel 1 is this function, 2 its caller
    while frame is not None and _inside(frame.f_code.co_filename):
        level, frame = level + 1, frame.f_back
    warnings.warn(message, TissuesimWarning, stacklevel=level)


def _inside(filename: str) -> bool:
    """Whether code of ``filename`` is this package's own (a dataclass's generated ``__init__`` counts as its)."""
    return filename == "<string>" or str(Path(filename).resolve()).startswith(_PACKAGE)


def first_indices(indices: Iterable[int], limit: int = 5) -> str:
    """Format the first few indices of a defect for an error message, e.g. ``"3, 17, 42 (and 9 more)"``."""
    indices = [int(i) for i in indices]
    shown = ", ".join(str(i) for i in indices[:limit])
    more = len(indices) - limit
    return shown + (f" (and {more} more)" if more > 0 else "")
