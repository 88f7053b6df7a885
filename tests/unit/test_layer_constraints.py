"""The NumPy reference constraints (eq 7–12): values, gradients, corrections, degenerate cases."""

import numpy as np
import pytest

from tissuesim.layer import constraints as C


def _random_hinge(rng):
    """A non-degenerate hinge: P1, P2 the shared edge, P3, P4 on either side, bent by a random angle."""
    while True:
        p = rng.normal(size=(4, 3))
        frame = C._hinge_frame(*p)
        if frame is None:
            continue
        theta = C.dihedral_angle(*p)
        if 0.2 < theta < np.pi - 0.2 and frame[5] > 0.3 and frame[6] > 0.3:
            return p


def _central_difference(fun, p, h=1e-6):
    g = np.zeros_like(p)
    for i in range(p.shape[0]):
        for k in range(3):
            plus, minus = p.copy(), p.copy()
            plus[i, k] += h
            minus[i, k] -= h
            g[i, k] = (fun(plus) - fun(minus)) / (2 * h)
    return g


def test_stretch_gradient_matches_central_differences():
    rng = np.random.default_rng(1)
    for _ in range(20):
        p = rng.normal(size=(2, 3))
        numeric = _central_difference(lambda q: C.stretch_value(q[0], q[1], 0.7), p)
        assert np.allclose(C.stretch_gradient(p[0], p[1]), numeric, atol=1e-8)


def test_bending_gradient_matches_central_differences():
    rng = np.random.default_rng(2)
    for _ in range(30):
        p = _random_hinge(rng)
        numeric = _central_difference(lambda q: C.bending_value(*q, 1.0), p)
        analytic = C.bending_gradient(*p)
        assert np.allclose(analytic, numeric, atol=1e-6 * max(1.0, np.abs(numeric).max()))


def test_bending_q_sum_to_zero_and_the_angle_is_pi_when_flat():
    rng = np.random.default_rng(3)
    p = _random_hinge(rng)
    assert np.allclose(C.bending_q(*p).sum(axis=0), 0.0, atol=1e-12)  # translation invariance (eq 12, q1)
    flat = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0]], dtype=float)
    assert C.dihedral_angle(*flat) == pytest.approx(np.pi)
    folded = flat.copy()
    folded[3] = [0.5, 0.0, 1.0]  # P4 rotated 90° about the edge
    assert C.dihedral_angle(*folded) == pytest.approx(np.pi / 2)


def test_stretch_projection_restores_rest_length_and_respects_masses():
    p1, p2 = np.array([0.0, 0.0, 0.0]), np.array([0.3, 0.4, 0.0])  # length 0.5
    dp = C.stretch_correction(p1, p2, 1.0, 1.0, 0.2)
    assert np.linalg.norm((p1 + dp[0]) - (p2 + dp[1])) == pytest.approx(0.2, abs=1e-15)
    assert np.allclose(dp[0] + dp[1], 0.0)  # equal masses: centre of mass kept
    dp = C.stretch_correction(p1, p2, 0.0, 2.0, 0.2)  # p1 prescribed
    assert np.all(dp[0] == 0.0)  # exact: inverse mass 0 times a finite step
    assert np.linalg.norm(p1 - (p2 + dp[1])) == pytest.approx(0.2, abs=1e-15)
    half = C.stretch_correction(p1, p2, 1.0, 1.0, 0.2, stiffness=0.5)
    assert np.linalg.norm((p1 + half[0]) - (p2 + half[1])) == pytest.approx(0.35, abs=1e-15)


def test_bending_projection_reduces_the_violation_quadratically():
    rng = np.random.default_rng(4)
    for _ in range(10):
        p = _random_hinge(rng)
        theta = C.dihedral_angle(*p)
        for error in (1e-2, 1e-3):
            dp = C.bending_correction(*p, np.ones(4), theta + error)
            after = C.bending_value(*(p + dp), theta + error)
            assert abs(after) < 50 * error ** 2  # one Newton step on C: first-order error removed
            assert np.allclose(dp.sum(axis=0), 0.0, atol=1e-14)  # equal masses: momentum kept


def test_bending_projection_never_moves_a_prescribed_node():
    rng = np.random.default_rng(5)
    p = _random_hinge(rng)
    w = np.array([0.0, 1.0, 0.0, 2.0])
    dp = C.bending_correction(*p, w, C.dihedral_angle(*p) + 0.01)
    assert np.all(dp[[0, 2]] == 0.0) and np.any(dp[3] != 0.0)


def test_degenerate_constraints_give_zero_correction_not_nan():
    same = np.zeros(3)
    assert np.all(C.stretch_correction(same, same, 1.0, 1.0, 0.1) == 0.0)
    assert np.all(C.stretch_gradient(same, same) == 0.0)  # exact: no direction, assigned 0
    flat = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0]], dtype=float)
    assert np.all(C.bending_correction(*flat, np.ones(4), 2.0) == 0.0)  # sin θ = 0: no direction
    sliver = flat.copy()
    sliver[2] = [2.0, 0.0, 0.0]  # P3 on the edge line: zero-area triangle
    assert np.all(C.bending_correction(*sliver, np.ones(4), 2.0) == 0.0)
    assert np.all(C.bending_gradient(*sliver) == 0.0)


def test_xpbd_multiplier_update_limits():
    g = np.array([[1.0, 0, 0], [-1.0, 0, 0]])
    assert C.xpbd_multiplier_update(0.1, g, [1.0, 1.0], 0.0, 0.0, 1e-3) == pytest.approx(-0.05)  # hard: eq 9
    assert C.xpbd_multiplier_update(0.1, g, [0.0, 0.0], 0.0, 0.0, 1e-3) == 0.0  # both prescribed


def test_signed_bend_gradient_matches_central_differences_also_when_flat():
    rng = np.random.default_rng(6)
    configs = [_random_hinge(rng) for _ in range(10)]
    configs.append(np.array([[0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.6, -1, 0]], dtype=float))  # flat
    for p in configs:
        numeric = _central_difference(lambda q: C.signed_bend_angle(*q), p)
        assert np.allclose(C.signed_bend_gradient(*p), numeric, atol=1e-6 * max(1.0, np.abs(numeric).max()))
        # β and eq 10's θ describe the same hinge: θ = π − |β|
        assert np.pi - abs(C.signed_bend_angle(*p)) == pytest.approx(C.dihedral_angle(*p), abs=1e-12)
