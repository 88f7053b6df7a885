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
