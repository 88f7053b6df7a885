"""§7 small incision on arrays: sweep ∩ surface, Fig 7 subdivision, vertex duplication, rest lengths (eq 19–23).

Pure functions (no solver): :func:`cut_surface` returns a :class:`CutResult`; :func:`check_cut_invariants` lists
what is wrong with a cut surface (used by the tests, the fuzz test and ``tissuesim incise``).
"""

from __future__ import annotations

from .core import DEFAULT_SNAP, cut_surface
from .invariants import check_cut_invariants
from .result import CutResult
from .sweep import Sweep

__all__ = ["DEFAULT_SNAP", "CutResult", "Sweep", "check_cut_invariants", "cut_surface"]
