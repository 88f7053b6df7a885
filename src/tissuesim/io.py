"""Reading and writing triangle surfaces: the user's fine surface M_S enters the method here (§5 step 1).

:func:`read_surface` reads OBJ (our own parser: it takes ``f v/vt/vn`` faces and ignores texture coordinates,
normals, groups and materials), and STL, PLY, OFF, VTK and VTU (through meshio). It then

1. triangulates polygons: a quad along its shorter diagonal, a larger polygon as a fan from its first corner (a
   non-convex polygon may fold; validation then reports it);
2. merges duplicate vertices, e.g. the copies an OBJ exporter makes along UV seams. Two vertices merge when their
   coordinates are *exactly* equal as stored in the file (decimal text parsed to float64, or STL's float32):
   tolerance zero, so distinct vertices never merge however close; ``-0.0`` equals ``0.0``;
3. drops vertices no triangle uses. Vertices keep the order of their first appearance in the file, so a clean file's
   vertex ``i`` is our vertex ``i``;
4. multiplies coordinates by ``scale`` (our unit is the metre: a file in cm needs ``scale=0.01``, in mm ``0.001``);
5. validates (:func:`tissuesim.mesh.validate.validate_surface`) and refuses a bad surface with a
   :class:`MeshError`, or, with ``repair=True``, repairs what is safe first (:func:`tissuesim.mesh.repair.repair_surface`)
   and logs every change on the ``tissuesim.repair`` logger at WARNING level.

Steps 1-3 change the representation, not the shape; they are logged at INFO level on ``tissuesim.io``.

:func:`replaced_atomically` writes any file whole or not at all (a temporary file beside it, then one rename): the
figures and reports the commands write use it, so an interrupted run leaves no truncated file.
"""

from __future__ import annotations

import logging
import math
import os
import re
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from io import StringIO
from pathlib import Path

import numpy as np

from .errors import MeshError
from .mesh.bundle_check import temporary_prefix
from .mesh.surface import SurfaceMesh

logger = logging.getLogger(__name__)

# File extension -> meshio format name. OBJ is parsed here, so `f v/vt/vn` faces and polygons of any size are
# handled alike and texture seams are plain duplicate vertices for the merge step.
_MESHIO_FORMATS = {".stl": "stl", ".ply": "ply", ".off": "off", ".vtk": "vtk", ".vtu": "vtu"}
SURFACE_EXTENSIONS = (".obj", *_MESHIO_FORMATS)

# meshio cell types that are volumes, named in the error when a file has no surface cells.
_VOLUME_CELLS = ("tetra", "hexahedron", "wedge", "pyramid", "tetra10", "hexahedron20", "hexahedron27", "wedge15")


def check_scale(scale: object) -> float:
    """``scale`` (factor from a file's unit to metres) as a float, or a MeshError unless positive and finite."""
    if isinstance(scale, bool) or not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
        raise MeshError(f"scale must be a positive finite number (0.01 for a file in cm), got {scale!r}")
    return float(scale)


#: Sizes [m] (bounding-box diagonal) a model may have: a surface outside is far more likely read in the wrong unit
#: than meant, and float64 geometry (areas, distances squared) loses its meaning far beyond them.
MODEL_SIZE_RANGE = (1e-6, 100.0)


def check_model_size(vertices: np.ndarray, *, scale: float, source: str) -> None:
    """Refuse (MeshError) a model whose ``(n, 3)`` vertices, in the file's unit, times ``scale`` span a bounding-box
    diagonal outside :data:`MODEL_SIZE_RANGE` (1 µm to 100 m), naming the scale as the likely cause. Call it before
    scaling: the product may overflow or underflow float64."""
    extent = np.ptp(np.asarray(vertices, dtype=np.float64), axis=0) if len(vertices) else np.zeros(3)
    if not np.all(np.isfinite(extent)):
        return                              # validation names the non-finite coordinates
    largest = float(extent.max())
    size = largest * float(np.linalg.norm(extent / largest)) * scale if largest > 0 else 0.0   # no overflow
    low, high = MODEL_SIZE_RANGE
    if low <= size <= high:
        return
    raise MeshError(f"{source} is {size:.3g} m across after scale {scale:g}; a model must be between {low * 1e6:g} µm "
                    f"and {high:g} m across: check the scale (--scale on the command line, scale= in Python), the "
                    "factor from the file's unit to metres (0.01 for cm, 0.001 for mm)")


def warn_model_size(vertices: np.ndarray, *, scale: float, source: str) -> None:
    """Warn (:class:`~tissuesim.errors.TissuesimWarning`) when a model's ``(n, 3)`` vertices [m], already scaled by
    ``scale``, span less than 5 mm or more than 2 m (:func:`tissuesim.mesh.sizes.size_warning`): a mesh in cm read
    as metres builds as a 100 times too large organ, which nothing else would tell."""
    from .errors import warn
    from .mesh.sizes import size_warning

    message = size_warning(vertices, scale=scale, source=source)
    if message is not None:
        warn(message)


def read_surface(path: Path | str, *, scale: float = 1.0, repair: bool = False) -> SurfaceMesh:
    """Read a closed triangle surface from ``path`` (OBJ, STL, PLY, OFF, VTK, VTU) and validate it.

    Args:
        path: the file; its extension (case-insensitive) picks the format.
        scale: factor applied to the file's coordinates to get metres (``0.01`` for cm, ``0.001`` for mm); > 0.
        repair: fix safe defects (orientation, self-intersections via pymeshfix, degenerate triangles whose
            removal keeps the surface closed) and log each change; without it a bad surface is refused unchanged.

    Returns:
        The surface with ``(n, 3) float64`` vertices [m] and ``(m, 3) int32`` triangles.

    Raises:
        FileNotFoundError: the file does not exist.
        MeshError: ``path`` is not a path (e.g. None), unknown extension, unreadable file, no triangles, a model
            outside 1 µm to 100 m across once scaled (:func:`check_model_size`), or a defect that validation finds
            (and, with ``repair=True``, that repair could not fix).

    Warns:
        TissuesimWarning: the model is smaller than 5 mm or larger than 2 m across once scaled
            (:func:`warn_model_size`): likely a forgotten ``scale``.
    """
    check_scale(scale)
    vertices, polygons = read_polygons(_file_path(path, "read_surface"))
    surface = surface_from_polygons(vertices, polygons, source=str(path))
    check_model_size(surface.vertices, scale=scale, source=str(path))
    surface = surface.with_vertices(surface.vertices * float(scale))
    warn_model_size(surface.vertices, scale=scale, source=str(path))
    from .mesh.validate import validate_surface

    if repair:
        from .mesh.repair import repair_surface

        surface, changes = repair_surface(surface)
        repair_logger = logging.getLogger("tissuesim.repair")
        for change in changes:
            repair_logger.warning("%s: %s", path, change)
    validate_surface(surface, source=str(path))
    return surface


def _file_path(path, caller: str) -> Path:
    """``path`` as a Path, or a MeshError unless it is a str or os.PathLike (None, a mesh, a number...)."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise MeshError(f"{caller} needs the path of a surface file (a str or pathlib.Path), got {path!r}; for a "
                        "built-in model use tissuesim.models.cube() (or sphere, liver, steak)")
    return Path(path)


def process_running(pid: int) -> bool:
    """Whether process ``pid`` runs (this one, or any user's): a partial file of a process that does not was
    abandoned. Where it cannot be told (a pid too large for the system, another error), it counts as running, so
    nothing that may still be written is removed."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OverflowError, OSError):        # PermissionError: another user's process
        return True
    return True


#: The name of :func:`replaced_atomically`'s temporary file: ``.<name>.<pid>.<mkstemp's 8 letters>.partial<suffix>``.
_PARTIAL = re.compile(r"^\..+\.(?P<pid>\d+)\.[a-z0-9_]{8}\.partial(\.[^.]*)?$")


def remove_abandoned_partials(folder: Path | str) -> None:
    """Remove the temporary files :func:`replaced_atomically` left in ``folder`` when its process was killed."""
    for path in Path(folder).glob(".*.partial*"):
        match = _PARTIAL.match(path.name)
        if match and int(match["pid"]) != os.getpid() and not process_running(int(match["pid"])) and path.is_file():
            path.unlink(missing_ok=True)


@contextmanager
def replaced_atomically(path: Path | str) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix) to write the whole file to; on success it replaces
    ``path`` in one rename, so a reader never sees half a file; on any error or interruption it is removed and
    ``path`` is left as it was. A symbolic link is written through (its target is replaced, the link kept); an
    existing file keeps its permissions, a new one gets those the umask gives a new file."""
    path = Path(path)
    if path.is_symlink():
        path = path.resolve()
    mode = stat.S_IMODE(path.stat().st_mode) if path.is_file() else None
    handle, temporary = tempfile.mkstemp(prefix=f"{temporary_prefix(path)}{os.getpid()}.",
                                         suffix=f".partial{path.suffix}", dir=path.parent)
    os.close(handle)
    try:
        yield Path(temporary)
        if mode is None:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask           # mkstemp makes it private; ours are ordinary files
        os.chmod(temporary, mode)
        os.replace(temporary, path)
    except OSError as error:
        Path(temporary).unlink(missing_ok=True)
        if error.filename not in (None, temporary):
            raise
        raise OSError(error.errno, error.strerror, str(path)) from None    # the file meant, not the temporary one
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def surface_from_polygons(vertices: np.ndarray, polygons: list[np.ndarray], *, source: str = "input") -> SurfaceMesh:
    """Triangulate, merge exact duplicate vertices and drop unused ones (steps 1-3 of the module docstring).

    Args:
        vertices: ``(n, 3)`` float64 positions (any unit; not scaled here).
        polygons: blocks of faces, each an ``(k, c) int`` array of 0-based vertex indices with ``c >= 3`` corners.
        source: name used in messages.

    Does not validate; returns an unvalidated :class:`SurfaceMesh`.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise MeshError(f"{source}: vertices must be 3D, got an array of shape {vertices.shape}")
    triangles = [_triangulate(vertices, block, source) for block in polygons if len(block)]
    if not triangles:
        raise MeshError(f"{source}: the file has no triangle or polygon faces; export the surface with its faces")
    triangles = np.concatenate(triangles)
    polygon_count = sum(len(b) for b in polygons if b.shape[1] > 3)
    if polygon_count:
        logger.info("%s: triangulated %d polygons with more than 3 corners", source, polygon_count)

    # Merge vertices with identical coordinates (+0.0 turns -0.0 into 0.0), keeping first-appearance order.
    _, first, inverse = np.unique(vertices + 0.0, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    representative = rank[inverse]  # new index of every file vertex after merging
    merged = len(vertices) - len(first)
    triangles = representative[triangles]
    vertices = vertices[np.sort(first)]
    # Drop unused vertices, keeping order.
    used = np.zeros(len(vertices), bool)
    used[triangles.ravel()] = True
    unused = int(len(vertices) - used.sum())
    remap = np.cumsum(used) - 1
    if merged or unused:
        logger.info("%s: merged %d duplicate vertices, dropped %d unused vertices", source, merged, unused)
    return SurfaceMesh(vertices[used], remap[triangles].astype(np.int32))


def write_surface(path: Path | str, surface: SurfaceMesh) -> None:
    """Write ``surface`` to ``path``; the extension picks the format (OBJ, STL, PLY, OFF, VTK, VTU).

    Coordinates are written as they are (metres); OBJ, PLY, VTK and VTU keep float64 bit for bit, OFF keeps what
    meshio's text writer prints, STL stores float32 (binary STL). Raises :class:`MeshError` for an unknown extension.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".obj":
        with open(path, "w", encoding="ascii") as f:
            f.write("# written by tissuesim (units: m)\n")
            np.savetxt(f, surface.vertices, fmt="v %.17g %.17g %.17g")
            np.savetxt(f, surface.triangles.astype(np.int64) + 1, fmt="f %d %d %d")
        return
    if ext not in _MESHIO_FORMATS:
        raise MeshError(f"cannot write {path.name}: unknown extension {ext!r}; use one of "
                        f"{', '.join(SURFACE_EXTENSIONS)}")
    import meshio

    mesh = meshio.Mesh(surface.vertices, [("triangle", surface.triangles.astype(np.int64))])
    options = {"binary": True} if ext in (".stl", ".ply", ".vtk") else {}
    meshio.write(path, mesh, file_format=_MESHIO_FORMATS[ext], **options)


# -----------------------------------------------------------------------------------------------------------------


def read_polygons(path: Path | str) -> tuple[np.ndarray, list[np.ndarray]]:
    """The file's raw content, unmerged, unscaled and unvalidated, for diagnosing a file ``read_surface`` refuses.

    Returns ``(vertices, blocks)``: ``(n, 3) float64`` positions in the file's unit, and a list of ``(k, c) int64``
    face blocks of ``c`` corners each (0-based vertex indices). Feed them to :func:`surface_from_polygons`.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"surface file not found: {path}")
    if path.is_dir():
        raise MeshError(f"{path} is a directory, not a surface file")
    ext = path.suffix.lower()
    if ext == ".obj":
        return _read_obj(path)
    if ext not in _MESHIO_FORMATS:
        raise MeshError(f"cannot read {path.name}: unknown extension {ext!r}; use one of "
                        f"{', '.join(SURFACE_EXTENSIONS)}")
    import meshio

    chatter = StringIO()
    try:
        # meshio prints its diagnosis and may call sys.exit(1) on a file it cannot parse: capture both.
        with redirect_stdout(chatter), redirect_stderr(chatter):
            mesh = meshio.read(path, file_format=_MESHIO_FORMATS[ext])
    except (Exception, SystemExit) as exc:  # ReadError, ValueError, struct.error, SystemExit, ...
        printed = chatter.getvalue().strip().splitlines()
        reason = (printed[0] if printed else "") if isinstance(exc, SystemExit) else str(exc)
        reason = _unquoted(reason) or type(exc).__name__
        if ext == ".stl":
            # meshio's ASCII STL reader refuses valid files it did not write (e.g. trimesh's blank line before
            # 'endsolid'); trimesh reads those.
            return _read_stl_with_trimesh(path, reason)
        raise MeshError(f"cannot read {path} as {ext[1:].upper()}: {reason}") from None
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:
        raise MeshError(f"{path}: the points are 2D; a surface needs x, y, z coordinates")
    blocks, volume = [], []
    for cells in mesh.cells:
        data = np.asarray(cells.data)
        if cells.type in ("triangle", "quad") or cells.type.startswith("polygon"):
            blocks.append(data.astype(np.int64).reshape(len(data), -1))
        elif cells.type in _VOLUME_CELLS:
            volume.append(f"{len(data)} {cells.type}")
    if not blocks:
        found = f" (found {', '.join(volume)} cells: a volume mesh)" if volume else ""
        raise MeshError(f"{path}: no triangle or polygon faces{found}; read_surface needs a surface mesh")
    return points, blocks


def _unquoted(reason: str) -> str:
    """A reader library's ``reason`` on one line, its quoted text (the file's words, e.g. "could not convert string
    to float: 'x'", or meshio's "got `element vertex x`") left out: a message never quotes a file's content."""
    return " ".join(re.sub(r"'[^']*'|\"[^\"]*\"|`[^`]*`", "(...)", reason).split())


def _read_stl_with_trimesh(path: Path, meshio_reason: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """An STL file meshio could not read, read by trimesh (unprocessed: one vertex per corner, merged later)."""
    import trimesh

    try:
        mesh = trimesh.load_mesh(path, file_type="stl", process=False)
        vertices = np.asarray(mesh.vertices, dtype=np.float64)
        faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        trimesh_reason = "" if len(faces) else "no triangle faces"
    except Exception as exc:  # trimesh raises many kinds on a malformed file
        trimesh_reason = _unquoted(str(exc)) or type(exc).__name__
    if trimesh_reason:
        raise MeshError(f"cannot read {path} as STL: {meshio_reason} (meshio); {trimesh_reason} (trimesh); check "
                        "that the file is a complete ASCII or binary STL with its faces")
    return vertices, [faces]


def _read_obj(path: Path) -> tuple[np.ndarray, list[np.ndarray]]:
    """Wavefront OBJ: ``v x y z [w | r g b]`` and ``f i[/vt[/vn]] ...`` (1-based or negative indices); the rest
    (``vt``, ``vn``, ``g``, ``o``, ``s``, ``usemtl``, ``mtllib``, ``l``, ``p``) is ignored."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise MeshError(f"cannot read {path}: {exc.strerror or exc}") from exc
    vertices: list[list[float]] = []
    faces: dict[int, list[list[int]]] = {}  # corner count -> faces, so each block is a rectangular array
    for number, line in enumerate(text.splitlines(), start=1):
        if line.startswith("v ") or line.startswith("v\t"):
            parts = line.split()
            try:
                vertices.append([float(parts[1]), float(parts[2]), float(parts[3])])
            except (IndexError, ValueError):
                raise MeshError(f"{path}:{number}: malformed vertex line; expected 'v x y z' with three numbers")
        elif line.startswith("f ") or line.startswith("f\t"):
            parts = line.split()[1:]
            try:
                corners = [int(p.split("/", 1)[0]) for p in parts]
            except ValueError:
                raise MeshError(f"{path}:{number}: malformed face line; expected 'f i j k' with vertex numbers")
            if len(corners) < 3:
                raise MeshError(f"{path}:{number}: a face needs at least 3 corners, got {len(corners)}")
            count = len(vertices)
            resolved = []
            for c in corners:
                index = c - 1 if c > 0 else count + c  # negative: relative to the vertices read so far
                if c == 0 or index < 0:
                    raise MeshError(f"{path}:{number}: face index {c} is invalid (OBJ indices start at 1)")
                resolved.append(index)
            faces.setdefault(len(resolved), []).append(resolved)
    points = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    blocks = [np.array(f, dtype=np.int64) for _, f in sorted(faces.items())]
    for block in blocks:
        if block.size and block.max() >= len(points):
            raise MeshError(f"{path}: a face refers to vertex {int(block.max()) + 1} but the file has only "
                            f"{len(points)} vertices")
    return points, blocks


def _triangulate(vertices: np.ndarray, block: np.ndarray, source: str) -> np.ndarray:
    """``(k, c)`` polygons -> ``(t, 3) int64`` triangles with the polygons' orientation."""
    block = np.asarray(block, dtype=np.int64)
    if block.ndim != 2 or block.shape[1] < 3:
        raise MeshError(f"{source}: faces need at least 3 corners, got a block of shape {block.shape}")
    if block.min() < 0 or block.max() >= len(vertices):
        raise MeshError(f"{source}: faces refer to vertices outside 0..{len(vertices) - 1}")
    corners = block.shape[1]
    if corners == 3:
        return block
    if corners == 4:
        p = vertices[block]
        # Split along the shorter diagonal: better-shaped triangles, and the usual choice of modelling tools.
        short02 = np.sum((p[:, 2] - p[:, 0]) ** 2, axis=1) <= np.sum((p[:, 3] - p[:, 1]) ** 2, axis=1)
        split02 = np.concatenate([block[:, [0, 1, 2]], block[:, [0, 2, 3]]], axis=1)
        split13 = np.concatenate([block[:, [0, 1, 3]], block[:, [1, 2, 3]]], axis=1)
        return np.where(short02[:, None], split02, split13).reshape(-1, 3)
    fan = [block[:, [0, i, i + 1]] for i in range(1, corners - 1)]
    return np.stack(fan, axis=1).reshape(-1, 3)
