"""Embedded-surface baseline: M_S rides on M_V's linear FEM through its barycentric embedding (SOFA's practice).

Every M_S vertex lies in (or next to) one M_V tet with barycentric weights b (``hybrid.embedding_tet``,
``hybrid.embedding_barycentric``): its displacement is u_s = Σ_j b_j u_V[tet_j] (SOFA's BarycentricMapping). A load
f on M_S node i goes to the four nodes of its tet as b_j f (the transpose of that mapping, so the work f·u_s equals
the work done on M_V: the mapping's virtual-work-consistent force transfer).

The method is static: each ``step`` is one FEM fast-path solve (cached K⁻¹ columns of the ≤ 4 loaded nodes) for the
M_V nodes that carry the surface, then the mapping. ``fixed`` defaults to the M_V nodes below the bottom height.
With a finite-strain ``material`` each step is a Newton solve of M_V (:class:`~tissuesim.fem.nonlinear.NonlinearFEM`),
warm-started from the last answer, and the mapping carries its displacement.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from ..fem.hyperelastic import MATERIALS
from .base import Solver
from .compliance import mapped_compliance
from .finite_strain import finite_volume, move_supports, solve_volume
from .attachments import volume_pieces
from .gravity import volume_constant_load, volume_springs
from .registry import register

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh


@njit(cache=True)
def map_embedded(rest: np.ndarray, tets: np.ndarray, tet_of: np.ndarray, weights: np.ndarray, node_slot: np.ndarray,
                 u_nodes: np.ndarray, positions: np.ndarray) -> None:
    """positions[i] = rest[i] + Σ_j weights[i, j] u_nodes[node_slot[tets[tet_of[i], j]]] in place (eq: mapping)."""
    for i in range(rest.shape[0]):
        t = tet_of[i]
        for k in range(3):
            positions[i, k] = rest[i, k]
        for j in range(4):
            slot = node_slot[tets[t, j]]
            w = weights[i, j]
            for k in range(3):
                positions[i, k] += w * u_nodes[slot, k]


@njit(cache=True)
def hold_at_rest(rest: np.ndarray, nodes: np.ndarray, positions: np.ndarray) -> None:
    """positions[nodes] = rest[nodes] in place: a prescribed node is where it was, exactly, not by interpolation."""
    for i in nodes:
        for k in range(3):
            positions[i, k] = rest[i, k]


@register("embedded")
class EmbeddedSolver(Solver):
    """M_S follows M_V's static linear FEM by barycentric embedding (see the module docstring).

    Attributes:
        output_displacement: ``(c, 3) float64`` [m] M_V's displacement at the nodes that carry M_S.
        volume_stale: M_V's answer is due again (the loads changed).
    """

    label = "embedded surface"
    short_label = "Emb."
    colour = "tab:orange"
    line_style = ":"

    static = True
    materials = MATERIALS       # every material of fem.hyperelastic: a volume takes finite strain
    cut_carrier = "tissuesim.solvers.surface_layer_cut:EmbeddedCut"
    kept_arrays = (*Solver.kept_arrays, "output_displacement")      # M_V's answer, due again when stale
    kept_values = (*Solver.kept_values, "volume_stale")

    def __init__(self, hybrid_mesh: HybridMesh, **common: object):
        super().__init__(hybrid_mesh, **common)
        from ..fem.linear import LinearFEM

        volume = hybrid_mesh.volume
        self.fixed_volume = self.fixed_volume_nodes(volume.points, self.surface_to_volume())
        self.tet_of = np.ascontiguousarray(hybrid_mesh.embedding_tet, dtype=np.int64)
        self.weights = np.ascontiguousarray(hybrid_mesh.embedding_barycentric, dtype=np.float64)
        tets = volume.tets
        springs = volume_springs(self, tets[self.tet_of], self.weights)     # through each vertex's tet
        self.fem = LinearFEM(volume, youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
                             fixed=self.fixed_volume, springs=springs)
        # Only the M_V nodes of tets that hold a surface vertex matter: solve for those alone.
        self.carrier_nodes = np.unique(tets[self.tet_of]).astype(np.int64)
        self.node_slot = np.full(volume.node_count, -1, dtype=np.int64)
        self.node_slot[self.carrier_nodes] = np.arange(self.carrier_nodes.size)
        self.output_displacement = np.zeros((self.carrier_nodes.size, 3))
        self._tets = tets.astype(np.int64)
        self.volume_stale = False
        self.finite = finite_volume(self, volume, self.fem)
        #: ``(N, 3) float64`` the volume's finite-strain displacement [m] (zero with the linear material).
        self.volume_displacement = np.zeros((volume.node_count, 3))
        self._volume_forces = np.zeros((volume.node_count, 3))
        #: ``(N, 3)`` M_V's constant load [N] (weight, attachments' pull; :mod:`.gravity`) or None; its response.
        self._constant_load = volume_constant_load(self, volume, springs)
        self._constant_u = None if self._constant_load is None or self.finite is not None else (
            self.fem.solve(self._constant_load))

    def point_compliance(self, nodes: np.ndarray) -> np.ndarray:
        """``(3k, 3k)`` [m/N] the small-strain compliance among M_S vertices ``nodes`` (:mod:`.compliance`): exact
        with the linear material, the tangent at rest with a finite-strain one (a grasper's starting Jacobian)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        return mapped_compliance(self.fem, self._tets[self.tet_of[nodes]], self.weights[nodes])

    def _on_load_changed(self) -> None:
        self.volume_stale = True

    def _pieces(self) -> np.ndarray:
        """M_V's pieces: the volume holds the surface together where a cut splits it."""
        h = self.hybrid
        return volume_pieces(h.volume, h.volume.tets[np.asarray(h.embedding_tet, dtype=np.int64), 0])

    def _solve(self) -> None:
        if self.finite is not None:
            self._finite_solve()
            return
        self.output_displacement[:] = 0.0        # the sum of each load's patch response (linear)
        one = np.empty_like(self.output_displacement) if len(self._loads) > 1 else self.output_displacement
        for load in self._loads:
            self.fem.patch_response(self._tets[self.tet_of[load.nodes]].ravel(),
                                    (self.weights[load.nodes] * load.shares[:, None]).ravel(), load.force,
                                    output_nodes=self.carrier_nodes, out=one)
            if one is not self.output_displacement:
                self.output_displacement += one
        if self._constant_u is not None:
            self.output_displacement += self._constant_u[self.carrier_nodes]

    def _tet_loads(self) -> tuple[np.ndarray, np.ndarray]:
        """``(M_V nodes (4p,), forces (4p, 3) [N])``: each loaded M_S node's share of its load split over its tet's
        nodes by its barycentric weights, every load in turn."""
        nodes = [self._tets[self.tet_of[load.nodes]].ravel() for load in self._loads]
        forces = [(self.weights[load.nodes][:, :, None] * (load.shares[:, None] * load.force[None, :])[:, None, :])
                  .reshape(-1, 3) for load in self._loads]
        return np.concatenate(nodes), np.concatenate(forces)

    def _finite_solve(self) -> None:
        """M_V's finite-strain equilibrium, warm-started from the last one; the carriers' displacement into
        ``output_displacement``."""
        forces = self._volume_forces
        forces[:] = 0.0
        if self._loads:
            np.add.at(forces, *self._tet_loads())
        if self._constant_load is not None:
            forces += self._constant_load
        self.volume_displacement = solve_volume(self, forces)
        self.output_displacement[:] = self.volume_displacement[self.carrier_nodes]

    def _move_fixed(self, positions: np.ndarray) -> None:
        move_supports(self, positions)

    def _step(self, dt: float) -> None:
        state = self.state
        self._solve()
        # v = (p_new − p)/dt keeps the state meaningful for callers that look at velocities.
        state.velocities[:] = state.positions
        map_embedded(self.rest_positions, self._tets, self.tet_of, self.weights, self.node_slot,
                     self.output_displacement, state.positions)
        if self.finite is None:
            hold_at_rest(self.rest_positions, self.fixed, state.positions)
        else:  # the fixed vertices where set_fixed_positions put them (at rest until then)
            state.positions[self.fixed] = self.fixed_positions
        np.subtract(state.positions, state.velocities, out=state.velocities)
        state.velocities /= dt
