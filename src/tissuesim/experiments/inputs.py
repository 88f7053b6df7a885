"""The models a command or experiment is given, checked before any work: names, sizes, resolutions, and what a
model must offer a method or a load (the fine volume, a free load node), each refusal in command-line terms."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import MeshError, SolverError
from ..mesh import models as builtin_models
from ..mesh.models import MAX_RESOLUTION

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..mesh.surface import SurfaceMesh
    from ..solvers.base import Solver


def builtin_surface(name: str, *, resolution: int | None = None, scale: float = 1.0) -> SurfaceMesh:
    """The built-in model ``name`` at ``resolution`` vertices (None: its Table-1 size), its coordinates multiplied
    by ``scale`` as a surface file's are (refused, naming the scale, outside 1 µm to 100 m across; warned of outside
    5 mm to 2 m)."""
    from ..io import check_model_size, check_scale, warn_model_size

    scale = check_scale(scale)
    surface = builtin_models.model(name, None if resolution is None else check_resolution(resolution))
    if scale == 1.0:
        return surface
    check_model_size(surface.vertices, scale=scale, source=f"the built-in {name}")
    surface = surface.with_vertices(surface.vertices * scale)
    warn_model_size(surface.vertices, scale=scale, source=f"the built-in {name}")
    return surface


def check_resolution(resolution: object) -> int:
    """``resolution`` (vertices of a built-in model) as an int, or a MeshError naming the accepted range."""
    low, high = builtin_models.MIN_RESOLUTION, MAX_RESOLUTION
    number = isinstance(resolution, (int, float)) and not isinstance(resolution, bool)
    if not (number and low <= resolution <= high and resolution == int(resolution)):
        given = f"{resolution:g}" if number else repr(resolution)
        raise MeshError(f"--resolution (vertices of a built-in model) must be a whole number from {low} to {high}, "
                        f"got {given}; the Table-1 sizes are about 1400")
    return int(resolution)


def check_free_node(solver: Solver, node: int, model: str, *, role: str) -> None:
    """Refuse (SolverError), in command-line terms, a command's load on a node of ``model`` that ``solver``'s support
    holds: a region given that holds it, or, with the default bottom, a model too small or coarse for the load
    (``role`` says which load)."""
    fixed = np.asarray(solver.fixed)
    if np.any(fixed == node) and not getattr(solver, "fixed_from_height", True):
        raise SolverError(f"{role} on {model} falls on node {node}, which the fixed region holds ({fixed.size} of "
                          f"its {len(solver.rest_positions)} surface nodes); choose a --fix region that leaves it "
                          "free")
    if np.any(fixed == node):
        raise SolverError(f"{model} is too small or too coarse for {role}: node {node}, where it is applied, lies in "
                          f"the supported bottom region ({fixed.size} of its {len(solver.rest_positions)} surface "
                          "nodes are held); give a larger model (a surface file in cm or mm needs --scale 0.01 or "
                          "0.001) or a finer one (--resolution for a built-in)")


def model_name(spec: str) -> str:
    """The name a model is reported under: the built-in name, or a file's stem."""
    return spec if spec in builtin_models.MODELS else Path(spec).stem


def check_model_specs(specs: Sequence[str]) -> None:
    """Refuse, before any work, a model that is neither a built-in name nor an existing file, or two models reported
    under one name (SolverError)."""
    for spec in specs:
        if spec not in builtin_models.MODELS and not Path(spec).is_file():
            raise SolverError(f"model {spec!r} is neither a built-in model ({', '.join(builtin_models.MODELS)}) nor "
                              "an existing file; name one of those or give a mesh path")
    check_model_names(specs)


def check_model_names(specs: Iterable[str]) -> None:
    """Refuse (SolverError) two models reported under one name (:func:`model_name`): their rows and files would
    overwrite each other."""
    seen = {}
    for spec in specs:
        name = model_name(spec)
        if name in seen:
            raise SolverError(f"models {seen[name]!r} and {spec!r} are both named {name!r}, so their results and files "
                              "would overwrite each other; give each model once, or copy a file under another name")
        seen[name] = spec


def check_fine_volume(hybrid: HybridMesh, spec: str) -> None:
    """Refuse (MeshError) a bundle without the fine volume the fem reference needs, naming the cause: a cut (the
    volume of the uncut surface is dropped by the first cut) or a build without it."""
    if hybrid.fine_volume is not None:
        return
    cuts = int(hybrid.info.get("cuts", 0) or 0)
    if cuts:
        raise MeshError(f"bundle {spec!r} was saved after {cuts} cutting moves, and the fem reference cannot run on a "
                        "cut surface (its fine volume is a mesh of the uncut surface); give the uncut bundle or its "
                        "surface file")
    raise MeshError(f"bundle {spec!r} was built without the fine volume, which the fem reference needs; rebuild it "
                    "with `tissuesim build SURFACE -o BUNDLE.npz` (without --no-fine-volume)")


def check_model_files(specs: Iterable[str], *, scale: float = 1.0, repair: bool = False) -> None:
    """Read, without building, every model file of ``specs`` that an experiment will build later: a surface file is
    read and validated (skipped with ``repair``, which may fix it), a bundle loaded and checked for its fine volume,
    so a bad later model is refused before the first model's minutes of work."""
    from ..io import SURFACE_EXTENSIONS, read_surface
    from ..mesh.hybrid import HybridMesh

    for spec in specs:
        if spec in builtin_models.MODELS:
            continue
        if Path(spec).suffix.lower() not in SURFACE_EXTENSIONS:
            check_fine_volume(HybridMesh.load(spec), spec)
        elif not repair:
            read_surface(spec, scale=scale)
