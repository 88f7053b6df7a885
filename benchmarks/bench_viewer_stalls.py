"""Longest frame of the viewer while a user drags, cuts and drags again, on spheres from ``models.sphere(n)``; the
target of issue 20 is no frame over 50 ms.

    python benchmarks/bench_viewer_stalls.py [--sizes 10000 100000] [--quick] [--no-draw]

OMP_NUM_THREADS=1 is the default here (set it to 2 to see what two cores give). Drives the real window layer
(:class:`tissuesim.viewer.app.ViewerApp`) in polyscope's offscreen EGL context (on a machine without GPU, Mesa's
software renderer), or the :class:`~tissuesim.viewer.controller.Controller` alone with ``--no-draw`` or where that
context cannot start (the output says so), with the default hybrid and the pin-head on a 4 mm patch, through a
scripted session paced at 60 frames/s like a window with vsync (a frame that ends early sleeps out its 1/60 s):

1. start: the first frames (the mesh registered, shaders), then the model settles;
2. drag: grab a node 35° down the side, drag it 2 cm in the camera plane (the camera looks straight down), release;
3. cut: switch to the scalpel, and as many frames later as the model settled (the hand reaching the surface) press
   over the top and cut a 3 cm incision, the cursor moving 1.5 edge lengths per frame, release, then frames with no
   event;
4. drag again: the same on a node never grabbed, on the other side.

A frame's wall time is the pointer event plus ``ViewerApp.tick`` (the controller's steps, the upload of the new
positions, the panel, the render). Per phase: median, p95 and the longest frame, with its event and where its time
went; then the frames over 50 ms by phase and event. The 100k sphere takes about 20 s to build, so it runs only when
asked. Asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from bench_interactive import GRAB_POLAR, RADIUS, surface_node
from tissuesim import HybridMesh
from tissuesim.experiments.wound import incision_line
from tissuesim.mesh import models
from tissuesim.viewer.app import WINDOW_SIZE, ViewerApp
from tissuesim.viewer.controller import Controller
from tissuesim.viewer.gl import NoOpenGLError, polyscope

FRAME = 1.0 / 60.0      # the window's frame period [s]
TARGET = 0.05           # the longest frame allowed [s]
DOWN = np.array([0.0, 0.0, -1.0])   # the camera's view direction
DRAG = 0.02             # [m]
INCISION = 0.03         # [m]
EDGES_PER_MOVE = 1.5    # the cursor's travel per frame while cutting, in mean edge lengths
INTERACTION = ("drag", "cut", "drag again")


class Session:
    """Scripted frames over ``controller`` (and ``app``, or None: the controller alone); ``frames`` holds one dict per
    frame: phase, event, steps run, the mean step [s], and seconds of the event, of the callback (steps, upload,
    panel), of the render and of the whole frame."""

    def __init__(self, controller: Controller, app: ViewerApp | None):
        self.controller, self.app, self.frames, self.notices = controller, app, [], []
        self._last = None

    def frame(self, phase: str, event: str, action=None) -> None:
        start = time.perf_counter()
        if action is not None:
            action()
        handled = time.perf_counter()
        if self.app is not None:
            self.app.tick()
            stats, callback = self.app.stats, self.app.callback_seconds
        else:  # the window's callback hands the controller the wall time since the last frame
            stats = self.controller.advance(0.0 if self._last is None else start - self._last)
            callback = time.perf_counter() - handled
        self._last, end = start, time.perf_counter()
        self.frames.append({"phase": phase, "event": event, "steps": stats.steps, "step_s": stats.step_seconds,
                            "event_s": handled - start, "callback_s": callback,
                            "render_s": None if self.app is None else end - handled - callback, "s": end - start})
        if self.controller.notice and self.controller.notice not in self.notices:
            self.notices.append(self.controller.notice)
        time.sleep(max(FRAME - (end - start), 0.0))

    def idle(self, phase: str, count: int, event: str = "no event") -> None:
        for _ in range(count):
            self.frame(phase, event)

    def drag(self, phase: str, node: int, frames: int) -> None:
        """Grab ``node``, drag it DRAG along x over ``frames`` frames, release."""
        c = self.controller
        hit = c.solver.positions[node].copy()
        self.frame(phase, "grab", lambda: c.pointer_down(hit, hit - DOWN, DOWN))
        for i in range(1, frames + 1):
            cursor = hit + [DRAG * i / frames, 0.0, 0.0]
            self.frame(phase, "first drag move" if i == 1 else "drag move",
                       lambda: c.pointer_move(None, cursor - DOWN, DOWN))
        self.frame(phase, "release", c.pointer_up)

    def cut(self, phase: str, pause: int) -> dict:
        """Take the scalpel, ``pause`` frames later cut INCISION over the top in moves of EDGES_PER_MOVE edge lengths;
        the moves and triangles split."""
        c = self.controller
        rest = c.solver.rest_positions
        start, end = incision_line(rest, length=INCISION)
        moves = int(np.ceil(INCISION / (EDGES_PER_MOVE * c.solver.hybrid.surface.mean_edge_length)))
        points = [on_sphere(rest, start + f * (end - start)) for f in np.linspace(0.0, 1.0, moves + 1)]
        self.frame(phase, "scalpel mode", lambda: c.set_mode("scalpel"))
        self.idle(phase, pause, "scalpel taken")  # the hand moves the cursor to the surface
        self.frame(phase, "press", lambda: c.pointer_down(points[0], points[0] - DOWN, DOWN))
        split = 0
        for i, point in enumerate(points[1:]):
            before = c.last_cut
            self.frame(phase, "first cut move" if i == 0 else "cut move",
                       lambda: c.pointer_move(point, point - DOWN, DOWN))
            split += c.last_cut.triangles_split if c.last_cut is not before else 0  # a refused move reports nothing
        self.frame(phase, "release", c.pointer_up)
        return {"moves": moves, "split": split}


def on_sphere(rest: np.ndarray, point: np.ndarray) -> np.ndarray:
    """``point`` moved radially onto the sphere of ``rest`` ``(n, 3)`` [m]: the surface point the cursor picks."""
    centre = 0.5 * (rest.min(axis=0) + rest.max(axis=0))
    return centre + 0.5 * np.ptp(rest[:, 2]) * (point - centre) / np.linalg.norm(point - centre)


def run(size: int, args, drawing: bool) -> tuple[Session, dict]:
    """The scripted session on a sphere of ``size`` vertices, drawn or not; (the session, what the cut did)."""
    hybrid = HybridMesh.build(models.sphere(size), fine_volume=False)
    controller = Controller(hybrid)
    controller.configure(radius=RADIUS)
    app = ViewerApp(controller, headless=True) if drawing else None
    if app is not None:
        app.ps.set_window_size(*WINDOW_SIZE)
    rest = controller.solver.rest_positions
    session = Session(controller, app)
    session.idle("start", args.settle)
    session.drag("drag", surface_node(rest, GRAB_POLAR, -np.pi / 2), args.drag_frames)
    session.idle("drag", args.settle, "after release")
    cut = session.cut("cut", args.settle)
    session.idle("cut", args.settle, "after the cut")
    session.frame("drag again", "pin-head mode", lambda: controller.set_mode("pin"))
    session.drag("drag again", surface_node(rest, GRAB_POLAR, np.pi / 2), args.drag_frames)
    session.idle("drag again", args.settle, "after release")
    if app is not None:
        app.ps.remove_all_structures()
    return session, cut


def describe(i: int, f: dict) -> str:
    """Frame ``i``: its event and where its time went [ms]."""
    render = "" if f["render_s"] is None else f", render {1e3 * f['render_s']:.1f}"
    return (f"#{i} {f['event']} {1e3 * f['s']:.1f} ms (pointer event {1e3 * f['event_s']:.1f}, callback "
            f"{1e3 * f['callback_s']:.1f} with {f['steps']} steps{render})")


def report(size: int, session: Session, cut: dict) -> dict:
    """Print the phases of ``session``; the median and longest frame [s] of the interaction phases, the frames over
    TARGET and all frames there."""
    frames = session.frames
    edge = 1e3 * session.controller.solver.hybrid.surface.mean_edge_length
    step = 1e3 * np.median([f["step_s"] for f in frames])
    print(f"\n## sphere of {size} vertices (mean edge {edge:.2f} mm, a step {step:.1f} ms): {len(frames)} frames, "
          f"the cut {cut['moves']} moves splitting {cut['split']} triangles")
    for phase in dict.fromkeys(f["phase"] for f in frames):
        index = [i for i, f in enumerate(frames) if f["phase"] == phase]
        ms = 1e3 * np.array([frames[i]["s"] for i in index])
        longest = index[int(np.argmax(ms))]
        print(f"  {phase:10} {len(index):4} frames  median {np.median(ms):6.1f}  p95 {np.percentile(ms, 95):6.1f}  "
              f"longest {describe(longest, frames[longest])}")
    slow = {}
    for i, f in enumerate(frames):
        if f["s"] > TARGET:
            slow.setdefault((f["phase"], f["event"]), []).append(i)
    print(f"  frames over {1e3 * TARGET:.0f} ms: {sum(map(len, slow.values()))} of {len(frames)}")
    for (phase, event), index in slow.items():
        longest = max(index, key=lambda i: frames[i]["s"])
        print(f"    {phase:10} {len(index):4} x {event:15} longest {describe(longest, frames[longest])}")
    for notice in session.notices:
        print(f"  notice: {notice}")
    seconds = np.array([f["s"] for f in frames if f["phase"] in INTERACTION])
    print(f"  longest frame while dragging and cutting: {1e3 * seconds.max():.1f} ms (target <= {1e3 * TARGET:.0f})")
    return {"median": np.median(seconds), "longest": seconds.max(), "over": int(np.sum(seconds > TARGET)),
            "frames": len(seconds)}


def start_renderer() -> tuple[bool, str]:
    """(whether polyscope's offscreen context runs, a line saying which renderer draws)."""
    try:
        ps = polyscope(headless=True)
    except NoOpenGLError as error:
        return False, f"none: the controller alone, nothing drawn, since the offscreen context failed ({error})"
    return True, (f"polyscope {ps.get_render_engine_backend_name()}, window {WINDOW_SIZE[0]}x{WINDOW_SIZE[1]}, "
                  f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10000],
                        help="sphere vertex counts (default 10000; 100000 takes about 20 s to build)")
    parser.add_argument("--quick", action="store_true", help="10000 only, drags of 30 frames, short pauses")
    parser.add_argument("--no-draw", action="store_true", help="the controller alone: the simulation's own stalls")
    args = parser.parse_args(argv)
    args.sizes = [10000] if args.quick else args.sizes
    args.drag_frames, args.settle = (30, 10) if args.quick else (60, 30)
    drawing, renderer = (False, "none: the controller alone (--no-draw)") if args.no_draw else start_renderer()
    print(f"renderer: {renderer}; OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}; hybrid, pin-head "
          f"{1e3 * RADIUS:.0f} mm patch; frames paced at {1 / FRAME:.0f} Hz")
    rows = {size: report(size, *run(size, args, drawing)) for size in args.sizes}
    print("\n| M_S vertices | while dragging and cutting: median frame ms | longest frame ms (target <= 50) "
          "| frames over 50 ms |\n|---:|---:|---:|---:|")
    for size, r in rows.items():
        print(f"| {size} | {1e3 * r['median']:.1f} | {1e3 * r['longest']:.1f} | {r['over']} of {r['frames']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
