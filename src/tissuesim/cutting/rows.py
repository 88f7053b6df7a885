"""Constraint arrays that a cut edits locally: retired rows become no-ops, new rows reuse free slots or append.

The step kernels sweep whole arrays, so a retired stretch row is set to the edge (0, 0) and a retired hinge to
(0, 0, 0, 0): both are degenerate, and the kernels skip degenerate constraints (zero length, zero normal), so
no kernel needs a mask. Capacity grows by 5 % (at least 64 rows) when the free list runs dry, so appending is
amortised O(1) and a cut never rebuilds the arrays of the whole mesh (few no-op rows are swept: measured 63 of 4252
after 40 cutting moves).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

GROWTH = 1.05
#: Fewest rows added when the arrays grow.
MIN_GROWTH = 64


class EdgeRows:
    """Edge → constraint row, for the edges of the whole mesh. Keyed by one int per edge (lo · 2³² + hi): a dict of
    ints is not tracked by Python's garbage collector, while one of tuples over a whole mesh is traversed by every
    full collection (measured: +1–2 ms per cutting move at 100k vertices).

    Args:
        edges: ``(k, 2) int`` vertex pairs (any order within a pair).
        rows: ``(k,) int`` their rows.
    """

    def __init__(self, edges: np.ndarray, rows: np.ndarray):
        edges = np.sort(np.asarray(edges, dtype=np.int64).reshape(-1, 2), axis=1)
        self._row = dict(zip(_codes(edges), np.asarray(rows).tolist()))
        self._journal: list | None = None       # (code, row before or None) per change, while a move may fail

    def begin(self) -> None:
        """Keep what changes from now on, so :meth:`undo` can take it back (O(changes), not O(edges))."""
        self._journal = []

    def undo(self) -> None:
        """Take back every change since :meth:`begin`."""
        row = self._row
        for code, before in reversed(self._journal or []):
            if before is None:
                row.pop(code, None)
            else:
                row[code] = before
        self._journal = None

    def commit(self) -> None:
        """Keep the changes since :meth:`begin` (and stop recording them)."""
        self._journal = None

    def pop(self, keys: np.ndarray) -> list[int]:
        """Remove the edges of ``keys`` ``(k, 2) int`` (lo < hi) that have a row; their rows."""
        row = self._row
        popped = [(c, row.pop(c)) for c in _codes(keys) if c in row]
        if self._journal is not None:
            self._journal += popped
        return [r for _, r in popped]

    def get(self, keys: np.ndarray) -> np.ndarray:
        """``(k,) int64`` the rows of the edges ``keys`` ``(k, 2) int`` (lo < hi), −1 where an edge has none."""
        row = self._row
        return np.array([row.get(c, -1) for c in _codes(keys)], dtype=np.int64)

    def update(self, keys: np.ndarray, rows: np.ndarray) -> None:
        """Edges ``keys`` ``(k, 2) int`` (lo < hi) now have rows ``rows`` ``(k,)``."""
        codes = _codes(keys)
        if self._journal is not None:
            self._journal += [(c, self._row.get(c)) for c in codes]
        self._row.update(zip(codes, np.asarray(rows).tolist()))


def _codes(keys) -> list[int]:
    keys = np.asarray(keys, dtype=np.int64).reshape(-1, 2)
    return ((keys[:, 0] << 32) | keys[:, 1]).tolist()


class Rows:
    """Named parallel arrays with a free list: ``take(k)`` gives k row indices, ``retire(rows)`` frees them."""

    def __init__(self, arrays: dict[str, np.ndarray], used: int, retired: dict[str, object]):
        self.arrays = arrays
        self.retired = retired      # the no-op value of each array
        self.free: list[int] = []
        self.used = used
        self._saved = None      # what :meth:`undo` restores, while a move may fail

    def begin(self) -> None:
        """Keep the state and every row retired from now on, so :meth:`undo` can take it back (O(changes))."""
        self._saved = (dict(self.arrays), list(self.free), self.used, [])

    def undo(self) -> None:
        """Take back every change since :meth:`begin`: the arrays as they were (the rows retired get their content
        back, the rows taken their no-op value), the free list and the count."""
        arrays, free, used, retired = self._saved
        taken = np.array(sorted(set(free) - set(self.free)) + list(range(used, min(self.used, self.capacity))),
                         dtype=np.int64)
        taken = taken[taken < len(next(iter(arrays.values())))]
        for name, array in arrays.items():
            array[taken] = self.retired[name]
            for rows, content in reversed(retired):
                array[rows] = content[name]
        self.arrays.clear()
        self.arrays.update(arrays)
        self.free, self.used, self._saved = free, used, None

    def commit(self) -> None:
        """Keep the changes since :meth:`begin` (and stop recording them)."""
        self._saved = None

    @property
    def capacity(self) -> int:
        return len(next(iter(self.arrays.values())))

    def take(self, count: int) -> tuple[np.ndarray, bool]:
        """``count`` free rows (``(count,) int64``) and whether the arrays were reallocated."""
        rows = [self.free.pop() for _ in range(min(count, len(self.free)))]
        grown = False
        need = count - len(rows)
        if self.used + need > self.capacity:
            new_capacity = max(int(self.capacity * GROWTH), self.capacity + MIN_GROWTH, self.used + need)
            for name, array in self.arrays.items():
                bigger = np.empty((new_capacity,) + array.shape[1:], dtype=array.dtype)
                bigger[: len(array)] = array
                bigger[len(array):] = self.retired[name]
                self.arrays[name] = bigger
            grown = True
        rows += list(range(self.used, self.used + need))
        self.used += need
        return np.array(rows, dtype=np.int64), grown

    def retire(self, rows: ArrayLike) -> None:
        rows = np.asarray(rows, dtype=np.int64)
        if self._saved is not None:
            self._saved[3].append((rows, {name: array[rows].copy() for name, array in self.arrays.items()}))
        for name, array in self.arrays.items():
            array[rows] = self.retired[name]
        self.free += rows.tolist()
