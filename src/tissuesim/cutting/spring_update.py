"""Cut updater of the mass-spring method: its stretch and bending springs edited locally, like the PBD constraints.

Every edge of a changed triangle loses its stretch spring and its bending spring (across the edge's two opposite
vertices); an edge that still exists gets a stretch spring again (rest length by eq 19–23, stiffness
k = E β Σ A_T / l over its new triangles, the method's own formula), and a bending spring if it still has two
triangles, so none crosses the cut. A retired spring joins node 0 to itself with zero stiffness (no force). The
stability bound ω_max is recomputed from the spring arrays (one vectorised pass: the substep count follows the new,
smaller springs).
"""

from __future__ import annotations

import numpy as np

from .layer_update import new_edge_constraints, new_hinges
from .rows import EdgeRows, Rows
from .solver_update import SolverCut, register_cut


@register_cut("mass-spring")
class MassSpringCut(SolverCut):
    """Updater of :class:`~tissuesim.solvers.mass_spring.MassSpringSolver`."""

    def __init__(self, solver):
        super().__init__(solver)
        self.mass_total = float(solver.mass.sum())
        springs = np.array(solver.springs)
        self.rows = Rows({"springs": springs, "rest": np.array(solver.rest_lengths),
                          "stiffness": np.array(solver.stiffness)}, len(springs),
                         {"springs": 0, "rest": 1.0, "stiffness": 0.0})
        surface = solver.hybrid.surface
        edges = np.asarray(surface.edges, dtype=np.int64)
        self.stretch_row = EdgeRows(edges, np.arange(len(edges)))
        # spring_network: stretch springs in edge order, then one bending spring per interior edge in that order
        directed = np.sort(surface.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        _, count = np.unique(directed, axis=0, return_counts=True)      # per edge, in the same (sorted) order
        interior = edges[count == 2]
        self.bend_row = EdgeRows(interior, len(edges) + np.arange(len(interior)))
        self._bind()

    def _bind(self) -> None:
        s, a = self.solver, self.rows.arrays
        s.springs, s.rest_lengths, s.stiffness = a["springs"], a["rest"], a["stiffness"]

    def update(self, result, n, released, touched) -> None:
        from ..solvers.mass_spring import _omega_bound

        s = self.solver
        keys, owners = self.touched_edges(result)
        self.rows.retire(self.stretch_row.pop(keys) + self.bend_row.pop(keys))
        live = owners[:, 0] >= 0
        keys, owners = keys[live], owners[live]
        rest, area = new_edge_constraints(result, keys, owners)
        two = owners[:, 1] >= 0
        hinges = new_hinges(result.triangles, keys[two], owners[two])
        across = hinges[:, 2:]
        across_rest = np.linalg.norm(result.rest[across[:, 0]] - result.rest[across[:, 1]], axis=1)
        rows, _ = self.rows.take(len(keys) + len(hinges))
        a = self.rows.arrays
        a["springs"][rows] = np.concatenate([keys, across])
        a["rest"][rows] = np.concatenate([rest, across_rest])
        a["stiffness"][rows] = (s.youngs_modulus * s.thickness_ratio * np.concatenate([area, area[two]])
                                / a["rest"][rows])
        self.stretch_row.update(keys, rows[: len(keys)])
        self.bend_row.update(keys[two], rows[len(keys):])
        self._bind()
        self.local_masses(touched, self.mass_total)
        added = len(result.parents)
        s.inv_mass = self.spare.extend("inv_mass", s.inv_mass, np.zeros(added))
        s.inv_mass[touched] = 1.0 / s.mass[touched]
        s.inv_mass[s.fixed] = 0.0
        # one pass over the springs: the explicit stability bound follows the new, smaller springs and masses
        s.omega_max = _omega_bound(s.springs, s.stiffness, s.inv_mass)
        s._accel = self.spare.extend("accel", s._accel, np.zeros((added, 3)))
