"""Meshes of the hybrid model: surfaces, tetrahedral volumes, validation, simplification (§5) and the hybrid mesh."""

from __future__ import annotations
