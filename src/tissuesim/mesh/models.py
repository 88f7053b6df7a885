"""Procedural built-in models at anatomical size, in metres, resting on the plane z = 0.

The paper's cube, sphere, liver and steak (Table 1) came from turbosquid.com and are not public; these stand in for
them at similar vertex counts (about 1,300–1,550 by default). Every model is deterministic: the same arguments give
bit-identical meshes. ``resolution`` is the approximate number of surface vertices.

Liver and steak are star-shaped about their centre: points spread evenly over the surface (farthest-point sampling
of a dense area-uniform sample) are triangulated by the convex hull of their directions from the centre, which is a
valid triangulation of the sphere and so of any star-shaped surface over it.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.spatial import ConvexHull, Delaunay

from ..errors import MeshError
from .surface import SurfaceMesh

# Sizes [m]: a cube and a sphere of organ scale; a liver of adult size; a steak of butcher's size.
CUBE_EDGE = 0.08
SPHERE_RADIUS = 0.05
LIVER_SEMI_AXES = (0.11, 0.075, 0.045)
STEAK_SEMI_AXES = (0.08, 0.055, 0.0125)

DEFAULT_RESOLUTION = {"cube": 1352, "sphere": 1402, "liver": 1379, "steak": 1543}
MIN_RESOLUTION = 50
#: Largest vertex count of a built-in model: 70 times the Table-1 sizes (about 1400), so a typo such as 1e12 is refused
#: at once instead of exhausting the memory while the model is built.
MAX_RESOLUTION = 100_000


def cube(resolution: int = DEFAULT_RESOLUTION["cube"], *, edge: float = CUBE_EDGE) -> SurfaceMesh:
    """An axis-aligned cube of side ``edge`` [m], each face a regular grid split into triangles.

    A grid of ``k`` points per edge gives ``6 (k-1)² + 2`` vertices; ``k`` is chosen to land nearest ``resolution``.
    """
    _check_resolution(resolution)
    k = max(2, int(round(np.sqrt((resolution - 2) / 6.0))) + 1)
    t = np.linspace(0.0, 1.0, k)
    u, v = np.meshgrid(t, t, indexing="ij")
    grid = np.stack([u.ravel(), v.ravel()], axis=1)
    quads = np.array([[i * k + j, (i + 1) * k + j, (i + 1) * k + j + 1, i * k + j + 1]
                      for i in range(k - 1) for j in range(k - 1)])
    # Alternate the diagonal so the faces have no preferred direction.
    flip = ((np.arange(k - 1)[:, None] + np.arange(k - 1)[None, :]) % 2).ravel().astype(bool)
    tri = np.where(flip[:, None, None],
                   np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1),
                   np.stack([quads[:, [0, 1, 3]], quads[:, [1, 2, 3]]], axis=1)).reshape(-1, 3)
    points, triangles = [], []
    for axis in range(3):
        for side in (0.0, 1.0):
            face = np.empty((len(grid), 3))
            a, b = (axis + 1) % 3, (axis + 2) % 3
            face[:, axis], face[:, a], face[:, b] = side, grid[:, 0], grid[:, 1]
            # (a, b, axis) is right-handed, so grid order faces +axis; reverse it on the low side.
            triangles.append((tri if side else tri[:, ::-1]) + sum(len(p) for p in points))
            points.append(face)
    vertices, triangles = _merge(np.concatenate(points), np.concatenate(triangles))
    vertices = (vertices - [0.5, 0.5, 0.0]) * edge
    return SurfaceMesh(vertices, triangles)


def sphere(resolution: int = DEFAULT_RESOLUTION["sphere"], *, radius: float = SPHERE_RADIUS) -> SurfaceMesh:
    """A sphere of ``radius`` [m] from a Fibonacci lattice of exactly ``resolution`` points."""
    _check_resolution(resolution)
    directions = _fibonacci_directions(resolution)
    return _on_plane(SurfaceMesh(radius * directions, _hull_triangles(directions)))


def liver(resolution: int = DEFAULT_RESOLUTION["liver"]) -> SurfaceMesh:
    """A liver-like closed shape: a thick right lobe tapering to a thin left lobe, a domed top, a flatter base."""
    a, b, c = LIVER_SEMI_AXES

    def radius(d):
        x, y, z = d[:, 0], d[:, 1], d[:, 2]
        base = 1.0 / np.sqrt((x / a) ** 2 + (y / b) ** 2 + (z / c) ** 2)
        taper = 1.0 - 0.28 * np.clip(-x, 0.0, None) * (1.0 + z)      # thin left lobe, thinner at its top
        dome = 1.0 + 0.12 * np.clip(z, 0.0, None) * (1.0 + x)         # right lobe rises
        base_flat = 1.0 - 0.18 * np.clip(-z, 0.0, None) ** 2            # visceral surface is flatter
        notch = 1.0 - 0.10 * np.exp(-((x - 0.15) ** 2 + (y - 0.95) ** 2) / 0.04)  # gallbladder notch
        ripple = 1.0 + 0.025 * np.sin(5.0 * x + 3.0 * y) * np.cos(4.0 * z - 2.0 * x)
        return base * taper * dome * base_flat * notch * ripple

    return _star_shaped(radius, resolution)


def steak(resolution: int = DEFAULT_RESOLUTION["steak"]) -> SurfaceMesh:
    """A flat slab with a rounded, slightly irregular outline and rounded rims (a superellipsoid)."""
    a, b, c = STEAK_SEMI_AXES

    def radius(d):
        x, y, z = d[:, 0], d[:, 1], d[:, 2]
        azimuth = np.arctan2(y, x)
        wobble = 1.0 + 0.06 * np.sin(3.0 * azimuth + 0.4) + 0.035 * np.cos(5.0 * azimuth - 1.1)
        # |x/a|^p + |y/b|^p + |z/c|^q = 1 along d, solved for the radius by bisection (monotone in r).
        p, q = 2.4, 6.0
        lo, hi = np.zeros(len(d)), np.full(len(d), 2.0 * max(a, b))
        for _ in range(60):
            r = 0.5 * (lo + hi)
            f = np.abs(r * x / (a * wobble)) ** p + np.abs(r * y / (b * wobble)) ** p + np.abs(r * z / c) ** q
            inside = f < 1.0
            lo, hi = np.where(inside, r, lo), np.where(inside, hi, r)
        return 0.5 * (lo + hi)

    return _star_shaped(radius, resolution)


def indentation_block(*, width: float = 0.08, height: float = 0.04, fine_edge: float = 0.5e-3,
                      fine_radius: float = 3e-3, coarse_edge: float = 8e-3, growth: float = 1.25) -> SurfaceMesh:
    """A block for indentation tests: ``width`` × ``width`` × ``height`` [m], centred over the origin in x and y,
    resting on z = 0, whose top face is graded fine around its centre and coarse far from it.

    The top face is triangulated (Delaunay) from rings about its centre: ring spacing and the spacing along each ring
    are ``fine_edge`` [m] out to ``fine_radius`` [m], then grow by ``growth`` per ring up to ``coarse_edge`` [m];
    the rest of the top, the sides and the bottom are grids of ``coarse_edge``. So a contact of radius a at the
    centre spans a / ``fine_edge`` edges while the block stays thick and wide compared with a (Hertz's half-space)
    at a few thousand vertices. TetGen grades the volume from the surface.
    """
    for name, value in (("width", width), ("height", height), ("fine_edge", fine_edge),
                        ("fine_radius", fine_radius), ("coarse_edge", coarse_edge)):
        if not np.isfinite(value) or value <= 0.0:
            raise MeshError(f"indentation block: {name} must be a positive number of metres, got {value!r}")
    if not fine_edge <= coarse_edge <= min(width, height) / 2 or fine_radius >= width / 2 - 2 * coarse_edge:
        raise MeshError(
            f"indentation block: need fine_edge ≤ coarse_edge ≤ half the smaller side and fine_radius < width/2 − "
            f"2 coarse_edge, got fine_edge {fine_edge:g}, coarse_edge {coarse_edge:g}, fine_radius {fine_radius:g}, "
            f"width {width:g}, height {height:g} m; shrink the fine patch or the coarse edge")
    if not 1.0 < growth <= 2.0:
        raise MeshError(f"indentation block: growth is a ratio in (1, 2], got {growth!r}")
    half = width / 2
    across = _edge_points(-half, half, coarse_edge)
    up = _edge_points(0.0, height, coarse_edge)
    faces = [
        (_top_points(half, across, fine_edge, fine_radius, coarse_edge, growth), (0, 1, 2), height, +1),
        (_grid(across, across), (0, 1, 2), 0.0, -1),
        (_grid(across, up), (0, 2, 1), -half, -1),
        (_grid(across, up), (0, 2, 1), half, +1),
        (_grid(across, up), (1, 2, 0), -half, -1),
        (_grid(across, up), (1, 2, 0), half, +1),
    ]
    points, triangles, offset = [], [], 0
    for plane, (a, b, normal), level, side in faces:
        tri = Delaunay(plane).simplices.astype(np.int64)
        face = np.empty((len(plane), 3))
        face[:, a], face[:, b], face[:, normal] = plane[:, 0], plane[:, 1], level
        e1, e2 = face[tri[:, 1]] - face[tri[:, 0]], face[tri[:, 2]] - face[tri[:, 0]]
        outward = np.cross(e1, e2)[:, normal] * side > 0
        triangles.append(np.where(outward[:, None], tri, tri[:, ::-1]) + offset)
        points.append(face)
        offset += len(plane)
    vertices, triangles = _merge(np.concatenate(points), np.concatenate(triangles))
    return SurfaceMesh(vertices, triangles)


def _edge_points(lo: float, hi: float, spacing: float) -> np.ndarray:
    """``(k,) float64`` evenly spaced coordinates from ``lo`` to ``hi`` [m], at most ``spacing`` apart."""
    return np.linspace(lo, hi, max(2, int(np.ceil((hi - lo) / spacing - 1e-9)) + 1))


def _grid(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(len(u) len(v), 2) float64`` the tensor grid of coordinates ``u`` and ``v``."""
    a, b = np.meshgrid(u, v, indexing="ij")
    return np.stack([a.ravel(), b.ravel()], axis=1)


def _top_points(half, across, fine_edge, fine_radius, coarse_edge, growth) -> np.ndarray:
    """The top face's points ``(k, 2)`` [m]: the boundary grid, rings about the centre (graded, see
    :func:`indentation_block`), and the coarse grid beyond the last ring."""
    rings, radius, spacing, turn = [np.zeros((1, 2))], 0.0, fine_edge, 0.0
    while radius + spacing < half - 1.5 * coarse_edge:
        radius += spacing
        count = max(6, int(round(2 * np.pi * radius / spacing)))
        turn += 0.5 * 2 * np.pi / count     # stagger neighbouring rings, so no spokes line up
        angles = turn + 2 * np.pi * np.arange(count) / count
        rings.append(radius * np.stack([np.cos(angles), np.sin(angles)], axis=1))
        if radius >= fine_radius:
            spacing = min(spacing * growth, coarse_edge)
    grid = _grid(across, across)
    on_boundary = np.any(np.isclose(np.abs(grid), half), axis=1)
    beyond = np.linalg.norm(grid, axis=1) > radius + 0.75 * coarse_edge
    return np.concatenate([*rings, grid[on_boundary | beyond]])


MODELS: dict[str, Callable[..., SurfaceMesh]] = {"cube": cube, "sphere": sphere, "liver": liver, "steak": steak}


def model(name: str, resolution: int | None = None) -> SurfaceMesh:
    """The built-in model ``name`` (one of :data:`MODELS`) at ``resolution`` vertices (default: Table 1 size)."""
    try:
        factory = MODELS[name]
    except KeyError:
        raise MeshError(f"unknown model {name!r}; choose one of {', '.join(MODELS)}") from None
    return factory(DEFAULT_RESOLUTION[name] if resolution is None else resolution)


def _check_resolution(resolution: int) -> None:
    if int(resolution) != resolution or resolution < MIN_RESOLUTION:
        raise MeshError(f"resolution must be an integer ≥ {MIN_RESOLUTION} vertices, got {resolution!r}")


def _fibonacci_directions(count: int) -> np.ndarray:
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    phi = np.pi * (1.0 + np.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _hull_triangles(directions: np.ndarray) -> np.ndarray:
    """Outward-oriented triangles of the convex hull of unit ``directions`` (all of which are hull vertices)."""
    triangles = ConvexHull(directions).simplices.astype(np.int32)
    p = directions[triangles]
    outward = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.sum(axis=1)) > 0
    return np.where(outward[:, None], triangles, triangles[:, ::-1])


def _star_shaped(radius: Callable[[np.ndarray], np.ndarray], resolution: int) -> SurfaceMesh:
    """Evenly spaced ``resolution`` points on the surface ``r(d) d`` (|d| = 1), triangulated over the sphere."""
    _check_resolution(resolution)
    dense = _fibonacci_directions(16 * resolution)
    points = radius(dense)[:, None] * dense
    # Area weights of the dense sample: the radial surface's area element is r² / cos(angle to normal) dω; a
    # local estimate by the hull triangles of the dense directions is simpler and as good.
    triangles = _hull_triangles(dense)
    tri = points[triangles]
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    weight = np.zeros(len(dense))
    np.add.at(weight, triangles.ravel(), np.repeat(areas / 3.0, 3))
    chosen = _farthest_points(points, resolution, weight)
    directions = dense[chosen]
    return _on_plane(SurfaceMesh(points[chosen], _hull_triangles(directions)))


def _farthest_points(points: np.ndarray, count: int, weight: np.ndarray) -> np.ndarray:
    """Greedy farthest-point sampling, started at the heaviest point: deterministic and evenly spread."""
    chosen = np.empty(count, dtype=np.int64)
    chosen[0] = int(np.argmax(weight))
    x, y, z = (np.ascontiguousarray(c) for c in points.T)
    distance = np.full(len(points), np.inf)
    for k in range(count):
        if k:
            chosen[k] = int(np.argmax(distance))
        px, py, pz = points[chosen[k]]
        np.minimum(distance, (x - px) ** 2 + (y - py) ** 2 + (z - pz) ** 2, out=distance)
    return chosen


def _merge(points: np.ndarray, triangles: np.ndarray, decimals: int = 9):
    keys = np.round(points, decimals)
    _, index, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return points[index], inverse.ravel()[triangles].astype(np.int32)


def _on_plane(surface: SurfaceMesh) -> SurfaceMesh:
    """Centre the model over the origin in x and y and rest it on z = 0."""
    lo, hi = surface.bounds
    return surface.with_vertices(surface.vertices - [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
