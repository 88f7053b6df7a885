"""Quadratic (10-node) tetrahedra: the accuracy the contact protocol's reference needs (not the paper's method).

Linear tets converge slowly in the whole body's stiffness: the contact reference refined near the load kept drifting
by 1–2 % per level on linear tets (docs/experiments.md). Quadratic tets on the same meshes converge within 1 % in
three levels, so the reference uses them; every simulation method keeps its linear tets (§3).

* **Nodes.** The mesh's corner nodes keep their indices; a midside node is added on every edge, numbered
  ``n + e`` in the order of :attr:`QuadraticFEM.edges` (straight edges: at the midpoint).
* **Shape functions** in barycentric coordinates L: corner a, N_a = L_a (2 L_a − 1); edge (a, b), N_ab = 4 L_a L_b.
  Their gradients are linear, so the stiffness ∫ Bᵀ D B dV is exact with the 4-point rule of degree 2.
* **Traction.** A uniform traction on a flat quadratic triangle loads its three midside nodes with a third of the
  force each and its corners with none (∫ N dA: 0 at a corner, A/3 at a midside).
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from ..mesh.tetmesh import TetMesh
from .assembly import scatter_elements, shape_gradients
from .linear import _check_rigid_modes, _fixed_mask, factorise_spd
from .material import Material

#: Local edges (a, b) of a tet, in the order of its six midside nodes 4..9.
TET_EDGES = np.array([(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)], dtype=np.int64)
#: The 4-point rule of degree 2 on a tet: barycentric points (α, β, β, β) and its permutations, weight V/4 each.
_ALPHA, _BETA = 0.5854101966249685, 0.1381966011250105
QUADRATURE = np.full((4, 4), _BETA) + np.eye(4) * (_ALPHA - _BETA)


def quadratic_elements(tets: np.ndarray, node_count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(elements (m, 10) int64, edges (e, 2) int64)``: each tet's 4 corners then its 6 midside nodes (node
    ``node_count + edge index``), and the mesh's unique edges, each sorted."""
    tets = np.asarray(tets, dtype=np.int64)
    pairs = np.sort(tets[:, TET_EDGES], axis=2).reshape(-1, 2)
    edges, which = np.unique(pairs, axis=0, return_inverse=True)
    elements = np.concatenate([tets, node_count + which.reshape(len(tets), 6)], axis=1)
    return elements, edges


def quadratic_gradients(linear_gradients: np.ndarray, point: np.ndarray) -> np.ndarray:
    """``(m, 10, 3)`` gradients [1/m] of the ten shape functions at barycentric ``point`` ``(4,)``, from the linear
    ones ∇L ``(m, 4, 3)``: ∇N_a = (4 L_a − 1) ∇L_a, ∇N_ab = 4 (L_b ∇L_a + L_a ∇L_b)."""
    g = np.empty((len(linear_gradients), 10, 3))
    g[:, :4] = (4.0 * point - 1.0)[None, :, None] * linear_gradients
    a, b = TET_EDGES[:, 0], TET_EDGES[:, 1]
    g[:, 4:] = 4.0 * (point[b][None, :, None] * linear_gradients[:, a]
                      + point[a][None, :, None] * linear_gradients[:, b])
    return g


def quadratic_element_stiffness(mesh: TetMesh, material: Material) -> np.ndarray:
    """``(m, 30, 30) float64`` element stiffness ∫ Bᵀ D B dV [N/m] of the quadratic tets, node-major local dofs
    (corners 0–3, then midsides in :data:`TET_EDGES` order)."""
    linear = shape_gradients(mesh)
    volume = mesh.volumes
    d = material.elasticity_matrix()
    ke = np.zeros((len(volume), 30, 30))
    b = np.zeros((len(volume), 6, 10, 3))
    for point in QUADRATURE:
        g = quadratic_gradients(linear, point)
        gx, gy, gz = g[..., 0], g[..., 1], g[..., 2]
        b[:, 0, :, 0], b[:, 1, :, 1], b[:, 2, :, 2] = gx, gy, gz
        b[:, 3, :, 0], b[:, 3, :, 1] = gy, gx
        b[:, 4, :, 1], b[:, 4, :, 2] = gz, gy
        b[:, 5, :, 0], b[:, 5, :, 2] = gz, gx
        flat = b.reshape(len(volume), 6, 30)
        ke += (0.25 * volume)[:, None, None] * (flat.transpose(0, 2, 1) @ (d @ flat))
    return 0.5 * (ke + ke.transpose(0, 2, 1))


class QuadraticFEM:
    """Small-strain linear elasticity on quadratic tets over the corner nodes of ``mesh``, static: K u = f.

    Args:
        mesh: the tet mesh (its nodes are the corners; midside nodes are added).
        youngs_modulus, poisson_ratio: the material [Pa], [-].
        fixed: a callable ``points (N, 3) -> (k,) int`` choosing the fixed nodes among all N = n + e nodes (e.g.
            ``lambda p: nodes_below(p, height)``), so that midside nodes on the support are fixed with it.

    Attributes:
        points: ``(N, 3) float64`` all nodes [m]: the mesh's, then the midsides.
        edges: ``(e, 2) int64`` the edge of each midside node (node ``n + e``).
        elements: ``(m, 10) int64`` corners and midsides of each tet.
        stiffness: the unconstrained K [N/m], ``(3N, 3N)`` CSR, node-major dofs.
    """

    def __init__(self, mesh: TetMesh, *, youngs_modulus: float, poisson_ratio: float, fixed):
        material = Material(youngs_modulus, poisson_ratio)
        n = mesh.node_count
        self.elements, self.edges = quadratic_elements(mesh.tets, n)
        midpoints = 0.5 * (mesh.points[self.edges[:, 0]] + mesh.points[self.edges[:, 1]])
        self.points = np.concatenate([mesh.points, midpoints])
        mask = _fixed_mask(np.asarray(fixed(self.points), dtype=np.int64), len(self.points))
        _check_rigid_modes(mesh, mask[:n])
        self._edge_of = {(int(a), int(b)): n + k for k, (a, b) in enumerate(self.edges.tolist())}
        self.free_dofs = np.flatnonzero(~mask.ravel())
        self.stiffness = scatter_elements(len(self.points), self.elements, quadratic_element_stiffness(mesh, material))
        reduced = self.stiffness[self.free_dofs][:, self.free_dofs].tocsc()
        self._factor = factorise_spd(reduced, self.free_dofs // 3)

    @property
    def node_count(self) -> int:
        return len(self.points)

    def midside(self, a: int, b: int) -> int:
        """The midside node of the mesh edge between corner nodes ``a`` and ``b``."""
        key = (int(a), int(b)) if a < b else (int(b), int(a))
        if key not in self._edge_of:
            raise SolverError(f"nodes {a} and {b} share no tet edge")
        return self._edge_of[key]

    def traction_weights(self, triangles: np.ndarray, shares: np.ndarray) -> np.ndarray:
        """``(N,) float64`` nodal weights of a traction that puts ``shares`` ``(t,)`` of a unit force on the flat
        boundary triangles ``(t, 3)`` (corner nodes), uniformly over each: a third of each share to its midsides."""
        weights = np.zeros(self.node_count)
        for (a, b, c), share in zip(np.asarray(triangles).tolist(), np.asarray(shares).tolist()):
            for u, v in ((a, b), (b, c), (c, a)):
                weights[self.midside(u, v)] += share / 3.0
        return weights

    def solve(self, forces: np.ndarray) -> np.ndarray:
        """``(N, 3) float64`` displacements [m] of all nodes under nodal forces ``(N, 3)`` [N]."""
        forces = np.asarray(forces, dtype=np.float64)
        if forces.shape != (self.node_count, 3):
            raise SolverError(f"forces must have shape ({self.node_count}, 3) [N], got {forces.shape}")
        u = np.zeros(3 * self.node_count)
        u[self.free_dofs] = self._factor.solve(forces.ravel()[self.free_dofs])
        return u.reshape(-1, 3)
