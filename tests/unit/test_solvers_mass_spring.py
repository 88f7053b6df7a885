"""Mass-spring kernel: forces are the gradient of the spring energy; the Numba step equals a NumPy reference."""

import numpy as np
import pytest

from tissuesim.mesh import models
from tissuesim.solvers.mass_spring import (
    _omega_bound,
    mass_spring_step,
    spring_network,
    surface_lumped_mass,
)


@pytest.fixture(scope="module")
def sphere():
    return models.sphere(resolution=80)


def spring_energy(x, springs, rest, k):
    d = x[springs[:, 1]] - x[springs[:, 0]]
    return 0.5 * np.sum(k * (np.linalg.norm(d, axis=1) - rest) ** 2)


def spring_forces(x, springs, rest, k):
    """Plain NumPy: f_i = Σ k (|d| − l0) d/|d| with d = x_j − x_i (and −that on j)."""
    d = x[springs[:, 1]] - x[springs[:, 0]]
    length = np.linalg.norm(d, axis=1)
    f = (k * (length - rest) / length)[:, None] * d
    out = np.zeros_like(x)
    np.add.at(out, springs[:, 0], f)
    np.add.at(out, springs[:, 1], -f)
    return out


def reference_step(x, v, w, f_ext, springs, rest, k, dt, substeps, keep):
    x, v = x.copy(), v.copy()
    h = dt / substeps
    free = w > 0
    for _ in range(substeps):
        a = (f_ext + spring_forces(x, springs, rest, k)) * w[:, None]
        v[free] = (v[free] + h * a[free]) * keep
        x[free] += h * v[free]
    return x, v


def test_network_has_an_edge_spring_per_edge_and_a_bending_spring_per_hinge(sphere):
    springs, rest, span = spring_network(sphere)
    edges = sphere.edges
    assert len(springs) == 2 * len(edges)  # closed surface: every edge is a hinge
    assert np.array_equal(np.sort(springs[: len(edges)], axis=1), edges)
    # the stretch spans are the two adjacent triangles' areas; their sum is twice... three times the total area
    assert np.isclose(span[: len(edges)].sum(), 3 * sphere.triangle_areas.sum())
    assert np.all(rest > 0)


def test_spring_forces_are_minus_the_energy_gradient(sphere):
    springs, rest, span = spring_network(sphere)
    k = 5500.0 * 0.01 * span / rest**2
    rng = np.random.default_rng(1)
    x = sphere.vertices + 2e-3 * rng.standard_normal(sphere.vertices.shape)
    forces = spring_forces(x, springs, rest, k)
    eps = 1e-7
    for i, c in [(0, 0), (5, 2), (33, 1)]:
        xp, xm = x.copy(), x.copy()
        xp[i, c] += eps
        xm[i, c] -= eps
        numeric = -(spring_energy(xp, springs, rest, k) - spring_energy(xm, springs, rest, k)) / (2 * eps)
        assert numeric == pytest.approx(forces[i, c], rel=1e-6, abs=1e-9)


def test_numba_step_equals_numpy_reference(sphere):
    springs, rest, span = spring_network(sphere)
    k = 5500.0 * 0.01 * span / rest**2
    mass = surface_lumped_mass(sphere, 1000.0)
    w = 1.0 / mass
    w[:5] = 0.0  # pinned
    rng = np.random.default_rng(2)
    x = sphere.vertices + 1e-3 * rng.standard_normal(sphere.vertices.shape)
    v = 1e-2 * rng.standard_normal(x.shape)
    f = np.zeros_like(x)
    f[40] = [0.0, 0.0, 0.5]
    expected_x, expected_v = reference_step(x, v, w, f, springs, rest, k, 0.01, 7, 0.97)
    x_n, v_n = x.copy(), v.copy()
    mass_spring_step(x_n, v_n, np.zeros_like(x), w, f, springs, rest, k, 0.01, 7, 0.97)
    assert np.allclose(x_n, expected_x, rtol=0, atol=1e-14)
    assert np.allclose(v_n, expected_v, rtol=0, atol=1e-12)
    assert np.array_equal(x_n[:5], x[:5])  # exact: inverse mass 0, so these nodes are never moved


def test_frequency_bound_exceeds_the_true_highest_frequency(sphere):
    """Gershgorin's bound must be ≥ sqrt(λ_max(M⁻¹K)) at rest, or the substep would be unstable."""
    springs, rest, span = spring_network(sphere)
    k = 5500.0 * 0.01 * span / rest**2
    w = 1.0 / surface_lumped_mass(sphere, 1000.0)
    n = len(w)
    K = np.zeros((3 * n, 3 * n))
    d = sphere.vertices[springs[:, 1]] - sphere.vertices[springs[:, 0]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    for (i, j), kk, e in zip(springs, k, d):
        block = kk * np.outer(e, e)
        for a, b, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            K[3 * a:3 * a + 3, 3 * b:3 * b + 3] += s * block
    scale = np.repeat(np.sqrt(w), 3)
    largest = np.linalg.eigvalsh(scale[:, None] * K * scale[None, :]).max()
    bound = _omega_bound(springs, k, w)
    assert np.sqrt(largest) <= bound < 3 * np.sqrt(largest)
