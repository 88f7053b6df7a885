"""The topology cases of Fig 7: how one cut triangle is split, in its own plane.

Every function here works on one triangle laid flat: a convex polygon ``(k, 2) float64`` in counter-clockwise
order (the triangle's corners with the edge points on its sides in order along them) plus, where the cut ends
inside, facet points. It returns sub-triangles ``(m, 3) int64`` as indices into the points
``polygon + facet points`` (polygon first), counter-clockwise like the parent, so the parent's orientation carries
over. The sub-triangles tile the parent exactly, and the cut segment is one of their edges.

* :func:`split_uncut` — Fig 7(a): edge points on the sides, no cut inside (the neighbour of a cut triangle);
* :func:`split_full_cut` — Fig 7(c): the cut joins two boundary points (edge points or corners);
* :func:`split_partial_cut` — Fig 7(b): the cut enters through a boundary point and stops at a facet point;
* :func:`split_interior_cut` — beyond Fig 7, for progressive cutting: a short move that starts and stops inside
  one triangle (both ends facet points).

Sides with extra points are split without zero-area triangles: a convex polygon is triangulated by the
diagonals that maximise the smallest triangle quality (dynamic programming over the polygon, Klincsek 1980),
which never picks three collinear points while another choice exists.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit

from ..errors import MeshError

SQRT3 = float(np.sqrt(3.0))


@njit(cache=True)
def triangle_quality(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray,
                     c: Sequence[float] | np.ndarray) -> float:
    """4√3 A / (|ab|² + |bc|² + |ca|²) of a 2-D triangle (corners as 2-sequences): 1 equilateral, 0 degenerate,
    < 0 clockwise."""
    abx, aby, bcx, bcy, cax, cay = b[0] - a[0], b[1] - a[1], c[0] - b[0], c[1] - b[1], a[0] - c[0], a[1] - c[1]
    area = 0.5 * (abx * (c[1] - a[1]) - aby * (c[0] - a[0]))
    squares = (abx * abx + aby * aby) + (bcx * bcx + bcy * bcy) + (cax * cax + cay * cay)
    return 4.0 * SQRT3 * area / squares if squares > 0.0 else 0.0


def split_uncut(polygon: np.ndarray) -> np.ndarray:
    """Fig 7(a): triangulate a convex polygon (sides may carry collinear points) at the best smallest quality."""
    polygon = np.asarray(polygon, dtype=np.float64)
    if len(polygon) < 3:
        raise MeshError(f"a polygon needs at least 3 points to triangulate, got {len(polygon)}")
    return _best_triangulation(polygon)


@njit(cache=True)
def _best_triangulation(points):
    """Dynamic programming over the diagonals of a convex polygon ``(k, 2)``: the triangulation whose smallest
    triangle quality is largest, as ``(k − 2, 3) int64`` point indices."""
    k = points.shape[0]
    best = np.full((k, k), np.inf)
    choice = np.full((k, k), -1, dtype=np.int64)
    for gap in range(2, k):
        for i in range(k - gap):
            j = i + gap
            best[i, j] = -np.inf
            for m in range(i + 1, j):
                q = min(triangle_quality(points[i], points[m], points[j]),
                        best[i, m] if m - i > 1 else np.inf, best[m, j] if j - m > 1 else np.inf)
                if q > best[i, j]:
                    best[i, j], choice[i, j] = q, m
    triangles = np.empty((k - 2, 3), dtype=np.int64)
    stack = np.empty((2 * k, 2), dtype=np.int64)         # (i, j) spans still to split
    stack[0, 0], stack[0, 1] = 0, k - 1
    depth, count = 1, 0
    while depth:
        depth -= 1
        i, j = stack[depth, 0], stack[depth, 1]
        if j - i < 2:
            continue
        m = choice[i, j]
        triangles[count, 0], triangles[count, 1], triangles[count, 2] = i, m, j
        count += 1
        stack[depth, 0], stack[depth, 1] = i, m
        stack[depth + 1, 0], stack[depth + 1, 1] = m, j
        depth += 2
    return triangles


def split_full_cut(polygon: np.ndarray, first: int, second: int) -> np.ndarray:
    """Fig 7(c): the cut chord between polygon points ``first`` and ``second`` splits the polygon in two convex
    pieces, each triangulated by :func:`split_uncut`. Points on one side (collinear pieces) are not split there."""
    k = len(polygon)
    i, j = sorted((first, second))
    pieces = [np.arange(i, j + 1), np.concatenate([np.arange(j, k), np.arange(0, i + 1)])]
    out = []
    for piece in pieces:
        if len(piece) >= 3 and not _collinear(polygon[piece]):
            out.append(piece[split_uncut(polygon[piece])])
    return np.concatenate(out)


def split_partial_cut(polygon: np.ndarray, facet: np.ndarray) -> np.ndarray:
    """Fig 7(b): the cut stops at ``facet`` ``(2,)`` strictly inside: a fan from it to every side (facet index k)."""
    k = len(polygon)
    _check_inside(polygon, facet)
    return np.array([(k, i, (i + 1) % k) for i in range(k)], dtype=np.int64)


def split_interior_cut(polygon: np.ndarray, first: np.ndarray, second: np.ndarray, *, snap: float) -> np.ndarray:
    """Both ends inside (indices k and k + 1): a fan from ``first``, then ``second`` inserted into the fan triangle
    holding it (onto the spoke when its weight off the spoke is below ``snap``), so first–second is an edge."""
    k = len(polygon)
    fan = split_partial_cut(polygon, first)
    points = np.concatenate([polygon, first[None], second[None]])
    for r, (f, a, b) in enumerate(fan):
        w = _barycentric_2d(points[f], points[a], points[b], second)
        if np.all(w >= -1e-12):
            break
    else:
        raise MeshError("the cut's second facet point lies outside its triangle")
    s = k + 1
    rest = [tuple(t) for q, t in enumerate(fan) if q != r]
    if w[1] < snap or w[2] < snap:
        # onto the spoke f–b (weight of a small) or f–a (weight of b small): split the two fan triangles there
        spoke_end = b if w[1] < snap else a
        other = [q for q, t in enumerate(fan) if q != r and spoke_end in t[1:]][0]
        _, oa, ob = fan[other]
        rest = [tuple(t) for q, t in enumerate(fan) if q not in (r, other)]
        if spoke_end == b:      # fan[r] = (f, a, b), fan[other] = (f, b, ob)
            new = [(f, a, s), (s, a, b), (f, s, ob), (s, b, ob)]
        else:                   # fan[r] = (f, a, b), fan[other] = (f, oa, a)
            new = [(f, s, b), (s, a, b), (f, oa, s), (s, oa, a)]
        return np.array(rest + new, dtype=np.int64)
    return np.array(rest + [(f, a, s), (a, b, s), (b, f, s)], dtype=np.int64)


def _barycentric_2d(a, b, c, p) -> np.ndarray:
    m = np.array([[a[0], b[0], c[0]], [a[1], b[1], c[1]], [1.0, 1.0, 1.0]])
    return np.linalg.solve(m, np.array([p[0], p[1], 1.0]))


def _check_inside(polygon, point) -> None:
    k = len(polygon)
    for i in range(k):
        a, b = polygon[i], polygon[(i + 1) % k]
        if (b[0] - a[0]) * (point[1] - a[1]) - (b[1] - a[1]) * (point[0] - a[0]) <= 0.0:
            raise MeshError("a facet point must lie strictly inside its triangle; snap it onto the edge first")


@njit(cache=True)
def _collinear(points) -> bool:
    """Whether the points ``(k, 2)`` lie on one line (relative to their spread)."""
    scale = 0.0
    for i in range(1, points.shape[0]):
        scale = max(scale, abs(points[i, 0] - points[0, 0]), abs(points[i, 1] - points[0, 1]))
    scale += 1e-300
    for i in range(1, points.shape[0]):
        for j in range(1, points.shape[0]):
            cross = ((points[i, 0] - points[0, 0]) * (points[j, 1] - points[0, 1])
                     - (points[i, 1] - points[0, 1]) * (points[j, 0] - points[0, 0]))
            if abs(cross) > 1e-12 * scale * scale:
                return False
    return True
