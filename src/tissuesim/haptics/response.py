"""The grabbed region's local response: x(f) ≈ x0 + C f at one M_S node, for a force f [N] spread over a contact
patch, or at a grasper's jaws, for the force f [N] they exert on the patch they hold, measured on the solver itself by its own
static solves (the grasper's static moves) and the visual state put back afterwards.

With the linear material the model is linear, so the affine map is exact (to round-off): four static solves (the
current load and one step along x, y, z) give x0 and the three columns of C. With a finite-strain material C is the
tangent compliance at the current load by forward differences of the same solves, and x0 + C f its linearisation
there: exact at that load, good near it; :meth:`HapticLoop.sync <tissuesim.haptics.HapticLoop.sync>` refreshes it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..solvers.snapshot import leaves_no_trace

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..tools.grasper import Grasper
    from ..solvers.base import Solver

#: The forward-difference step of a finite-strain tangent, as a multiple of E ℓ² [N] (ℓ: the contact radius, else
#: the mean M_S edge length): a force that strains the patch by about 1e-3, small against the nonlinearity and
#: large against the Newton solves' tolerance (0.09 mN on the cube's 4 mm tip; steps of 0.1 to 10 mN there give the
#: same tangent to 3 digits).
TANGENT_STEP = 1e-3
#: How close to its targets [the step's fraction] a grasper's measuring move goes: the columns' relative error.
MEASURE_FRACTION = 1e-3


@dataclass(frozen=True)
class LocalResponse:
    """x(f) = x0 + C f at a grabbed node (see the module docstring).

    Attributes:
        node: the M_S vertex index.
        radius: the contact radius R [m] of the patch the force is spread over, or None (the node alone).
        origin: ``(3,) float64`` x0 [m]: where the node rests without the grabbing force (measured under no other
            load either: the response is the solver's to this tool alone).
        compliance: ``(3, 3) float64`` C [m/N]: the node's displacement per unit force, column j for a force along
            axis j (exact for the linear material, the tangent at ``around`` for a finite-strain one).
        around: ``(3,) float64`` the force [N] it was measured at.
    """

    node: int
    radius: float | None
    origin: np.ndarray
    compliance: np.ndarray
    around: np.ndarray


def local_response(solver: Solver, node: int, *, radius: float | None,
                   around: ArrayLike = (0.0, 0.0, 0.0)) -> LocalResponse:
    """Measure :class:`LocalResponse` at ``node`` with contact ``radius`` [m] around force ``around`` ``(3,)`` [N].

    Four :meth:`Solver.solve_static` calls on ``solver``; its positions, velocities and load are put back afterwards,
    so the visual loop carries on from where it was. A load the solver refuses (a fixed node, a patch reaching the
    support, a finite-strain press beyond the stable range) raises its error and changes nothing.
    """
    around = np.array(around, dtype=np.float64)
    step = 1.0 if solver.material == "linear" else tangent_step(solver, radius)
    snapshot = solver.snapshot()
    try:
        base = solver.solve_static(node, around, radius=radius)[node]
        columns = [(solver.solve_static(node, around + step * axis, radius=radius)[node] - base) / step
                   for axis in np.eye(3)]
    finally:
        solver.restore(snapshot)
    compliance = np.column_stack(columns)
    return LocalResponse(int(node), radius, base - compliance @ around, compliance, around)


def tangent_step(solver: Solver, radius: float | None) -> float:
    """The forward-difference step [N] of a finite-strain tangent: :data:`TANGENT_STEP` × E ℓ²."""
    if radius is None:
        surface = solver.hybrid.surface
        ends = surface.vertices[surface.edges]
        radius = float(np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1).mean())
    return TANGENT_STEP * solver.youngs_modulus * radius ** 2


def grasper_response(grasper: Grasper, node: int) -> LocalResponse:
    """The jaws' translational response x_j(f) = x0 + C_g f where they are, as a :class:`LocalResponse` (``node``:
    the M_S vertex the jaws were put on; ``origin``: x0 [m], where the jaws hold the patch with no force;
    ``compliance``: C_g ``(3, 3)`` [m/N]; ``around``: the force f [N] at the jaws' position). f is the sum of the
    jaws' forces on the tissue, and C_g the held patch's compliance to a rigid translation, (Tᵀ J⁻¹ T)⁻¹ of the held
    vertices' compliance J (T: k 3×3 identities stacked).

    With the linear material and a solver that has its exact compliance J (``point_compliance``), from J itself.
    Otherwise measured by the grasper's own static moves (:meth:`~tissuesim.Grasper.move_to`, the jaws' rotation
    kept): where the jaws are, then one step along x, y and z; C_g is the inverse of the stiffness those give. The
    step is the jaws' radius with the linear material (exact: the model is affine), a strain of
    :data:`TANGENT_STEP` (that fraction of the radius) with a finite-strain one (the tangent), and each move goes
    within :data:`MEASURE_FRACTION` of the step of its targets. The solver's and the grasper's state are put back
    afterwards; a move the grasper refuses raises its error and changes nothing."""
    position = grasper.position.copy()
    exact = _patch_compliance(grasper)
    if exact is not None:
        base = -grasper.move_to(position)          # where the jaws are: none or one solve when they settled there
        return LocalResponse(int(node), grasper.radius, position - exact @ base, exact, base)
    step = grasper.radius if grasper.solver.material == "linear" else TANGENT_STEP * grasper.radius
    with leaves_no_trace(grasper):
        grasper.tolerance = min(grasper.tolerance, MEASURE_FRACTION * step)
        base = -grasper.move_to(position)
        columns = [(-grasper.move_to(position + step * axis) - base) / step for axis in np.eye(3)]
    compliance = np.linalg.inv(np.column_stack(columns))
    return LocalResponse(int(node), grasper.radius, position - compliance @ base, compliance, base)


def _patch_compliance(grasper) -> np.ndarray | None:
    """C_g ``(3, 3)`` [m/N] = (Tᵀ J⁻¹ T)⁻¹ from the solver's exact small-strain compliance J of the held vertices
    (``point_compliance``: the fem, the embedded surface, the hybrid), with the linear material; None where the
    solver has none or the material is finite-strain (then it is measured)."""
    solver = grasper.solver
    found = getattr(solver, "point_compliance", None)
    compliance = None if found is None or solver.material != "linear" else found(grasper.held)
    if compliance is None:
        return None
    stack = np.tile(np.eye(3), (grasper.held.size, 1))
    return np.linalg.inv(stack.T @ np.linalg.solve(compliance, stack))
