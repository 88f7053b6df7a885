"""The rigid probe's contact on arrays: where the surface's vertices lie with respect to a sphere or a capsule, the
half-space compliance that predicts how they move under nodal normal forces, and the complementarity problem that
gives the next forces. It knows no solver; :mod:`tissuesim.tools.probe` drives a solver with it.

A probe is a core (a point, or a segment for a capsule) swollen by a radius R: a vertex x has the gap
g = |x − p(x)| − R, p(x) the core's point nearest x, and the normal n = (x − p(x)) / |x − p(x)| along which the
probe pushes it (frictionless: the force on the vertex is λ n with λ ≥ 0).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.linalg import cho_factor, solve_triangular
from scipy.optimize import nnls

#: Below this fraction of R a vertex lies on the probe's core: its normal is undefined and borrowed (see
#: :func:`gaps_and_normals`).
ON_CORE = 1e-9


def core_points(points: np.ndarray, center: np.ndarray, end: np.ndarray | None) -> np.ndarray:
    """``(k, 3) float64`` the point of the probe's core nearest each of ``points`` ``(k, 3)`` [m]: ``center``
    ``(3,)`` for a sphere, the nearest point of the segment ``center``–``end`` for a capsule."""
    if end is None:
        return np.broadcast_to(center, points.shape)
    axis = end - center
    length2 = float(axis @ axis)
    if length2 == 0.0:
        return np.broadcast_to(center, points.shape)
    along = np.clip((points - center) @ axis / length2, 0.0, 1.0)
    return center + along[:, None] * axis


def gaps_and_normals(points: np.ndarray, center: np.ndarray, end: np.ndarray | None,
                     radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(gaps (k,) [m], normals (k, 3))`` of ``points`` ``(k, 3)`` [m] to a probe of ``radius`` [m]: negative
    gaps lie inside. A point on the core itself takes the mean normal of the others (or +z), so it is still
    pushed out to the side the surface lies on."""
    offset = points - core_points(points, center, end)
    distance = np.linalg.norm(offset, axis=1)
    on_core = distance <= ON_CORE * radius
    normals = offset / np.where(on_core, 1.0, distance)[:, None]
    if np.any(on_core):
        borrowed = normals[~on_core].sum(axis=0)
        size = np.linalg.norm(borrowed)
        normals[on_core] = borrowed / size if size > 0.0 else (0.0, 0.0, 1.0)
    return distance - radius, normals


def core_samples(center: np.ndarray, end: np.ndarray | None, radius: float) -> np.ndarray:
    """``(k, 3) float64`` points of the probe's core [m]: ``center`` ``(3,)`` for a sphere, the segment
    ``center``–``end`` at most ``radius`` [m] apart for a capsule (a part of the body between two samples is thinner
    than the probe, whose vertices then lie inside it)."""
    if end is None:
        return center[None]
    count = int(np.ceil(float(np.linalg.norm(end - center)) / radius)) + 1
    return center + np.linspace(0.0, 1.0, count)[:, None] * (end - center)


def winding_numbers(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(k,) float64`` the winding number of the closed surface ``vertices`` ``(n, 3)`` [m], ``triangles``
    ``(m, 3) int`` (outward), about each of ``points`` ``(k, 3)`` [m]: 1 inside the body, 0 outside (the sum of the
    triangles' signed solid angles over 4π, Van Oosterom and Strackee 1983)."""
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    triangles = np.ascontiguousarray(triangles, dtype=np.int64)
    return np.array([_winding_number(np.asarray(point, dtype=np.float64), vertices, triangles) for point in points])


@njit(cache=True)
def _winding_number(point: np.ndarray, vertices: np.ndarray, triangles: np.ndarray) -> float:
    """:func:`winding_numbers` about one ``point`` ``(3,)``: a pass over the triangles that allocates nothing (each
    placing of the probe and each of its iterations take one; NumPy's temporaries made it 10 ms on 10k triangles)."""
    total = 0.0
    for t in range(triangles.shape[0]):
        ax = vertices[triangles[t, 0], 0] - point[0]
        ay = vertices[triangles[t, 0], 1] - point[1]
        az = vertices[triangles[t, 0], 2] - point[2]
        bx = vertices[triangles[t, 1], 0] - point[0]
        by = vertices[triangles[t, 1], 1] - point[1]
        bz = vertices[triangles[t, 1], 2] - point[2]
        cx = vertices[triangles[t, 2], 0] - point[0]
        cy = vertices[triangles[t, 2], 1] - point[1]
        cz = vertices[triangles[t, 2], 2] - point[2]
        la = np.sqrt(ax * ax + ay * ay + az * az)
        lb = np.sqrt(bx * bx + by * by + bz * bz)
        lc = np.sqrt(cx * cx + cy * cy + cz * cz)
        volume = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
        below = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la
                 + (cx * ax + cy * ay + cz * az) * lb)
        total += np.arctan2(volume, below)
    return total / (2.0 * np.pi)      # each solid angle is 2 atan2(...); over 4π


def half_space_compliance(rest: np.ndarray, areas: np.ndarray, youngs_modulus: float,
                          poisson_ratio: float) -> np.ndarray:
    """``(k, k) float64`` normal compliance [m/N] of ``k`` surface vertices of an elastic half-space (Boussinesq):
    entry (i, j) is the normal displacement of vertex i under a unit normal force on vertex j.

    Off the diagonal a point load: (1 − ν²) / (π E r_ij), r_ij the rest distance (``rest`` ``(k, 3)`` [m]). On
    it, the centre of a uniform pressure over a disc of the vertex's area (``areas`` ``(k,)`` [m²], radius
    a = √(A/π)): 2 (1 − ν²) / (π E a). It is the model the probe's Newton iteration inverts; the solver's own
    answer is the residual, so the model sets only the speed of convergence, not the answer.
    """
    scale = (1.0 - poisson_ratio**2) / (np.pi * youngs_modulus)
    disc = np.sqrt(areas / np.pi)
    distance = np.linalg.norm(rest[:, None, :] - rest[None, :, :], axis=2)
    # no pair closer than their discs' mean radius: keeps the matrix diagonally weighted where vertices crowd
    distance = np.maximum(distance, 0.5 * (disc[:, None] + disc[None, :]))
    compliance = scale / distance
    np.fill_diagonal(compliance, 2.0 * scale / disc)
    return compliance


def complementary_forces(compliance: np.ndarray, gaps: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """``(k,) float64`` the normal forces λ' ≥ 0 [N] of one Newton step of the contact: with the gaps predicted as
    g' = ``gaps`` + W (λ' − ``forces``) (``compliance`` W ``(k, k)`` [m/N] symmetric positive definite, ``gaps``
    ``(k,)`` [m] now, under ``forces`` ``(k,)`` [N] now), λ' ≥ 0, g' ≥ 0 and λ'·g' = 0.

    That linear complementarity problem is the minimum of ½ λ'ᵀWλ' + (g − Wλ)ᵀλ' over λ' ≥ 0; with W = L Lᵀ
    (Cholesky) it is the non-negative least-squares problem min |Lᵀλ' + L⁻¹(g − Wλ)|, solved exactly by
    Lawson–Hanson's active set (:func:`scipy.optimize.nnls`).
    """
    if gaps.size == 0:
        return np.zeros(0)
    linear = gaps - compliance @ forces
    lower, _ = cho_factor(compliance, lower=True)
    lower = np.tril(lower)
    target = -solve_triangular(lower, linear, lower=True)
    solution, _ = nnls(lower.T, target, maxiter=50 * gaps.size)
    return solution


def circumradii(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(m,) float64`` circumradius [m] of each of ``triangles`` ``(m, 3) int`` over ``vertices`` ``(n, 3)`` [m]:
    the widest gap between its vertices that a sphere can sink into without touching one."""
    p = vertices[np.asarray(triangles, dtype=np.int64)]
    a = np.linalg.norm(p[:, 1] - p[:, 2], axis=1)
    b = np.linalg.norm(p[:, 2] - p[:, 0], axis=1)
    c = np.linalg.norm(p[:, 0] - p[:, 1], axis=1)
    double_area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return a * b * c / (2.0 * np.maximum(double_area, np.finfo(float).tiny))


def vertex_spans(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(n,) float64`` the largest circumradius [m] of the triangles around each vertex (0 for a lone vertex)."""
    triangles = np.asarray(triangles, dtype=np.int64)
    span = np.zeros(len(vertices))
    np.maximum.at(span, triangles.ravel(), np.repeat(circumradii(vertices, triangles), 3))
    return span


def undetected_depth(span: float, radius: float) -> float:
    """How deep [m] a sphere of ``radius`` [m] sinks into a flat triangle of circumradius ``span`` [m] before it
    touches a vertex: R − √(R² − ρ²) (≈ ρ²/2R), and R when ρ ≥ R (it can sink to its equator and beyond)."""
    if span >= radius:
        return radius
    return radius - np.sqrt(radius * radius - span * span)
