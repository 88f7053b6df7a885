"""Cut the liver with the scalpel, headless: the incision of §7 driven as a simulator drives it (§8.4).

Press the blade on the surface, move it along a stroke (each move cuts at once, so the wound grows under the tool),
step the solver between moves as a frame would, lift it. Run: python examples/scalpel_cut.py [--length L]
"""

import argparse

import numpy as np

import tissuesim
from tissuesim.mesh.validate import component_labels
from tissuesim.recording import border_edges


def cut_liver(*, length: float = 0.04, moves: int = 8, depth: float = 0.01, resolution: int | None = None):
    """Cut a straight stroke of ``length`` [m] across the liver's top in ``moves`` moves, a blade ``depth`` [m]
    long, one 10 ms step after each move.

    Returns the hybrid solver (its surface is the cut one) and a dict: the vertices the cut added, the cut's open
    edges (the wound's lips), the surface's connected pieces after the cut, and the cut's wall time [s] summed over
    the moves.
    """
    surface = tissuesim.models.liver(resolution) if resolution else tissuesim.models.liver()
    solver = tissuesim.make_solver("hybrid", tissuesim.HybridMesh.build(surface, fine_volume=False))
    scalpel = tissuesim.Scalpel(solver, depth=depth)
    top = surface.vertices[np.argmax(surface.vertices[:, 2])]
    stroke = top + np.outer(np.linspace(-0.5, 0.5, moves + 1) * length, [0.0, 1.0, 0.0])
    added, seconds = 0, 0.0
    scalpel.press(stroke[0])                           # the blade along the inward normal there
    for point in stroke[1:]:
        report = scalpel.move(point)                   # cuts what the blade swept since the last move
        added, seconds = added + report.vertices_added, seconds + report.seconds
        solver.step()
    scalpel.release()
    cut = solver.hybrid.surface                        # a new surface: the cut appended vertices
    return solver, {"vertices_added": added, "grown_by": cut.vertex_count - surface.vertex_count,
                    "cut_edges": len(border_edges(cut.triangles)), "pieces": component_labels(cut)[0],
                    "seconds": seconds}


def lip_pairs(solver) -> np.ndarray:
    """``(p, 2) int64`` the wound's vertex pairs: two vertices on the cut's open edges at the same rest position
    (a vertex the cut duplicated, one copy on each lip)."""
    lips = np.unique(border_edges(solver.hybrid.surface.triangles))
    rest = solver.rest_positions[lips]
    close = np.linalg.norm(rest[:, None] - rest[None], axis=2) < 1e-9 * solver.size
    first, second = np.nonzero(np.triu(close, k=1))
    return np.column_stack([lips[first], lips[second]])


def open_wound(solver, *, pull: float = 0.005, stiffness: float = 50.0) -> dict:
    """Solve for equilibrium under no load, then grab the lip vertex nearest the wound's middle and pull it
    ``pull`` [m] away from the cut (along x, across the stroke) with a pin-head of ``stiffness`` [N/m].

    Returns a dict: the largest displacement [m] of the unloaded cut body, and the largest gap [m] between the two
    copies of a cut vertex, unloaded and pulled.
    """
    pairs = lip_pairs(solver)
    solver.solve_static()                              # no load acts: the cut body must rest where it was
    unloaded = {"rest_motion_m": float(np.abs(solver.displacements).max()), "gap_unloaded_m": _gap(solver, pairs)}
    middle = solver.rest_positions[pairs].reshape(-1, 3).mean(axis=0)
    lip = pairs.ravel()[np.argmin(np.linalg.norm(solver.rest_positions[pairs.ravel()] - middle, axis=1))]
    pin = tissuesim.PinHead(solver, stiffness=stiffness)
    x0 = solver.positions[lip].copy()
    pin.grab(x0)
    side = _side(solver, lip, middle)
    pin.drag(x0 + [side * pull, 0.0, 0.0])
    solver.solve_static()
    return {**unloaded, "gap_pulled_m": _gap(solver, pairs), "pulled_node": int(lip)}


def _side(solver, vertex: int, middle: np.ndarray) -> float:
    """+1 or -1: the side of the cut (along x) where ``vertex``'s triangles lie at rest; both copies of a cut vertex
    sit on the cut, so their triangles say which lip each belongs to."""
    triangles = solver.hybrid.surface.triangles
    around = solver.rest_positions[triangles[np.any(triangles == vertex, axis=1)]].mean(axis=(0, 1))
    return 1.0 if around[0] >= middle[0] else -1.0


def _gap(solver, pairs: np.ndarray) -> float:
    x = solver.positions
    return float(np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1).max()) if len(pairs) else 0.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--length", type=float, default=0.04, help="the stroke's length [m]")
    args = parser.parse_args()
    solver, result = cut_liver(length=args.length)
    print(f"the cut added {result['vertices_added']} vertices and {result['cut_edges']} open edges in "
          f"{1e3 * result['seconds']:.0f} ms; the surface is {result['pieces']} piece(s)")
    wound = open_wound(solver)
    print(f"unloaded, the body moved {wound['rest_motion_m']:.2g} m; pulled across the cut, the wound opened "
          f"{1e3 * wound['gap_pulled_m']:.2f} mm")


if __name__ == "__main__":
    main()
