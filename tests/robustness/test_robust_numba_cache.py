"""Processes that compile the same kernels at once on a fresh Numba cache (a study's workers on a fresh machine):
each finishes, and the cache they leave gives every later process the code of the signature it asks for.

Numba saves a signature by reading the kernel's index, writing it, then the data file: two processes that compile
different signatures at once both took data file 1, and the index one left named the other's machine code (a later
process then ran int code on floats; with the library's kernels, glibc's ``free(): invalid pointer``).
tissuesim.numba_cache locks each save and load; the race is forced here by holding each process at the step where
the other must have gone on.
"""

import os
import subprocess
import sys
import textwrap

import pytest

KERNEL = '''
from numba import njit


@njit(cache=True)
def double(x):
    return x * 2
'''

# Process A compiles double(int), B double(float). Unlocked, the hooks order them: both read the empty index; A
# writes {int: 1}; B writes {float: 1} and its data file 1; A writes its data file 1 last. Locked, the first to
# save waits out the hooks' timeouts alone, and the second reads the first's index.
RACER = '''
import pathlib, sys, time
import tissuesim                    # locks Numba's cache when Numba loads it
from numba.core import caching

role, sync = sys.argv[1], pathlib.Path(sys.argv[2])


def signal(name):
    (sync / name).touch()


def wait(name):
    end = time.monotonic() + 1.5
    while not (sync / name).exists() and time.monotonic() < end:
        time.sleep(0.01)


cache_file = caching.IndexDataCacheFile
save_index, save_data = cache_file._save_index, cache_file._save_data


def hooked_save_index(self, overloads):
    signal(role + "-read")
    wait("B-read" if role == "A" else "A-index")
    save_index(self, overloads)
    signal(role + "-index")


def hooked_save_data(self, name, data):
    if role == "A":
        wait("B-data")
    save_data(self, name, data)
    signal(role + "-data")


cache_file._save_index, cache_file._save_data = hooked_save_index, hooked_save_data
import kernel
print(repr(kernel.double(3 if role == "A" else 3.0)))
'''

READER = '''
import tissuesim
import kernel
print(repr(kernel.double(3)), repr(kernel.double(3.0)))
'''


def _environment(tmp_path) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env.get("PYTHONPATH", "")])
    return env


def _run(tmp_path, code: str, *args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), *args], env=_environment(tmp_path),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)


def _finish(process, timeout: float = 120.0) -> str:
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        raise
    assert process.returncode == 0, err[-2000:]
    return out.strip()


def test_two_processes_compiling_one_kernel_at_once_leave_a_cache_that_gives_each_signature_its_code(tmp_path):
    (tmp_path / "kernel.py").write_text(KERNEL)
    (tmp_path / "sync").mkdir()
    racers = [_run(tmp_path, RACER, role, str(tmp_path / "sync")) for role in ("A", "B")]
    assert [_finish(p) for p in racers] == ["6", "6.0"]
    # A fresh process loads both signatures from the cache they left: int code for the int, float for the float
    # (unlocked, double(3.0) ran A's int code and returned 6).
    assert _finish(_run(tmp_path, READER)) == "6 6.0"


WORKLOAD = '''
import hashlib, sys
import numpy as np
import tissuesim
from tissuesim.experiments.wound import scripted_incision
from tissuesim.mesh import models

cube = tissuesim.HybridMesh.build(models.cube(resolution=386))
methods = ["pbd", "mass-spring", "hybrid", "embedded"]
shift = int(sys.argv[1])
digests = {}
for method in methods[shift:] + methods[:shift]:
    solver = tissuesim.make_solver(method, cube)
    scripted_incision(solver)
    solver.set_load(int(np.argmax(solver.rest_positions[:, 2])), [0.0, 0.0, -0.2])
    for _ in range(10):
        solver.step()
    digests[method] = hashlib.sha256(np.round(solver.positions, 12).tobytes()).hexdigest()   # to 1e-12 m
print(" ".join(digests[m] for m in methods))
'''


@pytest.mark.slow
def test_two_first_runs_of_the_library_at_once_agree_with_a_run_from_their_cache(tmp_path):
    # Two workers compiling the library's kernels on a fresh cache, each cutting and stepping the methods in its own
    # order (so they compile the kernels' signatures in different orders), then a run that loads them all.
    # (compiling every kernel takes minutes of a core, each)
    workers = [_run(tmp_path, WORKLOAD, str(shift)) for shift in (0, 2)]
    first, second = (_finish(p, timeout=1800.0) for p in workers)
    assert first == second
    assert _finish(_run(tmp_path, WORKLOAD, "1"), timeout=600.0) == first
