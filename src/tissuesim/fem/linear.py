"""Static linear FEM on a tet mesh (§3, §6.2): K assembled and factorised once, each solve a back-substitution,
plus a fast path for point loads from cached columns of K⁻¹.

Boundary conditions are homogeneous Dirichlet (zero displacement) on fixed nodes or fixed dofs, imposed by
eliminating those dofs, and optionally elastic springs from points of the mesh to fixed anchors (ligaments, option
``springs``), whose stiffness is added to K: the reduced system K_ff u_f = f_f is symmetric positive definite when
the fixed dofs and the springs remove all six rigid-body modes of every connected piece of the mesh, which the
constructor checks.

K_ff is factorised once (:mod:`.factorise`: METIS ordering, CHOLMOD or SuperLU).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from ..errors import MeshError, SolverError, first_indices
from ..mesh.tetmesh import TetMesh
from .assembly import assemble_stiffness
from .factorise import factorise_spd
from .material import DEFAULT_POISSON_RATIO, DEFAULT_YOUNGS_MODULUS, Material
from .springs import check_springs, spring_stiffness
from .supports import check_orphans, check_rigid_modes, fixed_mask
#: The memory [bytes] of the contact patches whose combined K⁻¹ columns :meth:`LinearFEM.patch_response` keeps
#: (72 n bytes each), and the fewest it keeps: a probe or a grasper holds a load on each of tens of vertices, and a
#: cache smaller than that solved every one of them again at every step.
PATCH_CACHE_BYTES = 256 * 2**20
PATCH_CACHE = 8


@njit(cache=True)
def _accumulate_point_load(columns, force, output_nodes, out):
    """out[r] += G[output_nodes[r]] @ force, with G = ``columns`` ``(n, 3, 3)`` the response of every node to a unit
    force on one node. O(len(output_nodes)), no allocation."""
    f0, f1, f2 = force[0], force[1], force[2]
    for r in range(output_nodes.shape[0]):
        i = output_nodes[r]
        for a in range(3):
            out[r, a] += columns[i, a, 0] * f0 + columns[i, a, 1] * f1 + columns[i, a, 2] * f2


class LinearFEM:
    """Small-strain linear elasticity on linear tets, static: K u = f (eq 5) with fixed nodes.

    Args:
        mesh: the tet mesh (positively oriented tets; :class:`TetMesh` checks that).
        youngs_modulus: E [Pa] (paper: 5500).
        poisson_ratio: ν [-] in (-1, 0.49] (paper: 0.3; above 0.45 linear tets lock, see Material).
        fixed: the zero-displacement constraints, one of
            * ``(k,)`` int array of node indices (e.g. from :func:`tissuesim.mesh.regions.nodes_below`): all three
              dofs of those nodes are fixed;
            * ``(n,)`` bool mask of fixed nodes;
            * ``(n, 3)`` bool mask of fixed dofs (x, y, z per node), for roller-type supports.
        springs: None, or isotropic springs to fixed anchors ``(nodes (p, r) int, weights (p, r) float64,
            stiffness (p,) float64 [N/m])``: spring j holds the point whose displacement is
            Σ_a weights[j, a] u[nodes[j, a]] (a node, or a point interpolated in a triangle or tet; weights sum to
            1) with stiffness k_j, adding k_j w_j w_jᵀ ⊗ I₃ to K. A spring holds its point as a fixed node does,
            so ``fixed`` may be empty where springs hold every piece.

    Raises:
        BoundaryConditionError: no fixed dof and no spring, indices out of range, or a piece of the mesh left free
            to move rigidly (nothing held in it, a single held point, or all its held points on one line).
        MeshError: nodes that belong to no tet and are not fixed (they have no stiffness).

    Attributes:
        mesh, material: the inputs.
        fixed_dofs: ``(n, 3) bool`` mask of fixed dofs (read-only).
        free_dofs: ``(f,) int64`` indices of the free dofs in node-major order.
        stiffness: the unconstrained global K [N/m], ``(3n, 3n)`` CSR float64, node-major dof order (elastic
            part only).
        spring_stiffness: the springs' ``(3n, 3n)`` CSR part [N/m] (None without springs).
        reduced_stiffness: K_ff [N/m], ``(f, f)`` CSC, the rows and columns of the free dofs (springs included).
        factor: K_ff's factor (:func:`~.factorise.factorise_spd`): ``factor.solve(b)`` for ``(f,)`` or ``(f, m)``.
    """

    def __init__(
        self,
        mesh: TetMesh,
        *,
        youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
        poisson_ratio: float = DEFAULT_POISSON_RATIO,
        fixed: ArrayLike,
        springs: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    ):
        if not isinstance(mesh, TetMesh):
            raise MeshError(f"mesh must be a tissuesim TetMesh, got {type(mesh).__name__}")
        self.mesh = mesh
        self.material = Material(youngs_modulus, poisson_ratio)
        n = mesh.node_count
        springs = check_springs(springs, n)
        mask = fixed_mask(fixed, n, sprung=springs is not None)
        check_orphans(mesh, mask)
        check_rigid_modes(mesh, mask, springs)
        mask.flags.writeable = False
        self.fixed_dofs = mask
        self.free_dofs = np.flatnonzero(~mask.ravel())
        self.stiffness = assemble_stiffness(mesh, self.material)
        self.spring_stiffness = None if springs is None else spring_stiffness(n, *springs)
        full = self.stiffness if springs is None else self.stiffness + self.spring_stiffness
        self.reduced_stiffness = full[self.free_dofs][:, self.free_dofs].tocsc()
        self.factor = factorise_spd(self.reduced_stiffness, self.free_dofs // 3)
        self._columns: dict[int, np.ndarray] = {}
        self._patches: dict[tuple[bytes, bytes], np.ndarray] = {}     # insertion order = least recently used first

    @property
    def node_count(self) -> int:
        return self.mesh.node_count

    # --- full solve -------------------------------------------------------------------------------------------

    def solve(self, forces: ArrayLike) -> np.ndarray:
        """Nodal displacements u [m], ``(n, 3) float64``, for nodal forces ``(n, 3)`` [N] (eq 5).

        Force components on fixed dofs go straight into the supports and move nothing. One back-substitution.
        """
        forces = np.asarray(forces, dtype=np.float64)
        if forces.shape != (self.node_count, 3):
            raise SolverError(f"forces must have shape ({self.node_count}, 3) [N], got {forces.shape}")
        if not np.all(np.isfinite(forces)):
            bad = np.flatnonzero(~np.all(np.isfinite(forces), axis=1))
            raise SolverError(f"{bad.size} nodal forces are non-finite (first nodes: {first_indices(bad)})")
        u = np.zeros(3 * self.node_count)
        u[self.free_dofs] = self.factor.solve(forces.ravel()[self.free_dofs])
        return u.reshape(-1, 3)

    def reactions(self, displacement: ArrayLike) -> np.ndarray:
        """Nodal forces K u [N], ``(n, 3)``, of a displacement ``(n, 3)`` [m]: at fixed dofs the support reactions
        (with the sign of a force applied to the body), at free dofs the applied load the displacement balances."""
        displacement = np.asarray(displacement, dtype=np.float64)
        if displacement.shape != (self.node_count, 3):
            raise SolverError(f"displacement must have shape ({self.node_count}, 3) [m], got {displacement.shape}")
        return (self.stiffness @ displacement.ravel()).reshape(-1, 3)

    # --- fast path for point loads ------------------------------------------------------------------------------

    def influence(self, node: int) -> np.ndarray:
        """``(n, 3, 3) float64`` read-only: entry ``[i, a, c]`` is the displacement [m/N] of node ``i`` along axis
        ``a`` under a unit force along axis ``c`` on ``node``, i.e. three columns of K⁻¹ (zero on fixed dofs).

        Computed on first use by one 3-right-hand-side back-substitution, then cached (9 n floats per node).
        """
        node = self._check_node(node)
        columns = self._columns.get(node)
        if columns is None:
            self.precompute([node])
            columns = self._columns[node]
        return columns

    def precompute(self, nodes: ArrayLike) -> None:
        """Compute and cache :meth:`influence` of several nodes ``(k,) int`` at once (one multi-RHS solve), e.g.
        all control nodes of a hybrid mesh before an interactive session. Memory: 72 n bytes per node."""
        nodes = np.unique(self._check_nodes(nodes, "nodes"))
        nodes = np.array([i for i in nodes if int(i) not in self._columns], dtype=np.int64)
        if nodes.size == 0:
            return
        n = self.node_count
        solution = self._unit_load_solution(nodes)
        for j, node in enumerate(nodes):
            columns = np.ascontiguousarray(solution[:, 3 * j : 3 * j + 3].reshape(n, 3, 3))
            columns.flags.writeable = False
            self._columns[int(node)] = columns

    def compliance_among(self, nodes: ArrayLike) -> np.ndarray:
        """``(3k, 3k) float64`` [m/N] K⁻¹ among the dofs of ``nodes`` ``(k,) int``, node-major: entry
        ``[3a + d, 3b + c]`` is node a's displacement along d under a unit force on node b along c. One multi-RHS
        solve; nothing is kept (a grasper asks for a new patch at each grab)."""
        nodes = self._check_nodes(nodes, "nodes")
        dofs = (3 * nodes[:, None] + np.arange(3)).ravel()
        return self._unit_load_solution(nodes)[dofs]

    def solve_columns(self, forces: np.ndarray) -> np.ndarray:
        """``(3n, m) float64`` displacements [m] of every dof (node-major) in ``m`` load cases ``(3n, m)`` [N]: one
        call of the factor for them all (a force on a fixed dof moves nothing, as in :meth:`solve`)."""
        u = np.zeros((3 * self.node_count, forces.shape[1]))
        u[self.free_dofs] = self.factor.solve(np.ascontiguousarray(forces[self.free_dofs]))
        return u

    def _unit_load_solution(self, nodes: np.ndarray) -> np.ndarray:
        """``(3n, 3k) float64`` [m/N] the displacement of every dof under a unit force along each axis on each of
        ``nodes`` ``(k,)`` in turn."""
        load_dofs = (3 * nodes[:, None] + np.arange(3)).ravel()
        forces = np.zeros((3 * self.node_count, load_dofs.size))
        forces[load_dofs, np.arange(load_dofs.size)] = 1.0
        return self.solve_columns(forces)

    def point_load_response(self, load_nodes: ArrayLike, load_forces: ArrayLike, *, output_nodes: ArrayLike,
                            out: np.ndarray | None = None) -> np.ndarray:
        """Displacements [m], ``(s, 3) float64``, of ``output_nodes`` ``(s,) int`` under forces ``load_forces``
        ``(k, 3)`` [N] on ``load_nodes`` ``(k,) int`` (no load elsewhere): u_out = Σ_j G_j[out] f_j with G_j =
        :meth:`influence` of node j.

        The same result as ``solve`` to round-off, at O(s k) per call once the loaded nodes' columns are cached
        (first use of a node costs one back-substitution). With ``out`` (an ``(s, 3)`` float64 C-contiguous array)
        the result is written there and nothing is allocated.
        """
        load_nodes = self._check_nodes(load_nodes, "load_nodes")
        load_forces = np.asarray(load_forces, dtype=np.float64)
        if load_forces.shape != (load_nodes.size, 3):
            raise SolverError(
                f"load_forces must have shape ({load_nodes.size}, 3) [N] to match load_nodes, got {load_forces.shape}"
            )
        if not np.all(np.isfinite(load_forces)):
            raise SolverError("load_forces contain non-finite values")
        output_nodes = self._check_nodes(output_nodes, "output_nodes")
        if out is None:
            out = np.zeros((output_nodes.size, 3))
        else:
            if out.shape != (output_nodes.size, 3) or out.dtype != np.float64 or not out.flags.c_contiguous:
                raise SolverError(f"out must be a C-contiguous ({output_nodes.size}, 3) float64 array")
            out[...] = 0.0
        for j in range(load_nodes.size):
            node = int(load_nodes[j])
            columns = self._columns.get(node)
            if columns is None:
                columns = self.influence(node)
            _accumulate_point_load(columns, load_forces[j], output_nodes, out)
        return out

    def patch_response(self, nodes: ArrayLike, weights: ArrayLike, force: ArrayLike, *, output_nodes: np.ndarray,
                       out: np.ndarray) -> np.ndarray:
        """Displacements [m] of ``output_nodes`` ``(s,) int`` into ``out`` ``(s, 3) float64`` (C-contiguous) under
        ``force`` ``(3,)`` [N] spread over ``nodes`` ``(k,) int`` with ``weights`` ``(k,)`` (node j carries w_j F;
        nodes may repeat): u_out = (Σ_j w_j G_j[out]) F, :meth:`point_load_response` with forces w_j F to round-off.

        A patch's response is learnt one direction of force per call (:class:`_PatchResponse`): its first use
        costs one single back-substitution, whatever k (k separate columns would cost k of them: the first grab
        of a wide patch), as do its second and third, after which a drag, which changes F on one patch, costs
        O(s) per call. The last patches are kept, as many as fit :data:`PATCH_CACHE_BYTES` (at least
        :data:`PATCH_CACHE`)."""
        nodes = np.ascontiguousarray(nodes, dtype=np.int64)
        weights = np.ascontiguousarray(weights, dtype=np.float64)
        key = (nodes.tobytes(), weights.tobytes())
        patch = self._patches.pop(key, None)
        if patch is None:
            patch = _PatchResponse(self, self._check_nodes(nodes, "nodes"), weights)
            if len(self._patches) >= max(PATCH_CACHE, PATCH_CACHE_BYTES // (72 * self.node_count)):
                self._patches.pop(next(iter(self._patches)))    # the least recently used
        self._patches[key] = patch
        force = np.asarray(force, dtype=np.float64)
        out[...] = 0.0
        _accumulate_point_load(patch.columns(force), force, output_nodes, out)
        return out

    def _unit_response(self, load: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """``(n, 3)`` displacements [m] under ``load`` ``(n,)`` (the share of each node) times ``direction``."""
        forces = load[:, None] * direction[None, :]
        u = np.zeros(3 * self.node_count)
        u[self.free_dofs] = self.factor.solve(np.ascontiguousarray(forces.ravel()[self.free_dofs]))
        return u.reshape(-1, 3)

    @property
    def cached_nodes(self) -> np.ndarray:
        """``(k,) int64`` sorted nodes whose K⁻¹ columns are cached."""
        return np.array(sorted(self._columns), dtype=np.int64)

    def clear_cache(self) -> None:
        """Drop the cached K⁻¹ columns (72 n bytes per node and per patch)."""
        self._columns.clear()
        self._patches.clear()

    # --- input checks -----------------------------------------------------------------------------------------

    def _check_node(self, node) -> int:
        if isinstance(node, (bool, np.bool_)) or not isinstance(node, (int, np.integer)):
            raise SolverError(f"node must be an integer node index, got {node!r}")
        if not 0 <= node < self.node_count:
            raise SolverError(f"node {node} is outside 0..{self.node_count - 1}")
        return int(node)

    def _check_nodes(self, nodes, name: str) -> np.ndarray:
        nodes = np.asarray(nodes)
        if nodes.ndim == 0:
            nodes = nodes.reshape(1)
        if nodes.ndim != 1 or not (nodes.dtype.kind in "iu" or nodes.size == 0):
            raise SolverError(f"{name} must be a 1-D integer array of node indices, got {nodes.dtype} {nodes.shape}")
        nodes = nodes.astype(np.int64, copy=False)
        if nodes.size and (nodes.min() < 0 or nodes.max() >= self.node_count):
            bad = np.flatnonzero((nodes < 0) | (nodes >= self.node_count))
            raise SolverError(
                f"{bad.size} {name} are outside 0..{self.node_count - 1} (first: {first_indices(nodes[bad])})"
            )
        return nodes


# --- construction helpers -------------------------------------------------------------------------------------


class _PatchResponse:
    """The response of a :class:`LinearFEM` to a force spread over a patch, learnt one force direction at a time.

    The response is linear in the force: it is known for every force in the span of the orthonormal directions
    solved so far. A force outside the span adds its orthogonal part as a direction; a force inside it still adds
    one direction orthogonal to the span, so the third call completes the basis and every later one is free. Each
    call costs at most one single-column back-substitution: a new grab acts at once, and the rest of the patch's
    response follows over the next two frames."""

    def __init__(self, fem: LinearFEM, nodes: np.ndarray, weights: np.ndarray):
        if weights.shape != nodes.shape or not np.all(np.isfinite(weights)):
            raise SolverError(f"weights must be ({nodes.size},) finite numbers, one per node, got {weights.shape}")
        self._fem = fem
        self._load = np.zeros(fem.node_count)
        np.add.at(self._load, nodes, weights)
        self._directions = np.zeros((0, 3))
        self._responses: list[np.ndarray] = []      # (n, 3) per direction
        self._columns: np.ndarray | None = None

    def columns(self, force: np.ndarray) -> np.ndarray:
        """``(n, 3, 3)`` the patch's columns, exact at least on ``force``'s direction (everywhere once complete)."""
        if self._columns is not None:
            return self._columns
        direction = force - self._directions.T @ (self._directions @ force)
        if np.linalg.norm(direction) <= 1e-12 * np.linalg.norm(force) or not np.any(direction):
            residual = np.eye(3) - self._directions.T @ self._directions   # F is known: add a missing direction
            direction = residual[np.argmax(np.linalg.norm(residual, axis=1))]
        direction = direction / np.linalg.norm(direction)
        self._directions = np.vstack([self._directions, direction])
        self._responses.append(self._fem._unit_response(self._load, direction))
        columns = np.ascontiguousarray(np.stack(self._responses, axis=2) @ self._directions)
        if len(self._responses) == 3:
            self._columns = columns
        return columns
