"""One cut of the pure core on arrays: geometry carried by barycentric coordinates, topology sound."""

import numpy as np
import pytest

from tissuesim.cutting import Sweep, cut_surface
from tissuesim.cutting.invariants import boundary_loops, check_cut_invariants
from tissuesim.cutting.separate import separate
from tissuesim.mesh import models


@pytest.fixture(scope="module")
def cube():
    surface = models.cube()
    return surface.vertices, surface.triangles


def _stroke(rest, triangles, xs, *, y=0.0011, positions=None, snap=0.25):
    """A progressive cut across the cube's top along x at height y, one sweep per step of xs."""
    positions = rest.copy() if positions is None else positions
    velocities = np.zeros_like(rest)
    top = rest[:, 2].max()
    closed = np.zeros((0, 2), dtype=np.int64)
    tip = np.array([xs[0], y, top])
    results = []
    for x in xs[1:]:
        new_tip = np.array([x, y, top])
        result = cut_surface(rest, positions, velocities, triangles, Sweep.between(tip, new_tip, [0, 0, -0.01]),
                             snap=snap, closed=closed)
        if result is None:
            continue                         # nothing cut: the next sweep starts where this one did
        if result.end_vertex >= 0:           # go on from where the cut stopped, as the scalpel does
            end = result.positions[result.end_vertex]
            new_tip = np.array([end[0], end[1], top])
        rest, positions, velocities = result.rest, result.positions, result.velocities
        triangles, closed = result.triangles, result.closed
        results.append(result)
        tip = new_tip
    return results


def test_a_slit_across_the_top_keeps_every_invariant_and_takes_chi_to_one(cube):
    rest, triangles = cube
    results = _stroke(rest, triangles, np.linspace(-0.015, 0.015, 11))
    last = results[-1]
    assert check_cut_invariants(last.rest, last.triangles, positions=last.positions) == []
    assert boundary_loops(last.triangles, len(last.rest)) == 1
    chi = len(last.rest) - len(np.unique(np.sort(last.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1),
                                         axis=0)) + len(last.triangles)
    assert chi == 1
    gap_vertices = sum(int(np.count_nonzero(r.copy_of >= 0)) for r in results)
    assert gap_vertices > 5


def test_new_vertices_are_barycentric_in_the_rest_triangle_and_moved_ones_lie_on_their_edge(cube):
    """A cut moves nothing but the vertices it puts onto the cut, each along one of its edges by the same weights at
    rest and now; new vertices interpolate the (moved) corners of their parent triangle."""
    rest, triangles = cube
    rng = np.random.default_rng(3)
    deformed = rest + 0.002 * rng.normal(size=rest.shape)
    result = _stroke(rest, triangles, [-0.01, 0.01], positions=deformed)[0]
    moves = result.moves
    assert len(moves) > 0 and np.all((moves.t > 0.0) & (moves.t < 0.25))
    n = len(rest)
    for array, old in ((result.rest, rest), (result.positions, deformed)):
        moved = old.copy()
        moved[moves.vertices] = (1.0 - moves.t[:, None]) * old[moves.vertices] + moves.t[:, None] * old[moves.toward]
        assert np.array_equal(array[:n], moved)        # exact: the other old rows are copied
        assert np.allclose(array[n:], np.einsum("ij,ijk->ik", result.weights, moved[result.parents]), atol=1e-15)
    assert np.array_equal(result.moved_from, rest[moves.vertices])
    area = lambda p, t: 0.5 * np.linalg.norm(np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]), axis=1)
    # the stroke stays on the cube's flat top, where moving a vertex inside its fan keeps the fan's area
    assert area(result.rest, result.triangles).sum() == pytest.approx(area(rest, triangles).sum(), rel=1e-12)
    # every piece lies in the triangle it came from (with its moved corners): its rest area sums to the parent's
    origin_area = np.bincount(result.triangle_origin, weights=area(result.rest, result.triangles))
    assert origin_area == pytest.approx(area(result.rest[:n], triangles)[: len(origin_area)], rel=1e-9)
    # the moved vertices' triangles are among the changed rows, unchanged in content
    rows = np.flatnonzero(np.isin(triangles, moves.vertices).any(axis=1))
    assert np.isin(rows, result.changed).all()


def test_a_cut_exactly_along_an_edge_and_through_vertices(cube):
    rest, triangles = cube
    top = rest[:, 2].max()
    on_top = np.flatnonzero(rest[:, 2] == top)
    a = on_top[np.argmin(np.linalg.norm(rest[on_top, :2], axis=1))]
    edges = {tuple(sorted((int(t[i]), int(t[(i + 1) % 3])))) for t in triangles for i in range(3)}
    b = next(v for v in on_top if tuple(sorted((int(a), int(v)))) in edges)
    tip0 = rest[a] - 0.2 * (rest[b] - rest[a])
    tip1 = rest[b] + 0.2 * (rest[b] - rest[a])
    result = cut_surface(rest, rest, np.zeros_like(rest), triangles, Sweep.between(tip0, tip1, [0, 0, -0.01]),
                         snap=0.25)
    assert result is not None
    assert (min(a, b), max(a, b)) in {tuple(e) for e in result.cut_edges.tolist()}
    assert check_cut_invariants(result.rest, result.triangles, positions=result.positions) == []


def test_a_sweep_that_misses_the_surface_changes_nothing(cube):
    rest, triangles = cube
    assert cut_surface(rest, rest, np.zeros_like(rest), triangles,
                       Sweep.between([0, 0, 0.2], [0.01, 0, 0.2], [0, 0, 0.01])) is None


def _patch(triangles):
    from tissuesim.cutting.fans import VertexFans
    from tissuesim.cutting.row_patch import RowPatch

    return RowPatch(triangles, VertexFans(triangles, 16), 16)


def test_separate_duplicates_inner_vertices_of_a_path_not_its_tips():
    # a 3 x 3 grid of quads, each split into two triangles; cut along the middle row's inner edges
    xs, ys = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    index = xs * 4 + ys
    tris = []
    for i in range(3):
        for j in range(3):
            a, b, c, d = index[i, j], index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]
            tris += [(a, b, c), (a, c, d)]
    tris = np.array(tris, dtype=np.int64)
    path = [(index[0, 2], index[1, 2]), (index[1, 2], index[2, 2]), (index[2, 2], index[3, 2])]
    path_inner = [(index[1, 2], index[2, 2]), (index[2, 2], index[3, 2])]
    copies, closed, _ = separate(_patch(tris), path_inner, 16)
    # the inner vertex and the one on the open border split; the tip index[1, 2] stays whole ...
    assert sorted(copies.tolist()) == [index[2, 2], index[3, 2]]
    assert closed == []
    copies, _, _ = separate(_patch(tris), path, 16)
    assert sorted(copies.tolist()) == sorted(index[:, 2].tolist())     # ... and splits once the path goes on
    copies, closed, _ = separate(_patch(tris), [(index[1, 1], index[1, 2])], 16)
    assert copies.size == 0 and closed == [(index[1, 1], index[1, 2])]     # one inner edge: nothing opens


@pytest.mark.parametrize("defect", ["sliver", "flip", "bow tie", "three triangles", "length", "mass"])
def test_the_invariant_check_finds_each_defect(cube, defect):
    rest, triangles = np.array(cube[0]), np.array(cube[1], dtype=np.int64)
    kwargs = {}
    if defect == "sliver":
        a, b, c = triangles[0]
        rest[c] = rest[a] + 1e-4 * (rest[b] - rest[a])
        expected = "sliver"
    elif defect == "flip":
        triangles[0] = triangles[0, ::-1]
        expected = "orientation"
    elif defect == "bow tie":
        # glue two separate cubes at one vertex
        n = len(rest)
        rest = np.concatenate([rest, rest + [0.1, 0, 0]])
        far = triangles + n
        far[far == n] = 0
        triangles = np.concatenate([triangles, far])
        expected = "not manifold"
    elif defect == "three triangles":
        triangles = np.concatenate([triangles, triangles[:1, [0, 1]].tolist() and
                                    np.array([[triangles[0, 0], triangles[0, 1], triangles[5, 2]]])])
        expected = "more than two triangles"
    elif defect == "length":
        edges = np.unique(np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
        lengths = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1)
        lengths[3] *= 1.01
        kwargs = dict(edges=edges, rest_length=lengths)
        expected = "rest lengths differ"
    else:
        kwargs = dict(masses=np.ones(len(rest)), total_mass=len(rest) + 1e-3)
        expected = "total mass"
    problems = check_cut_invariants(rest, triangles, **kwargs)
    assert any(expected in p for p in problems), problems


@pytest.mark.parametrize("slit_by", ["the same buffers", "an earlier surface"])
def test_in_place_cut_finds_what_the_full_search_finds_across_an_earlier_wound(cube, slit_by):
    # the in-place core searches the sweep's triangles by walking from the cut; a cross cut over an open slit must
    # reach the slit's far side (through the duplicated vertices, whether it saw them made or not) and cut exactly
    # what the full search cuts
    from tissuesim.cutting.buffers import CutSurface
    from tissuesim.cutting.core import plan_cut
    from tissuesim.cutting.sweep import candidate_triangles

    rest, triangles = cube
    top = rest[:, 2].max()
    if slit_by == "an earlier surface":
        slit = _stroke(rest, triangles, np.linspace(-0.02, 0.02, 9))[-1]
        surface = CutSurface(slit.rest, slit.positions, slit.velocities, slit.triangles)
        closed = slit.closed
    else:
        surface = CutSurface(rest, rest, np.zeros_like(rest), triangles)
        closed, seeds, tip = np.zeros((0, 2), dtype=np.int64), [], np.array([-0.02, 0.0011, top])
        for x in np.linspace(-0.02, 0.02, 9)[1:]:
            sweep = Sweep.between(tip, [x, 0.0011, top], [0, 0, -0.01])
            plan = surface.plan(sweep, snap=0.25, closed=closed, seeds=seeds)
            tip = np.array([x, 0.0011, top])
            if plan is not None:
                done = surface.apply(plan, sweep)
                closed, seeds = done.closed, [done.end_vertex]
                tip = np.array([*done.positions[done.end_vertex, :2], top])
    sweep = Sweep.between([0.0013, -0.006, top], [0.0013, 0.006, top], [0, 0, -0.01])
    seed = int(np.argmin(np.linalg.norm(surface.rest - [0.0013, -0.006, top], axis=1)))
    walked = surface.plan(sweep, snap=0.25, closed=closed, seeds=[seed])
    full = plan_cut(surface.rest, surface.positions, surface.triangles, sweep, snap=0.25, closed=closed,
                    fans=surface.fans, near=candidate_triangles(surface.positions, surface.triangles, sweep))
    assert full is not None and full.split_count >= 2     # both sides of the slit (vertices moved onto it split none)
    assert np.array_equal(walked.changed, full.changed) and np.array_equal(walked.parents, full.parents)
    applied = surface.apply(walked, sweep)
    assert check_cut_invariants(applied.rest, applied.triangles) == []


def test_the_walk_finds_the_connected_rows_in_the_box_through_a_wound(cube):
    # oracle: connected components (scipy) of the rows whose box overlaps, joined by a shared vertex or by two
    # vertices at one rest position (the sides of a wound)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from tissuesim.cutting.buffers import CutSurface
    from tissuesim.mesh.coincident import coincident_pairs

    rest, triangles = cube
    slit = _stroke(rest, triangles, np.linspace(-0.02, 0.02, 9))[-1]
    surface = CutSurface(slit.rest, slit.positions, slit.velocities, slit.triangles)
    tri, p = surface.triangles, surface.positions
    group = np.arange(len(p))
    pairs = coincident_pairs(surface.rest)
    group[pairs[:, 1]] = pairs[:, 0]
    box_lo, box_hi = p[tri].min(axis=1), p[tri].max(axis=1)
    rng = np.random.default_rng(1)
    for _ in range(20):
        centre = p[rng.integers(len(p))]
        low, high = centre - rng.uniform(0.002, 0.02, 3), centre + rng.uniform(0.002, 0.02, 3)
        inside = np.flatnonzero(np.all((box_lo <= high) & (box_hi >= low), axis=1))
        seed = int(rng.choice(inside))
        rows = np.repeat(np.arange(inside.size), 3)
        corner = group[tri[inside].ravel()]
        graph = coo_matrix((np.ones(rows.size), (rows, inside.size + corner)),
                           shape=(inside.size + len(p), inside.size + len(p)))
        _, label = connected_components(graph, directed=False)
        expected = inside[label[:inside.size] == label[np.searchsorted(inside, seed)]]
        assert np.array_equal(surface.fans.near(tri, p, low, high, [seed]), expected)
