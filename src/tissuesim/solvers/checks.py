"""Checks of the solvers' arguments: each returns the value in its canonical type or raises an error naming it."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BoundaryConditionError, SolverError, first_indices
from ..loads import number_fix, real_number

#: Shortest time step [s] a solver takes. Below it a step's motion is lost in the round-off of the positions
#: (~1e-17 m on a 10 cm body), and that round-off over dt is a spurious velocity that grows without bound
#: (measured on the cube, hybrid: 1.4e-8 m/s at 1 ns, 3.5e-3 m/s at 1 fs, 7e82 m/s at 1e-100 s); near 1e-154 s the
#: inertia m/dt² overflows. A nanosecond is a million times shorter than a 1 kHz haptic loop's step.
MIN_DT = 1e-9

#: Standard gravity g₀ [m/s²].
STANDARD_GRAVITY = 9.80665
#: Largest gravity [m/s²] a solver takes: about 1,000 g₀, ten times the peak of a car crash or a fall (~100 g₀) and
#: far beyond the ~1 g₀ of a patient on a table, tilted or not. Soft tissue under it is crushed, not deformed: the
#: weight of a 10 cm liver (E = 5500 Pa) strains it by ρ g L / E ≈ 180 at the bound. Beyond it an input is a unit
#: mistake (mm/s², or a typo) that would otherwise surface steps later, blamed on dt or the load.
MAX_GRAVITY = 1e4


def _number(name: str, value, unit: str, example: str = "0.01") -> float:
    """``value`` as a float, or a :class:`SolverError` naming ``name``, its ``unit`` and the fix (e.g. ``example``)
    unless a real number (:func:`~tissuesim.loads.real_number`: no text, bool or array)."""
    number = real_number(value)
    if number is None:
        raise SolverError(f"{name} must be a number [{unit}], got {value!r}; {number_fix(value, example)}")
    return number


def flag(name: str, value: object) -> bool:
    """``value`` as a bool, or a :class:`SolverError` naming the switch ``name`` unless True or False (any non-empty
    text, "no" too, would be true; scene files refuse it alike)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise SolverError(f"{name} is True or False, got {value!r}; pass {name}=False or {name}=True")


def numeric_array(value: object) -> np.ndarray | None:
    """``value`` as a ``float64`` array (the caller's own where it is one: copy what you keep), or None unless every
    element is a real number (no text, bool or None: ``np.asarray`` would read ``"1"`` as 1.0 and ``True`` as 1.0)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):      # ragged nesting
        return None
    if array.dtype.kind == "O":
        numbers = [real_number(item) for item in array.ravel()]
        if any(number is None for number in numbers):
            return None
        return np.array(numbers, dtype=np.float64).reshape(array.shape)
    if array.dtype.kind not in "iuf":
        return None
    return array.astype(np.float64, copy=False)


def positive_number(name: str, value: object, unit: str, example: str = "1") -> float:
    """``value`` as a float, or a :class:`SolverError` naming ``name`` and its ``unit`` unless positive and finite
    (``example``: a valid value, for the message's fix)."""
    value = _number(name, value, unit, example)
    if not np.isfinite(value) or value <= 0.0:
        raise SolverError(f"{name} must be a positive finite number [{unit}], got {value!r}")
    return value


def time_step(value: object, name: str = "time step dt") -> float:
    """``value`` as a float [s], or a :class:`SolverError` naming ``name`` and the valid range [MIN_DT, ∞)."""
    value = _number(name, value, "s")
    if not (np.isfinite(value) and value >= MIN_DT):
        why = (f"below {MIN_DT:g} s a step's motion is lost in the round-off of the positions and comes back as a "
               "spurious velocity" if np.isfinite(value) and value > 0.0 else "a step lasts a positive, finite time")
        raise SolverError(f"{name} must lie in [{MIN_DT:g}, ∞) s, got {value!r} s: {why}; pass a dt of at least "
                          f"{MIN_DT:g} s (the default is 0.01 s)")
    return value


def is_integer(value: object) -> bool:
    """True for an int or NumPy integer (not a bool: True would otherwise mean node 1), or an integral float."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, (int, np.integer)):
        return True
    return isinstance(value, (float, np.floating)) and float(value).is_integer()


def whole_count(name: str, value: object) -> int:
    """``value`` as an int of at least 1 (a count of steps or iterations), or a :class:`SolverError` naming ``name``
    (:func:`is_integer`: 2.5 or True is no count)."""
    if not is_integer(value) or value < 1:
        raise SolverError(f"{name} must be a whole number of at least 1, got {value!r}")
    return int(value)


def fraction(name: str, value: object) -> float:
    """``value`` as a float in [0, 1), or a :class:`SolverError` naming ``name``."""
    value = _number(name, value, "1")
    if not (0.0 <= value < 1.0):
        raise SolverError(f"{name} must lie in [0, 1) (fraction of velocity removed per step), got {value!r}")
    return value


def check_force(force: ArrayLike) -> np.ndarray:
    """``force`` as a ``(3,) float64`` array [N], or a :class:`SolverError` unless 3 finite numbers whose squared
    magnitude is finite too (the solvers take |f|: 1e200 N would overflow it)."""
    given, force = force, numeric_array(force)
    if force is None:
        raise SolverError(f"force must be 3 numbers [N], got {given!r}; pass numbers, e.g. [0, 0, -1]")
    if force.shape != (3,):
        raise SolverError(f"force must have shape (3,) [N], got shape {force.shape}")
    with np.errstate(over="ignore"):     # the overflow is what is checked here
        squared = float(force @ force)
    if not np.isfinite(squared):
        raise SolverError(f"force must be 3 finite numbers [N] below about 1e154 N (float64 must hold |f|²), got "
                          f"{force.tolist()}")
    return force


def gravity_vector(value: ArrayLike | None) -> np.ndarray | None:
    """``value`` as a read-only ``(3,) float64`` acceleration [m/s²], None for None, or a :class:`SolverError` unless
    3 finite numbers of magnitude at most :data:`MAX_GRAVITY`."""
    if value is None:
        return None
    vector = finite_triple(value)
    if vector is None:
        raise SolverError(f"gravity is an acceleration (gx, gy, gz) [m/s²] of 3 finite numbers, e.g. (0, 0, -9.81), "
                          f"or None for none; got {value!r}")
    with np.errstate(over="ignore"):     # 1e200 m/s² overflows the magnitude: that too is beyond the bound
        magnitude = float(np.linalg.norm(vector))
    if not magnitude <= MAX_GRAVITY:
        raise SolverError(f"gravity of {magnitude:.4g} m/s² ({magnitude / STANDARD_GRAVITY:.4g} g) is beyond "
                          f"{MAX_GRAVITY:g} m/s² (about {MAX_GRAVITY / STANDARD_GRAVITY:.0f} g), more than any "
                          "acceleration a body meets in surgery, and would crush the tissue many times over; give "
                          "the acceleration in m/s², e.g. (0, 0, -9.81), or None for none")
    return vector


def node_set(name: str, nodes: ArrayLike, count: int, *, allow_empty: bool = False) -> np.ndarray:
    """``(k,) int32`` sorted unique vertex indices from indices or a ``(count,)`` bool mask; BoundaryConditionError
    for bad ones, or an empty set unless ``allow_empty`` (attachments hold the body)."""
    nodes = np.asarray(nodes)
    if nodes.dtype == bool:
        if nodes.shape != (count,):
            raise BoundaryConditionError(f"boolean {name} mask must have shape ({count},), got {nodes.shape}")
        nodes = np.flatnonzero(nodes)
    if nodes.size and not np.issubdtype(nodes.dtype, np.integer):
        raise BoundaryConditionError(f"{name} must be integer M_S vertex indices, got dtype {nodes.dtype}")
    nodes = nodes.astype(np.int64).ravel()
    if nodes.size == 0 and not allow_empty:
        raise BoundaryConditionError(
            f"{name} is empty: the body would move freely; pass M_S vertex indices or leave it at its default "
            "(the model's bottom)"
        )
    bad = np.flatnonzero((nodes < 0) | (nodes >= count))
    if bad.size:
        raise BoundaryConditionError(
            f"{bad.size} {name} indices lie outside 0..{count - 1} (first positions in the list: "
            f"{first_indices(bad)})"
        )
    return np.unique(nodes).astype(np.int32)


def checked_point(point: ArrayLike, *, name: str = "a point") -> np.ndarray:
    """``point`` as a ``(3,) float64`` array [m] (possibly the caller's own: copy what you keep), or a SolverError
    naming it (``name``, e.g. "the probe centre")."""
    given, point = point, numeric_array(point)
    if point is None:
        raise SolverError(f"{name} must be 3 numbers [m], got {given!r}; pass coordinates, e.g. [0, 0, 0.05]")
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise SolverError(f"{name} must be 3 finite coordinates [m], got {point!r}")
    return point


def finite_triple(value: object) -> np.ndarray | None:
    """``value`` as a new read-only ``(3,) float64`` array, or None where it is not 3 finite numbers (the caller
    says what it should have been)."""
    vector = numeric_array(value)
    if vector is None or vector.shape != (3,) or not np.all(np.isfinite(vector)):
        return None
    vector = vector.copy()
    vector.flags.writeable = False
    return vector


#: M_V's elements (option ``element``): the paper's linear tets, or quadratic ones (:mod:`.quadratic_field`).
ELEMENTS = ("linear", "quadratic")


def check_element(element: object, near_field: float | None) -> str:
    """``element`` checked against :data:`ELEMENTS`, and against the near field, which the quadratic M_V replaces
    (SolverError with the fix)."""
    if not isinstance(element, str) or element not in ELEMENTS:
        raise SolverError(f"element must be one of {', '.join(map(repr, ELEMENTS))}, got {element!r}")
    if element == "quadratic" and near_field is not None:
        raise SolverError("element='quadratic' already drives every M_S vertex from M_V: drop near_field")
    return element
