"""Shared fixtures: the built-in models and the public organ meshes beside the repository; the suite's options.

* Slow checks (``@pytest.mark.slow``) are skipped unless ``--run-slow`` is given or ``TISSUESIM_SLOW=1`` is set
  (``make test-slow``); each has a fast sibling in the default run.
* The contact references that calibration and the contact protocol compute are cached in a folder of this run
  (``TISSUESIM_CACHE``), never in the user's cache: an entry written by another version of the code is not read.
* Hypothesis keeps its example database (``.hypothesis/``) and prints a failing example's blob
  (``@reproduce_failure``); ``--hypothesis-seed N`` replays a whole run; under CI (``CI`` set) it is derandomised.
"""

import os
from pathlib import Path

import pytest
from hypothesis import settings

from tissuesim.mesh import models

# The real meshes live outside the repository (see DESIGN data conventions); TISSUESIM_SHARED overrides the place.
SHARED = Path(os.environ.get("TISSUESIM_SHARED", Path(__file__).resolve().parents[1].parent / "shared"))
MESHES = SHARED / "data" / "meshes"

# Explicit, whatever Hypothesis would pick for the environment (its own "ci" profile drops the database and
# silences the too-slow health check): every health check speaks, no wall-clock deadline (a timing assert by
# another name), and under CI the examples are derandomised, so a landing never hangs on a draw.
settings.register_profile("tissuesim", parent=settings.get_profile("default"), print_blob=True, deadline=None,
                          derandomize="CI" in os.environ)
settings.load_profile("tissuesim")


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False,
                     help="also run the checks marked slow (or set TISSUESIM_SLOW=1)")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--run-slow") or os.environ.get("TISSUESIM_SLOW") == "1":
        return
    skip = pytest.mark.skip(reason="slow: run with --run-slow, TISSUESIM_SLOW=1 or make test-slow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="module", autouse=True)
def registries_left_as_found():
    """A method or tool a test module registers joins every list of methods or tools in the package: it must be
    taken back out before the next module runs (tissuesim.solvers.unregister, tissuesim.tools.base.unregister_tool)."""
    from tissuesim.solvers import available_solvers
    from tissuesim.tools.base import tool_kinds

    before = available_solvers(), tool_kinds()
    yield
    assert (available_solvers(), tool_kinds()) == before, "a test module left a method or tool registered"


@pytest.fixture(scope="session", autouse=True)
def private_cache(tmp_path_factory):
    """Point ``TISSUESIM_CACHE`` at a folder of this run for the whole session."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("TISSUESIM_CACHE", str(tmp_path_factory.mktemp("cache")))
        yield


def _assert_better_beyond_the_reference(errors: dict, better: str, worse: str, change: float) -> None:
    """``errors[(method, case)]``: relative RMSE against a refined reference whose last level changed by ``change``.

    An unconverged reference stands about its last change δ (RMS, relative) off its limit, the usual estimate for
    refinement that converges geometrically; by the triangle inequality every method's relative RMSE against the
    limit is within about δ of its value here. So ``better`` beats ``worse`` against the limit only where the gap
    exceeds 2δ, in every case.
    """
    assert 0.0 < change < 0.2
    for case in sorted({case for method, case in errors if method == better}):
        gap = errors[(worse, case)] - errors[(better, case)]
        assert gap > 2.0 * change, f"{better} vs {worse}, {case}: gap {gap:.3f}, reference change {change:.3f}"


@pytest.fixture(scope="session")
def better_beyond_the_reference():
    """The check of :func:`_assert_better_beyond_the_reference`, for the tests of method orderings."""
    return _assert_better_beyond_the_reference


def _flipped_triangles(positions, triangles) -> int:
    """How many surface triangles are turned inside out: whose normal points against the area-weighted mean normal
    of the triangles sharing an edge with it (a local orientation reversal, whatever the rigid turn of the region;
    written here, apart from the solvers' own inversion checks)."""
    import numpy as np

    p, t = np.asarray(positions, dtype=np.float64), np.asarray(triangles, dtype=np.int64)
    normals = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])   # length = twice the area
    edges = np.sort(t[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(len(t)), 3)
    _, edge_id = np.unique(edges, axis=0, return_inverse=True)
    edge_id = edge_id.ravel()
    edge_sum = np.zeros((edge_id.max() + 1, 3))
    np.add.at(edge_sum, edge_id, normals[owner])
    neighbours = np.zeros_like(normals)
    np.add.at(neighbours, owner, edge_sum[edge_id] - normals[owner])    # the other triangle across each edge
    return int(np.count_nonzero(np.einsum("ij,ij->i", normals, neighbours) < 0.0))


@pytest.fixture(scope="session")
def flipped_triangles():
    """The check of :func:`_flipped_triangles`: ``(positions (n, 3), triangles (t, 3)) -> count``."""
    return _flipped_triangles


def _step_allocation(solver, steps: int = 10) -> tuple[int, int]:
    """Bytes ``(still held, peak)`` that ``steps`` steps of ``solver`` allocate (tracemalloc), after two steps that
    build whatever a first step builds."""
    import tracemalloc

    solver.step()
    solver.step()
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        before = tracemalloc.get_traced_memory()[0]
        for _ in range(steps):
            solver.step()
        current, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return current - before, peak - before


@pytest.fixture(scope="session")
def step_allocation():
    """The measure of :func:`_step_allocation`: ``(solver, steps=10) -> (bytes held, peak bytes)``."""
    return _step_allocation


@pytest.fixture(scope="session")
def meshes_dir() -> Path:
    if not MESHES.is_dir():
        pytest.fail(f"shared organ meshes not found at {MESHES}; set TISSUESIM_SHARED to the shared folder")
    return MESHES


@pytest.fixture(scope="session", params=sorted(models.MODELS))
def model_name(request) -> str:
    return request.param
