"""The layout of ``results.json``: a metadata header and one record per model × load × force × method.

::

    {"schema": 1,
     "metadata": {"tissuesim": "0.1.0", "python": ..., "packages": {...}, "machine": {...}, "date": ISO-8601 UTC,
                  "options": {...}, "models": {name: {mesh sizes, load_node, sample nodes, build_s}}},
     "records": [{"model": "cube", "load": "tension", "force_N": 0.5, "method": "hybrid",
                  "rmse_mm": 0.03, "relative_rmse": 0.1, "step_ms": 1.2, "equilibrium_ms": 40.0,
                  "displacements_mm": [10 floats]}, ...]}

``rmse_mm`` is eq 26 over the 50 sample nodes against ``fem`` [mm]; ``relative_rmse`` divides it by the reference's
RMS displacement over the same nodes (null when that is zero); ``step_ms`` is the median time of one ``step(dt)``
with the load set [ms]; ``equilibrium_ms`` is the wall time of ``solve_static`` [ms]; ``displacements_mm`` is eq 25
for the 10 plot sample nodes, nearest first [mm]. Optional extras: ``equilibrium_steps`` (steps the quasi-static
solve took), ``converged`` (false when it hit the step cap; its last positions are what is measured) and
``max_displacement_mm`` (the largest M_S node displacement, compared with the model's ``size_m`` in the metadata to
say where linear elasticity stops being valid).
"""

from __future__ import annotations

import math

from ..errors import TissuesimError, first_indices

SCHEMA_VERSION = 1

# field -> accepted Python types after json.load (None allowed only where listed in NULLABLE).
RECORD_FIELDS = {
    "model": (str,),
    "load": (str,),
    "force_N": (int, float),
    "method": (str,),
    "rmse_mm": (int, float),
    "relative_rmse": (int, float),
    "step_ms": (int, float),
    "equilibrium_ms": (int, float),
    "displacements_mm": (list,),
}
NULLABLE = {"relative_rmse"}
METADATA_FIELDS = ("tissuesim", "python", "packages", "machine", "date", "options", "models")


class ResultsError(TissuesimError, ValueError):
    """A results document does not follow the ``results.json`` layout."""


def check_results(data: object) -> None:
    """Raise :class:`ResultsError` naming the first defect if ``data`` (a parsed results.json) is malformed."""
    if not isinstance(data, dict):
        raise ResultsError(f"results must be a JSON object, got {type(data).__name__}")
    if data.get("schema") != SCHEMA_VERSION:
        raise ResultsError(f"results schema is {data.get('schema')!r}, this version reads {SCHEMA_VERSION}; "
                           "rerun `tissuesim experiment` to regenerate them")
    metadata = data.get("metadata")
    if not isinstance(metadata, dict):
        raise ResultsError("results lack the 'metadata' object")
    missing = [key for key in METADATA_FIELDS if key not in metadata]
    if missing:
        raise ResultsError(f"metadata lacks {', '.join(missing)}")
    records = data.get("records")
    if not isinstance(records, list) or not records:
        raise ResultsError("results hold no 'records' list (or an empty one)")
    bad = [i for i, record in enumerate(records) if _record_defect(record)]
    if bad:
        raise ResultsError(f"{len(bad)} malformed records (first: {first_indices(bad)}): "
                           f"record {bad[0]}: {_record_defect(records[bad[0]])}")
    keys = [(r["model"], r["load"], float(r["force_N"]), r["method"]) for r in records]
    if len(set(keys)) != len(keys):
        raise ResultsError("results hold more than one record for the same model, load, force and method")


def _record_defect(record) -> str | None:
    if not isinstance(record, dict):
        return "not an object"
    for field, types in RECORD_FIELDS.items():
        if field not in record:
            return f"missing field {field!r}"
        value = record[field]
        if value is None and field in NULLABLE:
            continue
        if isinstance(value, bool) or not isinstance(value, types):
            return f"field {field!r} has type {type(value).__name__}"
        if isinstance(value, float) and not math.isfinite(value):
            return f"field {field!r} is not finite"
    if not all(isinstance(d, (int, float)) and math.isfinite(d) and d >= 0 for d in record["displacements_mm"]):
        return "displacements_mm must hold finite non-negative numbers"
    if record["rmse_mm"] < 0 or record["step_ms"] < 0 or record["equilibrium_ms"] < 0:
        return "rmse_mm, step_ms and equilibrium_ms must be non-negative"
    return None
