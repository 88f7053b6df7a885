"""Tools drawn from where they are, not from the objects that move them: a scene's scripted tools in the simulator,
and a recording's tools in a replay (:class:`tissuesim.recording.Tools`).

A pin-head is a ball at its cursor and its spring (eq 24) to the vertex it holds; a probe is a sphere of its radius.
The structures are registered anew when the number of tools changes, else only moved.
"""

from __future__ import annotations

import numpy as np

PIN_COLOR = (0.85, 0.1, 0.1)
PROBE_COLOR = (0.7, 0.72, 0.78)


class ToolLayers:
    """Polyscope structures for pin-heads and probes, named ``prefix`` + what they are.

    Args:
        ps: the polyscope module. prefix: the structures' name prefix (e.g. "scene", "recorded").
    """

    def __init__(self, ps, prefix: str):
        self.ps, self.prefix = ps, prefix
        self._pins = self._springs = None
        self._probes: list = []

    def update(self, pin_heads: np.ndarray, probes: np.ndarray) -> None:
        """Draw ``pin_heads`` ``(k, 2, 3)`` [m] (held vertex, cursor) and ``probes`` ``(p, 4)`` [m] (centre,
        radius)."""
        pin_heads = np.asarray(pin_heads, dtype=np.float64).reshape(-1, 2, 3)
        probes = np.asarray(probes, dtype=np.float64).reshape(-1, 4)
        self._draw_pins(pin_heads)
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

    def _remove_probes(self) -> None:
        for cloud in self._probes:
            cloud.remove()
        self._probes = []
