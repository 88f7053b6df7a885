"""The wound of the paper's Fig 16: a scripted incision across a model's top, a small force beside it, the gap.

* :func:`scripted_incision`: the scalpel pressed above the top, moved in a straight line along x over ``length``
  [m] in ``moves`` moves (progressive: each move cuts), blade straight down;
* :func:`wound_gap`: the widest opening [m]: the largest current distance between two vertices that share a rest
  position (the two sides of the cut; both copies start at the same point);
* :func:`open_wound`: pull a node beside the middle of the cut away from it and solve to equilibrium;
* :func:`unloaded_openings`: the openings at equilibrium with no force (non-zero only with a prestrained surface);
* :func:`lip_deviation`: how far the wound's lips (the new boundary's vertices, at rest) lie from the blade's trace,
  in mean edge lengths, and the smallest triangle quality of the cut surface: a straight stroke should leave a
  straight wound.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from ..cutting.core import DEFAULT_SNAP
from ..mesh.coincident import coincident_pairs
from ..tools.scalpel import Scalpel

if TYPE_CHECKING:
    from ..solvers.base import Solver

#: The incision of the experiment: 3 cm long, in 15 moves of 2 mm.
INCISION_LENGTH = 0.03
INCISION_MOVES = 15
#: Blade length [m] of the experiment and the tool's height above the top [m].
INCISION_DEPTH = 0.01
TOOL_HEIGHT = 0.001
#: The pulling force of the experiment [N] and its distance beside the cut [m].
PULL_FORCE = 0.1
PULL_OFFSET = 0.005
#: Steps allowed for the wound to settle (30 s of simulated time at 10 ms).
OPEN_MAX_STEPS = 3000


def incision_line(rest: np.ndarray, *, length: float = INCISION_LENGTH,
                  angle: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Tool start and end ``(3,)`` [m]: along x turned by ``angle`` [degrees] about z, centred over the model's
    vertical axis, just above its top."""
    centre = 0.5 * (rest.min(axis=0) + rest.max(axis=0))
    from_axis = np.linalg.norm(rest[:, :2] - centre[:2], axis=1)
    near_axis = from_axis <= max(0.25 * length, from_axis.min())  # a coarse mesh may have no node that close
    height = rest[near_axis, 2].max() + TOOL_HEIGHT
    # a small offset in y keeps the line off the procedural meshes' symmetry planes (off their edges)
    along = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle)), 0.0])
    across = np.array([-along[1], along[0], 0.0])
    start = np.array([centre[0], centre[1], height]) - 0.5 * length * along + 1.1e-3 * across
    return start, start + length * along


def scripted_incision(solver: Solver, *, length: float = INCISION_LENGTH, moves: int = INCISION_MOVES,
                      depth: float = INCISION_DEPTH, snap: float = DEFAULT_SNAP, angle: float = 0.0) -> dict:
    """Cut the top of ``solver``'s model along :func:`incision_line` (turned by ``angle`` [degrees]);
    ``{"moves": [CutReport...], "seconds": total, "line": (start, end)}``."""
    start, end = incision_line(solver.rest_positions, length=length, angle=angle)
    scalpel = Scalpel(solver, depth=depth, snap=snap)
    clock = time.perf_counter()
    reports = [scalpel.press(start, direction=[0.0, 0.0, -1.0])]
    for f in np.linspace(0.0, 1.0, moves + 1)[1:]:
        reports.append(scalpel.move(start + f * (end - start)))
    reports.append(scalpel.release())
    return {"moves": reports, "seconds": time.perf_counter() - clock, "line": (start, end)}


def wound_openings(solver: Solver) -> np.ndarray:
    """``(p,) float64`` the current distance [m] between the two sides at each vertex pair of the wound."""
    pairs = coincident_pairs(solver.rest_positions)     # the two sides of the cut start at one point
    x = solver.positions
    return np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)


def wound_gap(solver: Solver) -> float:
    """The widest opening of the wound [m] at the current positions (0 if uncut)."""
    openings = wound_openings(solver)
    return float(openings.max()) if openings.size else 0.0


def pull_node(rest: np.ndarray, line: tuple[np.ndarray, np.ndarray], *, offset: float = PULL_OFFSET) -> int:
    """The surface vertex nearest the point ``offset`` [m] beside the middle of the incision ``line`` (+y)."""
    start, end = line
    target = 0.5 * (start + end) + [0.0, offset, 0.0]
    top = rest[:, 2] > target[2] - 0.02
    candidates = np.flatnonzero(top)
    return int(candidates[np.argmin(np.linalg.norm(rest[candidates] - target, axis=1))])


def open_wound(solver: Solver, line: tuple[np.ndarray, np.ndarray], *, force: float = PULL_FORCE,
               offset: float = PULL_OFFSET, max_steps: int = OPEN_MAX_STEPS) -> dict:
    """Pull the node beside the cut away from it (+y) by ``force`` [N] toward equilibrium.

    Returns ``{"node", "gap" [m], "steps", "settled"}``; a solve that does not settle within ``max_steps`` is
    reported (``settled`` False, the gap where it stopped), not raised.
    """
    node = pull_node(solver.rest_positions, line, offset=offset)
    solver.solve_static(node, [0.0, force, 0.0], max_steps=max_steps, keep_unsettled=True)
    return {"node": node, "gap": wound_gap(solver), "steps": solver.last_solve.steps,
            "settled": bool(solver.last_solve.converged)}


def unloaded_openings(solver: Solver, line: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``(p,) float64`` the wound's openings [m] (:func:`wound_openings`) at equilibrium with no force: a
    prestrained capsule retracting (:mod:`tissuesim.layer.prestress`); zeros without a prestrain."""
    solver.solve_static(pull_node(solver.rest_positions, line), [0.0, 0.0, 0.0], max_steps=OPEN_MAX_STEPS)
    return wound_openings(solver)


def lip_deviation(rest: np.ndarray, triangles: np.ndarray, line: tuple[np.ndarray, np.ndarray], *,
                  depth: float = INCISION_DEPTH, edge: float, before: np.ndarray | None = None) -> dict:
    """How far the lips of a straight stroke's wound lie from the blade's trace, at rest.

    The trace is the rectangle the blade swept: from the tool's ``line`` (start, end ``(3,)`` [m]) down ``depth``
    [m] along −z. The lips are the vertices of the cut surface's border edges (``before``: ``(b,) int`` border
    vertices of the uncut surface, left out). A lip's deviation is its distance to that rectangle [m].

    Args:
        rest: ``(n, 3) float64`` rest positions [m] of the cut surface; triangles: ``(m, 3) int``.
        edge: the uncut surface's mean rest edge length [m]: the deviations are returned in units of it.

    Returns:
        ``{"rms", "max"}`` (fractions of ``edge``), ``"lips"`` (count), ``"reach"`` (the wound's extent along the
        stroke, a fraction of its length), ``"quality"`` (smallest triangle quality 4√3 A / Σ l² of the cut
        surface at rest).
    """
    from ..cutting.invariants import triangle_qualities

    tri = np.asarray(triangles, dtype=np.int64)
    directed = np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(directed, axis=0, return_counts=True)
    lips = np.unique(edges[counts == 1])
    if before is not None:
        lips = np.setdiff1d(lips, before)
    start, end = (np.asarray(p, dtype=np.float64) for p in line)
    u, v = end - start, np.array([0.0, 0.0, -depth])
    st = np.clip(np.stack([(rest[lips] - start) @ u / (u @ u), (rest[lips] - start) @ v / (v @ v)], axis=1), 0, 1)
    distance = np.linalg.norm(rest[lips] - (start + st[:, :1] * u + st[:, 1:] * v), axis=1) / edge
    return {"rms": float(np.sqrt(np.mean(distance ** 2))) if lips.size else 0.0,
            "max": float(distance.max()) if lips.size else 0.0, "lips": int(lips.size),
            "reach": float(np.ptp(st[:, 0])) if lips.size else 0.0,
            "quality": float(triangle_qualities(rest, tri).min())}
