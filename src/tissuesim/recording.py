"""Recording the simulated surface for ParaView, and reading a recording back.

A recording is a ParaView collection: ``NAME.pvd`` lists one VTU file per frame (written through meshio) in the
folder ``NAME_frames/`` beside it, each with its simulation time. Every VTU holds the M_S surface of that frame:

* points: the current positions ``(n, 3)`` [m]; cells: the triangles, then the *cut edges* as line cells;
* point data ``displacement`` ``(n, 3)`` [m] (position − rest position) and ``force`` ``(n, 3)`` [N] (the external
  load, zero but at the loaded node);
* cell data ``cut`` (1 on the cut-edge lines, 0 on triangles), so ParaView's Threshold shows the incision alone.

The cut edges are the surface's *border* edges (edges of one triangle only): the input surface is closed, so every
border edge was opened by an incision. The topology may change between frames (a cut adds vertices), which a
series of separate VTU files allows.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .errors import TissuesimError

FLUSH_EVERY = 50  # frames between rewrites of the .pvd index, so an interrupted recording stays readable


class RecordingError(TissuesimError, OSError):
    """A recording cannot be written or read where asked."""


@dataclass(frozen=True)
class Frame:
    """One recorded frame.

    Attributes:
        time: simulation time [s]. positions: ``(n, 3) float64`` [m]. triangles: ``(m, 3) int32``.
        displacement: ``(n, 3) float64`` [m]. force: ``(n, 3) float64`` [N]. cut_edges: ``(k, 2) int32``.
    """

    time: float
    positions: np.ndarray
    triangles: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    cut_edges: np.ndarray


def border_edges(triangles: np.ndarray) -> np.ndarray:
    """``(k, 2) int32`` edges that belong to exactly one of the ``(m, 3)`` triangles (sorted pairs)."""
    directed = np.sort(np.asarray(triangles)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(directed, axis=0, return_counts=True)
    return edges[counts == 1].astype(np.int32)


def solver_frame(solver, time: float) -> Frame:
    """The :class:`Frame` of a solver's current state at simulation ``time`` [s]."""
    triangles = solver.hybrid.surface.triangles
    return Frame(float(time), solver.positions.copy(), triangles, solver.displacements, solver.forces.copy(),
                 border_edges(triangles))


class Recorder:
    """Writes frames into ``path`` (a ``.pvd`` file) and ``<stem>_frames/`` beside it; use as a context manager.

    Args:
        path: the ``.pvd`` file to write; its folder must exist. An existing recording of that name is replaced.
    """

    def __init__(self, path):
        self.path = Path(path)
        if self.path.suffix.lower() != ".pvd":
            raise RecordingError(f"a recording is a ParaView .pvd file, got {str(self.path)!r}; name it e.g. "
                                 "session.pvd")
        if not self.path.parent.is_dir():
            raise RecordingError(f"cannot record to {str(self.path)!r}: folder {str(self.path.parent)!r} does not "
                                 "exist")
        self.folder = self.path.with_name(self.path.stem + "_frames")
        self.folder.mkdir(exist_ok=True)
        for old in self.folder.glob("frame_*.vtu"):
            old.unlink()
        self._entries: list[tuple[float, str]] = []

    @property
    def frame_count(self) -> int:
        return len(self._entries)

    def add(self, frame: Frame) -> Path:
        """Write one frame; returns its VTU path."""
        import meshio

        name = f"frame_{len(self._entries):06d}.vtu"
        cells = [("triangle", frame.triangles)]
        cut = [np.zeros(len(frame.triangles), dtype=np.int8)]
        if len(frame.cut_edges):
            cells.append(("line", frame.cut_edges))
            cut.append(np.ones(len(frame.cut_edges), dtype=np.int8))
        mesh = meshio.Mesh(frame.positions, cells, point_data={"displacement": frame.displacement,
                                                               "force": frame.force}, cell_data={"cut": cut})
        mesh.write(self.folder / name, binary=True)
        self._entries.append((frame.time, f"{self.folder.name}/{name}"))
        if len(self._entries) % FLUSH_EVERY == 0:
            self.close()
        return self.folder / name

    def close(self) -> Path:
        """Write the ``.pvd`` index of the frames so far; returns its path."""
        rows = "\n".join(f'    <DataSet timestep="{t!r}" part="0" file={quoteattr(f)}/>' for t, f in self._entries)
        self.path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
                             f'byte_order="LittleEndian">\n  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n')
        return self.path

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_recording(path) -> list[Frame]:
    """The frames of the recording ``path`` (a ``.pvd`` written by :class:`Recorder`), in time order."""
    import xml.etree.ElementTree as ElementTree

    import meshio

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"no recording at {str(path)!r}; record one with tissuesim view --record FILE.pvd")
    try:
        datasets = ElementTree.parse(path).getroot().iter("DataSet")
        entries = sorted((float(d.get("timestep")), d.get("file")) for d in datasets)
    except (ElementTree.ParseError, TypeError, ValueError) as error:
        raise RecordingError(f"{str(path)!r} is not a ParaView collection (.pvd): {error}") from None
    frames = []
    for time, name in entries:
        mesh = meshio.read(path.parent / name)
        blocks = {block.type: block.data for block in mesh.cells}
        frames.append(Frame(time, mesh.points, blocks["triangle"].astype(np.int32), mesh.point_data["displacement"],
                            mesh.point_data["force"], blocks.get("line", np.zeros((0, 2))).astype(np.int32)))
    return frames
