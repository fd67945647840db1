"""Compiled helpers of the per-face triangulation (`trimsurf.tessellate.face`, mesh side)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["deviation_samples"]


@njit(cache=True, nogil=True)
def deviation_samples(bary, uv, xyz, tris):
    """The sample points of `trimsurf.tessellate.face.triangle_deviation`: per triangle the points
    sum_k bary[b, k] * corner_k (in (u, v) and in 3D, summed in k order as numpy's einsum does) for the rows b
    of `bary`, rows 1-3 being the edge midpoints 01, 12, 20; a midpoint shared by two triangles (the same
    numbers either way round) is listed once.

    Returns (suv (n, 2), sx (n, 3), rows (m, nb)): the points and, per triangle, its samples' indices.
    """
    m, nb = tris.shape[0], bary.shape[0]
    n_own = nb - 3
    # edges by their lower corner (buckets of a CSR); an edge's point belongs to its first occurrence
    n_v = 0
    for i in range(m):
        for c in range(3):
            n_v = max(n_v, tris[i, c] + 1)
    start = np.zeros(n_v + 1, dtype=np.int64)
    for i in range(m):
        for c in range(3):
            start[min(tris[i, c], tris[i, (c + 1) % 3]) + 1] += 1
    for v in range(n_v):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    other = np.empty(3 * m, dtype=np.int64)          # the higher corner of the bucket's edges
    slot = np.empty(3 * m, dtype=np.int64)           # the triangle edge there
    edge_id = np.empty(3 * m, dtype=np.int64)
    n_edge = 0
    for i in range(m):
        for c in range(3):
            a, b = tris[i, c], tris[i, (c + 1) % 3]
            lo, hi = min(a, b), max(a, b)
            e = -1
            for r in range(start[lo], fill[lo]):
                if other[r] == hi:
                    e = edge_id[slot[r]]
                    break
            if e < 0:
                e = n_edge
                n_edge += 1
                other[fill[lo]] = hi
                slot[fill[lo]] = 3 * i + c
                fill[lo] += 1
            edge_id[3 * i + c] = e
    n = m * n_own + n_edge
    suv = np.empty((n, 2))
    sx = np.empty((n, 3))
    rows = np.empty((m, nb), dtype=np.int64)
    done = np.zeros(n_edge, dtype=np.bool_)
    for i in range(m):
        p, q, r = tris[i, 0], tris[i, 1], tris[i, 2]
        for b in range(nb):
            if 1 <= b <= 3:
                e = edge_id[3 * i + b - 1]
                k = m * n_own + e
                rows[i, b] = k
                if done[e]:
                    continue
                done[e] = True
            else:
                k = i * n_own + (0 if b == 0 else b - 3)
                rows[i, b] = k
            for d in range(2):
                suv[k, d] = bary[b, 0] * uv[p, d] + bary[b, 1] * uv[q, d] + bary[b, 2] * uv[r, d]
            for d in range(3):
                sx[k, d] = bary[b, 0] * xyz[p, d] + bary[b, 1] * xyz[q, d] + bary[b, 2] * xyz[r, d]
    return suv, sx, rows
