"""The cutting fuzz: random scalpel strokes on deformed surfaces, with loads between moves, for every cutting method
and both time integrators of the surface layer.

After every move, checks that do not use the cutting code:

* every piece of the surface (a connected component, found here with scipy.sparse.csgraph) holds a prescribed node:
  a fixed node, or for the hybrid a control node that is still held (the embedded method holds every vertex through
  its tet, so it keeps loose pieces by design);
* consistent orientation: every edge walked at most once in each direction; no zero-area triangle; quality
  4√3 A / Σ l² at rest at least the documented floor, and now, where the deformation had not already spoiled it;
* the solver's stretch rows (constraints or springs) rest at the rest distance of their ends, one per edge;
* the total mass is kept;
* a refused move changes nothing: positions, velocities, rest positions, triangles, fixed nodes.

Between moves the solver steps under a small load beside the cut; what the load adds to the motion (the difference
from the same steps without it, so that the deformation a stroke left does not count) must stay within
:data:`BOUND` times what the same load does to the uncut model in as many steps.

Hypothesis runs with a pinned seed (the failing example's blob is printed, and it is kept in the example database);
every health check is on. Failing episodes are not shrunk: one episode steps two solvers per move, and shrinking one
took over a minute; the printed example replays it as found. The slow run counts every failure over its 2,000 moves
and prints each with its episode, instead of stopping at the first.
"""

import numpy as np
import pytest
from hypothesis import Phase, given, seed, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import tissuesim
from tissuesim.errors import TissuesimError
from tissuesim.mesh import models

#: (method, options): every cutting method, and both integrators of the xpbd surface layer.
CONFIGS = [("hybrid", {}), ("hybrid", {"integrator": "xpbd"}), ("pbd", {}), ("pbd", {"integrator": "xpbd"}),
           ("mass-spring", {}), ("embedded", {})]
#: Quality floor at rest and now (the documented one of the cutting module, restated: the check must not read it).
MIN_QUALITY = 0.01
#: What a small load may add, as a multiple of the uncut model's answer. A vertex on a lip has half the support of
#: one inside an intact surface, and a tongue hanging on one edge less (3.5x measured for the hybrid's worst,
#: tests/robustness/test_robust_cut_flap.py); a layer thinned by a cut gave 51x.
BOUND = 5.0
#: Contact radius [m] of the load check: the project's pin-head tip (a load on one node is singular in elasticity,
#: and would put the whole force on a vertex of a sliver a cut left).
TIP_RADIUS = 0.004
#: Steps of the load check (dt 10 ms): long enough for the light new vertices to feel their support.
LOAD_STEPS = 5
_HYBRIDS, _UNCUT = {}, {}


def _hybrid(model):
    if model not in _HYBRIDS:
        _HYBRIDS[model] = tissuesim.HybridMesh.build(getattr(models, model)(), fine_volume=False)
    return _HYBRIDS[model]


@st.composite
def strokes(draw):
    """1–3 strokes of 1–5 moves, each with its own start, path, blade, depth, and small loads [N]."""
    return [{
        "seed": draw(st.integers(0, 2**31 - 1)),
        "start": draw(st.sampled_from(["vertex", "edge", "facet", "previous"])),
        "moves": draw(st.integers(1, 5)),
        "path": draw(st.sampled_from(["edge", "straight", "random"])),
        "blade": draw(st.sampled_from(["inward", "tilted", "grazing"])),
        "step": draw(st.floats(0.3, 2.5)),
        "depth": draw(st.floats(0.5, 3.0)),
        "deform": draw(st.sampled_from([0.0, 0.1, 0.2])),
        "force": draw(st.floats(0.05, 0.2)),
    } for _ in range(draw(st.integers(1, 3)))]


class Tally:
    """Moves, moves that cut, refusals (by their first words), load checks, the largest ratio seen, and, where
    ``collect`` is set, the failures (else the first one raises, for Hypothesis to report)."""

    def __init__(self, *, collect=False):
        self.moves = self.cuts = self.checks = 0
        self.refused: dict[str, int] = {}
        self.worst = 0.0
        self.collect = collect
        self.failures: list[str] = []

    def check(self, ok, message):
        if ok:
            return
        if not self.collect:
            raise AssertionError(message)
        self.failures.append(message)


# ------------------------------------------------------------------------------------------ independent checks
def _components(triangles, n):
    """``(count, label (n,))`` of the surface's pieces joined through triangles."""
    t = np.asarray(triangles, dtype=np.int64)
    rows = np.repeat(np.arange(len(t)), 3)
    incidence = coo_matrix((np.ones(rows.size), (t.ravel(), rows)), shape=(n, len(t))).tocsr()
    return connected_components(incidence @ incidence.T, directed=False)


def _held(solver):
    """Vertices prescribed by the method (the pieces must each hold one)."""
    if solver.name == "hybrid":
        return np.union1d(solver.fixed, solver.hybrid.control)
    return np.asarray(solver.fixed)


def _quality(points, triangles):
    p = points[np.asarray(triangles, dtype=np.int64)]
    double_area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    squares = np.sum((p - p[:, [1, 2, 0]]) ** 2, axis=(1, 2))
    return 2.0 * np.sqrt(3.0) * double_area / squares, 0.5 * double_area


def _stretch_rows(solver):
    """``(pairs (k, 2), rest lengths (k,))`` of the live stretch rows (retired rows join a node to itself)."""
    if solver.name == "mass-spring":
        pairs, rest = solver.springs, solver.rest_lengths
    else:
        pairs, rest = solver.constraints.edges, solver.constraints.rest_length
    live = pairs[:, 0] != pairs[:, 1]
    return np.asarray(pairs[live], dtype=np.int64), rest[live]


def _defects(solver, mass, *, sound_now):
    """Sentences naming what is wrong with the cut solver (empty when sound)."""
    rest, tri, n = solver.rest_positions, np.asarray(solver.hybrid.surface.triangles, dtype=np.int64), solver.node_count
    out = []
    count, label = _components(tri, n)
    if solver.name != "embedded":
        loose = np.setdiff1d(np.arange(count), label[_held(solver)])
        if loose.size:
            out.append(f"{loose.size} pieces hold no prescribed node ({np.isin(label, loose).sum()} vertices)")
    directed = tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    if len(np.unique(directed, axis=0)) != len(directed):
        out.append("an edge is walked twice in one direction (orientation or a non-manifold edge)")
    quality, area = _quality(rest, tri)
    if np.any(area <= 0.0) or quality.min() < MIN_QUALITY:
        out.append(f"rest quality {quality.min():.3g}, smallest area {area.min():.3g} m²")
    if sound_now and _quality(solver.positions, tri)[0].min() < MIN_QUALITY:
        out.append(f"quality now {_quality(solver.positions, tri)[0].min():.3g}")
    if solver.name == "embedded":       # no constraints or masses of its own: every vertex rides on its tet
        return out
    pairs, rest_length = _stretch_rows(solver)
    distance = np.linalg.norm(rest[pairs[:, 0]] - rest[pairs[:, 1]], axis=1)
    # 1e-9: eq 19-23 give the rest distance exactly, up to a few roundings of lengths of ~1e-3 m
    if np.any(np.abs(rest_length - distance) > 1e-9 * np.maximum(distance, 1e-3)):
        out.append(f"rest lengths off by up to {np.abs(rest_length - distance).max():.3g} m")
    edges = np.unique(np.sort(directed, axis=1), axis=0)
    keys = np.unique(np.sort(pairs, axis=1), axis=0)
    if solver.name != "mass-spring" and not np.array_equal(keys, edges):
        out.append("the stretch rows are not one per edge")
    if solver.name == "mass-spring" and len(np.setdiff1d(edges[:, 0] * n + edges[:, 1], keys[:, 0] * n + keys[:, 1])):
        out.append("an edge has no stretch spring")
    if abs(solver.mass.sum() - mass) > 1e-9 * mass:     # 1e-9: sums of ~1e3 terms
        out.append(f"mass {solver.mass.sum():.12g} kg, was {mass:.12g} kg")
    return out


def _snapshot(solver):
    return [np.array(a) for a in (solver.positions, solver.velocities, solver.rest_positions,
                                  solver.hybrid.surface.triangles, solver.fixed)]


# --------------------------------------------------------------------------------------------- the load check
def _uncut(model, method, options):
    key = (model, method, tuple(sorted(options.items())))
    if key not in _UNCUT:
        _UNCUT[key] = tissuesim.make_solver(method, _hybrid(model), **options)
    return _UNCUT[key]


def _steps(solver, node, force):
    """``(n, 3)`` positions [m] after ``LOAD_STEPS`` steps from the current state, under ``force`` at ``node`` (or
    none), the state then put back: the load's effect is the difference of two runs from one state."""
    state = solver.positions.copy(), solver.velocities.copy()
    if force is not None:
        solver.set_load(node, force, radius=TIP_RADIUS)
    for _ in range(LOAD_STEPS):
        solver.step()
    out = solver.positions.copy()
    solver.clear_load()
    solver.positions[:], solver.velocities[:] = state
    return out


def _load_effect(solver, node, force):
    """Largest motion [m] the load adds in ``LOAD_STEPS`` steps to what the state would do without it."""
    return np.linalg.norm(_steps(solver, node, force) - _steps(solver, node, None), axis=1).max()


def _load_check(solver, model, options, rng, force, tally):
    """A small load beside the cut; its effect within BOUND times the uncut model's under the same load."""
    n0 = _hybrid(model).surface.vertex_count
    free = np.setdiff1d(np.arange(solver.node_count), solver.fixed)
    new = free[free >= n0]
    node = int(rng.choice(new if new.size else free))
    direction = rng.normal(size=3)
    load = force * direction / np.linalg.norm(direction)
    uncut = _uncut(model, solver.name, options)
    twin = int(np.argmin(np.linalg.norm(uncut.rest_positions - solver.rest_positions[node], axis=1)))
    try:
        uncut.reset()
        solver.contact_patch(node, TIP_RADIUS)
        uncut.contact_patch(twin, TIP_RADIUS)
    except TissuesimError:      # the tip reaches the support: such a load is refused, nothing to compare
        return
    reference = _load_effect(uncut, twin, load)
    added = _load_effect(solver, node, load)
    tally.checks += 1
    tally.worst = max(tally.worst, added / reference)
    tally.check(added <= BOUND * reference,
                f"{force:.3g} N at node {node} added {1e3 * added:.3g} mm in {LOAD_STEPS} steps; the uncut model "
                f"{1e3 * reference:.3g} mm at node {twin}")


# ------------------------------------------------------------------------------------------------ one episode
def _press(solver, stroke, rng, edge, last):
    """Press the scalpel for ``stroke``; returns ``(scalpel, tip, tangent)``."""
    s, x = solver.hybrid.surface, solver.positions
    t = int(rng.integers(s.triangle_count))
    if stroke["start"] == "previous" and last >= 0:
        t = int(np.flatnonzero(np.any(s.triangles == last, axis=1))[0])
    a, b, c = s.triangles[t]
    point = {"vertex": x[a], "edge": 0.5 * (x[a] + x[b]),
             "previous": x[last] if last >= 0 else x[a]}.get(stroke["start"])
    if point is None:
        point = rng.dirichlet([1, 1, 1]) @ x[[a, b, c]]
    normal = np.cross(x[b] - x[a], x[c] - x[a])
    normal /= np.linalg.norm(normal)
    tangent = x[b] - x[a] if stroke["path"] == "edge" else rng.normal(size=3)
    tangent -= (tangent @ normal) * normal
    tangent /= np.linalg.norm(tangent) + 1e-300
    blade = {"inward": -normal, "tilted": -normal + 0.7 * tangent + 0.3 * rng.normal(size=3),
             "grazing": -0.15 * normal + np.cross(normal, tangent)}[stroke["blade"]]
    tip = point + 0.3 * edge * normal
    scalpel = tissuesim.Scalpel(solver, depth=stroke["depth"] * edge)
    scalpel.press(tip, direction=blade)
    return scalpel, tip, tangent


def _move(solver, scalpel, tip, mass, tally):
    """One move, checked; returns the vertex it stopped at (−1 if it did not cut)."""
    sound_now = not _quality(solver.positions, solver.hybrid.surface.triangles)[0].min() < MIN_QUALITY
    before = _snapshot(solver)
    tally.moves += 1
    try:
        report = scalpel.move(tip)
    except TissuesimError as error:
        tally.refused[" ".join(str(error).split()[:4])] = tally.refused.get(" ".join(str(error).split()[:4]), 0) + 1
        for old, now in zip(before, _snapshot(solver)):
            tally.check(np.array_equal(old, now), f"the refused move ({error}) changed the solver")
        return -1
    tally.cuts += report.triangles_split > 0
    defects = _defects(solver, mass, sound_now=sound_now)
    tally.check(defects == [], f"after a move: {defects}")
    return solver.node_count - 1 if report.vertices_added else -1


def episode(model, method, options, plan, tally):
    solver = tissuesim.make_solver(method, _hybrid(model), **options)
    mass = getattr(solver, "mass", np.zeros(1)).sum()
    s = solver.hybrid.surface
    edge = float(np.mean(np.linalg.norm(s.vertices[s.edges[:, 0]] - s.vertices[s.edges[:, 1]], axis=1)))
    last = -1
    for stroke in plan:
        rng = np.random.default_rng(stroke["seed"])
        if stroke["deform"]:     # cut a deformed surface
            free = np.setdiff1d(np.arange(solver.node_count), solver.fixed)
            direction = rng.normal(size=3)
            solver.set_load(int(rng.choice(free)), stroke["deform"] * direction / np.linalg.norm(direction))
            for _ in range(3):
                solver.step()
            solver.clear_load()
        scalpel, tip, tangent = _press(solver, stroke, rng, edge, last)
        for _ in range(stroke["moves"]):
            if stroke["path"] == "random":
                tangent = tangent + 0.8 * rng.normal(size=3)
                tangent /= np.linalg.norm(tangent)
            tip = tip + stroke["step"] * edge * tangent
            last = max(last, _move(solver, scalpel, tip, mass, tally))
            _load_check(solver, model, options, rng, stroke["force"], tally)
        scalpel.release()
    assert np.all(np.isfinite(solver.positions))


def _fuzz(examples, model_names, configs, rng_seed, *, collect=False):
    """``examples`` random episodes drawn from ``rng_seed`` on the models and ``configs`` (indices of CONFIGS);
    ``collect``: count every failure (an episode stops at an error) instead of stopping at the first."""
    tally = Tally(collect=collect)

    @seed(rng_seed)
    @settings(max_examples=examples, deadline=None, phases=[Phase.explicit, Phase.reuse, Phase.generate])
    @given(model=st.sampled_from(model_names), config=st.sampled_from(configs), plan=strokes())
    def run(model, config, plan):
        method, options = CONFIGS[config]
        try:
            episode(model, method, options, plan, tally)
        except Exception as error:      # noqa: BLE001 (collecting: an error ends the episode, and is counted)
            if not collect:
                raise
            tally.failures.append(f"{type(error).__name__}: {error}")
        if collect and tally.failures and "episode" not in tally.failures[-1]:
            tally.failures[-1] += f" (episode: {model}, {_id(method, options)}, {plan})"

    run()
    return tally


def _report(tally):
    print(f"\ncutting fuzz: {tally.moves} moves, {tally.cuts} cut, {sum(tally.refused.values())} refused "
          f"{tally.refused}; {tally.checks} load checks, worst {tally.worst:.2f}x the uncut model; "
          f"{len(tally.failures)} failures")
    for failure in tally.failures:
        print("  ", failure)


#: Configurations whose fast run fails the load check, with what was measured (strict: a fix makes them fail as
#: XPASS, so the mark comes off).
KNOWN = {
    "mass-spring": "a vertex on a cut's lip has no out-of-plane stiffness at first order (a flat hinge's spring "
                   "across it lies in the plane) and the uncut surface around it was what held it: 0.535 mm against "
                   "0.0216 mm (25x) under 0.125 N in 5 steps; up to 52x (3.07 mm at most) in the slow run",
}


def _id(method, options):
    return f"{method}-{options['integrator']}" if "integrator" in options else method


def _configs():
    return [pytest.param(i, id=_id(m, o), marks=[pytest.mark.xfail(reason=KNOWN[_id(m, o)], strict=True)]
                         if _id(m, o) in KNOWN else []) for i, (m, o) in enumerate(CONFIGS)]


@pytest.mark.parametrize("config", _configs())
def test_random_cuts_hold_together_and_stay_bounded_under_small_loads(config):
    tally = _fuzz(5, ["cube"], [config], 18 + config)
    _report(tally)
    # a quarter: 5 episodes make only 15-30 moves, and short or grazing moves cut nothing
    assert tally.cuts >= 0.25 * tally.moves, (tally.cuts, tally.moves)


@pytest.mark.slow
def test_two_thousand_random_moves_hold_together_and_stay_bounded():
    tally = _fuzz(540, sorted(models.MODELS), list(range(len(CONFIGS))), 1811, collect=True)
    _report(tally)
    assert tally.moves >= 2000
    assert tally.cuts >= 0.5 * tally.moves, (tally.cuts, tally.moves)
    unbounded = [failure for failure in tally.failures if "the uncut model" in failure]
    assert [failure for failure in tally.failures if failure not in unbounded] == []    # pieces, shape, refusals
    # Over-bound load checks are a known defect (KNOWN: mass-spring lips; flaps of a few nodes on one or two hinges
    # in hybrid and pbd), capped at what full runs measured so that a regression fails. The episodes drawn depend on
    # what ran before in the process: alone, 58 of 2,835 load checks beside a cut over 5x the uncut model, worst
    # 263.2x; after the other slow checks, 113 of 2,564, worst 212.7x. The caps leave about 15% above the larger.
    assert len(unbounded) <= 130, (len(unbounded), tally.checks, unbounded)
    assert tally.worst <= 300.0, (tally.worst, unbounded)
