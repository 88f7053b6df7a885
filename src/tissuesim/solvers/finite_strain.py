"""What the solvers share for finite strain: the ``material`` option, a moving fixed set, the volume's solve, its
range, and the refusal of a load that has no stable equilibrium.

A moving fixed set (:meth:`Solver.set_fixed_positions <tissuesim.solvers.base.Solver.set_fixed_positions>`) gives
the positions of the fixed M_S vertices; a volume's fixed nodes follow them: exactly where a volume node is one of
those vertices, and through the affine map that best fits the given motion (least squares) elsewhere, so a rigid
motion of the fixed set moves every fixed node rigidly. The volume is carried with its base by the same map, so a
solve starts from the carried body, and a motion that is no support's motion (too far, crushed, mirrored,
scattered) is refused where it is given.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BoundaryConditionError, SolverError
from ..fem.hyperelastic import MATERIALS, check_material
from ..fem.nonlinear import UnstableLoadError
from .report import FINITE_RANGE_J

if TYPE_CHECKING:
    from ..fem.linear import LinearFEM
    from ..fem.nonlinear import NonlinearFEM
    from ..mesh.tetmesh import TetMesh
    from .base import Solver


def check_method_material(cls: type[Solver], material: object) -> str:
    """``material`` if method ``cls`` accepts it (``cls.materials``), else a MaterialError or SolverError."""
    material = check_material(material)
    if material not in cls.materials:
        raise SolverError(f"the {cls.name} method takes material {' or '.join(map(repr, cls.materials))}, not "
                          f"{material!r}; finite strain ({', '.join(map(repr, MATERIALS[1:]))}) is available in "
                          f"the methods with a volume, tissuesim.solvers.method_names(material={material!r}) (a "
                          "surface alone has none, and a layer alone under a finite-strain pull tangles)")
    return material


def check_fixed_positions(positions: ArrayLike, fixed: np.ndarray) -> np.ndarray:
    """``(k, 3) float64`` copy of ``positions`` [m] for the ``fixed`` ``(k,)`` M_S vertices, checked: finite and
    one row per vertex."""
    kind = getattr(np.asarray(positions), "dtype", np.dtype(object)).kind
    if kind not in "iuf":
        raise BoundaryConditionError(f"fixed positions must be real numbers [m] (a ({fixed.size}, 3) float array), "
                                     f"got an array of {np.asarray(positions).dtype}")
    positions = np.array(positions, dtype=np.float64)
    if positions.shape != (fixed.size, 3):
        raise BoundaryConditionError(f"fixed positions must be a ({fixed.size}, 3) array [m], one row per vertex of "
                                     f"solver.fixed, got shape {positions.shape}")
    if not np.all(np.isfinite(positions)):
        raise BoundaryConditionError("fixed positions must be finite numbers [m]")
    return positions


#: Farthest a fixed vertex may be carried from rest, in body sizes (the diagonal of M_S's rest bounding box): a
#: grasper or retractor carries an organ a few of its sizes at most, and a body carried rigidly stays then far within
#: the runaway distance (``RUNAWAY_SIZES`` = 100 sizes) that a step calls a blow-up; farther is a slip of units or
#: a wrong array, which the next step would only report as a divergence under no load.
SUPPORT_REACH = 10.0
#: The most a support motion may depart from the affine map that fits it: the largest distance of a fixed vertex
#: from where that map puts it, over the fixed set's RMS distance from its centre. A base carried, turned or
#: squeezed by a rigid jaw moves affinely (0); vertices scattered independently are no support's motion.
NON_AFFINE = 0.1


def check_support_motion(rest: np.ndarray, positions: np.ndarray, size: float) -> None:
    """Refuse (BoundaryConditionError) a motion of the fixed set from ``rest`` to ``positions`` ``(k, 3)`` [m] that is
    no support's motion on a body of ``size`` [m]: carried farther than :data:`SUPPORT_REACH` sizes; crushed or
    mirrored (the affine map that fits it must keep the orientation and at least 10 % of the volume, and the set at
    least 30 % of its spread about its centre: a rigid motion keeps all of both, a grasper's squeeze far more); or
    scattered (farther than :data:`NON_AFFINE` of the set's spread from that map)."""
    step = positions - rest
    scale = np.abs(step).max(axis=1)        # the norm scaled, as 1e300² would overflow
    travel = scale * np.linalg.norm(step / np.where(scale > 0, scale, 1.0)[:, None], axis=1)
    far = int(np.argmax(travel))
    if travel[far] > SUPPORT_REACH * size:
        raise BoundaryConditionError(
            f"the fixed set's motion carries vertex {far} of it {travel[far]:.3g} m from rest, "
            f"{travel[far] / size:.3g} times the body's size {size:.3g} m: no grasper carries an organ that far "
            f"(positions are in metres); give positions within {SUPPORT_REACH:g} sizes of rest, e.g. rest positions "
            "turned and shifted")
    radius = np.sqrt(np.mean(np.sum((rest - rest.mean(axis=0)) ** 2, axis=1)))
    matrix, _ = affine_fit(rest, positions)
    determinant = float(np.linalg.det(matrix))
    spread = np.linalg.norm(positions - positions.mean(axis=0)) / np.linalg.norm(rest - rest.mean(axis=0))
    if not (determinant > 0.1 and spread > 0.3):    # a planar base's fit is a rotation: its spread says it all
        # a set gathered to a point or a line is crushed, whatever the sign round-off gives its determinant
        mirrored = determinant < -0.1 and spread > 0.3
        raise BoundaryConditionError(
            f"the fixed set's motion {'mirrors' if mirrored else 'crushes'} it (the affine map that fits it has "
            f"determinant {determinant:.3g} and keeps {spread:.2g} of its spread; a rigid motion keeps 1 and 1): "
            "give positions that carry or turn the base, e.g. rest positions turned and shifted")
    rest_h = np.hstack([rest, np.ones((len(rest), 1))])
    off = np.linalg.norm(rest_h @ np.linalg.lstsq(rest_h, positions, rcond=None)[0] - positions, axis=1)
    worst = int(np.argmax(off))
    if off[worst] > NON_AFFINE * radius:
        raise BoundaryConditionError(
            f"the fixed set's motion is no support's motion: vertex {worst} of it lies {off[worst]:.3g} m from where "
            f"the affine map that best fits the motion puts it, {off[worst] / radius:.2g} of the set's spread "
            f"{radius:.3g} m (a base carried, turned or squeezed moves affinely; at most {NON_AFFINE:g} is taken); "
            "move the whole base together, e.g. rest positions turned and shifted")


def affine_fit(rest: np.ndarray, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(A (3, 3), b (3,))`` minimising Σ |A x + b − y|² over rest points ``rest`` ``(k, 3)`` → ``moved`` ``(k, 3)``
    [m]: exact for a rigid or affine motion; the fixed set's points must not all lie on one line."""
    if len(rest) == 0:      # no fixed vertex (attachments hold the body): nothing moved
        return np.eye(3), np.zeros(3)
    rest_h = np.hstack([rest, np.ones((len(rest), 1))])
    solution, _, rank, _ = np.linalg.lstsq(rest_h, moved, rcond=None)
    if rank < 4:  # planar fixed sets (the bottom face) leave the normal free: complete the map with a rotation
        centre = rest.mean(axis=0)
        target_centre = moved.mean(axis=0)
        u, _, vt = np.linalg.svd((moved - target_centre).T @ (rest - centre))
        rotation = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
        return rotation, target_centre - rotation @ centre
    return solution[:3].T, solution[3]


def support_displacement(solver: Solver, positions: np.ndarray) -> np.ndarray:
    """``(N, 3)`` displacement [m] of ``solver``'s finite-strain volume at its fixed nodes (zero elsewhere) when its
    fixed M_S vertices move to ``positions`` ``(k, 3)``: exactly where a volume node is one of those vertices (the
    mesh as it is now: a cut adds fixed vertices that are none), by the affine map that best fits the motion
    elsewhere; a quadratic volume's midside node between two such vertices goes with their mean (straight edges)."""
    rest_surface, fixed_surface = solver.rest_positions, solver.fixed
    matrix, shift = affine_fit(rest_surface[fixed_surface], positions)
    volume_points = solver.finite.rest
    fixed = np.flatnonzero(np.any(solver.finite.fixed_dofs, axis=1))
    displacement = np.zeros_like(volume_points)
    points = volume_points[fixed]
    displacement[fixed] = points @ matrix.T + shift - points
    mapped = solver.surface_to_volume()[fixed_surface]
    on_surface = mapped >= 0
    displacement[mapped[on_surface]] = positions[on_surface] - rest_surface[fixed_surface[on_surface]]
    edges = getattr(solver.finite.linear, "edges", None)       # the midside nodes' edges (quadratic tets)
    if edges is not None:
        exact = np.zeros(len(volume_points), dtype=bool)
        exact[mapped[on_surface]] = True
        both = np.flatnonzero(exact[edges[:, 0]] & exact[edges[:, 1]])
        corners = len(volume_points) - len(edges)
        displacement[corners + both] = 0.5 * (displacement[edges[both, 0]] + displacement[edges[both, 1]])
    return displacement


def move_supports(solver: Solver, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Carry a finite-strain ``solver``'s fixed volume nodes to where its fixed vertices go, ``positions``
    ``(k, 3)`` [m], and its volume's displacement with them by the affine map that fits the base's motion from
    where it is now: the solves start from the body carried with its base, not from a body left behind, whose
    way to the carried one can pass through a crushed state (a half turn interpolated linearly crushes the base to
    a line halfway). Returns that map, ``(A (3, 3), b (3,) [m])``."""
    matrix, shift = affine_fit(solver.fixed_positions, positions)
    points = solver.finite.rest
    solver.volume_displacement[:] = (points + solver.volume_displacement) @ matrix.T + shift - points
    finite = solver.finite
    finite.set_fixed_displacement(support_displacement(solver, positions))
    fixed = solver.finite.fixed_dofs
    solver.volume_displacement[fixed] = finite.fixed_displacement[fixed]
    return matrix, shift


def carried_rest(solver: Solver) -> np.ndarray:
    """``(N, 3)`` the displacement [m] of a finite-strain ``solver``'s unloaded volume carried with its base as it
    is now (:func:`move_supports`'s map from rest): where a solve from rest starts; zero with the base at rest."""
    rest = solver.rest_positions[solver.fixed]
    if np.array_equal(solver.fixed_positions, rest):
        return np.zeros_like(solver.finite.rest)
    matrix, shift = affine_fit(rest, solver.fixed_positions)
    points = solver.finite.rest
    carried = points @ matrix.T + shift - points
    fixed = solver.finite.fixed_dofs
    carried[fixed] = solver.finite.fixed_displacement[fixed]
    return carried


def unstable_load_error(solver: Solver, error: UnstableLoadError) -> SolverError:
    """The SolverError a solver raises for ``error`` (:class:`~tissuesim.fem.nonlinear.UnstableLoadError`): what acts
    (the loads, with the patch's mean traction, a press's or a pull's, against the shear modulus μ; else the weight,
    the ligaments or the moved base: no load is never called an unstable one), and the fix."""
    loaded = np.unique(solver.load_nodes)
    head = f"{solver.name} solver ({solver.material}): "
    carried = f"{100 * error.reached:.3g} % of it was carried"
    if loaded.size == 0:
        return SolverError(head + f"with no load acting, {' and '.join(_other_causes(solver))} has no stable "
                           f"equilibrium ({carried})" + _other_fixes(solver))
    force = float(sum(np.linalg.norm(load.force) for load in solver.loads))
    area = float(solver.lumped_areas()[loaded].sum())
    mu = solver.elasticity.shear_modulus
    pressure = f"{force / area:.3g} Pa = {force / area / mu:.2g} μ" if area > 0 else "over no area"
    return SolverError(
        head + f"a dead load of {force:.3g} N on {loaded.size} node(s) ({1e6 * area:.3g} mm², mean traction "
        f"{pressure}, μ = {mu:.3g} Pa) has no stable equilibrium ({carried}): a fixed force of more than about μ over "
        "its patch buckles the body, or crushes the surface ahead of a tip pushed sideways; lower the load, spread "
        "it over a wider tip (radius=), or press with tissuesim.Probe, a rigid tip driven by displacement (the "
        "pin-head's force is a fixed force too)")


def _other_causes(solver) -> list[str]:
    """What loads a body that carries no load: its weight, its ligaments, its moved base."""
    causes = []
    if solver.gravity is not None:
        causes.append(f"its weight (g = {float(np.linalg.norm(solver.gravity)):.3g} m/s²)")
    if solver.attachments:
        causes.append("its attachments' pull")
    if not np.array_equal(solver.fixed_positions, solver.rest_positions[solver.fixed]):
        causes.append("the motion of its base (set_fixed_positions)")
    return causes or ["its state"]


def _other_fixes(solver) -> str:
    fixes = []
    if solver.gravity is not None or solver.attachments:
        fixes.append("a stiffer material (youngs_modulus) or a lighter body (density)")
    if not np.array_equal(solver.fixed_positions, solver.rest_positions[solver.fixed]):
        fixes.append("a base carried or turned less far")
    return f": try {' or '.join(fixes)}, then reset()" if fixes else ": call reset()"


def solve_volume(solver: Solver, forces: np.ndarray) -> np.ndarray:
    """``(N, 3)`` a finite-strain ``solver``'s volume displacement [m] at equilibrium under ``forces`` ``(N, 3)``
    [N], warm-started from its last one; where that start leads nowhere (a state tangled by an earlier load, e.g.
    a contact's, now withdrawn), again from the body at rest carried with its base, before calling the load
    unstable (:class:`~tissuesim.fem.nonlinear.UnstableLoadError`)."""
    try:
        return solver.finite.solve(forces, initial=solver.volume_displacement)
    except UnstableLoadError:
        start = carried_rest(solver)
        if np.array_equal(start, solver.volume_displacement):
            raise
        return solver.finite.solve(forces, initial=start)


def inverted_element_count(solver: Solver) -> int | None:
    """How many of a finite-strain solver's volume elements are turned inside out now (None for linear)."""
    if getattr(solver, "finite", None) is None:
        return None
    return int(np.count_nonzero(np.any(solver.finite.volume_ratios(solver.volume_displacement) <= 0.0, axis=1)))


def volume_range(solver: Solver) -> dict:
    """What a :class:`~.report.SolveReport` and ``Solver.warning`` need to judge ``solver``'s state: its material
    and, with a finite-strain one, ``smallest_volume_ratio`` (the smallest J = det F of its volume's elements) and
    ``crushed`` (how many are below :data:`~.report.FINITE_RANGE_J`)."""
    if getattr(solver, "finite", None) is None:
        return {"material": solver.material}
    ratios = solver.finite.volume_ratios(solver.volume_displacement).min(axis=1)
    return {"material": solver.material, "smallest_volume_ratio": float(ratios.min()),
            "crushed": int(np.count_nonzero(ratios < FINITE_RANGE_J))}


def finite_volume(solver: Solver, mesh: TetMesh, linear: LinearFEM) -> NonlinearFEM | None:
    """The :class:`~tissuesim.fem.nonlinear.NonlinearFEM` of ``mesh`` for ``solver``'s finite-strain material (sharing
    the factor of its LinearFEM ``linear``), or None for the linear material."""
    if solver.material == "linear":
        return None
    from ..fem.nonlinear import NonlinearFEM

    return NonlinearFEM(mesh, fixed=linear.fixed_dofs, material=solver.material, linear=linear)


#: A dead-load press whose mean pressure over the contact patch exceeds this many shear moduli μ is refused with a
#: finite-strain material: in the mesh-converged finite-strain solution of the cube (docs/finite-strain.md) a dead
#: traction above about μ over the patch has no stable equilibrium, and the load at which a given mesh still
#: converges falls as it is refined, so a coarse mesh's answer beyond it means nothing.
PRESS_LIMIT = 1.0


def check_dead_press(solver: Solver, node: int, force: np.ndarray, radius: float | None) -> None:
    """Refuse (SolverError) a finite-strain dead load at ``node`` that presses into the surface with a mean pressure
    above :data:`PRESS_LIMIT` μ over its contact patch; pulls and shears of any size pass."""
    if solver.material == "linear":
        return
    nodes, _ = solver.contact_patch(node, radius)
    rest, triangles = solver.rest_positions, solver.hybrid.surface.triangles
    around = triangles[np.any(triangles == node, axis=1)]
    normal = np.cross(rest[around[:, 1]] - rest[around[:, 0]], rest[around[:, 2]] - rest[around[:, 0]]).sum(axis=0)
    # the outward normal at the node, area-weighted over its triangles, turned with a moved base (a normal maps
    # by the inverse transpose of the base's fitted affine map)
    matrix, _ = affine_fit(rest[solver.fixed], solver.fixed_positions)
    normal = np.linalg.solve(matrix.T, normal)
    normal /= np.linalg.norm(normal)
    area = float(solver.lumped_areas()[nodes].sum())
    pressure = max(0.0, -float(np.dot(force, normal))) / area
    mu = solver.elasticity.shear_modulus
    if pressure > PRESS_LIMIT * mu:
        largest = PRESS_LIMIT * mu * area
        raise SolverError(
            f"a dead load pressing {-float(np.dot(force, normal)):.3g} N into the surface over {nodes.size} node(s) "
            f"({1e6 * area:.3g} mm²) is a mean pressure of {pressure:.3g} Pa = {pressure / mu:.2g} μ "
            f"(μ = {mu:.3g} Pa): beyond about μ a body pressed by a fixed force has no stable finite-strain "
            f"equilibrium (here: above {largest:.3g} N); lower the load, or press with tissuesim.Probe, a rigid tip "
            "driven by displacement (the pin-head's force is a fixed force too)")


def slow_static_solve(solver: Solver) -> bool:
    """Whether ``solver``'s static solve is a Newton solve its step only approaches (a finite-strain material on a
    method whose step is no static solve: the hybrid's takes seconds at 10k vertices): a tool that follows a hand
    then updates its forces once a frame and lets the steps relax, rather than solve each frame."""
    return solver.material != "linear" and not getattr(solver, "static", False)
