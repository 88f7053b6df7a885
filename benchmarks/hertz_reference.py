"""Hertz contact, the pieces the benchmark (hertz.py) and the validation tests share: the analytic force, the
indentation block, one static press of a rigid sphere, and a method of quadratic (10-node) tets on the fine volume
that tells the contact's error from the linear tets' (a method of one's own: ``register``).

Hertz (a rigid sphere of radius R pressed a depth δ into an elastic half-space, frictionless):
F = 4/3 · E/(1 − ν²) · √R · δ^{3/2}, contact radius a = √(R δ); valid for δ ≪ R and a body much larger than a. The
block is a layer bonded to its fixed bottom: :func:`layer_factor` is the published first-order correction.
"""

from __future__ import annotations

import numpy as np

import tissuesim
from tissuesim.mesh import models
from tissuesim.probe import Probe
from tissuesim.solvers import Solver, register

#: The probe's radius [m] and the block's default size: 80 × 80 × 40 mm, so a ≤ 1.6 mm is small beside it.
PROBE_RADIUS = 5e-3
#: The contact tolerance of each press, as a fraction of δ: it moves F by at most 1.5 times that fraction.
TOLERANCE_OF_DEPTH = 1e-3
QUADRATIC = "fem-quadratic"
#: The default block's elastic thickness [m]: its 40 mm less the fixed bottom tenth (a layer bonded to its base).
THICKNESS = 0.036


def hertz_force(depth, *, radius: float, youngs_modulus: float, poisson_ratio: float):
    """F [N] of a rigid sphere of ``radius`` [m] pressed ``depth`` [m] (scalar or array) into a half-space."""
    return 4.0 / 3.0 * youngs_modulus / (1.0 - poisson_ratio**2) * np.sqrt(radius) * np.asarray(depth) ** 1.5


def layer_factor(depth, *, radius: float, poisson_ratio: float, thickness: float = THICKNESS):
    """Dimitriadis et al. (Biophys. J. 82, 2002): the first-order correction of Hertz for an elastic
    layer of ``thickness`` [m] bonded to a rigid base, 1 − 2α₀χ/π with χ = √(R δ)/h and
    α₀ = −(1.2876 − 1.4678ν + 1.3442ν²)/(1 − ν); ``depth`` [m] scalar or array."""
    alpha = -(1.2876 - 1.4678 * poisson_ratio + 1.3442 * poisson_ratio**2) / (1.0 - poisson_ratio)
    return 1.0 - 2.0 * alpha * np.sqrt(radius * np.asarray(depth)) / (np.pi * thickness)


def block(fine_edge: float, *, control: float | None = None, **options):
    """The :func:`tissuesim.mesh.models.indentation_block` with the fine edge ``fine_edge`` [m], built hybrid
    (``control``: control nodes as a fraction of its vertices; None: the build's default)."""
    surface = models.indentation_block(fine_edge=fine_edge, **options)
    target = None if control is None else int(round(control * surface.vertex_count))
    return tissuesim.HybridMesh.build(surface, target_vertices=target)


def press(solver, depth: float, *, radius: float = PROBE_RADIUS) -> tuple[float, int, Probe]:
    """Press a sphere of ``radius`` [m] ``depth`` [m] into the middle of the block's top; ``(F_z [N], vertices in
    contact, probe)``, the probe released afterwards (its last iterations, steps and residual kept)."""
    top = solver.rest_positions[:, 2].max()
    probe = Probe(solver, radius=radius, tolerance=TOLERANCE_OF_DEPTH * depth)
    probe.press_static([0.0, 0.0, top + radius - depth])
    force, contacts = float(probe.force[2]), int(probe.contacts.size)
    probe.release()
    return force, contacts, probe


def quadratic_method() -> str:
    """Register (once) and name the quadratic-tet method."""
    if QUADRATIC not in tissuesim.available_solvers():
        register(QUADRATIC)(QuadraticTets)
    return QUADRATIC


class QuadraticTets(Solver):
    """Static linear FEM of quadratic tets on the fine volume (the ``fem`` method's mesh, midside nodes added).

    A nodal force f_i on M_S vertex i acts as a traction of density f_i / a_i (a_i its lumped area) linear over its
    triangles, which integrates back to f_i: a point force on a quadratic tet's corner would be singular.
    """

    static = True

    def __init__(self, hybrid_mesh, **common):
        super().__init__(hybrid_mesh, **common)
        from tissuesim.fem.quadratic import QuadraticFEM
        from tissuesim.solvers.near_field import fixed_corners

        volume = hybrid_mesh.fine_volume
        self.surface_nodes = np.asarray(hybrid_mesh.fine_surface_nodes, dtype=np.int64)
        fixed = fixed_corners(volume, self.fixed_volume_nodes(volume.points, self.surface_nodes))
        self.fem = QuadraticFEM(volume, youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
                                fixed=fixed)
        self._triangles = np.asarray(hybrid_mesh.surface.triangles, dtype=np.int64)

    def _step(self, dt: float) -> None:
        density = self.forces / self.lumped_areas()[:, None]
        loaded = np.flatnonzero(np.any(density[self._triangles] != 0.0, axis=(1, 2)))
        triangles = self._triangles[loaded]
        forces = np.zeros((self.fem.node_count, 3))
        for axis in range(3):
            forces[:, axis] = self.fem.linear_traction_weights(self.surface_nodes[triangles],
                                                               density[triangles, axis])
        u = self.fem.solve(forces)
        np.add(self.rest_positions, u[self.surface_nodes], out=self.state.positions)
