"""FEM against analytic solutions: the patch test and a cantilever converging toward Timoshenko's deflection."""

import numpy as np
import pytest
import tetgen

from tissuesim.fem.linear import LinearFEM
from tissuesim.mesh import models
from tissuesim.mesh.tetmesh import TetMesh, structured_box

E, NU = 5500.0, 0.3


def face_load_weights(mesh: TetMesh, nodes: np.ndarray) -> np.ndarray:
    """``(n,)`` consistent nodal areas [m²] of a uniform traction on the boundary faces spanned by ``nodes``."""
    tri = mesh.boundary_triangles
    tri = tri[np.all(np.isin(tri, nodes), axis=1)]
    p = mesh.points[tri]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return np.bincount(tri.ravel(), weights=np.repeat(area / 3.0, 3), minlength=mesh.node_count)


def test_patch_test_on_an_unstructured_mesh():
    # TetGen's quality mesh of the built-in cube (edge a = 8 cm, resting on z = 0): irregular interior tets.
    surface = models.cube(400)
    points, tets = tetgen.TetGen(surface.vertices, surface.triangles).tetrahedralize(switches="pq1.4a2e-7Q")[:2]
    mesh = TetMesh(points, tets)
    assert mesh.node_count > mesh.boundary_nodes.size + 100  # there really is an unstructured interior
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    sigma = 250.0  # compressive stress [Pa] on the top face
    top = np.flatnonzero(mesh.points[:, 2] >= hi[2] - 1e-12)
    forces = np.zeros((mesh.node_count, 3))
    forces[:, 2] = -sigma * face_load_weights(mesh, top)
    # Minimal supports: the bottom slides freely (u_z = 0), one corner is pinned, a second corner blocks the spin.
    bottom = mesh.points[:, 2] <= lo[2] + 1e-12
    corner = int(np.argmin(np.linalg.norm(mesh.points - lo, axis=1)))
    across = int(np.argmin(np.linalg.norm(mesh.points - [hi[0], lo[1], lo[2]], axis=1)))
    mask = np.zeros((mesh.node_count, 3), dtype=bool)
    mask[bottom, 2] = True
    mask[corner, :] = True
    mask[across, 1] = True
    u = LinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=mask).solve(forces)
    x = mesh.points - [lo[0], lo[1], 0.0]
    exact = np.column_stack([NU * sigma * x[:, 0] / E, NU * sigma * x[:, 1] / E, -sigma * x[:, 2] / E])
    assert np.abs(u - exact).max() <= 1e-10 * np.abs(exact).max()


def cantilever_tip_ratio(h: float) -> float:
    """Tip deflection of a 100 x 10 x 10 mm beam (clamped at x = 0, shear end load) over Timoshenko's."""
    length, width, height, load = 0.1, 0.01, 0.01, 1e-3
    mesh = structured_box((length, width, height), (round(length / h), round(width / h), round(height / h)))
    clamped = np.flatnonzero(mesh.points[:, 0] <= 1e-12)
    end = np.flatnonzero(mesh.points[:, 0] >= length - 1e-12)
    w = face_load_weights(mesh, end)
    forces = np.zeros((mesh.node_count, 3))
    forces[:, 2] = -load * w / w.sum()
    u = LinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=clamped).solve(forces)
    tip = -np.sum(u[end, 2] * w[end]) / w[end].sum()  # area-weighted mean over the end face
    inertia, shear = width * height**3 / 12.0, E / (2.0 * (1.0 + NU))
    timoshenko = load * length**3 / (3.0 * E * inertia) + load * length / (5.0 / 6.0 * shear * width * height)
    return tip / timoshenko


def test_cantilever_converges_toward_timoshenko():
    ratios = [cantilever_tip_ratio(h) for h in (0.01, 0.005, 0.0025, 0.00125)]
    # Linear tets are too stiff (shear locking in bending); the Kuhn-split mesh gives 0.22, 0.50, 0.79, 0.93.
    assert all(a < b < 1.0 for a, b in zip(ratios, ratios[1:]))
    assert ratios[1] == pytest.approx(0.50, abs=0.05)
    assert ratios[2] == pytest.approx(0.79, abs=0.05)
    assert ratios[3] > 0.9
    errors = 1.0 - np.array(ratios)
    # The error shrinks faster with each halving of h (approaching the O(h²) asymptotic rate).
    assert errors[2] / errors[3] > errors[1] / errors[2] > 2.0
