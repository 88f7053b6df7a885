"""The experimental protocol of §8.3: load cases, the load node, the sample nodes and the metrics (eq 25–26).

Every method is measured on the same footing: the same fine surface M_S, the same fixed region (the model's
bottom, :func:`tissuesim.mesh.regions.bottom_height` with its documented fraction), the same load node, the same
sample nodes and the same fine-volume FEM reference. These helpers are pure functions of arrays, so the solvers'
calibration can import them too and calibrate on exactly what is measured.

Choices where the paper is silent (also in docs/experiments.md):

* **Load node** — "the top surface node nearest the vertical axis through the model's centre". The centre is the
  middle of the bounding box in x and y. The vertical line through it is cast downward from above the model; the
  load node is the M_S vertex nearest (in 3-D) to the first point where that line meets the surface. This is the
  node on the *upper* surface, never one on the bottom, and on a flat top (cube) it is the node at the centre of
  the face. Ties go to the lowest vertex index. If the line misses the surface (a shape with a hole over its
  centre), the node nearest the top centre of the bounding box is used instead.
* **Sample nodes** — the k M_S vertices nearest at rest to the load node (Euclidean distance, the load node
  itself first; ties by vertex index): k = 10 for the displacement plots, 50 for the RMSE, as in §8.3.1.
* **Relative RMSE** — eq 26 divided by the reference's RMS displacement over the same nodes, so that errors on
  models and loads of different size compare.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import SolverError, first_indices
from ..mesh.regions import BOTTOM_FRACTION, bottom_height, nodes_below

# The magnitudes of §8.3.1 [N]: 0.5, 1, 2 N "small deformation", 5, 10, 20 N "large deformation".
FORCES_N = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
SMALL_FORCES_N = (0.5, 1.0, 2.0)
LARGE_FORCES_N = (5.0, 10.0, 20.0)

# Load kind -> unit direction: "vertical upward tension and vertical downward pressure" (§8.3.1).
LOAD_DIRECTIONS = {"tension": (0.0, 0.0, 1.0), "pressure": (0.0, 0.0, -1.0)}
LOADS = tuple(LOAD_DIRECTIONS)

# Sample sizes of §8.3.1.
PLOT_SAMPLES = 10
RMSE_SAMPLES = 50

#: The reference every method is measured against (the fine-volume FEM); the methods compared with it are every
#: registered method (:func:`.methods.protocol_methods`).
REFERENCE = "fem"

__all__ = [
    "BOTTOM_FRACTION", "FORCES_N", "LARGE_FORCES_N", "LOADS", "LOAD_DIRECTIONS", "PLOT_SAMPLES",
    "REFERENCE", "RMSE_SAMPLES", "SMALL_FORCES_N", "LoadCase", "displacements", "fixed_nodes", "load_cases",
    "load_node", "relative_rmse", "rms_displacement", "rmse", "sample_nodes",
]


@dataclass(frozen=True)
class LoadCase:
    """One load case: ``load`` ("tension" or "pressure") of magnitude ``force_N`` [N] on the load node."""

    load: str
    force_N: float

    def __post_init__(self):
        if self.load not in LOAD_DIRECTIONS:
            raise SolverError(f"unknown load {self.load!r}; choose one of {', '.join(LOAD_DIRECTIONS)}")
        if not (np.isfinite(self.force_N) and self.force_N > 0.0):
            raise SolverError(f"force magnitude must be a positive number of newtons, got {self.force_N!r}")

    @property
    def vector(self) -> np.ndarray:
        """``(3,) float64`` the force [N]: +z for tension, −z for pressure."""
        return float(self.force_N) * np.asarray(LOAD_DIRECTIONS[self.load], dtype=np.float64)

    @property
    def label(self) -> str:
        """A short human label, e.g. ``"tension 0.5 N"``."""
        return f"{self.load} {self.force_N:g} N"


def load_cases(forces: Iterable[float] = FORCES_N, loads: Iterable[str] = LOADS) -> list[LoadCase]:
    """The load cases of §8.3.1 in the paper's table order: every load kind, then every force ascending."""
    forces = sorted({float(f) for f in forces})
    if not forces:
        raise SolverError("no forces given; pass at least one force magnitude in newtons")
    return [LoadCase(load, force) for load in loads for force in forces]


def fixed_nodes(points: np.ndarray, *, fraction: float = BOTTOM_FRACTION) -> np.ndarray:
    """``(k,) int32`` the fixed region of every method: nodes of ``points`` ``(n, 3)`` [m] at the model's bottom."""
    return nodes_below(points, bottom_height(points, fraction=fraction))


def load_node(vertices: np.ndarray, triangles: np.ndarray | None = None) -> int:
    """The M_S vertex index where the load is applied: the top surface node nearest the vertical centre axis.

    Args:
        vertices: ``(n, 3) float64`` M_S rest positions [m], z up.
        triangles: ``(m, 3) int`` M_S triangles; without them the node nearest the top centre of the bounding box
            is returned (the fallback rule, see the module docstring).
    """
    vertices = _check_points(vertices)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    centre = 0.5 * (lo[:2] + hi[:2])
    target = np.array([centre[0], centre[1], hi[2]])
    if triangles is not None and len(triangles):
        hit = _highest_axis_hit(vertices, np.asarray(triangles), centre)
        if hit is not None:
            target = np.array([centre[0], centre[1], hit])
    distance = np.linalg.norm(vertices - target, axis=1)
    return int(np.argmin(distance))  # argmin returns the first (lowest index) of equal minima


def sample_nodes(rest_positions: np.ndarray, node: int, count: int) -> np.ndarray:
    """``(count,) int64`` the ``count`` nodes nearest at rest to ``node``, nearest first, ``node`` itself included.

    Args:
        rest_positions: ``(n, 3) float64`` rest positions [m].
        node: index of the load node.
        count: k, e.g. :data:`PLOT_SAMPLES` or :data:`RMSE_SAMPLES`.
    """
    rest_positions = _check_points(rest_positions)
    n = len(rest_positions)
    if not 0 <= int(node) < n:
        raise SolverError(f"load node {node} is outside 0..{n - 1}")
    if not 1 <= int(count) <= n:
        raise SolverError(f"sample count must lie in 1..{n} (the number of surface nodes), got {count}")
    distance = np.linalg.norm(rest_positions - rest_positions[int(node)], axis=1)
    distance[int(node)] = -1.0  # the load node first, even if another node coincides with it
    order = np.lexsort((np.arange(n), distance))  # by distance, then by index: deterministic
    return order[: int(count)].astype(np.int64)


def displacements(positions: np.ndarray, rest_positions: np.ndarray, nodes: np.ndarray | Sequence[int]) -> np.ndarray:
    """Eq 25: ``(k,) float64`` d = |x_s − x_0| [m] of ``nodes`` between ``rest_positions`` and ``positions``."""
    positions, rest_positions, nodes = _check_pair(positions, rest_positions, nodes)
    return np.linalg.norm(positions[nodes] - rest_positions[nodes], axis=1)


def rmse(positions: np.ndarray, reference: np.ndarray, nodes: np.ndarray | Sequence[int]) -> float:
    """Eq 26: r = sqrt(Σ |x_s − x_f|² / n) [m] over ``nodes`` between a method's and the reference's positions."""
    positions, reference, nodes = _check_pair(positions, reference, nodes)
    difference = positions[nodes] - reference[nodes]
    return float(np.sqrt(np.einsum("ij,ij->", difference, difference) / len(nodes)))


def rms_displacement(reference: np.ndarray, rest_positions: np.ndarray, nodes: np.ndarray | Sequence[int]) -> float:
    """The reference's RMS displacement sqrt(Σ |x_f − x_0|² / n) [m] over ``nodes``."""
    return rmse(reference, rest_positions, nodes)


def relative_rmse(positions: np.ndarray, reference: np.ndarray, rest_positions: np.ndarray,
                  nodes: np.ndarray | Sequence[int]) -> float:
    """Eq 26 divided by the reference's RMS displacement over the same nodes (dimensionless; 0 is exact).

    NaN when the reference does not move those nodes at all (nothing to be relative to).
    """
    scale = rms_displacement(reference, rest_positions, nodes)
    return rmse(positions, reference, nodes) / scale if scale > 0.0 else float("nan")


def _highest_axis_hit(vertices: np.ndarray, triangles: np.ndarray, centre: np.ndarray) -> float | None:
    """Height [m] of the highest point where the vertical line through ``centre`` (x, y) meets the triangles."""
    p = vertices[triangles]  # (m, 3, 3)
    a, b, c = p[:, 0, :2] - centre, p[:, 1, :2] - centre, p[:, 2, :2] - centre
    # Barycentric coordinates of the origin in each triangle's xy projection (signed areas).
    w0 = b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]
    w1 = c[:, 0] * a[:, 1] - c[:, 1] * a[:, 0]
    w2 = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    total = w0 + w1 + w2
    with np.errstate(divide="ignore", invalid="ignore"):
        inside = (np.abs(total) > 0) & (np.minimum(np.minimum(w0 * total, w1 * total), w2 * total) >= 0)
    if not np.any(inside):
        return None
    w = np.stack([w0, w1, w2], axis=1)[inside] / total[inside, None]
    heights = np.einsum("ij,ij->i", w, p[inside, :, 2])
    return float(heights.max())


def _check_points(points) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise SolverError(f"positions must have shape (n, 3) with n ≥ 1, got {points.shape}")
    return points


def _check_pair(a, b, nodes):
    a, b = _check_points(a), _check_points(b)
    if a.shape != b.shape:
        raise SolverError(f"position arrays differ in shape: {a.shape} and {b.shape}")
    nodes = np.asarray(nodes, dtype=np.int64).ravel()
    if nodes.size == 0:
        raise SolverError("no sample nodes given")
    bad = np.flatnonzero((nodes < 0) | (nodes >= len(a)))
    if bad.size:
        raise SolverError(
            f"{bad.size} sample nodes lie outside 0..{len(a) - 1} (first positions in the list: {first_indices(bad)})"
        )
    return a, b, nodes
