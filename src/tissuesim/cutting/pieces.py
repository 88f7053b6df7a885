"""One triangle's pieces in a cut: its sides' cut points laid flat in the plane of its rest triangle, and the case
of Fig 7 that fits its cut segment (:mod:`.subdivide`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .edges import edge_key
from .subdivide import split_full_cut, split_interior_cut, split_partial_cut, split_uncut

if TYPE_CHECKING:
    from .points import CutPoints


def split_triangle(t: int, corners: np.ndarray, rest: np.ndarray, points: CutPoints, segment: tuple[int, int] | None,
                   snap: float) -> tuple[np.ndarray, set[tuple[int, int]]]:
    """Sub-triangles (global ids) of triangle ``t`` and the cut edges inside it (Fig 7 case by case).

    ``corners``: its vertex ids; ``points``: the move's :class:`~.points.CutPoints`, those on its sides and inside
    it become corners of the pieces; ``segment``: its cut (two vertex ids), None when only its sides have points."""
    poly_ids, xy, frame = _polygon(corners, rest, points)
    polygon = np.array(xy)
    facet_of = {pid: w for w, pid in points.facet.get(t, [])}
    if segment is None:
        local = split_uncut(polygon)
        return _globals(local, poly_ids), set()
    a, b = segment
    if a in facet_of and b in facet_of:
        local = split_interior_cut(polygon, frame(facet_of[a]), frame(facet_of[b]), snap=snap)
        return _globals(local, poly_ids + [a, b]), {edge_key(a, b)}
    if a in facet_of or b in facet_of:
        facet, edge_end = (a, b) if a in facet_of else (b, a)
        local = split_partial_cut(polygon, frame(facet_of[facet]))
        return _globals(local, poly_ids + [facet]), {edge_key(facet, edge_end)}
    i, j = poly_ids.index(a), poly_ids.index(b)
    chain = _side_chain(xy, i, j)
    if chain is not None:       # along one side: its pieces between a and b are the cut
        local = split_uncut(polygon)
        cut = {edge_key(poly_ids[p], poly_ids[q]) for p, q in zip(chain, chain[1:])}
        return _globals(local, poly_ids), cut
    local = split_full_cut(polygon, i, j)
    return _globals(local, poly_ids), {edge_key(a, b)}


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
        on_side = points.edge.get(edge_key(u, v), ())
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
