"""Tetrahedralization with TetGen (paper §5 step 3): the coarse volume M_V from M'_S, the fine volume from M_S.

TetGen is AGPL-licensed; it is used through the PyPI ``tetgen`` package. Switches (TetGen manual §4.2):

* ``p``  tetrahedralize the piecewise linear complex given by the surface (keep the surface as the boundary);
* ``Y``  add *no* Steiner point on the boundary, so the boundary nodes of the volume are exactly the surface's
  vertices, at the same coordinates bit for bit (TetGen keeps the input points first, in input order);
* ``q R/D`` quality: radius-edge ratio at most R, dihedral angles at least D degrees, reached by adding *interior*
  points only (boundary points are frozen by ``Y``);
* ``Q``  quiet.

Coarse M_V: ``pYq1.8/12``. With the default simplification ratio this gives M_V nodes of 0.34-0.41x M_S's vertices
and 1,300-2,000 tets on the built-in models, close to Table 1 (0.34-0.42x, 1,220-1,719 tets); without ``q`` the
volume has no interior node at all and many slivers.
Fine reference volume: ``pYq1.2/15``: a quality mesh graded from the fine surface inward (1.3-1.8x M_S's vertices
as nodes; Table 1's fine volumes have about 2.3x).
"""

from __future__ import annotations

import glob
import os
import sys
import tempfile
from contextlib import contextmanager, suppress

import numpy as np

from ..errors import MeshError, first_indices
from .surface import SurfaceMesh
from .tetmesh import TetMesh, tet_signed_volumes

COARSE_SWITCHES = "pYq1.8/12"
FINE_SWITCHES = "pYq1.2/15"
#: Files TetGen writes into the working directory on some failures (removed again).
TETGEN_LEFTOVERS = "tetgen-tmpfile*"


def tetrahedralize(surface: SurfaceMesh, *, switches: str = COARSE_SWITCHES) -> tuple[TetMesh, np.ndarray]:
    """Fill a closed, outward-oriented surface with positive tetrahedra, keeping its vertices as the boundary.

    Args:
        surface: the closed surface (M'_S for M_V, M_S for the fine volume).
        switches: TetGen switches; must contain ``p`` and ``Y`` (boundary preserved). ``Q`` is added.

    Returns:
        ``(volume, surface_nodes)``: the :class:`TetMesh` and ``(n,) int32`` volume node index of each surface
        vertex (``volume.points[surface_nodes] == surface.vertices`` bit for bit; the boundary node set of the
        volume is exactly ``surface_nodes``).

    Raises:
        MeshError: bad switches, TetGen failure (e.g. a self-intersecting surface), or a result whose boundary is
            not the input surface.
    """
    import tetgen

    if "p" not in switches or "Y" not in switches:
        raise MeshError(f"TetGen switches {switches!r} must contain 'p' and 'Y' so the boundary is kept as given")
    if "Q" not in switches:
        switches += "Q"
    try:
        with _quiet_stdout(), _no_leftovers():
            nodes, elems, *_ = tetgen.TetGen(surface.vertices, surface.triangles).tetrahedralize(switches=switches)
    except (RuntimeError, ValueError) as error:
        raise MeshError(
            f"TetGen could not tetrahedralize the surface ({surface.vertex_count} vertices, "
            f"{surface.triangle_count} triangles) with switches {switches!r}: {str(error).rstrip('.')}; check it with "
            "tissuesim.mesh.validate.validate_surface (self-intersections are the usual cause) or read it with "
            "repair=True") from error
    nodes = np.asarray(nodes, dtype=np.float64)
    elems = np.asarray(elems, dtype=np.int64)
    if len(elems) == 0:
        raise MeshError(f"TetGen produced no tetrahedra for a surface of {surface.vertex_count} vertices; "
                        "is it closed?")
    n = surface.vertex_count
    if len(nodes) < n or not np.array_equal(nodes[:n], surface.vertices):
        raise MeshError("TetGen moved or dropped input vertices (duplicate vertices in the surface?); "
                        "merge duplicates before tetrahedralizing")
    # TetGen's tets are positive in our convention; orient defensively (swap two nodes of any negative one).
    negative = tet_signed_volumes(nodes, elems) < 0
    elems[negative] = elems[negative][:, [0, 1, 3, 2]]
    volume = TetMesh(nodes, elems.astype(np.int32))
    surface_nodes = np.arange(n, dtype=np.int32)
    boundary = volume.boundary_nodes
    if not np.array_equal(boundary, surface_nodes):
        extra = np.setdiff1d(boundary, surface_nodes)
        missing = np.setdiff1d(surface_nodes, boundary)
        changes = []
        if extra.size:
            changes.append(f"{extra.size} added boundary nodes (first: {first_indices(extra)}, at "
                           f"{_where(nodes, extra)})")
        if missing.size:
            changes.append(f"{missing.size} surface vertices not on the boundary (first: {first_indices(missing)})")
        raise MeshError(
            f"TetGen changed the boundary of a {surface.vertex_count}-vertex surface: {', '.join(changes)}; it does "
            "so where it cannot fill the surface as given: run validate_surface (slivers, self-intersections), and "
            "for a valid surface remesh near those points or build with fewer target_vertices")
    return volume, surface_nodes


def _where(nodes: np.ndarray, extra: np.ndarray) -> str:
    """The position [m] of the first added node, for the message."""
    x, y, z = nodes[extra[0]]
    return f"({x:.4g}, {y:.4g}, {z:.4g}) m"


@contextmanager
def _no_leftovers():
    """Remove the ``tetgen-tmpfile*`` files TetGen may write into the working directory when it fails.

    The working directory itself is never changed: it belongs to the whole process, and another thread's relative
    paths would resolve inside a scratch folder. Only files that appeared during the call are removed.
    """
    before = set(glob.glob(TETGEN_LEFTOVERS))
    try:
        yield
    finally:
        for name in set(glob.glob(TETGEN_LEFTOVERS)) - before:
            with suppress(OSError):
                os.remove(name)


@contextmanager
def _quiet_stdout():
    """Silence text the TetGen wrapper prints to the C-level stdout (it ignores ``Q``), so CLI output stays clean."""
    try:
        # the C code writes to the process's stdout, which sys.stdout need not be (a notebook kernel's stream)
        fd = sys.__stdout__.fileno()
    except (AttributeError, OSError, ValueError):
        yield
        return
    sys.stdout.flush()
    saved = os.dup(fd)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), fd)
        try:
            yield
        finally:
            os.dup2(saved, fd)
            os.close(saved)
