"""Exceptions raised for bad input.

Every message names the defect, where it is (counts, first indices) and what to do about it, so the CLI can print
it as one line and exit non-zero.
"""


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


def first_indices(indices, limit: int = 5) -> str:
    """Format the first few indices of a defect for an error message, e.g. ``"3, 17, 42 (and 9 more)"``."""
    indices = [int(i) for i in indices]
    shown = ", ".join(str(i) for i in indices[:limit])
    more = len(indices) - limit
    return shown + (f" (and {more} more)" if more > 0 else "")
