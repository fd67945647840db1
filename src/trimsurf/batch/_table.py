"""The results table of a batch as CSV and Parquet (pyarrow), rewritten atomically as rows arrive."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from ._jobs import COLUMNS

__all__ = ["write_tables", "read_table", "SCHEMA_TYPES"]

#: column -> pyarrow type name
SCHEMA_TYPES = {"part": "string", "job": "string", "status": "string", "reason": "string", "faces": "int64",
                "triangles": "int64", "max_deviation": "float64", "flips": "int64", "watertight": "bool_",
                "certified_faces": "int64", "seconds": "float64", "worker": "string", "attempts": "int64",
                "reused": "bool_", "input": "string"}


def _clean(row: dict) -> dict:
    out = {}
    for c in COLUMNS:
        v = row.get(c)
        if isinstance(v, float) and not math.isfinite(v):
            v = None
        out[c] = v
    return out


def write_tables(rows: list[dict], out: str | Path) -> None:
    """``OUT/results.csv`` and ``OUT/results.parquet``: one row per part and job, columns `COLUMNS`.

    Each file is written to a temporary file and renamed, so a reader (or a
    batch stopped while writing) never sees half a table.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ..io._atomic import atomic_path

    out = Path(out)
    clean = [_clean(r) for r in rows]
    with atomic_path(out / "results.csv") as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=list(COLUMNS))
            w.writeheader()
            for r in clean:
                w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    schema = pa.schema([(c, getattr(pa, SCHEMA_TYPES[c])()) for c in COLUMNS])
    table = pa.Table.from_pylist(clean, schema=schema)
    with atomic_path(out / "results.parquet") as tmp:
        pq.write_table(table, tmp)


def read_table(out: str | Path) -> list[dict]:
    """The rows of ``OUT/results.parquet``."""
    import pyarrow.parquet as pq

    return pq.read_table(Path(out) / "results.parquet").to_pylist()
