"""Screenshots of the simulator window driven by scripted pointer events (the window's own calls), for the docs and
for looking at what users see:

    python benchmarks/viewer_screenshots.py [--output docs/figures] [--model liver] [--only two-tools support]
        [--element quadratic] [--method pbd]

* ``grasp``: the grasper, the tool ``tissuesim view`` starts with, holding the top and lifting it by a tenth of the
  model's size: the held patch is where the jaws are, the force on them in the panel (``viewer_grasp.png``);
* ``window``: the whole window with the paper's pin-head pulling the top up, the displacement colours off
  (``viewer_window.png``);
* ``colours``: the same with the displacement colours switched on, their legend at the top left
  (``viewer_colours.png``);
* ``replay``: a recording of the ``wound`` session played back (``tissuesim view --replay``), its cut's edges in
  yellow, the wound's walls, the pin-head left holding and the colours on (``viewer_replay.png``);
* ``creases``: the cube at rest, smooth-shaded as polyscope does it (left: its edges drawn as a ragged band) and
  split along its creases as the simulator draws it (right) (``viewer_creases.png``);
* ``two-tools``: a pin-head pulls a fold up and is let go with the hold modifier, so it keeps holding; then the
  scalpel cuts beside it (``viewer_two_tools.png``);
* ``probe``: a rigid sphere pressed into the top and held there (``viewer_probe.png``);
* ``wound``: a straight stroke across the top, opened by a pin-head left holding beside it: its walls go down to the
  blade's depth (``viewer_wound.png``);
* ``support``: the support brush paints a patch on one end (blue); a pull on the front then swings the model about
  it (``viewer_support.png``);
* ``scene``: ``tissuesim view examples/liver_retraction.toml`` playing its script: the grasper pulls the right
  edge while the scalpel cuts across the top (``viewer_scene.png``).

Draws in polyscope's offscreen EGL context (Mesa's software renderer where there is no GPU). Asserts nothing.
"""

from __future__ import annotations

import argparse
from functools import partial
from pathlib import Path

import numpy as np

from tissuesim.tools.scalpel import Scalpel
from tissuesim.viewer.app import PANEL_WIDTH, ViewerApp
from tissuesim.viewer.controller import Controller
from tissuesim.viewer.gl import look_at_oblique
from tissuesim.viewer.settings import DRAG_FRACTION, Settings, sized_defaults

DOWN = np.array([0.0, 0.0, -1.0])
SIDE = np.array([0.0, 1.0, 0.0])
SETTLE_FRAMES = 60


def vertex_towards(controller, direction) -> np.ndarray:
    x = controller.solver.positions
    return x[np.argmax(x @ np.asarray(direction, dtype=float))].copy()


def surface_hit(controller, xy) -> np.ndarray:
    """Where a ray straight down through ``xy`` (2,) [m] first meets the current surface (the window's pick): the
    highest triangle whose projection on the xy plane holds ``xy``, by its barycentric coordinates there."""
    x = controller.solver.positions
    corners = x[controller.solver.hybrid.surface.triangles]              # (m, 3, 3)
    a, b, c = corners[:, 0, :2], corners[:, 1, :2], corners[:, 2, :2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        u = ((b[:, 0] - xy[0]) * (c[:, 1] - xy[1]) - (c[:, 0] - xy[0]) * (b[:, 1] - xy[1])) / area
        v = ((c[:, 0] - xy[0]) * (a[:, 1] - xy[1]) - (a[:, 0] - xy[0]) * (c[:, 1] - xy[1])) / area
    weights = np.stack([u, v, 1.0 - u - v], axis=1)
    inside = np.all(weights >= 0.0, axis=1) & np.isfinite(area) & (area != 0.0)
    points = np.einsum("mk,mkd->md", weights[inside], corners[inside])
    return points[np.argmax(points[:, 2])]


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
    fold = vertex_towards(c, [-0.6, 0.0, 1.0])
    pull(c, fold, [0.0, 0.0, DRAG_FRACTION * size])
    c.pointer_up(hold=True)
    frames(app, SETTLE_FRAMES)
    c.set_mode("scalpel")
    centre = fold[:2] + [0.15 * size, 0.0]
    line = [surface_hit(c, centre + [0.0, t]) for t in np.linspace(-0.12, 0.12, 24) * size]
    c.pointer_down(line[0], line[0] - DOWN, DOWN)
    for point in line[1:]:
        c.pointer_move(point, point - DOWN, DOWN)
        frames(app, 1)
    c.pointer_up()
    frames(app, SETTLE_FRAMES)
    near = np.linalg.norm(c.solver.positions - fold, axis=1) < 0.3 * size
    look_at_oblique(app.ps, c.solver.positions[near], elevation=40.0, azimuth=-80.0, distance=2.4, pane=PANEL_WIDTH)
    frames(app, 1)


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
    pull(c, vertex_towards(c, [0.3, -1.0, 0.5]), [0.0, 0.0, -0.01 * c.solver.size])
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


def wound(app) -> None:
    """A straight stroke across the top, then a pin-head left holding beside its middle pulls it open."""
    c = app.controller
    size = c.solver.size
    top = vertex_towards(c, [0.0, 0.0, 1.0])
    c.set_mode("scalpel")
    line = [surface_hit(c, top[:2] + [t, 0.0]) for t in np.linspace(-0.1, 0.1, 30) * size]
    c.pointer_down(line[0], line[0] - DOWN, DOWN)
    for point in line[1:]:
        c.pointer_move(point, point - DOWN, DOWN)
        frames(app, 1)
    c.pointer_up()
    c.set_mode("pin")
    beside = surface_hit(c, top[:2] + [0.0, -0.07 * size])      # the tip's patch (0.05 of the size) clear of the cut
    pull(c, beside, [0.0, -DRAG_FRACTION * size, 0.0], view=DOWN)
    c.pointer_up(hold=True)
    frames(app, SETTLE_FRAMES)
    near = np.linalg.norm(c.solver.positions - top, axis=1) < 0.15 * size
    look_at_oblique(app.ps, c.solver.positions[near], elevation=50.0, azimuth=-70.0, distance=2.0,
                    pane=PANEL_WIDTH)
    frames(app, 1)


def grasp(app) -> None:
    """The grasper holds the top and lifts it by the sized drag (a tenth of the model's size), and keeps holding."""
    c = app.controller
    c.set_mode("grasper")
    pull(c, vertex_towards(c, [0.2, -0.3, 1.0]), [0.0, 0.0, DRAG_FRACTION * c.solver.size])
    frames(app, SETTLE_FRAMES)


def window(app) -> None:
    """The pin-head pulls the top up by the sized drag (a tenth of the model's size) and keeps pulling."""
    c = app.controller
    pull(c, vertex_towards(c, [0.2, -0.3, 1.0]), [0.0, 0.0, DRAG_FRACTION * c.solver.size])
    frames(app, SETTLE_FRAMES)


def colours(app) -> None:
    app.show_colours = True
    window(app)


def replay(app, output: Path) -> Path:
    """Record the ``wound`` session, then play it back in a window of its own and return the image's path."""
    from tissuesim.recording import Recorder, read_recording, solver_frame
    from tissuesim.viewer.replay import ReplayApp

    recording = output / "viewer_replay_session.pvd"
    with Recorder(recording) as recorder:
        recorder.add(solver_frame(app.controller.solver, 0.0, tools=app.recorded_tools()))
        wound(app)
        recorder.add(solver_frame(app.controller.solver, app.sim_time, tools=app.recorded_tools()))
    app.close()
    played = ReplayApp(read_recording(recording), title=recording.name, headless=True)
    played.show_colours = True
    played.index, played.playing = 1, False
    for _ in range(2):
        played.ps.set_user_callback(played.frame)
        played.ps.frame_tick()
    image = output / "viewer_replay.png"
    played.ps.screenshot(str(image), transparent_bg=False, include_UI=True)
    played.close()
    for path in [recording, *sorted(recording.with_name(recording.stem + "_frames").glob("*"))]:
        path.unlink()
    recording.with_name(recording.stem + "_frames").rmdir()
    return image


def scene(output: Path) -> Path:
    """``tissuesim view examples/liver_retraction.toml`` as it plays: the scripted grasper pulls the right edge,
    the scalpel has cut across the top (0.3 s of the script); returns the image's path."""
    from tissuesim.commands.view import SETTINGS_FIELDS, scene_hybrid
    from tissuesim.scene import read_scene, solver_options
    from tissuesim.viewer.playback import ScenePlayback

    loaded = read_scene(Path(__file__).resolve().parents[1] / "examples" / "liver_retraction.toml")
    hybrid, _ = scene_hybrid(loaded, progress=False)
    options = solver_options(loaded, hybrid)
    settings = Settings(method=loaded.scene.method.name, dt=loaded.scene.run.dt,
                        **{key: options[key] for key in SETTINGS_FIELDS if key in options and key != "dt"})
    controller = Controller(hybrid, settings=settings, playback=ScenePlayback(loaded),
                            solver_options={key: value for key, value in options.items()
                                            if key not in SETTINGS_FIELDS})
    app = ViewerApp(controller, title=loaded.scene.title, headless=True)
    while controller.playback.time < 0.3:
        controller.advance(controller.settings.dt)
        app.tick()
    frames(app, 3)
    image = output / "viewer_scene.png"
    app.ps.screenshot(str(image), transparent_bg=False, include_UI=True)
    app.close()
    return image


def creases(output: Path) -> Path:
    """The cube at rest, shaded smooth over every vertex and then split along its creases, side by side."""
    from PIL import Image

    from tissuesim.commands.view import load_hybrid
    from tissuesim.viewer.app import style_window
    from tissuesim.viewer.gl import polyscope
    from tissuesim.viewer.look import TISSUE_COLOR, TISSUE_MATERIAL, TissueSurface

    surface = load_hybrid("cube", progress=False)[0].surface
    x, triangles = surface.vertices, surface.triangles
    ps = polyscope(headless=True)
    style_window(ps)
    ps.set_window_size(640, 560)
    images = []
    for split in (False, True):
        ps.remove_all_structures()
        if split:
            TissueSurface(ps, x, triangles, x)
        else:
            ps.register_surface_mesh("plain", x, triangles, smooth_shade=True, color=TISSUE_COLOR,
                                     material=TISSUE_MATERIAL)
        look_at_oblique(ps, x, elevation=25.0, azimuth=-50.0, distance=3.0)
        images.append(ps.screenshot_to_buffer(transparent_bg=False)[:, :, :3])
    ps.remove_all_structures()
    image = output / "viewer_creases.png"
    Image.fromarray(np.concatenate(images, axis=1)).save(image)
    return image


SCENARIOS = {"grasp": (grasp, "viewer_grasp.png"), "window": (window, "viewer_window.png"), "colours": (colours, "viewer_colours.png"),
             "probe": (probe, "viewer_probe.png"), "wound": (wound, "viewer_wound.png"),
             "two-tools": (two_tools, "viewer_two_tools.png"), "support": (support, "viewer_support.png"),
             "replay": (None, "viewer_replay.png"), "creases": (None, "viewer_creases.png"),
             "scene": (None, "viewer_scene.png")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=Path("docs/figures"))
    parser.add_argument("--model", default="liver")
    parser.add_argument("--only", nargs="*", default=list(SCENARIOS), choices=list(SCENARIOS))
    parser.add_argument("--element", default="linear", help="the hybrid's M_V elements (linear or quadratic)")
    parser.add_argument("--method", default="hybrid", help="the method at start (default hybrid)")
    args = parser.parse_args()
    from tissuesim.commands.view import load_hybrid

    hybrid, name = load_hybrid(args.model, progress=False)
    args.output.mkdir(parents=True, exist_ok=True)
    for scenario in args.only:
        script, filename = SCENARIOS[scenario]
        # the tools sized as tissuesim view sizes them
        sized = sized_defaults(hybrid.surface.vertices, edge_length=hybrid.surface.mean_edge_length)
        controller = Controller(hybrid, settings=Settings(method=args.method, stiffness=sized.stiffness,
                                                          radius=sized.radius, element=args.element),
                                scalpel_factory=partial(Scalpel, depth=sized.depth))
        app = ViewerApp(controller, title=f"{name}: {scenario}", headless=True)
        frames(app, 3)
        if scenario == "replay":
            print(f"replay: {replay(app, args.output)}")
            continue
        if scenario in ("creases", "scene"):
            app.close()
            print(f"{scenario}: {(creases if scenario == 'creases' else scene)(args.output)}")
            continue
        script(app)
        app.ps.screenshot(str(args.output / filename), transparent_bg=False, include_UI=True)
        print(f"{scenario}: {args.output / filename}; notice: {controller.notice or '-'}")
        app.close()


if __name__ == "__main__":
    main()
