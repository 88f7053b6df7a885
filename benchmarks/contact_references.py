"""Recompute the contact protocol's converged references and write them into the package data.

    python benchmarks/contact_references.py            # every default model (the shared livers where present)
    python benchmarks/contact_references.py cube       # one model

Each model runs the contact protocol's own path (:func:`tissuesim.experiments.contact_protocol.run_contact`, the cheap
``embedded`` method and one load, which every reference serves: a reference is the response to a unit force) with a
fresh cache folder and nothing shipped, so each reference is computed here; its cache entry is then written to
``src/tissuesim/experiments/data/references/<key>.npz`` (:func:`tissuesim.experiments.reference_cache.ship_entry`:
compressed, float32, with the parameters below; the radii of a model share one sequence of meshes, refined around
the largest patch, ``refined_around_mm``). Entries of models not recomputed are kept; ``--clean`` removes
every entry first. Prints each model's time and the folder's size. On 2 cores the six default models take about
5 minutes, and the largest quadratic level needs about 10 GB of memory.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

from tissuesim.experiments import contact_protocol, reference
from tissuesim.experiments.reference_cache import SHIPPED_DIR, load_entry, ship_entry
from tissuesim.mesh import models as builtin_models


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("models", nargs="*", help="built-in models or shared liver paths (default: the protocol's)")
    parser.add_argument("--clean", action="store_true", help="remove every shipped entry first")
    args = parser.parse_args()
    livers = contact_protocol.shared_livers()
    specs = args.models or [*builtin_models.MODELS, *livers]
    if args.clean:
        for path in SHIPPED_DIR.glob("*.npz"):
            path.unlink()
    config = contact_protocol.ContactConfig()
    for spec in specs:
        start = time.perf_counter()
        written = ship_model(spec, livers.get(spec, 1.0), config.settings)
        print(f"{spec}: {len(written)} references in {time.perf_counter() - start:.0f} s", flush=True)
    files = sorted(SHIPPED_DIR.glob("*.npz"))
    print(f"{len(files)} entries, {sum(p.stat().st_size for p in files) / 1e6:.2f} MB in {SHIPPED_DIR}")
    return 0


def ship_model(spec: str, scale: float, settings) -> list:
    """Compute the references of one model into a fresh cache folder, then ship each entry; returns the paths."""
    with tempfile.TemporaryDirectory() as cache:
        run = contact_protocol.run_contact(contact_protocol.ContactConfig(
            models=(spec,), scales={spec: scale}, forces=(1.0,), loads=("pressure",), methods=("embedded",),
            cache_dir=cache, shipped=False), progress=True)
        (name, info), = run["metadata"]["models"].items()
        written = []
        for path in sorted(Path(cache).glob("*.npz")):
            entry = load_entry(cache, path.stem, settings)
            parameters = {"model": name, "source": _portable(spec), "scale": scale,
                          "surface_vertices": info["surface_nodes"], "load_node": info["load_node"],
                          "radius_mm": 1e3 * entry.radius, "refined_around_mm": max(map(float, info["references"])),
                          "element": settings.element,
                          "cache_format": reference.CACHE_FORMAT, "settings": dataclasses.asdict(settings)}
            written.append(ship_entry(SHIPPED_DIR, path.stem, entry, parameters))
        return written


def _portable(spec: str) -> str:
    """A built-in name as is; a shared mesh as its path inside the shared mesh folder."""
    for rel, _ in contact_protocol.SHARED_LIVERS:
        if spec.endswith(rel):
            return rel
    return spec


if __name__ == "__main__":
    raise SystemExit(main())
