"""The grasper against what nobody here wrote.

A grasper pressing a patch of radius a straight down by δ is a rigid flat punch bonded to the surface. On an elastic
half-space Sneddon gives the frictionless punch F = 2 a E* δ (E* = E / (1 − ν²)); bonded (no slip), Mossakovskii
(1954) gives F = 4 μ a δ ln(3 − 4ν) / (1 − 2ν), 2.9 % stiffer at ν = 0.3 and equal to Sneddon's at ν = 1/2. The held
vertices lie within the jaws' reach: the punch's edge lies between the last held ring and the next, so its radius is
taken half an edge beyond the held ring (an uncertainty of ± half an edge, ± 12 % at 0.5 mm edges and a = 2 mm). The
block is the Hertz tests' (80 × 80 × 40 mm, a layer bonded to its base: under 2 % stiffer than a half-space at
a / H = 0.06). δ = 0.02 mm ≪ a: the small-displacement limit.
"""


import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tissuesim import Grasper, HybridMesh, make_solver
from tissuesim.mesh import models
from tissuesim.solvers import method_names

E, NU = 5500.0, 0.3
SHEAR = E / (2.0 * (1.0 + NU))
PUNCH = 2e-3          # [m] the held ring's radius
DEPTH = 0.02e-3       # [m]
EDGE = 0.5e-3         # [m] the block's fine edge


def sneddon(radius, depth):
    return 2.0 * radius * E / (1.0 - NU**2) * depth


def mossakovskii(radius, depth):
    return 4.0 * SHEAR * radius * depth * np.log(3.0 - 4.0 * NU) / (1.0 - 2.0 * NU)


def punch_force(solver) -> tuple[float, float]:
    """``(F [N] pushing back on the jaws, the punch's radius [m])`` of a press of :data:`DEPTH`."""
    top = float(solver.rest_positions[:, 2].max())
    grasper = Grasper(solver, radius=PUNCH + 0.5 * EDGE * 0.999, tolerance=1e-4 * DEPTH)
    held = grasper.grab([0.0, 0.0, top])
    force = grasper.move_to([0.0, 0.0, top - DEPTH])
    ring = float(np.linalg.norm(solver.rest_positions[held, :2], axis=1).max())
    # straight down: a sideways reaction only from the mesh's asymmetry (measured 0.4 %)
    assert abs(force[0]) + abs(force[1]) <= 1e-2 * force[2]
    return float(force[2]), ring + 0.5 * EDGE


def test_a_bonded_flat_punch_meets_mossakovskii_and_sneddon(hertz):
    block = hertz.block(EDGE)
    # measured: quadratic tets 1.028 of Mossakovskii, the fem's linear tets 1.119, the hybrid's quadratic M_V 1.112
    for method, options, tolerance in ((hertz.quadratic_method(), {}, 0.05), ("fem", {}, 0.15),
                                       ("hybrid", {"element": "quadratic"}, 0.15)):
        solver = make_solver(method, block, youngs_modulus=E, poisson_ratio=NU, **options)
        force, radius = punch_force(solver)
        assert abs(force / mossakovskii(radius, DEPTH) - 1.0) <= tolerance, (method, force)
        # bonded is stiffer than frictionless, by less than the mesh's own error
        assert 1.0 < force / sneddon(radius, DEPTH) <= 1.0 + tolerance + 0.03, (method, force)


def test_the_punch_is_linear_in_depth_and_material(hertz):
    block = hertz.block(EDGE)
    solver = make_solver("fem", block, youngs_modulus=E, poisson_ratio=NU)
    top = float(solver.rest_positions[:, 2].max())
    grasper = Grasper(solver, radius=PUNCH, tolerance=1e-12)
    grasper.grab([0.0, 0.0, top])
    shallow = grasper.move_to([0.0, 0.0, top - DEPTH])[2]
    deep = grasper.move_to([0.0, 0.0, top - 2 * DEPTH])[2]
    pulled = grasper.move_to([0.0, 0.0, top + DEPTH])[2]
    assert abs(deep / shallow - 2.0) <= 1e-8 and abs(pulled / shallow + 1.0) <= 1e-8
    stiffer = make_solver("fem", block, youngs_modulus=2 * E, poisson_ratio=NU)
    other = Grasper(stiffer, radius=PUNCH, tolerance=1e-12)
    other.grab([0.0, 0.0, top])
    assert abs(other.move_to([0.0, 0.0, top - DEPTH])[2] / shallow - 2.0) <= 1e-8


@pytest.mark.parametrize("method", method_names(material="neo-hookean"))
def test_a_rigid_motion_of_the_grasper_and_the_base_moves_the_body_rigidly(method):
    # finite strain: turned 0.4 rad and carried 3 mm with its base, the body is strained nowhere and the jaws feel
    # nothing (linear elasticity would inflate it by about 1 + θ²)
    block = HybridMesh.build(models.indentation_block(width=0.03, height=0.012, fine_edge=2e-3, fine_radius=5e-3,
                                                      coarse_edge=4e-3))
    solver = make_solver(method, block, material="neo-hookean")
    turn = Rotation.from_rotvec([0.4, 0.1, 0.0]).as_matrix()
    shift = np.array([1e-3, -2e-3, 3e-3])
    rest = solver.rest_positions
    grip = np.array([0.0, 0.0, rest[:, 2].max()])
    grasper = Grasper(solver, radius=4.5e-3, tolerance=1e-8)
    grasper.grab(grip)
    solver.set_fixed_positions(rest[solver.fixed] @ turn.T + shift)
    grasper.move_to(grip @ turn.T + shift, turn)
    assert np.abs(solver.positions - (rest @ turn.T + shift)).max() <= 1e-7       # rigid to a tenth of a micron
    assert np.linalg.norm(grasper.force) <= 1e-6 and np.linalg.norm(grasper.torque) <= 1e-8
