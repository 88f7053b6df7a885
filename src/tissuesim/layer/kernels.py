"""Numba step kernels for the fine surface: one call per time step, every solver iteration inside (paper §6.5).

Each step does, for the n surface nodes (arrays are the caller's, updated in place, nothing allocated):

1. velocity damping ``v *= (1 − damping)`` of the velocity carried from the last step, then eq 15: ``v += f dt w``.
   Damping comes *before* the force, unlike Müller et al. 2007's step (6) which damps after it: damping after
   would also scale the force increment, and a steady state would then balance ``(1 − damping) f`` instead of f
   (measured: the static residual equalled ``damping × |f|``). A plain global factor is enough because the bottom
   is fixed, so damping rigid motion is harmless, and it makes quasi-static solves settle;
2. eq 16: ``p_new = p + v dt`` into the ``predicted`` workspace;
3. eq 17, first case: prescribed nodes (control nodes, pinned nodes) are set to their targets; they must carry
   ``inv_mass = 0`` so no projection moves them (the :class:`~tissuesim.layer.stepper.SurfaceStepper` wrapper
   arranges this);
4. ``iterations`` Gauss–Seidel sweeps: every stretch constraint (eq 9) in array order, then every bending constraint
   (eq 11) in array order;
5. eq 18: ``v = (p_solve − p)/dt``, ``p = p_solve``.

Two forms share this flow:

* :func:`pbd_step`: the paper's PBD with stiffness coefficients ``k_stretch, k_bend`` in [0, 1], applied per
  iteration as Müller's ``k' = 1 − (1 − k)^(1/iterations)`` so the stiffness after all sweeps does not depend on
  the iteration count.
* :func:`xpbd_step`: XPBD (Macklin et al. 2016) with per-constraint compliance α (stretch [m/N], bending
  [1/(N·m)]), ``α̃ = α/dt²``, multipliers λ accumulated across sweeps and reset at the start of each step. Its
  resting state approaches the layer's static equilibrium as the sweeps converge; the exact equilibrium is
  :mod:`tissuesim.layer.static`'s.

The constraints are the NumPy reference's (:mod:`tissuesim.layer.constraints`: angles by atan2, degenerate
constraints skipped, the same thresholds), equal to it up to round-off; the bending projection gets θ and its gradient
from cheaper, equivalent expressions (see :func:`_project_bend`). Array loads are copied into
locals before any write, so aliasing between positions does not force re-reads (DESIGN performance rules).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .hinge_kernels import TINY_LENGTH, bend_gradient, bend_gradient_signed

# Safeguard beyond the paper: one bending projection may move a vertex by at most this fraction of the hinge edge's
# current length. Eq 11's correction grows without bound on a tangled hinge (a surface pushed through itself under a
# large load), and one such step sends positions to ~1e20 m. Near rest the corrections are orders of magnitude
# smaller, so the limit changes nothing there (the calibration case is unchanged). Measured on the sphere under 20 N
# of pressure (hybrid, 10 iterations): a limit of 1.0 or 0.5 still leaves a 5–150 mm limit cycle; 0.25 settles in
# 15 steps.
BEND_MOVE_LIMIT = 0.25


# ---------------------------------------------------------------- single-constraint projections

@njit(cache=True, inline="always")
def _project_stretch(x, w, i, j, rest, scale, alpha, lam):
    """One stretch constraint (eq 8) between nodes i, j of ``x``, in place. Returns the multiplier increment.

    PBD: ``scale`` = k', ``alpha`` = 0, ``lam`` = 0 → eq 9 scaled by k'. XPBD: ``scale`` = 1, ``alpha`` = α̃,
    ``lam`` = λ so far → Δλ = (−C − α̃λ)/(w_i + w_j + α̃) (|∇C| = 1 per node).
    """
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    xj0 = x[j, 0]
    xj1 = x[j, 1]
    xj2 = x[j, 2]
    wi = w[i]
    wj = w[j]
    d0 = xi0 - xj0
    d1 = xi1 - xj1
    d2 = xi2 - xj2
    length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    denom = wi + wj + alpha
    if length <= TINY_LENGTH or denom <= 0.0:
        return 0.0
    # s = Δλ/|d| with one division: Δλ = k(−C − α̃λ)/(w_i + w_j + α̃), the correction is w s d.
    s = (-(length - rest) - alpha * lam) * (scale / (denom * length))
    dlam = s * length
    x[i, 0] = xi0 + wi * s * d0
    x[i, 1] = xi1 + wi * s * d1
    x[i, 2] = xi2 + wi * s * d2
    x[j, 0] = xj0 - wj * s * d0
    x[j, 1] = xj1 - wj * s * d1
    x[j, 2] = xj2 - wj * s * d2
    return dlam


@njit(cache=True, inline="always")
def _move_hinge(x, i1, i2, i3, i4, s1, s2, s3, s4, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z):
    """A hinge's correction in place: node i_k moves by s_k ∇_k C (s_k = w_k Δλ)."""
    x[i1, 0] += s1 * g1x
    x[i1, 1] += s1 * g1y
    x[i1, 2] += s1 * g1z
    x[i2, 0] += s2 * g2x
    x[i2, 1] += s2 * g2y
    x[i2, 2] += s2 * g2z
    x[i3, 0] += s3 * g3x
    x[i3, 1] += s3 * g3y
    x[i3, 2] += s3 * g3z
    x[i4, 0] += s4 * g4x
    x[i4, 1] += s4 * g4y
    x[i4, 2] += s4 * g4z


@njit(cache=True, inline="always")
def _project_bend(x, w, i1, i2, i3, i4, rest, scale, alpha, lam):
    """One bending constraint (eq 10) on hinge (P1, P2 | P3, P4), in place. Returns the multiplier increment.

    PBD (``alpha`` = 0, ``lam`` = 0): eq 11 scaled by k'. XPBD: Δλ = (−C − α̃λ)/(Σ w_j |∇_j C|² + α̃),
    Δp_i = w_i ∇_i C Δλ. With P1 at the origin (a = P2, b = P3, c = P4):

    * θ = atan2(|n1×n2|, n1·n2) = atan2(|a| |det(a, b, c)|, (a×b)·(a×c)), because (a×b)×(a×c) = det(a, b, c) a and
      atan2 ignores the common positive factor 1/(|a×b| |a×c|). So the atan2 call needs no square root or division
      and overlaps the rest.
    * ∇C = ∇θ, eq 12's q_i / sinθ, in closed form (Bridson et al. 2003; σ times the signed angle's gradient of
      ``constraints.signed_bend_gradient``): the same vectors up to round-off, without eq 12's division by sinθ,
      which loses digits near flat hinges (tested against eq 12's reference): ∇_3 = −σ|a| (a×b)/|a×b|²,
      ∇_4 = σ|a| (a×c)/|a×c|², σ = sign det(a, b, c); ∇_2 = −(b·a/|a|²) ∇_3 − (c·a/|a|²) ∇_4 (lever rule);
      ∇_1 = −∇_2 − ∇_3 − ∇_4.
    """
    valid, theta, length, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = bend_gradient(
        x, i1, i2, i3, i4)
    if not valid:
        return 0.0
    w1 = w[i1]
    w2 = w[i2]
    w3 = w[i3]
    w4 = w[i4]
    m1 = w1 * (g1x * g1x + g1y * g1y + g1z * g1z)
    m2 = w2 * (g2x * g2x + g2y * g2y + g2z * g2z)
    m3 = w3 * (g3x * g3x + g3y * g3y + g3z * g3z)
    m4 = w4 * (g4x * g4x + g4y * g4y + g4z * g4z)
    denom = (m1 + m2 + m3 + m4) + alpha
    if denom <= 0.0:
        return 0.0
    factor = scale / denom  # computed while atan2 runs: after it, only multiplications
    largest = math.sqrt(max(w1 * m1, w2 * m2, w3 * m3, w4 * m4))  # max_i |Δp_i| / |Δλ|
    limit = BEND_MOVE_LIMIT * length
    dlam = (-(theta - rest) - alpha * lam) * factor
    move = abs(dlam) * largest
    if move > limit:
        dlam *= limit / move
    _move_hinge(x, i1, i2, i3, i4, w1 * dlam, w2 * dlam, w3 * dlam, w4 * dlam,
                g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z)
    return dlam


@njit(cache=True, inline="always")
def _project_bend_signed(x, w, i1, i2, i3, i4, rest, scale, alpha, lam):
    """One signed bending constraint ``C = β − β0`` (beyond the paper, see :func:`constraints.signed_bend_angle`).

    Gradient in closed form (``constraints.signed_bend_gradient``): no division by sin β, so it is exact and smooth
    at flat hinges, where eq 10's unsigned angle has a cusp. Same PBD/XPBD update as :func:`_project_bend`.
    """
    valid, beta, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = bend_gradient_signed(
        x, i1, i2, i3, i4)
    if not valid:
        return 0.0
    w1 = w[i1]
    w2 = w[i2]
    w3 = w[i3]
    w4 = w[i4]
    m1 = w1 * (g1x * g1x + g1y * g1y + g1z * g1z)
    m2 = w2 * (g2x * g2x + g2y * g2y + g2z * g2z)
    m3 = w3 * (g3x * g3x + g3y * g3y + g3z * g3z)
    m4 = w4 * (g4x * g4x + g4y * g4y + g4z * g4z)
    denom = (m1 + m2 + m3 + m4) + alpha
    if denom <= 0.0:
        return 0.0
    dlam = scale * (-(beta - rest) - alpha * lam) / denom
    # the same bound as eq 11's projection: a sliver's gradient grows as 1/its height, and unbounded corrections on
    # tangled hinges tore the layer apart (pbd, XPBD integrator: 0.3 N on one node of the cube, 1,000 triangles
    # inverted and edges stretched 70-fold within 3 steps)
    e0 = x[i2, 0] - x[i1, 0]
    e1 = x[i2, 1] - x[i1, 1]
    e2 = x[i2, 2] - x[i1, 2]
    limit = BEND_MOVE_LIMIT * math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    move = abs(dlam) * math.sqrt(max(w1 * m1, w2 * m2, w3 * m3, w4 * m4))
    if move > limit:
        dlam *= limit / move
    _move_hinge(x, i1, i2, i3, i4, w1 * dlam, w2 * dlam, w3 * dlam, w4 * dlam,
                g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z)
    return dlam


# ---------------------------------------------------------------- the parts of a step shared by both forms

@njit(cache=True, inline="always")
def _predict(positions, velocities, predicted, inv_mass, forces, prescribed, targets, dt, damping):
    """Damping, eq 15, eq 16, and eq 17's first case (prescribed nodes to their targets)."""
    keep = 1.0 - damping
    for i in range(positions.shape[0]):
        w = inv_mass[i] * dt
        for k in range(3):
            v = velocities[i, k] * keep + forces[i, k] * w
            velocities[i, k] = v
            predicted[i, k] = positions[i, k] + v * dt
    for r in range(prescribed.shape[0]):
        i = prescribed[r]
        for k in range(3):
            predicted[i, k] = targets[r, k]


@njit(cache=True, inline="always")
def _finish(positions, velocities, predicted, dt):
    """Eq 18: ``v = (p_solve − p)/dt``, ``p = p_solve``."""
    inv_dt = 1.0 / dt
    for i in range(positions.shape[0]):
        for k in range(3):
            p = predicted[i, k]
            velocities[i, k] = (p - positions[i, k]) * inv_dt
            positions[i, k] = p


# ---------------------------------------------------------------- step entries

@njit(cache=True)
def pbd_step(positions: np.ndarray, velocities: np.ndarray, predicted: np.ndarray, inv_mass: np.ndarray,
             forces: np.ndarray, prescribed: np.ndarray, targets: np.ndarray, dt: float, damping: float,
             iterations: int, edges: np.ndarray, rest_length: np.ndarray, k_stretch: float, bending: np.ndarray,
             rest_angle: np.ndarray, k_bend: float, signed_bending: bool = False) -> None:
    """One PBD time step (paper §6.5, eq 15–18) with stiffness coefficients; all arrays updated in place.

    Args:
        positions: ``(n, 3) float64`` node positions p [m]; on return, p_solve.
        velocities: ``(n, 3) float64`` [m/s]; on return, eq 18's velocities.
        predicted: ``(n, 3) float64`` workspace [m] (contents ignored, overwritten).
        inv_mass: ``(n,) float64`` w = 1/m [1/kg]; 0 for prescribed nodes.
        forces: ``(n, 3) float64`` external force f [N].
        prescribed: ``(k,) int32/int64`` node indices set to ``targets`` (eq 17, first case).
        targets: ``(k, 3) float64`` their positions this step [m].
        dt: time step [s] > 0.  damping: velocity damping factor in [0, 1).  iterations: Gauss–Seidel sweeps ≥ 1.
        edges: ``(e, 2) int32`` stretch constraints; rest_length: ``(e,) float64`` [m].
        k_stretch: stretch stiffness in [0, 1] (after all sweeps).
        bending: ``(b, 4) int32`` hinges (P1, P2 shared edge, P3, P4 opposite); rest_angle: ``(b,) float64`` [rad].
        k_bend: bending stiffness in [0, 1] (after all sweeps).
        signed_bending: False (the paper, eq 10: ``rest_angle`` = ``SurfaceConstraints.rest_angle``) or True (the
            signed angle β, smooth at flat hinges: ``rest_angle`` = ``SurfaceConstraints.rest_signed_angle``).
    """
    _predict(positions, velocities, predicted, inv_mass, forces, prescribed, targets, dt, damping)
    ks = 1.0 - (1.0 - k_stretch) ** (1.0 / iterations)
    kb = 1.0 - (1.0 - k_bend) ** (1.0 / iterations)
    for _ in range(iterations):
        for c in range(edges.shape[0]):
            _project_stretch(predicted, inv_mass, edges[c, 0], edges[c, 1], rest_length[c], ks, 0.0, 0.0)
        if kb > 0.0 and signed_bending:
            for c in range(bending.shape[0]):
                _project_bend_signed(predicted, inv_mass, bending[c, 0], bending[c, 1], bending[c, 2],
                                     bending[c, 3], rest_angle[c], kb, 0.0, 0.0)
        elif kb > 0.0:
            for c in range(bending.shape[0]):
                _project_bend(predicted, inv_mass, bending[c, 0], bending[c, 1], bending[c, 2], bending[c, 3],
                              rest_angle[c], kb, 0.0, 0.0)
    _finish(positions, velocities, predicted, dt)


@njit(cache=True)
def xpbd_step(positions: np.ndarray, velocities: np.ndarray, predicted: np.ndarray, inv_mass: np.ndarray,
              forces: np.ndarray, prescribed: np.ndarray, targets: np.ndarray, dt: float, damping: float,
              iterations: int, edges: np.ndarray, rest_length: np.ndarray, stretch_compliance: np.ndarray,
              bending: np.ndarray, rest_angle: np.ndarray, bend_compliance: np.ndarray, lambda_stretch: np.ndarray,
              lambda_bend: np.ndarray, signed_bending: bool = False) -> None:
    """One XPBD time step (paper §6.5 flow, Macklin et al. 2016 projection); all arrays updated in place.

    Arguments as :func:`pbd_step`, except:
        stretch_compliance: ``(e,) float64`` α per stretch constraint [m/N] (0 = inextensible).
        bend_compliance: ``(b,) float64`` α per hinge [1/(N·m)] (0 = rigid hinge).
        lambda_stretch, lambda_bend: ``(e,)``, ``(b,) float64`` multiplier workspaces (zeroed here each step).
        signed_bending: as :func:`pbd_step`.
    """
    _predict(positions, velocities, predicted, inv_mass, forces, prescribed, targets, dt, damping)
    inv_dt2 = 1.0 / (dt * dt)
    lambda_stretch[:] = 0.0
    lambda_bend[:] = 0.0
    for _ in range(iterations):
        for c in range(edges.shape[0]):
            lambda_stretch[c] += _project_stretch(predicted, inv_mass, edges[c, 0], edges[c, 1], rest_length[c],
                                                  1.0, stretch_compliance[c] * inv_dt2, lambda_stretch[c])
        if signed_bending:
            for c in range(bending.shape[0]):
                lambda_bend[c] += _project_bend_signed(predicted, inv_mass, bending[c, 0], bending[c, 1],
                                                       bending[c, 2], bending[c, 3], rest_angle[c], 1.0,
                                                       bend_compliance[c] * inv_dt2, lambda_bend[c])
        else:
            for c in range(bending.shape[0]):
                lambda_bend[c] += _project_bend(predicted, inv_mass, bending[c, 0], bending[c, 1], bending[c, 2],
                                                bending[c, 3], rest_angle[c], 1.0, bend_compliance[c] * inv_dt2,
                                                lambda_bend[c])
    _finish(positions, velocities, predicted, dt)
