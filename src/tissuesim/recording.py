"""Recording the simulated surface for ParaView, and reading a recording back.

A recording is a ParaView collection: ``NAME.pvd`` lists one VTU file per frame (written through meshio) in the
folder ``NAME_frames/`` beside it, each with its simulation time. Every VTU holds the M_S surface of that frame:

* points: the current positions ``(n, 3)`` [m]; cells: the triangles, then the *cut edges* as line cells;
* point data ``displacement`` ``(n, 3)`` [m] (position − rest position) and ``force`` ``(n, 3)`` [N] (the external
  load, zero but at the loaded node);
* cell data ``cut`` (1 on the cut-edge lines, 0 on triangles), so ParaView's Threshold shows the incision alone;
* beside it, where tools act, ``frame_N.tools.json``: each pin-head's held vertex and cursor, each probe's centre and
  radius, the scalpel's depth (:class:`Tools`), so a replay draws them where they were (meshio's VTU writer keeps no
  field data; ParaView ignores the file).

The cut edges are the surface's *border* edges (edges of one triangle only): the input surface is closed, so every
border edge was opened by an incision. The topology may change between frames (a cut adds vertices), which a
series of separate VTU files allows.

A frame is written only when something changed since the last one written: the surface was cut, the load
changed, or a vertex moved more than :data:`MIN_MOTION` (a tissue at rest writes nothing). A recording is written
under a temporary name beside its target (the folder ``NAME_frames.partial-PID-N``, readable on its own through the
index inside it, written at the first frame and every :data:`FLUSH_EVERY` frames) and takes the target's place only
when it is closed, so an old recording of that name survives until the new one is complete. The partial folder of
a killed session stays until a new recording of that name starts, which removes those whose process is gone.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np

from .errors import first_indices
from .recording_place import (RecordingError, check_target, fresh_folder, frames_folder, partial_stem,
                              remove_path, remove_stale_partials)

if TYPE_CHECKING:
    from .solvers.base import Solver

FLUSH_EVERY = 50  # frames between rewrites of the .pvd index, so an interrupted recording stays readable
MIN_MOTION = 1e-6  # m: a frame in which no vertex moved farther than this since the last frame written (and
# neither the load nor the surface changed) is not written: 1 um is far below what a tissue model of centimetres
# shows, and far above the round-off of a solver at rest
MAX_COORDINATE = 1e6  # m: a frame with a point farther from the origin is refused. A model is at most 100 m across
# (the build's bound) and the runaway guard stops a simulation at 100 model sizes, so 1e6 m is never recorded; it is
# far inside float32 (3.4e38), which the viewer draws in, and a camera can still frame it
MIN_EXTENT = 1e-9  # m: a frame whose points span less (all in one place) is refused: a model is at least 1 um
# across, and a viewer cannot frame a single point (polyscope blocks in a modal dialog)


#: A frame's tools file larger than this [bytes] is refused: about 10,000 tools, more than any session holds.
MAX_TOOLS_BYTES = 640_000


@dataclass(frozen=True)
class Tools:
    """The tools acting in a frame, for a replay to draw them where they were.

    Attributes:
        pin_heads: ``(k, 2, 3) float64`` [m] each pin-head's held vertex and its cursor (eq 24's spring).
        probes: ``(p, 4) float64`` [m] each probe's centre and radius.
        blade_depth: the scalpel's depth [m] (a wound's walls reach it), 0 without a scalpel.
        graspers: ``(g, 4) float64`` [m] each grasper's jaws: their position and reach.
    """

    pin_heads: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))
    probes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    blade_depth: float = 0.0
    graspers: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))

    @property
    def empty(self) -> bool:
        return (len(self.pin_heads) == 0 and len(self.probes) == 0 and self.blade_depth == 0.0
                and len(self.graspers) == 0)


@dataclass(frozen=True)
class Frame:
    """One recorded frame.

    Attributes:
        time: simulation time [s]. positions: ``(n, 3) float64`` [m]. triangles: ``(m, 3) int32``.
        displacement: ``(n, 3) float64`` [m]. force: ``(n, 3) float64`` [N]. cut_edges: ``(k, 2) int32``.
        tools: the :class:`Tools` acting (none by default).
    """

    time: float
    positions: np.ndarray
    triangles: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    cut_edges: np.ndarray
    tools: Tools = field(default_factory=Tools)


def border_edges(triangles: np.ndarray) -> np.ndarray:
    """``(k, 2) int32`` edges that belong to exactly one of the ``(m, 3)`` triangles (sorted pairs)."""
    directed = np.sort(np.asarray(triangles)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(directed, axis=0, return_counts=True)
    return edges[counts == 1].astype(np.int32)


def solver_frame(solver: Solver, time: float, *, tools: Tools | None = None) -> Frame:
    """The :class:`Frame` of a solver's current state at simulation ``time`` [s], with the ``tools`` acting."""
    triangles = solver.hybrid.surface.triangles
    return Frame(float(time), solver.positions.copy(), triangles, solver.displacements, solver.forces.copy(),
                 border_edges(triangles), Tools() if tools is None else tools)


def tools_of(pin_heads: Iterable[tuple[np.ndarray, np.ndarray]] = (), probes: Iterable[tuple[np.ndarray, float]] = (),
             blade_depth: float = 0.0, graspers: Iterable[tuple[np.ndarray, float]] = ()) -> Tools:
    """:class:`Tools` from ``pin_heads`` ``[(vertex position (3,), cursor (3,))]`` [m], ``probes``
    ``[(centre (3,), radius)]`` [m], ``blade_depth`` [m] and ``graspers`` ``[(jaws' position (3,), reach)]`` [m]."""
    pins = np.array([np.concatenate([held, cursor]) for held, cursor in pin_heads], dtype=np.float64)
    probes = np.array([[*centre, radius] for centre, radius in probes], dtype=np.float64)
    jaws = np.array([[*position, reach] for position, reach in graspers], dtype=np.float64)
    return Tools(pins.reshape(-1, 2, 3), probes.reshape(-1, 4), float(blade_depth), jaws.reshape(-1, 4))


class Recorder:
    """Writes frames into ``path`` (a ``.pvd`` file) and ``<stem>_frames/`` beside it; use as a context manager.

    Args:
        path: the ``.pvd`` file to write (:func:`check_target`). An existing recording of that name is replaced
            when this one is closed, not before.
        min_motion: a frame is written when a vertex moved more than this [m] since the last one written, or the
            load or the surface changed (default :data:`MIN_MOTION`; 0 writes every frame that changed at all).

    Leaving the ``with`` block by an exception discards the new recording and keeps the old one (:meth:`abort`).
    The viewer does otherwise: Ctrl-C or SIGTERM ends a session as closing its window does, and what was recorded
    is kept (:meth:`tissuesim.viewer.app.ViewerApp.close`).
    """

    def __init__(self, path: Path | str, *, min_motion: float = MIN_MOTION):
        self.path = check_target(path)
        self.folder = frames_folder(self.path)
        self.min_motion = _distance(min_motion)
        remove_stale_partials(self.path)
        self._partial = fresh_folder(self.path.parent, partial_stem(self.path))
        self._entries: list[tuple[float, str]] = []
        self._last = None  # (positions, triangles, force) of the last frame written

    @property
    def frame_count(self) -> int:
        return len(self._entries)

    def add(self, frame: Frame) -> bool:
        """Write ``frame`` if it changed (see ``min_motion``); returns whether it was written."""
        import meshio

        if not self._changed(frame):
            return False
        name = f"frame_{len(self._entries):06d}.vtu"
        cells = [("triangle", frame.triangles)]
        cut = [np.zeros(len(frame.triangles), dtype=np.int8)]
        if len(frame.cut_edges):
            cells.append(("line", frame.cut_edges))
            cut.append(np.ones(len(frame.cut_edges), dtype=np.int8))
        mesh = meshio.Mesh(frame.positions, cells, point_data={"displacement": frame.displacement,
                                                               "force": frame.force}, cell_data={"cut": cut})
        try:
            mesh.write(self._partial / name, binary=True)
            if not frame.tools.empty:
                (self._partial / _tools_name(name)).write_text(json.dumps(
                    {"pin_heads": frame.tools.pin_heads.reshape(-1, 6).tolist(),
                     "probes": frame.tools.probes.tolist(), "blade_depth": frame.tools.blade_depth,
                     "graspers": frame.tools.graspers.tolist()}))
            if len(self._entries) == 0 or (len(self._entries) + 1) % FLUSH_EVERY == 0:
                _write_index(self._partial / self.path.name, self._entries + [(frame.time, name)], "")
        except OSError as error:  # e.g. a full disk
            where = f"frame {len(self._entries)} into {str(self._partial)!r}"
            raise RecordingError(f"cannot write {where}: {error}") from None
        self._entries.append((frame.time, name))
        self._last = (frame.positions.copy(), np.array(frame.triangles), frame.force.copy())
        return True

    def _changed(self, frame: Frame) -> bool:
        if self._last is None:
            return True
        positions, triangles, force = self._last
        if not np.array_equal(triangles, frame.triangles):
            return True  # a cut
        if not np.array_equal(force, frame.force):  # the load: assigned values, any change counts
            return True
        return float(np.max(np.linalg.norm(frame.positions - positions, axis=1))) > self.min_motion

    def close(self) -> Path:
        """Write the ``.pvd`` index and put the recording in place of any old one of that name; returns its path."""
        if self._partial is None:
            return self.path
        try:
            index = self._partial / (self.path.name + ".final")
            _write_index(index, self._entries, self.folder.name + "/")
            (self._partial / self.path.name).unlink(missing_ok=True)  # the partial index, which names no folder
            old = self._swap(index.name)
        except OSError as error:
            where = self._partial if self._partial.exists() else self.folder
            raise RecordingError(f"cannot put the recording in place at {str(self.path)!r} ({error}); its frames "
                                 f"are in {str(where)!r}") from None
        self._partial = None
        if old is not None:
            remove_path(old)
        return self.path

    def _swap(self, index: str) -> Path | None:
        """The new frames folder takes the old one's name (moved aside: returned, else None), then its ``index``
        file replaces the old ``.pvd`` in one atomic rename."""
        old = self._partial.with_name(self._partial.name + "-old") if self.folder.exists() else None
        if old is not None:
            self.folder.rename(old)
        try:
            self._partial.rename(self.folder)
        except OSError:
            if old is not None:
                old.rename(self.folder)
            raise
        os.replace(self.folder / index, self.path)
        return old

    def abort(self) -> None:
        """Discard this recording (its frames so far); an old recording of that name stays as it was."""
        if self._partial is not None:
            remove_path(self._partial)
            self._partial = None

    def __enter__(self):
        return self

    def __exit__(self, kind, error, trace):
        if kind is None:
            self.close()
        else:
            self.abort()


def _distance(min_motion) -> float:
    """``min_motion`` as a finite float [m] of at least 0, or a :class:`RecordingError` (a bool or a string is no
    distance)."""
    try:
        if isinstance(min_motion, (bool, np.bool_, str, bytes)):
            raise TypeError
        value = float(min_motion)
    except (TypeError, ValueError):
        value = float("nan")
    if not (np.isfinite(value) and value >= 0.0):
        raise RecordingError(f"min_motion must be a finite distance of at least 0 m, got {min_motion!r}")
    return value


def _write_index(path: Path, entries, prefix: str) -> None:
    """The ParaView collection of ``entries`` ``[(time [s], VTU name)]``, each name under ``prefix``."""
    rows = "\n".join(f'    <DataSet timestep="{float(t)!r}" part="0" file={quoteattr(prefix + name)}/>'
                     for t, name in entries)
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
                    f'byte_order="LittleEndian">\n  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n')


def read_recording(path: Path | str, *, progress: bool = False) -> list[Frame]:
    """The frames of the recording ``path`` (a ``.pvd`` written by :class:`Recorder`), in time order, all in memory
    (checked before a viewer opens); ``progress`` shows a tqdm bar on stderr (a long recording takes seconds).

    A damaged or foreign recording raises a :class:`RecordingError` naming the file and the defect: an index that
    is not a collection or lists no frame, a missing or unreadable VTU, no triangles, indices out of range,
    missing or wrongly shaped point data, non-finite values, points beyond :data:`MAX_COORDINATE` or spanning
    less than :data:`MIN_EXTENT`."""
    from tqdm import tqdm

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"no recording at {str(path)!r}; record one with tissuesim view --record FILE.pvd")
    entries = _index(path)
    return [_read_frame(path.parent / name, time)
            for time, name in tqdm(entries, disable=not progress, unit="frame", leave=False, desc="reading")]


def _index(path: Path) -> list[tuple[float, str]]:
    """``[(time [s], VTU name relative to path's folder)]`` of the collection ``path``, in time order."""
    import xml.etree.ElementTree as ElementTree

    try:
        datasets = list(ElementTree.parse(path).getroot().iter("DataSet"))
    except (ElementTree.ParseError, OSError, UnicodeDecodeError) as error:
        raise RecordingError(f"{str(path)!r} is not a ParaView collection (.pvd): {error}") from None
    if not datasets:
        raise RecordingError(f"{str(path)!r} lists no frame (no <DataSet>); record again")
    entries = []
    for i, dataset in enumerate(datasets):
        name, time = dataset.get("file"), dataset.get("timestep", "")
        if not name:
            raise RecordingError(f"{str(path)!r}: <DataSet> {i} names no file; the index is damaged, record again")
        try:
            time = float(time)
        except ValueError:
            time = float("nan")
        if not np.isfinite(time):
            raise RecordingError(f"{str(path)!r}: <DataSet> {i} ({name}) has no finite timestep, got "
                                 f"{dataset.get('timestep')!r}")
        entries.append((time, name))
    return sorted(entries)


def _read_frame(file: Path, time: float) -> Frame:
    """The :class:`Frame` in the VTU ``file``, checked (see :func:`read_recording`)."""
    import meshio.vtu

    if not file.is_file():
        raise RecordingError(f"frame file {str(file)!r} is missing; the recording is incomplete")
    if file.suffix.lower() != ".vtu":
        raise RecordingError(f"frame file {str(file)!r} is not a VTU file (.vtu), which is all a recording holds")
    try:  # meshio.vtu.read raises where meshio.read prints and exits the process
        mesh = meshio.vtu.read(str(file))
    except Exception as error:  # a truncated or foreign file: any parser error means the same to the user
        raise RecordingError(f"cannot read frame file {str(file)!r}: truncated or not a VTU file"
                             + (f" ({error})" if str(error) else "")) from None
    points = np.asarray(mesh.points, dtype=np.float64)
    triangles, lines = mesh.get_cells_type("triangle"), mesh.get_cells_type("line")
    if len(triangles) == 0:
        kinds = ", ".join(sorted({block.type for block in mesh.cells})) or "none"
        raise RecordingError(f"frame file {str(file)!r} holds no triangles (cells: {kinds}); a recording holds "
                             "the surface's triangles")
    data = {name: _point_data(file, mesh, name, len(points)) for name in ("displacement", "force")}
    _check_finite(file, "positions", points)
    _check_extent(file, points)
    for kind, cells in (("triangle", triangles), ("line", lines)):
        bad = np.flatnonzero(np.any((cells < 0) | (cells >= len(points)), axis=1))
        if bad.size:
            raise RecordingError(f"frame file {str(file)!r}: {bad.size} {kind} cells name points outside 0.."
                                 f"{len(points) - 1} (first cells {first_indices(bad)})")
    return Frame(time, points, triangles.astype(np.int32), data["displacement"], data["force"],
                 lines.reshape(-1, 2).astype(np.int32), _read_tools(file.with_name(_tools_name(file.name))))


def _tools_name(frame_name: str) -> str:
    """The tools file of the VTU ``frame_name``."""
    return frame_name[: -len(".vtu")] + ".tools.json"


def _read_tools(file: Path) -> Tools:
    """The frame's :class:`Tools` from its tools file (none where there is no file: a frame without tools, or a
    recording older than tools), checked."""
    if not file.is_file():
        return Tools()
    if file.stat().st_size > MAX_TOOLS_BYTES:
        raise RecordingError(f"tools file {str(file)!r} is {file.stat().st_size} bytes, more than a session's "
                             "tools take; it was not written by tissuesim")
    try:
        data = json.loads(file.read_text())
        pins = np.array(data.get("pin_heads", []), dtype=np.float64).reshape(-1, 6)
        probes = np.array(data.get("probes", []), dtype=np.float64).reshape(-1, 4)
        depth = float(data.get("blade_depth", 0.0))
        jaws = np.array(data.get("graspers", []), dtype=np.float64).reshape(-1, 4)
    except (ValueError, TypeError, AttributeError, OSError, UnicodeDecodeError) as error:
        raise RecordingError(f"cannot read tools file {str(file)!r}: {error}") from None
    if not (np.all(np.isfinite(pins)) and np.all(np.isfinite(probes)) and np.all(np.isfinite(jaws))
            and np.isfinite(depth) and depth >= 0.0 and np.all(probes[:, 3] > 0.0) and np.all(jaws[:, 3] > 0.0)):
        raise RecordingError(f"tools file {str(file)!r} holds non-finite values or a radius or depth below 0")
    return Tools(pins.reshape(-1, 2, 3), probes, depth, jaws)


def _point_data(file: Path, mesh, name: str, count: int) -> np.ndarray:
    """``(count, 3) float64`` point data ``name`` of ``mesh``, checked."""
    if name not in mesh.point_data:
        raise RecordingError(f"frame file {str(file)!r} has no point data {name!r} (it has "
                             f"{', '.join(mesh.point_data) or 'none'}); it was not written by tissuesim")
    values = np.asarray(mesh.point_data[name], dtype=np.float64)
    if values.shape != (count, 3):
        raise RecordingError(f"frame file {str(file)!r}: point data {name!r} has shape {values.shape}, expected "
                             f"({count}, 3) for its {count} points")
    _check_finite(file, name, values)
    return values


def _check_extent(file: Path, points: np.ndarray) -> None:
    """RecordingError unless the frame's points lie within MAX_COORDINATE of the origin and span at least
    MIN_EXTENT (a viewer cannot frame a point, nor coordinates its float32 drawing turns into infinities)."""
    far = np.flatnonzero(np.any(np.abs(points) > MAX_COORDINATE, axis=1))
    if far.size:
        raise RecordingError(f"frame file {str(file)!r}: {far.size} points lie farther than {MAX_COORDINATE:g} m "
                             f"from the origin (first points {first_indices(far)}, e.g. {points[far[0]].tolist()}); "
                             "no model is that large: the recording is damaged or in other units")
    extent = float(np.linalg.norm(np.ptp(points, axis=0)))
    if extent < MIN_EXTENT:
        raise RecordingError(f"frame file {str(file)!r}: its {len(points)} points span {extent:.3g} m, less than "
                             f"{MIN_EXTENT:g} m: there is no surface to show; the recording is damaged")


def _check_finite(file: Path, name: str, values: np.ndarray) -> None:
    bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
    if bad.size:
        raise RecordingError(f"frame file {str(file)!r}: {bad.size} points have non-finite {name} (first points "
                             f"{first_indices(bad)})")
