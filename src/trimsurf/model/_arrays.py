"""Array validation shared by the model dataclasses."""

from __future__ import annotations

import numpy as np

from ..errors import GeometryError


def as_float_array(value, name: str, *, ndim: int | None = None, last: int | None = None,
                   error=GeometryError) -> np.ndarray:
    """Return `value` as a read-only C-contiguous float64 array, checked for shape and NaN."""
    arr = np.array(value, dtype=np.float64, order="C", copy=True)
    if ndim is not None and arr.ndim != ndim:
        raise error(f"{name} must have {ndim} dimensions; got shape {arr.shape}")
    if last is not None and arr.shape[-1] != last:
        raise error(f"{name} must have shape (..., {last}); got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise error(f"{name} has a non-finite value at index {tuple(int(i) for i in bad)}")
    arr.setflags(write=False)
    return arr


def as_index_array(value, name: str, *, ndim: int | None = None, last: int | None = None,
                   error=GeometryError) -> np.ndarray:
    """Return `value` as a read-only C-contiguous int64 array, checked for shape."""
    raw = np.asarray(value)
    if raw.size and not np.issubdtype(raw.dtype, np.integer):
        if not np.all(np.isfinite(raw)) or not np.all(raw == np.round(raw)):
            raise error(f"{name} must hold integers")
    arr = np.array(raw, dtype=np.int64, order="C", copy=True)
    if ndim is not None and arr.ndim != ndim:
        if not (arr.size == 0 and ndim == 2 and last is not None):
            raise error(f"{name} must have {ndim} dimensions; got shape {arr.shape}")
        arr = arr.reshape(0, last)
    if last is not None and arr.shape[-1] != last:
        raise error(f"{name} must have shape (..., {last}); got {arr.shape}")
    arr.setflags(write=False)
    return arr
