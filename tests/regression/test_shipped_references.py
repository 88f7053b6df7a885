"""The contact protocol's references shipped with the package (benchmarks/contact_references.py): complete, small,
found under the keys a run computes here, and what the refinement computes again.

The coarse check recomputes the cube's levels 0 and 1 (R = 8 mm, the largest patch, so the same meshes as the shipped
run) in seconds. Its table rows must match the shipped rows to 1e-6 (the same meshes and solves; only round-off
differs), and its level-1 field must lie within the shipped levels' own changes of the shipped converged field: by
the triangle inequality ‖u₁ − u_L‖ ≤ Σ_{k=2..L} ‖u_k − u_{k−1}‖ = Σ c_k ‖u_k‖ (c_k the shipped change of level k,
relative to that level's RMS, the largest over the axes).
"""

import json

import numpy as np
import pytest

from tissuesim.experiments import contact_protocol, protocol, reference
from tissuesim.experiments.reference_cache import SHIPPED_DIR, SHIPPED_SCHEMA, load_shipped
from tissuesim.mesh import models

SETTINGS = contact_protocol.ContactConfig().settings
#: What the shipped references may weigh in the repository (measured: 1.2 MB).
SIZE_BUDGET_MB = 5.0


def _entries() -> dict:
    entries = {}
    for path in sorted(SHIPPED_DIR.glob("*.npz")):
        with np.load(path) as data:
            entries[path.stem] = (json.loads(str(data["meta"])), {name: data[name] for name in data.files
                                                                  if name != "meta"})
    return entries


ENTRIES = _entries()


def _surface(parameters: dict, meshes_dir):
    source = parameters["source"]
    if source in models.MODELS:
        return models.model(source)
    from tissuesim.io import read_surface

    return read_surface(meshes_dir / source, scale=parameters["scale"])


def test_every_protocol_model_and_radius_is_shipped_in_a_small_folder():
    shipped = {(meta["parameters"]["model"], meta["parameters"]["radius_mm"]) for meta, _ in ENTRIES.values()}
    names = [*models.MODELS, "liver2", "softbodyliver-liver"]
    assert shipped == {(name, radius) for name in names for radius in contact_protocol.RADII_MM}
    size = sum(path.stat().st_size for path in SHIPPED_DIR.glob("*.npz")) / 1e6
    assert size < SIZE_BUDGET_MB


@pytest.mark.parametrize("key", sorted(ENTRIES))
def test_a_shipped_entry_is_complete_and_found_under_the_key_a_run_computes(key, meshes_dir):
    meta, arrays = ENTRIES[key]
    parameters = meta["parameters"]
    assert meta["schema"] == SHIPPED_SCHEMA and meta["key"] == key
    assert parameters["cache_format"] == reference.CACHE_FORMAT and parameters["settings"]["element"] == "quadratic"
    n = parameters["surface_vertices"]
    assert arrays["response"].shape == arrays["nodal_response"].shape == (n, 3, 3)
    assert arrays["response"].dtype == np.float32 and np.all(np.isfinite(arrays["response"]))
    assert len(arrays["samples"]) == SETTINGS.samples and arrays["samples"][0] == meta["node"]
    assert [row["level"] for row in meta["levels"]] == list(range(len(meta["levels"])))
    assert meta["converged"] == (meta["levels"][-1]["change"] < SETTINGS.tolerance)
    surface = _surface(parameters, meshes_dir)
    node = protocol.load_node(surface.vertices, surface.triangles)
    assert surface.vertex_count == n and node == meta["node"] == parameters["load_node"]
    assert reference._cache_key(surface, node, meta["radius"], 5500.0, 0.3, SETTINGS) == key
    assert load_shipped(key, SETTINGS) is not None


def _shipped(model: str, radius_mm: float):
    (key,) = [k for k, (meta, _) in ENTRIES.items()
              if (meta["parameters"]["model"], meta["parameters"]["radius_mm"]) == (model, radius_mm)]
    return load_shipped(key, SETTINGS)


def _relative(u, v) -> float:
    return float(np.sqrt(np.mean(np.sum((u - v) ** 2, axis=1)) / np.mean(np.sum(v ** 2, axis=1))))


def test_the_cube_coarse_levels_recomputed_match_the_shipped_table_and_approach_its_field():
    surface = models.model("cube")
    node = protocol.load_node(surface.vertices, surface.triangles)
    shipped = _shipped("cube", 8.0)
    again = reference.refinement_levels(surface, node, 8e-3, levels=1, settings=SETTINGS)
    for row, ship in zip(again.levels, shipped.levels[:2]):
        assert row.tets == ship.tets and row.nodes == ship.nodes
        for name in ("sample_rms_mm", "contact_mm", "others_rms_mm"):
            assert getattr(row, name) == pytest.approx(getattr(ship, name), rel=1e-6)
    samples = shipped.samples
    level1, final = -again.response[samples, :, 2], -shipped.response[samples, :, 2]
    rms = [row.sample_rms_mm for row in shipped.levels]
    bound = sum(row.change * rms[row.level] for row in shipped.levels[2:]) / rms[-1]
    assert _relative(level1, final) <= bound + 1e-6


@pytest.mark.slow
def test_the_cube_references_recomputed_whole_equal_the_shipped_ones_to_float32():
    """Both radii on their shared meshes, as a run computes them (about 15 s on 2 cores)."""
    surface = models.model("cube")
    node = protocol.load_node(surface.vertices, surface.triangles)
    radii = [1e-3 * r for r in contact_protocol.RADII_MM]
    for radius_mm, again in zip(contact_protocol.RADII_MM, reference.contact_references(surface, node, radii,
                                                                                settings=SETTINGS)):
        shipped = _shipped("cube", radius_mm)
        assert [row.tets for row in again.levels] == [row.tets for row in shipped.levels]
        assert [row.sample_rms_mm for row in again.levels] == pytest.approx(
            [row.sample_rms_mm for row in shipped.levels], rel=1e-9)
        # float32 storage: 2^-24 of each value; the solve's round-off is far below
        scale = np.abs(again.response).max()
        assert np.abs(shipped.response - again.response).max() <= 1e-6 * scale
