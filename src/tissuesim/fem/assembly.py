"""Element stiffness K^e = V Bᵀ D B of linear tets (eq 1–4), global assembly of K (eq 5), and the lumped mass.

Element matrices and the scatter-add are Numba kernels over all elements (no Python loop over tets);
:func:`shape_gradients` and :func:`strain_matrices` are the same maths in vectorised NumPy, for tests and users. Degrees of
freedom are node-major: dof ``3 i + c`` is component ``c`` (x, y, z) of node ``i``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit
from numpy.typing import ArrayLike

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
    """``(m, 12, 12) float64`` element stiffness matrices K^e = V Bᵀ D B [N/m] (eq 4; B and D are constant in a
    linear tet, so the integral is the volume V times the integrand), exactly symmetric."""
    if not isinstance(material, Material):
        raise MaterialError(f"material must be a tissuesim Material, got {type(material).__name__}")
    ke = np.empty((mesh.element_count, 12, 12))
    _element_stiffness_kernel(mesh.points, mesh.tets, material.elasticity_matrix(), ke)
    return ke


def element_dofs(tets: np.ndarray) -> np.ndarray:
    """``(m, 12) int64`` global dof indices of each tet, node-major (3 i + c)."""
    return (3 * tets.astype(np.int64)[:, :, None] + _COMPONENTS).reshape(len(tets), 12)


def assemble_stiffness(mesh: TetMesh, material: Material) -> sp.csr_matrix:
    """Global stiffness K [N/m] of eq (5): ``(3n, 3n)`` scipy CSR, float64, sorted indices, unconstrained (singular:
    the six rigid modes are its null space), dof order node-major (x, y, z per node).

    The sparsity pattern comes from the node graph (3×3 blocks per pair of nodes sharing a tet); a Numba kernel
    then scatter-adds every K^e into it (eq 5). This is the COO-with-duplicate-summation assembly done without
    materialising 144 m triplets, and it adds each element's (i, j) and (j, i) entries in the same order, so K is
    exactly symmetric.
    """
    return scatter_elements(mesh.node_count, mesh.tets, element_stiffness(mesh, material))


def scatter_elements(node_count: int, elements: np.ndarray, ke: np.ndarray) -> sp.csr_matrix:
    """``(3n, 3n)`` CSR sum of element matrices ``ke`` ``(m, 3w, 3w)`` over elements ``(m, w) int`` of any node
    count w (4: linear tets, 10: quadratic ones), node-major dofs; see :func:`assemble_stiffness`."""
    n = int(node_count)
    elements = np.ascontiguousarray(elements, dtype=np.int64)
    # Node-pair pattern: all w² ordered pairs of each element, deduplicated and sorted row-major.
    keys = np.sort((elements[:, :, None] * n + elements[:, None, :]).ravel())
    keys = keys[np.r_[True, keys[1:] != keys[:-1]]]  # sort + mask: ~8x faster than np.unique here
    node_rows, node_cols = np.divmod(keys, n)
    node_indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(node_rows, minlength=n), out=node_indptr[1:])
    index_type = np.int32 if 9 * keys.size < 2**31 else np.int64
    indptr = np.empty(3 * n + 1, dtype=index_type)
    indices = np.empty(9 * keys.size, dtype=index_type)
    data = np.zeros(9 * keys.size)
    _scatter_kernel(elements, ke, node_indptr, node_cols, indptr, indices, data)
    k = sp.csr_matrix((data, indices, indptr), shape=(3 * n, 3 * n))
    k.has_sorted_indices = True
    return k


@njit(cache=True)
def _element_stiffness_kernel(points, tets, d, out):
    """out[e] = V Bᵀ D B for every tet e (eq 2, 4): gradients from the inverse Jacobian, B in Voigt order."""
    b = np.zeros((6, 12))
    db = np.empty((6, 12))
    g = np.empty((4, 3))  # scratch buffers live outside the loop: no allocation per element
    for e in range(tets.shape[0]):
        p0 = points[tets[e, 0]]
        # Jacobian columns p1−p0, p2−p0, p3−p0; its inverse's rows are ∇N_1..∇N_3.
        a00 = points[tets[e, 1], 0] - p0[0]
        a10 = points[tets[e, 1], 1] - p0[1]
        a20 = points[tets[e, 1], 2] - p0[2]
        a01 = points[tets[e, 2], 0] - p0[0]
        a11 = points[tets[e, 2], 1] - p0[1]
        a21 = points[tets[e, 2], 2] - p0[2]
        a02 = points[tets[e, 3], 0] - p0[0]
        a12 = points[tets[e, 3], 1] - p0[1]
        a22 = points[tets[e, 3], 2] - p0[2]
        c00 = a11 * a22 - a12 * a21
        c01 = a02 * a21 - a01 * a22
        c02 = a01 * a12 - a02 * a11
        c10 = a12 * a20 - a10 * a22
        c11 = a00 * a22 - a02 * a20
        c12 = a02 * a10 - a00 * a12
        c20 = a10 * a21 - a11 * a20
        c21 = a01 * a20 - a00 * a21
        c22 = a00 * a11 - a01 * a10
        det = a00 * c00 + a01 * c10 + a02 * c20
        volume = det / 6.0
        inv = 1.0 / det
        g[1, 0], g[1, 1], g[1, 2] = c00 * inv, c01 * inv, c02 * inv
        g[2, 0], g[2, 1], g[2, 2] = c10 * inv, c11 * inv, c12 * inv
        g[3, 0], g[3, 1], g[3, 2] = c20 * inv, c21 * inv, c22 * inv
        for c in range(3):
            g[0, c] = -(g[1, c] + g[2, c] + g[3, c])
        strain_matrix(g, b)
        out[e, :, :] = 0.0
        add_bt_d_b(b, d, db, volume, out[e])
        mirror_upper(out[e])


@njit(cache=True)
def strain_matrix(gradients: np.ndarray, b: np.ndarray) -> None:
    """B of eq (2) in place, ``b`` ``(6, 3 w)``, from shape-function gradients ``(w, 3)``: rows xx, yy, zz, xy, yz,
    zx (engineering shears), column ``3 a + c`` component c of node a. Entries B leaves zero are never written."""
    for a in range(gradients.shape[0]):
        gx, gy, gz = gradients[a, 0], gradients[a, 1], gradients[a, 2]
        col = 3 * a
        b[0, col] = gx
        b[1, col + 1] = gy
        b[2, col + 2] = gz
        b[3, col] = gy
        b[3, col + 1] = gx
        b[4, col + 1] = gz
        b[4, col + 2] = gy
        b[5, col] = gz
        b[5, col + 2] = gx


@njit(cache=True)
def add_bt_d_b(b: np.ndarray, d: np.ndarray, db: np.ndarray, weight: float, out: np.ndarray) -> None:
    """``out`` ``(k, k)`` upper triangle += weight Bᵀ D B (``db`` ``(6, k)`` scratch); :func:`mirror_upper` fills the
    lower one."""
    k = b.shape[1]
    for r in range(6):
        for col in range(k):
            acc = 0.0
            for s in range(6):
                acc += d[r, s] * b[s, col]
            db[r, col] = acc
    for i in range(k):
        for j in range(i, k):
            acc = 0.0
            for r in range(6):
                acc += b[r, i] * db[r, j]
            out[i, j] += weight * acc


@njit(cache=True)
def mirror_upper(out: np.ndarray) -> None:
    """The lower triangle of ``out`` ``(k, k)`` copied from the upper one: exactly symmetric."""
    for i in range(out.shape[0]):
        for j in range(i + 1, out.shape[0]):
            out[j, i] = out[i, j]


@njit(cache=True)
def _scatter_kernel(tets, ke, node_indptr, node_cols, indptr, indices, data):
    """Build the dof-level CSR from the node pattern and scatter-add every K^e (eq 5).

    Node i with neighbours node_cols[s:s+deg] owns dof rows 3i..3i+2, each holding 3 deg columns
    (3 j, 3 j + 1, 3 j + 2 per neighbour j, sorted), starting at 9 s + 3 c deg."""
    n = node_indptr.shape[0] - 1
    for i in range(n):
        start, deg = node_indptr[i], node_indptr[i + 1] - node_indptr[i]
        for c in range(3):
            row_start = 9 * start + 3 * c * deg
            indptr[3 * i + c] = row_start
            for q in range(deg):
                j = node_cols[start + q]
                for dd in range(3):
                    indices[row_start + 3 * q + dd] = 3 * j + dd
    indptr[3 * n] = 9 * node_indptr[n]
    width = tets.shape[1]
    for e in range(tets.shape[0]):
        for a in range(width):
            i = tets[e, a]
            start, deg = node_indptr[i], node_indptr[i + 1] - node_indptr[i]
            for bb in range(width):
                j = tets[e, bb]
                lo, hi = start, start + deg  # binary search for j among i's neighbours
                while lo < hi:
                    mid = (lo + hi) // 2
                    if node_cols[mid] < j:
                        lo = mid + 1
                    else:
                        hi = mid
                q = lo - start
                for c in range(3):
                    base = 9 * start + 3 * c * deg + 3 * q
                    for dd in range(3):
                        data[base + dd] += ke[e, 3 * a + c, 3 * bb + dd]


def lumped_mass(mesh: TetMesh, density: float = 1000.0) -> np.ndarray:
    """``(n,) float64`` lumped nodal masses [kg]: each tet's mass ρV split equally over its four nodes (row-sum
    lumping of the consistent P1 mass matrix). ``density`` ρ in kg/m³ (soft tissue ≈ 1000-1100)."""
    density = float(density)
    if not np.isfinite(density) or density <= 0.0:
        raise MaterialError(f"density must be finite and > 0 kg/m^3, got {density:g} (soft tissue is ~1000)")
    share = np.repeat(mesh.volumes * (density / 4.0), 4)
    return np.bincount(mesh.tets.ravel(), weights=share, minlength=mesh.node_count)


def body_force(mesh: TetMesh, density: float, acceleration: ArrayLike) -> np.ndarray:
    """``(n, 3) float64`` consistent nodal load [N] of the body force ρ g on linear tets: each node of a tet gets
    ρ g V/4 from it (the integral of ρ g against its linear shape function, exact for a constant g). ``density`` ρ
    [kg/m³], ``acceleration`` g ``(3,)`` [m/s²], e.g. gravity (0, 0, −9.81)."""
    share = mesh.volumes * (float(density) / 4.0)
    nodal = np.bincount(mesh.tets.ravel(), weights=np.repeat(share, 4), minlength=mesh.node_count)
    return nodal[:, None] * np.asarray(acceleration, dtype=np.float64)[None, :]
