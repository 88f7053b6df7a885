"""The accuracy reference of §8.3.1: static linear FEM on the fine volume mesh (TetGen's mesh of M_S itself).

The load on M_S node i goes to fine-volume node ``fine_surface_nodes[i]`` (the same point); positions are
rest + u[fine_surface_nodes]. Each ``step`` is one full sparse back-substitution over the fine volume (that is this
method's per-step time, as the paper's FEM column). ``fixed`` defaults to the fine-volume nodes below the bottom
height. With a finite-strain ``material`` each step is a Newton solve of the fine volume
(:class:`~tissuesim.fem.nonlinear.NonlinearFEM`), warm-started from the last answer.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..fem.hyperelastic import MATERIALS
from ..errors import SolverError
from .base import Solver
from .finite_strain import finite_volume, move_supports, solve_volume
from .attachments import volume_pieces
from .gravity import volume_constant_load, volume_springs
from .registry import register

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh


@register("fem")
class FineFEMSolver(Solver):
    """Static linear FEM on ``hybrid.fine_volume`` (see the module docstring)."""

    label = "fine-volume FEM, linear tets"
    short_label = "FEM"
    colour = "grey"
    line_style = "-"
    in_paper = True

    static = True
    materials = MATERIALS       # every material of fem.hyperelastic: a volume takes finite strain
    cut_refusal = ("the fem reference cannot be cut: cutting its fine volume would need re-tetrahedralizing and "
                   "re-factorizing K for every move (what the hybrid avoids); cut a hybrid, pbd, mass-spring or "
                   "embedded solver")

    def __init__(self, hybrid_mesh: HybridMesh, **common: object):
        super().__init__(hybrid_mesh, **common)
        from ..fem.linear import LinearFEM

        cuts = int(hybrid_mesh.info.get("cuts", 0))
        if cuts:  # a cut drops the fine volume: it is TetGen's mesh of the uncut surface
            raise SolverError(
                f"the fem reference cannot run on a cut surface ({cuts} cutting moves): its fine volume is a mesh of "
                "the uncut surface, and cutting it would need re-tetrahedralizing; run fem on the uncut mesh (in "
                "the viewer: reset, then switch to fem)"
            )
        if hybrid_mesh.fine_volume is None or hybrid_mesh.fine_surface_nodes is None:
            raise SolverError(
                "the fem reference needs the fine volume mesh, but this hybrid mesh was built without it; "
                "rebuild with HybridMesh.build(surface, fine_volume=True)"
            )
        volume = hybrid_mesh.fine_volume
        self.surface_nodes = np.asarray(hybrid_mesh.fine_surface_nodes, dtype=np.int64)
        self.fixed_volume = self.fixed_volume_nodes(volume.points, self.surface_nodes)
        springs = volume_springs(self, self.surface_nodes[:, None], np.ones((self.node_count, 1)))
        self.fem = LinearFEM(volume, youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
                             fixed=self.fixed_volume, springs=springs)
        self._volume_forces = np.zeros((volume.node_count, 3))
        #: ``(N, 3)`` the fine volume's constant load [N] (weight, attachments' pull; :mod:`.gravity`) or None.
        self._constant_load = volume_constant_load(self, volume, springs)
        self.finite = finite_volume(self, volume, self.fem)
        #: ``(N, 3) float64`` the volume's finite-strain displacement [m] (zero with the linear material).
        self.volume_displacement = np.zeros((volume.node_count, 3))

    def _pieces(self) -> np.ndarray:
        """The fine volume's pieces (the surface's where the mesh was built without it: refused just after)."""
        h = self.hybrid
        if h.fine_volume is None or h.fine_surface_nodes is None:
            return super()._pieces()
        return volume_pieces(h.fine_volume, h.fine_surface_nodes)

    def _step(self, dt: float) -> None:
        state = self.state
        u = self.displacement_field()  # the full solve is what this method costs per step
        state.velocities[:] = state.positions
        np.add(self.rest_positions, u[self.surface_nodes], out=state.positions)
        np.subtract(state.positions, state.velocities, out=state.velocities)
        state.velocities /= dt

    def displacement_field(self) -> np.ndarray:
        """``(N, 3) float64`` fine-volume displacement [m] under the current load (one full solve)."""
        self._volume_forces[:] = 0.0
        loaded = np.unique(self.load_nodes)
        self._volume_forces[self.surface_nodes[loaded]] = self.forces[loaded]
        if self._constant_load is not None:
            self._volume_forces += self._constant_load
        if self.finite is None:
            return self.fem.solve(self._volume_forces)
        self.volume_displacement = solve_volume(self, self._volume_forces)
        return self.volume_displacement

    def point_compliance(self, nodes: np.ndarray) -> np.ndarray:
        """``(3k, 3k) float64`` [m/N] the small-strain compliance at rest among M_S vertices ``nodes`` ``(k,)``
        (:meth:`LinearFEM.compliance_among <tissuesim.fem.linear.LinearFEM.compliance_among>`): exact with the linear
        material, the tangent at rest with a finite-strain one (what a grasper's Newton iteration starts from)."""
        return self.fem.compliance_among(self.surface_nodes[np.asarray(nodes, dtype=np.int64)])

    def surface_to_volume(self) -> np.ndarray:
        """Every M_S vertex is a fine-volume node (the fem reference is never cut)."""
        return self.surface_nodes

    def _move_fixed(self, positions: np.ndarray) -> None:
        move_supports(self, positions)
