"""One cut's view of the triangle rows (:class:`RowPatch`): every row the cut reads or writes goes through it, so
the cut is planned without writing an array (a solver can still refuse it) and applied afterwards, to new arrays or
in place.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .fans import VertexFans


class RowPatch:
    """The triangle rows of one cut: the array before it (never written) with the rows the cut rewrites and appends.

    Args:
        triangles: ``(m, 3) int`` triangles before the cut.
        fans: their :class:`~.fans.VertexFans`.
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

    def write(self, r: int, content: Iterable[int]) -> None:
        self._fans.clear()
        content = [int(x) for x in content]
        if r < self.m:
            self.edited[r] = content
        else:
            self.added[r - self.m] = content

    def append(self, contents: Iterable[Iterable[int]]) -> None:
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
