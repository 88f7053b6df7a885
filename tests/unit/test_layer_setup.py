"""Constraint topology, shell compliance and the validated stepper."""

import numpy as np
import pytest

from tissuesim.errors import MaterialError, MeshError, SolverError
from tissuesim.mesh import models
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.layer import constraints as C
from tissuesim.layer.compliance import hinge_stiffness, membrane_stiffness, shell_compliance, shell_masses
from tissuesim.layer.kernels import pbd_step
from tissuesim.layer.stepper import SurfaceStepper
from tissuesim.layer.topology import SurfaceConstraints


@pytest.fixture(scope="module")
def sphere():
    surface = models.sphere(200)
    return surface, SurfaceConstraints.from_surface(surface)


# ---------------------------------------------------------------- topology

def test_closed_surface_has_one_hinge_per_edge_with_consistent_rest_values(sphere):
    surface, c = sphere
    assert c.stretch_count == c.bending_count == 3 * surface.triangle_count // 2
    assert np.array_equal(np.unique(c.edges, axis=0), surface.edges)  # every edge once (interleaved order)
    assert np.allclose(c.rest_length, np.linalg.norm(np.subtract(*surface.vertices[c.edges.T]), axis=1))
    assert np.array_equal(np.sort(c.bending[:, :2], axis=1), c.edges[c.hinge_edge])
    for h in (0, 7, c.bending_count - 1):
        assert c.rest_angle[h] == pytest.approx(C.dihedral_angle(*surface.vertices[c.bending[h]]), abs=1e-14)
        # P3 and P4 are the opposite vertices of the two triangles sharing P1P2, P1P2P3 in winding order.
        p1, p2, p3, p4 = c.bending[h]
        tri = {tuple(np.roll(t, -k)) for t in surface.triangles.tolist() for k in range(3)}
        assert (p1, p2, p3) in tri and (p2, p1, p4) in tri
    assert np.allclose(c.edge_area.sum(), 3 * surface.triangle_areas.sum())
    assert np.all(c.rest_angle > 2.5)  # a fine sphere is nearly flat at every hinge (flat = π)


def test_open_surface_boundary_edges_have_no_hinge():
    strip = SurfaceMesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]], dtype=float),
                        np.array([[0, 1, 2], [1, 3, 2]]))
    c = SurfaceConstraints.from_surface(strip)
    assert c.stretch_count == 5 and c.bending_count == 1
    assert set(c.bending[0, :2]) == {1, 2} and set(c.bending[0, 2:]) == {0, 3}


def test_non_manifold_and_zero_length_edges_are_refused():
    fan = SurfaceMesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], dtype=float),
                      np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    with pytest.raises(MeshError, match="more than two triangles"):
        SurfaceConstraints.from_surface(fan)
    dup = SurfaceMesh(np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]], dtype=float), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="zero length"):
        SurfaceConstraints.from_surface(dup)


def test_interleaved_order_is_a_permutation():
    from tissuesim.layer.topology import interleaved_order

    for count in (0, 1, 2, 7, 10):
        order = interleaved_order(count)
        assert sorted(order.tolist()) == list(range(count))
    assert interleaved_order(5).tolist() == [0, 3, 1, 4, 2]


# ---------------------------------------------------------------- compliance

def _equilateral_triangle(a=0.01):
    return SurfaceMesh(np.array([[0, 0, 0], [a, 0, 0], [a / 2, a * np.sqrt(3) / 2, 0]]), np.array([[0, 1, 2]]))


def test_membrane_springs_reproduce_the_youngs_modulus_under_uniaxial_stress():
    """Van Gelder: an equilateral triangle's springs store ½ E h A ε² under uniaxial stress (ν = 1/3)."""
    tri = _equilateral_triangle()
    c = SurfaceConstraints.from_surface(tri)
    E, h, eps = 5500.0, 2e-3, 1e-6
    k = membrane_stiffness(c, youngs_modulus=E, thickness=h)
    strained = tri.vertices * [1 + eps, 1 - eps / 3, 1]
    energy = 0.5 * np.sum(k * (np.linalg.norm(strained[c.edges[:, 0]] - strained[c.edges[:, 1]], axis=1)
                               - c.rest_length) ** 2)
    assert energy == pytest.approx(0.5 * E * h * tri.triangle_areas[0] * eps ** 2, rel=1e-4)


@pytest.mark.parametrize("resolution", [100, 400, 1600])
def test_hinge_energy_of_a_sphere_approximates_the_plate_energy(resolution):
    """Grinspun: Σ ½ k_b (θ − φ_flat)² over a sphere ≈ ½ D ∫ (2H)² dA = 8π D.

    The dihedral-angle energy is not consistent on irregular meshes (Wardetzky et al. 2007): on the generator's
    spheres it stays 1.11–1.24 of the plate energy from 100 to 3200 vertices (1.17, 1.11, 1.21 at 100, 400, 1600)
    and does not converge, so no mesh size tightens it. The band is that non-convergent spread with 0.03 either
    side; a wrong factor in k_b (2, 3/2, 1 − ν against 1 − ν²) lands outside it."""
    surface = models.sphere(resolution)
    c = SurfaceConstraints.from_surface(surface)
    E, nu, h = 5500.0, 0.3, 1e-3
    k_b = hinge_stiffness(c, youngs_modulus=E, poisson_ratio=nu, thickness=h)
    energy = 0.5 * np.sum(k_b * (np.pi - c.rest_angle) ** 2)
    D = E * h ** 3 / (12 * (1 - nu ** 2))
    assert 1.08 < energy / (8 * np.pi * D) < 1.27


def test_compliance_is_inverse_stiffness_and_masses_sum_to_the_layer_mass(sphere):
    surface, c = sphere
    alpha_s, alpha_b = shell_compliance(c, thickness=3e-3)
    assert np.allclose(alpha_s * membrane_stiffness(c, thickness=3e-3), 1.0)
    assert np.allclose(alpha_b * hinge_stiffness(c, thickness=3e-3), 1.0)
    # Thicker is stiffer: stretch ∝ 1/h, bending ∝ 1/h³.
    alpha_s2, alpha_b2 = shell_compliance(c, thickness=6e-3)
    assert np.allclose(alpha_s / alpha_s2, 2.0) and np.allclose(alpha_b / alpha_b2, 8.0)
    m = shell_masses(surface, thickness=3e-3, density=1000.0)
    assert m.sum() == pytest.approx(1000.0 * 3e-3 * surface.triangle_areas.sum())
    assert np.all(m > 0)


@pytest.mark.parametrize("kwargs", [dict(thickness=0.0), dict(thickness=1e-3, youngs_modulus=-1.0),
                                    dict(thickness=1e-3, poisson_ratio=0.5), dict(thickness=float("nan"))])
def test_bad_material_is_refused(sphere, kwargs):
    with pytest.raises(MaterialError):
        shell_compliance(sphere[1], **kwargs)


# ---------------------------------------------------------------- stepper

def _stepper(surface, c, **options):
    n = surface.vertex_count
    x, v = surface.vertices.copy(), np.zeros((n, 3))
    return SurfaceStepper(c, positions=x, velocities=v, inv_mass=np.ones(n), **options), x, v


def test_stepper_equals_the_raw_kernel_and_keeps_prescribed_nodes(sphere):
    surface, c = sphere
    n = surface.vertex_count
    st, x, v = _stepper(surface, c, iterations=4, damping=0.1, k_stretch=0.8, k_bend=0.3, prescribed=[0, 9])
    st.forces[5] = [0.0, 0.0, 1.0]
    st.targets[1] += 1e-3
    st.step(1e-2)
    x2, v2, w = surface.vertices.copy(), np.zeros((n, 3)), np.ones(n)
    w[[0, 9]] = 0.0
    f = np.zeros((n, 3))
    f[5] = [0.0, 0.0, 1.0]
    targets = surface.vertices[[0, 9]].copy()
    targets[1] += 1e-3
    pbd_step(x2, v2, np.zeros((n, 3)), w, f, np.array([0, 9]), targets, 1e-2, 0.1, 4, c.edges, c.rest_length,
             0.8, c.bending, c.rest_angle, 0.3)
    # The stepper calls the same kernel with the same arguments: round-off at most; any other argument (a sweep, the
    # damping, a stiffness) changes the state by far more than 1e-15 of the size.
    size = np.ptp(surface.vertices, axis=0).max()
    assert np.abs(x - x2).max() <= 1e-15 * size and np.abs(v - v2).max() <= 1e-15 * size / 1e-2
    assert np.array_equal(x[9], st.targets[1])  # exact: assigned
    assert st.weights[0] == 0.0 and st.weights[5] == 1.0  # exact: assigned


def test_xpbd_stepper_runs_and_needs_compliance(sphere):
    surface, c = sphere
    alpha_s, alpha_b = shell_compliance(c, thickness=1e-3)
    st, x, _ = _stepper(surface, c, form="xpbd", stretch_compliance=alpha_s, bend_compliance=alpha_b)
    st.forces[3] = [0.0, 0.0, 1e-3]
    st.step(1e-3)
    assert np.all(np.isfinite(x)) and np.any(x != surface.vertices)
    with pytest.raises(SolverError, match="needs stretch_compliance"):
        _stepper(surface, c, form="xpbd")
    signed, y, _ = _stepper(surface, c, form="xpbd", stretch_compliance=alpha_s, bend_compliance=alpha_b,
                            signed_bending=True)
    signed.forces[3] = [0.0, 0.0, 1e-3]
    signed.step(1e-3)
    assert np.all(np.isfinite(y)) and np.any(y != surface.vertices)


@pytest.mark.parametrize("options, match", [
    (dict(form="verlet"), "unknown PBD form"),
    (dict(iterations=0), "iterations"),
    (dict(damping=1.0), "damping"),
    (dict(k_stretch=1.5), "k_stretch"),
    (dict(prescribed=[0, 10**6]), "outside"),
    (dict(prescribed=[1, 1]), "repeat"),
    (dict(form="xpbd", stretch_compliance=np.ones(3), bend_compliance=1.0), r"shape \(\d+,\)"),
    (dict(form="xpbd", stretch_compliance=-1.0, bend_compliance=1.0), "negative"),
])
def test_stepper_refuses_bad_options(sphere, options, match):
    surface, c = sphere
    with pytest.raises(SolverError, match=match):
        _stepper(surface, c, **options)


def test_stepper_refuses_mismatched_state_arrays(sphere):
    surface, c = sphere
    n = surface.vertex_count
    good = np.zeros((n, 3))
    with pytest.raises(SolverError, match="positions must be"):
        SurfaceStepper(c, positions=np.zeros((n - 1, 3)), velocities=good, inv_mass=np.ones(n))
    with pytest.raises(SolverError, match="velocities must be"):
        SurfaceStepper(c, positions=good, velocities=np.zeros((n, 3), dtype=np.float32), inv_mass=np.ones(n))
    with pytest.raises(SolverError, match="inv_mass must have shape"):
        SurfaceStepper(c, positions=good, velocities=np.zeros((n, 3)), inv_mass=np.ones(n + 1))
    with pytest.raises(SolverError, match="negative or not finite"):
        SurfaceStepper(c, positions=good, velocities=np.zeros((n, 3)), inv_mass=-np.ones(n))
    st, _, _ = _stepper(surface, c)
    with pytest.raises(SolverError, match="positive"):
        st.step(0.0)
