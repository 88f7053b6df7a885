"""Cut updaters of the position-based methods (hybrid, pbd) and of the embedded baseline.

Stretch and bending constraints are edited locally (§7): every edge of a changed triangle has its constraints
retired and, if the edge still exists, made again from the new triangles around it: rest length from the parent
triangle's rest lengths (eq 19–23, :func:`~tissuesim.cutting.lengths.barycentric_distance`), the adjacent area,
and a hinge where the edge has two triangles. A hinge's rest angle is measured on the rest positions, which lie
in the parent triangles' planes: sub-triangles of one hinge keep the original hinge's angle, and two pieces of one
triangle are flat (§7). Edges that now border the cut have one triangle, so no hinge joins the two sides. The
XPBD compliances come from :mod:`tissuesim.pbd.compliance` with the new lengths and areas.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..loads import triangle_areas
from ..pbd.kernels import dihedral_angles, signed_bend_angles
from .lengths import barycentric_distance
from .remap import interpolate
from .rows import Rows
from .solver_update import SolverCut, lumped_masses, register_cut


class CutConstraints(SimpleNamespace):
    """The mutable stand-in of :class:`~tissuesim.pbd.topology.SurfaceConstraints` a cut solver steps with:
    the same array names, with retired rows as no-ops (:mod:`.rows`)."""

    @property
    def stretch_count(self) -> int:
        return len(self.edges)

    @property
    def bending_count(self) -> int:
        return len(self.bending)


def new_edge_constraints(result, old_rest, old_triangles, edge_map, keys, n):
    """Stretch data of edges ``keys`` (vertex pairs) of the cut mesh: ``(edges (k, 2), rest lengths (k,) [m],
    areas (k,) [m²])``; rest lengths by eq 19–23 in the parent triangle."""
    edges = np.array(keys, dtype=np.int64).reshape(-1, 2)
    owner = np.array([edge_map.of(k)[0] for k in keys], dtype=np.int64)
    origin = result.triangle_origin[owner]
    corners = old_triangles[origin]                                     # (k, 3) old vertex ids
    p = old_rest[corners]
    side = np.linalg.norm(p - p[:, [1, 2, 0]], axis=2)                  # l_AB, l_BC, l_CA
    bary = [_in_corners(result, edges[:, j], corners) for j in (0, 1)]
    rest = barycentric_distance(side, bary[0], bary[1])
    return edges, rest, adjacent_area(result, edge_map, keys)


def adjacent_area(result, edge_map, keys) -> np.ndarray:
    """``(k,) float64`` rest area [m²] of the (one or two) triangles around each edge of ``keys``."""
    owners = [edge_map.of(k) for k in keys]
    rows = np.array([r for o in owners for r in o], dtype=np.int64)
    area = triangle_areas(result.rest, result.triangles[rows])
    counts = np.array([len(o) for o in owners], dtype=np.int64)
    return np.add.reduceat(area, np.concatenate([[0], np.cumsum(counts)[:-1]])) if len(keys) else np.zeros(0)


def new_hinges(triangles, edge_map, keys):
    """Hinges ``(h, 4) int64`` (P1, P2 in the first triangle's winding, P3, P4 opposite) of the ``keys`` with two
    triangles, and those keys."""
    hinges, kept = [], []
    for key in keys:
        owners = edge_map.of(key)
        if len(owners) != 2:
            continue
        first, second = triangles[owners[0]], triangles[owners[1]]
        k = [i for i in range(3) if {int(first[i]), int(first[(i + 1) % 3])} == set(key)][0]
        p1, p2, p3 = first[k], first[(k + 1) % 3], first[(k + 2) % 3]
        p4 = [v for v in second if v not in key][0]
        hinges.append((p1, p2, p3, p4))
        kept.append(key)
    return np.array(hinges, dtype=np.int64).reshape(-1, 4), kept


def _in_corners(result, vertices, corners):
    """Barycentric ``(k, 3)`` of each vertex in its parent triangle ``corners`` ``(k, 3)`` (old ids)."""
    bary = np.zeros((len(vertices), 3))
    parents, weights = result.parents_of(vertices)
    for j in range(3):
        bary += (parents[:, j, None] == corners) * weights[:, j, None]
    return bary


def touched_edges(old_content, new_content):
    """Sorted vertex pairs of every edge of the old and new content of the changed triangles."""
    keys = set()
    for content in (old_content, new_content):
        for a, b, c in np.asarray(content).tolist():
            keys |= {(min(u, v), max(u, v)) for u, v in ((a, b), (b, c), (c, a))}
    return sorted(keys)


@register_cut("pbd")
class SurfaceLayerCut(SolverCut):
    """Updater of :class:`~tissuesim.solvers.pbd.SurfaceLayerSolver` (the pbd and hybrid methods)."""

    def __init__(self, solver):
        super().__init__(solver)
        c = solver.constraints
        xpbd = solver.form == "xpbd"
        self.mass_total = float(solver.mass.sum())
        stretch = {"edges": np.array(c.edges), "rest_length": np.array(c.rest_length),
                   "edge_area": np.array(c.edge_area)}
        bend = {"bending": np.array(c.bending), "rest_angle": np.array(c.rest_angle),
                "rest_signed_angle": np.array(c.rest_signed_angle), "hinge_area": np.array(c.hinge_area)}
        if xpbd:
            stretch.update(compliance=np.array(solver.stretch_compliance), multiplier=solver._lambda_stretch)
            bend.update(compliance=np.array(solver.bend_compliance), multiplier=solver._lambda_bend)
        self.stretch = Rows(stretch, len(c.edges), {"edges": 0, "rest_length": 1.0, "edge_area": 1.0,
                                                     "compliance": 1.0, "multiplier": 0.0})
        self.bend = Rows(bend, len(c.bending), {"bending": 0, "rest_angle": np.pi, "rest_signed_angle": 0.0,
                                                "hinge_area": 1.0, "compliance": 1.0, "multiplier": 0.0})
        edges = c.edges.astype(np.int64)
        self.stretch_row = {(int(min(u, v)), int(max(u, v))): r for r, (u, v) in enumerate(edges.tolist())}
        hinge_edges = edges[c.hinge_edge]
        self.hinge_row = {(int(min(u, v)), int(max(u, v))): r for r, (u, v) in enumerate(hinge_edges.tolist())}
        self._bind()

    def _bind(self) -> None:
        """Point the solver at the (possibly reallocated) arrays; the kernels read them from there."""
        s, a, b = self.solver, self.stretch.arrays, self.bend.arrays
        s.constraints = CutConstraints(vertex_count=len(s.rest_positions), edges=a["edges"],
                                       rest_length=a["rest_length"], edge_area=a["edge_area"],
                                       bending=b["bending"], rest_angle=b["rest_angle"],
                                       rest_signed_angle=b["rest_signed_angle"], hinge_area=b["hinge_area"])
        s._rest_angle = b["rest_signed_angle"] if s.signed_bending else b["rest_angle"]
        if s.form == "xpbd":
            s.stretch_compliance, s._lambda_stretch = a["compliance"], a["multiplier"]
            s.bend_compliance, s._lambda_bend = b["compliance"], b["multiplier"]

    def update(self, result, n, old_triangles, old_content, released) -> None:
        s = self.solver
        old_rest = result.rest[:n]
        old_triangles = np.asarray(old_triangles, dtype=np.int64)
        keys = touched_edges(old_content, result.triangles[result.changed])
        self._retire(keys)
        live = [k for k in keys if self.edges.of(k)]
        edges, rest, area = new_edge_constraints(result, old_rest, old_triangles, self.edges, live, n)
        rows, _ = self.stretch.take(len(live))
        a = self.stretch.arrays
        a["edges"][rows], a["rest_length"][rows], a["edge_area"][rows] = edges, rest, area
        hinges, hinge_keys = new_hinges(result.triangles, self.edges, live)
        hrows, _ = self.bend.take(len(hinge_keys))
        b = self.bend.arrays
        b["bending"][hrows] = hinges
        b["rest_angle"][hrows] = dihedral_angles(result.rest, hinges.astype(np.int32))
        b["rest_signed_angle"][hrows] = signed_bend_angles(result.rest, hinges.astype(np.int32))
        b["hinge_area"][hrows] = adjacent_area(result, self.edges, hinge_keys)
        self.stretch_row.update(zip(live, rows.tolist()))
        self.hinge_row.update(zip(hinge_keys, hrows.tolist()))
        if s.form == "xpbd":
            self._compliance(rows, hrows)
        self._bind()
        s.mass = lumped_masses(self.lumped, self.mass_total)
        s._predicted = np.zeros_like(s.state.positions)
        self.prescribe(result, n, released)

    def _retire(self, keys) -> None:
        gone = [self.stretch_row.pop(k) for k in keys if k in self.stretch_row]
        self.stretch.retire(gone)
        gone = [self.hinge_row.pop(k) for k in keys if k in self.hinge_row]
        self.bend.retire(gone)

    def _compliance(self, rows, hrows) -> None:
        """XPBD compliance of the new rows from the material, with their own rest lengths and areas."""
        from ..pbd.compliance import relative_shell_compliance

        s, a, b = self.solver, self.stretch.arrays, self.bend.arrays
        hinge_length = np.linalg.norm(s.rest_positions[b["bending"][hrows, 0]]
                                      - s.rest_positions[b["bending"][hrows, 1]], axis=1)
        # the new stretch rows, then the hinges' edges as extra rows that the hinges point at
        new = SimpleNamespace(rest_length=np.concatenate([a["rest_length"][rows], hinge_length]),
                              edge_area=np.concatenate([a["edge_area"][rows], np.ones(len(hrows))]),
                              hinge_edge=np.arange(len(rows), len(rows) + len(hrows)),
                              hinge_area=b["hinge_area"][hrows])
        stretch, bend = relative_shell_compliance(new, youngs_modulus=s.youngs_modulus,
                                                  poisson_ratio=s.poisson_ratio, thickness_ratio=s.thickness_ratio)
        a["compliance"][rows] = stretch[: len(rows)]
        b["compliance"][hrows] = bend

    def prescribe(self, result, n, released) -> None:
        """pbd: the fixed nodes; the hybrid overrides this."""
        self.solver._set_prescribed(self.solver.fixed)


@register_cut("hybrid")
class HybridCut(SurfaceLayerCut):
    """The hybrid's extra arrays: control nodes (released ones dropped), load map, embedding for warm start."""

    def held_nodes(self, result, fixed, released):
        control = np.setdiff1d(self.solver.hybrid.control, released)
        return np.concatenate([np.asarray(fixed, dtype=np.int64), control.astype(np.int64)])

    def prescribe(self, result, n, released) -> None:
        s, h = self.solver, self.solver.hybrid
        control = np.asarray(h.control, dtype=np.int64)
        control_volume = np.asarray(h.control_volume, dtype=np.int64)
        if released.size:
            rest_nodes = s.output_nodes[~np.isin(s.output_nodes, control_volume)]
            s.output_nodes = np.concatenate([control_volume, rest_nodes]).astype(np.int64)
            s._slot[:] = -1
            s._slot[s.output_nodes] = np.arange(s.output_nodes.size)
            s._u = np.zeros((s.output_nodes.size, 3))
            s.control_displacement = s._u[: control.size]
        s.control, s.control_count = control, control.size
        is_control = np.zeros(len(s.rest_positions), dtype=bool)
        is_control[control] = True
        pinned = s.fixed[~is_control[s.fixed]].astype(np.int64)
        s._set_prescribed(np.concatenate([control, pinned]))
        coarse_nodes = np.asarray(h.coarse_surface.triangles, dtype=np.int64)
        s.load_volume_nodes = np.asarray(h.coarse_volume_nodes, dtype=np.int64)[coarse_nodes[h.coarse_triangle]]
        s.load_weights = np.asarray(h.coarse_barycentric, dtype=np.float64)
        s._tet_of = np.ascontiguousarray(h.embedding_tet, dtype=np.int64)
        s._weights = np.ascontiguousarray(h.embedding_barycentric, dtype=np.float64)
        s._embedded = interpolate(s._embedded, result, n)
        s._embedded_new = np.array(s._embedded)
        s._delta = np.zeros_like(s._embedded)
        s._dirty = True


@register_cut("embedded")
class EmbeddedCut(SolverCut):
    """The embedded baseline: every new vertex rides on its tet, so both sides of a cut move together."""

    keeps_loose = True

    def update(self, result, n, old_triangles, old_content, released) -> None:
        s, h = self.solver, self.solver.hybrid
        s.tet_of = np.ascontiguousarray(h.embedding_tet, dtype=np.int64)
        s.weights = np.ascontiguousarray(h.embedding_barycentric, dtype=np.float64)
        s._dirty = True

