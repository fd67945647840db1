"""Where a closed polygon crosses itself: blocks of consecutive segments, pruned by their bounding boxes."""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["polygon_crossings"]

_BLOCK = 32


@njit(cache=True, nogil=True)
def _orient(ax, ay, bx, by, cx, cy):  # pragma: no cover - compiled
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True, nogil=True)
def _on(ax, ay, bx, by, px, py):  # pragma: no cover - compiled
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@njit(cache=True, nogil=True)
def _kernel(p, block):  # pragma: no cover - compiled
    n = p.shape[0]
    nb = (n + block - 1) // block
    lo = np.empty((nb, 2))
    hi = np.empty((nb, 2))
    for b in range(nb):
        lo[b, 0] = lo[b, 1] = np.inf
        hi[b, 0] = hi[b, 1] = -np.inf
        for i in range(b * block, min(n, (b + 1) * block)):
            j = (i + 1) % n
            for c in range(2):
                lo[b, c] = min(lo[b, c], p[i, c], p[j, c])
                hi[b, c] = max(hi[b, c], p[i, c], p[j, c])
    out = []
    for b1 in range(nb):
        for b2 in range(b1, nb):
            if lo[b1, 0] > hi[b2, 0] or lo[b2, 0] > hi[b1, 0] or lo[b1, 1] > hi[b2, 1] or lo[b2, 1] > hi[b1, 1]:
                continue
            for i in range(b1 * block, min(n, (b1 + 1) * block)):
                i2 = (i + 1) % n
                ax, ay, bx, by = p[i, 0], p[i, 1], p[i2, 0], p[i2, 1]
                j0 = i + 2 if b1 == b2 else b2 * block
                for j in range(j0, min(n, (b2 + 1) * block)):
                    j2 = (j + 1) % n
                    if j == i2 or j2 == i:        # adjacent (also through the wrap-around)
                        continue
                    cx, cy, dx, dy = p[j, 0], p[j, 1], p[j2, 0], p[j2, 1]
                    if max(ax, bx) < min(cx, dx) or max(cx, dx) < min(ax, bx) or \
                            max(ay, by) < min(cy, dy) or max(cy, dy) < min(ay, by):
                        continue
                    o1 = _orient(ax, ay, bx, by, cx, cy)
                    o2 = _orient(ax, ay, bx, by, dx, dy)
                    o3 = _orient(cx, cy, dx, dy, ax, ay)
                    o4 = _orient(cx, cy, dx, dy, bx, by)
                    hit = ((o1 > 0 and o2 < 0) or (o1 < 0 and o2 > 0)) and ((o3 > 0 and o4 < 0) or (o3 < 0 and o4 > 0))
                    if not hit:
                        hit = (o1 == 0 and _on(ax, ay, bx, by, cx, cy)) or (o2 == 0 and _on(ax, ay, bx, by, dx, dy)) \
                            or (o3 == 0 and _on(cx, cy, dx, dy, ax, ay)) or (o4 == 0 and _on(cx, cy, dx, dy, bx, by))
                    if hit:
                        out.append((i, j))
    return out


def polygon_crossings(points: np.ndarray) -> np.ndarray:
    """Pairs (i, j) of non-adjacent segments of the closed polygon `points` that meet, (k, 2) int64.

    Segment i runs from points[i] to points[i + 1] (the last one back to points[0]). Blocks of consecutive
    segments whose bounding boxes are disjoint are skipped, so a polygon that does not fold onto itself
    costs about O(n) segment tests.

    Examples
    --------
    >>> polygon_crossings(np.array([[0., 0.], [1., 0.], [0., 1.], [1., 1.]])).tolist()   # a bow tie
    [[1, 3]]
    """
    p = np.ascontiguousarray(points, dtype=np.float64)
    if len(p) < 4:
        return np.zeros((0, 2), dtype=np.int64)
    out = _kernel(p, _BLOCK)
    return np.array(out, dtype=np.int64).reshape(-1, 2)
