"""Cut updaters of the position-based methods (hybrid, pbd) and of the embedded baseline.

Stretch and bending constraints are edited locally (§7): every edge of a changed triangle has its constraints
retired and, if the edge still exists, made again from the new triangles around it: rest length from the parent
triangle's rest lengths (eq 19–23, :func:`~tissuesim.cutting.lengths.barycentric_distance`), the adjacent area,
and a hinge where the edge has two triangles. A hinge's rest angle is measured on the rest positions, which lie
in the parent triangles' planes: sub-triangles of one hinge keep the original hinge's angle, and two pieces of one
triangle are flat (§7). Edges that now border the cut have one triangle, so no hinge joins the two sides. The
XPBD compliances come from :mod:`tissuesim.layer.compliance` with the new lengths and areas, and the layer's thickness
as built (β × M_S's mean edge length at build) on every row with an end the cut made: a cut does not thin the
tissue, and a thickness that followed the new, shorter edges would soften their hinges by the cube of the ratio (a
flap beside a cut then swung metres away). A row between two of the body's own vertices keeps β × its own length,
as built (:func:`~tissuesim.layer.compliance.thickness_lengths`, the rule a solver built on the cut mesh reads too).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from ..cutting.lengths import barycentric_distance
from ..cutting.rows import EdgeRows, Rows
from ..layer.rest_measures import dihedral_angles, signed_bend_angles
from ..layer.topology import ConstraintCounts
from ..loads import triangle_areas
from .cut_carry import SolverCut, members

if TYPE_CHECKING:
    from ..cutting.result import CutResult
    from .surface_layer import SurfaceLayerSolver


class CutConstraints(ConstraintCounts, SimpleNamespace):
    """The mutable stand-in of :class:`~tissuesim.layer.topology.SurfaceConstraints` a cut solver steps with:
    the same array names, with retired rows as no-ops (:mod:`.rows`)."""


def new_edge_constraints(result: CutResult, keys: np.ndarray, owners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stretch data of the edges ``keys`` ``(k, 2)`` of the cut mesh, held by rows ``owners`` ``(k, 2)`` (−1 for
    none; each has a first): ``(rest lengths (k,) [m], areas (k,) [m²])``; rest lengths by eq 19–23 in the parent
    triangle of the first owner."""
    corners = result.before(result.origin_of(owners[:, 0]))           # (k, 3) old vertex ids
    p = result.rest[corners]
    side = np.linalg.norm(p - p[:, [1, 2, 0]], axis=2)                  # l_AB, l_BC, l_CA
    bary = [_in_corners(result, keys[:, j], corners) for j in (0, 1)]
    return barycentric_distance(side, bary[0], bary[1]), adjacent_area(result, owners)


def adjacent_area(result: CutResult, owners: np.ndarray) -> np.ndarray:
    """``(k,) float64`` rest area [m²] of the (one or two) triangles ``owners`` ``(k, 2)`` (−1 for none) around
    each edge."""
    area = triangle_areas(result.rest, result.triangles[np.maximum(owners, 0).ravel()]).reshape(-1, 2)
    return np.where(owners >= 0, area, 0.0).sum(axis=1)


def new_hinges(triangles: np.ndarray, keys: np.ndarray, owners: np.ndarray) -> np.ndarray:
    """Hinges ``(h, 4) int64`` (P1, P2 in the first triangle's winding, P3, P4 opposite) of edges ``keys``
    ``(h, 2)`` held by two rows ``owners`` ``(h, 2)``."""
    first, second = (triangles[owners[:, j]].astype(np.int64) for j in (0, 1))
    ends = keys.sum(axis=1)
    p3, p4 = first.sum(axis=1) - ends, second.sum(axis=1) - ends       # the corner off the edge in each
    k = (np.argmax(first == p3[:, None], axis=1) + 1) % 3               # the edge is (first[k], first[k + 1])
    rows = np.arange(len(keys))
    return np.stack([first[rows, k], first[rows, (k + 1) % 3], p3, p4], axis=1)


def _new_of(sorted_nodes: np.ndarray, n: int) -> np.ndarray:
    """``(k,) int64`` the entries ≥ n of the ascending ``sorted_nodes`` (the vertices a cut added to them)."""
    return np.asarray(sorted_nodes[np.searchsorted(sorted_nodes, n):], dtype=np.int64)


def _in_corners(result, vertices, corners):
    """Barycentric ``(k, 3)`` of each vertex in its parent triangle ``corners`` ``(k, 3)`` (old ids)."""
    bary = np.zeros((len(vertices), 3))
    parents, weights = result.parents_of(vertices)
    for j in range(3):
        bary += (parents[:, j, None] == corners) * weights[:, j, None]
    return bary


class SurfaceLayerCut(SolverCut):
    """Updater of :class:`~tissuesim.solvers.surface_layer.SurfaceLayerSolver` (the pbd and hybrid methods)."""

    def __init__(self, solver: SurfaceLayerSolver):
        super().__init__(solver)
        c = solver.constraints
        xpbd = solver.form == "xpbd"
        self.mass_total = float(solver.mass.sum())
        stretch = {"edges": np.array(c.edges), "rest_length": np.array(c.rest_length),
                   "edge_area": np.array(c.edge_area)}
        bend = {"bending": np.array(c.bending), "rest_angle": np.array(c.rest_angle),
                "rest_signed_angle": np.array(c.rest_signed_angle), "hinge_area": np.array(c.hinge_area)}
        if xpbd:
            stretch.update(compliance=np.array(solver.stretch_compliance), multiplier=solver.stretch_multipliers)
            bend.update(compliance=np.array(solver.bend_compliance), multiplier=solver.bend_multipliers)
        self.stretch = Rows(stretch, len(c.edges), {"edges": 0, "rest_length": 1.0, "edge_area": 1.0,
                                                     "compliance": 1.0, "multiplier": 0.0})
        self.bend = Rows(bend, len(c.bending), {"bending": 0, "rest_angle": np.pi, "rest_signed_angle": 0.0,
                                                "hinge_area": 1.0, "compliance": 1.0, "multiplier": 0.0})
        edges = c.edges.astype(np.int64)
        self.stretch_row = EdgeRows(edges, np.arange(len(edges)))
        hinge_edges = edges[c.hinge_edge]
        self.hinge_row = EdgeRows(hinge_edges, np.arange(len(hinge_edges)))
        self._bind()

    def _bind(self) -> None:
        """Point the solver at the (possibly reallocated) arrays; the kernels read them from there."""
        s, a, b = self.solver, self.stretch.arrays, self.bend.arrays
        s.constraints = CutConstraints(vertex_count=len(s.rest_positions), edges=a["edges"],
                                       rest_length=a["rest_length"], edge_area=a["edge_area"],
                                       bending=b["bending"], rest_angle=b["rest_angle"],
                                       rest_signed_angle=b["rest_signed_angle"], hinge_area=b["hinge_area"])
        s.rest_angle = b["rest_signed_angle"] if s.signed_bending else b["rest_angle"]
        if s.form == "xpbd":
            s.stretch_compliance, s.stretch_multipliers = a["compliance"], a["multiplier"]
            s.bend_compliance, s.bend_multipliers = b["compliance"], b["multiplier"]

    def update(self, result: CutResult, n: int, released: np.ndarray, touched: np.ndarray) -> None:
        s = self.solver
        keys, owners = self.touched_edges(result)
        retired = self.stretch_row.pop(keys), self.hinge_row.pop(keys)
        with result.rest_before_moves():        # what the factor holds: the rows at the rest before the cut
            removed = self._stiffness_of(*retired)
        self.stretch.retire(retired[0])
        self.bend.retire(retired[1])
        live = owners[:, 0] >= 0
        keys, owners = keys[live], owners[live]
        rest, area = new_edge_constraints(result, keys, owners)
        rows, _ = self.stretch.take(len(keys))
        a = self.stretch.arrays
        a["edges"][rows], a["rest_length"][rows], a["edge_area"][rows] = keys, rest, area
        two = owners[:, 1] >= 0
        hinges = new_hinges(result.triangles, keys[two], owners[two])
        hrows, _ = self.bend.take(len(hinges))
        b = self.bend.arrays
        b["bending"][hrows] = hinges
        b["rest_angle"][hrows] = dihedral_angles(result.rest, hinges.astype(np.int32))
        b["rest_signed_angle"][hrows] = signed_bend_angles(result.rest, hinges.astype(np.int32))
        b["hinge_area"][hrows] = area[two]
        self.stretch_row.update(keys, rows)
        self.hinge_row.update(keys[two], hrows)
        if s.form == "xpbd":
            self._compliance(rows, hrows)
        self._bind()
        self.local_masses(touched, self.mass_total)
        added = len(result.parents)
        s.predicted = self.spare.extend("predicted", s.predicted, np.zeros((added, 3)))
        statics, s.built_statics = s.built_statics, None
        self.prescribe(result, n, released, touched)
        s.inv_mass = self.spare.extend("inv_mass", s.inv_mass, np.zeros(added))
        s.inv_mass[touched] = np.where(self.is_prescribed[touched], 0.0, 1.0 / s.mass[touched])
        if removed is not None and statics is not None:
            # the linear layer's step goes on with its factor and a correction (layer/cut_statics.py); where that
            # does not apply, the layer is factorised again when next needed
            from ..layer.cut_statics import after_cut

            s.built_statics = after_cut(statics, change=self._stiffness_of(rows, hrows) - removed, mass=s.mass,
                                   prescribed=s.prescribed)

    def prepare(self) -> None:
        """The linear layer's explicit factor for its first cut, built in the background from now."""
        super().prepare()
        s = self.solver
        if s.form == "xpbd" and s.material == "linear":
            from ..layer.cut_statics import prepare

            prepare(s.built_statics)

    def _stiffness_of(self, rows, hinge_rows):
        """``(3n, 3n)`` the linear layer's stiffness [N/m] of these stretch and hinge rows (None where the layer
        has no linear stiffness: the pbd form, a finite-strain material)."""
        s = self.solver
        if s.form != "xpbd" or s.material != "linear":
            return None
        from ..layer.static import layer_stiffness

        a, b = self.stretch.arrays, self.bend.arrays
        rows, hinge_rows = np.asarray(rows, dtype=np.int64), np.asarray(hinge_rows, dtype=np.int64)
        return layer_stiffness(s.rest_positions, edges=a["edges"][rows], stretch_compliance=a["compliance"][rows],
                               hinges=b["bending"][hinge_rows], bend_compliance=b["compliance"][hinge_rows],
                               signed_bending=s.signed_bending)

    def _compliance(self, rows, hrows) -> None:
        """XPBD compliance of the new rows from the material, with their own rest lengths and areas and the
        body's thickness (:func:`~tissuesim.layer.compliance.thickness_lengths`), not one that shrinks with the cut's
        shorter edges."""
        from ..layer.compliance import relative_shell_compliance, thickness_lengths

        s, a, b = self.solver, self.stretch.arrays, self.bend.arrays
        hinge_length = np.linalg.norm(s.rest_positions[b["bending"][hrows, 0]]
                                      - s.rest_positions[b["bending"][hrows, 1]], axis=1)
        # the new stretch rows, then the hinges' edges as extra rows that the hinges point at
        ends = np.concatenate([a["edges"][rows], b["bending"][hrows, :2]])
        new = SimpleNamespace(rest_length=np.concatenate([a["rest_length"][rows], hinge_length]),
                              edge_area=np.concatenate([a["edge_area"][rows], np.ones(len(hrows))]),
                              hinge_edge=np.arange(len(rows), len(rows) + len(hrows)),
                              hinge_area=b["hinge_area"][hrows])
        stretch, bend = relative_shell_compliance(new, youngs_modulus=s.youngs_modulus,
                                                  poisson_ratio=s.poisson_ratio, thickness_ratio=s.thickness_ratio,
                                                  thickness_length=thickness_lengths(s.hybrid, ends, new.rest_length))
        a["compliance"][rows] = stretch[: len(rows)]
        b["compliance"][hrows] = bend

    @property
    def is_prescribed(self) -> np.ndarray:
        """``(n,) bool`` whether each vertex is prescribed (kept per cut: new vertices appended, changes set)."""
        s = self.solver
        mask = getattr(self, "prescribed_mask", None)
        if mask is None:
            mask = np.zeros(len(s.rest_positions), dtype=bool)
            mask[s.prescribed] = True
        elif len(mask) < len(s.rest_positions):
            mask = self.spare.extend("is_prescribed", mask, np.zeros(len(s.rest_positions) - len(mask), bool))
        self.prescribed_mask = mask
        return mask

    def prescribe_more(self, nodes: np.ndarray) -> None:
        """Prescribe new vertices ``nodes`` too (at rest), after the ones already prescribed."""
        s = self.solver
        if nodes.size:
            s.prescribed = self.spare.extend("prescribed", s.prescribed, nodes.astype(np.int64))
            s.targets = self.spare.extend("targets", s.targets, s.rest_positions[nodes])
            self.is_prescribed[nodes] = True

    def prescribe(self, result: CutResult, n: int, released: np.ndarray, touched: np.ndarray) -> None:
        """pbd: the fixed nodes (the new vertices that are fixed are appended); the hybrid overrides this."""
        s = self.solver
        self.prescribe_more(_new_of(s.fixed, n))


class HybridCut(SurfaceLayerCut):
    """The hybrid's extra arrays: control nodes (released ones dropped), load map, embedding for warm start."""

    def held_nodes(self) -> np.ndarray:
        """The fixed and attached nodes, then the control nodes (ascending)."""
        control = np.unique(self.solver.hybrid.control)
        return np.concatenate([super().held_nodes(), control.astype(np.int64)])

    def prescribe(self, result: CutResult, n: int, released: np.ndarray, touched: np.ndarray) -> None:
        s, h, spare = self.solver, self.solver.hybrid, self.spare
        if s.element == "quadratic":
            self._free_cut(touched, released)
            s.quadratic_field = s.quadratic_field.extended(h, result.moved)
        elif released.size:
            self._release(released, n)
        else:
            self.prescribe_more(_new_of(s.fixed, n))
        new = slice(n, None)
        coarse_nodes = np.asarray(h.coarse_surface.triangles, dtype=np.int64)
        volume_nodes = np.asarray(h.coarse_volume_nodes, dtype=np.int64)[coarse_nodes[h.coarse_triangle[new]]]
        s.load_volume_nodes = spare.extend("load_volume_nodes", s.load_volume_nodes, volume_nodes)
        s.load_weights = h.coarse_barycentric
        s.embedding_tet = spare.extend("tet_of", s.embedding_tet, h.embedding_tet[new].astype(np.int64))
        s.embedding_weights = h.embedding_barycentric
        spare.rewrite(s.warm_positions, result.moved, result.moves.values(s.warm_positions))     # with their rest
        embedded = result.interpolate(s.warm_positions)
        s.warm_positions = spare.extend("embedded", s.warm_positions, embedded)
        s.warm_target = spare.extend("embedded_new", s.warm_target, embedded)
        s.warm_delta = spare.extend("delta", s.warm_delta, np.zeros_like(embedded))
        s.volume_stale = True

    def _free_cut(self, touched, released) -> None:
        """The quadratic M_V prescribes every vertex but those of the triangles a cut changed (M_V is not cut, so
        only the layer lets the lips part) and where the support holds them; the control nodes on the cut leave
        the control list, as the paper's M_V's do."""
        s = self.solver
        if released.size:
            s.control = s.control[np.isin(s.control, released, invert=True)]
            s.control_count = s.control.size
            s.control_displacement = s.output_displacement[: s.control_count]
        mask = self.is_prescribed
        mask[touched] = False
        mask[s.fixed] = True
        s.prescribed = np.flatnonzero(mask)
        s.targets = np.array(s.rest_positions[s.prescribed])

    def _release(self, released, n) -> None:
        """Control nodes ``released`` (and their copies) are no longer prescribed. The lists keep their order (the
        kept control nodes first, then the pinned fixed nodes ascending) and are edited, not rebuilt with set
        operations over the whole mesh: only the moves that release nodes pay this, O(prescribed) copies."""
        s = self.solver
        kept = np.isin(s.control, released, invert=True)
        count = s.control_count
        # the control part of the output nodes is the control nodes' M_V nodes, in the same order
        s.output_nodes = np.concatenate([s.output_nodes[:count][kept], s.output_nodes[:count][~kept],
                                         s.output_nodes[count:]])
        s.output_slot[s.output_nodes] = np.arange(s.output_nodes.size)      # the same nodes, reordered
        s.output_displacement = np.zeros((s.output_nodes.size, 3))
        control = s.control[kept]
        s.control_displacement = s.output_displacement[: control.size]
        s.control, s.control_count = control, control.size
        # pinned: the fixed nodes off the control list, with the released fixed ones and this cut's new fixed ones
        fixed = np.asarray(s.fixed, dtype=np.int64)
        pinned = s.prescribed[count:]
        freed = np.sort(released[members(released, fixed)])
        pinned = np.concatenate([np.insert(pinned, np.searchsorted(pinned, freed), freed), _new_of(fixed, n)])
        s.prescribed = np.concatenate([control, pinned])
        s.targets = np.array(s.rest_positions[s.prescribed])
        mask = self.is_prescribed
        mask[released] = False
        mask[s.prescribed] = True


class EmbeddedCut(SolverCut):
    """The embedded baseline: every new vertex rides on its tet, so both sides of a cut move together."""

    keeps_loose = True

    def update(self, result: CutResult, n: int, released: np.ndarray, touched: np.ndarray) -> None:
        s, h = self.solver, self.solver.hybrid
        s.tet_of = self.spare.extend("tet_of", s.tet_of, h.embedding_tet[n:].astype(np.int64))
        s.weights = h.embedding_barycentric
        s.volume_stale = True

