"""The hybrid mesh of §5: fine surface M_S, coarse surface M'_S, coarse volume M_V, and the maps between them.

Build (:meth:`HybridMesh.build`): validate M_S, simplify it to M'_S (:mod:`.simplify`), tetrahedralize M'_S into
M_V and M_S into the fine reference volume (:mod:`.tetrahedralize`), then map every M_S vertex to

* its closest point on M'_S (triangle + barycentric weights, inside the triangle), used to spread a load on that
  vertex over three control nodes (§6.1); a control node maps to itself with weight 1;
* its barycentric coordinates in the M_V tet that contains it, or, for a vertex outside M_V, in the tet owning the
  M'_S face of its closest point (the nearest tet); these coordinates are not clamped, so they reproduce the vertex.

Both searches use a k-d tree on element centroids, so the cost is about O(n log m), not O(n m).

Its bundle (:meth:`HybridMesh.save` / :meth:`HybridMesh.load`) is :mod:`.bundle`'s; its row of Table 1
(:meth:`HybridMesh.table1_row`) is :mod:`.table1`'s.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MeshError
from .bundle import load_bundle, save_bundle
from .bundle_check import SURFACE_EDGE_KEY, SURFACE_VERTICES_KEY
from .surface import SurfaceMesh
from .maps import closest_on_surface, embed_in_volume, own_corner
from .table1 import table1_row
from .tetmesh import TetMesh

# the progress bar's last steps, the same for every construction
MAP_STEP = "map M_S onto M'_S and M_V"
FINE_STEP = "tetrahedralize M_S -> fine volume"


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
        from .tetrahedralize import COARSE_SWITCHES, tetrahedralize
        from .validate import validate_surface

        steps, timings = _plan(["simplify M_S -> M'_S", "tetrahedralize M'_S -> M_V"], fine_volume), {}
        # A bar left open on an error would run into the error line on stderr: close it on every exit.
        with _progress(len(steps), progress) as bar:
            with _step(bar, steps[0], timings, "validate_s"):
                validate_surface(surface)
            with _step(bar, steps[1], timings, "simplify_s"):
                simplified = simplify(surface, target_vertices=target_vertices)
                coarse, control = simplified.surface, simplified.kept
            with _step(bar, steps[2], timings, "coarse_tetgen_s"):
                volume, control_volume = tetrahedralize(coarse, switches=COARSE_SWITCHES)
            return cls._completed(surface, coarse, control, volume, control_volume, fine_volume, bar, timings,
                                  {"simplify": simplified.report.as_dict(), "coarse_switches": COARSE_SWITCHES})

    @classmethod
    def from_volume(cls, surface: SurfaceMesh, volume: TetMesh, *, fine_volume: bool = False,
                    progress: bool = False) -> "HybridMesh":
        """The hybrid mesh of M_S with a coarse volume M_V from a mesher of your choice, so that no TetGen runs
        (it is AGPL-3.0): M'_S is ``volume``'s boundary, and its nodes are the control nodes
        (:mod:`.given_volume`).

        Args:
            surface: M_S, closed, manifold, outward-oriented, free of self-intersections (validated here).
            volume: M_V as a :class:`~.tetmesh.TetMesh` in metres, positively oriented tets, whose every boundary
                node is a vertex of ``surface`` (no Steiner point on the boundary; interior nodes are free).
            fine_volume: also tetrahedralize M_S with TetGen (the ``fem`` method's mesh); default False.
            progress: show the steps with a tqdm bar on stderr.

        Raises:
            MeshError: ``surface`` is invalid, a boundary node of ``volume`` is no vertex of ``surface`` (or two
                share one), or the boundary is not a valid closed surface (each names the first offenders).
        """
        _check_is_surface(surface)
        from .given_volume import coarse_from_volume
        from .validate import validate_surface

        steps, timings = _plan(["check M_V against M_S"], fine_volume), {}
        with _progress(len(steps), progress) as bar:
            with _step(bar, steps[0], timings, "validate_s"):
                validate_surface(surface)
            with _step(bar, steps[1], timings, "coarse_check_s"):
                coarse, control, control_volume = coarse_from_volume(surface, volume)
                try:
                    validate_surface(coarse)
                except MeshError as error:
                    raise MeshError(f"the volume's boundary is no valid M'_S: {error}") from None
            return cls._completed(surface, coarse, control, volume, control_volume, fine_volume, bar, timings,
                                  {"simplify": None, "coarse_switches": None, "coarse_volume": "given"})

    @classmethod
    def _completed(cls, surface, coarse, control, volume, control_volume, fine_volume: bool, bar, timings: dict,
                   info: dict) -> "HybridMesh":
        """The steps every construction ends with, once M'_S and M_V are known: the maps, the fine volume if
        asked for, the build report (``info`` with the timings and M_S's size)."""
        from .tetrahedralize import FINE_SWITCHES, tetrahedralize

        with _step(bar, MAP_STEP, timings, "maps_s"):
            maps = _map_surface(surface, coarse, control, volume)
        fine, fine_nodes = None, None
        if fine_volume:
            with _step(bar, FINE_STEP, timings, "fine_tetgen_s"):
                fine, fine_nodes = tetrahedralize(surface, switches=FINE_SWITCHES)
        timings["total_s"] = sum(timings.values())
        info = {**info, "fine_switches": FINE_SWITCHES if fine_volume else None, "timings": timings,
                SURFACE_EDGE_KEY: surface.mean_edge_length, SURFACE_VERTICES_KEY: surface.vertex_count}
        return cls(surface=surface, coarse_surface=coarse, volume=volume, control=control,
                   control_volume=np.asarray(control_volume, dtype=np.int32), **maps, fine_volume=fine,
                   fine_surface_nodes=fine_nodes, info=info)

    # -- bundle ------------------------------------------------------------------------------------------------

    def save(self, path: Path | str) -> Path:
        """Write the bundle to ``path`` (``.npz``) atomically; return the path.

        Raises:
            BundleError: ``path`` is empty or not a path, exists and is not a regular file (a folder, device or
                pipe would be replaced), or no file can be written there (the message names ``path``).
        """
        return save_bundle(self, path)

    @classmethod
    def load(cls, path: Path | str) -> "HybridMesh":
        """Read a bundle written by :meth:`save`.

        Raises:
            FileNotFoundError: no such file.
            BundleError: ``path`` is not a path or is a folder, device or pipe; the file is not a bundle, is
                corrupt, or was written in another bundle format version.
        """
        return cls(**load_bundle(path))

    # -- reporting ---------------------------------------------------------------------------------------------

    def table1_row(self) -> dict:
        """Table 1's figures for this mesh: see :func:`.table1.table1_row`."""
        return table1_row(self)


def _plan(middle: list[str], fine_volume: bool) -> list[str]:
    """The progress bar's steps of a construction: validate M_S, ``middle``, the maps, the fine volume if asked."""
    return ["validate M_S", *middle, MAP_STEP, *([FINE_STEP] if fine_volume else [])]


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


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, disable=not enabled, unit="step", leave=False)


@contextmanager
def _step(bar, description: str, timings: dict, key: str):
    """One step of :meth:`HybridMesh.build`: named on ``bar``, its wall time into ``timings[key]`` [s]."""
    bar.set_description(description)
    t = time.perf_counter()
    yield
    timings[key] = time.perf_counter() - t
    bar.update()


def _map_surface(surface: SurfaceMesh, coarse: SurfaceMesh, control: np.ndarray, volume: TetMesh) -> dict:
    """The maps of every M_S vertex onto M'_S and into M_V (module docstring), as :class:`HybridMesh` fields."""
    coarse_triangle, coarse_barycentric = closest_on_surface(coarse, surface.vertices)
    # Control nodes map to themselves exactly (the search can land on another triangle at distance 0).
    coarse_triangle[control], coarse_barycentric[control] = own_corner(coarse, len(control))
    embedding_tet, embedding_barycentric = embed_in_volume(volume, surface.vertices, coarse, coarse_triangle,
                                                           coarse_barycentric)
    return dict(coarse_triangle=coarse_triangle, coarse_barycentric=coarse_barycentric, embedding_tet=embedding_tet,
                embedding_barycentric=embedding_barycentric)
