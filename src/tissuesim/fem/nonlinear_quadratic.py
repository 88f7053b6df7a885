"""Hyperelastic statics on quadratic (10-node) tets: :class:`QuadraticNonlinearFEM`, the quadratic-tet sibling of
:class:`~.nonlinear.NonlinearFEM` (the same Newton, load stepping and constant-factor relaxation,
:class:`~.nonlinear.HyperelasticStatics`), with the element quantities of :mod:`.hyperelastic_quadratic`."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from ..mesh.tetmesh import TetMesh
from .hyperelastic import check_material
from .hyperelastic_quadratic import quadrature_gradients
from .material import DEFAULT_POISSON_RATIO, DEFAULT_YOUNGS_MODULUS, Material
from .nonlinear import HyperelasticStatics
from .quadratic import QuadraticFEM


class QuadraticNonlinearFEM(HyperelasticStatics):
    """Hyperelastic statics on the quadratic (10-node) tets of :class:`~.quadratic.QuadraticFEM`
    (:mod:`.hyperelastic_quadratic`): the same Newton, load stepping and :meth:`relax` as :class:`NonlinearFEM`, with
    K₀ the quadratic small-strain stiffness (the tangent at rest, exactly).

    Args:
        mesh: the tet mesh whose nodes are the corners; midside nodes are added as QuadraticFEM adds them.
        youngs_modulus: E [Pa].
        poisson_ratio: ν [-].
        fixed: the supports among all N corner and midside nodes, as QuadraticFEM takes them (a callable
            ``points (N, 3) ->`` indices or a node or dof mask).
        material: ``"corotated"`` or ``"neo-hookean"``.
        linear: an existing QuadraticFEM of the same mesh, E, ν and supports whose factor :meth:`relax` reuses
            (default: one is built).

    Attributes:
        linear: the small-strain quadratic model; ``rest`` ``(N, 3) float64`` [m] all its nodes.
        elements: ``(m, 10) int64`` corners and midsides of each tet.
        gradients: ``(m, 4, 10, 3) float64`` rest shape-function gradients at the quadrature points [1/m];
            ``weights`` ``(m, 4)`` [m³].
    """

    def __init__(self, mesh: TetMesh, *, youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
                 poisson_ratio: float = DEFAULT_POISSON_RATIO, fixed: Callable[[np.ndarray], ArrayLike],
                 material: str = "neo-hookean", linear: QuadraticFEM | None = None):
        self.material_name = check_material(material)
        elastic = Material(youngs_modulus, poisson_ratio)
        self.linear = linear if linear is not None else QuadraticFEM(
            mesh, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, fixed=fixed)
        self.mesh = mesh
        fixed_mask = np.ones(3 * self.linear.node_count, dtype=bool)
        fixed_mask[self.linear.free_dofs] = False
        self._setup(material, elastic, self.linear.points, fixed_mask.reshape(-1, 3),
                    np.ascontiguousarray(self.linear.elements, dtype=np.int64), *quadrature_gradients(mesh),
                    self.linear.factor)
        self._springs = self.linear.spring_stiffness      # the QuadraticFEM's springs (ligaments), if any
