"""Linear finite elements on tetrahedra (§3, §6.2)."""

from __future__ import annotations
