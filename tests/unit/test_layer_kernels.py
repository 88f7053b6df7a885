"""Numba step kernels (§6.5, eq 15–18) against the NumPy reference, and their invariants."""

import numpy as np
import pytest

from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_height, nodes_below
from tissuesim.layer import constraints as C
from tissuesim.layer.compliance import shell_compliance, shell_masses
from tissuesim.layer.kernels import pbd_step, xpbd_step
from tissuesim.layer.topology import SurfaceConstraints


@pytest.fixture(scope="module")
def small():
    surface = models.sphere(80)
    return surface, SurfaceConstraints.from_surface(surface)


def _reference_step(x, v, w, f, pre, targets, dt, damping, iterations, c, *, k_stretch=None, k_bend=None,
                    stretch_compliance=None, bend_compliance=None, signed=False):
    """Eq 15–18 with the NumPy constraint functions, one constraint at a time, in the kernels' order."""
    x, v = x.copy(), v.copy()
    v = v * (1.0 - damping) + f * (w * dt)[:, None]
    p = x + v * dt
    p[pre] = targets
    xpbd = stretch_compliance is not None
    if not xpbd:
        ks = 1 - (1 - k_stretch) ** (1 / iterations)
        kb = 1 - (1 - k_bend) ** (1 / iterations)
    lam_s = np.zeros(len(c.edges))
    lam_b = np.zeros(len(c.bending))
    for _ in range(iterations):
        for e, (i, j) in enumerate(c.edges):
            if xpbd:
                g = C.stretch_gradient(p[i], p[j])
                dl = C.xpbd_multiplier_update(C.stretch_value(p[i], p[j], c.rest_length[e]), g, w[[i, j]],
                                              lam_s[e], stretch_compliance[e], dt)
                lam_s[e] += dl
                dp = w[[i, j], None] * g * dl
            else:
                dp = C.stretch_correction(p[i], p[j], w[i], w[j], c.rest_length[e], stiffness=ks)
            p[i] += dp[0]
            p[j] += dp[1]
        for h, idx in enumerate(c.bending):
            if signed:
                g = C.signed_bend_gradient(*p[idx])
                value = C.signed_bend_angle(*p[idx]) - c.rest_signed_angle[h]
                alpha = bend_compliance[h] if xpbd else 0.0
                dl = C.xpbd_multiplier_update(value, g, w[idx], lam_b[h], alpha, dt)
                if not xpbd:
                    dl *= kb
                lam_b[h] += dl
                dp = w[idx, None] * g * dl
            elif xpbd:
                g = C.bending_gradient(*p[idx])
                dl = C.xpbd_multiplier_update(C.bending_value(*p[idx], c.rest_angle[h]), g, w[idx], lam_b[h],
                                              bend_compliance[h], dt)
                lam_b[h] += dl
                dp = w[idx, None] * g * dl
            else:
                dp = C.bending_correction(*p[idx], w[idx], c.rest_angle[h], stiffness=kb)
            p[idx] += dp
    return p, (p - x) / dt


def _state(surface, seed=0, scale=2e-3):
    rng = np.random.default_rng(seed)
    n = surface.vertex_count
    x = surface.vertices + rng.normal(scale=scale, size=(n, 3))
    v = rng.normal(scale=0.05, size=(n, 3))
    f = rng.normal(scale=0.5, size=(n, 3))
    w = rng.uniform(50.0, 200.0, size=n)
    pre = np.array([0, 5, 17], dtype=np.int64)
    w[pre] = 0.0
    targets = surface.vertices[pre] + 1e-3
    return x, v, f, w, pre, targets


def _ws(n, c):
    return np.zeros((n, 3)), np.zeros(len(c.edges)), np.zeros(len(c.bending))


def test_pbd_kernel_matches_numpy_reference(small):
    surface, c = small
    x, v, f, w, pre, targets = _state(surface)
    ref_x, ref_v = _reference_step(x, v, w, f, pre, targets, 1e-3, 0.1, 3, c, k_stretch=0.7, k_bend=0.4)
    pred, _, _ = _ws(len(x), c)
    pbd_step(x, v, pred, w, f, pre, targets, 1e-3, 0.1, 3, c.edges, c.rest_length, 0.7, c.bending, c.rest_angle,
             0.4)
    assert np.abs(x - surface.vertices).max() > 1e-3  # it did move
    assert np.allclose(x, ref_x, rtol=0, atol=1e-12)
    assert np.allclose(v, ref_v, rtol=0, atol=1e-12 / 1e-3)


def test_xpbd_kernel_matches_numpy_reference(small):
    surface, c = small
    x, v, f, w, pre, targets = _state(surface, seed=1)
    alpha_s, alpha_b = shell_compliance(c, thickness=2e-3)
    ref_x, ref_v = _reference_step(x, v, w, f, pre, targets, 1e-3, 0.0, 3, c, stretch_compliance=alpha_s,
                                   bend_compliance=alpha_b)
    pred, ls, lb = _ws(len(x), c)
    xpbd_step(x, v, pred, w, f, pre, targets, 1e-3, 0.0, 3, c.edges, c.rest_length, alpha_s, c.bending,
              c.rest_angle, alpha_b, ls, lb)
    assert np.allclose(x, ref_x, rtol=0, atol=1e-12)
    assert np.allclose(v, ref_v, rtol=0, atol=1e-12 / 1e-3)


@pytest.mark.parametrize("form", ["pbd", "xpbd"])
def test_signed_bending_kernel_matches_numpy_reference(small, form):
    surface, c = small
    x, v, f, w, pre, targets = _state(surface, seed=3)
    alpha_s, alpha_b = shell_compliance(c, thickness=2e-3)
    pred, ls, lb = _ws(len(x), c)
    if form == "pbd":
        ref_x, ref_v = _reference_step(x, v, w, f, pre, targets, 1e-3, 0.1, 3, c, k_stretch=0.7, k_bend=0.4,
                                       signed=True)
        pbd_step(x, v, pred, w, f, pre, targets, 1e-3, 0.1, 3, c.edges, c.rest_length, 0.7, c.bending,
                 c.rest_signed_angle, 0.4, True)
    else:
        ref_x, ref_v = _reference_step(x, v, w, f, pre, targets, 1e-3, 0.1, 3, c, stretch_compliance=alpha_s,
                                       bend_compliance=alpha_b, signed=True)
        xpbd_step(x, v, pred, w, f, pre, targets, 1e-3, 0.1, 3, c.edges, c.rest_length, alpha_s, c.bending,
                  c.rest_signed_angle, alpha_b, ls, lb, True)
    assert np.allclose(x, ref_x, rtol=0, atol=1e-12)
    assert np.allclose(v, ref_v, rtol=0, atol=1e-12 / 1e-3)


@pytest.mark.parametrize("model", ["sphere", "cube"])
def test_rest_stays_exactly_at_rest(model):
    surface = models.model(model, 200)
    c = SurfaceConstraints.from_surface(surface)
    n = surface.vertex_count
    x, v, f, w = surface.vertices.copy(), np.zeros((n, 3)), np.zeros((n, 3)), np.ones(n)
    pre, targets = np.array([3], dtype=np.int64), surface.vertices[[3]].copy()
    pred, ls, lb = _ws(n, c)
    alpha_s, alpha_b = shell_compliance(c, thickness=1e-3)
    for _ in range(5):
        pbd_step(x, v, pred, w, f, pre, targets, 1e-2, 0.0, 10, c.edges, c.rest_length, 1.0, c.bending,
                 c.rest_angle, 1.0)
        xpbd_step(x, v, pred, w, f, pre, targets, 1e-2, 0.0, 10, c.edges, c.rest_length, alpha_s, c.bending,
                  c.rest_angle, alpha_b, ls, lb)
        pbd_step(x, v, pred, w, f, pre, targets, 1e-2, 0.0, 10, c.edges, c.rest_length, 1.0, c.bending,
                 c.rest_signed_angle, 1.0, True)
        xpbd_step(x, v, pred, w, f, pre, targets, 1e-2, 0.0, 10, c.edges, c.rest_length, alpha_s, c.bending,
                  c.rest_signed_angle, alpha_b, ls, lb, True)
    # At rest the constraints' errors are round-off of the rest lengths and angles (~1e-16 relative): the state
    # may move by round-off, never by a correction (a wrong sign or rest value moves it by ~1e-3 of the size).
    size = np.ptp(surface.vertices, axis=0).max()
    assert np.abs(x - surface.vertices).max() <= 1e-12 * size
    assert np.abs(v).max() <= 1e-12 * size / 1e-2


def test_prescribed_nodes_end_exactly_at_targets(small):
    surface, c = small
    x, v, f, w, pre, targets = _state(surface, seed=2)
    pred, ls, lb = _ws(len(x), c)
    pbd_step(x, v, pred, w, f, pre, targets, 1e-3, 0.0, 5, c.edges, c.rest_length, 1.0, c.bending, c.rest_angle,
             1.0)
    assert np.array_equal(x[pre], targets)  # exact: the kernel assigns the targets
    targets = targets + 1e-4
    alpha_s, alpha_b = shell_compliance(c, thickness=2e-3)
    xpbd_step(x, v, pred, w, f, pre, targets, 1e-3, 0.0, 5, c.edges, c.rest_length, alpha_s, c.bending,
              c.rest_angle, alpha_b, ls, lb)
    assert np.array_equal(x[pre], targets)  # exact: assigned


def _readonly(a):
    a.flags.writeable = False  # as SurfaceConstraints hands them over: one Numba specialisation, not two
    return a


def _two_particles(rest=0.2):
    edges = _readonly(np.array([[0, 1]], dtype=np.int32))
    x = np.array([[0.0, 0.0, 0.0], [0.3, 0.4, 0.0]])
    return x, edges, _readonly(np.array([rest]))


@pytest.mark.parametrize("iterations", [1, 4, 25])
def test_pbd_stiffness_does_not_depend_on_iteration_count(iterations):
    """Müller's k' = 1 − (1 − k)^(1/n): after n sweeps an isolated constraint keeps (1 − k) of its violation."""
    x, edges, rest = _two_particles()
    v, f, w = np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2)
    none = np.zeros(0, dtype=np.int64)
    pbd_step(x, v, np.zeros((2, 3)), w, f, none, np.zeros((0, 3)), 1e-2, 0.0, iterations, edges, rest, 0.6,
             _readonly(np.zeros((0, 4), np.int32)), _readonly(np.zeros(0)), 0.0)
    assert np.linalg.norm(x[0] - x[1]) - 0.2 == pytest.approx(0.4 * 0.3, rel=1e-12)
    x, edges, rest = _two_particles()
    pbd_step(x, v, np.zeros((2, 3)), w, f, none, np.zeros((0, 3)), 1e-2, 0.0, iterations, edges, rest, 1.0,
             _readonly(np.zeros((0, 4), np.int32)), _readonly(np.zeros(0)), 0.0)
    assert np.linalg.norm(x[0] - x[1]) == pytest.approx(0.2, abs=1e-15)  # k = 1 restores the rest length


def _equilibrium(surface, c, fixed, load_node, force, *, iterations, dt, duration, thickness=1e-2, damping=0.05):
    n = surface.vertex_count
    x, v, f = surface.vertices.copy(), np.zeros((n, 3)), np.zeros((n, 3))
    f[load_node] = force
    w = 1.0 / shell_masses(surface, thickness=thickness)
    w[fixed] = 0.0
    alpha_s, alpha_b = shell_compliance(c, thickness=thickness)
    pred, ls, lb = _ws(n, c)
    targets = surface.vertices[fixed].copy()
    for _ in range(int(round(duration / dt))):
        xpbd_step(x, v, pred, w, f, fixed, targets, dt, damping, iterations, c.edges, c.rest_length, alpha_s,
                  c.bending, c.rest_angle, alpha_b, ls, lb)
    return x, alpha_s, alpha_b


def _elastic_residual(x, c, alpha_s, alpha_b):
    """Σ_c −(1/α_c) C_c ∇C_c per node [N]: the internal force of the compliance energy (reference functions)."""
    r = np.zeros_like(x)
    for e, (i, j) in enumerate(c.edges):
        r[[i, j]] -= C.stretch_value(x[i], x[j], c.rest_length[e]) * C.stretch_gradient(x[i], x[j]) / alpha_s[e]
    for h, idx in enumerate(c.bending):
        r[idx] -= C.bending_value(*x[idx], c.rest_angle[h]) * C.bending_gradient(*x[idx]) / alpha_b[h]
    return r


def test_xpbd_converges_to_the_compliance_equilibrium_independent_of_iterations_and_dt(small):
    """A damped XPBD steady state satisfies f + Σ −α⁻¹ C ∇C = 0 whatever dt and iterations (Macklin 2016 §4).

    This also pins the damping order: damping the force increment too would leave a residual of damping × |f|.
    """
    surface, c = small
    fixed = nodes_below(surface.vertices, bottom_height(surface.vertices)).astype(np.int64)
    top = int(np.argmax(surface.vertices[:, 2]))
    force = np.array([0.0, 0.0, 0.02])  # N; about 1 mm at the top of this 1 cm layer
    results = []
    for iterations, dt in ((20, 2e-3), (40, 4e-3)):
        x, alpha_s, alpha_b = _equilibrium(surface, c, fixed, top, force, iterations=iterations, dt=dt,
                                           duration=0.6)
        results.append(x)
        residual = _elastic_residual(x, c, alpha_s, alpha_b)
        residual[top] += force
        residual[fixed] = 0.0
        assert np.abs(residual).max() < 0.01 * np.linalg.norm(force)
    # The sideways mode of a point-pulled sphere is nearly free (tiny lateral stiffness), so compare the load's
    # direction, where the stiffness is well defined.
    lift = results[0][top, 2] - surface.vertices[top, 2]
    assert lift > 5e-4
    for other in results[1:]:
        assert abs(other[top, 2] - results[0][top, 2]) < 0.03 * lift


def test_a_tangled_hinge_moves_no_vertex_by_more_than_half_its_edge():
    """Eq 11 on a hinge folded almost shut against a flat rest angle asks for a huge correction; the kernel bounds
    it (BEND_MOVE_LIMIT), as a surface pushed through itself under a large load otherwise blows up."""
    from tissuesim.layer.kernels import BEND_MOVE_LIMIT

    # P1, P2: the hinge edge (length 1); P3, P4 folded onto the same side, 1e-6 rad apart; rest angle π (flat).
    x = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.5, 1.0, 0], [0.5, np.cos(1e-6), np.sin(1e-6)]])
    start = x.copy()
    hinge = _readonly(np.array([[0, 1, 2, 3]], dtype=np.int32))
    none = np.zeros(0, dtype=np.int64)
    pbd_step(x, np.zeros((4, 3)), np.zeros((4, 3)), np.ones(4), np.zeros((4, 3)), none, np.zeros((0, 3)), 1e-2,
             0.0, 1, _readonly(np.zeros((0, 2), np.int32)), _readonly(np.zeros(0)), 0.0, hinge,
             _readonly(np.array([np.pi])), 1.0)
    moved = np.linalg.norm(x - start, axis=1)
    assert np.all(np.isfinite(x))
    assert moved.max() == pytest.approx(BEND_MOVE_LIMIT * 1.0, rel=1e-9)  # the bound is reached, not exceeded


def test_kernel_dihedral_angle_matches_the_reference_formula():
    """The kernels take θ as atan2(|a| |det(a, b, c)|, (a×b)·(a×c)); the reference as atan2(|n1×n2|, n1·n2)."""
    from tissuesim.layer.rest_measures import dihedral_angles

    rng = np.random.default_rng(7)
    points = rng.normal(size=(300, 4, 3))
    points[::3, 3] = points[::3, 0] + points[::3, 1] - points[::3, 2] + 1e-7 * rng.normal(size=(100, 3))  # ~flat
    points[1::3, 3] = points[1::3, 2] + 1e-7 * rng.normal(size=(100, 3))  # ~folded shut
    x = points.reshape(-1, 3)
    hinges = np.arange(len(x), dtype=np.int32).reshape(-1, 4)
    reference = np.array([C.dihedral_angle(*p) for p in points])
    assert np.allclose(dihedral_angles(x, hinges), reference, rtol=0, atol=1e-13)
