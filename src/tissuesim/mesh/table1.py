"""Table 1 of the paper for a :class:`~tissuesim.mesh.hybrid.HybridMesh`: nodes, elements and size of M_S, M_V and
the fine volume.

*Size* is the byte count of the mesh as an ASCII file, in kB (1000 bytes), as the paper's sizes suggest: a surface as
OBJ (``v x y z`` with ``%.8g`` coordinates in metres, ``f a b c`` 1-based), a volume as TetGen ``.node`` + ``.ele``
files.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .surface import SurfaceMesh
from .tetmesh import TetMesh

if TYPE_CHECKING:
    from .hybrid import HybridMesh

TABLE1_HEADER = ("| model | M_S #node | M_S #elem | M_S size (kB) | M_V #node | M_V #elem | M_V size (kB) "
                 "| fine #node | fine #elem | fine size (kB) |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def table1_row(hybrid: HybridMesh) -> dict:
    """Table 1's figures of ``hybrid`` (a HybridMesh): ``{"M_S": {...}, "M_V": {...}, "fine": {...} or None}``, each ``{"nodes", "elements", "size_kb"}``.

    Size is the byte count of the mesh as an ASCII file (OBJ for M_S; TetGen ``.node`` + ``.ele`` for volumes), in
    kB of 1000 bytes.
    """
    s, v, f = hybrid.surface, hybrid.volume, hybrid.fine_volume
    row = {"M_S": {"nodes": s.vertex_count, "elements": s.triangle_count, "size_kb": ascii_size(s) / 1000.0},
           "M_V": {"nodes": v.node_count, "elements": v.element_count, "size_kb": ascii_size(v) / 1000.0},
           "fine": None}
    if f is not None:
        row["fine"] = {"nodes": f.node_count, "elements": f.element_count, "size_kb": ascii_size(f) / 1000.0}
    return row


def table1_markdown(rows: dict) -> str:
    """A Markdown table (header included) of ``{model name: table1_row(...)}``."""
    lines = [TABLE1_HEADER]
    for name, row in rows.items():
        cells = [name]
        for part in ("M_S", "M_V", "fine"):
            entry = row[part]
            cells += ["-", "-", "-"] if entry is None else [str(entry["nodes"]), str(entry["elements"]),
                                                           f"{entry['size_kb']:.0f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def ascii_size(mesh: SurfaceMesh | TetMesh) -> int:
    """Bytes of ``mesh`` written as ASCII: OBJ for a surface, TetGen .node + .ele for a volume (``%.8g`` metres)."""
    if isinstance(mesh, SurfaceMesh):
        points, cells, base = mesh.vertices, mesh.triangles, 1
        text = [f"v {x:.8g} {y:.8g} {z:.8g}\n" for x, y, z in points.tolist()]
        text += ["f " + " ".join(str(i + base) for i in cell) + "\n" for cell in cells.tolist()]
        return sum(len(line) for line in text)
    points, cells = mesh.points, mesh.tets
    text = [f"{len(points)} 3 0 0\n"] + [f"{k} {x:.8g} {y:.8g} {z:.8g}\n" for k, (x, y, z) in
                                         enumerate(points.tolist())]
    text += [f"{len(cells)} 4 0\n"] + [f"{k} " + " ".join(map(str, cell)) + "\n" for k, cell in
                                       enumerate(cells.tolist())]
    return sum(len(line) for line in text)
