"""The cut's compiled kernels loaded before the first cut of a process: one small cut of a procedural cube.

Numba loads a cached kernel from disk on its first call in a process (measured: about 17 ms of a 31 ms first move on
a 10k sphere, and more where another thread holds the interpreter). Doing it when the scalpel is picked up keeps it
out of the first cutting move.
"""

from __future__ import annotations

import numpy as np

from ..mesh.models import cube
from .buffers import CutSurface
from .core import DEFAULT_SNAP
from .invariants import unanchored_pieces
from .sweep import Sweep

_LOADED = False


def load_cut_kernels() -> None:
    """Cut a small cube once per process (nothing of the caller's is touched)."""
    global _LOADED
    if _LOADED:
        return
    surface = cube(200)
    rest = np.array(surface.vertices)
    top = rest[:, 2].max()
    cut = CutSurface(rest, rest.copy(), np.zeros_like(rest), np.array(surface.triangles))
    tip = np.array([rest[:, 0].min() * 0.5, 1.1e-3, top + 1e-3])      # across the top, off its symmetry planes
    sweep = Sweep.between(tip, tip * [-1.0, 1.0, 1.0], [0.0, 0.0, -0.01])
    plan = cut.plan(sweep, snap=DEFAULT_SNAP)
    if plan is not None:
        result = cut.apply(plan, sweep)
        unanchored_pieces(cut.triangles, len(result.rest), np.zeros(1, dtype=np.int64))
    _LOADED = True
