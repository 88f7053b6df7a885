"""Two tools at once, headless: two pin-heads pulling a block, and a pin-head holding the liver while the scalpel
cuts beside it.

Every tool holds a load of its own on the solver, beside the others'; ``solver.solve_static()`` with no arguments
finds the equilibrium under every load acting. Run: python examples/two_tools.py
"""

import argparse

import numpy as np

import tissuesim

STIFFNESS = 50.0  # N/m: each pin-head's spring (eq 24)


def _block(resolution: int):
    surface = tissuesim.models.cube(resolution)
    return tissuesim.make_solver("hybrid", tissuesim.HybridMesh.build(surface, fine_volume=False))


def two_pinheads(pull_a, pull_b, *, resolution: int = 800) -> dict:
    """Grab the cube's top face at a point A and pull the cursor by ``pull_a`` ``(3,)`` [m], solve for
    equilibrium; grab a second point B 40 mm away, pull by ``pull_b``, solve under both; release A, solve under B
    alone.

    Returns a dict: the forces of the two pin-heads [N], the ``(n, 3)`` displacements [m] under both, under A
    alone and under B alone, and the two grabbed nodes.
    """
    solver = _block(resolution)
    top = solver.rest_positions[:, 2].max()
    grab_a, grab_b = np.array([-0.02, 0.0, top]), np.array([0.02, 0.01, top])
    pin_a, pin_b = (tissuesim.PinHead(solver, stiffness=STIFFNESS) for _ in range(2))
    node_a = pin_a.grab(grab_a)
    force_a = pin_a.drag(grab_a + pull_a)
    alone_a = solver.solve_static() - solver.rest_positions
    node_b = pin_b.grab(grab_b)       # from where A left the surface: the node nearest the point there
    force_b = pin_b.drag(grab_b + pull_b)
    both = solver.solve_static() - solver.rest_positions           # every load acting: both pin-heads
    pin_a.release()
    alone_b = solver.solve_static() - solver.rest_positions
    return {"force_a_N": force_a, "force_b_N": force_b, "both_m": both, "a_m": alone_a, "b_m": alone_b,
            "nodes": (node_a, node_b)}


def hold_and_cut(*, pull: float = 0.01, length: float = 0.04, resolution: int | None = None) -> dict:
    """Grab the liver's top and pull the cursor ``pull`` [m] sideways (+x), hold it, and cut a stroke of ``length``
    [m] along y, 20 mm from the grabbed point on the other side (−x), a step after each move; then solve for
    equilibrium under the pin-head's load.

    Returns a dict: the grabbed node, the pin-head's force [N], the loads acting after the cut, the force on the
    grabbed node after the cut [N], the vertices the cut added, and the grabbed node's displacement [m] at
    equilibrium.
    """
    surface = tissuesim.models.liver(resolution) if resolution else tissuesim.models.liver()
    solver = tissuesim.make_solver("hybrid", tissuesim.HybridMesh.build(surface, fine_volume=False))
    top = surface.vertices[np.argmax(surface.vertices[:, 2])]
    pin = tissuesim.PinHead(solver, stiffness=STIFFNESS)
    node = pin.grab(top)
    force = pin.drag(top + [pull, 0.0, 0.0])
    scalpel = tissuesim.Scalpel(solver, depth=0.02)    # the top falls away from the grabbed point
    stroke = top + [-0.02, 0.0, 0.0] + np.outer(np.linspace(-0.5, 0.5, 9) * length, [0.0, 1.0, 0.0])
    scalpel.press(stroke[0])
    added = 0
    for point in stroke[1:]:
        added += scalpel.move(point).vertices_added
        solver.step()
    scalpel.release()
    solver.solve_static()
    return {"node": node, "force_N": force, "loads": len(solver.loads), "node_force_N": solver.forces[node].copy(),
            "vertices_added": added, "held_displacement_m": solver.displacements[node].copy()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args()
    result = two_pinheads([0.0, 0.0, 0.004], [0.003, 0.0, 0.002])
    error = np.abs(result["both_m"] - result["a_m"] - result["b_m"]).max()
    print(f"two pin-heads: {np.round(result['force_a_N'], 3).tolist()} N and "
          f"{np.round(result['force_b_N'], 3).tolist()} N; the answer under both is the sum of the answers under "
          f"each to {error:.1e} m")
    held = hold_and_cut()
    print(f"held node {held['node']} with {np.round(held['force_N'], 3).tolist()} N while the cut added "
          f"{held['vertices_added']} vertices; it rests {1e3 * held['held_displacement_m'][0]:.2f} mm along the pull")


if __name__ == "__main__":
    main()
