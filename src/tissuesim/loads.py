"""Contact loads: a pin-head's force spread over the surface nodes under its tip.

A force on one node is a point load, and in 3-D linear elasticity a point load has a singular displacement: a
reference FEM's value at the loaded node grows as 1/h under refinement and never converges (docs/experiments.md
measures it). A real pin-head or instrument tip has a contact patch of radius R, so tissuesim can spread the force
as a uniform traction over the M_S nodes within R of the snapped node.

The nodal shares are area-weighted: node i's share is its lumped area (a third of each adjacent triangle's area,
at rest) over the patch's total, i.e. the consistent nodal forces of a uniform traction on the patch for linear
triangles with a lumped load vector. Every method gets the same nodal forces; each maps them onto its own
unknowns (the hybrid splits each node's share over its coarse triangle, §6.1).
"""

from __future__ import annotations

import numpy as np

from .errors import SolverError


def triangle_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(m,) float64`` area [m²] of each of ``triangles`` ``(m, 3) int`` over ``vertices`` ``(n, 3)`` [m]."""
    p = vertices[np.asarray(triangles, dtype=np.int64)]
    u, v = (p[:, 1] - p[:, 0]).T, (p[:, 2] - p[:, 0]).T
    # the cross product written out: np.cross costs more than this arithmetic on the few rows of a cut
    x, y, z = u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]
    return 0.5 * np.sqrt(x * x + y * y + z * z)


def lumped_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(n,) float64`` a third of the area of every triangle around each vertex [m²].

    Args:
        vertices: ``(n, 3) float64`` positions [m].
        triangles: ``(m, 3) int`` vertex indices.
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    share = np.repeat(triangle_areas(vertices, triangles) / 3.0, 3)
    return np.bincount(triangles.ravel(), weights=share, minlength=len(vertices))


def contact_patch(rest_positions: np.ndarray, triangles: np.ndarray, node: int,
                  radius: float | None, *, areas: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The M_S nodes under a pin-head tip of ``radius`` centred on ``node``, and their shares of the force.

    Args:
        rest_positions: ``(n, 3) float64`` M_S rest positions [m].
        triangles: ``(m, 3) int`` M_S triangles.
        node: the snapped M_S vertex (the patch's centre).
        radius: tip radius R [m], positive and finite; None is a single-node load.
        areas: ``(n,) float64`` :func:`lumped_areas` [m²], if already known (saves one pass over the mesh).

    Returns:
        ``(nodes (k,) int64, weights (k,) float64)``: the vertices within R of ``node`` at rest (Euclidean
        distance, ``node`` first) and their area-weighted shares, summing to 1.
    """
    if radius is None:
        return np.array([node], dtype=np.int64), np.ones(1)
    radius = contact_radius(radius)
    distance = np.linalg.norm(rest_positions - rest_positions[node], axis=1)
    nodes = np.flatnonzero(distance <= radius)
    nodes = np.concatenate([[node], nodes[nodes != node]]).astype(np.int64)
    if areas is None:
        areas = lumped_areas(rest_positions, triangles)
    weights = areas[nodes]
    total = weights.sum()
    if not total > 0.0:
        return np.array([node], dtype=np.int64), np.ones(1)
    return nodes, weights / total


def contact_radius(radius: object) -> float:
    """``radius`` as a float [m], or a :class:`SolverError` unless a positive finite number (:func:`real_number`)."""
    value = real_number(radius)
    if value is None:
        raise SolverError(f"contact radius must be a number [m] or None, got {radius!r}; {number_fix(radius)}")
    if not np.isfinite(value) or value <= 0.0:
        raise SolverError(
            f"contact radius must be a positive finite number of metres (or None for a single-node load), got "
            f"{radius!r}"
        )
    return value


def real_number(value: object) -> float | None:
    """``value`` as a float, or None unless a real number: text is none (the API takes numbers, as scene files do: a
    string "5" would silently be 5 m), nor is a bool (True would mean 1), a complex, or an array of more than one
    element. Any object with ``__float__`` is taken (``Fraction``, ``Decimal``), and NumPy's 0-d integers and floats.

    It lives here, the lowest layer that checks numbers (the contact radius), for every check above to share."""
    if isinstance(value, (bool, np.bool_, str, bytes, bytearray)):   # NumPy's str_ and bytes_ are str and bytes
        return None
    if isinstance(value, (np.ndarray, np.generic)):
        if value.ndim != 0 or value.dtype.kind not in "iuf":
            return None
    elif not hasattr(type(value), "__float__"):   # None, lists, complex, arbitrary objects
        return None
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return None


def number_fix(value: object, example: str = "0.01") -> str:
    """What to do about ``value``, which :func:`real_number` refused: pass the number itself (the one a string
    spells, if it spells one), e.g. ``example``."""
    if isinstance(value, (str, bytes, bytearray)):
        try:
            spelled = float(value)
        except ValueError:
            spelled = None
        if spelled is not None and np.isfinite(spelled):
            return f"pass a number, e.g. {spelled:g} rather than the text {value!r}"
    return f"pass a number, e.g. {example}"
