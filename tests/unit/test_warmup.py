"""The warm-up before a session: every method and material played once, a stamp so that it runs once per install,
and (slow, from an empty kernel cache) no compilation left for a scripted session after it."""

import os
import subprocess
import sys

import pytest

import tissuesim.warmup as warmup
from tissuesim.solvers.registry import available_solvers, solver_class


def test_the_session_covers_every_method_and_material():
    played = warmup.sessions()
    for method in available_solvers():
        for material in solver_class(method).materials:
            assert (method, {"material": material}) in played
    assert ("hybrid", {"material": "neo-hookean", "element": "quadratic"}) in played


def test_it_plays_once_per_build(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    played = []
    monkeypatch.setattr(warmup, "warm_up", lambda *, progress: played.append(progress) or 1)
    assert warmup.ensure_warm(progress=False) is True
    assert warmup.ensure_warm(progress=False) is False            # the stamp says this build was played
    assert warmup.stamp_path().parent == tmp_path
    monkeypatch.setattr(warmup, "fingerprint", lambda: "another build")
    assert warmup.ensure_warm(progress=False) is True              # changed sources or Numba: again
    assert played == [False, False]


def test_a_read_only_install_keeps_its_stamp_in_the_users_cache(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert warmup.stamp_path().parent.name == "__pycache__"              # a writable package: beside its kernels
    monkeypatch.setattr(warmup, "_writable", lambda folder: False)
    assert warmup.stamp_path() == tmp_path / "tissuesim" / warmup.STAMP


SESSION = """
import numpy as np
from numba.core import event
import tissuesim
from tissuesim.warmup import ensure_warm
from tissuesim.viewer.controller import Controller
from tissuesim.viewer.settings import Settings

ensure_warm(progress=False)
compiled = []
class Count(event.Listener):
    def on_start(self, ev):
        module = getattr(getattr(ev.data.get("dispatcher"), "py_func", None), "__module__", "")
        if module.startswith("tissuesim."):
            compiled.append(module)
    def on_end(self, ev):
        pass
event.register("numba:compile", Count())
hybrid = tissuesim.HybridMesh.build(tissuesim.models.liver(600))
c = Controller(hybrid, settings=Settings(stiffness=30.0, radius=0.01))
down = np.array([0.0, 0.0, -1.0])
top = hybrid.surface.vertices[np.argmax(hybrid.surface.vertices[:, 2])]
c.pointer_down(top, top - down, down); c.pointer_move(None, top - down + [0.0, 0.0, 0.01], down); c.advance(0.05)
c.pointer_up()
c.configure(material="neo-hookean")
c.pointer_down(top, top - down, down); c.pointer_move(None, top - down + [0.0, 0.0, 0.01], down); c.advance(0.05)
c.pointer_up()
c.set_mode("grasper"); c.pointer_down(top, top - down, down)
c.pointer_move(None, top - down + [0.01, 0.0, 0.0], down); c.advance(0.05); c.pointer_up()
c.set_mode("probe"); c.pointer_down(top, top - down, down); c.advance(0.05); c.pointer_up()
c.configure(material="linear")
c.set_mode("scalpel")
start = top + [-0.02, 0.0, 0.0]
c.pointer_down(start, start - down, down); c.pointer_move(start + [0.04, 0.0, 0.0], start - down, down)
c.advance(0.05); c.pointer_up(); c.advance(0.05)
print("compiled after the warm-up:", len(compiled), sorted(set(compiled)))
"""


@pytest.mark.slow
def test_after_the_warm_up_a_session_compiles_nothing(tmp_path):
    """From an empty kernel cache (a fresh install): the warm-up compiles what the session uses; grabbing,
    switching to neo-Hookean, grasping, pressing the probe and cutting then compile no kernel (measured: about 4
    minutes on 2 cores, most of it the warm-up's compilation)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    done = subprocess.run([sys.executable, "-c", SESSION], env=env, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "compiled after the warm-up: 0 []" in done.stdout, done.stdout[-2000:]
