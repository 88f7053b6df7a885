"""Stretch and bending constraints of the fine surface M_S (paper §4, eq 7–12), in plain NumPy.

These are the readable reference: one constraint at a time, no Numba. The hot loop in
:mod:`tissuesim.layer.kernels` does the same arithmetic in the same order and is tested against these functions.

Conventions (all positions ``(3,) float64`` [m], inverse masses ``w = 1/m`` [1/kg], ``w = 0`` = prescribed):

* Eq 7, generalised to masses as in Müller et al. 2007 §3.3: a constraint ``C(p_1..p_k)`` is projected by
  ``Δp_i = -s w_i ∇_i C`` with ``s = C / Σ_j w_j |∇_j C|²``.
* Stretch, eq 8: ``C = |p1 − p2| − l``; its projection is eq 9.
* Bending, eq 10: ``C = θ − φ`` where θ is the dihedral angle of the hinge as eq 12 writes it (Müller 2007,
  appendix): with ``P1`` at the origin, ``n1 = p2×p3/|p2×p3|``, ``n2 = p2×p4/|p2×p4|`` and θ = arccos(n1·n2). With
  the hinge's triangles oriented (P1, P2, P3) and (P2, P1, P4), n1 is triangle 1's outward normal and n2 is minus
  triangle 2's, so a flat hinge has θ = π and a fold toward the outside makes θ smaller. The paper's text names the
  normals of ΔP1P3P2 and ΔP1P2P4 instead, which flips the sign of θ − φ and of its gradient together: the correction
  (eq 11) is the same either way.
* θ is evaluated as ``atan2(|n1×n2|, n1·n2)`` rather than ``arccos(n1·n2)``: the same angle, but accurate near 0
  and π, where arccos loses half the digits.
* Eq 11 with the paper's factor ``4 w_i / Σ_j w_j`` equals eq 7 only when all four masses are equal; we use eq 7's
  exact mass weighting ``w_i / Σ_j w_j |q_j|²`` (the same for equal masses, and right next to prescribed nodes).
* Degenerate cases are skipped (zero correction) rather than divided by zero: a zero-length edge (stretch), a
  zero-area hinge triangle (``|p2×p3|`` or ``|p2×p4|`` ≈ 0), or a hinge at exactly 0 or π where the unsigned angle
  has no gradient direction (``|n1×n2|`` ≈ 0).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

# Below these, a length [m] / a sine is treated as zero and the constraint is skipped (see module docstring).
TINY_LENGTH = 1e-300
TINY_SINE = 1e-12


# ---------------------------------------------------------------- stretch (eq 8-9)

def stretch_value(p1: ArrayLike, p2: ArrayLike, rest_length: float) -> float:
    """Eq 8: ``C = |p1 − p2| − l`` [m]."""
    d = np.asarray(p1, dtype=np.float64) - np.asarray(p2, dtype=np.float64)
    return float(np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - rest_length)


def stretch_gradient(p1: ArrayLike, p2: ArrayLike) -> np.ndarray:
    """``(2, 3)`` gradient of eq 8 with respect to p1, p2: ``±(p1 − p2)/|p1 − p2|`` (zero if p1 = p2)."""
    d = np.asarray(p1, dtype=np.float64) - np.asarray(p2, dtype=np.float64)
    length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if length <= TINY_LENGTH:
        return np.zeros((2, 3))
    n = d / length
    return np.stack([n, -n])


def stretch_correction(p1: ArrayLike, p2: ArrayLike, w1: float, w2: float, rest_length: float, *,
                       stiffness: float = 1.0) -> np.ndarray:
    """Eq 9: ``(2, 3)`` corrections ``Δp1, Δp2`` [m], scaled by a PBD stiffness in [0, 1]."""
    d = np.asarray(p1, dtype=np.float64) - np.asarray(p2, dtype=np.float64)
    length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    wsum = w1 + w2
    if length <= TINY_LENGTH or wsum <= 0.0:
        return np.zeros((2, 3))
    s = stiffness * (length - rest_length) / (wsum * length)
    return np.stack([-w1 * s * d, w2 * s * d])


# ---------------------------------------------------------------- bending (eq 10-12)

def _hinge_frame(p1, p2, p3, p4):
    """Eq 12's quantities with P1 at the origin, or None when a hinge triangle has (nearly) no area."""
    p1 = np.asarray(p1, dtype=np.float64)
    a = np.asarray(p2, dtype=np.float64) - p1
    b = np.asarray(p3, dtype=np.float64) - p1
    c = np.asarray(p4, dtype=np.float64) - p1
    c1 = np.cross(a, b)
    c2 = np.cross(a, c)
    l1 = np.sqrt(c1 @ c1)
    l2 = np.sqrt(c2 @ c2)
    if l1 <= TINY_LENGTH or l2 <= TINY_LENGTH:
        return None
    n1 = c1 / l1
    n2 = c2 / l2
    return a, b, c, n1, n2, l1, l2


def dihedral_angle(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike) -> float:
    """θ of eq 10 [rad] in [0, π] (π for a flat hinge; see module docstring). 0 for a degenerate hinge."""
    frame = _hinge_frame(p1, p2, p3, p4)
    if frame is None:
        return 0.0
    n1, n2 = frame[3], frame[4]
    cr = np.cross(n1, n2)
    return float(np.arctan2(np.sqrt(cr @ cr), n1 @ n2))


def bending_value(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike, rest_angle: float) -> float:
    """Eq 10: ``C = θ − φ`` [rad]."""
    return dihedral_angle(p1, p2, p3, p4) - rest_angle


def bending_q(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike) -> np.ndarray | None:
    """Eq 12: ``(4, 3)`` vectors q1..q4 (Müller's q_i = −∂(n1·n2)/∂p_i), or None for a degenerate hinge."""
    frame = _hinge_frame(p1, p2, p3, p4)
    if frame is None:
        return None
    a, b, c, n1, n2, l1, l2 = frame
    d = n1 @ n2
    q3 = (np.cross(a, n2) + np.cross(n1, a) * d) / l1
    q4 = (np.cross(a, n1) + np.cross(n2, a) * d) / l2
    q2 = -(np.cross(b, n2) + np.cross(n1, b) * d) / l1 - (np.cross(c, n1) + np.cross(n2, c) * d) / l2
    q1 = -q2 - q3 - q4
    return np.stack([q1, q2, q3, q4])


def bending_gradient(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike) -> np.ndarray:
    """``(4, 3)`` gradient of eq 10 [rad/m]: ``∇_i C = q_i / sin θ`` (zero where degenerate)."""
    q = bending_q(p1, p2, p3, p4)
    if q is None:
        return np.zeros((4, 3))
    frame = _hinge_frame(p1, p2, p3, p4)
    cr = np.cross(frame[3], frame[4])
    sine = np.sqrt(cr @ cr)
    if sine <= TINY_SINE:
        return np.zeros((4, 3))
    return q / sine


def bending_correction(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike, w: ArrayLike, rest_angle: float,
                       *, stiffness: float = 1.0) -> np.ndarray:
    """Eq 11 (with eq 7's exact mass weighting): ``(4, 3)`` corrections [m], scaled by a PBD stiffness in [0, 1].

    ``Δp_i = −k w_i sinθ (θ − φ) q_i / Σ_j w_j |q_j|²``, which is ``−k w_i C ∇_i C / Σ_j w_j |∇_j C|²``.
    """
    w = np.asarray(w, dtype=np.float64)
    frame = _hinge_frame(p1, p2, p3, p4)
    if frame is None:
        return np.zeros((4, 3))
    n1, n2 = frame[3], frame[4]
    cr = np.cross(n1, n2)
    sine = np.sqrt(cr @ cr)
    if sine <= TINY_SINE:
        return np.zeros((4, 3))
    q = bending_q(p1, p2, p3, p4)
    denom = float(np.sum(w * np.einsum("ij,ij->i", q, q)))
    if denom <= 0.0:
        return np.zeros((4, 3))
    theta = np.arctan2(sine, n1 @ n2)
    s = stiffness * sine * (theta - rest_angle) / denom
    return -(w * s)[:, None] * q


# ---------------------------------------------------------------- XPBD (Macklin et al. 2016, eq 18)

def xpbd_multiplier_update(value: float, gradient: np.ndarray, w: ArrayLike, lam: float, compliance: float,
                           dt: float) -> float:
    """Macklin 2016 eq 18: ``Δλ = (−C − α̃ λ) / (Σ_j w_j |∇_j C|² + α̃)``, ``α̃ = α/dt²``.

    Args:
        value: constraint value C (m or rad).
        gradient: ``(k, 3)`` ∇C per particle.
        w: ``(k,)`` inverse masses [1/kg].
        lam: multiplier accumulated so far this step.
        compliance: α [m/N for stretch, 1/(N·m) for bending]; 0 gives the hard constraint.
        dt: time step [s].
    Returns Δλ; the correction is ``Δp_i = w_i ∇_i C Δλ``. 0 if the denominator vanishes.
    """
    w = np.asarray(w, dtype=np.float64)
    alpha = compliance / (dt * dt)
    denom = float(np.sum(w * np.einsum("ij,ij->i", gradient, gradient))) + alpha
    if denom <= 0.0:
        return 0.0
    return (-value - alpha * lam) / denom


# ---------------------------------------------------------------- signed bending (beyond the paper)

def signed_bend_angle(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike) -> float:
    """β [rad] in (−π, π]: the signed angle between the outward normals of (P1, P2, P3) and (P2, P1, P4).

    0 for a flat hinge and smooth through it, unlike eq 10's unsigned θ (= π − |β|), which has a cusp there. The
    sign is that of ``(nA × nB) · (P2 − P1)``. 0 for a degenerate hinge. Opt-in and not the default: in the PBD
    form it measured no gain and failed to settle on the hybrid cube (docs/pbd.md).
    """
    p1 = np.asarray(p1, dtype=np.float64)
    a = np.asarray(p2, dtype=np.float64) - p1
    na = np.cross(a, np.asarray(p3, dtype=np.float64) - p1)
    nb = np.cross(np.asarray(p4, dtype=np.float64) - p1, a)
    la, lb, length = np.sqrt(na @ na), np.sqrt(nb @ nb), np.sqrt(a @ a)
    if la <= TINY_LENGTH or lb <= TINY_LENGTH or length <= TINY_LENGTH:
        return 0.0
    return float(np.arctan2(np.cross(na, nb) @ a / length, na @ nb))


def signed_bend_gradient(p1: ArrayLike, p2: ArrayLike, p3: ArrayLike, p4: ArrayLike) -> np.ndarray:
    """``(4, 3)`` gradient of β [rad/m], in closed form (no division by sin β, exact at flat).

    A vertex opposite the edge rotates its triangle about the edge by its normal displacement over the triangle's
    height h = |N|/|e|: ∇_3 β = −|e| N_A/|N_A|², ∇_4 β = −|e| N_B/|N_B|². The edge vertices share these by the lever
    rule (t = foot of the opposite vertex along the edge from P1): ∇_1 = −(1 − t_A) ∇_3 − (1 − t_B) ∇_4,
    ∇_2 = −t_A ∇_3 − t_B ∇_4, so the four sum to zero (translation invariance).
    """
    p1 = np.asarray(p1, dtype=np.float64)
    a = np.asarray(p2, dtype=np.float64) - p1
    b = np.asarray(p3, dtype=np.float64) - p1
    c = np.asarray(p4, dtype=np.float64) - p1
    na, nb = np.cross(a, b), np.cross(c, a)
    la2, lb2, length2 = na @ na, nb @ nb, a @ a
    if la2 <= TINY_LENGTH or lb2 <= TINY_LENGTH or length2 <= TINY_LENGTH:
        return np.zeros((4, 3))
    length = np.sqrt(length2)
    g3 = -length * na / la2
    g4 = -length * nb / lb2
    ta, tb = (b @ a) / length2, (c @ a) / length2
    return np.stack([-(1 - ta) * g3 - (1 - tb) * g4, -ta * g3 - tb * g4, g3, g4])
