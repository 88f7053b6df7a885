"""Tools drawn from where they are, not from the objects that move them: the simulator's own graspers, a scene's
scripted tools, and a recording's tools in a replay (:class:`tissuesim.recording.Tools`).

A pin-head is a ball at its cursor and its spring (eq 24) to the vertex it holds; a probe is a sphere of its radius;
a grasper is a pair of jaws closed on its position, coming down the model's z (the viewer's up), and a ring of its
reach around it, so that what it holds shows (the vertices within the reach of the position).
The structures are registered anew when the number of tools changes, else only moved.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from types import ModuleType

    from numpy.typing import ArrayLike

PIN_COLOR = (0.85, 0.1, 0.1)
PROBE_COLOR = (0.7, 0.72, 0.78)
GRASPER_COLOR = (0.15, 0.55, 0.75)   # steel blue: apart from the tissue, the pin-heads' red and the probes' grey
#: The ring of a grasper's reach: this many segments.
RING_SEGMENTS = 32
#: A grasper's jaws, in reaches: each this long, their tips this far either side of the position, and the shaft
#: above the hinge this long.
JAW_LENGTH, JAW_SPREAD, SHAFT_LENGTH = 2.0, 0.35, 3.0
#: The jaws' and the ring's thickness, in reaches.
JAW_THICKNESS = 0.08


class ToolLayers:
    """Polyscope structures for pin-heads, probes and graspers, named ``prefix`` + what they are.

    Args:
        ps: the polyscope module. prefix: the structures' name prefix (e.g. "scene", "recorded").
    """

    def __init__(self, ps: ModuleType, prefix: str):
        self.ps, self.prefix = ps, prefix
        self._pins = self._springs = self._jaws = None
        self._probes: list = []

    def update(self, pin_heads: np.ndarray, probes: np.ndarray, graspers: ArrayLike = ()) -> None:
        """Draw ``pin_heads`` ``(k, 2, 3)`` [m] (held vertex, cursor), ``probes`` ``(p, 4)`` [m] (centre, radius)
        and ``graspers`` ``(g, 4)`` [m] (the jaws' position, their reach)."""
        pin_heads = np.asarray(pin_heads, dtype=np.float64).reshape(-1, 2, 3)
        probes = np.asarray(probes, dtype=np.float64).reshape(-1, 4)
        self._draw_pins(pin_heads)
        self._draw_graspers(np.asarray(graspers, dtype=np.float64).reshape(-1, 4))
        if len(probes) != len(self._probes):
            self._remove_probes()
            self._probes = [self.ps.register_point_cloud(f"{self.prefix} probe {i}", probe[None, :3],
                                                         color=PROBE_COLOR, material="wax")
                            for i, probe in enumerate(probes)]
        for cloud, probe in zip(self._probes, probes):
            cloud.update_point_positions(probe[None, :3])
            cloud.set_radius(float(probe[3]), relative=False)

    def remove(self) -> None:
        """Take every structure away."""
        self._draw_pins(np.zeros((0, 2, 3)))
        self._draw_graspers(np.zeros((0, 4)))
        self._remove_probes()

    def _draw_pins(self, pin_heads: np.ndarray) -> None:
        count = len(pin_heads)
        if self._pins is not None and self._pins.n_points() != count:
            self._pins.remove()
            self._springs.remove()
            self._pins = self._springs = None
        if count == 0:
            return
        ends = np.concatenate([pin_heads[:, 0], pin_heads[:, 1]])
        if self._pins is None:
            pairs = np.stack([np.arange(count), count + np.arange(count)], axis=1)
            self._pins = self.ps.register_point_cloud(f"{self.prefix} pin-heads", pin_heads[:, 1], color=PIN_COLOR,
                                                      radius=0.01)
            self._springs = self.ps.register_curve_network(f"{self.prefix} springs", ends, pairs, color=PIN_COLOR,
                                                           radius=0.002)
        else:
            self._pins.update_point_positions(pin_heads[:, 1])
            self._springs.update_node_positions(ends)

    def _draw_graspers(self, graspers: np.ndarray) -> None:
        nodes, edges = jaws_geometry(graspers)
        if self._jaws is not None and self._jaws.n_nodes() != len(nodes):
            self._jaws.remove()
            self._jaws = None
        if len(graspers) == 0:
            return
        if self._jaws is None:
            self._jaws = self.ps.register_curve_network(f"{self.prefix} jaws", nodes, edges, color=GRASPER_COLOR,
                                                        material="wax")
        else:
            self._jaws.update_node_positions(nodes)
        self._jaws.set_radius(JAW_THICKNESS * float(graspers[:, 3].mean()), relative=False)

    def _remove_probes(self) -> None:
        for cloud in self._probes:
            cloud.remove()
        self._probes = []


def jaws_geometry(graspers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(nodes (g q, 3) float64 [m], edges (g e, 2) int64)`` of the curves that draw ``graspers`` ``(g, 4)`` [m]
    (position, reach): per grasper a ring of its reach around its position in the plane normal to z, and a pair of
    jaws whose tips meet either side of the position, hinged above it on a shaft."""
    turn = np.linspace(0.0, 2.0 * np.pi, RING_SEGMENTS, endpoint=False)
    ring = np.stack([np.cos(turn), np.sin(turn), np.zeros_like(turn)], axis=1)                 # (s, 3) unit
    hinge = np.array([0.0, 0.0, JAW_LENGTH])
    jaws = np.array([[JAW_SPREAD, 0.0, 0.0], [-JAW_SPREAD, 0.0, 0.0], hinge, hinge + [0.0, 0.0, SHAFT_LENGTH]])
    shape = np.concatenate([ring, jaws])                                                       # (q, 3) in reaches
    ring_edges = np.stack([np.arange(RING_SEGMENTS), (np.arange(RING_SEGMENTS) + 1) % RING_SEGMENTS], axis=1)
    jaw_edges = RING_SEGMENTS + np.array([[0, 2], [1, 2], [2, 3]])
    local = np.concatenate([ring_edges, jaw_edges])                                            # (e, 2)
    nodes = graspers[:, None, :3] + graspers[:, 3, None, None] * shape[None]
    edges = local[None] + len(shape) * np.arange(len(graspers))[:, None, None]
    return nodes.reshape(-1, 3), edges.reshape(-1, 2).astype(np.int64)
