"""Element stiffness (eq 1-4), assembly (eq 5) and lumped mass."""

import numpy as np
import pytest
import scipy.sparse as sp

from tissuesim.errors import MaterialError
from tissuesim.fem.assembly import (
    assemble_stiffness,
    element_dofs,
    element_stiffness,
    lumped_mass,
    shape_gradients,
    strain_matrices,
)
from tissuesim.fem.material import Material
from tissuesim.mesh.tetmesh import TetMesh, structured_box

RNG = np.random.default_rng(7)


def random_mesh():
    # A structured box with jittered interior nodes: irregular tets, still positively oriented.
    box = structured_box((0.03, 0.02, 0.01), (3, 2, 2))
    p = box.points.copy()
    interior = np.flatnonzero(~np.isin(np.arange(len(p)), box.boundary_nodes))
    p[interior] += RNG.uniform(-1e-3, 1e-3, (interior.size, 3))
    return TetMesh(p, box.tets)


def rigid_modes(points):
    x = points - points.mean(axis=0)
    modes = np.zeros((len(points), 3, 6))
    modes[:, [0, 1, 2], [0, 1, 2]] = 1.0
    modes[:, :, 3] = np.cross([1.0, 0, 0], x)
    modes[:, :, 4] = np.cross([0, 1.0, 0], x)
    modes[:, :, 5] = np.cross([0, 0, 1.0], x)
    return modes.reshape(-1, 6)


def test_shape_gradients_reproduce_a_linear_field():
    mesh = random_mesh()
    g = shape_gradients(mesh)
    a = np.array([0.3, -1.2, 2.5])
    values = mesh.points @ a + 4.0  # linear field
    np.testing.assert_allclose(np.einsum("ea,eac->ec", values[mesh.tets], g), np.tile(a, (mesh.element_count, 1)))
    np.testing.assert_allclose(g.sum(axis=1), 0.0, atol=1e-10)


def test_element_stiffness_equals_numpy_btdb():
    mesh = random_mesh()
    mat = Material(4000.0, 0.35)
    b = strain_matrices(shape_gradients(mesh))
    reference = mesh.volumes[:, None, None] * np.matmul(b.transpose(0, 2, 1), mat.elasticity_matrix() @ b)
    ke = element_stiffness(mesh, mat)
    assert np.abs(ke - reference).max() <= 1e-12 * np.abs(ke).max()


def test_element_stiffness_equals_lame_closed_form():
    # Independent formula for isotropic P1: K_ab = V (λ g_a g_bᵀ + μ g_b g_aᵀ + μ (g_a·g_b) I).
    mesh = random_mesh()
    mat = Material(4000.0, 0.35)
    g = shape_gradients(mesh)
    lam, mu = mat.lame_lambda, mat.shear_modulus
    v = mesh.volumes[:, None, None, None, None]
    closed = v * (
        lam * np.einsum("eai,ebj->eaibj", g, g)
        + mu * np.einsum("ebi,eaj->eaibj", g, g)
        + mu * np.einsum("eak,ebk,ij->eaibj", g, g, np.eye(3))
    )
    ke = element_stiffness(mesh, mat)
    np.testing.assert_allclose(ke, closed.reshape(-1, 12, 12), rtol=1e-12, atol=1e-12 * np.abs(ke).max())
    # Symmetric to round-off (what a Cholesky factorisation needs; an index slip breaks it at order 1).
    assert np.abs(ke - ke.transpose(0, 2, 1)).max() <= 1e-14 * np.abs(ke).max()


def test_global_stiffness_is_symmetric_and_kills_rigid_modes():
    mesh = random_mesh()
    k = assemble_stiffness(mesh, Material())
    assert k.shape == (3 * mesh.node_count,) * 2 and k.format == "csr"
    assert abs(k - k.T).max() <= 1e-14 * abs(k).max()  # symmetric to round-off, as in the element test
    assert k.has_sorted_indices
    r = rigid_modes(mesh.points)
    assert np.abs(k @ r).max() <= 1e-12 * abs(k).max() * np.abs(r).max()
    # The same matrix as plain COO assembly with duplicate summation (eq 5).
    ke = element_stiffness(mesh, Material())
    dofs = element_dofs(mesh.tets)
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    coo = sp.coo_matrix((ke.ravel(), (rows, cols)), shape=k.shape).tocsr()
    assert abs(coo - k).max() <= 1e-13 * abs(k).max()


def test_refuses_a_non_material():
    with pytest.raises(MaterialError):
        element_stiffness(random_mesh(), (5500.0, 0.3))


def test_lumped_mass_conserves_mass():
    mesh = random_mesh()
    m = lumped_mass(mesh, density=1060.0)
    assert m.shape == (mesh.node_count,) and np.all(m > 0)
    assert m.sum() == pytest.approx(1060.0 * 0.03 * 0.02 * 0.01, rel=1e-12)
    with pytest.raises(MaterialError, match="density"):
        lumped_mass(mesh, density=0.0)
