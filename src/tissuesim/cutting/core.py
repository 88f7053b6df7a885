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
from .fans import RowPatch, VertexFans, read_only
from .separate import rows_touching, separate
from .snapping import opposite_vertices, snapped_weights
from .subdivide import split_full_cut, split_interior_cut, split_partial_cut, split_uncut
from .sweep import Sweep, candidate_triangles, check_snap, crossings

#: Default snap fraction of the local edge length (see :mod:`.sweep`).
DEFAULT_SNAP = 0.25


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
        end_vertex: the cut point farthest along the sweep (where the cut stopped) on the sheet nearest the tool
            tip, −1 if none; a progressive cut starts its next sweep there so the wound stays one path.
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
    now: np.ndarray                               # (n, 3) current positions: and there
    patch: RowPatch | None = None                 # the rows, for the triangles of an edge
    edge: dict = field(default_factory=dict)      # (lo, hi) -> list of [t from lo, id]
    facet: dict = field(default_factory=dict)     # triangle -> list of [weights (3,), id]
    parents: list = field(default_factory=list)   # per new point: (3,) vertex ids
    weights: list = field(default_factory=list)   # per new point: (3,) weights

    def locate(self, corners: np.ndarray, triangle: int, w: np.ndarray, opposite: np.ndarray) -> tuple:
        """Snap barycentric ``w`` in a triangle with vertex ids ``corners`` (its sides' opposite vertices
        ``opposite``, :func:`~.snapping.opposite_vertices`): ``("v", id)``, ``("e", lo, hi, t)`` (t from lo) or
        ``("f", triangle, weights)``; nothing is registered yet."""
        w = snapped_weights(self.rest, self.now, corners, w, opposite, self.snap)
        nonzero = [k for k, x in enumerate(w.tolist()) if x != 0.0]
        if len(nonzero) == 1:
            return ("v", int(corners[nonzero[0]]))
        if len(nonzero) == 2:
            i, j = int(corners[nonzero[0]]), int(corners[nonzero[1]])
            lo, hi = (i, j) if i < j else (j, i)
            t = float(w[nonzero[1]] if j == hi else w[nonzero[0]])
            if t < self.snap:
                return ("v", lo)
            if t > 1.0 - self.snap:
                return ("v", hi)
            return ("e", lo, hi, t)
        return ("f", triangle, w)

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

    def vertices(self) -> np.ndarray:
        """``(k,) int64`` every vertex of the rows this plan rewrites or appends, before and after it, ascending."""
        rows = list(self.patch.edited.values()) + self.patch.added
        return np.unique(np.concatenate([self.replaced.ravel(), np.asarray(rows, dtype=np.int64).ravel()]))

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
    rest, positions, triangles = (read_only(a) for a in (rest, positions, triangles))
    found = crossings(positions, triangles, sweep, near=near)
    if not found:
        return None
    n, m = len(rest), len(triangles)
    patch = RowPatch(triangles, fans, n)
    points = _Points(n=n, snap=snap, rest=rest, now=positions, patch=patch)
    segments, known_sides = {}, {}
    for crossing in found:
        corners = triangles[crossing.triangle]
        opposite = opposite_vertices(patch, corners.tolist(), crossing.ends, snap, known_sides)
        ends = [points.locate(corners, crossing.triangle, w, opposite) for w in crossing.ends]
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


def _farthest(segments, positions, sweep) -> int:
    """The segment end farthest along the move (the tip's side of the cut), on the sheet nearest the tool tip.

    A blade deeper than the body crosses two sheets (the top and the bottom of a slab entered from the side), whose
    fronts lie level along the move to within the snapping. The blade enters the sheet nearest its tip first, so a
    front point shallower by more than a cut segment's length (more than one sheet can slope between two points a
    segment apart) wins: the next move's walk then follows that sheet."""
    pairs = np.array(list(segments.values()), dtype=np.int64).reshape(-1, 2)
    ends = np.unique(pairs.ravel())
    if ends.size == 0:
        return -1
    st = sweep.plane_coordinates(positions[ends])
    along, deep = st[:, 0] * np.linalg.norm(sweep.u), st[:, 1] * np.linalg.norm(sweep.v)     # [m]
    reach = float(np.linalg.norm(positions[pairs[:, 0]] - positions[pairs[:, 1]], axis=1).max())
    best = int(np.argmax(along))
    front = np.flatnonzero((along >= along[best] - reach) & (deep < deep[best] - reach))
    if front.size:
        best = int(front[np.argmin(deep[front])])
    return int(ends[best])


def _affected(segments, points, patch) -> list[int]:
    """Triangles with a segment, or with an edge point on a side (both triangles of its edge, from the fans)."""
    affected = set(segments)
    for lo, hi in points.edge:
        affected.update(patch.owners(lo, hi))
    return sorted(affected)


def _split(t, corners, rest, points, segment, snap):
    """Sub-triangles (global ids) of triangle ``t`` and the cut edges inside it (Fig 7 case by case)."""
    poly_ids, xy, frame = _polygon(corners, rest, points)
    polygon = np.array(xy)
    facet_of = {pid: w for w, pid in points.facet.get(t, [])}
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
    chain = _side_chain(xy, i, j)
    if chain is not None:       # along one side: its pieces between a and b are the cut
        local = split_uncut(polygon)
        return _globals(local, poly_ids), {_key(poly_ids[p], poly_ids[q]) for p, q in zip(chain, chain[1:])}
    local = split_full_cut(polygon, i, j)
    return _globals(local, poly_ids), {_key(a, b)}


def _polygon(corners, rest, points):
    """The triangle's boundary points counter-clockwise, as vertex ids and 2-D coordinates in the plane of its rest
    triangle, and a map barycentric weights → those coordinates. Plain floats: a handful of points."""
    ids = corners.tolist()
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = rest[corners].tolist()
    ux, uy, uz, vx, vy, vz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    along = (vx * ux + vy * uy + vz * uz) / length
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    across = math.sqrt(nx * nx + ny * ny + nz * nz) / length      # no cancellation on thin triangles
    flat = ((0.0, 0.0), (length, 0.0), (along, across))
    poly_ids, xy = [], []
    for k in range(3):
        u, v = ids[k], ids[(k + 1) % 3]
        (x0, y0), (x1, y1) = flat[k], flat[(k + 1) % 3]
        poly_ids.append(u)
        xy.append(flat[k])
        on_side = points.edge.get((u, v) if u < v else (v, u), ())
        for s, pid in sorted((tt if u < v else 1.0 - tt, pid) for tt, pid in on_side):
            poly_ids.append(pid)
            xy.append(((1.0 - s) * x0 + s * x1, (1.0 - s) * y0 + s * y1))

    def frame(w):
        return np.array([w[1] * length + w[2] * along, w[2] * across])

    return poly_ids, xy, frame


def _side_chain(xy, i, j):
    """Polygon indices from i to j along one side (all collinear), or None if i, j are not on one side."""
    k = len(xy)
    for step in (1, -1):
        chain = [i]
        while chain[-1] != j:
            chain.append((chain[-1] + step) % k)
        x0, y0 = xy[i]
        dx, dy = xy[j][0] - x0, xy[j][1] - y0
        tolerance = 1e-9 * (dx * dx + dy * dy)
        if all(abs((xy[c][0] - x0) * dy - (xy[c][1] - y0) * dx) <= tolerance for c in chain):
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
