"""Element stiffness K^e = V Bᵀ D B of linear tets (eq 1–4), global assembly of K (eq 5), and the lumped mass.

Everything is vectorised over elements (batched NumPy matmul); there is no Python loop over tets. Degrees of
freedom are node-major: dof ``3 i + c`` is component ``c`` (x, y, z) of node ``i``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import MaterialError
from ..mesh.tetmesh import TetMesh
from .material import Material

_COMPONENTS = np.arange(3, dtype=np.int64)


def shape_gradients(mesh: TetMesh) -> np.ndarray:
    """``(m, 4, 3) float64`` constant gradients ∇N_a [1/m] of the four linear shape functions of each tet (eq 1).

    With J = [p1−p0, p2−p0, p3−p0] (columns), the rows of J⁻¹ are ∇N_1..∇N_3 and ∇N_0 = −Σ ∇N_a, so the four
    gradients sum to zero exactly as the partition of unity demands.
    """
    p = mesh.points[mesh.tets]  # (m, 4, 3)
    jacobian = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]], axis=2)  # (m, 3, 3) columns
    inverse = np.linalg.inv(jacobian)  # rows are ∇N_1..∇N_3
    gradients = np.empty((len(p), 4, 3))
    gradients[:, 1:] = inverse
    gradients[:, 0] = -inverse.sum(axis=1)
    return gradients


def strain_matrices(gradients: np.ndarray) -> np.ndarray:
    """``(m, 6, 12) float64`` strain matrices B^e [1/m] of eq (2), ε = B^e u^e, from ``(m, 4, 3)`` gradients.

    Voigt order (xx, yy, zz, xy, yz, zx) with engineering shear strains, matching
    :meth:`Material.elasticity_matrix`; column ``3 a + c`` is component ``c`` of local node ``a``.
    """
    m = len(gradients)
    b = np.zeros((m, 6, 4, 3))
    gx, gy, gz = gradients[..., 0], gradients[..., 1], gradients[..., 2]
    b[:, 0, :, 0] = gx
    b[:, 1, :, 1] = gy
    b[:, 2, :, 2] = gz
    b[:, 3, :, 0] = gy
    b[:, 3, :, 1] = gx
    b[:, 4, :, 1] = gz
    b[:, 4, :, 2] = gy
    b[:, 5, :, 0] = gz
    b[:, 5, :, 2] = gx
    return b.reshape(m, 6, 12)


def element_stiffness(mesh: TetMesh, material: Material) -> np.ndarray:
    """``(m, 12, 12) float64`` element stiffness matrices K^e = V Bᵀ D B [N/m] (eq 4; B and D constant in a tet,
    so the integral is the volume V times the integrand). Exactly symmetric (symmetrised against round-off)."""
    if not isinstance(material, Material):
        raise MaterialError(f"material must be a tissuesim Material, got {type(material).__name__}")
    b = strain_matrices(shape_gradients(mesh))
    db = material.elasticity_matrix() @ b  # (m, 6, 12)
    k = np.matmul(b.transpose(0, 2, 1), db)
    k *= mesh.volumes[:, None, None]
    # BᵀDB is symmetric in exact arithmetic; averaging with the transpose makes each K^e so bit for bit (the
    # assembled K is then symmetric to round-off: duplicates of (i, j) and (j, i) may be summed in other orders).
    k += k.transpose(0, 2, 1)
    k *= 0.5
    return k


def element_dofs(tets: np.ndarray) -> np.ndarray:
    """``(m, 12) int64`` global dof indices of each tet, node-major (3 i + c)."""
    return (3 * tets.astype(np.int64)[:, :, None] + _COMPONENTS).reshape(len(tets), 12)


def assemble_stiffness(mesh: TetMesh, material: Material) -> sp.csr_matrix:
    """Global stiffness K [N/m] of eq (5): ``(3n, 3n)`` scipy CSR, float64, unconstrained (singular: the six rigid
    modes are its null space), dof order node-major (x, y, z per node).

    Built as COO triplets (row, col, K^e entry) of all elements; the conversion to CSR sums duplicates, which is
    the scatter-add of eq (5).
    """
    ke = element_stiffness(mesh, material)
    dofs = element_dofs(mesh.tets)
    m = len(dofs)
    index_type = np.int32 if 3 * mesh.node_count < 2**31 else np.int64
    rows = np.broadcast_to(dofs[:, :, None], (m, 12, 12)).astype(index_type).ravel()
    cols = np.broadcast_to(dofs[:, None, :], (m, 12, 12)).astype(index_type).ravel()
    size = 3 * mesh.node_count
    k = sp.coo_matrix((ke.ravel(), (rows, cols)), shape=(size, size)).tocsr()
    k.sort_indices()
    return k


def lumped_mass(mesh: TetMesh, density: float = 1000.0) -> np.ndarray:
    """``(n,) float64`` lumped nodal masses [kg]: each tet's mass ρV split equally over its four nodes (row-sum
    lumping of the consistent P1 mass matrix). ``density`` ρ in kg/m³ (soft tissue ≈ 1000-1100)."""
    density = float(density)
    if not np.isfinite(density) or density <= 0.0:
        raise MaterialError(f"density must be finite and > 0 kg/m^3, got {density:g} (soft tissue is ~1000)")
    share = np.repeat(mesh.volumes * (density / 4.0), 4)
    return np.bincount(mesh.tets.ravel(), weights=share, minlength=mesh.node_count)
