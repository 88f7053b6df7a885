"""Tetrahedral volume meshes: the coarse volume M_V and the fine reference volume of the paper (§5, §8.3)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError, first_indices

# A tet whose volume is below this fraction of (bounding-box diagonal)³ is degenerate: its stiffness would be
# dominated by round-off.
DEGENERATE_VOLUME_FRACTION = 1e-14

# Local vertex triples of a tet's four faces, ordered so that each face's normal points out of a positive tet.
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int32)


def tet_signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """``(m,) float64`` signed volumes [m³]; positive when ``(p1-p0, p2-p0, p3-p0)`` is right-handed."""
    p = points[tets]
    return np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])) / 6.0


@dataclass(frozen=True, eq=False)
class TetMesh:
    """A linear tetrahedral mesh.

    Attributes:
        points: ``(n, 3) float64`` node positions [m].
        tets: ``(m, 4) int32`` node indices per tetrahedron, positively oriented.

    Inverted or degenerate tets are refused with a :class:`MeshError` naming them.
    """

    points: np.ndarray
    tets: np.ndarray

    def __post_init__(self):
        points = np.ascontiguousarray(self.points, dtype=np.float64)
        tets = np.ascontiguousarray(self.tets, dtype=np.int32)
        if points.ndim != 2 or points.shape[1] != 3:
            raise MeshError(f"points must have shape (n, 3), got {points.shape}")
        if tets.ndim != 2 or tets.shape[1] != 4:
            raise MeshError(f"tets must have shape (m, 4), got {tets.shape}")
        if len(tets) == 0:
            raise MeshError("the tet mesh has no tetrahedra")
        if not np.all(np.isfinite(points)):
            bad = np.flatnonzero(~np.all(np.isfinite(points), axis=1))
            raise MeshError(f"{bad.size} points have non-finite coordinates (first: {first_indices(bad)})")
        out = np.flatnonzero(np.any((tets < 0) | (tets >= len(points)), axis=1))
        if out.size:
            raise MeshError(
                f"{out.size} tets reference nodes outside 0..{len(points) - 1} (first tets: {first_indices(out)})"
            )
        volumes = tet_signed_volumes(points, tets)
        scale = np.linalg.norm(np.ptp(points, axis=0)) ** 3
        degenerate = np.flatnonzero(np.abs(volumes) <= DEGENERATE_VOLUME_FRACTION * scale)
        if degenerate.size:
            raise MeshError(
                f"{degenerate.size} degenerate (zero-volume) tets (first: {first_indices(degenerate)}); "
                "remesh with a quality bound"
            )
        inverted = np.flatnonzero(volumes < 0)
        if inverted.size:
            raise MeshError(
                f"{inverted.size} inverted tets (negative volume; first: {first_indices(inverted)}); "
                "swap two nodes of each to orient them positively"
            )
        points.flags.writeable = False
        tets.flags.writeable = False
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "tets", tets)

    @property
    def node_count(self) -> int:
        return len(self.points)

    @property
    def element_count(self) -> int:
        return len(self.tets)

    @cached_property
    def volumes(self) -> np.ndarray:
        """``(m,) float64`` tet volumes [m³], all positive."""
        return tet_signed_volumes(self.points, self.tets)

    @cached_property
    def boundary_triangles(self) -> np.ndarray:
        """``(b, 3) int32`` faces that belong to exactly one tet, oriented outward."""
        faces = self.tets[:, TET_FACES].reshape(-1, 3)
        keys = np.sort(faces, axis=1)
        _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        return np.ascontiguousarray(faces[counts[inverse.ravel()] == 1], dtype=np.int32)

    @cached_property
    def boundary_nodes(self) -> np.ndarray:
        """``(k,) int32`` sorted indices of the nodes on the boundary surface."""
        return np.unique(self.boundary_triangles).astype(np.int32)


# Kuhn (Freudenthal) split of a hex into six tets around its main diagonal, corners numbered 4i + 2j + k for the
# offsets (i, j, k) ∈ {0,1}³; every hex is cut the same way, so neighbouring hexes' face diagonals match.
_KUHN_TETS = np.array([[0, 4, 6, 7], [0, 4, 5, 7], [0, 2, 6, 7], [0, 2, 3, 7], [0, 1, 5, 7], [0, 1, 3, 7]])


def structured_box(size: ArrayLike, divisions: ArrayLike, *, origin: ArrayLike = (0.0, 0.0, 0.0)) -> TetMesh:
    """A conforming structured tet mesh of the box ``origin`` .. ``origin + size`` (``(3,)`` [m] each):
    ``divisions`` ``(3,) int`` hexes per axis, each split into six tets (Kuhn split). For tests with known
    solutions (patch test, cantilever) and benchmarks; node ``(i, j, k)`` of the grid has index
    ``(i (ny+1) + j) (nz+1) + k``."""
    size = np.asarray(size, dtype=np.float64)
    divisions = np.asarray(divisions)
    if size.shape != (3,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
        raise MeshError(f"box size must be three positive lengths [m], got {size.tolist()}")
    if divisions.shape != (3,) or divisions.dtype.kind not in "iu" or np.any(divisions < 1):
        raise MeshError(f"box divisions must be three integers >= 1, got {divisions.tolist()}")
    nx, ny, nz = (int(d) for d in divisions)
    axes = [np.linspace(0.0, s, d + 1) for s, d in zip(size, (nx, ny, nz))]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3) + np.asarray(origin, float)
    index = np.arange(len(points)).reshape(nx + 1, ny + 1, nz + 1)
    corners = np.stack(
        [index[i : i + nx, j : j + ny, k : k + nz].ravel() for i in (0, 1) for j in (0, 1) for k in (0, 1)], axis=1
    )
    tets = corners[:, _KUHN_TETS].reshape(-1, 4)
    # Half of the Kuhn tets come out left-handed; swapping two nodes orients them positively.
    negative = tet_signed_volumes(points, tets) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    return TetMesh(points, tets)
