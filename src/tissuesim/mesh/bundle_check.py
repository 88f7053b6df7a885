"""Checks of a hybrid-mesh bundle's header and arrays at load, before any of them is used.

A bundle is a file: it can be damaged, edited or forged. Every array is checked for dtype, shape, finiteness, index
range and consistency with the others (the invariants :class:`~tissuesim.mesh.hybrid.HybridMesh` documents), so a
bad bundle is a :class:`BundleError` naming the array at load, not an ``IndexError`` or a solver that never settles
later. Geometric checks of the meshes themselves (tet orientation, degenerate tets) stay with
:class:`~tissuesim.mesh.tetmesh.TetMesh`. Before a save (and before a build that will be saved),
:func:`check_bundle_target` checks that the bundle can be written where asked.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..errors import BundleError, first_indices

#: Largest |sum of barycentric weights − 1| accepted (the builder's are exact to round-off).
WEIGHT_SUM_TOLERANCE = 1e-9
#: Largest distance, in model sizes, between a vertex and the point its embedding weights give back.
EMBEDDING_TOLERANCE = 1e-9
REBUILD = "the file is damaged or was edited; rebuild it with `tissuesim build MESH --output FILE`"
#: ``info`` keys of M_S as built (re-exported by :mod:`.hybrid`): its mean edge length [m] and its vertex count, which
#: a cut keeps and the solvers read (a cut row's thickness), so a bundle's are checked at load.
SURFACE_EDGE_KEY = "surface_mean_edge_m"
SURFACE_VERTICES_KEY = "surface_vertices_built"


def check_header(where: Path, header: dict) -> None:
    """The types of the header's ``format_version`` (an int), ``has_fine_volume`` (a bool) and ``info`` (a dict)."""
    found = header.get("format_version")
    if isinstance(found, bool) or not isinstance(found, int):
        raise BundleError(f"{where}: the header's format_version is {found!r} ({type(found).__name__}), not an "
                          f"integer; {REBUILD}")
    if not isinstance(header.get("has_fine_volume"), bool):
        raise BundleError(f"{where}: the header's has_fine_volume is {header.get('has_fine_volume')!r}, not true "
                          f"or false, so whether the fine volume belongs to the bundle is unknown; {REBUILD}")
    info = header.get("info", {})
    if not isinstance(info, dict):
        raise BundleError(f"{where}: the header's info is not a JSON object; {REBUILD}")
    for key, kind in ((SURFACE_EDGE_KEY, (int, float)), (SURFACE_VERTICES_KEY, int)):
        value = info.get(key, 1)
        if isinstance(value, bool) or not isinstance(value, kind) or not 0 < value < float("inf"):
            raise BundleError(f"{where}: the header's info {key} is {value!r}, not a positive number; {REBUILD}")


#: The arrays of every bundle, and those of a bundle with a fine volume.
REQUIRED = ("surface_vertices", "surface_triangles", "coarse_triangles", "volume_points", "volume_tets", "control",
            "control_volume", "coarse_triangle", "coarse_barycentric", "embedding_tet", "embedding_barycentric")
FINE = ("fine_points", "fine_tets", "fine_surface_nodes")
#: The array a bundle has once a cut released control nodes (M'_S's vertices, M_V nodes).
OPTIONAL = ("coarse_volume",)
#: The arrays of floating-point values (the others hold indices).
FLOATING = ("surface_vertices", "volume_points", "coarse_barycentric", "embedding_barycentric", "fine_points")


def check_declared(where: Path, declared: dict, *, fine: bool) -> None:
    """Dtype and shape of each bundle array, and its rows against the counts of the others, from ``declared`` (name
    → ``(shape, dtype)``): what the .npy headers say, so a bundle is refused before its data is read."""
    rows = {name: _rows(where, name, *declared[name], "f" if name in FLOATING else "i", width)
            for name, width in _WIDTHS.items() if name in declared}
    n, c = rows["surface_vertices"], rows["control"]
    expected = {"control_volume": c, "coarse_triangle": n, "coarse_barycentric": n, "embedding_tet": n,
                "embedding_barycentric": n, "fine_surface_nodes": n if fine else None}
    for name, count in expected.items():
        if count is not None and rows[name] != count:
            raise BundleError(f"{where}: array {name} has {rows[name]} rows, expected {count}; {REBUILD}")


#: Each array's columns (None: a 1-D array).
_WIDTHS = {"surface_vertices": 3, "control": None, "volume_points": 3, "surface_triangles": 3, "coarse_triangles": 3,
           "volume_tets": 4, "control_volume": None, "coarse_triangle": None, "coarse_barycentric": 3,
           "embedding_tet": None, "embedding_barycentric": 4, "coarse_volume": None, "fine_points": 3,
           "fine_tets": 4, "fine_surface_nodes": None}


def check_arrays(where: Path, a: dict, *, fine: bool) -> None:
    """Dtype, shape, finiteness, ranges and consistency of the bundle arrays ``a`` (name → array)."""
    check_declared(where, {name: (array.shape, array.dtype) for name, array in a.items()}, fine=fine)
    for name in FLOATING:
        if name in a:
            _finite(where, a, name)
    n, c, volume_nodes = len(a["surface_vertices"]), len(a["control"]), len(a["volume_points"])
    _in_range(where, a, "surface_triangles", n)
    _in_range(where, a, "control", n)
    if np.any(np.diff(a["control"]) <= 0):
        raise BundleError(f"{where}: array control is not strictly increasing (M_S vertex indices of the control "
                          f"nodes are stored sorted, each once); {REBUILD}")
    # M'_S's vertices: the control nodes, or, once a cut has released some, the M_V nodes kept in coarse_volume
    coarse_vertices = c
    if "coarse_volume" in a:
        coarse_vertices = len(a["coarse_volume"])
        _in_range(where, a, "coarse_volume", volume_nodes)
    _in_range(where, a, "coarse_triangles", coarse_vertices)
    _in_range(where, a, "volume_tets", volume_nodes)
    _in_range(where, a, "control_volume", volume_nodes)
    _in_range(where, a, "coarse_triangle", len(a["coarse_triangles"]))
    _in_range(where, a, "embedding_tet", len(a["volume_tets"]))
    _same_points(where, a["volume_points"][a["control_volume"]], a["surface_vertices"][a["control"]],
                 "volume_points[control_volume]", "surface_vertices[control]")
    if fine:
        _in_range(where, a, "fine_tets", len(a["fine_points"]))
        _in_range(where, a, "fine_surface_nodes", len(a["fine_points"]))
        _same_points(where, a["fine_points"][a["fine_surface_nodes"]], a["surface_vertices"],
                     "fine_points[fine_surface_nodes]", "surface_vertices")
    _weights(where, a, "coarse_barycentric", nonnegative=True)
    _weights(where, a, "embedding_barycentric", nonnegative=False)
    _embedding_reproduces_vertices(where, a)


def _rows(where, name: str, shape: tuple, dtype: np.dtype, kind: str, width: int | None) -> int:
    """Row count of array ``name`` of ``shape`` and ``dtype`` after checking its dtype kind (``"i"``: integer,
    ``"f"``: float) and shape."""
    integer = np.issubdtype(dtype, np.integer)
    if (kind == "i" and not integer) or (kind == "f" and not np.issubdtype(dtype, np.floating)):
        wanted = "an integer" if kind == "i" else "a floating-point"
        raise BundleError(f"{where}: array {name} has dtype {dtype}, expected {wanted} dtype; {REBUILD}")
    expected = "(rows,)" if width is None else f"(rows, {width})"
    if (width is None and len(shape) != 1) or (width is not None and (len(shape) != 2 or shape[1] != width)):
        raise BundleError(f"{where}: array {name} has shape {shape}, expected {expected}; {REBUILD}")
    return int(shape[0])


def _finite(where, a: dict, name: str) -> None:
    array = a[name]
    bad = np.flatnonzero(~np.isfinite(array).reshape(len(array), -1).all(axis=1))
    if bad.size:
        raise BundleError(f"{where}: array {name} has {bad.size} non-finite rows (first: {first_indices(bad)}); "
                          f"{REBUILD}")


def _in_range(where, a: dict, name: str, count: int) -> None:
    values = a[name]
    bad = np.flatnonzero(((values < 0) | (values >= count)).reshape(len(values), -1).any(axis=1))
    if bad.size:
        raise BundleError(f"{where}: array {name} has {bad.size} rows with indices outside 0..{count - 1} (first "
                          f"rows: {first_indices(bad)}); {REBUILD}")


def _same_points(where, found: np.ndarray, expected: np.ndarray, found_name: str, expected_name: str) -> None:
    bad = np.flatnonzero(np.any(found != expected, axis=1))
    if bad.size:
        raise BundleError(f"{where}: {found_name} differs from {expected_name} in {bad.size} rows (first: "
                          f"{first_indices(bad)}); the maps between the meshes are inconsistent; {REBUILD}")


def _weights(where, a: dict, name: str, *, nonnegative: bool) -> None:
    w = a[name]
    bad = np.abs(w.sum(axis=1) - 1.0) > WEIGHT_SUM_TOLERANCE
    if nonnegative:
        bad |= np.any(w < -WEIGHT_SUM_TOLERANCE, axis=1)
    rows = np.flatnonzero(bad)
    if rows.size:
        rule = "are non-negative and sum to 1" if nonnegative else "sum to 1"
        raise BundleError(f"{where}: array {name} has {rows.size} rows of barycentric weights that do not {rule} "
                          f"(first: {first_indices(rows)}); {REBUILD}")


def _embedding_reproduces_vertices(where, a: dict) -> None:
    vertices = a["surface_vertices"]
    corners = a["volume_points"][a["volume_tets"][a["embedding_tet"]]]            # (n, 4, 3)
    back = np.einsum("ij,ijk->ik", a["embedding_barycentric"], corners)
    size = float(np.linalg.norm(np.ptp(vertices, axis=0))) or 1.0
    bad = np.flatnonzero(np.linalg.norm(back - vertices, axis=1) > EMBEDDING_TOLERANCE * size)
    if bad.size:
        raise BundleError(f"{where}: embedding_tet / embedding_barycentric do not give back {bad.size} M_S vertices "
                          f"(first: {first_indices(bad)}); {REBUILD}")


def check_bundle_target(path: Path | str) -> Path:
    """``path`` as a Path where :meth:`HybridMesh.save` can write a bundle, or a :class:`BundleError` naming it.

    Refused: an empty path; an existing folder, device or pipe; a place where no file can be created (tried for
    real in the nearest existing folder, then removed), so a build can be refused before it runs.
    """
    path = bundle_path(path)
    if path.exists() and not path.is_file():
        raise BundleError(f"cannot save the bundle to {path}: it exists and is not a regular file (a folder, "
                          "device or pipe); give the path of a new or existing .npz file")
    folder = path.parent
    while not folder.exists() and folder != folder.parent:  # save creates the missing folders
        folder = folder.parent
    try:
        handle, probe = tempfile.mkstemp(prefix=temporary_prefix(path), suffix=".tmp", dir=folder)
    except OSError as error:
        raise BundleError(unsaveable(path, error)) from None
    os.close(handle)
    os.unlink(probe)
    return path


def temporary_prefix(path: Path) -> str:
    """The name prefix of a temporary file written beside ``path``: hidden, and short enough that with mkstemp's
    letters and a suffix it stays a valid file name (at most 255 bytes) whatever the length of ``path``'s name."""
    return f".{path.name[:100]}."


def bundle_path(path: object) -> Path:
    """``path`` as a Path, or a :class:`BundleError` unless it is a non-empty str or os.PathLike."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise BundleError(f"a bundle path must be a str or pathlib.Path, got {type(path).__name__} {path!r:.60}")
    if not str(path).strip():
        raise BundleError("the bundle path is empty; give the path of a .npz file, e.g. --output cube.npz")
    return Path(path)


def unsaveable(path: Path, error: OSError) -> str:
    """The message of a bundle that cannot be written at ``path``: names the bundle, never a temporary file."""
    return (f"cannot save the bundle to {path}: {error.strerror or error} in {path.parent}; choose another path or "
            "make that folder writable")
