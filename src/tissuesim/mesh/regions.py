"""Node selectors for boundary conditions, shared by every method so all fix the same region: the bottom, a box,
the nodes behind a plane, a list of indices, a mask or index file, and :func:`fixed_region`, which picks one from a
plain-data spec (a command line's ``--fix``, a scene file's table)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BoundaryConditionError, first_indices

# The fixed region of the experiments (§8.2, Fig 6: "the bottom of M_V is subject to displacement constraints"):
# nodes within this fraction of the model's height above its lowest point.
BOTTOM_FRACTION = 0.1


def bottom_height(points: np.ndarray, *, fraction: float = BOTTOM_FRACTION, axis: int = 2) -> float:
    """The height [m] on ``axis`` below which nodes of ``points`` ``(n, 3)`` count as the bottom."""
    if not 0.0 < fraction < 1.0:
        raise BoundaryConditionError(f"bottom fraction must lie in (0, 1), got {fraction}")
    lo, hi = float(points[:, axis].min()), float(points[:, axis].max())
    return lo + fraction * (hi - lo)


def nodes_below(points: np.ndarray, height: float, *, axis: int = 2) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] with coordinate ``axis`` ≤ ``height`` [m]."""
    if axis not in (0, 1, 2):
        raise BoundaryConditionError(f"axis must be 0, 1 or 2 (x, y, z), got {axis}")
    selected = np.flatnonzero(points[:, axis] <= height + 1e-12 * max(1.0, abs(height))).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies at or below {height:g} m on axis {'xyz'[axis]} (lowest is "
            f"{points[:, axis].min():g} m); raise the height"
        )
    return selected


def bottom_nodes(points: np.ndarray, *, fraction: float = BOTTOM_FRACTION, axis: int = 2) -> np.ndarray:
    """``(k,) int32`` the experiments' fixed region: nodes of ``points`` ``(n, 3)`` [m] at or below
    :func:`bottom_height` of those same points. To fix one region across meshes (M_S, M_V, fine volume), compute
    the height once from M_S and call :func:`nodes_below` on each mesh instead."""
    return nodes_below(points, bottom_height(points, fraction=fraction, axis=axis), axis=axis)


def nodes_above(points: np.ndarray, height: float, *, axis: int = 2) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] with coordinate ``axis`` ≥ ``height`` [m]."""
    if axis not in (0, 1, 2):
        raise BoundaryConditionError(f"axis must be 0, 1 or 2 (x, y, z), got {axis}")
    selected = np.flatnonzero(points[:, axis] >= height - 1e-12 * max(1.0, abs(height))).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies at or above {height:g} m on axis {'xyz'[axis]} (highest is "
            f"{points[:, axis].max():g} m); lower the height"
        )
    return selected


def nodes_in_box(points: np.ndarray, lower: ArrayLike, upper: ArrayLike) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] inside the closed axis-aligned box ``lower`` ≤ x ≤
    ``upper`` (each ``(3,)`` [m]; use ±inf to leave an axis open)."""
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    if lower.shape != (3,) or upper.shape != (3,) or np.any(np.isnan(lower)) or np.any(np.isnan(upper)):
        raise BoundaryConditionError(f"box corners must be (3,) numbers, got {lower.shape} and {upper.shape}")
    if np.any(lower > upper):
        raise BoundaryConditionError(f"box lower corner {lower.tolist()} exceeds upper corner {upper.tolist()}")
    slack = 1e-12 * np.maximum(1.0, np.abs(np.where(np.isfinite(upper), upper, 0.0)))
    inside = np.all((points >= lower - slack) & (points <= upper + slack), axis=1)
    selected = np.flatnonzero(inside).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies in the box {lower.tolist()}..{upper.tolist()} m; the points span "
            f"{points.min(axis=0).tolist()}..{points.max(axis=0).tolist()} m: move or enlarge the box (in metres, "
            "after any scale) to take part of the surface"
        )
    return selected


def node_indices(indices: ArrayLike, *, node_count: int) -> np.ndarray:
    """``(k,) int32`` sorted unique node indices from an explicit list, checked against ``0..node_count-1``."""
    indices = np.asarray(indices)
    if indices.ndim != 1 or indices.size == 0 or indices.dtype.kind not in "iu":
        raise BoundaryConditionError(
            f"node indices must be a non-empty 1-D integer array, got {indices.dtype} {indices.shape}"
        )
    bad = np.flatnonzero((indices < 0) | (indices >= node_count))
    if bad.size:
        raise BoundaryConditionError(
            f"{bad.size} node indices are outside 0..{node_count - 1} (first: {first_indices(indices[bad])}); "
            "check the mesh they refer to"
        )
    return np.unique(indices).astype(np.int32)


def nodes_behind_plane(points: np.ndarray, point: ArrayLike, normal: ArrayLike) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] on or behind the plane through ``point`` ``(3,)`` [m]
    with outward ``normal`` ``(3,)`` (any length but zero; it points out of the held region, toward the free
    part): the nodes with (x − point) · n ≤ 0, so normal (0, 0, 1) holds what lies below the plane. Nodes within
    1e-9 of the model's size of the plane count as on it, so a plane through a flat face takes the whole face."""
    point = _vector(point, "plane point")
    normal = _vector(normal, "plane normal")
    length = float(np.linalg.norm(normal))
    if not length > 0.0:
        raise BoundaryConditionError("the plane's normal is the zero vector; give the direction pointing out of the "
                                     "region to hold, toward the free part: 0,0,1 holds what lies below the plane")
    distance = (np.asarray(points, dtype=np.float64) - point) @ (normal / length)
    slack = 1e-9 * float(np.linalg.norm(np.ptp(points, axis=0)))
    selected = np.flatnonzero(distance <= slack).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies on or behind the plane through {point.tolist()} m with outward normal "
            f"{(normal / length).tolist()}: the nearest is {distance.min():.3g} m in front of it; move the point into "
            "the model or flip the normal (it points out of the region to hold, toward the free part)"
        )
    return selected


def node_mask(mask: ArrayLike, *, node_count: int, source: str = "the mask") -> np.ndarray:
    """``(k,) int32`` indices of the nodes whose entry in ``mask`` ``(node_count,)`` (0/1 or bool, one per M_S
    vertex in vertex order) is 1."""
    mask = np.asarray(mask)
    if mask.ndim != 1 or mask.shape[0] != node_count:
        raise BoundaryConditionError(
            f"{source} has {mask.size} entries {'in shape ' + str(mask.shape) + ' ' if mask.ndim != 1 else ''}but the "
            f"model has {node_count} surface vertices; give one 0 or 1 per vertex, in vertex order, of this model "
            "(a mask of another resolution or a cut surface does not fit)"
        )
    bad = np.flatnonzero(~np.isin(mask, (0, 1)))
    if bad.size:
        raise BoundaryConditionError(
            f"{source} holds {bad.size} entries that are neither 0 nor 1 (first at vertices {first_indices(bad)}); "
            "write 1 for a held vertex and 0 for a free one"
        )
    selected = np.flatnonzero(mask.astype(bool)).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(f"{source} holds no 1: it selects no vertex; mark the vertices to hold with 1")
    return selected


def read_node_file(path: Path | str, *, kind: str) -> np.ndarray:
    """The 1-D array stored in ``path``: a NumPy ``.npy`` file, or text (numbers separated by spaces, commas or
    line breaks; ``#`` starts a comment). ``kind`` ("mask" or "indices") names the file in messages."""
    path = Path(path)
    if not path.is_file():
        raise BoundaryConditionError(f"the {kind} file {path} does not exist or is not a file; give the path of a "
                                     ".npy or text file with one entry per line")
    try:
        if path.suffix.lower() == ".npy":
            values = np.load(path, allow_pickle=False)
        else:
            text = "\n".join(line.split("#", 1)[0] for line in path.read_text().splitlines())
            values = np.array([float(word) for word in text.replace(",", " ").split()])
    except OSError as error:
        raise BoundaryConditionError(f"cannot read the {kind} file {path}: {error.strerror or 'unreadable'}; give a "
                                     "readable .npy array or text file") from None
    except (ValueError, UnicodeDecodeError):
        # the file's content is never quoted: it may be someone else's (a scene naming /etc/...)
        raise BoundaryConditionError(f"cannot read the {kind} file {path}: it is not a .npy array of numbers nor "
                                     "text of numbers; give a .npy array or text with one number per line") from None
    values = np.asarray(values)
    if values.ndim == 2 and 1 in values.shape:
        values = values.ravel()         # a column or a row written by np.save / np.savetxt
    if values.dtype.kind == "f" and np.all(np.isfinite(values)) and np.all(values == np.round(values)):
        values = values.astype(np.int64)    # text is read as numbers; whole ones are indices or 0/1
    return values


#: The keys of a fixed-region spec (:func:`fixed_region`), each with what its value is.
REGION_KINDS = {
    "bottom": "fraction of the model's height above its lowest point, in (0, 1)",
    "box": '{"lower": [x, y, z], "upper": [x, y, z]} in metres',
    "plane": '{"point": [x, y, z], "normal": [x, y, z]}: the nodes on or behind it (the normal points out)',
    "indices": "a list of M_S vertex indices",
    "mask": "path of a file with one 0/1 per M_S vertex (.npy or text)",
    "indices_file": "path of a file of M_S vertex indices (.npy or text)",
}


def fixed_region(spec: Mapping[str, object], points: np.ndarray, *, folder: Path | str | None = None) -> np.ndarray:
    """``(k,) int32`` sorted M_S vertex indices selected by the plain-data ``spec``, for the solver option ``fixed=``.

    Args:
        spec: a mapping with exactly one key of :data:`REGION_KINDS`, e.g. ``{"bottom": 0.1}``,
            ``{"box": {"lower": [-1, -1, 0], "upper": [1, 1, 0.01]}}``,
            ``{"plane": {"point": [0, 0, 0.1], "normal": [0, 0, 1]}}``, ``{"indices": [3, 39, 64]}``,
            ``{"mask": "held.npy"}`` or ``{"indices_file": "held.txt"}``. Lengths in metres.
        points: ``(n, 3) float64`` M_S rest positions [m].
        folder: where a relative file path of the spec lies (e.g. the scene file's folder); None: the current one.

    Raises:
        BoundaryConditionError: an unknown or missing key, a malformed value, an unreadable or mislengthed file, a
            zero normal, or a selection with no vertex; each names the fix.
    """
    points = np.asarray(points, dtype=np.float64)
    kind, value = _only_entry(spec)
    if kind == "bottom":
        return bottom_nodes(points, fraction=_number(value, "bottom"))
    if kind == "box":
        box = _fields(value, "box", ("lower", "upper"))
        return nodes_in_box(points, _vector(box["lower"], "box lower"), _vector(box["upper"], "box upper"))
    if kind == "plane":
        plane = _fields(value, "plane", ("point", "normal"))
        return nodes_behind_plane(points, plane["point"], plane["normal"])
    if kind == "indices":
        return node_indices(_integers(value, "indices"), node_count=len(points))
    path = _path(value, kind, folder)
    values = read_node_file(path, kind=kind.replace("_file", ""))
    if kind == "mask":
        return node_mask(values, node_count=len(points), source=f"the mask file {path}")
    return node_indices(_integers(values, f"the indices file {path}"), node_count=len(points))


def _only_entry(spec) -> tuple[str, object]:
    choices = ", ".join(REGION_KINDS)
    if not isinstance(spec, Mapping) or len(spec) != 1:
        raise BoundaryConditionError(f"a fixed region is a mapping with exactly one of the keys {choices}, got "
                                     f"{spec!r}; e.g. {{'bottom': 0.1}}")
    (kind, value), = spec.items()
    if kind not in REGION_KINDS:
        raise BoundaryConditionError(f"unknown fixed region {kind!r}; choose one of {choices}")
    return kind, value


def _fields(value, kind: str, names: tuple[str, str]) -> dict:
    if not isinstance(value, Mapping) or set(value) != set(names):
        got = sorted(value) if isinstance(value, Mapping) else repr(value)
        raise BoundaryConditionError(f"a {kind} region needs exactly the keys {' and '.join(names)}, got {got}; "
                                     f"{kind} is {REGION_KINDS[kind]}")
    return dict(value)


def _vector(value, what: str) -> np.ndarray:
    try:
        vector = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        vector = None
    if vector is None or vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise BoundaryConditionError(f"the {what} must be three finite numbers (x, y, z), got {value!r}")
    return vector


def _number(value, kind: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise BoundaryConditionError(f"a {kind} region is a {REGION_KINDS[kind]}, got {value!r}")
    return float(value)


def _integers(value, what: str) -> np.ndarray:
    array = np.asarray(value)
    if array.dtype.kind == "f" and array.size and np.all(np.isfinite(array)) and np.all(array == np.round(array)):
        array = array.astype(np.int64)
    if array.dtype.kind not in "iu" or array.ndim != 1 or array.size == 0:
        raise BoundaryConditionError(f"{what} must be a non-empty list of whole vertex indices, got "
                                     f"{np.asarray(value).dtype} {np.asarray(value).shape}")
    return array


def _path(value, kind: str, folder):
    if isinstance(value, bytes) or not isinstance(value, (str, os.PathLike)) or not str(value).strip():
        raise BoundaryConditionError(f"a {kind} region is the {REGION_KINDS[kind]}, got {value!r}")
    path = Path(value)
    return path if folder is None or path.is_absolute() else Path(folder) / path
