"""The finite-strain surface layer against what it must equal: an independent minimisation of the same energy, and
frame invariance (a rigidly moved problem has the rigidly moved answer; the linearised layer has not)."""

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from tissuesim.mesh import models
from tissuesim.layer.compliance import relative_shell_compliance
from tissuesim.layer.finite_layer import FiniteLayer
from tissuesim.layer.static import LayerStatics, layer_stiffness
from tissuesim.layer.topology import SurfaceConstraints

EDGE = models.CUBE_EDGE


@pytest.fixture(scope="module")
def coarse_cube():
    """The coarsest cube surface (56 nodes), its constraints, compliances and bottom face."""
    surface = models.cube(50)
    c = SurfaceConstraints.from_surface(surface)
    stretch, bend = relative_shell_compliance(c, thickness_ratio=1.0)
    bottom = np.flatnonzero(surface.vertices[:, 2] < 1e-12)
    return surface.vertices.copy(), c, stretch, bend, bottom


def _layer(rest, c, stretch, bend, bottom):
    return FiniteLayer(rest, edges=c.edges, rest_length=c.rest_length, stretch_compliance=stretch, hinges=c.bending,
                       rest_angle=c.rest_signed_angle, bend_compliance=bend, prescribed=bottom)


def _reference_potential(c, stretch, bend, fixed, free, targets, forces):
    """Π = Σ C²/(2α) − fᵀx over the free coordinates, and its gradient, in vectorised NumPy from the definitions
    of tissuesim.layer.constraints (stretch_value and its gradient, signed_bend_angle by atan2 of the normals and
    signed_bend_gradient's closed form): no code shared with the Numba kernels."""
    i, j = c.edges.T
    p1, p2, p3, p4 = c.bending.T

    def potential(free_coordinates):
        x = np.empty((len(fixed) + len(free), 3))
        x[fixed], x[free] = targets, free_coordinates.reshape(-1, 3)
        gradient = np.zeros_like(x)
        d = x[i] - x[j]
        length = np.linalg.norm(d, axis=1)
        value = length - c.rest_length
        pull = (value / (stretch * length))[:, None] * d
        np.add.at(gradient, i, pull)
        np.add.at(gradient, j, -pull)
        a, b, e = x[p2] - x[p1], x[p3] - x[p1], x[p4] - x[p1]
        na, nb = np.cross(a, b), np.cross(e, a)
        span = np.linalg.norm(a, axis=1)
        beta = np.arctan2(np.einsum("ij,ij->i", np.cross(na, nb), a) / span, np.einsum("ij,ij->i", na, nb))
        turn = beta - c.rest_signed_angle
        g3 = -(span / np.einsum("ij,ij->i", na, na))[:, None] * na
        g4 = -(span / np.einsum("ij,ij->i", nb, nb))[:, None] * nb
        ta = (np.einsum("ij,ij->i", b, a) / span ** 2)[:, None]
        tb = (np.einsum("ij,ij->i", e, a) / span ** 2)[:, None]
        weight = (turn / bend)[:, None]
        for nodes, g in ((p1, -(1 - ta) * g3 - (1 - tb) * g4), (p2, -ta * g3 - tb * g4), (p3, g3), (p4, g4)):
            np.add.at(gradient, nodes, weight * g)
        energy = np.sum(value ** 2 / (2 * stretch)) + np.sum(turn ** 2 / (2 * bend))
        return energy - np.vdot(forces[free], x[free]), (gradient[free] - forces[free]).ravel()
    return potential


def test_static_equals_an_independent_minimisation_of_the_layer_energy(coarse_cube):
    rest, c, stretch, bend, bottom = coarse_cube
    layer = _layer(rest, c, stretch, bend, bottom)
    forces = np.zeros_like(rest)
    corner = int(np.argmax(rest[:, 2] * 10 + rest[:, 0] + rest[:, 1]))
    forces[corner] = [1.2, -0.6, 4.0]  # N: moves the corner by a third of the cube's edge
    x = rest.copy()
    layer.static(x, forces, rest[bottom])
    displacement = np.abs(x - rest).max()
    assert displacement > 0.3 * EDGE  # far beyond small strain
    potential = _reference_potential(c, stretch, bend, bottom, layer.free_nodes, rest[bottom], forces)
    found = minimize(potential, rest[layer.free_nodes].ravel(), jac=True, method="L-BFGS-B",
                     options={"gtol": 1e-11, "ftol": 1e-16, "maxiter": 20000, "maxcor": 50})
    independent = found.x.reshape(-1, 3)
    # L-BFGS stops where Π stops falling measurably (gradient ~5e-8 N here); that leaves it 2e-8 of the
    # displacement from Newton's answer (measured)
    assert np.abs(independent - x[layer.free_nodes]).max() <= 1e-6 * displacement
    linear = LayerStatics(layer_stiffness(rest, edges=c.edges, stretch_compliance=stretch, hinges=c.bending,
                                          bend_compliance=bend), prescribed=bottom)
    small = rest[layer.free_nodes] + linear.displacement(forces, np.zeros((bottom.size, 3)))
    # the test tells finite from small strain: the linear layer is 20 % off (measured)
    assert np.abs(small - independent).max() > 0.1 * displacement


def test_a_rigidly_moved_problem_has_the_rigidly_moved_answer(coarse_cube):
    rest, c, stretch, bend, bottom = coarse_cube
    layer = _layer(rest, c, stretch, bend, bottom)
    forces = np.zeros_like(rest)
    corner = int(np.argmax(rest[:, 2] * 10 + rest[:, 0] + rest[:, 1]))
    forces[corner] = [0.6, -0.3, 2.0]
    x = rest.copy()
    layer.static(x, forces, rest[bottom])
    turn = Rotation.from_rotvec(np.radians(75.0) * np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5]))
    shift = np.array([0.02, -0.01, 0.03])
    moved_targets = turn.apply(rest[bottom]) + shift
    moved_forces = turn.apply(forces)
    # the same layer (built at the unturned rest), its supports turned and shifted, the load turned with them;
    # started from the linear answer, as callers do
    linear = LayerStatics(layer_stiffness(rest, edges=c.edges, stretch_compliance=stretch, hinges=c.bending,
                                          bend_compliance=bend), prescribed=bottom)
    start = rest.copy()
    start[layer.free_nodes] += linear.displacement(moved_forces, moved_targets - rest[bottom])
    expected = turn.apply(x) + shift
    scale = np.abs(x - rest).max()
    assert np.abs(start - expected).max() > 0.3 * scale  # the linear layer's answer is not the moved one
    layer.static(start, moved_forces, moved_targets)
    # both solves converge to 1e-8 of the load; Newton's last step leaves them far closer
    assert np.abs(start - expected).max() <= 1e-8 * scale
