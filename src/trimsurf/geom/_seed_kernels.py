"""Compiled (numba) kernels of the projection's seed grid (`projection._build_seeds`).

`seed_grid_kernel` computes, for a 2-D grid of surface samples, each sample's
largest distance to its 8 grid neighbours (the grid edge-padded) and the spread
of the four boundary grid lines (pole test) with the same operations as the
numpy expressions it replaces (``norm`` of a 3-vector as ``sqrt((x0^2 + x1^2) + x2^2)``,
``np.maximum`` propagating NaN), so the numbers are the same. `memo_points_kernel` evaluates the
points of grids (the seed grids, the measurement's (u, v) grids) with the numbers of
`_nurbs_kernels.surface_derivatives_kernel` (nd = 0), each grid line's basis functions once.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode
from ._nurbs_kernels import _ders_basis, _span

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


#: slots of each parameter direction's table in `memo_points_kernel` (a power of 2, read when the kernel compiles;
#: at most half are filled; the hash keeps its top 11 bits, any power of 2 up to 2^11 works with the mask)
MEMO_SLOTS = 2048


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _memo_basis(keys, used, spans, basis, count, p, knots, n_ctrl, t, bits, ndu, a, left, right, ders):
    """Row of the table (keys, used, spans, basis) holding t's span and degree-p basis (`_span`, then
    `_ders_basis` with nd = 0, the functions `surface_derivatives_kernel` calls), computed on the first
    look-up of t's exact bits; -1 (span and basis left in ``ders[0]`` and returned as its span encoded as
    -2 - span) when the table is half full and t is new. count[0]: rows filled; bits: t's bits."""
    cap = keys.shape[0]
    h = (bits * np.uint64(11400714819323198485)) >> np.uint64(53)     # 64 - log2(MEMO_SLOTS) bits
    slot = np.int64(h) & (cap - 1)
    while used[slot]:
        if keys[slot] == bits:
            return slot
        slot = (slot + 1) & (cap - 1)
    s = _span(p, knots, n_ctrl, t)
    _ders_basis(s, t, p, knots, np.int64(0), ndu, a, left, right, ders)
    if 2 * (count[0] + 1) > cap:
        return -2 - s
    used[slot] = True
    keys[slot] = bits
    spans[slot] = s
    for r in range(p + 1):
        basis[slot, r] = ders[0, r]
    count[0] += 1
    return slot


@njit(cache=True, nogil=True)
def memo_points_kernel(pu, pv, ku, kv, pw, rational, u, v, out):
    """out[i] = S(u[i], v[i]) (u, v C-contiguous, clamped to the domain by the caller), the numbers of
    `_nurbs_kernels.surface_derivatives_kernel` with nd = 0 (`_surface_point01`: the same span and basis
    functions, the same sums in the same order, the same division by the weight), with each distinct u
    (v) value's span and basis computed once: grid points (seed grids, the measurement's (u, v) grids)
    share a few dozen or hundred parameter values per direction, so the basis functions (the divisions
    of Cox-de Boor) are evaluated per grid line instead of per point."""
    nu_ctrl, nv_ctrl, dimw = pw.shape
    dim = dimw - 1 if rational else dimw
    cap = MEMO_SLOTS
    keys_u = np.empty(cap, dtype=np.uint64)
    keys_v = np.empty(cap, dtype=np.uint64)
    used_u = np.zeros(cap, dtype=np.bool_)
    used_v = np.zeros(cap, dtype=np.bool_)
    spans_u = np.empty(cap, dtype=np.int64)
    spans_v = np.empty(cap, dtype=np.int64)
    basis_u = np.empty((cap, pu + 1))
    basis_v = np.empty((cap, pv + 1))
    count_u = np.zeros(1, dtype=np.int64)
    count_v = np.zeros(1, dtype=np.int64)
    ndu_u = np.empty((pu + 1, pu + 1))
    ndu_v = np.empty((pv + 1, pv + 1))
    a_u = np.empty((2, pu + 1))
    a_v = np.empty((2, pv + 1))
    l_u = np.empty(pu + 1)
    r_u = np.empty(pu + 1)
    l_v = np.empty(pv + 1)
    r_v = np.empty(pv + 1)
    du = np.empty((1, pu + 1))
    dv = np.empty((1, pv + 1))
    bu = np.empty(pu + 1)
    bv = np.empty(pv + 1)
    tmp = np.empty((pu + 1, dimw))
    skl = np.empty(dimw)
    ubits = u.view(np.uint64)
    vbits = v.view(np.uint64)
    for i in range(u.shape[0]):
        ru = _memo_basis(keys_u, used_u, spans_u, basis_u, count_u, pu, ku, nu_ctrl, u[i], ubits[i], ndu_u, a_u,
                         l_u, r_u, du)
        if ru >= 0:
            su = spans_u[ru]
            for r in range(pu + 1):
                bu[r] = basis_u[ru, r]
        else:
            su = -2 - ru
            for r in range(pu + 1):
                bu[r] = du[0, r]
        rv = _memo_basis(keys_v, used_v, spans_v, basis_v, count_v, pv, kv, nv_ctrl, v[i], vbits[i], ndu_v, a_v,
                         l_v, r_v, dv)
        if rv >= 0:
            sv = spans_v[rv]
            for s in range(pv + 1):
                bv[s] = basis_v[rv, s]
        else:
            sv = -2 - rv
            for s in range(pv + 1):
                bv[s] = dv[0, s]
        for r in range(pu + 1):
            for d in range(dimw):
                tmp[r, d] = 0.0
            for s in range(pv + 1):
                b = bv[s]
                if b != 0.0:
                    row = su - pu + r
                    col = sv - pv + s
                    for d in range(dimw):
                        tmp[r, d] += b * pw[row, col, d]
        for d in range(dimw):
            acc = 0.0
            for r in range(pu + 1):
                acc += bu[r] * tmp[r, d]
            skl[d] = acc
        if not rational:
            for d in range(dim):
                out[i, d] = skl[d]
        else:
            w0 = skl[dim]
            for d in range(dim):
                out[i, d] = skl[d] / w0
