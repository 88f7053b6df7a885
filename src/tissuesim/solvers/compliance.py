"""The small-strain compliance among surface vertices that ride on a volume through weights: what a grasper's
Newton iteration starts from (:mod:`tissuesim.tools.grasper`). A vertex a at Σ_p w_ap u_p (its embedding, or for the
hybrid its M'_S triangle's control nodes) loaded by the transpose of the same map has the compliance

    J[a, b] = Σ_p Σ_q w_ap K⁻¹[p, q] w_bq    (3 × 3 blocks),

exact for the embedded surface, and the coarse surface's part for the hybrid, whose layer adds its own motion."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..fem.linear import LinearFEM

#: The most memory [bytes] the hybrid's exact compliance may take (its columns over M_V and over the layer).
LAYERED_BYTES = 512 * 2**20


def mapped_compliance(fem: LinearFEM, nodes: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(3k, 3k) float64`` [m/N], node-major, of ``k`` vertices on the volume nodes ``nodes`` ``(k, r) int`` of
    ``fem`` (a :class:`~tissuesim.fem.linear.LinearFEM`) with ``weights`` ``(k, r)``: ``[3a + d, 3b + c]`` is vertex
    a's motion along d under a unit force on vertex b along c."""
    unique, inverse = np.unique(np.asarray(nodes, dtype=np.int64), return_inverse=True)
    among = fem.compliance_among(unique).reshape(unique.size, 3, unique.size, 3)
    k = len(nodes)
    spread = np.zeros((k, unique.size))
    np.add.at(spread, (np.repeat(np.arange(k), nodes.shape[1]), inverse.ravel()), np.asarray(weights).ravel())
    return np.einsum("ap,pdqc,bq->adbc", spread, among, spread).reshape(3 * k, 3 * k)


class HybridCompliance:
    """The hybrid solver's compliances among M_S vertices (a mixin of
    :class:`~tissuesim.solvers.hybrid.HybridSolver`, which holds ``quadratic_field``, ``finite``, ``prescribed``,
    ``fem``, ``load_volume_nodes`` and ``load_weights``): exact ones where M_V is quadratic and the vertices ride
    on it, the coarse surface's model otherwise."""

    def contact_compliance(self, nodes: np.ndarray, normals: np.ndarray) -> np.ndarray | None:
        """``(k, k)`` [m/N] the normal compliance of M_S vertices ``nodes`` along ``normals`` ``(k, 3)`` (what the
        probe's Newton step uses): M_V's own (:meth:`QuadraticField.compliance
        <tissuesim.solvers.quadratic_field.QuadraticField.compliance>`) with ``element="quadratic"``, the linear
        material and every one of ``nodes`` on the field, where their responses fit in memory; None otherwise (a
        vertex freed by a cut is the layer's: the probe then models it)."""
        if self.finite is not None or not self._on_quadratic_field(nodes):
            return None
        return self.quadratic_field.compliance(nodes, normals)

    def point_compliance(self, nodes: np.ndarray) -> np.ndarray | None:
        """``(3k, 3k)`` [m/N] the small-strain compliance among M_S vertices ``nodes`` (a grasper's starting
        Jacobian, exact with the linear material): with ``element="quadratic"`` M_V's own where every one of
        ``nodes`` is on the field and their responses fit in memory; with the paper's linear M_V and the layer's
        static form, the whole model's (:meth:`_layered_compliance`); the tangent at rest with a finite-strain
        material; None otherwise (a near field: :meth:`compliance_model`)."""
        if self.quadratic_field is not None:
            return self.quadratic_field.point_compliance(nodes) if self._on_quadratic_field(nodes) else None
        if self._near is not None or self.form != "xpbd":
            return None
        return self._layered_compliance(np.asarray(nodes, dtype=np.int64))

    def _layered_compliance(self, nodes: np.ndarray) -> np.ndarray | None:
        """The hybrid's static answer is linear in the loads: a unit force on vertex j loads M_V through its M'_S
        triangle, which moves the control nodes, and the layer, whose free nodes answer
        K_ff u_f = e_j − K_fp u_p. Both for all 3k unit forces at once: one multi-column solve of M_V's factor and
        one of the layer's. None where the layer's columns would not fit :data:`LAYERED_BYTES`."""
        statics = self.linear_statics()
        k = nodes.size
        if 8 * 9 * k * max(statics.free_nodes.size, self.fem.node_count) > LAYERED_BYTES:
            return None
        volume = np.zeros((3 * self.fem.node_count, 3 * k))
        for slot, (corners, weights) in enumerate(zip(self.load_volume_nodes[nodes], self.load_weights[nodes])):
            for axis in range(3):
                np.add.at(volume[:, 3 * slot + axis], 3 * corners + axis, weights)
        moved = self.fem.solve_columns(volume)
        prescribed = np.zeros((3 * statics.prescribed.size, 3 * k))        # the fixed nodes stay at rest
        control = (3 * self.output_nodes[: self.control_count, None] + np.arange(3)).ravel()
        prescribed[: 3 * self.control_count] = moved[control]
        # each vertex's place among the layer's unknowns: its free nodes first, then its prescribed ones
        free_count = statics.free_nodes.size
        place = np.full(self.node_count, -1, dtype=np.int64)
        place[statics.free_nodes] = np.arange(free_count)
        place[statics.prescribed] = free_count + np.arange(statics.prescribed.size)
        forces = np.zeros((3 * free_count, 3 * k))
        for slot, node in enumerate(nodes):
            if place[node] < free_count:       # a force on a prescribed node acts on M_V alone
                forces[3 * place[node]:3 * place[node] + 3, 3 * slot:3 * slot + 3] = np.eye(3)
        whole = np.concatenate([statics.displacement_columns(forces, prescribed), prescribed])
        return whole[(3 * place[nodes][:, None] + np.arange(3)).ravel()]

    def compliance_model(self, nodes: np.ndarray) -> np.ndarray:
        """``(3k, 3k)`` [m/N] the coarse surface's compliance among M_S vertices ``nodes``
        (:func:`mapped_compliance` through M'_S to the control nodes): a model of the hybrid's, which leaves out
        the layer's own motion between control nodes (a grasper sizes it by its first solve)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        return mapped_compliance(self.fem, self.load_volume_nodes[nodes], self.load_weights[nodes])

    def _on_quadratic_field(self, nodes: np.ndarray) -> bool:
        """Whether M_S vertices ``nodes`` all follow the quadratic field and their responses fit in memory."""
        if self.quadratic_field is None or not self.quadratic_field.compliance_fits(len(nodes)):
            return False
        on_field = np.zeros(self.node_count, dtype=bool)
        on_field[self.prescribed] = True
        return bool(np.all(on_field[np.asarray(nodes, dtype=np.int64)]))
