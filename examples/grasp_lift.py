"""Grasp the liver's top and lift it, headless (``tissuesim.Grasper``): the held tissue goes where the jaws go.

The jaws hold the surface within their reach and carry it as prescribed displacements; the force is the output, the
tissue's reaction on the jaws. ``move_to`` finds the equilibrium with the jaws held there; a simulator moving them
calls ``follow`` once a frame. Run: python examples/grasp_lift.py
"""

import argparse

import numpy as np

import tissuesim

REACH = 0.02  # m: the jaws hold the surface within 20 mm of where they close (the liver is 191 mm across)


def lift(heights, *, method: str = "hybrid", resolution: int = 800) -> dict:
    """Grasp the liver's highest point and lift it to each of ``heights`` ``(k,)`` [m] above where it was.

    Returns a dict of ``(k, 3)`` arrays: the force [N] the jaws pull with (minus the tissue's reaction on them), and
    how far [m] each lift left a held vertex from where the jaws put it (within the grasper's tolerance)."""
    hybrid = tissuesim.HybridMesh.build(tissuesim.models.liver(resolution), fine_volume=method == "fem")
    solver = tissuesim.make_solver(method, hybrid)
    top = hybrid.surface.vertices[np.argmax(hybrid.surface.vertices[:, 2])].copy()
    grasper = tissuesim.Grasper(solver, radius=REACH)
    grasper.grab(top)
    pulls, misses = [], []
    for height in heights:
        pulls.append(-grasper.move_to(top + [0.0, 0.0, height]))
        misses.append(np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max())
    return {"pull": np.array(pulls), "miss": np.array(misses), "held": grasper.held.size,
            "tolerance": grasper.tolerance}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="hybrid", choices=tissuesim.available_solvers())
    args = parser.parse_args()
    heights = np.array([0.002, 0.005, 0.01])
    result = lift(heights, method=args.method)
    print(f"the jaws hold {result['held']} vertices of the liver's top ({args.method})")
    for height, pull, miss in zip(heights, result["pull"], result["miss"]):
        print(f"  lifted {1e3 * height:4.1f} mm: the jaws pull {pull[2]:.3f} N up; a held vertex is at most "
              f"{1e6 * miss:.2f} µm from the jaws")


if __name__ == "__main__":
    main()
