"""Turn result objects into plain JSON-ready values (floats, ints, lists, dicts)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["jsonable", "ResultMixin"]


def jsonable(value, *, arrays: bool = True):
    """`value` with numpy scalars and arrays turned into Python numbers and lists.

    Non-finite floats become None (JSON has no NaN). With ``arrays=False``
    arrays of more than 16 entries are left out (None), so a report keeps the
    summary figures only.
    """
    if isinstance(value, ResultMixin):
        return value.as_dict(arrays=arrays)
    if isinstance(value, dict):
        return {str(k): jsonable(v, arrays=arrays) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v, arrays=arrays) for v in value]
    if isinstance(value, np.ndarray):
        if not arrays and value.size > 16:
            return None
        return jsonable(value.tolist(), arrays=arrays)
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    return value


class ResultMixin:
    """`as_dict()` for the frozen result dataclasses of `trimsurf.quality`."""

    __slots__ = ()

    def as_dict(self, *, arrays: bool = False) -> dict:
        """The fields as JSON-ready values; large per-item arrays only with ``arrays=True``."""
        return {f.name: jsonable(getattr(self, f.name), arrays=arrays)
                for f in dataclasses.fields(self)}  # type: ignore[arg-type]
