"""Quadratic (10-node) tetrahedra: the accuracy the contact protocol's reference needs (not the paper's method).

Linear tets converge slowly in the whole body's stiffness: the contact reference refined near the load kept drifting
by 1–2 % per level on linear tets (docs/experiments.md). Quadratic tets on the same meshes converge within 1 % in
three levels, so the reference uses them; every simulation method keeps its linear tets (§3).

* **Nodes.** The mesh's corner nodes keep their indices; a midside node is added on every edge, numbered
  ``n + e`` in the order of :attr:`QuadraticFEM.edges` (straight edges: at the midpoint).
* **Shape functions** in barycentric coordinates L: corner a, N_a = L_a (2 L_a − 1); edge (a, b), N_ab = 4 L_a L_b,
  so ∇N_a = (4 L_a − 1) ∇L_a and ∇N_ab = 4 (L_b ∇L_a + L_a ∇L_b). The gradients are linear, so the stiffness
  ∫ Bᵀ D B dV is exact with the 4-point rule of degree 2.
* **Traction.** A traction linear over a flat quadratic triangle of area A, with densities t_a at its corners, loads
  corner a with A (t_a/30 − (t_b + t_c)/60) and the midside of edge (a, b) with A (2 (t_a + t_b) + t_c)/15
  (∫ N L dA with ∫ L_a^i L_b^j L_c^k dA = 2A i! j! k!/(i + j + k + 2)!). A uniform traction loads the three midsides
  with a third of the force each and the corners with none.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from numba import njit
from numpy.typing import ArrayLike

from ..errors import SolverError
from ..mesh.tetmesh import TetMesh
from .assembly import add_bt_d_b, mirror_upper, scatter_elements, shape_gradients, strain_matrix
from .factorise import factorise_spd
from .supports import check_rigid_modes, fixed_mask
from .springs import check_springs, spring_stiffness
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


def shape_values(barycentric: np.ndarray) -> np.ndarray:
    """``(k, 10) float64`` the quadratic shape functions at barycentric points ``(k, 4)``: corners L_a (2 L_a − 1),
    then the midsides 4 L_a L_b in :data:`TET_EDGES` order (module docstring); they sum to 1 at every point."""
    points = np.asarray(barycentric, dtype=np.float64)
    values = np.empty((len(points), 10))
    values[:, :4] = points * (2.0 * points - 1.0)
    values[:, 4:] = 4.0 * points[:, TET_EDGES[:, 0]] * points[:, TET_EDGES[:, 1]]
    return values


def quadratic_body_force(mesh: TetMesh, elements: np.ndarray, node_count: int, density: float,
                         acceleration: ArrayLike) -> np.ndarray:
    """``(N, 3) float64`` consistent nodal load [N] of the body force ρ g on the quadratic ``elements`` ``(m, 10)``:
    ∫ N ρ g dV gives each corner −ρ g V/20 and each midside ρ g V/5 (exact for a constant g; they sum to ρ g V)."""
    share = mesh.volumes * float(density)
    nodal = np.bincount(elements[:, :4].ravel(), weights=np.repeat(-share / 20.0, 4), minlength=node_count)
    nodal += np.bincount(elements[:, 4:].ravel(), weights=np.repeat(share / 5.0, 6), minlength=node_count)
    return nodal[:, None] * np.asarray(acceleration, dtype=np.float64)[None, :]


def quadratic_element_stiffness(mesh: TetMesh, material: Material) -> np.ndarray:
    """``(m, 30, 30) float64`` element stiffness ∫ Bᵀ D B dV [N/m] of the quadratic tets, node-major local dofs
    (corners 0–3, then midsides in :data:`TET_EDGES` order); exactly symmetric."""
    ke = np.empty((mesh.element_count, 30, 30))
    _element_kernel(shape_gradients(mesh), mesh.volumes, material.elasticity_matrix(), QUADRATURE, TET_EDGES, ke)
    return ke


def quadratic_stiffness(mesh: TetMesh, material: Material, elements: np.ndarray, node_count: int) -> sp.csr_matrix:
    """The unconstrained K [N/m], ``(3N, 3N)`` CSR, node-major dofs, over the quadratic ``elements`` ``(m, 10)`` of
    :func:`quadratic_elements` with N = ``node_count`` nodes."""
    return scatter_elements(node_count, elements, quadratic_element_stiffness(mesh, material))


@njit(cache=True)
def _element_kernel(linear_gradients, volumes, d, quadrature, tet_edges, out):
    """out[e] = Σ_q V/4 Bᵀ D B at the quadrature points (module docstring), without temporaries per element."""
    g = np.empty((10, 3))
    b = np.zeros((6, 30))
    db = np.empty((6, 30))
    for e in range(volumes.shape[0]):
        lg = linear_gradients[e]
        out[e, :, :] = 0.0
        weight = 0.25 * volumes[e]
        for q in range(quadrature.shape[0]):
            point = quadrature[q]
            for a in range(4):
                for c in range(3):
                    g[a, c] = (4.0 * point[a] - 1.0) * lg[a, c]
            for k in range(6):
                a, bb = tet_edges[k, 0], tet_edges[k, 1]
                for c in range(3):
                    g[4 + k, c] = 4.0 * (point[bb] * lg[a, c] + point[a] * lg[bb, c])
            strain_matrix(g, b)
            add_bt_d_b(b, d, db, weight, out[e])
        mirror_upper(out[e])


class QuadraticFEM:
    """Small-strain linear elasticity on quadratic tets over the corner nodes of ``mesh``, static: K u = f.

    Args:
        mesh: the tet mesh (its nodes are the corners; midside nodes are added).
        youngs_modulus: the material's E [Pa].
        poisson_ratio: its ν [-].
        fixed: a callable ``points (N, 3) -> (k,) int`` (or an ``(N,)`` bool mask) choosing the fixed nodes among
            all N = n + e nodes (e.g. ``lambda p: nodes_below(p, height)``), so that midside nodes on the support are
            fixed with it. The rigid-mode check looks at the corner nodes: fix corners, not midsides alone.
        springs: None, or isotropic springs to fixed anchors over all N nodes, as :class:`~.linear.LinearFEM` takes
            them ``(nodes (p, r) int, weights (p, r), stiffness (p,) [N/m])``; their stiffness is added to K.
        topology: ``(elements, edges)`` of :func:`quadratic_elements` for ``mesh``, where already known.

    Attributes:
        points: ``(N, 3) float64`` all nodes [m]: the mesh's, then the midsides.
        edges: ``(e, 2) int64`` the edge of each midside node (node ``n + e``).
        elements: ``(m, 10) int64`` corners and midsides of each tet.
        factor: K_ff's factor (:func:`~.factorise.factorise_spd`): ``factor.solve(b)`` for ``(f,)`` or ``(f, m)``.
    """

    def __init__(self, mesh: TetMesh, *, youngs_modulus: float, poisson_ratio: float,
                 fixed: Callable[[np.ndarray], ArrayLike],
                 springs: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
                 topology: tuple[np.ndarray, np.ndarray] | None = None):
        material = Material(youngs_modulus, poisson_ratio)
        n = mesh.node_count
        self.elements, self.edges = quadratic_elements(mesh.tets, n) if topology is None else topology
        midpoints = 0.5 * (mesh.points[self.edges[:, 0]] + mesh.points[self.edges[:, 1]])
        self.points = np.concatenate([mesh.points, midpoints])
        if not callable(fixed):
            raise SolverError("fixed must be a callable points (N, 3) -> fixed node indices or (N,) mask, e.g. "
                              "lambda points: nodes_below(points, height)")
        springs = check_springs(springs, len(self.points))
        mask = fixed_mask(np.asarray(fixed(self.points)), len(self.points), sprung=springs is not None)
        check_rigid_modes(mesh, mask[:n], None if springs is None else _on_corners(springs, self.edges, n))
        self._edge_of = {(int(a), int(b)): n + k for k, (a, b) in enumerate(self.edges.tolist())}
        self.free_dofs = np.flatnonzero(~mask.ravel())
        # K itself is not kept: at the reference's largest level it is ~1 GB, and the factor needs the memory.
        stiffness = quadratic_stiffness(mesh, material, self.elements, len(self.points))
        #: the springs' ``(3N, 3N)`` CSR part of K [N/m], or None.
        self.spring_stiffness = None if springs is None else spring_stiffness(len(self.points), *springs)
        if springs is not None:
            stiffness = stiffness + self.spring_stiffness
        reduced = stiffness[self.free_dofs][:, self.free_dofs].tocsc()
        del stiffness
        self.factor = factorise_spd(reduced, self.free_dofs // 3)

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
        triangles, shares = _check_triangles(triangles), np.asarray(shares, dtype=np.float64)
        if shares.shape != (len(triangles),) or not np.all(np.isfinite(shares)):
            raise SolverError(f"traction_weights needs (t,) finite shares for its (t, 3) triangles, got "
                              f"{shares.shape}")
        areas = self._areas(triangles)
        return self.linear_traction_weights(triangles, np.repeat((shares / areas)[:, None], 3, axis=1))

    def linear_traction_weights(self, triangles: np.ndarray, densities: np.ndarray) -> np.ndarray:
        """``(N,) float64`` nodal weights of a traction linear over each flat boundary triangle ``(t, 3)`` (corner
        nodes), with ``densities`` ``(t, 3) float64`` [1/m²] at its corners: the fraction of a unit force per unit
        area (module docstring). The weights sum to ∫ t dA."""
        triangles, densities = _check_triangles(triangles), np.asarray(densities, dtype=np.float64)
        if densities.shape != triangles.shape or not np.all(np.isfinite(densities)):
            raise SolverError(f"linear_traction_weights needs (t, 3) finite corner densities for its (t, 3) "
                              f"triangles, got {densities.shape}")
        areas = self._areas(triangles)[:, None]
        weights = np.zeros(self.node_count)
        corner = areas * (densities / 30.0 - (densities.sum(axis=1, keepdims=True) - densities) / 60.0)
        np.add.at(weights, triangles.ravel(), corner.ravel())
        for a, b in ((0, 1), (1, 2), (2, 0)):
            c = 3 - a - b
            side = areas[:, 0] * (2.0 * (densities[:, a] + densities[:, b]) + densities[:, c]) / 15.0
            mids = [self.midside(u, v) for u, v in zip(triangles[:, a].tolist(), triangles[:, b].tolist())]
            np.add.at(weights, np.asarray(mids, dtype=np.int64), side)
        return weights

    def _areas(self, triangles: np.ndarray) -> np.ndarray:
        p = self.points
        a, b, c = p[triangles[:, 0]], p[triangles[:, 1]], p[triangles[:, 2]]
        return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)

    def solve(self, forces: np.ndarray) -> np.ndarray:
        """``(N, 3) float64`` displacements [m] of all nodes under nodal forces ``(N, 3)`` [N]."""
        forces = np.asarray(forces, dtype=np.float64)
        if forces.shape != (self.node_count, 3):
            raise SolverError(f"forces must have shape ({self.node_count}, 3) [N], got {forces.shape}")
        if not np.all(np.isfinite(forces)):
            raise SolverError("forces contain non-finite values; give finite nodal forces [N]")
        return self.solve_columns(forces.reshape(-1, 1)).reshape(-1, 3)

    def solve_columns(self, forces: np.ndarray) -> np.ndarray:
        """``(3N, k) float64`` displacements [m] of all dofs (node-major) under ``k`` load cases ``(3N, k)`` [N]: one
        call of the factor for them all."""
        u = np.zeros((3 * self.node_count, forces.shape[1]))
        u[self.free_dofs] = self.factor.solve(np.ascontiguousarray(forces[self.free_dofs]))
        return u


def _on_corners(springs, edges: np.ndarray, n: int):
    """``springs`` over all nodes as springs over the corner nodes alone, holding the same points: a midside is
    its edge's midpoint, so its weight goes half to each end (what the rigid-mode check needs)."""
    nodes, weights, stiffness = springs
    mid = nodes >= n
    ends = np.where(mid[..., None], edges[np.where(mid, nodes - n, 0)], nodes[..., None])      # (p, r, 2)
    halves = np.where(mid, 0.5, 1.0) * weights
    return (np.concatenate([ends[..., 0], ends[..., 1]], axis=1),
            np.concatenate([halves, np.where(mid, halves, 0.0)], axis=1), stiffness)


def _check_triangles(triangles) -> np.ndarray:
    triangles = np.asarray(triangles)
    if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.dtype.kind not in "iu":
        raise SolverError(f"traction_weights needs (t, 3) integer triangles, got {triangles.shape} {triangles.dtype}")
    return triangles.astype(np.int64)
