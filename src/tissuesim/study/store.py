"""A study's output folder: one small Parquet part per finished case, the fields in Zarr, the combined table.

    OUTPUT/parts/<case_id>.parquet    one row: every input and metric of the case (or its error)
    OUTPUT/fields.zarr/<case_id>      (n, 3) float32 displacement [m] of every M_S node, one chunk per case
    OUTPUT/results.parquet            every part, combined at the end of a run

Nothing half-written is read as a result: a part is written under a temporary name and renamed into place (atomic
on one file system), after its field; a part that pyarrow cannot read, or whose row is not its case's, or whose
field is missing or misshapen, counts as not done: it is removed and the case computed again.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .cases import Case

if TYPE_CHECKING:
    import pyarrow as pa

PARTS = "parts"
FIELDS = "fields.zarr"
RESULTS = "results.parquet"


def case_inputs(case: Case) -> dict:
    """The input columns of a case's row: flat scalars, so the table is tidy."""
    model = asdict(case.model)
    label, youngs_modulus, poisson_ratio, density = case.material
    seed, index, lowest, highest = case.random or (None, None, None, None)
    direction = case.direction or (None, None, None)
    return {"case_id": case.case_id, "model": case.model.label, "model_kind": model["kind"],
            "model_source": model["source"], "model_key": model["key"], "resolution": model["resolution"],
            "scale": model["scale"], "method": case.method, "options": case.options, "material": label,
            "youngs_modulus_Pa": youngs_modulus, "poisson_ratio": poisson_ratio, "density_kg_m3": density,
            "radius_m": case.radius, "force_N": case.force_N, "direction_x": direction[0],
            "direction_y": direction[1], "direction_z": direction[2], "random_seed": seed, "random_index": index,
            "random_force_low_N": lowest, "random_force_high_N": highest, "reference_key": case.reference_key}


class Store:
    """The output folder ``root`` of one study (created if missing)."""

    def __init__(self, root: Path | str):
        self.root = Path(root)
        (self.root / PARTS).mkdir(parents=True, exist_ok=True)
        self._group = None

    def part(self, case_id: str) -> Path:
        return self.root / PARTS / f"{case_id}.parquet"

    def done(self, case: Case) -> bool:
        """Whether ``case`` has a sound part (and field, when it records one); a damaged one is removed."""
        path = self.part(case.case_id)
        if not path.exists():
            return False
        row = self._read_row(path)
        if row is None or row.get("case_id") != case.case_id or row.get("status") not in ("done", "failed"):
            path.unlink(missing_ok=True)
            return False
        return row["status"] == "failed" or not case.record.field or self._field_sound(case.case_id, row)

    def write(self, case: Case, row: dict, field: np.ndarray | None) -> None:
        """Write ``case``'s result: its field first, then its part (renamed into place: the commit)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        row = {**case_inputs(case), **row}
        if field is not None:
            self._write_field(case.case_id, field)
            row["field_sha256"] = hashlib.sha256(np.ascontiguousarray(field).tobytes()).hexdigest()
        path = self.part(case.case_id)
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        pq.write_table(pa.Table.from_pylist([row]), temporary)
        os.replace(temporary, path)

    def combine(self) -> pa.Table:
        """The table of every part (a ``pyarrow.Table``), also written to ``results.parquet`` atomically."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        tables = [pq.read_table(path) for path in sorted((self.root / PARTS).glob("*.parquet"))]
        table = pa.concat_tables(tables, promote_options="default") if tables else pa.table({})
        temporary = self.root / f".{RESULTS}.{os.getpid()}.tmp"
        pq.write_table(table, temporary)
        os.replace(temporary, self.root / RESULTS)
        return table

    def field(self, case_id: str) -> np.ndarray:
        """``(n, 3) float32`` the displacement field [m] of a finished case."""
        return np.asarray(self._fields()[case_id][...])

    def _fields(self):
        # opening the group costs more as it grows (~15 ms a case at a few hundred): open it once per store
        import zarr

        if self._group is None:
            self._group = zarr.open_group(self.root / FIELDS, mode="a")
        return self._group

    def _write_field(self, case_id: str, field: np.ndarray) -> None:
        array = self._fields().create_array(case_id, shape=field.shape, chunks=field.shape, dtype=field.dtype,
                                            overwrite=True)
        array[...] = field

    def _field_sound(self, case_id: str, row: dict) -> bool:
        try:
            field = self.field(case_id)
        except Exception:  # noqa: BLE001 - any unreadable field means the case is not done
            field = None
        sound = (field is not None and field.shape == (row.get("surface_nodes"), 3)
                 and hashlib.sha256(np.ascontiguousarray(field).tobytes()).hexdigest() == row.get("field_sha256"))
        if not sound:
            self.part(case_id).unlink(missing_ok=True)
        return sound

    @staticmethod
    def _read_row(path: Path) -> dict | None:
        import pyarrow.parquet as pq

        try:
            rows = pq.read_table(path).to_pylist()
        except Exception:  # noqa: BLE001 - pyarrow raises several kinds for a truncated or garbled file
            return None
        return rows[0] if len(rows) == 1 else None
