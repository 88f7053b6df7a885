"""The surface layer on the fine surface M_S (§4, §6.3–6.5): its position-based constraints and step kernels, its
physical compliance, its linear statics and implicit step, and its finite-strain solve."""

from __future__ import annotations
