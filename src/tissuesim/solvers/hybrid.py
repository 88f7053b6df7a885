"""The paper's hybrid method (§6): linear FEM on the coarse volume M_V drives PBD on the fine surface M_S.

Per time step (§6.5):

1. (set-up) K of M_V is assembled and factorised once (:class:`~tissuesim.fem.linear.LinearFEM`), with the M_V
   nodes of the bottom fixed;
2. the load f on M_S node i is split over the three control nodes of the coarse triangle under i by its
   barycentric weights (§6.1, ``hybrid.coarse_triangle`` / ``coarse_barycentric``: linear interpolation as the
   triangle's shape functions); M_V's displacement at the control nodes comes from LinearFEM's fast path (cached
   columns of K⁻¹, §6.2), redone only when the load changes (an interactive drag changes it every frame);
3. eq 15 (v += f dt w on node i) and eq 16 (prediction) for M_S;
4. control nodes are set to rest + u (eq 17, first case; ``p'_i``), fixed M_S nodes to rest; every other node is
   projected by stretch (eq 9) and bending (eq 11) constraints, Gauss–Seidel (eq 17, second case);
5. eq 18 updates velocities and positions.

Steps 3–5 are the paper's projection (:mod:`tissuesim.layer.kernels`, one Numba call) with ``integrator="xpbd"`` or
``form="pbd"``. By default the layer between the control nodes is the material-derived elastic layer of
:class:`~tissuesim.solvers.surface_layer.SurfaceLayerSolver`, stepped by implicit Euler and solved exactly in quasi-static
solves (:mod:`tissuesim.layer.static`); steps 1–2 are the same for every form.

Options beyond the paper (each module named says more; docs/solvers.md measures them):

* ``warm_start``: when the load changes, the free M_S nodes move by the change of M_V's embedded displacement (as
  the ``embedded`` method), so the layer relaxes only the local detail: it changes the path, not the equilibrium.
* ``material="corotated"`` or ``"neo-hookean"``: M_V finite-strain (:class:`~tissuesim.fem.nonlinear.NonlinearFEM`)
  and the layer nonlinear (:mod:`tissuesim.layer.finite_layer`); ``solve_static`` converges both (Newton), ``step``
  relaxes M_V by :data:`VOLUME_ITERATIONS` iterations on K₀'s factor, warm-started: at rest, where the solve ends.
* ``gravity`` and ``attachments`` (:mod:`.gravity`): M_V carries the weight and the ligaments (their response solved
  once); the layer follows its control nodes, without a weight of its own.
* ``element="quadratic"`` (:mod:`.quadratic_field`): every M_S vertex follows M_V's quadratic-tet field; it takes
  every load, tool, material and support above and cuts (which free the changed triangles' vertices to the layer).
* ``near_field`` (:mod:`.near_field`): the M_S nodes near the contact follow the fine volume's quadratic-tet
  response, the layer relaxes the rest; it needs the fine volume and is switched off by a cut.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..fem.hyperelastic import MATERIALS
from ..errors import BoundaryConditionError, SolverError, warn
from .checks import check_element, flag
from .compliance import HybridCompliance
from .registry import register
from .embedded import map_embedded
from .finite_strain import carried_rest, finite_volume, move_supports, solve_volume
from .attachments import volume_pieces
from .gravity import volume_constant_load, volume_springs
from .surface_layer import SurfaceLayerSolver

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh

DEFAULT_WARM_START = True
#: Default per-step velocity damping: settles 1 N on the cube in 15 steps (0.2: 21; 0.1: 22), 20 N in 31 (0.2: 45),
#: the same equilibrium.
HYBRID_DAMPING = 0.4
#: M_V's iterations per step with a finite-strain material (:meth:`NonlinearFEM.relax
#: <tissuesim.fem.nonlinear.NonlinearFEM.relax>`): each costs one back-substitution of M_V.
VOLUME_ITERATIONS = 1


@register("hybrid")
class HybridSolver(HybridCompliance, SurfaceLayerSolver):
    """FEM on M_V + PBD/XPBD on M_S (paper §6; see the module docstring).

    Options (besides those of :class:`~tissuesim.solvers.surface_layer.SurfaceLayerSolver`):
        warm_start: move free nodes with the embedded FEM displacement when the load changes.
        near_field: None (default, the paper's method) or a distance W [m]: M_S nodes within W of the contact node
            follow the fine volume's quadratic-tet response (:mod:`.near_field`).
        element: ``"linear"`` (default, the paper's M_V) or ``"quadratic"`` (:mod:`.quadratic_field`).

    Attributes:
        fem: the :class:`~tissuesim.fem.linear.LinearFEM` of M_V.
        fixed_volume: ``(k,) int32`` fixed M_V nodes.
        control_displacement: ``(c,) (c, 3) float64`` M_V displacement of the control nodes [m], in the order of
            ``hybrid.control``.
        quadratic_field: the :class:`~.quadratic_field.QuadraticField` of ``element="quadratic"``, else None.
        embedding_tet, embedding_weights: ``(n,) int64``, ``(n, 4) float64`` each M_S vertex's M_V tet and its
            barycentric weights there (the warm start's embedding).
        output_displacement: ``(o, 3) float64`` [m] M_V's displacement at the nodes the surface reads, control
            nodes first; ``output_slot`` ``(N,) int64`` each M_V node's row there (−1: none).
        warm_positions, warm_target: ``(n, 3) float64`` [m] rest + the embedded displacement applied so far, and the
            one M_V's answer now gives; ``warm_delta`` ``(n, 3)`` [m] their difference, a workspace.
        volume_stale: M_V's answer is due again (loads changed); ``volume_settled``: finite strain, M_V at rest.
        near_window, near_window_slots: ``(w,) int64`` the near field's prescribed M_S nodes and their rows in
            ``prescribed``; ``near_window_node``: the contact node they surround (−1: none).
    """

    label = "hybrid FEM + PBD"
    short_label = "Ours"
    colour = "tab:red"
    line_style = "-"
    in_paper = True
    free_scalars = {"xpbd": ("thickness_ratio", 0.6, 4.0), "pbd": ("stiffness", 1e-3, 1.0)}

    materials = MATERIALS       # every material of fem.hyperelastic: a volume takes finite strain
    cut_carrier = "tissuesim.solvers.surface_layer_cut:HybridCut"
    body_on_layer = False       # M_V carries the weight and the attachments; the layer follows it
    # where M_V's output and the warm start's embedded field were last brought to, and whether they are due again, so
    # the first step after a restore moves the surface as it would have (a pending warm-start move included); the
    # near field's window as it was
    kept_arrays = (*SurfaceLayerSolver.kept_arrays, "output_displacement", "warm_positions", "warm_target")
    kept_values = (*SurfaceLayerSolver.kept_values, "volume_stale", "volume_settled", "near_window",
                   "near_window_slots", "near_window_node")

    def __init__(self, hybrid_mesh: HybridMesh, *, warm_start: bool = DEFAULT_WARM_START,
                 damping: float = HYBRID_DAMPING, near_field: float | None = None, element: str = "linear",
                 **options: object):
        super().__init__(hybrid_mesh, damping=damping, **options)
        from ..fem.linear import LinearFEM

        h = hybrid_mesh
        self.warm_start = flag("warm_start", warm_start)
        self.element = check_element(element, near_field)
        volume = h.volume
        control = np.asarray(h.control, dtype=np.int64)
        control_volume = np.asarray(h.control_volume, dtype=np.int64)
        self.fixed_volume = self.fixed_volume_nodes(volume.points, self.surface_to_volume())
        # §6.1: M_S vertex → the 3 M_V nodes of its coarse triangle (loads and attachments reach M_V through it).
        coarse_nodes = np.asarray(h.coarse_surface.triangles, dtype=np.int64)
        coarse_volume = np.asarray(h.coarse_volume_nodes, dtype=np.int64)     # control_volume until a cut
        self.load_volume_nodes = coarse_volume[coarse_nodes[np.asarray(h.coarse_triangle, dtype=np.int64)]]
        self.load_weights = np.asarray(h.coarse_barycentric, dtype=np.float64)
        springs = volume_springs(self, self.load_volume_nodes, self.load_weights)
        self.fem = LinearFEM(volume, youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
                             fixed=self.fixed_volume, springs=springs)
        #: ``(N, 3)`` M_V's constant load [N] (weight, attachments' pull; :mod:`.gravity`) or None; its response.
        self._constant_load = volume_constant_load(self, volume, springs)
        # Prescribed M_S nodes: control nodes (FEM positions) first, then fixed non-control nodes (rest).
        is_control = np.zeros(self.node_count, dtype=bool)
        is_control[control] = True
        pinned = self.fixed[~is_control[self.fixed]].astype(np.int64)
        self._held = np.concatenate([control, pinned])
        self._set_prescribed(self._held)
        self.finite = None if self.element == "quadratic" else finite_volume(self, volume, self.fem)
        #: ``(N, 3) float64`` the volume's finite-strain displacement [m] (zero with the linear material).
        self.volume_displacement = np.zeros((volume.node_count, 3))
        self._volume_forces = np.zeros((volume.node_count, 3))
        self.volume_settled = True
        self._init_near_field(near_field)
        self.quadratic_field = None
        if self.element == "quadratic":
            self._init_quadratic()
        self.control = control
        self.control_count = control.size
        # M_V nodes whose displacement a step needs: control nodes first, then (warm start) the embedding tets.
        tets = volume.tets.astype(np.int64)
        self.embedding_tet = np.ascontiguousarray(h.embedding_tet, dtype=np.int64)
        self._tets = tets
        self.embedding_weights = np.ascontiguousarray(h.embedding_barycentric, dtype=np.float64)
        extra = (np.setdiff1d(np.unique(tets[self.embedding_tet]), control_volume) if self.warm_start
                 else np.zeros(0, int))
        self.output_nodes = np.concatenate([control_volume, extra]).astype(np.int64)
        self.output_slot = np.full(volume.node_count, -1, dtype=np.int64)
        self.output_slot[self.output_nodes] = np.arange(self.output_nodes.size)
        self.output_displacement = np.zeros((self.output_nodes.size, 3))
        self.control_displacement = self.output_displacement[: self.control_count]  # a view: updated with it
        self.warm_positions = np.array(self.rest_positions)  # rest + embedded displacement now applied (warm start)
        self.warm_target = np.array(self.rest_positions)
        self.warm_delta = np.zeros_like(self.warm_positions)
        self._constant_u = None if self._constant_load is None or self.finite is not None else (
            self.fem.solve(self._constant_load))
        constant = self._constant_load if self.quadratic_field is None else self.quadratic_field.constant_load
        self.volume_stale = constant is not None    # the first step moves M_V under its weight

    def _pieces(self) -> np.ndarray:
        """M_V's pieces: the volume holds the surface together where a cut splits it."""
        h = self.hybrid
        return volume_pieces(h.volume, h.volume.tets[np.asarray(h.embedding_tet, dtype=np.int64), 0])

    def _init_near_field(self, near_field) -> None:
        self.near_field, self._near, self.near_window_node = None, None, -1
        self.near_window = self.near_window_slots = np.zeros(0, dtype=np.int64)
        if near_field is None:
            return
        from .near_field import near_field_of

        self._near, self.near_field = near_field_of(self, near_field), float(near_field)
        self._is_free, self._is_pinned = np.ones(self.node_count, dtype=bool), np.zeros(self.node_count, dtype=bool)
        self._is_free[self._held] = False
        self._is_pinned[self.fixed] = True

    def _init_quadratic(self) -> None:
        """``element="quadratic"``: M_V's quadratic field (:mod:`.quadratic_field`) prescribes every M_S vertex; it
        carries the weight and the finite strain in place of the linear M_V's."""
        from .quadratic_field import quadratic_field_of

        self.quadratic_field = quadratic_field_of(self)
        self.finite = self.quadratic_field.finite
        self._constant_load = None
        self.volume_displacement = np.zeros((self.quadratic_field.node_count, 3))
        self._volume_forces = np.zeros((self.quadratic_field.node_count, 3))
        self._held = np.arange(self.node_count, dtype=np.int64)
        self._set_prescribed(self._held)

    @property
    def static(self) -> bool:
        """Whether a step is the static answer under the loads acting: with ``element="quadratic"``, the linear
        material and every vertex on M_V's field (none freed by a cut)."""
        return (self.quadratic_field is not None and self.finite is None
                and self.prescribed.size == len(self.rest_positions))

    def before_first_cut(self) -> None:
        """The fine volume is not cut: a cut switches the near field off, back to the paper's prescribed nodes."""
        if self.near_field is None:
            return
        warn(f"cutting switches the hybrid's near field (W = {1e3 * self.near_field:g} mm) off: its fine "
             "volume is not cut; the paper's hybrid carries on")
        self.near_field, self._near = None, None
        self.near_window = self.near_window_slots = np.zeros(0, dtype=np.int64)
        self._set_prescribed(self._held)
        self.volume_stale = True

    # The FEM part is redone only when the load changes: with a constant load it is constant (linear statics).
    def _on_load_changed(self) -> None:
        super()._on_load_changed()
        self.volume_stale = True

    def _on_reset(self) -> None:
        self.warm_positions[:] = self.rest_positions
        self.volume_displacement[:] = 0.0 if self.finite is None else carried_rest(self)
        if self._near is not None:
            self._near.reset()
        self._update_fem()

    def _move_fixed(self, positions: np.ndarray) -> None:
        if self._near is not None:
            raise BoundaryConditionError("the near field's fine volume keeps its supports at rest: drop near_field "
                                         "to move the fixed set")
        matrix, shift = move_supports(self, positions)
        # the surface layer goes with its volume (its warm start then adds nothing), so its first steps need not
        # find the carried body from the one left behind
        for carried in (self.state.positions, self.warm_positions):
            carried[:] = carried @ matrix.T + shift
        self.volume_stale = True

    def _finite_response(self, exact: bool) -> None:
        """M_V's finite-strain displacement of the output nodes into ``output_displacement``: converged (``exact``)
        or relaxed by :data:`VOLUME_ITERATIONS` iterations from the last one."""
        forces = self._volume_forces
        forces[:] = 0.0
        if self._loads:
            np.add.at(forces, *self._coarse_loads())
        if self._constant_load is not None:
            forces += self._constant_load
        if exact:
            self.volume_displacement = solve_volume(self, forces)
            self.volume_settled = True
        else:
            self.volume_settled = self.finite.relax(forces, self.volume_displacement, iterations=VOLUME_ITERATIONS)
        self.output_displacement[:] = self.volume_displacement[self.output_nodes]
        pinned = self.prescribed[self.control_count:]    # the fixed nodes that are not control nodes
        self.targets[self.control_count:] = self.fixed_positions[np.searchsorted(self.fixed, pinned)]

    def _coarse_loads(self) -> tuple[np.ndarray, np.ndarray]:
        """§6.1: ``(M_V nodes (3p,), forces (3p, 3) [N])``, each loaded M_S node's share of its load split over
        the nodes of its coarse triangle by its barycentric weights, every load in turn."""
        split = [self._coarse_split(load) for load in self._loads]
        forces = [shares[:, None] * load.force[None, :] for (_, shares), load in zip(split, self._loads)]
        return np.concatenate([nodes for nodes, _ in split]), np.concatenate(forces)

    def _coarse_split(self, load) -> tuple[np.ndarray, np.ndarray]:
        """``(M_V nodes (3k,), shares (3k,))`` of one load's patch (§6.1's barycentric split)."""
        return (self.load_volume_nodes[load.nodes].ravel(),
                (self.load_weights[load.nodes] * load.shares[:, None]).ravel())

    def _update_fem(self, *, exact: bool = False) -> None:
        if self.quadratic_field is not None:
            self._quadratic_update(exact)
            return
        if self.finite is not None:
            self._finite_response(exact)
        else:
            self._linear_response()
        if self._near is not None:
            self._prescribe_window(self._loads[0].node if self._loads else -1)
        c = self.control_count
        np.add(self.rest_positions[self.control], self.output_displacement[:c], out=self.targets[:c])
        if self._near is not None and self.near_window.size:
            self._prescribe_near(exact)
        if self.warm_start:
            map_embedded(self.rest_positions, self._tets, self.embedding_tet, self.embedding_weights, self.output_slot,
                         self.output_displacement, self.warm_target)
            # Move every node by the change of the embedded field (exactly zero when it did not change); the
            # kernel then overrides the prescribed nodes.
            np.subtract(self.warm_target, self.warm_positions, out=self.warm_delta)
            self.state.positions += self.warm_delta
            self.warm_positions[:] = self.warm_target
        self.volume_stale = False

    def _quadratic_update(self, exact: bool) -> None:
        """``element="quadratic"``: the prescribed vertices' targets are M_V's quadratic field under the loads and
        the weight (finite strain: converged when ``exact``, else :data:`VOLUME_ITERATIONS` iterations toward it),
        the fixed ones where the support holds them; the free ones (at a cut) move with the field's change."""
        field = self.quadratic_field
        if self.finite is None:
            u = field.linear_displacement(self._loads)
        else:
            forces = field.volume_forces(self._loads)
            if exact:
                self.volume_displacement = solve_volume(self, forces)
                self.volume_settled = True
            else:
                self.volume_settled = self.finite.relax(forces, self.volume_displacement,
                                                         iterations=VOLUME_ITERATIONS)
            u = field.surface(self.volume_displacement)
        carried = np.add(self.rest_positions, u, out=self.warm_target)
        carried[self.fixed] = self.fixed_positions
        self.state.positions += carried - self.warm_positions
        self.warm_positions[:] = carried
        self.targets[:] = carried[self.prescribed]
        self.output_displacement[: self.control_count] = u[self.control]
        self.volume_stale = False

    def _linear_response(self) -> None:
        """M_V's displacement of the output nodes into ``output_displacement``: the sum of each load's patch response
        (linear)."""
        self.output_displacement[:] = 0.0
        one = np.empty_like(self.output_displacement) if len(self._loads) > 1 else self.output_displacement
        for load in self._loads:
            self.fem.patch_response(*self._coarse_split(load), load.force, output_nodes=self.output_nodes, out=one)
            if one is not self.output_displacement:
                self.output_displacement += one
        if self._constant_u is not None:
            self.output_displacement += self._constant_at_outputs()

    def _constant_at_outputs(self) -> np.ndarray:
        """``(s, 3)`` the constant load's response at the output nodes [m], kept while they stay the same (a cut
        that releases control nodes reorders them), so a drag allocates nothing for it."""
        nodes, values = getattr(self, "_constant_out", (None, None))
        if nodes is not self.output_nodes:
            values = self._constant_u[self.output_nodes]
            self._constant_out = (self.output_nodes, values)
        return values

    def _attached_positions(self) -> np.ndarray:
        """Where the attachments hold M_V: rest + the displacement interpolated on each node's coarse triangle (the
        quadratic M_V: its field at the vertex)."""
        nodes = self.attached_nodes
        if self.quadratic_field is not None:
            return self.warm_positions[nodes]
        u = self.output_displacement[self.output_slot[self.load_volume_nodes[nodes]]]            # (p, 3 nodes, 3)
        return self.rest_positions[nodes] + np.einsum("pj,pjk->pk", self.load_weights[nodes], u)

    def _admit(self, load) -> None:
        if self._near is not None and self._loads:
            raise SolverError("the near field follows one contact: remove the load acting first (remove_load), or "
                              "replace it (set_load)")

    def _prescribe_near(self, exact: bool) -> None:
        """The window's targets: the near field's displacement under the load (converged when ``exact``, else
        :data:`VOLUME_ITERATIONS` iterations toward it; still moving means M_V's part is not settled either)."""
        iterations = None if exact or self._near.finite is None else VOLUME_ITERATIONS
        load = self._loads[0]
        self.targets[self.near_window_slots] = self.rest_positions[self.near_window] + self._near.displacement(
            load.nodes, load.shares, load.force, self.near_window, iterations=iterations)
        if iterations is not None and not self._near.settled:
            self.volume_settled = False

    def _prescribe_window(self, node: int) -> None:
        """The window: the M_S nodes within W of the contact node but the pinned ones. Its control nodes keep
        their slots (their targets become the fine response); the others are prescribed after the held nodes."""
        if node == self.near_window_node:    # a drag changes the force, not the window
            return
        self.near_window_node = node
        rest = self.rest_positions
        if node < 0:
            window = np.zeros(0, dtype=np.int64)
        else:
            window = np.flatnonzero((np.linalg.norm(rest - rest[node], axis=1) <= self.near_field)
                                    & ~self._is_pinned)
        added = window[self._is_free[window]]
        self._set_prescribed(np.concatenate([self._held, added]))
        slot = np.full(self.node_count, -1, dtype=np.int64)
        slot[self.prescribed] = np.arange(self.prescribed.size)
        self.near_window, self.near_window_slots = window, slot[window]

    def _prepare_static(self) -> None:
        if self.volume_stale or not self.volume_settled:
            self._update_fem()

    def _finite_start(self, positions: np.ndarray) -> None:
        """The finite-strain layer starts from the surface carried by M_V's finite-strain displacement (its
        embedding, as ``warm_start``), much closer than the linear layer's answer once M_V turns."""
        if self.warm_start:
            map_embedded(self.rest_positions, self._tets, self.embedding_tet, self.embedding_weights, self.output_slot,
                         self.output_displacement, positions)
            positions[self.prescribed] = self.targets

    def _static_solve(self) -> int | None:
        if self.finite is not None:
            self._update_fem(exact=True)
        return super()._static_solve()

    def _step(self, dt: float) -> None:
        self._prepare_static()
        super()._step(dt)
