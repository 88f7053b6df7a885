"""The hybrid mesh's bundle: :meth:`HybridMesh.save <tissuesim.mesh.hybrid.HybridMesh.save>` and
:meth:`~tissuesim.mesh.hybrid.HybridMesh.load` write and read it here.

One ``.npz`` file of plain arrays (no pickle) plus a JSON header carrying the bundle format version and the tissuesim
version that wrote it. Loading reads only the members a hybrid mesh has (others are never read), each after the
shape and dtype its .npy header declares passed the checks of :mod:`.bundle_check` against the others' counts, so a
forged or zip-bomb member is refused before its data is inflated. Loading a bundle of another format version, an
unreadable one, or one whose arrays fail those checks (dtype, shape, finiteness, index range, consistency between the
meshes) raises :class:`BundleError` naming the array, never quoting the file's bytes. Saving writes a temporary file
beside the target and renames it, so a bundle is never half-written; a target that exists and is not a regular file
is refused. Arrays survive bit for bit; M'_S is stored as triangles only (its vertices are
``surface.vertices[control]``).
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
import zlib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import BundleError, MeshError
from .bundle_check import (FINE, OPTIONAL, REBUILD, REQUIRED, bundle_path, check_arrays, check_bundle_target,
                           check_declared, check_header, temporary_prefix, unsaveable)
from .surface import SurfaceMesh
from .tetmesh import TetMesh

if TYPE_CHECKING:
    from .hybrid import HybridMesh

BUNDLE_FORMAT = "tissuesim-hybrid"
BUNDLE_VERSION = 1
#: Most a bundle's member may inflate: its uncompressed size over its compressed one. HybridMesh.save stores its
#: arrays (1×); deflated, a mesh's arrays shrink 2-8× (measured on the cube's bundle), zeros about 1000×. Beyond it
#: a member is a zip bomb (a 14 MB file could otherwise inflate to gigabytes); INFLATION_SLACK [bytes] spares tiny
#: members, whose .npy header alone may deflate well.
MAX_INFLATION = 100
INFLATION_SLACK = 2 ** 16
#: Largest JSON header [bytes] read (a mesh's build record is about 1 kB).
MAX_HEADER_BYTES = 2 ** 24
WHAT_A_BUNDLE_IS = ("a bundle is the .npz file that `tissuesim build MESH --output FILE.npz` or HybridMesh.save "
                    "writes; read a surface file with tissuesim.read_surface and build it with HybridMesh.build")


def save_bundle(hybrid: HybridMesh, path: Path | str) -> Path:
    """Write ``hybrid`` (a :class:`~tissuesim.mesh.hybrid.HybridMesh`) to ``path`` atomically; see
    :meth:`HybridMesh.save <tissuesim.mesh.hybrid.HybridMesh.save>`."""
    from .. import __version__

    path = check_bundle_target(path)
    header = {"format": BUNDLE_FORMAT, "format_version": BUNDLE_VERSION, "tissuesim_version": __version__,
              "has_fine_volume": hybrid.fine_volume is not None, "info": _jsonable(hybrid.info)}
    arrays = {
        "surface_vertices": hybrid.surface.vertices, "surface_triangles": hybrid.surface.triangles,
        "coarse_triangles": hybrid.coarse_surface.triangles, "volume_points": hybrid.volume.points,
        "volume_tets": hybrid.volume.tets, "control": hybrid.control, "control_volume": hybrid.control_volume,
        "coarse_triangle": hybrid.coarse_triangle, "coarse_barycentric": hybrid.coarse_barycentric,
        "embedding_tet": hybrid.embedding_tet, "embedding_barycentric": hybrid.embedding_barycentric,
    }
    if hybrid.coarse_volume is not None:
        arrays["coarse_volume"] = hybrid.coarse_volume
    if hybrid.fine_volume is not None:
        arrays.update(fine_points=hybrid.fine_volume.points, fine_tets=hybrid.fine_volume.tets,
                      fine_surface_nodes=hybrid.fine_surface_nodes)
    arrays["header"] = np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8)
    _write_atomically(path, arrays)
    return path


def _write_atomically(path: Path, arrays: dict) -> None:
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


def load_bundle(path: Path | str) -> dict:
    """The :class:`~tissuesim.mesh.hybrid.HybridMesh` fields of the bundle at ``path``, checked; see
    :meth:`HybridMesh.load <tissuesim.mesh.hybrid.HybridMesh.load>`."""
    path = bundle_path(path)
    arrays, fine_volume, info = _read_arrays(path)
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
    return dict(surface=surface, coarse_surface=coarse, volume=volume, control=control,
                control_volume=arrays["control_volume"], coarse_triangle=arrays["coarse_triangle"],
                coarse_barycentric=arrays["coarse_barycentric"], embedding_tet=arrays["embedding_tet"],
                embedding_barycentric=arrays["embedding_barycentric"], fine_volume=fine,
                fine_surface_nodes=fine_nodes, info=info, coarse_volume=coarse_volume)


def _read_arrays(path: Path) -> tuple[dict, bool, dict]:
    """``(arrays, has_fine_volume, info)`` of the bundle at ``path``: only the members a hybrid mesh has are read,
    each after its declared shape and dtype passed :func:`.bundle_check.check_declared` (a member that is no array of
    plain numbers, or is not there, or declares more than it holds, is a BundleError); other members are never
    read, however large they would inflate."""
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
        with zipfile.ZipFile(path) as archive:
            members = {info.filename[:-len(".npy")]: info for info in archive.infolist()
                       if info.filename.endswith(".npy")}
            if "header" not in members:
                raise BundleError(f"{path} has no bundle header; it is not a tissuesim hybrid-mesh bundle")
            header = _read_header(path, _read_member(path, archive, members["header"], _declared_header))
            fine = header["has_fine_volume"]
            names = [*REQUIRED, *(FINE if fine else ()), *(name for name in OPTIONAL if name in members)]
            missing = [name for name in names if name not in members]
            if missing:
                raise BundleError(f"{path} lacks arrays {', '.join(missing)}; the file is damaged, rebuild it")
            declared = {name: _declared(path, archive, members[name]) for name in names}
            check_declared(path, {name: (shape, dtype) for name, (shape, dtype, _) in declared.items()}, fine=fine)
            arrays = {name: _read_member(path, archive, members[name]) for name in names}
    except BundleError:
        raise
    except (zipfile.BadZipFile, zlib.error, ValueError, OSError, EOFError, RuntimeError,
            NotImplementedError) as error:
        raise BundleError(f"{path} is not a readable hybrid-mesh bundle ({_damage(error)}); {WHAT_A_BUNDLE_IS}") \
            from None
    return arrays, fine, header.get("info", {})


def _damage(error: Exception) -> str:
    """What kind of damage ``error`` (from zipfile, zlib or numpy's .npy reader) shows, in words of our own: the
    readers' text quotes the file's bytes (a .npy magic string, a header's keys), and a bundle may be someone
    else's."""
    if isinstance(error, ValueError):
        return "a member is no .npy array of plain numbers"
    if isinstance(error, (zipfile.BadZipFile, zlib.error, EOFError)):
        return "its zip archive is damaged or cut short"
    if isinstance(error, (RuntimeError, NotImplementedError)):
        return "a member is encrypted or compressed in a way a .npz never is"
    return f"it could not be read: {error.strerror or type(error).__name__}"


def _declared(path: Path, archive: zipfile.ZipFile, member: zipfile.ZipInfo) -> tuple[tuple, np.dtype, bool]:
    """``(shape, dtype, fortran_order)`` that ``member``'s .npy header declares, read without inflating its data;
    BundleError for Python objects, a member that inflates more than :data:`MAX_INFLATION` times, or a header that
    declares more (or fewer) bytes than the member holds."""
    name = member.filename[:-len(".npy")]
    if member.file_size > MAX_INFLATION * member.compress_size + INFLATION_SLACK:
        raise BundleError(f"{path}: member {name} inflates from {member.compress_size} to {member.file_size} bytes, "
                          f"more than {MAX_INFLATION} times, which no mesh's arrays do; {REBUILD}")
    with archive.open(member) as stream:
        version = np.lib.format.read_magic(stream)
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)
        shape, fortran, dtype = read_header(stream)
        header_bytes = stream.tell()
    if dtype.hasobject:
        raise BundleError(f"{path} is not a readable hybrid-mesh bundle: its array {name} holds Python objects, "
                          f"which a bundle never does; {WHAT_A_BUNDLE_IS}")
    data = int(np.prod(shape, dtype=object)) * dtype.itemsize      # Python ints: a forged shape cannot overflow
    if data != member.file_size - header_bytes:
        raise BundleError(f"{path}: array {name} declares shape {shape} of {dtype} ({data} bytes) but its entry "
                          f"holds {member.file_size - header_bytes} bytes; {REBUILD}")
    return shape, dtype, fortran


def _declared_header(path: Path, archive: zipfile.ZipFile, member: zipfile.ZipInfo) -> None:
    shape, dtype, _ = _declared(path, archive, member)
    if dtype != np.uint8 or len(shape) != 1 or shape[0] > MAX_HEADER_BYTES:
        raise BundleError(f"{path}: the bundle header declares shape {shape} of {dtype}, not at most "
                          f"{MAX_HEADER_BYTES} bytes of JSON text; {REBUILD}")


def _read_member(path: Path, archive: zipfile.ZipFile, member: zipfile.ZipInfo, check=None) -> np.ndarray:
    """The array in ``member``, after ``check`` (path, archive, member) where one is given."""
    if check is not None:
        check(path, archive, member)
    with archive.open(member) as stream:
        return np.lib.format.read_array(stream, allow_pickle=False)


def _read_header(path: Path, array: np.ndarray) -> dict:
    try:
        header = json.loads(array.tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise BundleError(f"{path} has a corrupt bundle header (not JSON text); rebuild it") from None
    if not isinstance(header, dict) or header.get("format") != BUNDLE_FORMAT:
        raise BundleError(f"{path} is not a tissuesim hybrid-mesh bundle")
    check_header(path, header)
    if header.get("format_version") != BUNDLE_VERSION:
        raise BundleError(
            f"{path} is bundle format version {header.get('format_version')} (written by tissuesim "
            f"{header.get('tissuesim_version', '?')}); this tissuesim reads version {BUNDLE_VERSION}: rebuild it "
            "with `tissuesim build ... --output`")
    return header


def _jsonable(value):
    """``info`` with numpy scalars turned into plain numbers, for the JSON header."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
