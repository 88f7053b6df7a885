"""What the simulator's panel edits (:class:`Settings`), and the checks that turn a value a user or a script gives
into the number a solver takes (:func:`checked_settings`): before a mesh is built, so a bad one costs nothing."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import SolverError
from ..fem.hyperelastic import check_material
from ..layer.prestress import check_prestrain
from ..solvers.checks import positive_number, time_step, whole_count
from ..solvers.checks import check_element
from ..solvers.registry import available_solvers

DEFAULT_STIFFNESS = 50.0  # N/m: 2 cm of drag = 1 N


@dataclass(frozen=True)
class Settings:
    """What the panel edits.

    Attributes:
        method: solver name (``tissuesim.available_solvers()``).
        youngs_modulus: E [Pa]. poisson_ratio: ν [-].
        stiffness: pin-head k of eq 24 [N/m].
        radius: pin-head contact radius [m] (the force spread over the M_S nodes within it), or None: one node.
        iterations: PBD iterations per step, or None where the method has none (or keeps its default).
        dt: simulation time step [s].
        prestrain: in-plane prestrain of the surface [-] (:mod:`tissuesim.layer.prestress`), on the methods that
            take one (hybrid, pbd): a cut then gapes by itself.
        near_field: W [m] of the hybrid's near field (:mod:`tissuesim.solvers.near_field`), or None (the paper's
            hybrid); not on a cut mesh (its fine volume is not cut).
        material: ``"linear"`` or a finite-strain material (:data:`tissuesim.fem.hyperelastic.MATERIALS`), on the
            methods that have it (the others keep their own model).
        element: the hybrid's M_V elements, ``"linear"`` (the paper's) or ``"quadratic"``
            (:mod:`tissuesim.solvers.quadratic_field`: as accurate as the fine FEM, slower to build); the other
            methods keep their own.
    """

    method: str = "hybrid"
    youngs_modulus: float = 5500.0
    poisson_ratio: float = 0.3
    stiffness: float = DEFAULT_STIFFNESS
    radius: float | None = None
    iterations: int | None = None
    dt: float = 0.01
    prestrain: float = 0.0
    near_field: float | None = None
    material: str = "linear"
    element: str = "linear"


def _setting_number(name: str, value, unit: str, check=positive_number) -> float:
    """``value`` of the setting ``name`` as ``check`` returns it, or SolverError: a bool or a string is no number
    here (True would mean 1, and "0.01" would reach the solver as text)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise SolverError(f"setting {name} must be a number [{unit}], got {value!r}")
    return check(f"setting {name}", value, unit)


def _finite(name: str, value, unit: str) -> float:
    """``value`` as a finite float, or SolverError naming ``name`` (the material checks its range)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if not np.isfinite(number):
        raise SolverError(f"{name} must be a finite number [{unit}], got {value!r}")
    return number


def _iterations(value) -> int | None:
    """PBD iterations as an int of at least 1 (or None), else SolverError: 2.5 or True is no count."""
    if value is None:
        return None
    return whole_count("setting iterations", value)


def checked_settings(settings: Settings) -> Settings:
    """``settings`` in canonical form (floats, an int or None for iterations), or SolverError naming the first bad
    one (cheap: checked before a mesh is built)."""
    if not isinstance(settings.method, str) or settings.method not in available_solvers():
        raise SolverError(f"unknown method {settings.method!r}; choose one of {', '.join(available_solvers())}")
    radius, near_field = settings.radius, settings.near_field
    return replace(
        settings,
        youngs_modulus=_setting_number("youngs_modulus (Young's modulus E)", settings.youngs_modulus, "Pa"),
        poisson_ratio=_setting_number("poisson_ratio (Poisson's ratio)", settings.poisson_ratio, "1", _finite),
        stiffness=_setting_number("stiffness (pin-head stiffness k)", settings.stiffness, "N/m"),
        radius=None if radius is None else _setting_number("radius (contact radius)", radius, "m"),
        iterations=_iterations(settings.iterations),
        dt=_setting_number("dt (time step dt)", settings.dt, "s", lambda name, value, unit: time_step(value, name)),
        prestrain=_setting_number("prestrain (in-plane strain)", settings.prestrain, "1", lambda name, value, unit:
                                  check_prestrain(value)),
        near_field=None if near_field is None else _setting_number("near_field (near field W)", near_field, "m"),
        material=check_material(settings.material),
        element=check_element(settings.element, near_field))


#: The cursor's travel, as a fraction of the model's size, that loads the pin-head with the sized default force.
DRAG_FRACTION = 0.1


@dataclass(frozen=True)
class SizedDefaults:
    """The simulator's tool defaults for one model (:func:`sized_defaults`). SI units.

    Attributes:
        stiffness: pin-head k [N/m]: a drag of :data:`DRAG_FRACTION` of the model's size gives the default force of
            :func:`tissuesim.mesh.sizes.load_defaults`, which keeps the answer in the small-strain range.
        radius: the pin-head's (and the probe's) contact radius [m].
        depth: the scalpel's blade length [m].
        line: one sentence saying what was chosen and why.
    """

    stiffness: float
    radius: float
    depth: float
    line: str


def sized_defaults(points: np.ndarray, *, edge_length: float = 0.0, youngs_modulus: float = 5500.0,
                   poisson_ratio: float = 0.3) -> SizedDefaults:
    """Tool defaults sized to a model with rest points ``points`` ``(n, 3) float64`` [m], mean edge length
    ``edge_length`` [m] (the tip covers a few edges; 0: no floor) and the material's E [Pa] and ν: the same
    reasoning as ``render`` and ``incise`` (:func:`~tissuesim.mesh.sizes.load_defaults`)."""
    from ..mesh.sizes import load_defaults

    loads = load_defaults(points, edge_length=edge_length, youngs_modulus=youngs_modulus,
                          poisson_ratio=poisson_ratio)
    stiffness = float(f"{loads.force / (DRAG_FRACTION * loads.size):.3g}")
    drag_mm = 1e3 * DRAG_FRACTION * loads.size
    line = (f"pin-head k = {stiffness:.3g} N/m ({loads.force:.3g} N for a drag of {drag_mm:.0f} mm) over a "
            f"{1e3 * loads.radius:.3g} mm tip, blade {1e3 * loads.depth:.3g} mm: sized to the model "
            f"({1e3 * loads.size:.0f} mm across) and E = {youngs_modulus:g} Pa, so that a drag stays in small strain")
    return SizedDefaults(stiffness=stiffness, radius=loads.radius, depth=loads.depth, line=line)
