"""Frame time of the simulator while it draws: simulation vs rendering, on the default models and a 10k surface.

Drives the real window layer (:class:`tissuesim.viewer.app.ViewerApp`) in polyscope's offscreen EGL context — on a
machine without GPU that is Mesa's software renderer (llvmpipe), the worst case — with a scripted pin-head drag,
for ``--seconds`` of wall time per model, the simulation at its real-time fixed dt (10 ms). Prints per model:

* step alone: one simulation step with nothing drawn [ms]; step: the same while drawing; draw: mean time polyscope spends rendering a frame [ms];
  frame: mean wall time per frame [ms] and frames/s;
* sim steps/s while drawing (target ≥ 100 = real time at dt = 10 ms) and the simulated time lost to slow frames;
* first grab: wall time of grabbing, first dragging and the first step under a node never loaded before (any
  per-node precomputation, e.g. the hybrid's K⁻¹ columns, happens here).

Asserts nothing about time.   python benchmarks/bench_viewer.py [--seconds 3] [--models cube liver] [--large 10000]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from tissuesim import HybridMesh
from tissuesim.experiments.protocol import load_node
from tissuesim.mesh import models
from tissuesim.viewer.app import WINDOW_SIZE, ViewerApp
from tissuesim.viewer.controller import Controller

DOWN = np.array([0.0, 0.0, -1.0])


def measure(name: str, surface, seconds: float, method: str, size) -> dict:
    hybrid = HybridMesh.build(surface, fine_volume=method == "fem")
    controller = Controller(hybrid)
    controller.configure(method=method)
    app = ViewerApp(controller, headless=True)
    app.ps.set_window_size(*size)
    top = controller.solver.positions[load_node(surface.vertices, surface.triangles)].copy()
    start = time.perf_counter()
    controller.pointer_down(top, top - DOWN, DOWN)
    controller.pointer_move(None, top - DOWN + [0.001, 0.0, 0.0], DOWN)
    controller.solver.step()  # the first step under a new node's load does any per-node precomputation
    first_grab = time.perf_counter() - start
    for _ in range(5):  # warm up: shaders, first uploads, Numba dispatch
        app.tick()
    start = time.perf_counter()
    for _ in range(20):
        controller.solver.step()
    alone = (time.perf_counter() - start) / 20
    steps = frames = 0
    draw = dropped = 0.0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        phase = 2.0 * np.pi * (time.perf_counter() - start)  # the cursor circles 1 cm around the grab point
        cursor = top + 0.01 * np.array([np.cos(phase), np.sin(phase), 0.0])
        controller.pointer_move(None, cursor - DOWN, DOWN)
        app.tick()
        steps += app.stats.steps
        dropped += app.stats.dropped
        frames += 1
        draw += app.render_seconds
    wall = time.perf_counter() - start
    controller.pointer_up()
    app.ps.remove_all_structures()
    return {"model": name, "vertices": surface.vertex_count, "alone_ms": 1e3 * alone,
            "step_ms": 1e3 * app.stats.step_seconds,
            "draw_ms": 1e3 * draw / max(frames - 1, 1), "frame_ms": 1e3 * wall / frames, "fps": frames / wall,
            "steps_per_s": steps / wall, "dropped_s": dropped, "first_grab_ms": 1e3 * first_grab}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--models", nargs="+", default=list(models.MODELS))
    parser.add_argument("--large", type=int, default=10000, help="vertices of the large sphere (0: skip)")
    parser.add_argument("--method", default="hybrid")
    parser.add_argument("--window", type=int, nargs=2, default=None, metavar=("W", "H"),
                        help="window size in pixels (default: the viewer's)")
    args = parser.parse_args()
    cases = [(name, models.model(name)) for name in args.models]
    if args.large:
        cases.append((f"sphere-{args.large}", models.sphere(args.large)))
    from tissuesim.viewer.gl import polyscope

    ps = polyscope(headless=True)
    size = args.window or WINDOW_SIZE
    print(f"renderer: {ps.get_render_engine_backend_name()}, window {size[0]}x{size[1]}, method {args.method}, "
          f"{args.seconds:g} s per model, LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')}")
    print("| model | M_S vertices | step alone ms | step ms | draw ms | frame ms | frames/s | sim steps/s | dropped s "
          "| first grab ms |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, surface in cases:
        r = measure(name, surface, args.seconds, args.method, size)
        print(f"| {r['model']} | {r['vertices']} | {r['alone_ms']:.2f} | {r['step_ms']:.2f} | {r['draw_ms']:.1f} | {r['frame_ms']:.1f} | "
              f"{r['fps']:.0f} | {r['steps_per_s']:.0f} | {r['dropped_s']:.2f} | {r['first_grab_ms']:.1f} |",
              flush=True)


if __name__ == "__main__":
    main()
