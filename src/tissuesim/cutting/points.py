"""The cut points of one move: existing vertices, edge points (per edge) and facet points (per triangle).

A crossing's ends are snapped (:mod:`.snapping`) and registered here, so both triangles of an edge share its edge
points and a point near one already made is reused.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..numba_cache import kernel_view
from .snapping import snapped_weights


@dataclass
class CutPoints:
    """The cut points of one move, and the parents and weights of those it adds (vertex ids from ``n`` on)."""

    n: int
    snap: float
    rest: np.ndarray                              # (n, 3) rest positions: the quality guard measures there
    now: np.ndarray                               # (n, 3) current positions: and there
    edge: dict = field(default_factory=dict)      # (lo, hi) -> list of [t from lo, id]
    facet: dict = field(default_factory=dict)     # triangle -> list of [weights (3,), id]
    parents: list = field(default_factory=list)   # per new point: (3,) vertex ids
    weights: list = field(default_factory=list)   # per new point: (3,) weights

    def locate(self, corners: np.ndarray, triangle: int, w: np.ndarray, opposite: np.ndarray) -> tuple:
        """Snap barycentric ``w`` in a triangle with vertex ids ``corners`` (its sides' opposite vertices
        ``opposite``, :func:`~.snapping.opposite_vertices`): ``("v", id)``, ``("e", lo, hi, t)`` (t from lo) or
        ``("f", triangle, weights)``; nothing is registered yet."""
        w = snapped_weights(*map(kernel_view, (self.rest, self.now, corners, w, opposite)), self.snap)
        nonzero = [k for k, x in enumerate(w.tolist()) if x != 0.0]
        if len(nonzero) == 1:
            return ("v", int(corners[nonzero[0]]))
        if len(nonzero) == 2:
            i, j = int(corners[nonzero[0]]), int(corners[nonzero[1]])
            lo, hi = (i, j) if i < j else (j, i)
            t = float(w[nonzero[1]] if j == hi else w[nonzero[0]])
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
