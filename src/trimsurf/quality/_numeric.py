"""Small numpy helpers of the measurement's per-face glue: the same numbers as numpy's, fewer calls."""

from __future__ import annotations

import numpy as np


def median(x) -> float:
    """``float(np.median(x))`` of a 1-D float64 array, bit for bit, without its general machinery (axis
    handling, dispatch: ~4x its cost on the short arrays of a face).

    np.median partitions at the middle index (two middle indices for an even size, where it returns their
    mean: ``(a + b) / 2``) and the last (a NaN sorts last and makes the result NaN); so does this.

    >>> median(np.array([3.0, 1.0, 2.0])), median(np.array([4.0, 1.0, 2.0, 3.0]))
    (2.0, 2.5)
    """
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    n = x.shape[0]
    if n < 2:
        return float(np.median(x)) if n == 0 else float(x[0])
    h = n // 2
    if n % 2:
        p = np.partition(x, (h, n - 1))
        val = p[h]
    else:
        p = np.partition(x, (h - 1, h, n - 1))
        val = (p[h - 1] + p[h]) / 2.0
    if p[n - 1] != p[n - 1]:       # NaN
        return float("nan")
    return float(val)
