"""The combination fuzz: seeded episodes that drive every method and material with every tool at once.

An episode (one seed) draws a model (the built-in cube and liver, the shared liver2 and SoftBodyLiver), a method
and a material that method takes, gravity on or off and a ligament or none, then a random sequence of actions:
pin-head grab / drag / release, probe move_to / press_static / update / release, scalpel press / move / release,
gravity switched (a new solver over the current, possibly cut, mesh, as the viewer does), a small rigid motion of
the base (``set_fixed_positions``), ``solve_static`` under one load or under the loads acting, ``step`` and
``reset``. After every action, checks that do not use the code under test's own verdicts:

* anything raised other than a TissuesimError is a failure (a traceback);
* a TissuesimError is a refusal: nothing may have changed (positions, velocities, rest positions, triangles, the
  fixed set and where it is, the loads acting, the tools' places), compared with a snapshot taken before;
* no non-finite position; the surface passes :func:`~tissuesim.cutting.invariants.check_cut_invariants` (manifold,
  oriented, no rest sliver, genus, rest lengths, mass) and no piece is loose where the method anchors its pieces;
* a converged probe press pushes every vertex it touches away from its centre (a frictionless sphere cannot pull)
  and leaves none inside beyond its tolerance.

Counted, not failed: a mass-spring surface that turns inside out (InversionError: that model's own limit, which
its message names) and a step or solve that runs away after a cut (the flaps a cut leaves, the physics that
tests/robustness/test_robust_cut_flap.py measures); the solver is then reset, as their messages say.

Every failure names its seed and action index;
``python tests/robustness/combination_fuzz.py SEED`` replays that episode alone, printing each action.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import tissuesim
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.errors import TissuesimError, TissuesimWarning
from tissuesim.mesh import models
from tissuesim.solvers.cut_carry import anchored_nodes
from tissuesim.solvers.registry import solver_class

SHARED = {"liver2": ("sofa/liver2.obj", 0.01), "softbodyliver": ("softbodyliver/liver.obj", 0.01)}
MODELS = ["cube", "liver", *SHARED]
#: (method, options): every method, and both integrators of the xpbd surface layer.
METHODS = [("hybrid", {}), ("hybrid", {"integrator": "xpbd"}), ("pbd", {}), ("pbd", {"integrator": "xpbd"}),
           ("mass-spring", {}), ("embedded", {}), ("fem", {})]
#: Built-in models at a few hundred vertices (the fine volume of the fem reference stays small); the shared
#: SoftBodyLiver (3,001 vertices) gets no fine volume, so fem is not drawn on it.
RESOLUTION = 600
NO_FINE_VOLUME = LINEAR_ONLY = {"softbodyliver"}
GRAVITY = (0.0, 0.0, -9.81)
#: Relative weights of the actions.
ACTIONS = {"grab": 3, "drag": 6, "release_pin": 2, "probe_move": 3, "probe_press": 2, "probe_update": 4,
           "probe_release": 2, "scalpel_press": 3, "scalpel_move": 10, "scalpel_release": 1, "gravity": 1,
           "move_base": 2, "solve_load": 1, "solve_acting": 1, "step": 8, "reset": 1}
#: Largest pin-head force [N] and probe depth [fractions of its radius] the actions ask for: small loads, so the
#: answers stay in the range every method is meant for.
PIN_STIFFNESS = 20.0
MAX_PIN_STRETCH = 0.008
MAX_PROBE_DEPTH = 0.3
#: Largest base turn [rad] and shift [m] of one base motion.
MAX_TURN = np.radians(10.0)
MAX_SHIFT = 0.002
#: A non-settling quasi-static solve of a stepping method gives up after this many steps (refused).
SOLVE_STEPS = 200
#: An action slower than this [s] is listed (a hang shows as one).
SLOW_ACTION = 10.0
_HYBRIDS: dict[str, object] = {}


def hybrid(model: str, meshes: Path):
    """The hybrid mesh of ``model`` (built once per process), with a fine volume except for :data:`NO_FINE_VOLUME`."""
    if model not in _HYBRIDS:
        if model in SHARED:
            path, scale = SHARED[model]
            surface = tissuesim.read_surface(meshes / path, scale=scale)
        else:
            surface = getattr(models, model)(resolution=RESOLUTION)
        _HYBRIDS[model] = tissuesim.HybridMesh.build(surface, fine_volume=model not in NO_FINE_VOLUME)
    return _HYBRIDS[model]


@dataclass
class Tally:
    """What the episodes did: moves (actions), cutting moves, refusals by action and first words, counted flap
    events and warnings, and the failures (each a sentence with its seed and action index)."""

    episodes: int = 0
    moves: int = 0
    cuts: int = 0
    actions: Counter = field(default_factory=Counter)
    configs: Counter = field(default_factory=Counter)
    refused: Counter = field(default_factory=Counter)
    counted: Counter = field(default_factory=Counter)
    warned: Counter = field(default_factory=Counter)
    failures: list = field(default_factory=list)
    #: ``(seconds, seed, action index, action)`` of every action that took over :data:`SLOW_ACTION` seconds
    slow: list = field(default_factory=list)

    def summary(self) -> str:
        lines = [f"combination fuzz: {self.episodes} episodes, {self.moves} moves, {self.cuts} cutting, "
                 f"{sum(self.refused.values())} refused, {len(self.failures)} failures",
                 f"  configurations: {dict(sorted(self.configs.items()))}",
                 f"  actions: {dict(sorted(self.actions.items()))}",
                 f"  refusals: {dict(self.refused.most_common())}",
                 f"  counted (inversions, run-aways after a cut): {dict(self.counted)}",
                 f"  warnings: {dict(self.warned.most_common())}"]
        lines += [f"  slow: {seconds:.0f} s, seed {seed}, action {index} ({action})" for seconds, seed, index, action
                  in sorted(self.slow, reverse=True)]
        return "\n".join(lines + [f"  FAIL {failure}" for failure in self.failures])


def _words(error: BaseException, count: int = 6) -> str:
    """The first ``count`` words of ``error``'s message, numbers as #, to count refusals by kind."""
    return " ".join("#" if any(c.isdigit() for c in word) else word for word in str(error).split()[:count])


class Episode:
    """One seeded episode (see the module docstring); :meth:`run` plays it into a :class:`Tally`."""

    def __init__(self, seed: int, meshes: Path, *, log=None, method: tuple | None = None):
        self.seed, self.meshes, self.log = seed, meshes, log
        rng = self.rng = np.random.default_rng(seed)
        self.model = MODELS[rng.integers(len(MODELS))]
        choices = [m for m in METHODS if not (m[0] == "fem" and self.model in NO_FINE_VOLUME)]
        self.method, self.options = choices[rng.integers(len(choices))]
        if method is not None:       # this method instead of the drawn one, the rest of the draws unchanged
            self.method, self.options = method
        # the xpbd integrator takes neither a finite-strain layer nor (pbd) attachments: refused, as documented; on
        # the 3,001-vertex liver a finite-strain probe press takes minutes (a Newton solve per contact iteration)
        linear_only = "integrator" in self.options or self.model in LINEAR_ONLY
        materials = ("linear",) if linear_only else solver_class(self.method).materials
        self.material = materials[rng.integers(len(materials))]
        self.gravity = rng.random() < 0.4
        self.ligament = rng.random() < 0.4 and not (self.method == "pbd" and "integrator" in self.options)
        self.cut = False        # whether any move cut (a run-away only counts as a flap after one)
        self.moved_base = False

    @property
    def name(self) -> str:
        options = "".join(f", {k}={v}" for k, v in self.options.items())
        return (f"{self.model}, {self.method}{options}, {self.material}, gravity {'on' if self.gravity else 'off'}, "
                f"{'a ligament' if self.ligament else 'no ligament'}")

    # ----------------------------------------------------------------------------------------------- building
    def _build(self, mesh) -> None:
        """A solver over ``mesh`` with the episode's options, and fresh tools (the old ones are dropped)."""
        options = dict(self.options, material=self.material)
        if self.gravity:
            options["gravity"] = GRAVITY
        if self.ligament:
            options["attachments"] = (self._attachment(mesh),)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TissuesimWarning)     # gravity on a surface method: a known caveat
            self.solver = tissuesim.make_solver(self.method, mesh, **options)
        s = self.solver
        self.mass = float(np.sum(s.mass)) if hasattr(s, "mass") else None
        self.edge = float(np.mean(np.linalg.norm(np.diff(mesh.surface.vertices[mesh.surface.edges], axis=1)[:, 0],
                                                 axis=1)))
        self.pin = tissuesim.PinHead(s, stiffness=PIN_STIFFNESS, radius=None if self.rng.random() < 0.5
                                     else 1.5 * self.edge)
        self.cursor = None
        self.probe = tissuesim.Probe(s, radius=float(self.rng.uniform(1.5, 4.0)) * self.edge)
        self.scalpel = None
        self.anchored = anchored_nodes(s)

    def _attachment(self, mesh):
        """A ligament on the few vertices nearest a random point of the upper half, to their rest places or pulled
        a little toward a point beside them."""
        v = mesh.surface.vertices
        upper = np.flatnonzero(v[:, 2] > 0.5 * (v[:, 2].min() + v[:, 2].max()))
        rng = np.random.default_rng(self.seed + 1)       # the same ligament after every rebuild
        centre = v[rng.choice(upper)]
        nodes = np.argsort(np.linalg.norm(v - centre, axis=1))[:int(rng.integers(3, 10))]
        anchor = None if rng.random() < 0.5 else centre + rng.normal(scale=0.002, size=3)
        return tissuesim.Attachment(np.sort(nodes), float(rng.uniform(5.0, 50.0)), anchor)

    # ------------------------------------------------------------------------------------------------ playing
    def run(self, tally: Tally, *, moves: int) -> None:
        """Play ``moves`` actions (fewer where a traceback ends the episode) into ``tally``."""
        tally.episodes += 1
        variant = "".join(f"-{value}" for value in self.options.values())       # -xpbd, -quadratic
        tally.configs[f"{self.method}{variant}/{self.material}"] += 1
        try:
            self._build(hybrid(self.model, self.meshes))
        except TissuesimError as error:
            tally.refused[f"build: {_words(error)}"] += 1
            return
        names, weights = list(ACTIONS), np.array(list(ACTIONS.values()), dtype=float)
        for index in range(moves):
            action = names[self.rng.choice(len(names), p=weights / weights.sum())]
            if not self._play(index, action, tally):
                return

    def _fail(self, tally: Tally, index: int, action: str, what: str) -> None:
        tally.failures.append(f"seed {self.seed}, action {index} ({action}) [{self.name}; cut: {self.cut}, base "
                              f"moved: {self.moved_base}]: {what}")

    def _play(self, index: int, action: str, tally: Tally) -> bool:
        """One action, checked; False ends the episode (after a traceback, the solver's state is not trusted)."""
        before = self._snapshot()
        tally.moves += 1
        tally.actions[action] += 1
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", TissuesimWarning)
            try:
                outcome = getattr(self, "_" + action)()
            except TissuesimError as error:
                return self._refused(index, action, error, before, tally)
            except Exception as error:      # noqa: BLE001 (the fuzz reports every traceback)
                self._fail(tally, index, action, f"{type(error).__name__}: {error}")
                if self.log:
                    self.log(f"{index:4d} {action}: {type(error).__name__}: {error}")
                return False
            finally:
                seconds = time.perf_counter() - start
                if seconds > SLOW_ACTION:
                    tally.slow.append((seconds, self.seed, index, action))
        for warning in caught:
            if issubclass(warning.category, TissuesimWarning):
                tally.warned[f"{action}: {' '.join(str(warning.message).split()[:6])}"] += 1
        if self.log:
            self.log(f"{index:4d} {action} ({seconds:.2f} s): {outcome if outcome is not None else 'ok'}")
        if action == "scalpel_move" and outcome:
            tally.cuts += 1
            self.cut = True
        for what in self._defects(action):
            self._fail(tally, index, action, what)
        return True

    def _refused(self, index: int, action: str, error: TissuesimError, before, tally: Tally) -> bool:
        """Count a refusal, fail it where it changed anything; False ends the episode (the reset that follows a
        run-away or a changed state raised)."""
        if self.log:
            self.log(f"{index:4d} {action}: refused: {error}")
        text = str(error)
        runaway = action in ("step", "solve_load", "solve_acting", "probe_press") and (
            "diverged" in text or "not finite" in text)
        if isinstance(error, tissuesim.InversionError) or (runaway and self.cut):
            # the mass-spring surface's own limit (no force turns an inverted triangle back), or a flap a cut left
            # running away: counted; reset, as the message says
            tally.counted[f"{'after a cut' if self.cut else 'uncut'}, {action}: {_words(error, 5)}"] += 1
            return self._reset_after(index, action, tally)
        tally.refused[f"{action}: {_words(error)}"] += 1
        changed = [name for name, old, now in zip(_SNAPSHOT, before, self._snapshot()) if not _same(old, now)]
        if not changed:
            return True
        self._fail(tally, index, action, f"the refusal ({type(error).__name__}: {error}) changed {', '.join(changed)}")
        return self._reset_after(index, action, tally)

    def _reset_after(self, index: int, action: str, tally: Tally) -> bool:
        try:
            self._reset()
        except Exception as error:      # noqa: BLE001 (the fuzz reports every traceback)
            self._fail(tally, index, action, f"reset() after it raised {type(error).__name__}: {error}")
            return False
        return True

    def _snapshot(self) -> list:
        s = self.solver
        loads = [(load.node, load.force.tolist(), load.radius) for load in s.loads]
        return [np.array(s.positions), np.array(s.velocities), np.array(s.rest_positions),
                np.array(s.hybrid.surface.triangles), np.array(s.fixed), np.array(s.fixed_positions),
                np.array(s.forces), loads,
                (self.pin.node, None if self.pin.anchor is None else self.pin.anchor.tolist()),
                None if self.probe.center is None else self.probe.center.tolist(),
                None if self.scalpel is None or self.scalpel.tip is None else self.scalpel.tip.tolist()]

    def _defects(self, action: str) -> list[str]:
        s = self.solver
        if not np.all(np.isfinite(s.positions)):
            return [f"{np.count_nonzero(~np.isfinite(s.positions).all(axis=1))} non-finite positions"]
        tri = s.hybrid.surface.triangles
        edges = rest_length = None
        if hasattr(s, "constraints"):
            live = s.constraints.edges[:, 0] != s.constraints.edges[:, 1]
            edges, rest_length = s.constraints.edges[live], s.constraints.rest_length[live]
        out = check_cut_invariants(s.rest_positions, tri, edges=edges, rest_length=rest_length,
                                   masses=getattr(s, "mass", None), total_mass=self.mass, anchored=self.anchored)
        if s.name == "mass-spring":
            pairs = np.asarray(s.springs, dtype=np.int64)
            live = pairs[:, 0] != pairs[:, 1]       # a retired spring joins a node to itself
            pairs, rest = pairs[live], s.rest_lengths[live]
            distance = np.linalg.norm(s.rest_positions[pairs[:, 0]] - s.rest_positions[pairs[:, 1]], axis=1)
            # 1e-9: eq 19-23 give the rest distance exactly, up to a few roundings
            if np.any(np.abs(rest - distance) > 1e-9 * np.maximum(distance, 1e-3)):
                out.append(f"spring rest lengths off by up to {np.abs(rest - distance).max():.3g} m")
        if action == "probe_press":
            out += self._contact_defects()
        return out

    def _contact_defects(self) -> list[str]:
        """A converged press pushes each vertex it touches away from the sphere's centre, and leaves none inside
        beyond the tolerance."""
        probe, x = self.probe, self.solver.positions
        pulled = [load.node for load in self.solver.loads if load.node in probe.contacts
                  and load.force @ (x[load.node] - probe.center) <= 0.0]
        out = [f"the probe pulls vertices {pulled[:3]} toward its centre"] if pulled else []
        # 1.5: the residual bounds every gap at the last solve; the gaps are measured again here
        if probe.gaps().min() < -1.5 * probe.tolerance:
            out.append(f"a vertex lies {probe.gaps().min():.3g} m inside the converged probe (tolerance "
                       f"{probe.tolerance:.3g} m)")
        return out

    # ------------------------------------------------------------------------------------------------ actions
    def _free_vertex(self) -> int:
        free = np.setdiff1d(np.arange(self.solver.node_count), self.solver.fixed)
        return int(self.rng.choice(free))

    def _normal(self, vertex: int) -> np.ndarray:
        """``(3,)`` the outward unit normal at ``vertex`` now (area-weighted over its triangles)."""
        x, t = self.solver.positions, self.solver.hybrid.surface.triangles
        around = t[np.any(t == vertex, axis=1)]
        normal = np.cross(x[around[:, 1]] - x[around[:, 0]], x[around[:, 2]] - x[around[:, 0]]).sum(axis=0)
        return normal / (np.linalg.norm(normal) + 1e-300)

    def _grab(self):
        node = self._free_vertex()
        self.cursor = self.solver.positions[node] + self.rng.normal(scale=0.2 * self.edge, size=3)
        return f"node {self.pin.grab(self.cursor)}"

    def _drag(self):
        if not self.pin.grabbed:
            return "nothing held"
        step = self.rng.normal(size=3)
        self.cursor = self.pin.anchor + float(self.rng.uniform(0, MAX_PIN_STRETCH)) * step / np.linalg.norm(step)
        return f"{np.linalg.norm(self.pin.drag(self.cursor)):.3g} N"

    def _release_pin(self):
        self.pin.release()

    def _probe_place(self) -> np.ndarray:
        node = self._free_vertex()
        depth = float(self.rng.uniform(-0.1, MAX_PROBE_DEPTH)) * self.probe.radius
        return self.solver.positions[node] + (self.probe.radius - depth) * self._normal(node)

    def _probe_move(self):
        return f"{np.linalg.norm(self.probe.move_to(self._probe_place())):.3g} N"

    def _probe_press(self):
        self.probe.press_static(self._probe_place(), max_iterations=15, max_steps=SOLVE_STEPS)
        return f"{np.linalg.norm(self.probe.force):.3g} N in {self.probe.iterations} iterations"

    def _probe_update(self):
        if self.probe.center is None:
            return "not placed"
        self.probe.update()
        return f"{np.linalg.norm(self.probe.force):.3g} N"

    def _probe_release(self):
        self.probe.release()

    def _scalpel_press(self):
        """A scalpel pressed near a random vertex, the blade inward, tilted or grazing, as the cutting fuzz does."""
        s = self.solver
        if self.scalpel is None:
            self.scalpel = tissuesim.Scalpel(s, depth=float(self.rng.uniform(0.5, 3.0)) * self.edge)
        x, t = s.positions, s.hybrid.surface.triangles
        a, b, c = t[self.rng.integers(len(t))]
        point = self.rng.dirichlet([1, 1, 1]) @ x[[a, b, c]]
        normal = np.cross(x[b] - x[a], x[c] - x[a])
        normal /= np.linalg.norm(normal)
        tangent = self.rng.normal(size=3)
        tangent -= (tangent @ normal) * normal
        self.tangent, self.blade_normal = tangent / np.linalg.norm(tangent), normal
        blade = [-normal, -normal + 0.7 * self.tangent, -0.15 * normal + np.cross(normal, self.tangent)][
            self.rng.integers(3)]
        self.scalpel.press(point + 0.3 * self.edge * normal, direction=blade)

    def _scalpel_move(self):
        if self.scalpel is None or not self.scalpel.pressed:
            self._scalpel_press()       # a hand that cuts presses first
        turn = self.rng.normal(size=3)
        turn -= (turn @ self.blade_normal) * self.blade_normal     # the path turns within the surface pressed
        self.tangent = self.tangent + 0.5 * turn
        self.tangent /= np.linalg.norm(self.tangent)
        report = self.scalpel.move(self.scalpel.tip + float(self.rng.uniform(0.3, 2.5)) * self.edge * self.tangent)
        return report.triangles_split > 0

    def _scalpel_release(self):
        if self.scalpel is not None:
            self.scalpel.release()

    def _gravity(self):
        """Gravity switched: a new solver over the current mesh (what the viewer's gravity switch does)."""
        self.gravity = not self.gravity
        try:
            self._build(self.solver.hybrid)
        except TissuesimError:
            self.gravity = not self.gravity
            raise
        self.moved_base = False
        return f"gravity {'on' if self.gravity else 'off'}"

    def _move_base(self):
        """A small rigid motion of the base: turned about a random axis through its centre and shifted."""
        s = self.solver
        rest = s.rest_positions[s.fixed]
        axis = self.rng.normal(size=3)
        angle = float(self.rng.uniform(-MAX_TURN, MAX_TURN))
        turn = _rotation(axis / np.linalg.norm(axis), angle)
        centre = rest.mean(axis=0)
        shift = self.rng.normal(scale=MAX_SHIFT / 2, size=3)
        s.set_fixed_positions((rest - centre) @ turn.T + centre + shift)
        self.moved_base = True
        return f"{np.degrees(angle):.3g}°, {1e3 * np.linalg.norm(shift):.3g} mm"

    def _solve_load(self):
        force = self.rng.normal(size=3)
        force *= float(self.rng.uniform(0.02, 0.3)) / np.linalg.norm(force)
        self.solver.solve_static(self._free_vertex(), force, radius=1.5 * self.edge, max_steps=SOLVE_STEPS)

    def _solve_acting(self):
        self.solver.solve_static(reset=False, max_steps=SOLVE_STEPS)

    def _step(self):
        for _ in range(int(self.rng.integers(1, 4))):
            self.solver.step()

    def _reset(self):
        self.solver.reset()
        self.moved_base = False


_SNAPSHOT = ["positions", "velocities", "rest positions", "triangles", "the fixed set", "the fixed positions",
             "the forces", "the loads", "the pin-head", "the probe's place", "the scalpel's tip"]


def _same(old, now) -> bool:
    if isinstance(old, np.ndarray):
        return old.shape == now.shape and np.array_equal(old, now, equal_nan=True)
    return old == now


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """``(3, 3)`` the rotation by ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def fuzz(seeds, meshes: Path, *, moves: int, progress=None, method: tuple | None = None) -> Tally:
    """Episodes of ``moves`` actions from each of ``seeds``, into one :class:`Tally`; ``progress`` (e.g. print) is
    given a line after each episode; ``method`` ``(name, options)`` plays every episode with that method."""
    tally = Tally()
    for seed in seeds:
        start, failures = time.perf_counter(), len(tally.failures)
        episode = Episode(int(seed), meshes, method=method)
        episode.run(tally, moves=moves)
        if progress:
            progress(f"seed {seed} ({episode.name}): {time.perf_counter() - start:.1f} s; {tally.moves} moves so far")
            for failure in tally.failures[failures:]:
                progress(f"  FAIL {failure}")
    return tally


if __name__ == "__main__":      # replay one episode: python tests/robustness/combination_fuzz.py SEED [MOVES]
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from conftest import MESHES

    seed, count = int(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 40
    tally, episode = Tally(), Episode(seed, MESHES, log=print)
    print(episode.name)
    episode.run(tally, moves=count)
    print(tally.summary())
