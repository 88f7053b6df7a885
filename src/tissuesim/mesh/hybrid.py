"""The hybrid mesh of §5: fine surface M_S, coarse surface M'_S, coarse volume M_V, and the maps between them.

Build (:meth:`HybridMesh.build`): validate M_S, simplify it to M'_S (:mod:`.simplify`), tetrahedralize M'_S into
M_V and M_S into the fine reference volume (:mod:`.tetrahedralize`), then map every M_S vertex to

* its closest point on M'_S (triangle + barycentric weights, inside the triangle), used to spread a load on that
  vertex over three control nodes (§6.1); a control node maps to itself with weight 1;
* its barycentric coordinates in the M_V tet that contains it, or, for a vertex outside M_V, in the tet owning the
  M'_S face of its closest point (the nearest tet); these coordinates are not clamped, so they reproduce the vertex.

Both searches use a k-d tree on element centroids, so the cost is about O(n log m), not O(n m).

Bundle (:meth:`HybridMesh.save` / :meth:`HybridMesh.load`): one ``.npz`` file of plain arrays (no pickle) plus a JSON
header carrying the bundle format version and the tissuesim version that wrote it. Loading a bundle of another
format version, an unreadable one, or one whose arrays fail the checks of :mod:`.bundle_check` (dtype, shape,
finiteness, index range, consistency between the meshes) raises :class:`BundleError` naming the array. Saving writes
a temporary file beside the target and renames it, so a bundle is never half-written; a target that exists and is
not a regular file is refused. Arrays survive bit for bit; M'_S is stored as triangles only (its
vertices are ``surface.vertices[control]``).

Table 1 (:func:`table1_row`): nodes, elements and size of M_S, M_V and the fine volume. *Size* is the byte count of
the mesh as an ASCII file, in kB (1000 bytes), as the paper's sizes suggest: a surface as OBJ (``v x y z`` with
``%.8g`` coordinates in metres, ``f a b c`` 1-based), a volume as TetGen ``.node`` + ``.ele`` files.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import BundleError, MeshError
from .bundle_check import (SURFACE_EDGE_KEY, SURFACE_VERTICES_KEY, bundle_path, check_arrays, check_bundle_target,
                           check_header, temporary_prefix, unsaveable)
from .surface import SurfaceMesh
from .maps import closest_on_surface, embed_in_volume, own_corner
from .tetmesh import TetMesh


BUNDLE_FORMAT = "tissuesim-hybrid"
BUNDLE_VERSION = 1
WHAT_A_BUNDLE_IS = ("a bundle is the .npz file that `tissuesim build MESH --output FILE.npz` or HybridMesh.save "
                    "writes; read a surface file with tissuesim.read_surface and build it with HybridMesh.build")


@dataclass(frozen=True, eq=False)
class HybridMesh:
    """Static data of the hybrid model. Build with :meth:`HybridMesh.build`; save/load with :meth:`save`/:meth:`load`.

    Attributes:
        surface: M_S, the fine triangle surface that is rendered and cut; ``n_s`` vertices [m].
        coarse_surface: M'_S, the simplified surface; its vertices are ``surface.vertices[control]`` in that order,
            its triangles index them (``(t, 3) int32``).
        volume: M_V, TetGen's tetrahedralization of M'_S; its boundary nodes are exactly the control nodes.
        control: ``(c,) int32`` M_S vertex indices of the control nodes (§6), sorted ascending.
        control_volume: ``(c,) int32`` M_V node index of each control node:
            ``volume.points[control_volume] == surface.vertices[control]`` bit for bit.
        coarse_triangle: ``(n_s,) int32`` for every M_S vertex, the M'_S triangle under it (closest point),
            used to split a load on that vertex over three control nodes (§6.1).
        coarse_barycentric: ``(n_s, 3) float64`` barycentric weights of that closest point in its M'_S triangle;
            non-negative, summing to 1; a control node has weight 1 on itself.
        embedding_tet: ``(n_s,) int32`` the M_V tet containing each M_S vertex (or the nearest one when the vertex
            lies outside M_V), for the embedded-surface baseline.
        embedding_barycentric: ``(n_s, 4) float64`` barycentric coordinates of each M_S vertex in that tet; they
            sum to 1 and reproduce the vertex exactly (they may be slightly negative for a vertex outside M_V).
        fine_volume: the paper's fine volume mesh, TetGen's tetrahedralization of M_S itself, or None if not built.
        fine_surface_nodes: ``(n_s,) int32`` fine-volume node index of every M_S vertex (identical coordinates), or
            None with ``fine_volume``.
        info: build report (simplification rounds, collapses skipped, TetGen switches, timings, M_S's mean edge
            and vertex count as built, which a cut keeps: :func:`tissuesim.layer.compliance.thickness_lengths`).
        coarse_volume: ``(c0,) int32`` M_V node of each M'_S vertex once a cut (§7) has released control nodes
            (then ``control``/``control_volume`` list only the control nodes still prescribed), else None: see
            :attr:`coarse_volume_nodes`.
    """

    surface: SurfaceMesh
    coarse_surface: SurfaceMesh
    volume: TetMesh
    control: np.ndarray
    control_volume: np.ndarray
    coarse_triangle: np.ndarray
    coarse_barycentric: np.ndarray
    embedding_tet: np.ndarray
    embedding_barycentric: np.ndarray
    fine_volume: TetMesh | None = None
    fine_surface_nodes: np.ndarray | None = None
    info: dict = field(default_factory=dict)
    coarse_volume: np.ndarray | None = None

    @property
    def built_edge_length(self) -> float:
        """M_S's mean rest edge length [m] as built: a cut keeps it (its shorter new edges do not count), so what
        it sizes stays a property of the body."""
        return float(self.info.get(SURFACE_EDGE_KEY) or self.surface.mean_edge_length)

    @property
    def coarse_volume_nodes(self) -> np.ndarray:
        """``(c0,) int32`` the M_V node of each M'_S vertex (M_V is never cut, so neither is M'_S)."""
        return self.control_volume if self.coarse_volume is None else self.coarse_volume

    # -- construction ------------------------------------------------------------------------------------------

    @classmethod
    def build(cls, surface: SurfaceMesh, *, target_vertices: int | None = None, fine_volume: bool = True,
              progress: bool = False) -> "HybridMesh":
        """Build the hybrid mesh of §5 from a fine surface M_S.

        Args:
            surface: M_S, closed, manifold, outward-oriented, free of self-intersections (validated here).
            target_vertices: vertex count of M'_S (= number of control nodes); default
                :func:`tissuesim.mesh.simplify.default_target` (32 % of M_S's vertices).
            fine_volume: also tetrahedralize M_S itself (the FEM reference of §8.3).
            progress: show the steps with a tqdm bar on stderr.

        Raises:
            MeshError: ``surface`` is not a SurfaceMesh, ``target_vertices`` is not a whole number, the surface is
                invalid, or TetGen fails.
        """
        _check_is_surface(surface)
        _check_target_vertices(target_vertices)
        from .simplify import simplify
        from .tetrahedralize import COARSE_SWITCHES, FINE_SWITCHES, tetrahedralize
        from .validate import validate_surface

        steps = ["validate M_S", "simplify M_S -> M'_S", "tetrahedralize M'_S -> M_V", "map M_S onto M'_S and M_V"]
        if fine_volume:
            steps.append("tetrahedralize M_S -> fine volume")
        # A bar left open on an error would run into the error line on stderr: close it on every exit.
        with _progress(len(steps), progress) as bar:
            timings = {}

            def step(k):
                bar.set_description(steps[k])
                return time.perf_counter()

            t = step(0)
            validate_surface(surface)
            timings["validate_s"] = time.perf_counter() - t
            bar.update()

            t = step(1)
            simplified = simplify(surface, target_vertices=target_vertices)
            coarse, control = simplified.surface, simplified.kept
            timings["simplify_s"] = time.perf_counter() - t
            bar.update()

            t = step(2)
            volume, control_volume = tetrahedralize(coarse, switches=COARSE_SWITCHES)
            timings["coarse_tetgen_s"] = time.perf_counter() - t
            bar.update()

            t = step(3)
            coarse_triangle, coarse_barycentric = closest_on_surface(coarse, surface.vertices)
            # Control nodes map to themselves exactly (the search can land on another triangle at distance 0).
            coarse_triangle[control], coarse_barycentric[control] = own_corner(coarse, len(control))
            embedding_tet, embedding_barycentric = embed_in_volume(volume, surface.vertices, coarse, coarse_triangle,
                                                                   coarse_barycentric)
            timings["maps_s"] = time.perf_counter() - t
            bar.update()

            fine, fine_nodes = None, None
            if fine_volume:
                t = step(4)
                fine, fine_nodes = tetrahedralize(surface, switches=FINE_SWITCHES)
                timings["fine_tetgen_s"] = time.perf_counter() - t
                bar.update()
        timings["total_s"] = sum(timings.values())
        info = {"simplify": simplified.report.as_dict(), "coarse_switches": COARSE_SWITCHES,
                "fine_switches": FINE_SWITCHES if fine_volume else None, "timings": timings,
                SURFACE_EDGE_KEY: surface.mean_edge_length, SURFACE_VERTICES_KEY: surface.vertex_count}
        return cls(surface=surface, coarse_surface=coarse, volume=volume, control=control,
                   control_volume=control_volume.astype(np.int32), coarse_triangle=coarse_triangle,
                   coarse_barycentric=coarse_barycentric, embedding_tet=embedding_tet,
                   embedding_barycentric=embedding_barycentric, fine_volume=fine, fine_surface_nodes=fine_nodes,
                   info=info)

    # -- bundle ------------------------------------------------------------------------------------------------

    def save(self, path) -> Path:
        """Write the bundle to ``path`` (``.npz``) atomically; return the path.

        Raises:
            BundleError: ``path`` is empty or not a path, exists and is not a regular file (a folder, device or
                pipe would be replaced), or no file can be written there (the message names ``path``).
        """
        from .. import __version__

        path = check_bundle_target(path)
        header = {"format": BUNDLE_FORMAT, "format_version": BUNDLE_VERSION, "tissuesim_version": __version__,
                  "has_fine_volume": self.fine_volume is not None, "info": _jsonable(self.info)}
        arrays = {
            "surface_vertices": self.surface.vertices, "surface_triangles": self.surface.triangles,
            "coarse_triangles": self.coarse_surface.triangles, "volume_points": self.volume.points,
            "volume_tets": self.volume.tets, "control": self.control, "control_volume": self.control_volume,
            "coarse_triangle": self.coarse_triangle, "coarse_barycentric": self.coarse_barycentric,
            "embedding_tet": self.embedding_tet, "embedding_barycentric": self.embedding_barycentric,
        }
        if self.coarse_volume is not None:
            arrays["coarse_volume"] = self.coarse_volume
        if self.fine_volume is not None:
            arrays.update(fine_points=self.fine_volume.points, fine_tets=self.fine_volume.tets,
                          fine_surface_nodes=self.fine_surface_nodes)
        arrays["header"] = np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            handle, temporary = tempfile.mkstemp(prefix=temporary_prefix(path), suffix=".tmp", dir=path.parent)
        except OSError as error:
            raise BundleError(unsaveable(path, error)) from None
        try:
            with os.fdopen(handle, "wb") as stream:
                np.savez(stream, **arrays)
                stream.flush()
                os.fsync(stream.fileno())
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(temporary, 0o666 & ~umask)     # mkstemp makes it private; a bundle is an ordinary file
            os.replace(temporary, path)
        except BaseException as error:
            Path(temporary).unlink(missing_ok=True)
            if isinstance(error, OSError):      # e.g. a full disk: name the bundle, not the temporary file
                raise BundleError(unsaveable(path, error)) from None
            raise
        return path

    @classmethod
    def load(cls, path) -> "HybridMesh":
        """Read a bundle written by :meth:`save`.

        Raises:
            FileNotFoundError: no such file.
            BundleError: ``path`` is not a path or is a folder, device or pipe; the file is not a bundle, is
                corrupt, or was written in another bundle format version.
        """
        path = bundle_path(path)
        if path.is_dir():
            raise BundleError(f"{path} is a folder, not a hybrid-mesh bundle; {WHAT_A_BUNDLE_IS}")
        if path.exists() and not path.is_file():
            raise BundleError(f"{path} is not a regular file (a device or pipe), so not a hybrid-mesh bundle; "
                              f"{WHAT_A_BUNDLE_IS}")
        if not path.is_file():
            raise FileNotFoundError(f"no hybrid-mesh bundle at {path}")
        if not zipfile.is_zipfile(path):
            raise BundleError(f"{path} is not a readable hybrid-mesh bundle: it is not a .npz (zip) archive; "
                              f"{WHAT_A_BUNDLE_IS}")
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {key: data[key] for key in data.files}
        except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError) as error:
            # numpy's own text would suggest allow_pickle=True: never load a file's Python objects
            reason = "it holds Python objects, which a bundle never does" if "pickle" in str(error) else str(error)
            raise BundleError(f"{path} is not a readable hybrid-mesh bundle ({reason}); {WHAT_A_BUNDLE_IS}") \
                from None
        header = _read_header(path, arrays)
        fine_volume = header["has_fine_volume"]
        required = ["surface_vertices", "surface_triangles", "coarse_triangles", "volume_points", "volume_tets",
                    "control", "control_volume", "coarse_triangle", "coarse_barycentric", "embedding_tet",
                    "embedding_barycentric"]
        if fine_volume:
            required += ["fine_points", "fine_tets", "fine_surface_nodes"]
        missing = [key for key in required if key not in arrays]
        if missing:
            raise BundleError(f"{path} lacks arrays {', '.join(missing)}; the file is damaged, rebuild it")
        check_arrays(path, arrays, fine=fine_volume)
        try:
            surface = SurfaceMesh(arrays["surface_vertices"], arrays["surface_triangles"])
            control = arrays["control"]
            volume = TetMesh(arrays["volume_points"], arrays["volume_tets"])
            coarse_volume = arrays.get("coarse_volume")
            coarse = SurfaceMesh(surface.vertices[control] if coarse_volume is None else
                                 volume.points[coarse_volume], arrays["coarse_triangles"])
            fine = fine_nodes = None
            if fine_volume:
                fine = TetMesh(arrays["fine_points"], arrays["fine_tets"])
                fine_nodes = arrays["fine_surface_nodes"]
        except MeshError as error:
            raise BundleError(f"{path} holds inconsistent meshes ({error}); rebuild it") from error
        return cls(surface=surface, coarse_surface=coarse, volume=volume, control=control,
                   control_volume=arrays["control_volume"], coarse_triangle=arrays["coarse_triangle"],
                   coarse_barycentric=arrays["coarse_barycentric"], embedding_tet=arrays["embedding_tet"],
                   embedding_barycentric=arrays["embedding_barycentric"], fine_volume=fine,
                   fine_surface_nodes=fine_nodes, info=header.get("info", {}), coarse_volume=coarse_volume)

    # -- reporting ---------------------------------------------------------------------------------------------

    def table1_row(self) -> dict:
        """Table 1's figures for this mesh: see :func:`table1_row`."""
        return table1_row(self)


# -------------------------------------------------------------------------------------------------------------
# Table 1


TABLE1_HEADER = ("| model | M_S #node | M_S #elem | M_S size (kB) | M_V #node | M_V #elem | M_V size (kB) "
                 "| fine #node | fine #elem | fine size (kB) |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def table1_row(hybrid: HybridMesh) -> dict:
    """``{"M_S": {...}, "M_V": {...}, "fine": {...} or None}``, each ``{"nodes", "elements", "size_kb"}``.

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


def _read_header(path: Path, arrays: dict) -> dict:
    if "header" not in arrays:
        raise BundleError(f"{path} has no bundle header; it is not a tissuesim hybrid-mesh bundle")
    try:
        header = json.loads(arrays["header"].tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise BundleError(f"{path} has a corrupt bundle header ({error}); rebuild it") from error
    if not isinstance(header, dict) or header.get("format") != BUNDLE_FORMAT:
        raise BundleError(f"{path} is not a tissuesim hybrid-mesh bundle")
    check_header(path, header)
    if header.get("format_version") != BUNDLE_VERSION:
        raise BundleError(
            f"{path} is bundle format version {header.get('format_version')} (written by tissuesim "
            f"{header.get('tissuesim_version', '?')}); this tissuesim reads version {BUNDLE_VERSION}: rebuild it "
            "with `tissuesim build ... --output`")
    return header


def _check_target_vertices(target_vertices) -> None:
    """Refuse (MeshError) a ``target_vertices`` that is not None or a whole number (NaN, 2.5, a bool, text)."""
    if target_vertices is None:
        return
    number = isinstance(target_vertices, (int, float, np.integer, np.floating)) and not isinstance(target_vertices,
                                                                                                    bool)
    if not (number and math.isfinite(target_vertices) and target_vertices == int(target_vertices)):
        raise MeshError(f"target_vertices must be a whole number of vertices (or None for the default), got "
                        f"{target_vertices!r}")


def _check_is_surface(surface) -> None:
    from .models import MODELS

    if isinstance(surface, SurfaceMesh):
        return
    hint = (f"for the built-in model use tissuesim.models.{surface}()" if isinstance(surface, str) and
            surface in MODELS else "read a surface file with tissuesim.read_surface(path), or use a built-in model, "
            "e.g. tissuesim.models.cube()")
    raise MeshError(f"HybridMesh.build takes a SurfaceMesh, got {type(surface).__name__} {surface!r:.60}; {hint}")


def _jsonable(value):
    """``info`` with numpy scalars turned into plain numbers, for the JSON header."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, disable=not enabled, unit="step", leave=False)
