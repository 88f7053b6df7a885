"""Surface prestress (beyond the paper): a capsule under tension, so that a wound gapes without any load.

Skin and organ capsules are stretched in the body, which is why a cut in them opens by itself. The layer is given a
uniform isotropic membrane tension, the stress of an in-plane prestrain ε,

    T = E h̄ ε / (1 − ν)          [N/m],

with h̄ the layer's mean thickness: β times M_S's mean rest edge length as built
(:attr:`~tissuesim.mesh.hybrid.HybridMesh.built_edge_length`), which a cut keeps, so that a cut's smaller
triangles carry the same tension, and a solver built on a cut mesh the same as the one that cut it. A uniform
tension has the energy T × area, so it pulls on vertex v with −T ∇_v A.

The rest state is the body's equilibrium: on the uncut surface the tissue underneath reacts that pull everywhere
(on a flat region the pulls cancel; on a curved one they press the capsule inward). A cut does not change the tissue
underneath, so the reaction stays what it was on the uncut surface, T Σ_{u ∈ g} ∇_u A over the copies g of one
original vertex, shared among the copies by lumped area a. What a copy feels is the difference,

    f_v = T ( a_v / Σ_{u ∈ g} a_u  Σ_{u ∈ g} ∇_u A  −  ∇_v A ).

It is zero at every vertex without a copy (its group is itself), so an uncut surface feels nothing. At the lips of
a cut, the pull of the tension across the cut is gone: each lip is pulled back by its own side, and the wound gapes.
The forces of the two lips of one original vertex sum to zero, so the release moves no body as a whole.

Small strain, as the rest of the layer: the release forces are evaluated at rest and held constant, and the
prestress's geometric stiffness (T ≪ E h̄) is neglected. The gap is then linear in ε and independent of E, dt and
the masses, and zero on an uncut surface.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from ..loads import lumped_areas
from ..mesh.coincident import coincident_pairs

#: Largest prestrain accepted: beyond it the small-strain release is no longer a fair model of a retracting capsule.
MAX_PRESTRAIN = 0.3


def check_prestrain(prestrain: object) -> float:
    """``prestrain`` ε as a float in [0, :data:`MAX_PRESTRAIN`], or SolverError naming the defect."""
    try:
        if isinstance(prestrain, (str, bytes)):
            raise TypeError
        value = float(prestrain)
    except (TypeError, ValueError):
        raise SolverError(f"prestrain must be a number (a strain, e.g. 0.05 for 5 %), got {prestrain!r}") from None
    if not (np.isfinite(value) and 0.0 <= value <= MAX_PRESTRAIN):
        raise SolverError(f"prestrain must lie in [0, {MAX_PRESTRAIN:g}] (a strain, e.g. 0.05 for 5 %), got "
                          f"{prestrain!r}")
    return value


def prestress_tension(*, youngs_modulus: float, poisson_ratio: float, thickness: float, prestrain: float) -> float:
    """T = E h ε / (1 − ν) [N/m] of a membrane of modulus E [Pa], ratio ν, thickness h [m] under strain ε [-]."""
    return youngs_modulus * thickness * prestrain / (1.0 - poisson_ratio)


def layer_tension(prestrain: float, *, form: str, integrator: str, youngs_modulus: float, poisson_ratio: float,
                  thickness: float) -> float:
    """The tension T [N/m] (:func:`prestress_tension`) of a surface layer of ``form`` and ``integrator`` under a
    checked ``prestrain`` ε (0: none); SolverError where the layer cannot carry one."""
    if prestrain == 0.0:
        return 0.0
    if form != "xpbd":
        raise SolverError("prestrain needs the xpbd form (the pbd form's stiffness has no unit to make a tension "
                          "from); drop form='pbd' or the prestrain")
    if integrator != "implicit":
        # measured: pbd on a cut cube, ε = 0.1, the XPBD projection left the wound 0.3-0.8 m open and moving
        raise SolverError("prestrain needs the implicit integrator: under the tension a cut releases, the XPBD "
                          "projection does not settle; drop integrator='xpbd' or the prestrain")
    return prestress_tension(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, thickness=thickness,
                             prestrain=prestrain)


def area_gradient(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(n, 3) float64`` gradient of the surface's area [m] with respect to each vertex of ``positions`` ``(n, 3)``
    [m]: ∇_a A = ½ (b − c) × n̂ summed over the triangles (a, b, c) around it (degenerate triangles add nothing)."""
    tri = np.asarray(triangles, dtype=np.int64)
    p = positions[tri]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    unit = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0.0)
    gradient = np.zeros_like(positions, dtype=np.float64)
    for corner in range(3):
        opposite = p[:, (corner + 1) % 3] - p[:, (corner + 2) % 3]
        np.add.at(gradient, tri[:, corner], 0.5 * np.cross(opposite, unit))
    return gradient


def copy_origin(rest: np.ndarray) -> np.ndarray:
    """``(n,) int64`` for each vertex of a cut surface, the vertex it is a copy of: the first of those sharing its rest
    position ``(n, 3)`` [m] (a cut duplicates a vertex in place), itself for the others. Read from the mesh alone,
    so a solver built on an already cut mesh knows its wound too."""
    origin = np.arange(len(rest))
    pairs = coincident_pairs(rest)
    origin[pairs[:, 1]] = pairs[:, 0]
    return origin


def release_forces(rest: np.ndarray, triangles: np.ndarray, origin: np.ndarray, tension: float) -> np.ndarray:
    """``(n, 3) float64`` forces [N] the released prestress puts on each vertex of a cut surface (module docstring).

    Args:
        rest: ``(n, 3)`` rest positions [m] of the cut surface.
        triangles: ``(m, 3) int`` its triangles.
        origin: ``(n,) int`` the original vertex each vertex is a copy of (itself if it is none; see
            :func:`copy_origin`).
        tension: T [N/m].
    """
    forces = np.zeros((len(rest), 3))
    origin = np.asarray(origin, dtype=np.int64)
    copied = np.bincount(origin, minlength=len(rest))[origin] > 1
    if tension == 0.0 or not copied.any():
        return forces
    members = np.flatnonzero(copied)
    # only the triangles around the copies: the work grows with the wound, not with the mesh
    triangles = np.asarray(triangles, dtype=np.int64)
    around = triangles[np.isin(triangles, members).any(axis=1)]
    gradient = area_gradient(rest, around)[members]
    area = lumped_areas(rest, around)[members]
    group = np.unique(origin[members], return_inverse=True)[1]
    group_gradient = np.zeros((group.max() + 1, 3))
    group_area = np.zeros(group.max() + 1)
    np.add.at(group_gradient, group, gradient)
    np.add.at(group_area, group, area)
    share = np.divide(area, group_area[group], out=np.zeros(members.size), where=group_area[group] > 0.0)
    forces[members] = tension * (share[:, None] * group_gradient[group] - gradient)
    return forces
