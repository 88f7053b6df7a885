"""The hybrid's quadratic volume (option ``element="quadratic"``, beyond the paper): 10-node tets on M_V drive every
M_S vertex.

The paper's M_V has linear tets and drives the control nodes only; the surface layer relaxes the vertices between
them. Measured against the converged contact references (docs/solvers.md), that layer carries no volume and M_V's
linear tets are too stiff under a concentrated load, so the hybrid's error is 1.3–2.7× the fine FEM's. The same M_V
with quadratic tets (:mod:`tissuesim.fem.quadratic`: a midside node on each edge) is as accurate as the fine FEM in
the contact protocol's median (0.160 against 0.158; not at R = 4 mm on three of the six models) while keeping a
third of its nodes as corners, and its field is curved between the control nodes, so every M_S vertex follows it:

* **Surface.** Vertex i lies in tet t_i at barycentric coordinates L_i (``hybrid.embedding_tet`` /
  ``embedding_barycentric``); its displacement is Σ_a N_a(L_i) u_a over the tet's ten nodes
  (:func:`~tissuesim.fem.quadratic.shape_values`). A control node is a corner: it takes that corner's displacement
  exactly.
* **Load.** By virtual work, a force f on vertex i loads node a with N_a(L_i) f (the transpose of the surface map):
  the load does the same work on M_V as on M_S.
* **Cost.** Linear material: each contact patch's response at every vertex is three back-substitutions (one per
  axis) when the patch first acts, kept for the patches acting last; a drag that changes the force costs one
  product per vertex. Finite strain: M_V's quadratic equilibrium under the same forces
  (:class:`~tissuesim.fem.nonlinear_quadratic.QuadraticNonlinearFEM`), Newton in a static solve and constant-factor
  iterations per step, as the paper's M_V.
* **Weight.** The consistent load of ρ g on the quadratic tets (:func:`~tissuesim.fem.quadratic.quadratic_body_force`),
  solved once.
* **Cuts.** M_V is not cut: the vertices of the triangles a cut changes are freed to the surface layer, the others
  keep following the field (:meth:`QuadraticField.extended` adds the new vertices' embedding rows).
"""

from __future__ import annotations

import copy
from collections import OrderedDict
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..fem.quadratic import QuadraticFEM, shape_values

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..mesh.tetmesh import TetMesh
    from .hybrid import HybridSolver
    from .load_set import Load

#: Contact patches whose responses are kept (pin-heads grabbed in turn).
KEPT_RESPONSES = 16
#: Up to this many loads act through their kept responses (a force changed costs one product per vertex); more
#: (a probe's contacts) are solved at once (one back-substitution).
KEPT_LOADS = 4
#: Memory [bytes] for the kept responses of single vertices (the probe's exact contact compliance).
KEPT_BYTES = 256 * 2 ** 20
#: The contact compliance's diagonal floor, as a fraction of its largest diagonal entry
#: (:meth:`QuadraticField.compliance`).
COMPLIANCE_FLOOR = 1e-9


class QuadraticField:
    """M_V's quadratic-tet displacement at every M_S vertex (see the module docstring).

    Args:
        hybrid_mesh: the :class:`~tissuesim.mesh.hybrid.HybridMesh` (M_V and each M_S vertex's embedding).
        youngs_modulus, poisson_ratio: the material [Pa], [-].
        fixed: ``(N,) bool`` the fixed nodes among M_V's corner and midside nodes
            (:func:`~tissuesim.solvers.near_field.fixed_corners`).
        material: ``"linear"``, ``"corotated"`` or ``"neo-hookean"``.
        springs: the attachments' springs over M_V's quadratic nodes (:func:`~.gravity.volume_springs` of
            :func:`surface_embedding`), or None.
        constant_load: ``(N, 3) float64`` [N] the loads that never change (the weight, the attachments' pull:
            :func:`~.gravity.volume_constant_load`), or None.
        topology: ``(elements, edges)`` of :func:`~tissuesim.fem.quadratic.quadratic_elements` for M_V, where
            already known.

    Attributes:
        fem: the :class:`~tissuesim.fem.quadratic.QuadraticFEM` of M_V.
        finite: its :class:`~tissuesim.fem.nonlinear_quadratic.QuadraticNonlinearFEM` (finite strain) or None.
        nodes: ``(n, 10) int64`` the ten M_V nodes each M_S vertex moves with; ``values`` ``(n, 10) float64`` [-]
            their shape functions there.
        constant_load: ``(N, 3) float64`` [N] the loads that never change, or None.
    """

    def __init__(self, hybrid_mesh: HybridMesh, *, youngs_modulus: float, poisson_ratio: float, fixed: np.ndarray,
                 material: str = "linear", springs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                 constant_load: np.ndarray | None = None,
                 topology: tuple[np.ndarray, np.ndarray] | None = None):
        volume = hybrid_mesh.volume
        self.fem = QuadraticFEM(volume, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                                fixed=lambda points: fixed, springs=springs, topology=topology)
        self.finite = None
        if material != "linear":
            from ..fem.nonlinear_quadratic import QuadraticNonlinearFEM

            self.finite = QuadraticNonlinearFEM(volume, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                                                fixed=lambda points: fixed, material=material, linear=self.fem)
        self.nodes, self.values = surface_embedding(hybrid_mesh, self.fem.elements)
        self.constant_load = constant_load
        self._constant_u = None
        self._responses: OrderedDict = OrderedDict()
        self._points: OrderedDict = OrderedDict()

    def extended(self, hybrid_mesh: HybridMesh, moved: np.ndarray) -> "QuadraticField":
        """This field for ``hybrid_mesh`` after a cut (M_V is not cut): the same volume and factor, the embedding
        rows of the vertices it appended and of those it ``moved`` ``(k,) int`` onto the cut read anew, no
        response kept (each was of the vertices before). A new object, so that a cut taken back keeps the old
        one."""
        field = copy.copy(self)
        rows = np.concatenate([np.asarray(moved, dtype=np.int64),
                               np.arange(len(self.nodes), len(hybrid_mesh.embedding_tet))])
        tets = np.asarray(hybrid_mesh.embedding_tet, dtype=np.int64)[rows]
        field.nodes = np.concatenate([self.nodes, np.zeros((len(hybrid_mesh.embedding_tet) - len(self.nodes), 10),
                                                           dtype=np.int64)])
        field.values = np.concatenate([self.values, np.zeros((len(field.nodes) - len(self.values), 10))])
        field.nodes[rows] = self.fem.elements[tets]
        field.values[rows] = shape_values(np.asarray(hybrid_mesh.embedding_barycentric)[rows])
        field._constant_u = None
        field._responses, field._points = OrderedDict(), OrderedDict()
        return field

    @property
    def node_count(self) -> int:
        """Corner and midside nodes of M_V."""
        return self.fem.node_count

    def surface(self, displacement: np.ndarray) -> np.ndarray:
        """``(n, 3) float64`` [m] every M_S vertex's displacement from M_V's ``(N, 3)`` [m]."""
        return np.einsum("ik,ikd->id", self.values, displacement[self.nodes])

    def volume_forces(self, loads: Sequence[Load]) -> np.ndarray:
        """``(N, 3) float64`` [N] M_V's nodal forces of ``loads`` (each with ``nodes``, ``shares``, ``force``), the
        weight included."""
        forces = np.zeros((self.node_count, 3)) if self.constant_load is None else self.constant_load.copy()
        for load in loads:
            shares = self.values[load.nodes] * np.asarray(load.shares)[:, None]          # (p, 10)
            np.add.at(forces, self.nodes[load.nodes].ravel(), shares.ravel()[:, None] * np.asarray(load.force))
        return forces

    def linear_displacement(self, loads: Sequence[Load]) -> np.ndarray:
        """``(n, 3) float64`` [m] every M_S vertex's small-strain displacement under ``loads`` and the weight."""
        if len(loads) > KEPT_LOADS:     # a probe's many contacts: one solve, cheaper than a response for each
            return self.surface(self.fem.solve(self.volume_forces(loads)))
        u = np.zeros((len(self.nodes), 3))
        for load in loads:
            u += self.response(load.nodes, load.shares) @ np.asarray(load.force, dtype=np.float64)
        if self.constant_load is not None:
            if self._constant_u is None:
                self._constant_u = self.surface(self.fem.solve(self.constant_load))
            u += self._constant_u
        return u

    def response(self, nodes: np.ndarray, shares: np.ndarray) -> np.ndarray:
        """``(n, 3, 3) float64`` [m/N]: ``[i, a, b]`` is M_S vertex i's displacement along a under a unit force along
        b shared as ``shares`` ``(p,)`` by the M_S vertices ``nodes`` ``(p,)``; computed once per patch."""
        nodes, shares = np.asarray(nodes, dtype=np.int64), np.asarray(shares, dtype=np.float64)
        key = (nodes.tobytes(), shares.tobytes())
        found = self._responses.get(key)
        if found is not None:
            self._responses.move_to_end(key)
            return found
        weights = np.zeros(self.node_count)
        np.add.at(weights, self.nodes[nodes].ravel(), (self.values[nodes] * shares[:, None]).ravel())
        columns = np.zeros((self.node_count, 3, 3))                 # (node, dof axis, force axis)
        for axis in range(3):
            columns[:, axis, axis] = weights
        solved = self.fem.solve_columns(columns.reshape(-1, 3)).reshape(self.node_count, 3, 3)
        response = np.einsum("ik,ikab->iab", self.values, solved[self.nodes])
        if len(self._responses) >= KEPT_RESPONSES:
            self._responses.popitem(last=False)
        self._responses[key] = response
        return response

    def compliance(self, nodes: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """``(k, k) float64`` [m/N] the small-strain normal compliance of M_S vertices ``nodes`` ``(k,)`` along
        ``normals`` ``(k, 3)``: ``[j, i]`` is vertex j's motion along its normal under a unit force on vertex i along
        its normal, plus :data:`COMPLIANCE_FLOOR` of its largest diagonal entry on the diagonal. The field has a
        finite number of dofs under a contact: more contact vertices than that (a wide probe on a coarse M_V) make
        the exact matrix singular, and the floor keeps it positive definite for the probe's Newton step (whose
        answer is the solver's own). Each vertex's M_V response to a unit force along each axis is kept
        (:meth:`point_responses`)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        normals = np.asarray(normals, dtype=np.float64)
        if nodes.size == 0:
            return np.zeros((0, 0))
        motion = self.point_compliance(nodes).reshape(nodes.size, 3, nodes.size, 3)     # (j, d, i, b)
        compliance = np.einsum("jd,jdib,ib->ji", normals, motion, normals)
        compliance[np.diag_indices(nodes.size)] += COMPLIANCE_FLOOR * np.abs(np.diagonal(compliance)).max()
        return compliance

    def point_compliance(self, nodes: np.ndarray) -> np.ndarray:
        """``(3k, 3k) float64`` [m/N] the small-strain compliance among M_S vertices ``nodes`` ``(k,)``, node-major:
        ``[3j + d, 3i + b]`` is vertex j's motion along d under a unit force on vertex i along b (through
        :meth:`point_responses`)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        at = self.point_responses(nodes)[:, self.nodes[nodes]]                   # (i, j, 10, 3, 3)
        motion = np.einsum("ja,ijadb->jdib", self.values[nodes], at)
        return motion.reshape(3 * nodes.size, 3 * nodes.size)

    def compliance_fits(self, count: int) -> bool:
        """Whether the responses of ``count`` vertices (what :meth:`compliance` keeps) fit :data:`KEPT_BYTES`: on a
        large M_V a wide probe's contacts would take gigabytes, and the probe then models the compliance."""
        return count * 9 * 8 * self.node_count <= KEPT_BYTES

    def point_responses(self, nodes: np.ndarray) -> np.ndarray:
        """``(k, N, 3, 3) float64`` [m/N]: M_V's displacement (node, axis) under a unit force along each axis on
        each M_S vertex of ``nodes``; those not kept yet are solved together in one factor call. At most
        :data:`KEPT_BYTES` of them are kept, the least recently asked for dropped first (never those of this
        call)."""
        asked = [int(i) for i in nodes.tolist()]
        missing = [i for i in dict.fromkeys(asked) if i not in self._points]
        if missing:
            columns = np.zeros((3 * self.node_count, 3 * len(missing)))
            for slot, node in enumerate(missing):
                for axis in range(3):
                    columns[3 * self.nodes[node] + axis, 3 * slot + axis] += self.values[node]
            solved = self.fem.solve_columns(columns).reshape(self.node_count, 3, len(missing), 3)
            for slot, node in enumerate(missing):
                self._points[node] = np.ascontiguousarray(solved[:, :, slot])
        for node in asked:
            self._points.move_to_end(node)
        result = np.stack([self._points[i] for i in asked])
        kept = max(len(set(asked)), KEPT_BYTES // (9 * 8 * self.node_count))
        while len(self._points) > kept:
            self._points.popitem(last=False)
        return result


def quadratic_field_of(solver: HybridSolver) -> QuadraticField:
    """The :class:`QuadraticField` of a hybrid ``solver`` built with ``element="quadratic"``: its M_V with a midside
    node on each edge, its material and supports, its attachments' springs and weight through the quadratic
    embedding."""
    from ..fem.quadratic import quadratic_elements
    from .gravity import volume_constant_load, volume_springs

    volume = solver.hybrid.volume
    elements, edges = quadratic_elements(volume.tets, volume.node_count)     # once: every part below reads it
    springs = volume_springs(solver, *surface_embedding(solver.hybrid, elements))
    constant = volume_constant_load(solver, volume, springs, quadratic=(elements, volume.node_count + len(edges)))
    return QuadraticField(solver.hybrid, youngs_modulus=solver.youngs_modulus, poisson_ratio=solver.poisson_ratio,
                          fixed=quadratic_supports(solver, edges), material=solver.material, springs=springs,
                          constant_load=constant, topology=(elements, edges))


def surface_embedding(hybrid_mesh: HybridMesh, elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(nodes (n, 10) int64, values (n, 10) float64)``: the ten quadratic nodes of each M_S vertex's embedding tet
    (``elements`` ``(m, 10)`` of :func:`~tissuesim.fem.quadratic.quadratic_elements`) and their shape functions
    there."""
    return (elements[np.asarray(hybrid_mesh.embedding_tet, dtype=np.int64)],
            shape_values(hybrid_mesh.embedding_barycentric))


def quadratic_supports(solver: HybridSolver, edges: np.ndarray) -> np.ndarray:
    """``(N,) bool`` the fixed nodes of ``solver``'s quadratic M_V, whose midside nodes sit on ``edges`` ``(e, 2)``:
    with the default bottom, every corner and midside node at or below its height (as every volume's); else the
    fixed corners and the midsides between them."""
    from ..mesh.regions import nodes_below
    from .near_field import fixed_corners

    volume = solver.hybrid.volume
    if not solver.fixed_from_height:
        return fixed_corners(volume, solver.fixed_volume, edges=edges)(None)
    points = np.concatenate([volume.points, midside_points(volume, edges)])
    fixed = np.zeros(len(points), dtype=bool)
    fixed[nodes_below(points, solver.fixed_height)] = True
    return fixed


def midside_points(volume: TetMesh, edges: np.ndarray) -> np.ndarray:
    """``(e, 3) float64`` [m] the midside nodes of ``volume`` on ``edges`` ``(e, 2)`` (of
    :func:`~tissuesim.fem.quadratic.quadratic_elements`, in its order: after the corners)."""
    return 0.5 * (volume.points[edges[:, 0]] + volume.points[edges[:, 1]])
