"""Shipped contact references: their file form, when one is read instead of computed, the key's tolerance of a
last-bit difference, and the estimate of a computation's time."""

import json

import numpy as np
import pytest

from tissuesim.experiments import protocol, reference, reference_cache
from tissuesim.experiments.reference_progress import LevelProgress
from tissuesim.mesh import models
from tissuesim.mesh.surface import SurfaceMesh

SETTINGS = reference.RefinementSettings(max_levels=1)


@pytest.fixture(scope="module")
def cube():
    surface = models.model("cube", 400)
    return surface, protocol.load_node(surface.vertices, surface.triangles)


@pytest.fixture(scope="module")
def computed(cube):
    surface, node = cube
    return reference.contact_reference(surface, node, 8e-3, settings=SETTINGS)


@pytest.fixture()
def shipped_dir(tmp_path, monkeypatch):
    folder = tmp_path / "shipped"
    monkeypatch.setattr(reference_cache, "SHIPPED_DIR", folder)
    return folder


def _key(cube, radius=8e-3, youngs_modulus=5500.0):
    surface, node = cube
    return reference._cache_key(surface, node, radius, youngs_modulus, 0.3, SETTINGS)


def test_a_shipped_entry_is_compressed_float32_with_its_parameters_and_reads_back_within_float32(
        cube, computed, shipped_dir):
    path = reference_cache.ship_entry(shipped_dir, _key(cube), computed, {"model": "cube", "radius_mm": 8.0})
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        assert data["response"].dtype == np.float32 and data["nodal_response"].dtype == np.float32
    assert meta["schema"] == reference_cache.SHIPPED_SCHEMA and meta["parameters"]["model"] == "cube"
    assert meta["E"] == 5500.0 and len(meta["levels"]) == 2
    back = reference_cache.load_shipped(_key(cube), SETTINGS)
    assert back.response.dtype == np.float64 and back.levels == computed.levels
    # float32 rounds each value to 2^-24 of itself
    assert np.all(np.abs(back.response - computed.response) <= 2.0 ** -24 * np.abs(computed.response))
    assert np.array_equal(back.samples, computed.samples)


def test_a_shipped_reference_is_read_instead_of_computed_only_for_its_own_parameters(cube, computed, shipped_dir,
                                                                                   tmp_path):
    surface, node = cube
    reference_cache.ship_entry(shipped_dir, _key(cube), computed, {})
    lines = []
    read = reference.contact_reference(surface, node, 8e-3, settings=SETTINGS, cache_dir=tmp_path / "c",
                                       progress=lines.append, shipped=True)
    assert not lines and not (tmp_path / "c").exists()   # nothing refined, nothing cached
    assert read.levels == computed.levels
    # Another material: another key, computed with its progress, the response scaling as 1/E.
    stiffer = reference.contact_reference(surface, node, 8e-3, youngs_modulus=11000.0, settings=SETTINGS,
                                          progress=lines.append, shipped=True)
    assert any("level 1" in line for line in lines)
    assert np.allclose(stiffer.response, 0.5 * computed.response, rtol=1e-9, atol=1e-12 * np.abs(
        computed.response).max())
    # Not asked for: the shipped entry is not read.
    lines.clear()
    reference.contact_reference(surface, node, 8e-3, settings=SETTINGS, progress=lines.append)
    assert any("level 1" in line for line in lines)


def test_a_shipped_entry_of_another_schema_is_not_read(cube, computed, shipped_dir):
    key = _key(cube)
    reference_cache.write_arrays(shipped_dir, key, {"schema": "other/1"}, response=computed.response)
    assert reference_cache.load_shipped(key, SETTINGS) is None


def test_the_key_ignores_a_last_bit_difference_of_the_positions_and_sees_a_micrometre(cube):
    surface, node = cube
    nudged = SurfaceMesh(np.nextafter(surface.vertices, np.inf), surface.triangles)
    moved = SurfaceMesh(surface.vertices + [0.0, 0.0, 1e-6], surface.triangles)
    key = _key(cube)
    assert reference._cache_key(nudged, node, 8e-3, 5500.0, 0.3, SETTINGS) == key
    assert reference._cache_key(moved, node, 8e-3, 5500.0, 0.3, SETTINGS) != key


def test_the_estimate_scales_the_last_level_by_the_square_of_the_tets(monkeypatch):
    """Levels whose time is 1e-9 s · tets² and whose tets triple: after one timed level the estimates of the next
    and of the rest are exact; before, there is none."""
    clock = [0.0]
    monkeypatch.setattr("tissuesim.experiments.reference_progress.time.perf_counter", lambda: clock[0])
    progress = LevelProgress(None, 4)
    tets = [1000 * 3 ** level for level in range(5)]
    progress.level_meshed(0, tets[0])
    assert progress.estimate(0) == (None, 0.0)
    for level in range(2):
        if level:
            progress.level_meshed(level, tets[level])
        clock[0] += 1e-9 * tets[level] ** 2
        progress.level_solved()
    progress.level_meshed(2, tets[2])
    now, rest = progress.estimate(2)
    assert now == pytest.approx(1e-9 * tets[2] ** 2, rel=1e-12)
    assert rest == pytest.approx(1e-9 * (tets[3] ** 2 + tets[4] ** 2), rel=1e-12)
