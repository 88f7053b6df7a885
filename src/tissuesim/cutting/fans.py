"""Vertex → triangle incidence of M_S, built once and updated per cut, so a cut finds its neighbourhood locally.

A cut rewrites a few triangle rows and appends a few, so the incidence is kept as a static table (built in one
vectorised pass) plus the rows each vertex gained since; a row that lost a vertex stays listed and is filtered out
by reading the row itself. The fans give a triangle's neighbours, an edge's triangles, and the triangles near a
sweep by walking outward from a seed (:meth:`VertexFans.near`) instead of testing every triangle of the mesh.
A vertex and its duplicates are *twins*: the walk steps across a cut through them, so a move that crosses an
earlier wound reaches its other side.
"""

from __future__ import annotations

import numpy as np


class VertexFans:
    """Rows of a triangle array holding each vertex.

    Args:
        triangles: ``(m, 3) int`` triangles.
        vertex_count: n, the number of vertices.
        rows: ``(m,) int`` the row number of each of ``triangles`` when they are a subset of the array (then only
            the fans of their corners are complete); default 0..m−1.
    """

    def __init__(self, triangles: np.ndarray, vertex_count: int, *, rows: np.ndarray | None = None):
        flat = np.asarray(triangles, dtype=np.int64).ravel()
        order = np.argsort(flat, kind="stable") // 3
        self._rows = order if rows is None else np.asarray(rows, dtype=np.int64)[order]
        self._start = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=vertex_count))])
        self._built = vertex_count
        self._extra: dict[int, list[int]] = {}
        self._twins: dict[int, list[int]] = {}

    def candidates(self, v: int) -> list[int]:
        """Rows that hold or once held vertex ``v`` (a superset of its fan)."""
        base = self._rows[self._start[v]:self._start[v + 1]].tolist() if v < self._built else []
        return base + self._extra.get(v, [])

    def fan(self, v: int, triangles: np.ndarray, edited=None) -> list[int]:
        """Rows holding ``v`` now in ``triangles``, or in ``edited`` (row → content list) for the rows it has."""
        edited = edited or {}
        m = len(triangles)
        rows = [r for r in dict.fromkeys(self.candidates(v)) if r < m]
        contents = triangles[rows].tolist()         # one gather: per-row reads cost more than the rows
        return [r for r, content in zip(rows, contents) if v in (edited[r] if r in edited else content)]

    def record(self, rows, contents, copies=()) -> None:
        """Rows ``rows`` now hold ``contents`` ``(k, 3)``; ``copies`` are ``(copy, original)`` vertex pairs."""
        for r, content in zip(np.asarray(rows).tolist(), np.asarray(contents).tolist()):
            for v in content:
                gained = self._extra.setdefault(v, [])
                if r not in gained:
                    gained.append(r)
        for copy, original in copies:
            group = [original] + self._twins.get(original, [])
            for v in group:
                self._twins.setdefault(v, []).append(copy)
            self._twins[copy] = group

    def twins(self, v: int) -> list[int]:
        """The vertices ``v`` was duplicated from or into (either side of a cut)."""
        return self._twins.get(v, [])

    def near(self, triangles: np.ndarray, positions: np.ndarray, low: np.ndarray, high: np.ndarray,
             seeds) -> np.ndarray:
        """``(k,) int64`` rows whose bounding box (at ``positions``) overlaps the box [``low``, ``high``] and that
        are joined to the rows ``seeds`` through such rows (sharing a vertex or twins); empty when no seed overlaps.
        Level by level, so each level is one vectorised box test."""
        seen = set(seeds)
        frontier = list(seen)
        found: list[np.ndarray] = []
        while frontier:
            rows = np.array(frontier, dtype=np.int64)
            p = positions[triangles[rows]]
            hits = rows[np.all((p.min(axis=1) <= high) & (p.max(axis=1) >= low), axis=1)]
            found.append(hits)
            vertices = set(triangles[hits].ravel().tolist())
            vertices.update(t for v in list(vertices) for t in self.twins(v))
            frontier = []
            for v in vertices:
                for r in self.candidates(v):
                    if r not in seen:
                        seen.add(r)
                        frontier.append(r)
        return np.unique(np.concatenate(found)) if found else np.zeros(0, dtype=np.int64)


class RowPatch:
    """The triangle rows of one cut: the array before it (never written) with the rows the cut rewrites and appends.

    Args:
        triangles: ``(m, 3) int`` triangles before the cut.
        fans: their :class:`VertexFans`.
        vertex_count: n, the vertex count before the cut (vertices from n on are this cut's).

    The rewritten (``edited``: row → content) and appended (``added``) rows are kept as lists of three ints: the
    cut reads them one at a time, where list membership is far cheaper than an array's.
    """

    def __init__(self, triangles: np.ndarray, fans: VertexFans, vertex_count: int):
        self.base, self.fans = triangles, fans
        self.m, self.n = len(triangles), vertex_count
        self.edited: dict[int, list[int]] = {}
        self.added: list[list[int]] = []
        self._fans: dict[int, list[int]] = {}       # fans read since the last write
        self._base_rows: dict[int, list[int]] = {}  # rows of ``base`` read so far (never written)

    def row_list(self, r: int) -> list[int]:
        """Row ``r``'s current content as a list."""
        if r in self.edited:
            return self.edited[r]
        if r >= self.m:
            return self.added[r - self.m]
        row = self._base_rows.get(r)
        if row is None:
            row = self._base_rows[r] = self.base[r].tolist()
        return row

    def write(self, r: int, content) -> None:
        self._fans.clear()
        content = [int(x) for x in content]
        if r < self.m:
            self.edited[r] = content
        else:
            self.added[r - self.m] = content

    def append(self, contents) -> None:
        self._fans.clear()
        self.added += [[int(x) for x in c] for c in contents]

    def fan(self, v: int) -> list[int]:
        """Rows holding vertex ``v`` now. A rewritten row only loses old vertices (a piece keeps its triangle's
        corners; a copy is new), so an old vertex's rows are its fan before the cut and the appended rows."""
        rows = self._fans.get(v)
        if rows is None:
            rows = (self.fans.fan(v, self.base, self.edited) if v < self.n
                    else [r for r, c in self.edited.items() if v in c])
            rows = self._fans[v] = rows + [self.m + i for i, c in enumerate(self.added) if v in c]
        return rows

    def owners(self, lo: int, hi: int) -> list[int]:
        """Rows holding the edge (lo, hi) now."""
        return [r for r in self.fan(lo) if hi in self.row_list(r)]


class EdgeOwners:
    """Edge → triangle rows of a :class:`~tissuesim.cutting.buffers.CutSurface`'s current triangles, read from its
    fans (no table of every edge: a Python dict of the whole mesh's edges slows every garbage collection).
    Cached until :meth:`clear` (call it after each cut)."""

    def __init__(self, surface):
        self.surface = surface
        self._owners: dict = {}

    def clear(self) -> None:
        self._owners.clear()

    def of(self, key) -> list[int]:
        """Rows holding the edge ``key`` = (lo, hi)."""
        lo, hi = int(key[0]), int(key[1])
        owners = self._owners.get((lo, hi))
        if owners is None:
            triangles = self.surface.triangles
            owners = [r for r in self.surface.fans.fan(lo, triangles) if hi in triangles[r].tolist()]
            self._owners[(lo, hi)] = owners
        return owners
