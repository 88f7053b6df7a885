"""The ``pbd`` method (the paper's PBD baseline): the surface layer (:mod:`.surface_layer`) on M_S alone, its fixed
nodes pinned at rest and every other node projected; no FEM."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .registry import register
from .surface_layer import SurfaceLayerSolver

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh

#: The pbd method's default: settles 1 N on the cube in 104 steps (0.2: 157; 0.4: 286) and 20 N in 1261 (0.2: not
#: within 1500).
PBD_DAMPING = 0.1


@register("pbd")
class PBDSolver(SurfaceLayerSolver):
    """PBD on M_S alone: fixed nodes pinned at rest, every other node projected (see the module docstring)."""

    label = "surface PBD"
    short_label = "PBD"
    colour = "tab:blue"
    line_style = "--"
    in_paper = True
    free_scalars = {"xpbd": ("thickness_ratio", 1.0, 16.0), "pbd": ("mass_scale", 1.0, 1e5)}

    gravity_caveat = ("a surface layer has no volume to carry its weight, so its sag is not an elastic body's (a "
                      "column's top sags 0.24 of the analytic ρgH²/(2E); the models are 22-49 % off the fine FEM, "
                      "docs/gravity-and-supports.md); use hybrid, embedded or fem for self-weight")

    def __init__(self, hybrid_mesh: HybridMesh, *, damping: float = PBD_DAMPING, **options: object):
        super().__init__(hybrid_mesh, damping=damping, **options)
        self._set_prescribed(self.fixed)
