"""Cut updater of the mass-spring method: its stretch and bending springs edited locally, like the PBD constraints.

Every edge of a changed triangle loses its stretch spring and its bending spring (across the edge's two opposite
vertices); an edge that still exists gets a stretch spring again (rest length by eq 19–23, stiffness
k = E β Σ A_T / l over its new triangles, the method's own formula), and a bending spring if it still has two
triangles, so none crosses the cut. A retired spring joins node 0 to itself with zero stiffness (no force). The
stability bound ω_max follows the new, smaller springs and masses (so does the substep count): its Gershgorin row
sums are kept per vertex and recomputed only where a cut changed a spring or a mass, at the vertices of the changed
triangles and their spring neighbours.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..cutting.edges import touched_edges
from ..cutting.rows import EdgeRows, Rows
from ..layer.compliance import thickness_lengths
from .cut_carry import SolverCut, members
from .mass_spring import gershgorin_rows
from .surface_layer_cut import new_edge_constraints, new_hinges

if TYPE_CHECKING:
    from ..cutting.result import CutResult
    from .mass_spring import MassSpringSolver


class MassSpringCut(SolverCut):
    """Updater of :class:`~tissuesim.solvers.mass_spring.MassSpringSolver`."""

    def __init__(self, solver: MassSpringSolver):
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
        self.gershgorin = gershgorin_rows(solver.springs, solver.stiffness, solver.inv_mass)
        np.add.at(self.gershgorin, solver.attached_nodes, solver.attached_stiffness
                  * solver.inv_mass[solver.attached_nodes])

    def _bind(self) -> None:
        s, a = self.solver, self.rows.arrays
        s.springs, s.rest_lengths, s.stiffness = a["springs"], a["rest"], a["stiffness"]

    def update(self, result: CutResult, n: int, released: np.ndarray, touched: np.ndarray) -> None:
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
        # k = E h Σ A_T / l² with the body's thickness h = β × M_S's edge length as built on a spring with an end the
        # cut made (the cut's shorter springs are no thinner tissue), β l between the body's own vertices, as built
        thickness = s.thickness_ratio * thickness_lengths(s.hybrid, a["springs"][rows], a["rest"][rows])
        a["stiffness"][rows] = (s.youngs_modulus * thickness * np.concatenate([area, area[two]])
                                / a["rest"][rows] ** 2)
        self.stretch_row.update(keys, rows[: len(keys)])
        self.bend_row.update(keys[two], rows[len(keys):])
        self._bind()
        self.local_masses(touched, self.mass_total)
        added = len(result.parents)
        s.inv_mass = self.spare.extend("inv_mass", s.inv_mass, np.zeros(added))
        s.inv_mass[touched] = np.where(members(touched, s.fixed), 0.0, 1.0 / s.mass[touched])
        # the explicit stability bound follows the new, smaller springs and masses
        self.gershgorin = self.spare.extend("gershgorin", self.gershgorin, np.zeros(added))
        # the rows that changed: the touched vertices' (masses, springs) and their spring neighbours' (the √(w_i w_j)
        # term); a retired spring's ends are among them (a bending spring's far end is a neighbour of its edge)
        near = self._springs_at(touched)
        self._recompute_rows(np.unique(np.concatenate([touched, s.springs[near].ravel()])))
        s.omega_max = float(np.sqrt(self.gershgorin.max()))
        s.acceleration = self.spare.extend("accel", s.acceleration, np.zeros((added, 3)))

    def _springs_at(self, vertices: np.ndarray) -> np.ndarray:
        """``(k,) int64`` the springs with an end in ``vertices`` (ascending): the stretch and bending springs of
        the edges of the triangles holding them (a bending spring's end is opposite its edge in such a triangle)."""
        triangles = self.surface.triangles
        rows = self.surface.fans.rows_holding(vertices, triangles)
        edges = touched_edges(triangles[rows], np.zeros((0, 3), dtype=np.int64))
        ids = np.concatenate([self.stretch_row.get(edges), self.bend_row.get(edges)])
        ids = np.unique(ids[ids >= 0])
        ends = self.solver.springs[ids]
        return ids[members(ends[:, 0], vertices) | members(ends[:, 1], vertices)]

    def _recompute_rows(self, vertices: np.ndarray) -> None:
        """Gershgorin row sums Σ k (w_i + √(w_i w_j)) of ``vertices`` (ascending) from their springs."""
        s, row = self.solver, self.gershgorin
        ids = self._springs_at(vertices)
        springs, stiffness, w = s.springs[ids], s.stiffness[ids], s.inv_mass
        cross = np.sqrt(w[springs[:, 0]] * w[springs[:, 1]])
        row[vertices] = 0.0
        for end in (0, 1):
            at = members(springs[:, end], vertices)
            np.add.at(row, springs[at, end], stiffness[at] * (w[springs[at, end]] + cross[at]))
        # an attachment spring to a fixed point adds k w_i to its node's row (attachments hold old vertices only)
        at = members(s.attached_nodes, vertices)
        np.add.at(row, s.attached_nodes[at], s.attached_stiffness[at] * w[s.attached_nodes[at]])
