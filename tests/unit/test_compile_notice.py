"""A script or a notebook is told when tissuesim's kernels compile (the library's notice), once, with the time it
took; a run that loads them from the cache is told nothing; a command's own notice speaks instead of it."""

import os
import subprocess
import sys

FIRST_KERNEL = ("import numpy as np, tissuesim\n"
                "from tissuesim.tools.probe_complementarity import winding_numbers\n"
                "square = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])\n"
                "winding_numbers(np.zeros((1, 3)), square, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))\n")


def _run(code: str, cache) -> str:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stderr


def test_a_first_run_is_told_that_it_compiles_and_a_cached_one_is_not(tmp_path):
    said = _run(FIRST_KERNEL, tmp_path).splitlines()
    assert said[0].startswith("tissuesim: compiling the numerical kernels, first run only")
    assert said[-1].startswith("tissuesim: compiled 1 kernels in") and "from the cache" in said[-1]
    assert _run(FIRST_KERNEL, tmp_path) == ""


def test_a_users_own_kernel_is_not_announced_as_ours(tmp_path):
    own = "import tissuesim, numba\n@numba.njit\ndef twice(x):\n    return 2 * x\ntwice(1.0)\n"
    assert _run(own, tmp_path) == ""


def test_inside_a_commands_block_only_the_command_speaks(tmp_path):
    code = ("from tissuesim.compile_notice import announce_compilation\n"
            "with announce_compilation('tissuesim test'):\n" + "".join(f"    {line}\n" for line in
                                                                        FIRST_KERNEL.splitlines()))
    said = _run(code, tmp_path).splitlines()
    assert len(said) == 2 and all(line.startswith("tissuesim test: ") for line in said), said
