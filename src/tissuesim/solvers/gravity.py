"""Gravity and attachments in each method: where the weight goes, and the volume methods' constant load.

The weight is the body force ρ g of the body's mass, counted once, where the method keeps its mass:

* **fem, embedded, hybrid** (a volume): the consistent load of ρ g on the volume's linear tets, each node getting
  ρ g V_e/4 from each of its tets (:func:`tissuesim.fem.assembly.body_force`): on the fine volume (fem) or on M_V
  (embedded, hybrid). The hybrid's surface layer gets no weight: its lumped masses are the same body's mass (density
  × enclosed volume, spread over M_S) that M_V already carries, so adding it there would count the weight twice;
  the layer follows M_V's sag through its control nodes, as it follows a load's response.
* **pbd, mass-spring** (no volume): m_i g on each M_S node's lumped mass (the body's mass spread by lumped area),
  the same masses a cut carries over (new vertices get their share, the total stays). The paper's pbd form has a
  calibrated ``mass_scale`` on its masses; the weight uses the physical masses (ρ × volume), not the scaled ones.

Gravity acts beside the loads (``solver.forces`` stays the user's loads), in ``step`` and ``solve_static`` alike,
and after a cut; ``reset()`` keeps it.

Attachments (:mod:`.attachments`) on a volume method add their stiffness to the volume's K, through the same
embedding the loads use (:class:`~tissuesim.fem.linear.LinearFEM`'s ``springs``): the hybrid's coarse triangle under
the node (§6.1's barycentric split), the embedded method's tet, the fine volume's node. An anchor away from the
node's rest position pulls with k (a − X) at rest: a constant load, solved with the weight once (one
back-substitution) and added to each response, since the volume is linear.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..fem.assembly import body_force
from ..fem.quadratic import quadratic_body_force

if TYPE_CHECKING:
    from ..mesh.tetmesh import TetMesh
    from .base import Solver


def volume_springs(solver: Solver, nodes_of: np.ndarray,
                   weights_of: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``springs`` for :class:`~tissuesim.fem.linear.LinearFEM` (None without attachments): each attached M_S vertex
    held through volume nodes ``nodes_of`` ``(n, r) int`` with ``weights_of`` ``(n, r)`` (its embedding, per M_S
    vertex)."""
    nodes = solver.attached_nodes
    if nodes.size == 0:
        return None
    return (np.asarray(nodes_of, dtype=np.int64)[nodes].reshape(nodes.size, -1),
            np.asarray(weights_of, dtype=np.float64)[nodes].reshape(nodes.size, -1), solver.attached_stiffness)


def volume_constant_load(solver: Solver, mesh: TetMesh, springs: tuple[np.ndarray, np.ndarray, np.ndarray] | None, *,
                         quadratic: tuple[np.ndarray, int] | None = None) -> np.ndarray | None:
    """``(N, 3) float64`` [N] the volume ``mesh``'s loads that never change: the weight, plus the attachments' pull
    toward anchors away from the nodes' rest positions through ``springs`` (:func:`volume_springs`); None when there
    are none (the paper's model, bit-identical). ``quadratic``: ``(elements (m, 10), N)`` of the mesh's quadratic
    tets (:func:`~tissuesim.fem.quadratic.quadratic_elements`), whose consistent weight differs."""
    count = mesh.node_count if quadratic is None else quadratic[1]
    if solver.gravity is None:
        load = None
    elif quadratic is None:
        load = body_force(mesh, solver.density, solver.gravity)
    else:
        load = quadratic_body_force(mesh, *quadratic, solver.density, solver.gravity)
    if springs is None:
        return load
    nodes, weights, stiffness = springs
    pull = stiffness[:, None] * (solver.attached_anchors - solver.rest_positions[solver.attached_nodes])
    if not np.any(pull):
        return load
    load = np.zeros((count, 3)) if load is None else load
    np.add.at(load, nodes.ravel(), (weights[:, :, None] * pull[:, None, :]).reshape(-1, 3))
    return load


def surface_constant_load(solver: Solver, mass: np.ndarray) -> np.ndarray | None:
    """``(n, 3) float64`` [N] a surface method's loads that never change: the weight m_i g of the node masses
    ``mass`` ``(n,)`` [kg], plus the attachments' pull k_i (a_i − X_i) at rest; None when there are none."""
    load = None if solver.gravity is None else mass[:, None] * solver.gravity[None, :]
    pull = solver.attached_stiffness[:, None] * (solver.attached_anchors - solver.rest_positions[solver.attached_nodes])
    if not np.any(pull):
        return load
    load = np.zeros((len(mass), 3)) if load is None else load
    np.add.at(load, solver.attached_nodes, pull)
    return load
