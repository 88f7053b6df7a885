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

from dataclasses import dataclass, field

import numpy as np

from ..errors import MeshError
from .separate import separate
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
        copy_of: ``(n',) int64`` the vertex (new numbering) a duplicate copies, −1 for the others.
        triangle_origin: ``(m',) int64`` the old triangle each triangle lies in.
        changed: ``(k,) int64`` rows of ``triangles`` that are new or rewritten.
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
    copy_of: np.ndarray
    triangle_origin: np.ndarray
    changed: np.ndarray
    cut_edges: np.ndarray
    closed: np.ndarray
    split_count: int
    end_vertex: int = -1

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
        return np.unique(self.copy_of[self.copy_of >= 0])


@dataclass
class _Points:
    """The cut points of one move: existing vertices, edge points (per edge), facet points (per triangle)."""

    n: int
    snap: float
    rest: np.ndarray                              # (n, 3) rest positions: the quality guard measures there
    now: np.ndarray | None = None                 # (n, 3) current positions: and there
    opposite: dict = field(default_factory=dict)  # (lo, hi) -> opposite vertices of the edge's triangles
    edge: dict = field(default_factory=dict)      # (lo, hi) -> list of [t from lo, id]
    facet: dict = field(default_factory=dict)     # triangle -> list of [weights (3,), id]
    parents: list = field(default_factory=list)   # per new point: (3,) vertex ids
    weights: list = field(default_factory=list)   # per new point: (3,) weights

    def locate(self, corners: np.ndarray, triangle: int, w: np.ndarray) -> tuple:
        """Snap barycentric ``w`` in a triangle with vertex ids ``corners``: ``("v", id)``, ``("e", lo, hi, t)`` (t
        from lo) or ``("f", triangle, weights)``; nothing is registered yet."""
        w = np.where(w < self.snap, 0.0, w)
        w = self._guard(corners, w / w.sum())
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

    def _guard(self, corners, w):
        """Snap further while a piece the point would make in this triangle falls below :data:`GUARD_QUALITY` at
        rest or at the current positions (a cut on a deformed surface): a facet point onto the edge of its worst
        piece, an edge point onto the nearer end (repeated re-cuts would otherwise thin the triangles step by step)."""
        while np.count_nonzero(w) > 1:
            inside = np.flatnonzero(w)
            quality = np.min([self._piece_quality(corners, w, inside, where)
                              for where in (self.rest, self.now) if where is not None], axis=0)
            if min(quality) >= GUARD_QUALITY:
                break
            if inside.size == 3:
                worst = int(np.argmin(quality))
                w[(worst + 2) % 3] = 0.0                # onto the worst piece's edge (worst, worst + 1)
            else:
                i, j = inside
                w[i if w[i] < w[j] else j] = 0.0        # onto the nearer end
            w = w / w.sum()
        return w

    def _piece_quality(self, corners, w, inside, where) -> list:
        """Qualities of the pieces a point at barycentric ``w`` would make, with vertices at ``where`` ``(n, 3)``:
        three in its triangle for a facet point (piece i on edge (i, i + 1)), two per triangle of its edge for an edge
        point (the neighbour gets the point too, Fig 7(a))."""
        p = where[corners]
        x = w @ p
        if inside.size == 3:
            return [_quality3(x, p[i], p[(i + 1) % 3]) for i in range(3)]
        i, j = inside
        key = tuple(sorted((int(corners[i]), int(corners[j]))))
        others = self.opposite.get(key) or [int(corners[3 - i - j])]
        return [_quality3(x, p[e], where[o]) for o in others for e in (i, j)]

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
    n = len(rest)
    near = candidate_triangles(positions, triangles, sweep)
    found = crossings(positions, triangles, sweep, near=near)
    if not found:
        return None
    points = _Points(n=n, snap=snap, rest=rest, now=positions, opposite=_opposites(triangles, near))
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
    affected = _affected(positions, triangles, sweep, segments, points, near)
    parents = np.array(points.parents, dtype=np.int64).reshape(-1, 3)
    weights = np.array(points.weights, dtype=np.float64).reshape(-1, 3)
    tri_rows, origin, cut_edges = [], [], set()
    out = triangles.copy()
    for t in affected:
        pieces, cut = _split(t, triangles[t], rest, points, segments.get(t), snap)
        out[t] = pieces[0]
        tri_rows.append(pieces[1:])
        origin += [t] * (len(pieces) - 1)
        cut_edges |= cut
    extra = np.concatenate(tri_rows).astype(np.int32) if tri_rows else np.zeros((0, 3), dtype=np.int32)
    out = np.concatenate([out, extra])
    new_rows = np.concatenate([np.asarray(affected, dtype=np.int64), np.arange(len(triangles), len(out))])
    _check_edges(out[new_rows], sorted(cut_edges), affected)
    # earlier tips that are no longer edges (a later cut went through them) are ignored by separate()
    cut_list = sorted(cut_edges | _carry_closed(closed, points))
    copy_of, still_closed, rewritten = separate(out, cut_list, n + len(parents))
    # a copy of an old vertex interpolates that vertex alone; a copy of an inserted point takes its parents
    copy_parents = np.repeat(copy_of[:, None], 3, axis=1)
    copy_weights = np.zeros((len(copy_of), 3))
    copy_weights[:, 0] = 1.0
    inserted = copy_of >= n
    copy_parents[inserted] = parents[copy_of[inserted] - n]
    copy_weights[inserted] = weights[copy_of[inserted] - n]
    parents = np.concatenate([parents, copy_parents])
    weights = np.concatenate([weights, copy_weights])
    new_rest, new_pos, new_vel = (np.concatenate([a, np.einsum("ij,ijk->ik", weights, a[parents])])
                                  for a in (rest, positions, velocities))
    copies = np.full(len(new_rest), -1, dtype=np.int64)
    copies[len(new_rest) - copy_of.size:] = copy_of
    triangle_origin = np.concatenate([np.arange(len(triangles)), np.array(origin, dtype=np.int64)])
    changed = np.unique(np.concatenate([new_rows, rewritten]))
    return CutResult(rest=new_rest, positions=new_pos, velocities=new_vel, triangles=out, old_count=n,
                     end_vertex=_farthest(segments, new_pos, sweep), parents=parents, weights=weights,
                     copy_of=copies, triangle_origin=triangle_origin, changed=changed,
                     cut_edges=np.array(cut_list, dtype=np.int64).reshape(-1, 2),
                     closed=np.array(still_closed, dtype=np.int64).reshape(-1, 2), split_count=len(affected))


def _opposites(triangles, rows) -> dict:
    """For each edge of ``rows``: the opposite vertex in each of those triangles holding it."""
    opposite: dict = {}
    for a, b, c in triangles[rows].tolist():
        for u, v, w in ((a, b, c), (b, c, a), (c, a, b)):
            opposite.setdefault((u, v) if u < v else (v, u), []).append(w)
    return opposite


def _quality3(a, b, c) -> float:
    """4√3 A / (|ab|² + |bc|² + |ca|²) of a triangle in 3-D (1 equilateral, 0 degenerate)."""
    squares = np.sum((b - a) ** 2) + np.sum((c - b) ** 2) + np.sum((a - c) ** 2)
    return 2.0 * np.sqrt(3.0) * np.linalg.norm(np.cross(b - a, c - a)) / squares if squares > 0.0 else 0.0


def _farthest(segments, positions, sweep) -> int:
    """The segment end with the largest sweep coordinate s (the tip's side of the cut)."""
    ends = np.unique(np.array(list(segments.values()), dtype=np.int64).ravel())
    if ends.size == 0:
        return -1
    return int(ends[np.argmax(sweep.plane_coordinates(positions[ends])[:, 0])])


def _affected(positions, triangles, sweep, segments, points, near) -> list[int]:
    """Triangles with a segment, or with an edge point on a side. Searched among the sweep's candidates ``near``;
    only when an edge point's edge shows fewer than two triangles there (a point snapped just outside the sweep's
    box, or an edge on an opening) is the search widened by the longest edge of the cut triangles."""
    affected = set(segments)
    if not points.edge:
        return sorted(affected)
    owners = _edge_owners(triangles, near, points.edge)
    if any(len(owners.get(key, ())) < 2 for key in points.edge):
        t = np.array(sorted(affected | set(points.facet)) or [0])
        p = positions[triangles[t]]
        reach = float(np.linalg.norm(p - p[:, [1, 2, 0]], axis=2).max())
        owners = _edge_owners(triangles, candidate_triangles(positions, triangles, sweep, pad=reach), points.edge)
    for rows in owners.values():
        affected |= set(rows)
    return sorted(affected)


def _edge_owners(triangles, rows, edges) -> dict:
    """Among ``rows``, the triangles having each of ``edges`` (sorted vertex pairs)."""
    owners: dict = {}
    for r, (a, b, c) in zip(rows.tolist(), triangles[rows].tolist()):
        for u, v in ((a, b), (b, c), (c, a)):
            key = (u, v) if u < v else (v, u)
            if key in edges:
                owners.setdefault(key, []).append(r)
    return owners


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
