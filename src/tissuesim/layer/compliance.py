"""XPBD compliance of the surface layer from the tissue's material (beyond the paper: DESIGN "PBD has no unit").

The fine surface is treated as a thin elastic layer (membrane + shell) of Young's modulus E [Pa], Poisson ratio ν
and thickness h [m]; h is the one free scalar a solver calibrates against the FEM reference.

Stretch (eq 8), membrane springs after Van Gelder (1998), "Approximate simulation of elastic membranes by
triangulated spring meshes", J. Graphics Tools 3(2):

    k_e = E h Σ_{T ∋ e} A_T / l_e²          [N/m]

For an equilateral triangle lattice of side a this gives k = E h √3/2, and such a lattice's in-plane Young's
modulus is 2k/(√3 h) = E exactly (its Poisson ratio is fixed at 1/3 by the spring network, so ν does not enter).
A boundary edge has one triangle and so half the stiffness, as a free edge should.

Bending (eq 10), discrete-shell hinges after Grinspun et al. (2003), "Discrete shells", SCA: the plate energy
½ D ∫ (2H)² dA, with the mean curvature of the hinge's third of the two triangles 2H ≈ θ|e|/A_e and
A_e = (A1 + A2)/3, gives ½ k_b (θ − φ)² with

    k_b = 3 D |e|² / (A1 + A2),   D = E h³ / (12 (1 − ν²))          [N·m/rad²]

XPBD compliance is the inverse stiffness, α = 1/k (Macklin et al. 2016, U = ½ α⁻¹ C²): m/N for stretch and
1/(N·m) for bending. Node masses lump the layer's mass (density × area × h) a third to each triangle corner.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import MaterialError
from ..mesh.bundle_check import SURFACE_VERTICES_KEY
from ..mesh.surface import SurfaceMesh
from .topology import SurfaceConstraints

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh

DEFAULT_YOUNGS_MODULUS = 5500.0  # Pa, the paper's tissue (§8.3)
DEFAULT_POISSON_RATIO = 0.3
DEFAULT_DENSITY = 1000.0  # kg/m³, soft tissue ≈ water


def _check(youngs_modulus: float, poisson_ratio: float, thickness) -> None:
    if not (np.isfinite(youngs_modulus) and youngs_modulus > 0.0):
        raise MaterialError(f"Young's modulus must be a positive finite number of pascals, got {youngs_modulus!r}")
    if not (np.isfinite(poisson_ratio) and -1.0 < poisson_ratio < 0.5):
        raise MaterialError(f"Poisson ratio must lie in (-1, 0.5), got {poisson_ratio!r}")
    if not np.all(np.isfinite(thickness) & (np.asarray(thickness) > 0.0)):
        raise MaterialError(f"surface layer thickness must be a positive finite number of metres, got {thickness!r}")


def membrane_stiffness(constraints: SurfaceConstraints, *, youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
                       thickness: float) -> np.ndarray:
    """``(e,) float64`` stretch stiffness k_e = E h Σ A_T / l_e² per edge [N/m] (Van Gelder 1998)."""
    _check(youngs_modulus, DEFAULT_POISSON_RATIO, thickness)
    return youngs_modulus * thickness * constraints.edge_area / constraints.rest_length ** 2


def hinge_stiffness(constraints: SurfaceConstraints, *, youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
                    poisson_ratio: float = DEFAULT_POISSON_RATIO, thickness: float) -> np.ndarray:
    """``(b,) float64`` bending stiffness k_b = 3 D |e|²/(A1 + A2) per hinge [N·m/rad²] (Grinspun et al. 2003)."""
    _check(youngs_modulus, poisson_ratio, thickness)
    flexural_rigidity = youngs_modulus * thickness ** 3 / (12.0 * (1.0 - poisson_ratio ** 2))
    length = constraints.rest_length[constraints.hinge_edge]
    return 3.0 * flexural_rigidity * length ** 2 / constraints.hinge_area


def shell_compliance(constraints: SurfaceConstraints, *, youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
                     poisson_ratio: float = DEFAULT_POISSON_RATIO,
                     thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """XPBD compliances ``(stretch (e,) [m/N], bending (b,) [1/(N·m)])`` of a layer of thickness h [m]."""
    k_e = membrane_stiffness(constraints, youngs_modulus=youngs_modulus, thickness=thickness)
    k_b = hinge_stiffness(constraints, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                          thickness=thickness)
    return 1.0 / k_e, 1.0 / k_b


def relative_shell_compliance(constraints: SurfaceConstraints, *, youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
                              poisson_ratio: float = DEFAULT_POISSON_RATIO, thickness_ratio: float,
                              thickness_length: float | np.ndarray | None = None
                              ) -> tuple[np.ndarray, np.ndarray]:
    """XPBD compliances of a layer whose thickness follows the mesh: h = β × the constraint's rest edge length.

    ``thickness_ratio`` β is dimensionless, so one calibrated value carries over between meshes of different
    resolution and between models of different size; the stiffness still scales with E (and the hinges with
    1/(1 − ν²)). ``thickness_length`` [m], a number or ``(e,)`` one per row, if given, replaces the edge length in
    h: a cut's constraints pass the body's edge length as built (:func:`thickness_lengths`), since the short edges a
    cut makes are no thinner tissue (the hinges' stiffness goes with h³, so an edge a quarter as long would bend 64
    times more easily). Returns ``(stretch (e,) [m/N], bending (b,) [1/(N·m)])``.
    """
    _check(youngs_modulus, poisson_ratio, thickness_ratio)
    length = constraints.rest_length if thickness_length is None else np.broadcast_to(
        np.asarray(thickness_length, dtype=np.float64), np.shape(constraints.rest_length))
    stretch_thickness = thickness_ratio * length
    hinge_thickness = thickness_ratio * length[constraints.hinge_edge]
    k_e = youngs_modulus * stretch_thickness * constraints.edge_area / constraints.rest_length ** 2
    k_b = hinge_stiffness(constraints, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                          thickness=hinge_thickness)
    return 1.0 / k_e, 1.0 / k_b


def thickness_lengths(hybrid: HybridMesh, edges: np.ndarray, rest_length: np.ndarray) -> np.ndarray:
    """``(k,) float64`` the length [m] whose β-multiple is the layer's thickness at each row (a constraint or a
    spring) joining ``edges`` ``(k, 2) int`` of rest length ``rest_length`` ``(k,)`` [m] on ``hybrid``'s surface.

    A row between two of the body's own vertices (numbered below M_S's vertex count at build) takes its own length,
    as an uncut build does; a row with an end a cut made takes M_S's mean edge length as built, since a cut does not
    thin the tissue. The rule reads only the mesh, so a solver built on a cut mesh (or on its saved bundle) gives
    every row the thickness the solver that made the cut gave it.
    """
    built = int(hybrid.info.get(SURFACE_VERTICES_KEY, hybrid.surface.vertex_count))
    own = np.all(np.asarray(edges) < built, axis=1)
    return np.where(own, rest_length, hybrid.built_edge_length)


def shell_masses(surface: SurfaceMesh, *, thickness: float, density: float = DEFAULT_DENSITY) -> np.ndarray:
    """``(n,) float64`` lumped node masses [kg]: density × A_T × h / 3 to each corner of every triangle.

    A node in no triangle gets mass 0; give it a prescribed position (inverse mass 0) or drop it.
    """
    _check(DEFAULT_YOUNGS_MODULUS, DEFAULT_POISSON_RATIO, thickness)
    if not (np.isfinite(density) and density > 0.0):
        raise MaterialError(f"density must be a positive finite number of kg/m³, got {density!r}")
    share = np.repeat(surface.triangle_areas * (density * thickness / 3.0), 3)
    return np.bincount(surface.triangles.ravel(), weights=share, minlength=surface.vertex_count)
