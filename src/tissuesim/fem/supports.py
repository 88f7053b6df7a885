"""A finite-element model's supports checked: the fixed nodes as a dof mask, every node stiff somewhere, and no piece
of the mesh left free to move rigidly (:class:`~.linear.LinearFEM` and :class:`~.quadratic.QuadraticFEM` refuse such
supports before they factorise)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BoundaryConditionError, MeshError, first_indices
from ..mesh.tetmesh import TetMesh
from .rigid_modes import connected_pieces, free_rigid_modes


def fixed_mask(fixed: ArrayLike | None, n: int, *, sprung: bool = False) -> np.ndarray:
    """``(n, 3) bool`` fixed-dof mask from node indices, a node mask or a dof mask (see :class:`LinearFEM`); empty
    only where springs hold the mesh (``sprung``)."""
    if fixed is None and sprung:
        fixed = np.zeros(0, dtype=np.int64)
    if fixed is None:
        raise BoundaryConditionError(
            "no fixed node given: without supports K is singular (the body can move rigidly); pass fixed=, e.g. "
            "nodes_below(points, bottom_height(points)) from tissuesim.mesh.regions"
        )
    fixed = np.asarray(fixed)
    if fixed.dtype == bool:
        if fixed.shape == (n,):
            mask = np.repeat(fixed[:, None], 3, axis=1)
        elif fixed.shape == (n, 3):
            mask = fixed.copy()
        else:
            raise BoundaryConditionError(f"a boolean fixed mask must have shape ({n},) or ({n}, 3), got {fixed.shape}")
    else:
        if fixed.ndim != 1 or not (fixed.dtype.kind in "iu" or fixed.size == 0):
            raise BoundaryConditionError(
                f"fixed must be a 1-D integer array of node indices (or a bool mask), got {fixed.dtype} {fixed.shape}"
            )
        fixed = fixed.astype(np.int64)
        bad = np.flatnonzero((fixed < 0) | (fixed >= n))
        if bad.size:
            raise BoundaryConditionError(
                f"{bad.size} fixed node indices are outside 0..{n - 1} (first: {first_indices(fixed[bad])})"
            )
        mask = np.zeros((n, 3), dtype=bool)
        mask[fixed] = True
    if not mask.any() and not sprung:
        raise BoundaryConditionError(
            "no fixed node: without supports K is singular (the body can move rigidly); fix some nodes, e.g. "
            "nodes_below(points, bottom_height(points)) from tissuesim.mesh.regions"
        )
    return mask


def check_orphans(mesh: TetMesh, mask: np.ndarray) -> None:
    used = np.zeros(mesh.node_count, dtype=bool)
    used[mesh.tets.ravel()] = True
    orphans = np.flatnonzero(~used & ~mask.all(axis=1))
    if orphans.size:
        raise MeshError(
            f"{orphans.size} nodes belong to no tet (first: {first_indices(orphans)}), so nothing resists their "
            "motion; remove unreferenced nodes from the mesh or add them to the fixed set"
        )


def check_rigid_modes(mesh: TetMesh, mask: np.ndarray,
                      springs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
    """Refuse constraints that leave a rigid-body mode free in some connected piece of the mesh.

    The six rigid modes (3 translations, 3 rotations ω × x) restricted to the fixed dofs of a piece and to the
    points its springs hold (every axis) must have rank 6 (:func:`~.rigid_modes.free_rigid_modes`, O(held dofs))."""
    n = mesh.node_count
    t = mesh.tets
    count, label = connected_pieces(t, n)
    used = np.zeros(n, dtype=bool)
    used[t.ravel()] = True
    if springs is not None:
        nodes, weights, _ = springs
        spring_points = np.einsum("pr,prk->pk", weights, mesh.points[nodes])
        spring_piece = label[nodes[np.arange(len(nodes)), np.argmax(np.abs(weights), axis=1)]]
    for piece in np.unique(label[used]):
        nodes_in = np.flatnonzero((label == piece) & used)
        where = " in the mesh" if count == 1 else f" in a piece of the mesh ({nodes_in.size} nodes, first: " + (
            f"{first_indices(nodes_in)})"
        )
        fixed_nodes, axis = np.nonzero(mask[nodes_in])
        held, axes = mesh.points[nodes_in[fixed_nodes]], axis
        sprung = 0
        if springs is not None:
            on = spring_points[spring_piece == piece]
            sprung = len(on)
            held = np.concatenate([held, np.repeat(on, 3, axis=0)])
            axes = np.concatenate([axes, np.tile(np.arange(3), len(on))])
        if len(held) == 0:
            raise BoundaryConditionError(
                f"no fixed node{where}: that piece can move rigidly and K is singular; fix at least three "
                "non-collinear nodes of it" + (" or attach it" if springs is not None else "")
            )
        free = free_rigid_modes(mesh.points[nodes_in], held, axes)
        if free:
            detail = (
                "a single fixed node leaves rotations about it free"
                if np.unique(nodes_in[fixed_nodes]).size == 1 and not sprung
                else "the held points are collinear (rotation about their line is free) or the fixed dofs do not "
                "block every translation and rotation"
            )
            raise BoundaryConditionError(
                f"the fixed dofs{' and springs' if sprung else ''} leave {free} rigid-body mode(s) free{where}: "
                f"{detail}; fix at least three non-collinear nodes"
            )
