"""Vertex → triangle incidence of M_S, built once and updated per cut, so a cut finds its neighbourhood locally.

A cut rewrites a few triangle rows and appends a few, so the incidence is kept as a static table (built in one
vectorised pass) plus the rows each vertex gained since; a row that lost a vertex stays listed and is filtered out
by reading the row itself. The fans give a triangle's neighbours, an edge's triangles, and the triangles near a
sweep by walking outward from a seed (:meth:`VertexFans.near`) instead of testing every triangle of the mesh.
A vertex and its duplicates are *twins*: the walk steps across a cut through them, so a move that crosses an
earlier wound reaches its other side.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

#: ``held`` of :meth:`VertexFans.joined` when no held vertex is asked for (an empty mask: any vertex will do).
_NO_HOLD = np.zeros(0, dtype=np.bool_)


class VertexFans:
    """Rows of a triangle array holding each vertex.

    Args:
        triangles: ``(m, 3) int`` triangles.
        vertex_count: n, the number of vertices.
        rows: ``(m,) int`` the row number of each of ``triangles`` when they are a subset of the array (then only
            the fans of their corners are complete); default 0..m−1.

    Everything lives in arrays, so the walk (:meth:`near`) runs compiled: the static table, the rows each vertex
    gained since as singly linked lists (``_head`` → ``_next`` / ``_gained``), and each group of duplicates as a
    ring (``_ring[v]`` is the next vertex of v's group, v itself when it has none).
    """

    def __init__(self, triangles: np.ndarray, vertex_count: int, *, rows: np.ndarray | None = None):
        flat = np.asarray(triangles, dtype=np.int64).ravel()
        order = np.argsort(flat, kind="stable") // 3
        self._rows = order if rows is None else np.asarray(rows, dtype=np.int64)[order]
        self._start = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=vertex_count))])
        self._built = vertex_count
        self._head = np.full(vertex_count, -1, dtype=np.int64)
        self._ring = np.arange(vertex_count, dtype=np.int64)
        self._next = np.zeros(0, dtype=np.int64)
        self._gained = np.zeros(0, dtype=np.int64)
        self._slots = 0
        # the walk's marks (a row or vertex is seen in this walk when its mark equals the walk's number) and queue
        self._walks = 0
        self._vertex_mark = np.zeros(vertex_count, dtype=np.int64)
        self._row_mark = np.zeros(0, dtype=np.int64)
        self._queue = np.zeros(0, dtype=np.int64)

    def candidates(self, v: int) -> list[int]:
        """Rows that hold or once held vertex ``v`` (a superset of its fan)."""
        base = self._rows[self._start[v]:self._start[v + 1]].tolist() if v < self._built else []
        return base + self._gained_rows(v)

    def _gained_rows(self, v: int) -> list[int]:
        rows = []
        slot = int(self._head[v]) if v < len(self._head) else -1
        while slot >= 0:
            rows.append(int(self._gained[slot]))
            slot = int(self._next[slot])
        return rows[::-1]

    def fan(self, v: int, triangles: np.ndarray, edited: dict[int, list[int]] | None = None) -> list[int]:
        """Rows holding ``v`` now in ``triangles``, or in ``edited`` (row → content list) for the rows it has."""
        edited = edited or {}
        m = len(triangles)
        rows = [r for r in dict.fromkeys(self.candidates(v)) if r < m]
        contents = triangles[rows].tolist()         # one gather: per-row reads cost more than the rows
        return [r for r, content in zip(rows, contents) if v in (edited[r] if r in edited else content)]

    def record(self, rows: ArrayLike, contents: ArrayLike, copies: Sequence[Sequence[int]] = ()) -> None:
        """Rows ``rows`` now hold ``contents`` ``(k, 3)``; ``copies`` are ``(copy, original)`` vertex pairs."""
        rows = np.asarray(rows, dtype=np.int64)
        contents = np.asarray(contents, dtype=np.int64).reshape(-1, 3)
        highest = max([int(contents.max(initial=-1))] + [v for pair in copies for v in pair])
        self._grow_vertices(highest + 1)
        if self._slots + contents.size > len(self._gained):
            self._next, self._gained = (_grown(a, self._slots + contents.size) for a in (self._next, self._gained))
        self._slots = _record_rows(rows, contents, self._head, self._next, self._gained, self._slots)
        for copy, original in copies:
            if copy not in self.twins(original):
                # swapping two ring links joins two rings (and would split one, hence the test)
                self._ring[copy], self._ring[original] = self._ring[original], self._ring[copy]

    def mark(self, vertices: np.ndarray, vertex_count: int) -> tuple:
        """What :meth:`record` may change for rows holding ``vertices`` (and copies of them), to :meth:`restore` it:
        O(len(vertices)). ``vertex_count``: n, the vertex count now (higher ids are the move's new vertices)."""
        vertices = np.asarray(vertices, dtype=np.int64)
        vertices = vertices[vertices < len(self._head)]
        return self._slots, vertex_count, vertices, self._head[vertices], self._ring[vertices]

    def restore(self, mark: tuple) -> None:
        """Take back the :meth:`record` calls since ``mark`` (the slots they filled are free again)."""
        slots, vertex_count, vertices, head, ring = mark
        self._slots = slots
        self._head[vertices], self._ring[vertices] = head, ring
        self._head[vertex_count:] = -1
        self._ring[vertex_count:] = np.arange(vertex_count, len(self._ring))

    def _grow_vertices(self, count: int) -> None:
        """Room for vertices up to ``count`` (×1.5 when full, so a cut's few new vertices cost O(1) amortised)."""
        old = len(self._head)
        if count > old:
            new = max(count, int(1.5 * old) + 16)
            self._head = np.concatenate([self._head, np.full(new - old, -1, dtype=np.int64)])
            self._ring = np.concatenate([self._ring, np.arange(old, new, dtype=np.int64)])
            self._vertex_mark = np.concatenate([self._vertex_mark, np.zeros(new - old, dtype=np.int64)])

    def twins(self, v: int) -> list[int]:
        """The vertices ``v`` was duplicated from or into (either side of a cut)."""
        group, w = [], int(self._ring[v]) if v < len(self._ring) else v
        while w != v:
            group.append(w)
            w = int(self._ring[w])
        return group

    def near(self, triangles: np.ndarray, positions: np.ndarray, low: np.ndarray, high: np.ndarray,
             seeds: ArrayLike) -> np.ndarray:
        """``(k,) int64`` rows whose bounding box (at ``positions``) overlaps the box [``low``, ``high``] and that
        are joined to the rows ``seeds`` through such rows (sharing a vertex or twins), ascending; empty when no
        seed overlaps. A compiled breadth-first walk: its cost grows with the rows it meets, not with the mesh."""
        self._new_walk(len(positions), len(triangles))
        triangles, positions = read_only(triangles), read_only(positions)
        count = _walk(triangles, positions, np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64),
                      np.asarray(seeds, dtype=np.int64), self._rows, self._start, self._built, self._head,
                      self._next, self._gained, self._ring, self._row_mark, self._vertex_mark, self._walks,
                      self._queue)
        return np.sort(self._queue[:count])

    def rows_holding(self, vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
        """``(k,) int64`` the rows of ``triangles`` that hold any of ``vertices`` now, ascending (one compiled pass
        over their candidates)."""
        vertices = np.asarray(vertices, dtype=np.int64)
        self._new_walk(int(vertices.max(initial=-1)) + 1, len(triangles))
        count = _holding(read_only(triangles), vertices, self._rows, self._start, self._built, self._head,
                         self._next, self._gained, self._row_mark, self._walks, self._queue)
        return np.sort(self._queue[:count])

    def joined(self, triangles: np.ndarray, vertex_count: int, vertices: np.ndarray, budget: int, *,
               held: np.ndarray | None = None) -> bool:
        """Whether all of ``vertices`` ``(k,) int`` (ascending) are reached from the first through the triangles
        (``vertex_count`` vertices) sharing vertices (not twins: a cut separates them), and, with ``held``
        ``(vertex_count,) bool``, a held vertex too, visiting at most ``budget`` vertices: a local proof that a
        cut split no piece (and left it held); False says only that the search gave up or did not reach them."""
        vertices = np.asarray(vertices, dtype=np.int64)
        self._new_walk(vertex_count, len(triangles))
        return _joined(read_only(triangles), vertices, int(budget), _NO_HOLD if held is None else held, self._rows,
                       self._start, self._built, self._head, self._next, self._gained, self._vertex_mark, self._walks)

    def _new_walk(self, vertex_count: int, row_count: int) -> None:
        """Room in the marks and the queue, and a new walk number (which unmarks everything at once)."""
        self._grow_vertices(vertex_count)
        if len(self._row_mark) < row_count:
            self._row_mark = _grown(self._row_mark, row_count)
            self._queue = np.zeros(len(self._row_mark), dtype=np.int64)
        self._walks += 1


def read_only(array: np.ndarray) -> np.ndarray:
    """A read-only view of ``array``: the compiled kernels then see one array type whoever owns it (one
    compilation, not one per writeable flag)."""
    view = array.view()
    view.flags.writeable = False
    return view


def _grown(array: np.ndarray, length: int) -> np.ndarray:
    """``array`` with room for at least ``length`` entries (×1.5, so appends are amortised O(1)); new ones 0."""
    grown = np.zeros(max(length, int(1.5 * len(array)) + 16), dtype=array.dtype)
    grown[:len(array)] = array
    return grown


@njit(cache=True)
def _walk(triangles, positions, low, high, seeds, rows, start, built, head, next_slot, gained, ring, row_mark,
          vertex_mark, walk, queue):
    """Breadth-first over rows from ``seeds``: a row whose box overlaps [low, high] is kept (moved to the front
    of ``queue``) and its corners' and their twins' candidate rows are queued. Returns the count kept."""
    queued = 0
    for r in seeds:
        if r < row_mark.size and row_mark[r] != walk:
            row_mark[r] = walk
            queue[queued] = r
            queued += 1
    kept, head_index = 0, 0
    while head_index < queued:
        r = queue[head_index]
        head_index += 1
        if not _box_overlaps(positions, triangles[r], low, high):
            continue
        queue[kept] = r         # kept rows are never read again from the queue: it is safe to overwrite
        kept += 1
        for c in range(3):
            v = triangles[r, c]
            w = v
            while True:
                if vertex_mark[w] != walk:
                    vertex_mark[w] = walk
                    if w < built:
                        for k in range(start[w], start[w + 1]):
                            queued = _enqueue(rows[k], row_mark, walk, queue, queued, triangles.shape[0])
                    slot = head[w]
                    while slot >= 0:
                        queued = _enqueue(gained[slot], row_mark, walk, queue, queued, triangles.shape[0])
                        slot = next_slot[slot]
                w = ring[w]
                if w == v:
                    break
    return kept


@njit(cache=True)
def _record_rows(rows, contents, head, next_slot, gained, slots):
    """Push each row onto the gained list of each of its corners that does not list it yet; the new slot count."""
    for i in range(rows.size):
        for c in range(3):
            v, r = contents[i, c], rows[i]
            slot = head[v]
            while slot >= 0 and gained[slot] != r:
                slot = next_slot[slot]
            if slot < 0:
                gained[slots], next_slot[slots] = r, head[v]
                head[v] = slots
                slots += 1
    return slots


@njit(cache=True)
def _holding(triangles, vertices, rows, start, built, head, next_slot, gained, row_mark, walk, out):
    """Write into ``out`` the rows holding any of ``vertices`` (each once); returns their count."""
    count = 0
    for v in vertices:
        if v < built:
            for k in range(start[v], start[v + 1]):
                count = _take_if_holding(triangles, rows[k], v, row_mark, walk, out, count)
        slot = head[v] if v < head.size else -1
        while slot >= 0:
            count = _take_if_holding(triangles, gained[slot], v, row_mark, walk, out, count)
            slot = next_slot[slot]
    return count


@njit(cache=True)
def _joined(triangles, targets, budget, held, rows, start, built, head, next_slot, gained, vertex_mark, walk):
    """Breadth-first from ``targets[0]`` over the rows holding each vertex; True once every vertex of the ascending
    ``targets`` and a ``held`` one (any vertex, where ``held`` is empty) are reached, False when ``budget``
    vertices were visited first or the piece ends."""
    if targets.size == 0:
        return True
    queue = np.empty(budget + 3, dtype=np.int64)
    queue[0] = targets[0]
    vertex_mark[targets[0]] = walk
    found, size, head_of_queue, anchored = 1, 1, 0, held.size == 0 or held[targets[0]]
    if found == targets.size and anchored:
        return True
    while head_of_queue < size:
        v = queue[head_of_queue]
        head_of_queue += 1
        slot = head[v] if v < head.size else -1
        k = start[v] if v < built else 0
        end = start[v + 1] if v < built else 0
        while k < end or slot >= 0:
            if k < end:
                r = rows[k]
                k += 1
            else:
                r = gained[slot]
                slot = next_slot[slot]
            if r >= triangles.shape[0] or not (triangles[r, 0] == v or triangles[r, 1] == v or triangles[r, 2] == v):
                continue
            for c in range(3):
                w = triangles[r, c]
                if vertex_mark[w] == walk:
                    continue
                if size > budget:
                    return False
                vertex_mark[w] = walk
                queue[size] = w
                size += 1
                anchored = anchored or held[w]
                at = np.searchsorted(targets, w)
                if at < targets.size and targets[at] == w:
                    found += 1
                if found == targets.size and anchored:
                    return True
    return False


@njit(cache=True)
def _take_if_holding(triangles, r, v, row_mark, walk, out, count):
    if r < triangles.shape[0] and row_mark[r] != walk and \
            (triangles[r, 0] == v or triangles[r, 1] == v or triangles[r, 2] == v):
        row_mark[r] = walk
        out[count] = r
        count += 1
    return count


@njit(cache=True)
def _enqueue(r, row_mark, walk, queue, queued, row_count):
    if r < row_count and row_mark[r] != walk:
        row_mark[r] = walk
        queue[queued] = r
        queued += 1
    return queued


@njit(cache=True)
def _box_overlaps(positions, corners, low, high):
    for k in range(3):
        a, b, c = positions[corners[0], k], positions[corners[1], k], positions[corners[2], k]
        if min(a, b, c) > high[k] or max(a, b, c) < low[k]:
            return False
    return True
