"""Random progressive cuts (Hypothesis): through vertices, along edges, grazing, crossing and re-cutting earlier
cuts, on deformed states, across control nodes and the fixed region, on the built-in models and the shared livers.
After every move every invariant must hold; a refused cut (a loose piece) must leave the solver untouched, and
most moves must cut (a scalpel that refused or skipped every move would otherwise pass)."""

import numpy as np
import pytest
from hypothesis import given, seed, settings
from hypothesis import strategies as st

import tissuesim
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.errors import SolverError
from tissuesim.mesh import models
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))     # the surface-layer methods

SHARED = {"liver2": ("sofa/liver2.obj", 0.01), "softbodyliver": ("softbodyliver/liver.obj", 0.01)}
_HYBRIDS = {}


def _hybrid(name, meshes_dir):
    if name not in _HYBRIDS:
        if name in SHARED:
            path, scale = SHARED[name]
            surface = tissuesim.read_surface(meshes_dir / path, scale=scale)
        else:
            surface = getattr(models, name)()
        _HYBRIDS[name] = tissuesim.HybridMesh.build(surface, fine_volume=False)
    return _HYBRIDS[name]


@st.composite
def strokes(draw):
    """1–3 strokes of 1–4 moves; each stroke starts at a vertex, an edge midpoint, a point in a triangle, or on
    the previous stroke; moves follow an edge, go straight, or turn at random; the blade is inward, tilted or
    grazing; the state may be deformed by a load first."""
    plan = []
    for _ in range(draw(st.integers(1, 3))):
        plan.append({
            "start": draw(st.sampled_from(["vertex", "edge", "facet", "previous"])),
            "seed": draw(st.integers(0, 2**31 - 1)),
            "moves": draw(st.integers(1, 4)),
            "path": draw(st.sampled_from(["edge", "straight", "random"])),
            "blade": draw(st.sampled_from(["inward", "tilted", "grazing"])),
            "step": draw(st.floats(0.3, 2.5)),
            "depth": draw(st.floats(0.5, 3.0)),
            "deform": draw(st.booleans()),
        })
    return plan


def _run(solver, plan, mass):
    h = solver.hybrid
    edge = float(np.mean(np.linalg.norm(h.surface.vertices[h.surface.edges[:, 0]]
                                        - h.surface.vertices[h.surface.edges[:, 1]], axis=1)))
    moves = cuts = 0
    for stroke in plan:
        rng = np.random.default_rng(stroke["seed"])
        s = solver.hybrid.surface
        x = solver.positions
        if stroke["deform"]:
            free = np.setdiff1d(np.arange(solver.node_count), solver.fixed)   # a load on a fixed node is refused
            node = int(rng.choice(free))
            solver.set_load(node, rng.normal(size=3) * 0.2)
            for _ in range(3):
                solver.step()
            solver.clear_load()
        t = int(rng.integers(s.triangle_count))
        if stroke["start"] == "previous" and cuts:
            # re-cut: start on the newest vertex, which lies on an earlier cut
            t = int(np.flatnonzero(np.any(s.triangles == solver.node_count - 1, axis=1))[0])
        a, b, c = s.triangles[t]
        if stroke["start"] == "vertex":
            point = x[a].copy()
        elif stroke["start"] == "edge":
            point = 0.5 * (x[a] + x[b])
        elif stroke["start"] == "previous" and cuts:
            point = x[solver.node_count - 1].copy()
        else:
            point = rng.dirichlet([1, 1, 1]) @ x[[a, b, c]]
        normal = np.cross(x[b] - x[a], x[c] - x[a])
        normal /= np.linalg.norm(normal)
        tangent = {"edge": x[b] - x[a], "straight": rng.normal(size=3), "random": rng.normal(size=3)}[stroke["path"]]
        tangent -= (tangent @ normal) * normal
        tangent /= np.linalg.norm(tangent) + 1e-300
        blade = {"inward": -normal, "tilted": -normal + 0.7 * tangent + 0.3 * rng.normal(size=3),
                 "grazing": -0.15 * normal + np.cross(normal, tangent)}[stroke["blade"]]
        tip = point + 0.3 * edge * normal
        scalpel = tissuesim.Scalpel(solver, depth=stroke["depth"] * edge)
        scalpel.press(tip, direction=blade)
        for _ in range(stroke["moves"]):
            if stroke["path"] == "random":
                tangent = tangent + 0.8 * rng.normal(size=3)
                tangent /= np.linalg.norm(tangent)
            tip = tip + stroke["step"] * edge * tangent
            before = (solver.node_count, solver.hybrid.surface.triangle_count)
            # the quality now is the cut's to keep only where the deformation had not already spoiled it
            sound_now = not any("now" in p for p in _problems(solver, mass, now=True))
            moves += 1
            try:
                report = scalpel.move(tip)
            except SolverError as error:
                assert "would separate" in str(error), error
                assert (solver.node_count, solver.hybrid.surface.triangle_count) == before
                continue
            cuts += report.triangles_split > 0
            assert _problems(solver, mass, now=sound_now) == []
            if solver.name == "hybrid":
                assert np.all(np.isin(solver.hybrid.control, solver.prescribed))
        scalpel.release()
    for _ in range(5):
        solver.step()
    assert np.all(np.isfinite(solver.positions))
    return moves, cuts


def _problems(solver, mass, *, now):
    h = solver.hybrid
    c = solver.constraints
    live = c.edges[:, 0] != c.edges[:, 1]
    return check_cut_invariants(h.surface.vertices, h.surface.triangles,
                                positions=solver.positions if now else None, edges=c.edges[live],
                                rest_length=c.rest_length[live], masses=solver.mass, total_mass=mass)


def _fuzz(meshes_dir, examples, rng_seed):
    """Run ``examples`` random plans drawn from ``rng_seed`` (pinned: a failure replays, and the example database
    keeps it); ``(moves, moves that cut)`` over all of them."""
    tally = np.zeros(2, dtype=int)

    @seed(rng_seed)
    @settings(max_examples=examples, deadline=None)
    @given(model=st.sampled_from(MODELS), method=st.sampled_from(LAYER), plan=strokes())
    def run(model, method, plan):
        solver = tissuesim.make_solver(method, _hybrid(model, meshes_dir))
        tally[:] += _run(solver, plan, solver.mass.sum())

    run()
    return tally


MODELS = [*sorted(models.MODELS), *SHARED]
#: Smallest share of the moves that must cut. Measured: 45 of 109 moves (0.41) in the fast run, 720 of 1,229
#: (0.59) in the slow one; the others are moves shorter than the snap (kept for the next move), grazing
#: blades that miss, and refused loose pieces. A quarter fails a scalpel that cuts nothing, or one move in five.
MIN_CUTTING_SHARE = 0.25


def test_random_cuts_keep_every_invariant(meshes_dir):
    moves, cuts = _fuzz(meshes_dir, 25, 2611)
    print(f"\n{cuts} of {moves} moves cut")
    assert moves > 0 and cuts >= MIN_CUTTING_SHARE * moves, (cuts, moves)


@pytest.mark.slow
def test_a_thousand_random_cuts_keep_every_invariant(meshes_dir):
    moves, cuts = _fuzz(meshes_dir, 250, 2612)
    assert moves > 0 and cuts >= MIN_CUTTING_SHARE * moves, (cuts, moves)
