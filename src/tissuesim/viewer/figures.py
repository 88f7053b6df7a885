"""The paper's figures, drawn offscreen: Fig 11 (deformation) and Fig 16 (incision), one PNG per model.

Each panel is a polyscope render (EGL, no display needed) of M_S with its displacement magnitude colour-mapped;
matplotlib puts the panels side by side under a title naming the model, the load and the method, with one colour
bar [mm] shared by the panels, so colours compare across them.

* ``deformation_<model>.png`` (Fig 11): at rest, under tension and under pressure, at the experiment's load node
  (:func:`tissuesim.experiments.protocol.load_node`) and a force of :data:`FIGURE_FORCE` [N], solved quasi-statically.
* ``incision_<model>.png`` (Fig 16): the scripted incision of :mod:`tissuesim.experiments.wound` (a straight stroke
  across the top), closed, then opened by :data:`OPENING_FORCE` [N] sideways beside the cut's middle (that
  module's pull), seen close up, the cut edges drawn red and the wound's walls down to the blade's depth dark red
  (:func:`tissuesim.cutting.walls.wound_walls`). Needs ``tissuesim.Scalpel``.

Choices where the paper is silent: 5 N (1 N barely shows at organ size and E = 5.5 kPa, 20 N folds the model
through itself); the camera looks down at 35° from the front-left, the same for every panel of a figure.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..experiments.protocol import LOAD_DIRECTIONS, load_node
from ..io import replaced_atomically
from ..recording import border_edges
from ..solvers.registry import solver_class
from .gl import look_at_oblique, polyscope

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..mesh.hybrid import HybridMesh

FIGURE_FORCE = 5.0  # N
# N, beside the incision's middle: the wound experiment's 0.1 N opens the liver by 0.7 mm, invisible at figure scale
OPENING_FORCE = 0.3
PANEL_SIZE = (640, 560)  # pixels
WALL_COLOR = (0.32, 0.06, 0.07)  # the wound's walls: dark red, darker than any colour of the map
COLORMAP = "viridis"  # the same name in polyscope and matplotlib


def render_panels(rest: np.ndarray, triangles: np.ndarray | list[np.ndarray], frames: Sequence[np.ndarray], *,
                  markers: Sequence[int | None] = (), edges: Sequence[np.ndarray | None] | None = None,
                  vmax: float | None = None, focus: np.ndarray | None = None, elevation: float = 35.0,
                  walls: Sequence[tuple[np.ndarray, np.ndarray] | None] | None = None
                  ) -> tuple[list[np.ndarray], float]:
    """Offscreen renders of the surface in each of ``frames``; returns (RGB images, colour-bar top [mm]).

    Args:
        rest: ``(n, 3)`` rest positions [m]. triangles: ``(m, 3)`` (a single array, or one per frame).
        frames: list of ``(n, 3)`` positions [m]. markers: per frame, a node index to mark (the pin-head) or None.
        edges: per frame, ``(k, 2)`` edges to draw in red (cut edges) or None.
        focus: ``(p, 3)`` points [m] the camera frames (default: everything); elevation: camera angle [degrees].
        walls: per frame, the wound's walls ``(points (p, 3) [m], faces (q, 3))`` to draw in :data:`WALL_COLOR`
            (:func:`tissuesim.cutting.walls.wound_walls`), or None.
    """
    ps = polyscope(headless=True)
    ps.clear_user_callback()  # a window's callback left behind must not draw into the figures
    _style(ps)
    ps.set_ground_plane_mode("shadow_only" if focus is None else "none")  # close up, the shadow is a grey band
    tris = triangles if isinstance(triangles, list) else [triangles] * len(frames)
    magnitudes = [1e3 * np.linalg.norm(x - rest[: len(x)], axis=1) for x in frames]
    vmax = vmax or max(float(max(m.max() for m in magnitudes)), 1e-3)
    look_at_oblique(ps, np.vstack(frames) if focus is None else focus, elevation=elevation)
    images = []
    for index, (x, t, mm) in enumerate(zip(frames, tris, magnitudes)):
        marker = markers[index] if index < len(markers) else None
        cut = None if edges is None else edges[index]
        wall = None if walls is None else walls[index]
        images.append(_render_one(ps, x, t, mm, vmax, marker, cut, wall))
    ps.remove_all_structures()
    return _crop(images), vmax


def _render_one(ps, x, triangles, mm, vmax, marker, cut_edges, walls=None) -> np.ndarray:
    """One panel's RGB image. Polyscope's Python wrappers live only inside this call, so none outlives the
    structure it wraps (a new structure at the same address would come back as the stale wrapper's type)."""
    ps.remove_all_structures()
    mesh = ps.register_surface_mesh("M_S", x, triangles, smooth_shade=True, material="clay", edge_width=0.0)
    mesh.add_scalar_quantity("|u| [mm]", mm, enabled=True, cmap=COLORMAP, vminmax=(0.0, vmax))
    if marker is not None:
        ps.register_point_cloud("pin-head", x[[marker]], color=(0.85, 0.1, 0.1), radius=0.012)
    if cut_edges is not None and len(cut_edges):
        nodes, local = np.unique(cut_edges, return_inverse=True)  # only the cut's own nodes are drawn
        ps.register_curve_network("cut", x[nodes], local.reshape(-1, 2), color=(0.9, 0.05, 0.05), radius=0.0015)
    if walls is not None and len(walls[1]):
        ps.register_surface_mesh("walls", walls[0], walls[1], color=WALL_COLOR, material="flat", edge_width=0.0,
                                 back_face_policy="identical")
    return ps.screenshot_to_buffer(transparent_bg=False)[:, :, :3].copy()


def _crop(images, margin: int = 12) -> list[np.ndarray]:
    """The images cut to the box holding anything but background in any of them (same box for all)."""
    drawn = np.any([np.any(image < 250, axis=2) for image in images], axis=0)
    rows, cols = np.flatnonzero(drawn.any(axis=1)), np.flatnonzero(drawn.any(axis=0))
    if rows.size == 0:
        return images
    r0, r1 = max(rows[0] - margin, 0), rows[-1] + margin + 1
    c0, c1 = max(cols[0] - margin, 0), cols[-1] + margin + 1
    return [image[r0:r1, c0:c1] for image in images]


def compose(images: Sequence[np.ndarray], captions: Sequence[str], title: str, vmax: float,
            path: Path | str) -> Path:
    """Panels side by side with ``captions``, a ``title`` and a colour bar |u| [mm] from 0 to ``vmax``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    figure, axes = plt.subplots(1, len(images), figsize=(3.6 * len(images) + 0.9, 3.9), squeeze=False)
    for ax, image, caption in zip(axes[0], images, captions):
        ax.imshow(image)
        ax.set_title(caption, fontsize=10)
        ax.set_axis_off()
    bar = figure.colorbar(ScalarMappable(Normalize(0.0, vmax), COLORMAP), ax=list(axes[0]), shrink=0.8, pad=0.02)
    bar.set_label("displacement |u| [mm]")
    figure.suptitle(title, fontsize=11, y=1.03)
    path = Path(path)
    try:
        with replaced_atomically(path) as partial:    # an interrupted save leaves no truncated image
            figure.savefig(partial, dpi=110, bbox_inches="tight", format=path.suffix.lstrip(".") or "png")
    finally:
        plt.close(figure)
    return path


def deformation_figure(hybrid: HybridMesh, name: str, path: Path | str, *, method: str = "hybrid",
                       force: float = FIGURE_FORCE, radius: float | None = None,
                       fixed: ArrayLike | None = None) -> Path:
    """Fig 11 for one model: at rest, under tension, under pressure (quasi-static, ``force`` [N] on the load node,
    or spread over a contact patch of ``radius`` [m] around it), held at ``fixed`` (the solvers' option; None: the
    bottom)."""
    from ..experiments.inputs import check_free_node
    from ..solvers.registry import make_solver

    surface = hybrid.surface
    node = load_node(surface.vertices, surface.triangles)
    solver = make_solver(method, hybrid, fixed=fixed)
    check_free_node(solver, node, name, role="the figure's load at its top centre")
    frames = [surface.vertices] + [solver.solve_static(node, force * np.asarray(LOAD_DIRECTIONS[kind]), radius=radius)
                                   for kind in ("tension", "pressure")]
    images, vmax = render_panels(surface.vertices, surface.triangles, frames, markers=[None, node, node])
    captions = ["at rest", f"tension {force:g} N (up)", f"pressure {force:g} N (down)"]
    where = f"on node {node}" if radius is None else f"over {1e3 * radius:g} mm around node {node}"
    title = (f"{name}: {force:g} N {where} (pin-head at the top centre), "
             f"{solver_class(method).label}, E = {solver.youngs_modulus:g} Pa, ν = {solver.poisson_ratio:g}")
    return compose(images, captions, title, vmax, path)


def incision_figure(hybrid: HybridMesh, name: str, path: Path | str, *, method: str = "hybrid",
                    force: float = OPENING_FORCE, fixed: ArrayLike | None = None, length: float | None = None,
                    depth: float | None = None, offset: float | None = None) -> Path:
    """Fig 16 for one model: the scripted incision (:mod:`tissuesim.experiments.wound`), closed, then pulled open by
    ``force`` [N] beside its middle; the camera frames the wound. ``fixed``: the solvers' option (None: the bottom);
    the incision's ``length`` and ``depth`` [m] and the pull's ``offset`` [m] beside it (None: the experiment's)."""
    from ..cutting.walls import wound_walls
    from ..experiments.wound import INCISION_DEPTH, open_wound, pull_node, scripted_incision, wound_gap
    from ..experiments.inputs import check_free_node
    from ..mesh.coincident import coincident_pairs
    from ..solvers.registry import make_solver

    stroke = {k: v for k, v in (("length", length), ("depth", depth)) if v is not None}
    offset = {} if offset is None else {"offset": offset}
    solver = make_solver(method, hybrid, fixed=fixed)
    line = scripted_incision(solver, **stroke)["line"]
    check_free_node(solver, pull_node(solver.rest_positions, line, **offset), name,
                    role="the pull beside the incision")
    cut_surface = solver.hybrid.surface
    closed = solver.positions.copy()
    opened = open_wound(solver, line, force=force, **offset)
    edges = border_edges(cut_surface.triangles)
    length = float(np.linalg.norm(line[1] - line[0]))
    middle = 0.5 * (line[0] + line[1])
    focus = middle + np.array([[-1.0, -1.0, -0.4], [1.0, 1.0, 0.2]]) * length  # the wound and its surroundings
    frames = [closed, solver.positions.copy()]
    pairs = coincident_pairs(solver.rest_positions)
    walls = [wound_walls(x, cut_surface.triangles, pairs, depth or INCISION_DEPTH) for x in frames]
    images, vmax = render_panels(solver.rest_positions, cut_surface.triangles, frames, markers=[None, opened["node"]],
                                 edges=[edges, edges], focus=focus, elevation=55.0, walls=walls)
    captions = [f"{1e3 * length:.0f} mm incision, {len(edges)} cut edges",
                f"{force:g} N beside it: gap {1e3 * wound_gap(solver):.1f} mm"]
    title = (f"{name}: scalpel stroke across the top, then {force:g} N sideways on node {opened['node']}, "
             f"{solver_class(method).label}")
    return compose(images, captions, title, vmax, path)


def _style(ps) -> None:
    ps.set_window_size(*PANEL_SIZE)
    ps.set_up_dir("z_up")
    ps.set_front_dir("neg_y_front")
    ps.set_background_color((1.0, 1.0, 1.0))
    ps.set_SSAA_factor(2)
    ps.set_autocenter_structures(False)
    ps.set_autoscale_structures(False)
