"""Drag a liver with the pin-head, headless: the interaction loop of the paper's §8.2 without a viewer.

A simulator calls the same four things from its mouse or haptic callback: grab (button down), drag (cursor move),
step (each frame), release (button up). Run: python examples/pinhead_drag.py [--frames N]
"""

import argparse

import numpy as np

import tissuesim


def drag_liver(*, frames: int = 60, lift: float = 0.01, stiffness: float = 50.0, resolution: int | None = None):
    """Grab the liver's top, pull the cursor up by ``lift`` [m] over ``frames`` frames of 10 ms, hold, release.

    Returns a dict of what a user would look at: the grabbed node, the largest force [N], and the node's lift [m]
    while held and after release.
    """
    surface = tissuesim.models.liver(resolution) if resolution else tissuesim.models.liver()
    hybrid = tissuesim.HybridMesh.build(surface, fine_volume=False)
    solver = tissuesim.make_solver("hybrid", hybrid)
    pin = tissuesim.PinHead(solver, stiffness=stiffness)

    top = surface.vertices[np.argmax(surface.vertices[:, 2])]
    node = pin.grab(top + [0.0, 0.0, 0.001])          # a millimetre above the surface: snaps to the nearest node
    rest_height = solver.positions[node, 2]
    largest = 0.0
    for frame in range(1, frames + 1):                 # the cursor rises, then holds
        cursor = top + [0.0, 0.0, 0.001 + lift * min(1.0, 2.0 * frame / frames)]
        largest = max(largest, float(np.linalg.norm(pin.drag(cursor))))
        solver.step()
    held = solver.positions[node, 2] - rest_height
    pin.release()
    for _ in range(frames):
        solver.step()
    return {"node": node, "force_N": largest, "held_lift_m": held,
            "released_lift_m": solver.positions[node, 2] - rest_height}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    args = parser.parse_args()
    result = drag_liver(frames=args.frames)
    print(f"grabbed node {result['node']}; pulled with up to {result['force_N']:.2f} N: it rose "
          f"{1e3 * result['held_lift_m']:.2f} mm, and {1e3 * result['released_lift_m']:.4f} mm after release")


if __name__ == "__main__":
    main()
