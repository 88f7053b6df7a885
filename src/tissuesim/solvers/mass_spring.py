"""Mass-spring model (MSM) on the fine surface M_S: the paper's third comparison method (§8.3, ref 17).

Springs:

* **stretch**: one spring per M_S edge (i, j);
* **bending**: one spring per interior edge across its two opposite vertices (P3, P4 of the hinge of eq 10–12),
  which resists folding of the two triangles about the edge.

Stiffness from the material (van Gelder 1998, "Approximate simulation of elastic membranes by triangulated spring
meshes", the formula Lloyd et al. 2007 also start from): a linear-elastic membrane of Young's modulus E and
thickness h triangulated into springs is best matched by

    k_ij = E h Σ_{T ∋ ij} A_T / |ij|²           [N/m]

summing over the (one or two) triangles T adjacent to the spring. We give the bending spring across P3 P4 the same
formula over the hinge's two triangles (the spring is the diagonal of the quad they form), so both kinds scale with
E h. The thickness follows the mesh, h = β |ij| (β × M_S's edge length as built on a spring a cut made), with the
dimensionless ``thickness_ratio`` β the method's one free scalar, calibrated against the fine FEM (see
:mod:`tissuesim.solvers.calibrated`). Spring forces are f = k (|d| − l0) d/|d| (Hooke along the spring).

Quasi-static solves step until the remaining motion is negligible (:meth:`Solver.solve_static`): the state where
symplectic Euler stops is where the spring forces balance the load exactly, whatever dt, the masses or the damping.
(A static Newton solve, as the xpbd layer has, does not work here: springs alone have no stiffness normal to a flat
patch, so its matrix is singular.)

Masses: the body's mass (density × enclosed volume) spread over the surface nodes in proportion to their lumped
area (1/3 of each adjacent triangle's area): the surface stands for the whole body, as in the paper's MSM.

Inversion: a spring network has no restoring force for a triangle turned inside out (it is an equilibrium of the
springs too), so a large load that inverts triangles leaves them inverted after release (measured before this check:
20 N on the sphere for 300 steps, then 3000 steps without load, left 149 mm of deformation and 1597 flipped
triangles). A step that inverts a triangle (its normal against its rest normal; one O(m) pass) therefore raises
:class:`~tissuesim.errors.InversionError`, and ``reset()`` returns to rest. On a cut surface a flap may swing past a
right angle as a whole, each hinge of it bent far less (measured: a two-triangle flap on a lip turned 90° under 0.3 N
with folds of 34° and 52°); its springs bring it back, so a triangle with a corner on the cut's open edge is inside
out only if it is also folded more than a right angle against a neighbour (:func:`swung_flaps`).

Gravity and attachments (:mod:`.gravity`): every unpinned node gets the acceleration g (its weight m_i g on the
lumped mass), and an attached node the force k_i (a_i − x_i) of its spring, inside the kernel; the stability bound
below counts the springs to anchors. Under its weight the network rests where its path takes it: a flat face of
springs has no first-order stiffness across it, so the rest state depends on dt (measured on the cube: 1.4 mm apart
for dt = 5 and 20 ms, of a 2.9 mm sag), although the weight is balanced wherever it rests.

Integration: semi-implicit (symplectic) Euler, stable for a substep h_s ≤ 2/ω_max. ω_max² is bounded at set-up by
Gershgorin's theorem on M^{-1/2} K M^{-1/2} (block norms: a spring of stiffness k between i, j adds k w_i to row i's
diagonal block and k √(w_i w_j) off it; a stretched spring's tangent never exceeds k), and each step runs
``ceil(dt / (SAFETY · 2/ω_max))`` substeps inside one Numba call. Damping removes the same fraction of velocity per
step as in the other methods, spread evenly over the substeps.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from ..errors import InversionError, SolverError
from ..loads import lumped_areas
from ..mesh.surface import SurfaceMesh
from ..layer.compliance import thickness_lengths
from .base import Solver
from .checks import positive_number, time_step
from .registry import register

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh

#: Most substeps one step may take: beyond it the step is refused (a stiff material at a large dt would otherwise
#: run for hours: 5.7e7 substeps at E = 1e15 Pa).
MAX_SUBSTEPS = 10000

#: Fraction of the explicit stability limit 2/ω_max used as substep (ω_max is already an upper bound: measured
#: 1.6x the true highest frequency on the sphere at rest, tests/unit/test_solvers_mass_spring.py).
SAFETY = 0.9
#: Default per-step velocity damping: settles the quasi-static solve in few steps (measured, docs/solvers.md).
DEFAULT_DAMPING = 0.3


@njit(cache=True)
def mass_spring_step(positions: np.ndarray, velocities: np.ndarray, accel: np.ndarray, inv_mass: np.ndarray,
                     forces: np.ndarray, springs: np.ndarray, rest: np.ndarray, stiffness: np.ndarray, dt: float,
                     substeps: int, keep: np.ndarray, attached: np.ndarray = np.zeros(0, np.int64),
                     attached_stiffness: np.ndarray = np.zeros(0), anchors: np.ndarray = np.zeros((0, 3)),
                     gravity: np.ndarray = np.zeros(3), weighed: bool = False) -> None:
    """One time step ``dt`` [s] of ``substeps`` symplectic-Euler substeps, in place, allocating nothing.

    Args:
        positions, velocities: ``(n, 3) float64`` [m], [m/s], updated in place.
        accel: ``(n, 3) float64`` workspace.
        inv_mass: ``(n,) float64`` [1/kg]; 0 pins a node (it keeps its position and velocity).
        forces: ``(n, 3) float64`` external forces [N].
        springs: ``(s, 2) int32`` node pairs; rest: ``(s,)`` rest lengths [m]; stiffness: ``(s,)`` [N/m].
        keep: velocity factor per substep, (1 − damping)^(1/substeps).
        attached: ``(p,) int64`` nodes held by attachment springs of ``attached_stiffness`` ``(p,)`` [N/m] toward
            ``anchors`` ``(p, 3)`` [m] (zero rest length: force k (a − x)).
        gravity: ``(3,)`` [m/s²] the acceleration every unpinned node gets (its weight m g) when ``weighed``.
    """
    n = positions.shape[0]
    h = dt / substeps
    h0, h1, h2 = h * gravity[0], h * gravity[1], h * gravity[2]
    for _ in range(substeps):
        for i in range(n):
            accel[i, 0] = forces[i, 0]
            accel[i, 1] = forces[i, 1]
            accel[i, 2] = forces[i, 2]
        for s in range(springs.shape[0]):
            i = springs[s, 0]
            j = springs[s, 1]
            d0 = positions[j, 0] - positions[i, 0]
            d1 = positions[j, 1] - positions[i, 1]
            d2 = positions[j, 2] - positions[i, 2]
            length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if length <= 1e-300:
                continue
            c = stiffness[s] * (length - rest[s]) / length
            accel[i, 0] += c * d0
            accel[i, 1] += c * d1
            accel[i, 2] += c * d2
            accel[j, 0] -= c * d0
            accel[j, 1] -= c * d1
            accel[j, 2] -= c * d2
        for a in range(attached.shape[0]):
            i = attached[a]
            for k in range(3):
                accel[i, k] += attached_stiffness[a] * (anchors[a, k] - positions[i, k])
        for i in range(n):
            w = inv_mass[i]
            if w == 0.0:
                continue
            if weighed:
                velocities[i, 0] += h0
                velocities[i, 1] += h1
                velocities[i, 2] += h2
            for k in range(3):
                v = (velocities[i, k] + h * w * accel[i, k]) * keep
                velocities[i, k] = v
                positions[i, k] += h * v


@njit(cache=True)
def inverted_triangles(rest: np.ndarray, positions: np.ndarray, triangles: np.ndarray) -> tuple[int, int]:
    """``(count, first)`` of the triangles whose normal now points against their rest normal (first: −1 if none)."""
    count, first = 0, -1
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        dot = 0.0
        for k in range(3):
            k1, k2 = (k + 1) % 3, (k + 2) % 3
            rest_normal = ((rest[b, k1] - rest[a, k1]) * (rest[c, k2] - rest[a, k2])
                           - (rest[b, k2] - rest[a, k2]) * (rest[c, k1] - rest[a, k1]))
            normal = ((positions[b, k1] - positions[a, k1]) * (positions[c, k2] - positions[a, k2])
                      - (positions[b, k2] - positions[a, k2]) * (positions[c, k1] - positions[a, k1]))
            dot += rest_normal * normal
        if dot < 0.0:
            count += 1
            if first < 0:
                first = t
    return count, first


def spring_network(surface: SurfaceMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Springs of M_S and the area each spans: ``(s, 2) int32`` nodes, ``(s,)`` rest lengths [m], ``(s,)`` Σ A_T [m²].

    Stretch springs first (every edge, with the area of its adjacent triangles), then one bending spring per edge
    shared by two triangles, between the two opposite vertices (with the area of those two triangles).
    """
    tri = surface.triangles.astype(np.int64)
    areas = surface.triangle_areas
    n = surface.vertex_count
    # Directed edge (a, b) of triangle t, with c the opposite vertex; undirected key low*n + high.
    a = tri[:, [0, 1, 2]].ravel()
    b = tri[:, [1, 2, 0]].ravel()
    c = tri[:, [2, 0, 1]].ravel()
    t = np.repeat(np.arange(len(tri)), 3)
    key = np.minimum(a, b) * n + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    key, c, t = key[order], c[order], t[order]
    unique, first, counts = np.unique(key, return_index=True, return_counts=True)
    edge_area = np.add.reduceat(areas[t], first)
    edges = np.stack([unique // n, unique % n], axis=1)
    hinge = counts == 2
    opposite = np.stack([c[first[hinge]], c[first[hinge] + 1]], axis=1)
    hinge_area = edge_area[hinge]
    springs = np.concatenate([edges, opposite]).astype(np.int32)
    span = np.concatenate([edge_area, hinge_area])
    v = surface.vertices
    rest = np.linalg.norm(v[springs[:, 0]] - v[springs[:, 1]], axis=1)
    if np.any(rest <= 0.0):
        raise SolverError("the surface has coincident vertices joined by a spring; merge duplicate vertices first")
    return springs, rest, span


def surface_lumped_mass(surface: SurfaceMesh, density: float) -> np.ndarray:
    """``(n,) float64`` node masses [kg]: density × enclosed volume, spread by each node's lumped area."""
    lumped = lumped_areas(surface.vertices, surface.triangles)
    total = density * abs(surface.signed_volume)
    if total <= 0.0 or np.any(lumped <= 0.0):
        raise SolverError(
            "cannot lump masses on this surface: it encloses no volume or has vertices in no triangle; "
            "validate it with tissuesim.mesh.validate.validate_surface"
        )
    return total * lumped / lumped.sum()


@register("mass-spring")
class MassSpringSolver(Solver):
    """Mass-spring model on M_S (see the module docstring).

    Options (besides the common ones of :class:`~tissuesim.solvers.base.Solver`):
        thickness_ratio: β, the dimensionless thickness h = β l of the spring-stiffness formula
            k = E h Σ A_T / l²; default the calibrated value :data:`tissuesim.solvers.calibrated.MASS_SPRING_THICKNESS`.
        damping: fraction of velocity removed per step (default :data:`DEFAULT_DAMPING`).

    Attributes:
        acceleration: ``(n, 3) float64`` [m/s²] the substep's accelerations, a workspace.
    """

    label = "mass-spring"
    short_label = "MSM"
    colour = "tab:green"
    line_style = "-."
    in_paper = True
    free_scalars = {"springs": ("thickness_ratio", 10.0, 3000.0)}
    linear_in_load = False      # a spring's force turns with it
    kept_values = (*Solver.kept_values, "inv_mass")

    gravity_caveat = ("springs on the surface have no volume to carry its weight and no unique rest under it (a "
                      "column's top sags 0.005-0.01 of the analytic ρgH²/(2E); the models are 85-98 % off the fine "
                      "FEM, docs/gravity-and-supports.md); use hybrid, embedded or fem for self-weight")

    cut_carrier = "tissuesim.solvers.mass_spring_cut:MassSpringCut"

    def __init__(self, hybrid_mesh: HybridMesh, *, thickness_ratio: float | None = None,
                 damping: float = DEFAULT_DAMPING, **common: object):
        super().__init__(hybrid_mesh, damping=damping, **common)
        if thickness_ratio is None:
            from .calibrated import MASS_SPRING_THICKNESS as thickness_ratio
        self.thickness_ratio = positive_number("thickness_ratio", thickness_ratio, "1")
        surface = hybrid_mesh.surface
        self.springs, self.rest_lengths, span = spring_network(surface)
        # h = β l between the body's own vertices; a spring with an end a cut made (a mesh cut before this solver)
        # takes h = β × M_S's edge length as built, as the cutting solver gave it; the ratio is 1 for the others
        thicker = thickness_lengths(hybrid_mesh, self.springs, self.rest_lengths) / self.rest_lengths
        self.stiffness = self.youngs_modulus * self.thickness_ratio * span / self.rest_lengths * thicker
        self.mass = surface_lumped_mass(surface, self.density)
        self.inv_mass = 1.0 / self.mass
        self.inv_mass[self.fixed] = 0.0
        self.omega_max = _omega_bound(self.springs, self.stiffness, self.inv_mass, self.attached_nodes,
                                      self.attached_stiffness)
        self.acceleration = np.zeros_like(self.state.positions)
        self._gravity = np.zeros(3) if self.gravity is None else np.array(self.gravity)

    @Solver.dt.setter
    def dt(self, value: float) -> None:
        """The default step [s], refused (SolverError, nothing changed) where it needs more than MAX_SUBSTEPS."""
        value = time_step(value)
        if getattr(self, "omega_max", None) is not None:    # None while the common options are set up
            self.substeps(value)
        self._dt = value

    def substeps(self, dt: float) -> int:
        """Substeps per step of ``dt`` [s] that keep symplectic Euler stable; SolverError beyond MAX_SUBSTEPS."""
        if self.omega_max == 0.0:
            return 1
        stable = SAFETY * 2.0 / self.omega_max
        needed = dt / stable        # compared as a float: near the float's top it is inf, which ceil cannot take
        if not needed <= MAX_SUBSTEPS:
            raise SolverError(
                f"the explicit mass-spring step would need {needed:.3g} substeps at dt = {dt:g} s with E = "
                f"{self.youngs_modulus:g} Pa (stable substep {stable:.3g} s; at most {MAX_SUBSTEPS} allowed, so dt "
                f"at most {MAX_SUBSTEPS * stable:.3g} s); lower dt or E, or use the hybrid method"
            )
        return max(1, math.ceil(needed))

    def _step(self, dt: float) -> None:
        substeps = self.substeps(dt)
        keep = (1.0 - self.damping) ** (1.0 / substeps)
        mass_spring_step(self.state.positions, self.state.velocities, self.acceleration, self.inv_mass, self.forces,
                         self.springs, self.rest_lengths, self.stiffness, dt, substeps, keep, self.attached_nodes,
                         self.attached_stiffness, self.attached_anchors, self._gravity, self.gravity is not None)
        count, first = inverted_triangles(self.rest_positions, self.state.positions, self.hybrid.surface.triangles)
        if count and self.hybrid.info.get("cuts"):
            count, first = self._inside_out_beyond_flaps()
        if count:
            raise InversionError(f"the mass-spring surface turned {count} triangles inside out (first: {first}) "
                                 f"{self._inverting_cause()}")

    def _inverting_cause(self) -> str:
        """What turned the surface inside out (the loads, its weight, or both) and what to do about it."""
        load = float(sum(np.linalg.norm(held.force) for held in self.loads))
        why = ("springs have no force that turns an inverted triangle back, so it may stay inverted after release (a "
               "cut's lip, held only by springs in its own plane, folds under smaller loads)")
        if self.gravity is None:
            return f"under {load:g} N: {why}; lower the force, or use the hybrid method (reset() returns to rest)"
        weight = f"gravity {np.linalg.norm(self.gravity):g} m/s²"
        if not self.loads:
            return (f"under its own weight ({weight}, no load): {why}; the surface has no volume to carry its weight, "
                    "so lower gravity, or use hybrid, embedded or fem for self-weight (reset() returns to rest)")
        return (f"under {load:g} N and its own weight ({weight}): {why}; lower the force or gravity, or use the "
                "hybrid method (reset() returns to rest)")

    def _inside_out_beyond_flaps(self) -> tuple[int, int]:
        """``(count, first)`` of the triangles turned against their rest normal, less those of flaps that swung
        (:func:`swung_flaps`); only called when the O(m) pass found some on a cut surface."""
        surface = self.hybrid.surface
        now = SurfaceMesh.trusted(self.state.positions.copy(), surface.triangles).triangle_normals
        rest = surface.triangle_normals
        turned = np.flatnonzero(np.sum(now * rest, axis=1) < 0.0)
        turned = turned[~swung_flaps(np.asarray(surface.triangles, dtype=np.int64), turned, now, rest)]
        return turned.size, int(turned[0]) if turned.size else -1


def swung_flaps(triangles: np.ndarray, turned: np.ndarray, now: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """``(k,) bool``: which of the triangles ``turned`` (indices into ``triangles`` ``(m, 3)``) belong to a flap
    that swung rather than turned inside out: a corner lies on an open edge (one triangle; only a cut makes them),
    and the fold against each neighbour across an edge has not grown by more than a right angle since rest.
    ``now``, ``rest``: ``(m, 3)`` unit normals."""
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 3, 2), axis=2)       # (m, 3, 2)
    n = int(triangles.max()) + 1
    key = (edges[..., 0] * n + edges[..., 1]).ravel()
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    first = np.searchsorted(sorted_key, key, side="left")
    count = np.searchsorted(sorted_key, key, side="right") - first
    open_vertex = np.zeros(n, dtype=bool)
    open_vertex[edges.reshape(-1, 2)[count == 1].ravel()] = True
    # the other triangle across each edge of the turned triangles (itself where the edge is open)
    slots = (3 * turned[:, None] + np.arange(3)).ravel()
    pair = order[first[slots] + (order[first[slots]] == slots).astype(np.int64) * (count[slots] - 1)]
    neighbour = (pair // 3).reshape(-1, 3)
    fold_now = np.arccos(np.clip(np.sum(now[turned, None] * now[neighbour], axis=2), -1.0, 1.0))
    fold_rest = np.arccos(np.clip(np.sum(rest[turned, None] * rest[neighbour], axis=2), -1.0, 1.0))
    folded = np.any(fold_now - fold_rest > 0.5 * np.pi, axis=1)
    return open_vertex[triangles[turned]].any(axis=1) & ~folded


def _omega_bound(springs, stiffness, inv_mass, attached=np.zeros(0, np.int64), attached_stiffness=np.zeros(0)) \
        -> float:
    """Upper bound [rad/s] of the highest natural frequency (Gershgorin on M^{-1/2} K M^{-1/2}, block norms; an
    attachment spring k to a fixed point adds k w_i to its node's row)."""
    rows = gershgorin_rows(springs, stiffness, inv_mass)
    np.add.at(rows, attached, attached_stiffness * inv_mass[attached])
    return float(np.sqrt(rows.max()))


@njit(cache=True)
def gershgorin_rows(springs: np.ndarray, stiffness: np.ndarray, inv_mass: np.ndarray) -> np.ndarray:
    """``(n,) float64`` each vertex's Gershgorin row sum Σ k (w_i + √(w_i w_j)) over its springs [1/s²] (one
    compiled pass; a cut keeps them and recomputes only the vertices it touched)."""
    row = np.zeros(inv_mass.size)
    for end in range(2):        # the first ends, then the second ends: the summation order of np.add.at
        for s in range(springs.shape[0]):
            i, j = springs[s, end], springs[s, 1 - end]
            row[i] += stiffness[s] * (inv_mass[i] + np.sqrt(inv_mass[i] * inv_mass[j]))
    return row