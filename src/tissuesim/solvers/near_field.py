"""The hybrid's near field (option ``near_field``, beyond the paper): quadratic FEM on the fine volume near a contact.

The coarse M_V is too stiff under a concentrated load, and the surface layer between its control nodes only
partly makes up for it (docs/solvers.md). With ``near_field=W`` the M_S nodes within W [m] of the contact node (at
rest) are prescribed, like control nodes, to the response of quadratic (10-node) tets on the fine volume (TetGen's
mesh of M_S, the ``fem`` method's mesh), and the layer relaxes the rest between them and the control nodes. The
structure stays §6's: FEM drives prescribed nodes, the layer relaxes the others; only the prescribed set grows near
the contact.

* **Load.** The solvers' nodal forces f_i (:func:`tissuesim.loads.contact_patch`) as a traction linear over M_S's
  triangles, with density f_i / a_i at node i (a_i: its lumped area), which lumps back to exactly f_i. A point
  force on a quadratic tet's corner is singular (and loads the wrong nodes: a uniform traction puts nothing on the
  corners), so the force is given its node's area.
* **Cost.** One factorisation of the quadratic fine volume when the solver is built, and one back-substitution per
  axis when the contact node or radius changes (cached for the last one); a change of the force alone is three
  3×3 products per window node.
* **Finite strain.** With ``material="corotated"`` or ``"neo-hookean"`` the window follows the equilibrium of the
  same quadratic volume (:class:`~tissuesim.fem.nonlinear_quadratic.QuadraticNonlinearFEM`) under the same traction as a
  dead load, warm-started from the last answer for the same contact (a drag changes only the force):
  converged by Newton (one factorisation per iteration), or approached by iterations with the constant factor of
  K₀ (the interactive path); :meth:`NearField.displacement` gives either, and the linear response, alike. On the
  default cube's fine volume (14.5k nodes, 2 cores) a 1 N pull from rest takes 11 Newton iterations (15 s
  neo-Hookean, 40 s corotated); a constant-factor iteration about 0.1 s neo-Hookean, 0.7 s corotated (its SVD per
  quadrature point).
* **Validity.** The fine volume is not cut: a cut switches the near field off (with a warning).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SolverError
from ..fem.hyperelastic import check_material
from ..loads import lumped_areas

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..mesh.tetmesh import TetMesh
    from .hybrid import HybridSolver

#: W [m] of the contact protocol's ``hybrid-near`` (``make_solver("hybrid", mesh, near_field=W)``), chosen on its
#: calibration row (cube, 1 N, R = 4 mm): relative RMSE 0.254 / 0.190 / 0.187 / 0.183 at W = 8 / 12 / 16 / 24 mm,
#: flat beyond 12 mm; the 50 samples reach 22 mm from the contact there.
NEAR_FIELD_WINDOW = 0.015


class NearField:
    """The fine volume's quadratic-tet response of M_S nodes to a contact load.

    Args:
        hybrid_mesh: a :class:`~tissuesim.mesh.hybrid.HybridMesh` built with its fine volume.
        youngs_modulus, poisson_ratio: the material [Pa], [-].
        fixed: the fixed nodes among the quadratic volume's corner and midside nodes, as
            :class:`~tissuesim.fem.quadratic.QuadraticFEM` takes them (:func:`fixed_corners` for a list of fixed
            corner nodes).
        material: ``"linear"`` (small strain), ``"corotated"`` or ``"neo-hookean"``.

    Attributes:
        surface_nodes: ``(n,) int64`` fine-volume node of each M_S vertex.
        lumped_area: ``(n,) float64`` [m²] each M_S vertex's third of its triangles' areas.
        finite: the :class:`~tissuesim.fem.nonlinear_quadratic.QuadraticNonlinearFEM` of a finite-strain material
            (sharing :attr:`fem`'s factor), or None for ``"linear"``.
        last_iterations: Newton iterations of the last converged finite-strain :meth:`displacement` (0: its warm
            start was already in equilibrium).
        settled: whether the last :meth:`displacement` is the equilibrium (always, but after constant-factor
            iterations that have not reached it yet): a stepping caller repeats them until it is.
    """

    def __init__(self, hybrid_mesh: HybridMesh, *, youngs_modulus: float, poisson_ratio: float, fixed: np.ndarray,
                 material: str = "linear"):
        from ..fem.quadratic import QuadraticFEM

        material = check_material(material)
        if hybrid_mesh.fine_volume is None or hybrid_mesh.fine_surface_nodes is None:
            raise SolverError("near_field needs the fine volume mesh, but this hybrid mesh was built without it; "
                              "rebuild with HybridMesh.build(surface, fine_volume=True) or drop near_field")
        self.fem = QuadraticFEM(hybrid_mesh.fine_volume, youngs_modulus=youngs_modulus,
                                poisson_ratio=poisson_ratio, fixed=fixed)
        self.finite = None
        if material != "linear":
            from ..fem.nonlinear_quadratic import QuadraticNonlinearFEM

            self.finite = QuadraticNonlinearFEM(hybrid_mesh.fine_volume, youngs_modulus=youngs_modulus,
                                                poisson_ratio=poisson_ratio, fixed=fixed, material=material,
                                                linear=self.fem)
        self.last_iterations = 0
        self.settled = True
        self._contact = None     # (load key, weights (N,), last displacement (N, 3) [m]) of the finite solve
        surface = hybrid_mesh.surface
        self.surface_nodes = np.asarray(hybrid_mesh.fine_surface_nodes, dtype=np.int64)
        self._triangles = np.asarray(surface.triangles, dtype=np.int64)
        self.lumped_area = lumped_areas(surface.vertices, self._triangles)
        self._key = None
        self._response = np.zeros((0, 3, 3))

    def response(self, load_nodes: np.ndarray, load_shares: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """``(k, 3, 3) float64`` [m/N]: ``[j, a, b]`` is M_S node ``nodes[j]``'s displacement along a under a unit
        force along b shared as ``load_shares`` ``(p,)`` by the M_S nodes ``load_nodes`` ``(p,)``."""
        key = (np.asarray(load_nodes).tobytes(), np.asarray(load_shares).tobytes(), np.asarray(nodes).tobytes())
        if key != self._key:
            weights = self._load_weights(np.asarray(load_nodes, dtype=np.int64), np.asarray(load_shares, float))
            fine = self.surface_nodes[np.asarray(nodes, dtype=np.int64)]
            response = np.empty((len(fine), 3, 3))
            forces = np.zeros((self.fem.node_count, 3))
            for axis in range(3):
                forces[:] = 0.0
                forces[:, axis] = weights
                response[:, :, axis] = self.fem.solve(forces)[fine]
            self._key, self._response = key, response
        return self._response

    def displacement(self, load_nodes: np.ndarray, load_shares: np.ndarray, force: ArrayLike, nodes: np.ndarray, *,
                     iterations: int | None = None) -> np.ndarray:
        """``(k, 3) float64`` [m]: M_S nodes ``nodes``' displacement under ``force`` ``(3,)`` [N] shared as
        ``load_shares`` ``(p,)`` by the M_S nodes ``load_nodes`` ``(p,)``. Linear: exactly ``response(...) @ force``
        (``iterations`` unused). Finite strain, from the last answer for the same contact (from rest for a new
        one): with ``iterations=None`` the converged equilibrium (Newton; raises
        :class:`~tissuesim.fem.nonlinear.UnstableLoadError` for a dead load with no stable equilibrium, keeping the
        last answer as the next start); with an int, that many constant-K₀ iterations toward it (the interactive
        path: back-substitutions with the factor built at start-up, no refactorisation)."""
        force = np.asarray(force, dtype=np.float64)
        if force.shape != (3,) or not np.all(np.isfinite(force)):
            raise SolverError(f"the near field's force must be a finite (3,) vector [N], got shape {force.shape}")
        if self.finite is None:
            return self.response(load_nodes, load_shares, nodes) @ force
        key = (np.asarray(load_nodes).tobytes(), np.asarray(load_shares).tobytes())
        if self._contact is None or self._contact[0] != key:   # a new contact starts from rest
            weights = self._load_weights(np.asarray(load_nodes, dtype=np.int64), np.asarray(load_shares, float))
            self._contact = (key, weights, np.zeros_like(self.finite.rest))
        _, weights, u = self._contact
        forces = weights[:, None] * force[None, :]
        if iterations is None:
            u = self.finite.solve(forces, initial=u)
            self.last_iterations, self.settled = self.finite.last_iterations, True
        else:
            self.settled = self.finite.relax(forces, u, iterations=iterations)
        self._contact = (key, weights, u)
        return u[self.surface_nodes[np.asarray(nodes, dtype=np.int64)]]

    def reset(self) -> None:
        """Forget the last finite-strain answer: the next :meth:`displacement` starts from rest (as M_V does after a
        solver's reset)."""
        self._contact = None

    def _load_weights(self, load_nodes: np.ndarray, load_shares: np.ndarray) -> np.ndarray:
        density = np.zeros(len(self.lumped_area))
        density[load_nodes] = load_shares / self.lumped_area[load_nodes]
        loaded = np.flatnonzero(np.any(density[self._triangles] != 0.0, axis=1))
        triangles = self._triangles[loaded]
        return self.fem.linear_traction_weights(self.surface_nodes[triangles], density[triangles])


def fixed_corners(volume: TetMesh, fixed_volume: np.ndarray, *,
                  edges: np.ndarray | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """The ``fixed`` of the quadratic elements on ``volume`` (a :class:`~tissuesim.mesh.tetmesh.TetMesh`) whose fixed
    corner nodes are ``fixed_volume`` ``(k,) int``: those corners, and every midside node whose edge has both ends
    fixed. ``edges``: the midside nodes' edges, ``(e, 2) int64`` of
    :func:`~tissuesim.fem.quadratic.quadratic_elements`, where already known."""
    from ..fem.quadratic import quadratic_elements

    if edges is None:
        edges = quadratic_elements(volume.tets, volume.node_count)[1]
    corners = np.zeros(volume.node_count, dtype=bool)
    corners[np.asarray(fixed_volume, dtype=np.int64)] = True
    mask = np.concatenate([corners, corners[edges[:, 0]] & corners[edges[:, 1]]])
    return lambda points: mask


def near_field_of(solver: HybridSolver, distance: object) -> NearField:
    """The :class:`NearField` of a hybrid ``solver`` built with ``near_field=distance`` [m], on its fine volume with
    the solver's material and supports; SolverError where the option cannot be taken (gravity or attachments, a
    distance that is not a positive number, a cut mesh)."""
    from functools import partial

    from ..mesh.regions import nodes_below

    if solver.gravity is not None or solver.attachments:
        raise SolverError("near_field does not take gravity or attachments yet: its fine volume responds to the "
                          "contact's load alone; drop near_field, or the gravity and attachments")
    if isinstance(distance, bool) or not isinstance(distance, (int, float, np.floating, np.integer)) \
            or not np.isfinite(distance) or distance <= 0:
        raise SolverError(f"near_field must be None or a positive, finite distance in metres (e.g. 0.015), "
                          f"got {distance!r}")
    if solver.hybrid.info.get("cuts"):
        raise SolverError("near_field needs an uncut mesh: its fine volume is not cut, so it does not describe "
                          "this surface; drop near_field on a cut mesh")
    fine = solver.hybrid.fine_volume
    if solver.fixed_from_height or fine is None:  # as every solver's volume: the nodes at or below the height
        fixed = partial(nodes_below, height=solver.fixed_height)
    else:
        fixed = fixed_corners(fine, solver.fixed_volume_nodes(
            fine.points, np.asarray(solver.hybrid.fine_surface_nodes, dtype=np.int64)))
    return NearField(solver.hybrid, youngs_modulus=solver.youngs_modulus, poisson_ratio=solver.poisson_ratio,
                     material=solver.material, fixed=fixed)
