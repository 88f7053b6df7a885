"""Sweep item 9: a sliver triangle that TetGen cannot fill is refused by validation, naming the triangle."""

import numpy as np
import pytest

from tissuesim import MeshError
from tissuesim.mesh import models
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.mesh.tetrahedralize import tetrahedralize
from tissuesim.mesh.validate import validate_surface


def cube_with_a_sliver(height: float) -> tuple[SurfaceMesh, int]:
    """The cube with one top-face corner moved to ``height`` [m] from the opposite edge of its triangle."""
    cube = models.cube(resolution=386)
    v, t = cube.vertices.copy(), cube.triangles
    top = np.isclose(v[:, 2], v[:, 2].max())
    inner = top & (np.abs(v[:, 0]) < 0.03) & (np.abs(v[:, 1]) < 0.03)
    triangle = int(np.flatnonzero(inner[t].all(axis=1))[0])
    a, b, c = t[triangle]
    middle = 0.5 * (v[b] + v[c])
    v[a] = middle + height * (v[a] - middle) / np.linalg.norm(v[a] - middle)
    return SurfaceMesh(v, t), triangle


@pytest.mark.parametrize("height", [1e-9, 1e-6])
def test_a_sliver_is_refused_naming_the_triangle(height):
    surface, triangle = cube_with_a_sliver(height)
    with pytest.raises(MeshError, match=rf"1 sliver triangles .*first: {triangle}\b.*remesh"):
        validate_surface(surface)


def test_tetgen_changing_the_boundary_is_not_blamed_on_a_non_manifold_surface():
    surface, _ = cube_with_a_sliver(1e-9)          # closed and manifold; TetGen adds a boundary node at the sliver
    with pytest.raises(MeshError) as caught:
        tetrahedralize(surface)
    message = str(caught.value)
    assert "not a closed manifold" not in message
    assert "TetGen changed the boundary" in message and "validate_surface" in message
