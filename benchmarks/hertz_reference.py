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
from tissuesim.tools.probe import Probe
from tissuesim.errors import SolverError
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
    label, short_label, colour = "fine-volume FEM, quadratic tets", "FEM-Q", "black"

    def __init__(self, hybrid_mesh, **common):
        super().__init__(hybrid_mesh, **common)
        if self.gravity is not None or self.attachments:
            raise SolverError(f"the {QUADRATIC} method of the Hertz benchmark models contact loads alone: drop the "
                              "gravity and attachments, or use fem")
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


def refined_block(fine_edge: float, levels: int):
    """The block of :func:`block` whose fine volume is split ``levels`` times into 8 (every tet at its edges'
    midpoints, the surface with it: a true h/2 per level, which refining the surface alone is not, since TetGen
    grades the volume from it), built hybrid over the refined surface with that volume as its fine volume."""
    from dataclasses import replace

    from tissuesim.mesh.surface import SurfaceMesh
    from tissuesim.mesh.tetmesh import TetMesh

    surface = models.indentation_block(fine_edge=fine_edge)
    coarse = tissuesim.HybridMesh.build(surface)
    points, tets = coarse.fine_volume.points, np.asarray(coarse.fine_volume.tets, dtype=np.int64)
    nodes = np.asarray(coarse.fine_surface_nodes, dtype=np.int64)
    triangles = nodes[np.asarray(surface.triangles, dtype=np.int64)]      # the surface on volume nodes
    for _ in range(levels):
        points, tets, triangles = _split_in_eight(points, tets, triangles)
    on_surface = np.unique(triangles)
    local = np.full(len(points), -1, dtype=np.int64)
    local[on_surface] = np.arange(on_surface.size)
    refined = SurfaceMesh(points[on_surface], local[triangles])
    hybrid = tissuesim.HybridMesh.build(refined, fine_volume=False)
    return replace(hybrid, fine_volume=TetMesh(points, tets), fine_surface_nodes=on_surface.astype(np.int32))


def _split_in_eight(points, tets, triangles):
    """Red refinement: each tet into 4 corner tets and 4 about the octahedron's diagonal between the midpoints of
    two opposite edges, each triangle into 4, positively oriented."""
    pairs = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
    edges = np.sort(tets[:, pairs].reshape(-1, 2), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mid = len(points) + inverse.reshape(-1, 6)
    points = np.concatenate([points, 0.5 * (points[unique[:, 0]] + points[unique[:, 1]])])
    a, b, c, d = tets.T
    ab, ac, ad, bc, bd, cd = mid.T
    children = np.concatenate([np.stack(t, axis=1) for t in (
        (a, ab, ac, ad), (ab, b, bc, bd), (ac, bc, c, cd), (ad, bd, cd, d),
        (ac, bd, ab, ad), (ac, bd, ad, cd), (ac, bd, cd, bc), (ac, bd, bc, ab))])
    p = points[children]
    negative = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) < 0
    children[negative] = children[negative][:, [0, 1, 3, 2]]
    lookup = {tuple(e): len(points) - len(unique) + i for i, e in enumerate(unique.tolist())}
    i, j, k = triangles.T
    ij, jk, ki = (np.array([lookup[tuple(sorted(e))] for e in zip(u.tolist(), v.tolist())])
                  for u, v in ((i, j), (j, k), (k, i)))
    triangles = np.concatenate([np.stack(t, axis=1) for t in ((i, ij, ki), (ij, j, jk), (ki, jk, k), (ij, jk, ki))])
    return points, children, triangles
