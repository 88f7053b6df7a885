"""Press a rigid probe into a block of tissue and slide it, headless (``tissuesim.Probe``).

The probe is displacement-driven: it is put where it is, and the tissue pushes back with whatever force holds it
out (frictionless unilateral contact on the surface's vertices). ``press_static`` finds that equilibrium; a
simulator moving the probe calls ``settle`` once a frame. Run: python examples/probe_press.py
"""

import argparse

import numpy as np

import tissuesim

RADIUS = 0.016  # m: the probe's sphere, larger than the surface's triangles (the probe refuses one that is not)


def make_block(*, youngs_modulus: float = 5500.0, resolution: int = 800):
    """The hybrid solver of an 80 mm cube of tissue (Young's modulus ``youngs_modulus`` [Pa], the paper's by
    default; ν = 0.3) resting on its bottom tenth, and the height [m] of its top face."""
    hybrid = tissuesim.HybridMesh.build(tissuesim.models.cube(resolution), fine_volume=False)
    solver = tissuesim.make_solver("hybrid", hybrid, youngs_modulus=youngs_modulus)
    return solver, float(solver.rest_positions[:, 2].max())


def press(depths, *, youngs_modulus: float = 5500.0, resolution: int = 800) -> dict:
    """Press the probe straight down on the top face's centre to each of ``depths`` ``(k,)`` [m] below the face,
    on a block of Young's modulus ``youngs_modulus`` [Pa].

    Returns a dict of ``(k, 3)`` arrays: the force on the probe [N] and the displacement [m] of the top vertex
    under it, at each depth; and the smallest gap [m] between the probe and any vertex (negative: inside), with
    the probe's contact tolerance [m].
    """
    solver, top = make_block(youngs_modulus=youngs_modulus, resolution=resolution)
    probe = tissuesim.Probe(solver, radius=RADIUS)
    under = int(np.argmin(np.linalg.norm(solver.rest_positions - [0.0, 0.0, top], axis=1)))
    forces, moved, gaps = [], [], []
    for depth in depths:
        probe.press_static([0.0, 0.0, top + RADIUS - depth])
        forces.append(probe.force)
        moved.append(solver.displacements[under].copy())
        gaps.append(probe.gaps().min())
    return {"force_N": np.array(forces), "top_displacement_m": np.array(moved), "smallest_gap_m": min(gaps),
            "tolerance_m": probe.tolerance}


def slide(*, depth: float = 0.004, travel: float = 0.02, frames: int = 10, resolution: int = 800) -> dict:
    """Press ``depth`` [m] into the top face, then slide the probe ``travel`` [m] along x over ``frames`` frames of
    one contact settle and one step each, as a simulator does.

    Returns a dict: the force on the probe [N] at the end of the slide, and the force of a static press straight
    down at the slide's end point on a fresh block [N] (frictionless contact: the two should agree).
    """
    solver, top = make_block(resolution=resolution)
    probe = tissuesim.Probe(solver, radius=RADIUS)
    start = np.array([0.0, 0.0, top + RADIUS - depth])
    probe.press_static(start)
    for frame in range(1, frames + 1):
        probe.settle(start + [travel * frame / frames, 0.0, 0.0])
        solver.step()
    fresh, _ = make_block(resolution=resolution)
    straight = tissuesim.Probe(fresh, radius=RADIUS)
    straight.press_static(start + [travel, 0.0, 0.0])
    return {"slid_force_N": probe.force, "pressed_force_N": straight.force}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args()
    depths = np.array([0.001, 0.002, 0.004])
    result = press(depths)
    for depth, force in zip(depths, result["force_N"]):
        print(f"{1e3 * depth:.0f} mm deep: the tissue pushes the probe with {force[2]:.3f} N upward")
    slid = slide()
    print(f"after sliding 20 mm: {np.round(slid['slid_force_N'], 4).tolist()} N; pressed straight down there: "
          f"{np.round(slid['pressed_force_N'], 4).tolist()} N")


if __name__ == "__main__":
    main()
