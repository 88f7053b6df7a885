"""The small-strain compliance among surface vertices that ride on a volume through weights: what a grasper's
Newton iteration starts from (:mod:`tissuesim.grasper`). A vertex a at Σ_p w_ap u_p (its embedding, or for the
hybrid its M'_S triangle's control nodes) loaded by the transpose of the same map has the compliance

    J[a, b] = Σ_p Σ_q w_ap K⁻¹[p, q] w_bq    (3 × 3 blocks),

exact for the embedded surface, and the coarse surface's part for the hybrid, whose layer adds its own motion."""

from __future__ import annotations

import numpy as np


def mapped_compliance(fem, nodes: np.ndarray, weights: np.ndarray) -> np.ndarray:
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
        ``nodes`` is on the field and their responses fit in memory; None otherwise (:meth:`compliance_model`)."""
        if not self._on_quadratic_field(nodes):
            return None
        return self.quadratic_field.point_compliance(nodes)

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
