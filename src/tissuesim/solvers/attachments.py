"""Elastic attachments (ligaments, vessels): springs from M_S vertices to fixed points, and the check that the
supports (fixed vertices plus attachments) hold the body.

An :class:`Attachment` ties ``nodes`` to an ``anchor`` with a total ``stiffness`` k [N/m], spread evenly: each of
its k_n nodes gets k/k_n, so a ligament's stiffness does not depend on how finely the surface is meshed. Each node's
spring is isotropic and of zero rest length: the force on node i is k_i (a_i − x_i), with a_i the anchor, or the
node's rest position when ``anchor`` is None (the spring then only resists motion). It is a spring, not a dead
load: each method adds its stiffness to the one it solves with (:mod:`tissuesim.solvers` methods: the FEM-based
ones map it to their volume through the embedding their loads use, the surface layer and the mass-spring network
take it on the node), so static answers are exact and stepping stays stable.

Supports must hold the body (:func:`check_supports_hold`): the fixed vertices plus the attached ones must remove
every rigid motion of every piece of the body (at least three non-collinear held vertices in each): a connected piece
of the surface for the surface methods, of the volume that carries the surface for the others (a cut may split the
surface where the volume still joins it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import BoundaryConditionError, SolverError, first_indices
from ..fem.rigid_modes import connected_pieces, free_rigid_modes
from .checks import finite_triple

if TYPE_CHECKING:
    from ..mesh.tetmesh import TetMesh


@dataclass(frozen=True)
class Attachment:
    """A ligament: springs from M_S vertices to a fixed point.

    Args:
        nodes: ``(k,)`` M_S vertex indices (integers ≥ 0, each once; the solver checks they are on its surface).
        stiffness: total stiffness k [N/m] (> 0), spread evenly over the nodes.
        anchor: ``(3,)`` [m] the point the nodes are pulled toward, or None (default): each node's own rest position.

    Raises:
        BoundaryConditionError: empty, repeated, negative or non-integer nodes, a stiffness that is not a positive
            finite number, or an anchor that is not 3 finite numbers.
    """

    nodes: np.ndarray
    stiffness: float
    anchor: np.ndarray | None = None

    def __post_init__(self):
        nodes = np.asarray(self.nodes)
        if nodes.ndim == 0:
            nodes = nodes.reshape(1)
        if nodes.ndim != 1 or nodes.size == 0 or nodes.dtype.kind not in "iu":
            raise BoundaryConditionError(f"an attachment's nodes are a non-empty 1-D list of integer M_S vertex "
                                         f"indices, got {np.asarray(self.nodes).dtype} of shape {nodes.shape}")
        if nodes.min() < 0 or np.unique(nodes).size != nodes.size:
            bad = np.flatnonzero(nodes < 0)
            why = (f"{bad.size} negative (first positions: {first_indices(bad)})" if bad.size
                   else "repeated")
            raise BoundaryConditionError(f"an attachment's nodes are {why}: give each M_S vertex index once")
        if isinstance(self.stiffness, (bool, np.bool_)) or not isinstance(self.stiffness, (int, float, np.number)) \
                or not np.isfinite(self.stiffness) or self.stiffness <= 0:
            raise BoundaryConditionError(f"an attachment's stiffness is its total spring constant, a positive "
                                         f"finite number [N/m], got {self.stiffness!r}")
        anchor = self.anchor
        if anchor is not None:
            anchor = finite_triple(anchor)
            if anchor is None:
                raise BoundaryConditionError(f"an attachment's anchor is a point (x, y, z) [m] of 3 finite numbers, "
                                             f"or None for the nodes' rest positions; got {self.anchor!r}")
        nodes = nodes.astype(np.int64)
        nodes.flags.writeable = False
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "stiffness", float(self.stiffness))
        object.__setattr__(self, "anchor", anchor)


def attachment_springs(attachments: Sequence[Attachment],
                       rest_positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The springs of ``attachments`` on a surface with rest positions ``(n, 3)`` [m]: ``(nodes (p,) int64,
    stiffness (p,) [N/m], anchors (p, 3) [m])``, one row per attached node of each attachment in turn.

    Raises:
        SolverError: ``attachments`` is not a sequence of :class:`Attachment`.
        BoundaryConditionError: a node lies outside the surface's vertices.
    """
    if isinstance(attachments, Attachment) or not isinstance(attachments, (tuple, list)) \
            or not all(isinstance(a, Attachment) for a in attachments):
        raise SolverError(f"attachments is a tuple of tissuesim Attachment(nodes, stiffness, anchor=None), got "
                          f"{attachments!r:.80}")
    n = len(rest_positions)
    nodes, stiffness, anchors = [], [], []
    for index, attachment in enumerate(attachments):
        bad = attachment.nodes[attachment.nodes >= n]
        if bad.size:
            raise BoundaryConditionError(f"attachment {index} names {bad.size} vertices outside the surface's "
                                         f"0..{n - 1} (first: {first_indices(bad)}); give M_S vertex indices")
        nodes.append(attachment.nodes)
        stiffness.append(np.full(attachment.nodes.size, attachment.stiffness / attachment.nodes.size))
        anchors.append(rest_positions[attachment.nodes] if attachment.anchor is None
                       else np.broadcast_to(attachment.anchor, (attachment.nodes.size, 3)))
    if not nodes:
        return np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, 3))
    return np.concatenate(nodes), np.concatenate(stiffness), np.array(np.concatenate(anchors))


def volume_pieces(volume: TetMesh, carriers: np.ndarray) -> np.ndarray:
    """``(n,) int`` the piece of ``volume`` (a :class:`~tissuesim.mesh.tetmesh.TetMesh`) that carries each M_S vertex,
    through ``carriers`` ``(n,) int``, one volume node per vertex (a node of its tet, or the vertex's own node)."""
    return connected_pieces(volume.tets, volume.node_count)[1][np.asarray(carriers, dtype=np.int64)]


def check_supports_hold(rest_positions: np.ndarray, pieces: np.ndarray, fixed: np.ndarray, attached: np.ndarray,
                        method: str) -> None:
    """Refuse (BoundaryConditionError, saying why and what to do) supports that leave some piece of the body free to
    move rigidly: ``pieces`` ``(n,) int`` labels each M_S vertex with its piece (the surface's connected pieces, or
    the volume's that carries it), and the ``fixed`` and ``attached`` vertices (M_S indices) of each piece must hold
    at least three points of it that are not on one line. ``method`` names the solver in the message."""
    pieces = np.asarray(pieces)
    held = np.zeros(len(rest_positions), dtype=bool)
    held[np.asarray(fixed, dtype=np.int64)] = True
    held[np.asarray(attached, dtype=np.int64)] = True
    labels = np.unique(pieces)
    for piece in labels:
        vertices = np.flatnonzero(pieces == piece)
        holding = vertices[held[vertices]]
        free = free_rigid_modes(rest_positions[vertices], rest_positions[holding])
        if not free:
            continue
        where = "the body" if labels.size == 1 else (f"a piece of the body ({vertices.size} surface vertices, first: "
                                                     f"{first_indices(vertices)})")
        if holding.size == 0:
            why = "no fixed vertex and no attachment holds it, so it falls or drifts freely"
        elif holding.size == 1:
            why = f"a single held vertex ({holding[0]}) leaves it free to turn about that point"
        else:
            why = (f"its {holding.size} held vertices (first: {first_indices(holding)}) lie on one line, leaving it "
                   "free to turn about that line")
        raise BoundaryConditionError(
            f"the supports do not hold {where} for the {method} method: {why} ({free} rigid motion(s) free); fix at "
            "least three vertices of it that are not on one line (fixed=, e.g. a region from tissuesim.mesh.regions)"
            ", or add attachments=(Attachment(nodes, stiffness),) that do")
