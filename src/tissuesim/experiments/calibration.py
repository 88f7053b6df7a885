"""Calibration of each method's one free scalar against the fine FEM reference, on one case, then frozen.

The case (DESIGN "free parameters"): the cube model at its default resolution, 1 N of pressure (−z) through a
pin-head tip of radius 4 mm at the load node (:func:`tissuesim.experiments.protocol.load_node`: the top node nearest the vertical centre axis); metric: eq 26
(RMSE) over the 50 M_S nodes nearest the load node (:func:`~tissuesim.experiments.protocol.sample_nodes`), against
the contact protocol's refined FEM reference (:func:`tissuesim.experiments.reference.contact_reference`,
cached on disk). A 1-D bounded minimisation (:func:`scipy.optimize.minimize_scalar`, ``bounded``) over
the logarithm of the scalar finds the value; ``tissuesim calibrate --write`` freezes it in
:mod:`tissuesim.solvers.calibrated`, and every model and load then uses it unchanged.

The load-node and sample-node helpers are the experiments' own, so calibration measures exactly what the
experiments measure.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize_scalar

from ..errors import SolverError
from ..solvers.registry import available_solvers, make_solver, solver_class
from .protocol import RMSE_SAMPLES, load_node, rms_displacement, rmse, sample_nodes

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh

CALIBRATION_MODEL = "cube"
CALIBRATION_FORCE = (0.0, 0.0, -1.0)  # N: 1 N of pressure
CALIBRATION_RADIUS = 0.004  # m: the pin-head's contact radius
#: Quasi-static step budget of every calibration solve.
MAX_STEPS = 3000


@dataclass(frozen=True)
class CalibrationResult:
    """One calibrated scalar.

    Attributes:
        method, form, option: what was calibrated (``option`` is the solver keyword, e.g. ``"stiffness"``).
        value: the calibrated scalar (unit of the option).
        rmse: eq 26 at that value [m]; reference_rms: the reference's RMS displacement over the samples [m].
        evaluations: solver runs the minimisation took; elapsed: wall time [s].
    """

    method: str
    form: str
    option: str
    value: float
    rmse: float
    reference_rms: float
    evaluations: int
    elapsed: float


def free_scalars() -> dict[str, dict[str, tuple[str, float, float]]]:
    """method -> form -> (option, lower bound, upper bound): each registered method's free scalars and their search
    intervals (:attr:`~tissuesim.solvers.base.Solver.free_scalars`)."""
    return {name: dict(solver_class(name).free_scalars) for name in available_solvers()
            if solver_class(name).free_scalars}


def calibration_case(hybrid_mesh: HybridMesh) -> tuple[int, np.ndarray, np.ndarray]:
    """``(node, samples (50,) int64, reference positions (n, 3) m)`` of the calibration case on ``hybrid_mesh``."""
    surface = hybrid_mesh.surface
    node = load_node(surface.vertices, surface.triangles)
    samples = sample_nodes(surface.vertices, node, RMSE_SAMPLES)
    from .reference import contact_reference, default_cache_dir

    reference = contact_reference(hybrid_mesh, node, CALIBRATION_RADIUS, cache_dir=default_cache_dir())
    return node, samples, surface.vertices + reference.displacements(CALIBRATION_FORCE)


def evaluate(method: str, hybrid_mesh: HybridMesh, case: tuple[int, np.ndarray, np.ndarray], **options: Any) -> float:
    """Eq 26 [m] of ``method`` with ``options`` on the calibration ``case`` (from :func:`calibration_case`).

    A solve that does not settle within :data:`MAX_STEPS` is scored on its last positions (a jittering method is
    still measured, not dropped); a non-finite result scores +inf.
    """
    node, samples, reference = case
    solver = make_solver(method, hybrid_mesh, **options)
    try:
        positions = solver.solve_static(node, CALIBRATION_FORCE, radius=CALIBRATION_RADIUS, max_steps=MAX_STEPS)
    except SolverError:
        positions = solver.positions
    if not np.all(np.isfinite(positions)):
        return math.inf
    return rmse(positions, reference, samples)


def calibrate(method: str, hybrid_mesh: HybridMesh, *, form: str | None = None,
              case: tuple[int, np.ndarray, np.ndarray] | None = None, xatol: float = 0.02,
              progress: Callable[[float, float], None] | None = None) -> CalibrationResult:
    """Calibrate ``method``'s free scalar in ``form`` on ``hybrid_mesh`` (the cube for the frozen values).

    ``xatol`` is the tolerance on the natural log of the scalar (0.02 ≈ 2 %). ``progress(value, rmse)`` is called
    after each evaluation if given.
    """
    scalars = free_scalars()
    if method not in scalars:
        raise SolverError(f"method {method!r} has no free scalar; calibrate one of {', '.join(scalars)}")
    forms = scalars[method]
    form = form or next(iter(forms))
    if form not in forms:
        raise SolverError(f"method {method!r} has no form {form!r}; choose one of {', '.join(forms)}")
    option, low, high = forms[form]
    case = case or calibration_case(hybrid_mesh)
    extra = {} if method == "mass-spring" else {"form": form}
    start, count = time.perf_counter(), 0

    def objective(log_value):
        nonlocal count
        count += 1
        value = math.exp(log_value)
        score = evaluate(method, hybrid_mesh, case, **extra, **{option: value})
        if progress is not None:
            progress(value, score)
        return score if math.isfinite(score) else 1e9

    found = minimize_scalar(objective, bounds=(math.log(low), math.log(high)), method="bounded",
                            options={"xatol": xatol})
    value = float(math.exp(found.x))
    node, samples, reference = case
    return CalibrationResult(method, form, option, value, float(found.fun),
                             rms_displacement(reference, hybrid_mesh.surface.vertices, samples), count,
                             time.perf_counter() - start)


def write_calibrated(results: Iterable[CalibrationResult], path: Path | None = None) -> Path:
    """Rewrite :mod:`tissuesim.solvers.calibrated` with ``results`` (a list of :class:`CalibrationResult`) merged
    into the values already there; returns the file written."""
    from ..solvers import calibrated

    table = {m: dict(forms) for m, forms in calibrated.CALIBRATED.items()}
    for r in results:
        table.setdefault(r.method, {})[r.form] = (r.option, r.value, r.rmse, r.reference_rms)
    path = Path(path or Path(calibrated.__file__))
    head = calibrated.__doc__.strip()
    lines = [f'"""{head}\n"""', "",
             "# method -> form -> (option name, value, calibration RMSE [m], reference RMS displacement [m])",
             "CALIBRATED = {"]
    for method, forms in table.items():
        lines.append(f"    {method!r}: {{")
        for form, (option, value, err, rms) in forms.items():
            lines.append(f"        {form!r}: ({option!r}, {value!r}, {_literal(err)}, {_literal(rms)}),")
        lines.append("    },")
    lines += ["}", "", 'MASS_SPRING_THICKNESS = CALIBRATED["mass-spring"]["springs"][1]', "", "",
              "def value(method: str, form: str) -> float:",
              '    """The calibrated free scalar of ``method`` in ``form``."""',
              "    return CALIBRATED[method][form][1]", "", "",
              "def option(method: str, form: str) -> tuple[str, float]:",
              '    """``(option name, calibrated value)`` of ``method`` in ``form``."""',
              "    name, number = CALIBRATED[method][form][:2]",
              "    return name, number", ""]
    path.write_text("\n".join(lines))
    return path


def _literal(x: float) -> str:
    return repr(float(x)) if math.isfinite(x) else 'float("nan")'
