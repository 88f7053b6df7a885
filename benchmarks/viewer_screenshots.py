"""Screenshots of the simulator window driven by scripted pointer events (the window's own calls), for the docs and
for looking at what users see:

    python benchmarks/viewer_screenshots.py [--output docs/figures] [--model liver] [--only two-tools support]

* ``two-tools``: a pin-head pulls a fold up and is let go with the hold modifier, so it keeps holding; then the
  scalpel cuts beside it (``viewer_two_tools.png``);
* ``probe``: a rigid sphere pressed into the top and held there (``viewer_probe.png``);
* ``support``: the support brush paints a patch on one end (blue); a pull on the front then swings the model about
  it (``viewer_support.png``).

Draws in polyscope's offscreen EGL context (Mesa's software renderer where there is no GPU). Asserts nothing.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from tissuesim.viewer.app import ViewerApp
from tissuesim.viewer.controller import Controller
from tissuesim.viewer.settings import Settings

DOWN = np.array([0.0, 0.0, -1.0])
SIDE = np.array([0.0, 1.0, 0.0])
SETTLE_FRAMES = 60


def vertex_towards(controller, direction) -> np.ndarray:
    x = controller.solver.positions
    return x[np.argmax(x @ np.asarray(direction, dtype=float))].copy()


def surface_hit(controller, xy) -> np.ndarray:
    """Where a ray straight down through ``xy`` (2,) [m] meets the surface: the highest vertex near it."""
    x = controller.solver.positions
    near = np.linalg.norm(x[:, :2] - xy, axis=1)
    within = near <= max(2.0 * near.min(), 1e-9)
    return x[within][np.argmax(x[within, 2])].copy()


def frames(app, count: int) -> None:
    for _ in range(count):
        app.controller.advance(1.0 / 60.0)
        app.tick()


def pull(controller, point, offset, view=SIDE) -> None:
    """Grab at ``point`` and drag the cursor by ``offset`` [m] (in the plane facing ``view``, the camera's
    direction: a camera looking from the side drags up and down)."""
    view = np.asarray(view, dtype=float)
    controller.pointer_down(point, point - view, view)
    target = point + np.asarray(offset, dtype=float)
    controller.pointer_move(None, target - view, view)


def two_tools(app) -> None:
    c = app.controller
    size = c.solver.size
    fold = vertex_towards(c, [0.6, 0.0, 1.0])
    pull(c, fold, [0.0, 0.0, 0.1 * size])
    c.pointer_up(hold=True)
    frames(app, SETTLE_FRAMES)
    c.set_mode("scalpel")
    centre = fold[:2] - [0.15 * size, 0.0]
    line = [surface_hit(c, centre + [0.0, t]) for t in np.linspace(-0.12, 0.12, 24) * size]
    c.pointer_down(line[0], line[0] - DOWN, DOWN)
    for point in line[1:]:
        c.pointer_move(point, point - DOWN, DOWN)
        frames(app, 1)
    c.pointer_up()
    frames(app, SETTLE_FRAMES)


def support(app) -> None:
    c = app.controller
    c.set_mode("support")
    c.brush.radius = 0.08 * c.solver.size
    side = vertex_towards(c, [-1.0, 0.0, 0.3])
    c.pointer_down(side, side + [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    for dy, dz in np.array([[0, 0], [1, 0], [1, 1], [-1, 1], [-1, 0], [0, 0]]) * 0.08 * c.solver.size:
        point = side + [0.0, dy, dz]
        c.pointer_move(point, point + [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    c.pointer_up()
    frames(app, 2)
    c.set_mode("pin")
    pull(c, vertex_towards(c, [0.3, -1.0, 0.5]), [0.0, 0.0, -0.03 * c.solver.size])
    frames(app, SETTLE_FRAMES)


def probe(app) -> None:
    c = app.controller
    c.set_mode("probe")
    c.probe.radius = 0.06 * c.solver.size
    c.probe.depth = 0.5 * c.probe.radius
    top = vertex_towards(c, [0.2, 0.0, 1.0])
    c.pointer_down(top, top - DOWN, DOWN)
    frames(app, SETTLE_FRAMES)
    c.pointer_up(hold=True)
    frames(app, 2)


SCENARIOS = {"probe": (probe, "viewer_probe.png"), "two-tools": (two_tools, "viewer_two_tools.png"), "support": (support, "viewer_support.png")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=Path("docs/figures"))
    parser.add_argument("--model", default="liver")
    parser.add_argument("--only", nargs="*", default=list(SCENARIOS), choices=list(SCENARIOS))
    args = parser.parse_args()
    from tissuesim.commands.view import load_hybrid

    hybrid, name = load_hybrid(args.model, progress=False)
    args.output.mkdir(parents=True, exist_ok=True)
    for scenario in args.only:
        script, filename = SCENARIOS[scenario]
        controller = Controller(hybrid, settings=Settings())
        app = ViewerApp(controller, title=f"{name}: {scenario}", headless=True)
        frames(app, 3)
        script(app)
        app.ps.screenshot(str(args.output / filename), transparent_bg=False, include_UI=True)
        print(f"{scenario}: {args.output / filename}; notice: {controller.notice or '-'}")
        app.close()


if __name__ == "__main__":
    main()
