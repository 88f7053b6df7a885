"""§7 on arrays: one cut of the fine surface M_S by one sweep of the blade, returning a new surface and maps.

:func:`cut_surface` runs the three steps of §7 on plain arrays and leaves its inputs untouched:

1. the sweep's crossings with the triangles at their current positions (:mod:`.sweep`), snapped, become edge points
   (keyed by their edge, so both triangles of an edge share the point) and facet points;
2. every triangle with a crossing segment or an edge point on a side is split by the case of Fig 7 that fits
   (:mod:`.subdivide`), in the plane of its rest triangle; the first piece keeps the triangle's row, the others
   are appended;
3. the vertices along the cut edges are duplicated per side (:mod:`.separate`).

A new vertex's rest position, current position and velocity are the same barycentric combination of its parent
triangle's (or edge's) corners (§7, Fig 8): the cut does not move anything. ``parents`` / ``weights`` give that
combination for every vertex of the result, in the numbering before the cut; old vertices keep their indices.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import MeshError
from .fans import RowPatch, VertexFans
from .separate import rows_touching, separate
from .subdivide import split_full_cut, split_interior_cut, split_partial_cut, split_uncut
from .sweep import Sweep, candidate_triangles, check_snap, crossings

#: Default snap fraction of the local edge length (see :mod:`.sweep`).
DEFAULT_SNAP = 0.25
#: A new point is snapped further (facet → edge → vertex) while it would make a piece of lower quality than this
#: (4√3 A / Σ l², at rest) in the triangle it lies in: twice the invariants' floor, so later cuts have room.
GUARD_QUALITY = 0.02


@dataclass(frozen=True, eq=False)
class CutResult:
    """A cut surface and how it relates to the one before.

    Attributes:
        rest: ``(n', 3) float64`` rest positions [m]; the first n rows are the old ones.
        positions: ``(n', 3) float64`` current positions [m].
        velocities: ``(n', 3) float64`` current velocities [m/s].
        triangles: ``(m', 3) int32`` triangles; the first m rows are the old rows (rewritten where split or
            where a corner became a copy).
        old_count: n, the vertex count before the cut.
        parents: ``(n' − n, 3) int64`` old vertices each new vertex n + i interpolates (row i).
        weights: ``(n' − n, 3) float64`` their barycentric weights (sum 1).
        new_copy_of: ``(n' − n,) int64`` for each new vertex n + i, the vertex (new numbering) it duplicates, −1 for
            an inserted point (:attr:`copy_of` is the same over all vertices).
        new_origin: ``(m' − m,) int64`` the old triangle each appended row lies in (:attr:`triangle_origin` is the
            same over all rows).
        changed: ``(k,) int64`` rows of ``triangles`` that are new or rewritten.
        replaced: ``(r, 3) int64`` the content before the cut of the rewritten old rows ``changed[changed < m]``.
        cut_edges: ``(c, 2) int64`` the edges cut by this move (vertex pairs, before duplication).
        closed: ``(p, 2) int64`` cut edges still shared by two triangles (a cut's tips), to pass to the next cut.
        split_count: old triangles split.
        end_vertex: the cut point farthest along the sweep (where the cut stopped), −1 if none; a progressive
            cut starts its next sweep there so the wound stays one path.
    """

    rest: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    triangles: np.ndarray
    old_count: int
    parents: np.ndarray
    weights: np.ndarray
    new_copy_of: np.ndarray
    new_origin: np.ndarray
    changed: np.ndarray
    replaced: np.ndarray
    cut_edges: np.ndarray
    closed: np.ndarray
    split_count: int
    end_vertex: int = -1

    @property
    def old_triangle_count(self) -> int:
        """m, the triangle count before the cut."""
        return len(self.triangles) - len(self.new_origin)

    @property
    def copy_of(self) -> np.ndarray:
        """``(n',) int64`` the vertex (new numbering) a duplicate copies, −1 for the others (a new array)."""
        return np.concatenate([np.full(self.old_count, -1, dtype=np.int64), self.new_copy_of])

    @property
    def triangle_origin(self) -> np.ndarray:
        """``(m',) int64`` the old triangle each triangle lies in (a new array)."""
        return np.concatenate([np.arange(self.old_triangle_count), self.new_origin])

    def origin_of(self, rows: np.ndarray) -> np.ndarray:
        """``(k,) int64`` the old triangle each of ``rows`` lies in."""
        rows = np.asarray(rows, dtype=np.int64)
        m = self.old_triangle_count
        origin = rows.copy()
        origin[rows >= m] = self.new_origin[rows[rows >= m] - m]
        return origin

    def before(self, rows: np.ndarray) -> np.ndarray:
        """``(k, 3) int64`` the content before the cut of old rows ``rows``."""
        rows = np.asarray(rows, dtype=np.int64)
        content = np.array(self.triangles[rows], dtype=np.int64)
        old = self.changed[self.changed < self.old_triangle_count]
        where = np.searchsorted(old, rows)
        hit = where < old.size
        hit[hit] = old[where[hit]] == rows[hit]
        content[hit] = self.replaced[where[hit]]
        return content

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """``(n' − n, ...)`` per-vertex ``values`` ``(n, ...)`` at the new vertices (their parents' mix)."""
        return _mix(self.weights, self.parents, values)

    def parents_of(self, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(parents (k, 3) int64, weights (k, 3))`` of any ``vertices`` (an old vertex is its own parent)."""
        vertices = np.asarray(vertices, dtype=np.int64)
        parents = np.repeat(vertices[:, None], 3, axis=1)
        weights = np.zeros((len(vertices), 3))
        weights[:, 0] = 1.0
        new = vertices >= self.old_count
        parents[new] = self.parents[vertices[new] - self.old_count]
        weights[new] = self.weights[vertices[new] - self.old_count]
        return parents, weights

    @property
    def duplicated(self) -> np.ndarray:
        """``(d,) int64`` vertices (new numbering) that got a copy."""
        return np.unique(self.new_copy_of[self.new_copy_of >= 0])


@dataclass
class _Points:
    """The cut points of one move: existing vertices, edge points (per edge), facet points (per triangle)."""

    n: int
    snap: float
    rest: np.ndarray                              # (n, 3) rest positions: the quality guard measures there
    now: np.ndarray | None = None                 # (n, 3) current positions: and there
    patch: RowPatch | None = None                 # the rows, for the triangles of an edge
    edge: dict = field(default_factory=dict)      # (lo, hi) -> list of [t from lo, id]
    facet: dict = field(default_factory=dict)     # triangle -> list of [weights (3,), id]
    parents: list = field(default_factory=list)   # per new point: (3,) vertex ids
    weights: list = field(default_factory=list)   # per new point: (3,) weights

    def locate(self, corners: np.ndarray, triangle: int, w: np.ndarray) -> tuple:
        """Snap barycentric ``w`` in a triangle with vertex ids ``corners``: ``("v", id)``, ``("e", lo, hi, t)`` (t
        from lo) or ``("f", triangle, weights)``; nothing is registered yet."""
        w = np.where(w < self.snap, 0.0, w)
        w = np.array(self._guard(corners.tolist(), (w / w.sum()).tolist()))
        nonzero = np.flatnonzero(w)
        if nonzero.size == 1:
            return ("v", int(corners[nonzero[0]]))
        if nonzero.size == 2:
            i, j = corners[nonzero]
            lo, hi = (int(i), int(j)) if i < j else (int(j), int(i))
            t = float(w[nonzero[1]] if j == hi else w[nonzero[0]])
            if t < self.snap:
                return ("v", lo)
            if t > 1.0 - self.snap:
                return ("v", hi)
            return ("e", lo, hi, t)
        return ("f", triangle, w)

    def _guard(self, corners: list, w: list) -> list:
        """Snap further while a piece the point would make in this triangle falls below :data:`GUARD_QUALITY` at
        rest or at the current positions (a cut on a deformed surface): a facet point onto the edge of its worst
        piece, an edge point onto the nearer end (repeated re-cuts would otherwise thin the triangles step by step).
        Plain floats: a handful of 3-vectors, where array calls would cost more than the arithmetic."""
        while sum(x != 0.0 for x in w) > 1:
            inside = [i for i in range(3) if w[i] != 0.0]
            quality = [min(q) for q in zip(*(self._piece_quality(corners, w, inside, where)
                                            for where in (self.rest, self.now) if where is not None))]
            if min(quality) >= GUARD_QUALITY:
                break
            if len(inside) == 3:
                worst = quality.index(min(quality))
                w[(worst + 2) % 3] = 0.0                # onto the worst piece's edge (worst, worst + 1)
            else:
                i, j = inside
                w[i if w[i] < w[j] else j] = 0.0        # onto the nearer end
            total = sum(w)
            w = [x / total for x in w]
        return w

    def _piece_quality(self, corners, w, inside, where) -> list:
        """Qualities of the pieces a point at barycentric ``w`` would make, with vertices at ``where`` ``(n, 3)``:
        three in its triangle for a facet point (piece i on edge (i, i + 1)), two per triangle of its edge for an edge
        point (the neighbour gets the point too, Fig 7(a))."""
        p = where[corners].tolist()
        x = [w[0] * p[0][k] + w[1] * p[1][k] + w[2] * p[2][k] for k in range(3)]
        if len(inside) == 3:
            return [_quality3(x, p[i], p[(i + 1) % 3]) for i in range(3)]
        i, j = inside
        lo, hi = sorted((corners[i], corners[j]))
        others = [o for r in self.patch.owners(lo, hi) for o in self.patch.row_list(r) if o not in (lo, hi)]
        others = others or [corners[3 - i - j]]
        return [_quality3(x, p[e], where[o].tolist()) for o in others for e in (i, j)]

    def same(self, a: tuple, b: tuple) -> bool:
        """Whether two located points are one point after snapping (then the segment between them is dropped)."""
        if a[0] != b[0]:
            return False
        if a[0] == "v":
            return a[1] == b[1]
        if a[0] == "e":
            return a[1:3] == b[1:3] and abs(a[3] - b[3]) < self.snap
        return a[1] == b[1] and bool(np.all(np.abs(a[2] - b[2]) < self.snap))

    def commit(self, corners: np.ndarray, point: tuple) -> int:
        """The vertex id of a located point, registering a new edge or facet point (or reusing a near one)."""
        if point[0] == "v":
            return point[1]
        if point[0] == "e":
            _, lo, hi, t = point
            for existing, pid in self.edge.get((lo, hi), []):
                if abs(existing - t) < self.snap:
                    return pid
            pid = self._new(np.array([lo, hi, lo]), np.array([1.0 - t, t, 0.0]))
            self.edge.setdefault((lo, hi), []).append([t, pid])
            return pid
        _, triangle, w = point
        for existing, pid in self.facet.get(triangle, []):
            if np.all(np.abs(existing - w) < self.snap):
                return pid
        pid = self._new(corners, w)
        self.facet.setdefault(triangle, []).append([w, pid])
        return pid

    def _new(self, parents, weights) -> int:
        self.parents.append(np.asarray(parents, dtype=np.int64))
        self.weights.append(np.asarray(weights, dtype=np.float64))
        return self.n + len(self.parents) - 1


def cut_surface(rest: np.ndarray, positions: np.ndarray, velocities: np.ndarray, triangles: np.ndarray,
                sweep: Sweep, *, snap: float = DEFAULT_SNAP, closed=()) -> CutResult | None:
    """Cut M_S along one sweep; None when the sweep crosses no triangle (nothing changes).

    Returns new arrays (O(n + m) copies, and one pass over the triangles to find the sweep's): for a cut every frame
    use :class:`~tissuesim.cutting.buffers.CutSurface`, which edits capacity buffers in place.

    Args:
        rest, positions, velocities: ``(n, 3) float64`` rest positions [m], current positions [m] (the sweep is
            intersected with these), velocities [m/s].
        triangles: ``(m, 3) int`` triangles, counter-clockwise from outside.
        sweep: the blade's sweep in this move.
        snap: snap fraction of the local edge length, in [0, 1/3).
        closed: ``(p, 2)`` cut edges of earlier moves still shared by two triangles (:attr:`CutResult.closed`),
            so a cut that goes on from its tip opens there.

    Raises:
        MeshError: a cut segment could not be made an edge (a defect of the input mesh, e.g. a degenerate
            triangle); the inputs are unchanged.
    """
    snap = check_snap(snap)
    triangles = np.asarray(triangles, dtype=np.int32)      # no copy for a SurfaceMesh's triangles
    near = candidate_triangles(positions, triangles, sweep)
    # the fans of every vertex the cut can touch: the candidates' corners and the earlier tips' ends
    marked = np.zeros(len(rest), dtype=np.bool_)
    marked[triangles[near].ravel()] = True
    marked[np.asarray(closed, dtype=np.int64).ravel()] = True
    rows = rows_touching(triangles, marked)
    plan = plan_cut(rest, positions, triangles, sweep, snap=snap, closed=closed,
                    fans=VertexFans(triangles[rows], len(rest), rows=rows), near=near)
    if plan is None:
        return None
    new_rest, new_pos, new_vel = (np.concatenate([a, plan.interpolate(a)]) for a in (rest, positions, velocities))
    out = triangles.copy()
    for r, content in plan.patch.edited.items():
        out[r] = content
    out = np.concatenate([out, np.array(plan.patch.added, dtype=np.int32).reshape(-1, 3)])
    return plan.result(new_rest, new_pos, new_vel, out, sweep)


@dataclass
class CutPlan:
    """What one cut changes, before any array is written: new vertices by their parents, and the rows edited on a
    :class:`~tissuesim.cutting.fans.RowPatch`. :func:`cut_surface` and
    :class:`~tissuesim.cutting.buffers.CutSurface` apply it, to new arrays or in place."""

    old_count: int
    parents: np.ndarray             # (v, 3) int64 old vertices of each new vertex
    weights: np.ndarray             # (v, 3) float64
    new_copy_of: np.ndarray         # (v,) int64
    patch: RowPatch
    origin: list                    # old triangle of each appended row
    changed: np.ndarray             # (k,) int64 sorted rows new or rewritten
    replaced: np.ndarray            # (r, 3) int64 content before the cut of changed[changed < m]
    cut_list: list
    still_closed: list
    split_count: int
    segments: dict

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """``(v, ...)`` per-vertex ``values`` ``(n, ...)`` at the new vertices (their parents' barycentric mix)."""
        return _mix(self.weights, self.parents, values)

    def result(self, rest, positions, velocities, triangles, sweep) -> CutResult:
        return CutResult(rest=rest, positions=positions, velocities=velocities, triangles=triangles,
                         old_count=self.old_count, parents=self.parents, weights=self.weights,
                         new_copy_of=self.new_copy_of, new_origin=np.array(self.origin, dtype=np.int64),
                         changed=self.changed, replaced=self.replaced,
                         cut_edges=np.array(self.cut_list, dtype=np.int64).reshape(-1, 2),
                         closed=np.array(self.still_closed, dtype=np.int64).reshape(-1, 2),
                         split_count=self.split_count, end_vertex=_farthest(self.segments, positions, sweep))


def plan_cut(rest, positions, triangles, sweep, *, snap, closed, fans: VertexFans, near) -> CutPlan | None:
    """The cut of ``sweep`` among the candidate rows ``near`` (arrays as :func:`cut_surface`'s; ``fans`` must
    cover every vertex of ``near`` and of ``closed``); None if nothing is cut. Writes nothing."""
    found = crossings(positions, triangles, sweep, near=near)
    if not found:
        return None
    n, m = len(rest), len(triangles)
    patch = RowPatch(triangles, fans, n)
    points = _Points(n=n, snap=snap, rest=rest, now=positions, patch=patch)
    segments = {}
    for crossing in found:
        corners = triangles[crossing.triangle]
        ends = [points.locate(corners, crossing.triangle, w) for w in crossing.ends]
        if points.same(*ends):
            continue            # the segment snapped to a point: nothing to cut in this triangle
        a, b = (points.commit(corners, end) for end in ends)
        if a != b:
            segments[crossing.triangle] = (a, b)
    if not points.parents and not segments:
        return None
    affected = _affected(segments, points, patch)
    parents = np.array(points.parents, dtype=np.int64).reshape(-1, 3)
    weights = np.array(points.weights, dtype=np.float64).reshape(-1, 3)
    origin, cut_edges = [], set()
    for t in affected:
        pieces, cut = _split(t, triangles[t], rest, points, segments.get(t), snap)
        patch.write(t, pieces[0])
        patch.append(pieces[1:])
        origin += [t] * (len(pieces) - 1)
        cut_edges |= cut
    new_rows = affected + list(range(m, m + len(patch.added)))
    _check_edges(np.array([patch.row_list(r) for r in new_rows]), sorted(cut_edges), affected)
    # earlier tips that are no longer edges (a later cut went through them) are ignored by separate()
    cut_list = sorted(cut_edges | _carry_closed(closed, points))
    copy_of, still_closed, rewritten = separate(patch, cut_list, n + len(parents))
    # a copy of an old vertex interpolates that vertex alone; a copy of an inserted point takes its parents
    copy_parents = np.repeat(copy_of[:, None], 3, axis=1)
    copy_weights = np.zeros((len(copy_of), 3))
    copy_weights[:, 0] = 1.0
    inserted = copy_of >= n
    copy_parents[inserted] = parents[copy_of[inserted] - n]
    copy_weights[inserted] = weights[copy_of[inserted] - n]
    changed = np.unique(np.concatenate([np.array(new_rows, dtype=np.int64), rewritten]))
    return CutPlan(old_count=n, parents=np.concatenate([parents, copy_parents]),
                   weights=np.concatenate([weights, copy_weights]),
                   new_copy_of=np.concatenate([np.full(len(parents), -1, dtype=np.int64), copy_of]),
                   patch=patch, origin=origin, changed=changed,
                   replaced=np.array(triangles[changed[changed < m]], dtype=np.int64), cut_list=cut_list,
                   still_closed=still_closed, split_count=len(affected), segments=segments)


def _mix(weights, parents, values):
    return np.einsum("ij,ij...->i...", weights, values[parents])


def _quality3(a, b, c) -> float:
    """4√3 A / (|ab|² + |bc|² + |ca|²) of a triangle in 3-D (1 equilateral, 0 degenerate); corners as 3-sequences
    (unrolled: it runs a few times per cut point, where array calls would cost more than the arithmetic)."""
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    wx, wy, wz = c[0] - b[0], c[1] - b[1], c[2] - b[2]
    squares = ux * ux + uy * uy + uz * uz + vx * vx + vy * vy + vz * vz + wx * wx + wy * wy + wz * wz
    if squares <= 0.0:
        return 0.0
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    return _TWO_ROOT3 * math.sqrt(cx * cx + cy * cy + cz * cz) / squares


_TWO_ROOT3 = 2.0 * math.sqrt(3.0)


def _farthest(segments, positions, sweep) -> int:
    """The segment end with the largest sweep coordinate s (the tip's side of the cut)."""
    ends = np.unique(np.array(list(segments.values()), dtype=np.int64).ravel())
    if ends.size == 0:
        return -1
    return int(ends[np.argmax(sweep.plane_coordinates(positions[ends])[:, 0])])


def _affected(segments, points, patch) -> list[int]:
    """Triangles with a segment, or with an edge point on a side (both triangles of its edge, from the fans)."""
    affected = set(segments)
    for lo, hi in points.edge:
        affected.update(patch.owners(lo, hi))
    return sorted(affected)


def _split(t, corners, rest, points, segment, snap):
    """Sub-triangles (global ids) of triangle ``t`` and the cut edges inside it (Fig 7 case by case)."""
    ids, frame = _polygon(corners, rest, points)
    polygon = np.array([frame(w) for _, w in ids])
    poly_ids = [pid for pid, _ in ids]
    facets = points.facet.get(t, [])
    facet_of = {pid: w for w, pid in facets}
    if segment is None:
        local = split_uncut(polygon)
        return _globals(local, poly_ids), set()
    a, b = segment
    if a in facet_of and b in facet_of:
        local = split_interior_cut(polygon, frame(facet_of[a]), frame(facet_of[b]), snap=snap)
        return _globals(local, poly_ids + [a, b]), {_key(a, b)}
    if a in facet_of or b in facet_of:
        facet, edge_end = (a, b) if a in facet_of else (b, a)
        local = split_partial_cut(polygon, frame(facet_of[facet]))
        return _globals(local, poly_ids + [facet]), {_key(facet, edge_end)}
    i, j = poly_ids.index(a), poly_ids.index(b)
    chain = _side_chain(polygon, i, j)
    if chain is not None:       # along one side: its pieces between a and b are the cut
        local = split_uncut(polygon)
        return _globals(local, poly_ids), {_key(poly_ids[p], poly_ids[q]) for p, q in zip(chain, chain[1:])}
    local = split_full_cut(polygon, i, j)
    return _globals(local, poly_ids), {_key(a, b)}


def _polygon(corners, rest, points):
    """The triangle's boundary points (vertex id, barycentric weights) counter-clockwise, and a map weights →
    2-D coordinates in the plane of its rest triangle."""
    p = rest[corners]
    ab, ac = p[1] - p[0], p[2] - p[0]
    length = np.linalg.norm(ab)
    x = ab / length
    cx = ac @ x
    cy = np.linalg.norm(ac - cx * x)
    flat = np.array([[0.0, 0.0], [length, 0.0], [cx, cy]])
    ids = []
    for k in range(3):
        u, v = int(corners[k]), int(corners[(k + 1) % 3])
        w = np.zeros(3)
        w[k] = 1.0
        ids.append((u, w))
        on_side = points.edge.get((min(u, v), max(u, v)), [])
        along = sorted((tt if u < v else 1.0 - tt, pid) for tt, pid in on_side)
        for s, pid in along:
            w = np.zeros(3)
            w[k], w[(k + 1) % 3] = 1.0 - s, s
            ids.append((pid, w))
    return ids, lambda w: w @ flat


def _side_chain(polygon, i, j):
    """Polygon indices from i to j along one side (all collinear), or None if i, j are not on one side."""
    k = len(polygon)
    for step in (1, -1):
        chain = [i]
        while chain[-1] != j:
            chain.append((chain[-1] + step) % k)
        pts = polygon[chain]
        d = pts - pts[0]
        cross = d[:, 0] * d[-1, 1] - d[:, 1] * d[-1, 0]
        scale = np.sum(d[-1] ** 2)
        if np.all(np.abs(cross) <= 1e-9 * scale):
            return chain
    return None


def _globals(local, ids):
    return np.asarray(ids, dtype=np.int64)[local]


def _carry_closed(closed, points):
    """Earlier cuts' closed edges, with any edge point inserted on them now (the edge became two)."""
    edges = set()
    for u, v in np.asarray(closed, dtype=np.int64).reshape(-1, 2):
        lo, hi = (int(u), int(v)) if u < v else (int(v), int(u))
        chain = [lo] + [pid for _, pid in sorted(points.edge.get((lo, hi), []))] + [hi]
        edges |= {_key(p, q) for p, q in zip(chain, chain[1:])}
    return edges


def _check_edges(pieces, cut_edges, affected) -> None:
    """Every cut edge must be an edge of the new pieces (the subdivision guarantees it; this guards it)."""
    if not cut_edges:
        return
    present = {_key(u, v) for u, v in pieces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).tolist()}
    missing = [e for e in cut_edges if e not in present]
    if missing:
        raise MeshError(f"{len(missing)} cut segments are not edges after subdivision (first: {missing[0]}, "
                        f"triangles split: {len(affected)}); the mesh near the cut is degenerate, repair it")


def _key(u, v):
    u, v = int(u), int(v)
    return (u, v) if u < v else (v, u)
