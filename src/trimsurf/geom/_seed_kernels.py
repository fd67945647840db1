"""Compiled (numba) kernels of the projection's seed grid (`projection._build_seeds`).

`seed_grid_kernel` computes, for a 2-D grid of surface samples, each sample's
largest distance to its 8 grid neighbours (the grid edge-padded) and the spread
of the four boundary grid lines (pole test) with the same operations as the
numpy expressions it replaces (``norm`` of a 3-vector as ``sqrt((x0^2 + x1^2) + x2^2)``,
``np.maximum`` propagating NaN), so the numbers are the same.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)


@njit(cache=True, nogil=True)
def seed_grid_kernel(pts, radius, spread):
    """pts (nu, nv, 3): radius[i, j] = max over the 3 x 3 neighbourhood (indices clamped) of
    |pts[neighbour] - pts[i, j]| (NaN if any is NaN); spread[0..3] = the largest coordinate range
    (max - min over the line, NaN if any is NaN) of the lines i = 0, i = nu - 1, j = 0, j = nv - 1."""
    nu, nv = pts.shape[0], pts.shape[1]
    for i in range(nu):
        for j in range(nv):
            r = 0.0
            for oi in range(3):
                ii = min(max(i + oi - 1, 0), nu - 1)
                for oj in range(3):
                    jj = min(max(j + oj - 1, 0), nv - 1)
                    d0 = pts[ii, jj, 0] - pts[i, j, 0]
                    d1 = pts[ii, jj, 1] - pts[i, j, 1]
                    d2 = pts[ii, jj, 2] - pts[i, j, 2]
                    d = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                    if np.isnan(r) or np.isnan(d):
                        r = np.nan
                    elif d > r:
                        r = d
            radius[i, j] = r
    for line in range(4):
        n = nv if line < 2 else nu
        best = -np.inf
        for c in range(3):
            lo = np.inf
            hi = -np.inf
            nan = False
            for k in range(n):
                if line == 0:
                    x = pts[0, k, c]
                elif line == 1:
                    x = pts[nu - 1, k, c]
                elif line == 2:
                    x = pts[k, 0, c]
                else:
                    x = pts[k, nv - 1, c]
                if np.isnan(x):
                    nan = True
                lo = min(lo, x)
                hi = max(hi, x)
            v = np.nan if nan else hi - lo
            if np.isnan(best) or np.isnan(v):
                best = np.nan
            elif v > best:
                best = v
        spread[line] = best


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _cell(vals, x):
    """``clip(searchsorted(vals, x, side="right") - 1, 0, len - 1)`` (NaN sorts last, as in numpy)."""
    n = vals.shape[0]
    if np.isnan(x):
        pos = n
    else:
        lo, hi = 0, n               # first index with vals[index] > x
        while lo < hi:
            mid = (lo + hi) // 2
            if vals[mid] <= x:
                lo = mid + 1
            else:
                hi = mid
        pos = lo
    return min(max(pos - 1, 0), n - 1)


@njit(cache=True, nogil=True)
def retry_seeds_kernel(axis_u, axis_v, radius, nearest, seed_dist, foot_params, distance, tol, used, has_used,
                       points, seed):
    """`projection._retry_seeds` for a 2-D seed grid (C order over (axis_u, axis_v)), point by point, the
    same tests: seed nearest[i, c] qualifies when its grid index lies more than two cells below or three
    above the foot's cell in some direction, it is not ``used[i]`` (with `has_used`), and
    ``seed_dist[i, c] - radius[seed] < distance[i] - tol``; points[:count] = the points with one, seed[:count]
    the first qualifying seed of each (in column order). Returns count."""
    nv = axis_v.shape[0]
    count = 0
    for i in range(nearest.shape[0]):
        cu = _cell(axis_u, foot_params[i, 0])
        cv = _cell(axis_v, foot_params[i, 1])
        lim = distance[i] - tol
        for c in range(nearest.shape[1]):
            s = nearest[i, c]
            gu = s // nv
            gv = s - gu * nv
            far = (gu < cu - 2) or (gu > cu + 3) or (gv < cv - 2) or (gv > cv + 3)
            if has_used and s == used[i]:
                far = False
            if far and seed_dist[i, c] - radius[s] < lim:
                points[count] = i
                seed[count] = s
                count += 1
                break
    return count
