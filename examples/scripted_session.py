"""A scripted simulator session, headless: drag the liver with the pin-head, cut it with the scalpel, record it all.

The same :class:`tissuesim.viewer.controller.Controller` that the window drives, fed with pointer events from a
script instead of a mouse (camera looking straight down), stepping 10 ms of simulated time per frame. Every frame
goes into a ParaView series (open ``session.pvd`` in ParaView, or ``tissuesim view --replay session.pvd``).
The cut needs ``tissuesim.Scalpel``; without it the session records the drag only and says so.

Run: python examples/scripted_session.py [--output session.pvd]
"""

import argparse

import numpy as np

import tissuesim
from tissuesim.recording import Recorder, border_edges, read_recording, solver_frame
from tissuesim.viewer.controller import Controller, Settings

DOWN = np.array([0.0, 0.0, -1.0])  # the camera looks straight down from CAMERA_HEIGHT above each point
CAMERA_HEIGHT = 0.5  # m
FRAME = 0.01  # s of wall time per frame: one step of the default dt


def _ray(point):
    return np.asarray(point) - CAMERA_HEIGHT * DOWN, DOWN


def run_session(path, *, frames: int = 30, pull: float = 0.02, resolution: int | None = None):
    """Drag the top of the liver sideways by ``pull`` [m] over ``frames`` frames, release, then cut across it.

    Returns a dict: the recording's path and frame count, the largest pin-head force [N], the grabbed node's
    sideways motion while held [m], whether a scalpel was there, and the cut edges and vertices the cut made.
    """
    surface = tissuesim.models.liver(resolution) if resolution else tissuesim.models.liver()
    hybrid = tissuesim.HybridMesh.build(surface, fine_volume=False)
    controller = Controller(hybrid, settings=Settings(stiffness=50.0))
    x = controller.solver.positions
    top = x[np.argmax(x[:, 2])].copy()
    largest, time = 0.0, 0.0
    with Recorder(path) as recorder:
        def frame():
            nonlocal time
            time += controller.advance(FRAME).steps * controller.settings.dt
            recorder.add(solver_frame(controller.solver, time))

        controller.pointer_down(top, *_ray(top))                       # button down on the top: grab
        node = controller.pin.node
        for i in range(1, frames + 1):                                 # drag sideways, in the camera plane
            controller.pointer_move(None, *_ray(top + [pull * i / frames, 0.0, 0.0]))
            largest = max(largest, controller.force_newtons)
            frame()
        moved = controller.solver.positions[node, 0] - hybrid.surface.vertices[node, 0]
        controller.pointer_up()                                        # release: the force goes
        for _ in range(frames):
            frame()
        if controller.scalpel_available:                               # a stroke across the top
            controller.set_mode("scalpel")
            stroke = top + np.outer(np.linspace(-0.03, 0.03, 10), [0.0, 1.0, 0.0])
            controller.pointer_down(stroke[0], *_ray(stroke[0]))
            for point in stroke[1:]:
                controller.pointer_move(None, *_ray(point))
                frame()
            controller.pointer_up()
            frame()
    surface = controller.solver.hybrid.surface
    return {"path": path, "frames": recorder.frame_count, "force_N": largest, "held_motion_m": moved,
            "scalpel": controller.scalpel_available, "cut_edges": len(border_edges(surface.triangles)),
            "vertices_added": surface.vertex_count - hybrid.surface.vertex_count}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="session.pvd")
    args = parser.parse_args()
    result = run_session(args.output)
    print(f"recorded {result['frames']} frames to {result['path']}: pulled with up to {result['force_N']:.2f} N, "
          f"the node moved {1e3 * result['held_motion_m']:.1f} mm")
    print(f"cut: {result['cut_edges']} cut edges, {result['vertices_added']} vertices added" if result["scalpel"]
          else "no tissuesim.Scalpel here: the cut was skipped")
    print(f"read back {len(read_recording(args.output))} frames")


if __name__ == "__main__":
    main()
