"""Compiled edge discretization (numba, nogil): `trims.discretize_chunk` for every chunk of a shell in one
call (`discretize_chunks_kernel`).

Each chunk goes through the steps of the numpy path with the same operations in the same order, so the
output is the numpy path's bit for bit (`trims._discretize_chunk_numpy` is the reference the tests compare
against): the start values (p-curve knots and 9 uniform values), the 33-point probe of the 3D extent,
the placement (`_line_kernels.equidistributed_kernel`), the iso-values (`_chunk_iso`, with the p-curve
points of `_uv_batch`; the numpy path calls it too, through `chunk_iso_kernel`),
the merge of nearly coincident points, the polygon reduction (`_reduce`), the even spacing between the
grid-line crossings of a shared edge (`_even_spacing`) and the shared 3D points (mean over the uses).

Inputs (see `trims._ChunkBatch`): the uses of all chunks in one chunk family (`ci`, `cf` rows, flat
read-only arrays `ck`, `cpw`, `cku`, `ckv`, `cpw4`, a surface stored once however many uses it has),
per use its grid (`gi` = (offset of us, len, offset of vs, len) into `gf`) and parameter tolerance,
per chunk the range of its uses (`c_off`) and whether it is degenerate (`forced`: 1 yes, 0 no, -1 decide
from the probe). numba's searchsorted,
argsort, boolean indexing and slice assignment cost seconds of compile time each: plain loops and the
helpers of `_line_kernels` instead. Every call of a compiled helper that takes arrays, and every array
view, costs numba an atomic reference count pair: the points evaluated per chunk (probe, p-curve points,
shared points) go through `_curve_uv` / `_surface_xyz`, the point code of `_chunk_criteria` (the numbers
of `_curve_point` / `_surface_point01`), in one call per use and one work array (`_scratch`) per kernel
call.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..geom._nurbs_kernels import _curve_point
from ._line_kernels import (_chunk_criteria, _grid, _nonzero, _sgn, _snap1, _ss_left, _ss_right, _stable_order, _take,
                            _unique, _use_arrays, equidistributed_kernel)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _on_grid(v, G, gl, j, axis):
    """np.isin(v, grid) for use j's sorted grid on axis."""
    n = gl[j, axis]
    lo, hi = 0, n
    while lo < hi:
        mid = (lo + hi) >> 1
        if G[j, axis, mid] < v:
            lo = mid + 1
        else:
            hi = mid
    return lo < n and G[j, axis, lo] == v


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _cell_ok(G, gl, uv_a0, uv_a1, uv_b0, uv_b1, j):
    """`trims._in_one_cell` for one pair of points of use j."""
    for axis in range(2):
        x = uv_a0 if axis == 0 else uv_a1
        y = uv_b0 if axis == 0 else uv_b1
        lo, hi = min(x, y), max(x, y)
        g = G[j, axis, :gl[j, axis]]
        if not _ss_right(g, lo) >= _ss_left(g, hi):
            return False
    return True


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _crossing_points(G, gl, uvs, k):
    """`trims._crossing_points`: points on a grid line of some use that the polygon does not run along
    on both sides."""
    must = np.zeros(k, dtype=np.bool_)
    for j in range(uvs.shape[0]):
        for axis in range(2):
            for i in range(k):
                c = uvs[j, i, axis]
                along = 0 < i < k - 1 and uvs[j, i - 1, axis] == c and uvs[j, i + 1, axis] == c
                if not along and _on_grid(c, G, gl, j, axis):
                    must[i] = True
    return must


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _select(s, uvs, flags, keep):
    """(s[keep], uvs[:, keep], flags[keep])."""
    idx = _nonzero(keep)
    n = idx.shape[0]
    L = uvs.shape[0]
    s2 = np.empty(n)
    uv2 = np.empty((L, n, 2))
    f2 = np.empty(n, dtype=np.bool_)
    for q in range(n):
        i = idx[q]
        s2[q] = s[i]
        f2[q] = flags[i]
        for j in range(L):
            uv2[j, q, 0] = uvs[j, i, 0]
            uv2[j, q, 1] = uvs[j, i, 1]
    return s2, uv2, f2


@njit(cache=True, nogil=True, inline="always")
def _crit(ci, cf, ck, cpw, cku, ckv, cpw4, a, b, m, max_len, max_dev, stop):
    """`interval_criteria` of the chunk family over [a_i, b_i] (one call site of `_chunk_criteria`, which
    indexes the flat arrays and writes its span searches and bases out: no reference counting per point)."""
    length = np.empty(a.shape[0])
    dev = np.empty(a.shape[0])
    e0 = np.empty(0)
    ok = _chunk_criteria(ci, cf, ck, cpw, cku, ckv, cpw4, a, b, m, length, dev, max_len, max_dev, stop, e0, e0)
    return ok, length, dev


@njit(cache=True, nogil=True, inline="always")
def _reduce(ci, cf, ck, cpw, cku, ckv, cpw4, G, gl, s, uvs, must, flags, tolerance, max_edge, m9):
    """`trims._reduce`: points that are no `must` point removed while the chord of their neighbours meets
    both criteria and stays in one closed grid cell of every use (rounds of parity 0, 1, 0, 1)."""
    k_all = s.shape[0]
    L = uvs.shape[0]
    keep = np.ones(k_all, dtype=np.bool_)
    no = m9 < 0
    # a point kept in an earlier round between the same two neighbours is kept again (the same chord:
    # the same criteria and cells), so it is not evaluated again: tried[i] = its neighbours then
    tried = np.full((k_all, 2), -1, dtype=np.int64)
    for rnd in range(4):
        parity = rnd % 2
        idx = _nonzero(keep)
        ni = idx.shape[0]
        if ni < 3:
            break
        cand = np.empty(ni, dtype=np.int64)
        nc = 0
        for c in range(1, ni - 1):
            if c % 2 == parity and not must[idx[c]]:
                if tried[idx[c], 0] == idx[c - 1] and tried[idx[c], 1] == idx[c + 1]:
                    continue
                tried[idx[c], 0], tried[idx[c], 1] = idx[c - 1], idx[c + 1]
                cand[nc] = c
                nc += 1
        if nc == 0:
            continue
        a = np.empty(nc)
        b = np.empty(nc)
        for q in range(nc):
            a[q] = s[idx[cand[q] - 1]]
            b[q] = s[idx[cand[q] + 1]]
        # (with the limits: a chord over one after its first use skips the others, as the test below reads)
        _, ln, dv = _crit(ci, cf, ck, cpw, cku, ckv, cpw4, a, b, m9, max_edge, tolerance, no)
        for q in range(nc):
            if not (ln[q] <= max_edge and dv[q] <= tolerance):
                continue
            i0, i1 = idx[cand[q] - 1], idx[cand[q] + 1]
            same = True
            for j in range(L):
                if not _cell_ok(G, gl, uvs[j, i0, 0], uvs[j, i0, 1], uvs[j, i1, 0], uvs[j, i1, 1], j):
                    same = False
                    break
            if same:
                keep[idx[cand[q]]] = False
    return _select(s, uvs, flags, keep)


@njit(cache=True, nogil=True, inline="always")
def _even_spacing(ci, cf, ck, cpw, cku, ckv, cpw4, G, gl, ptol, s, uvs, iso, tolerance, max_edge, m9, w):
    """`trims._even_spacing`: between consecutive grid-line crossings, the fewest equally spaced points
    (in s) that meet both criteria with every chord in one grid cell of every use, where they are no
    more than the reduction kept there."""
    L, k_all = uvs.shape[0], uvs.shape[1]
    must = _crossing_points(G, gl, uvs, k_all)
    must[0] = True
    must[k_all - 1] = True
    mi = _nonzero(must)
    nm = mi.shape[0] - 1
    cnt = 0
    for q in range(nm):
        if mi[q + 1] - mi[q] - 1 > 0:
            cnt += 1
    if cnt == 0:
        return s, uvs, iso
    cand = np.empty(cnt, dtype=np.int64)
    c = 0
    for q in range(nm):
        if mi[q + 1] - mi[q] - 1 > 0:
            cand[c] = q
            c += 1
    a = np.empty(cnt)
    b = np.empty(cnt)
    m = np.empty(cnt, dtype=np.int64)
    m_max = 0
    for q in range(cnt):
        a[q], b[q] = s[mi[cand[q]]], s[mi[cand[q] + 1]]
        m[q] = mi[cand[q] + 1] - mi[cand[q]] - 1
        m_max = max(m_max, m[q])
    best = np.zeros(cnt, dtype=np.int64)
    uvq = np.empty((L, 2))
    uvp = np.empty((L, 2))
    one = np.empty((1, 2))
    pt = np.empty(1)
    yes = m9 > 0
    for n in range(1, m_max + 2):
        any_sel = False
        for q in range(cnt):
            if best[q] != 0 or not n <= m[q] + 1:
                continue
            any_sel = True
            d = b[q] - a[q]
            gs = np.empty(n + 1)
            for jj in range(n + 1):
                gs[jj] = a[q] + d * (jj / n)
            la = np.empty(n)
            lb = np.empty(n)
            for jj in range(n):
                la[jj], lb[jj] = gs[jj], gs[jj + 1]
            ok, _, _ = _crit(ci, cf, ck, cpw, cku, ckv, cpw4, la, lb, m9, max_edge, tolerance, yes)
            if not ok:
                continue
            # (u, v) of the sequence: end, interior points (snapped), end; every chord in one cell
            cell = True
            for jj in range(n + 1):
                for j in range(L):
                    if jj == 0:
                        uvq[j, 0], uvq[j, 1] = uvs[j, mi[cand[q]], 0], uvs[j, mi[cand[q]], 1]
                    elif jj == n:
                        uvq[j, 0], uvq[j, 1] = uvs[j, mi[cand[q] + 1], 0], uvs[j, mi[cand[q] + 1], 1]
                    else:
                        pt[0] = gs[jj]
                        _uv_batch(ci, cf, ck, cpw, j, pt, one, w)
                        uvq[j, 0] = _snap1(one[0, 0], G[j, 0, :gl[j, 0]], ptol[j])[0]
                        uvq[j, 1] = _snap1(one[0, 1], G[j, 1, :gl[j, 1]], ptol[j])[0]
                    if jj > 0 and not _cell_ok(G, gl, uvp[j, 0], uvp[j, 1], uvq[j, 0], uvq[j, 1], j):
                        cell = False
                if not cell:
                    break
                for j in range(L):
                    uvp[j, 0], uvp[j, 1] = uvq[j, 0], uvq[j, 1]
            if cell:
                best[q] = n
        if not any_sel:
            break
    n_done = 0
    n_new = 0
    drop = np.zeros(k_all, dtype=np.bool_)
    for q in range(cnt):
        if best[q] > 0:
            n_done += 1
            for i in range(mi[cand[q]] + 1, mi[cand[q] + 1]):
                drop[i] = True
            n_new += best[q] - 1
    if n_done == 0:
        return s, uvs, iso
    new_s = np.empty(n_new)
    c = 0
    for q in range(cnt):
        nb = best[q]
        if nb > 1:
            for jj in range(1, nb):
                new_s[c] = a[q] + ((b[q] - a[q]) * jj) / nb
                c += 1
    n_kept = k_all
    for i in range(k_all):
        n_kept -= drop[i]
    n_out = n_kept + n_new
    s_cat = np.empty(n_out)
    iso_cat = np.zeros(n_out, dtype=np.bool_)
    c = 0
    for i in range(k_all):
        if not drop[i]:
            s_cat[c] = s[i]
            iso_cat[c] = iso[i]
            c += 1
    for i in range(n_new):
        s_cat[n_kept + i] = new_s[i]
    order = _stable_order(s_cat)
    uv_cat = np.empty((L, n_out, 2))
    _use_uv_all = np.empty((max(n_new, 1), 2))
    for j in range(L):
        c = 0
        for i in range(k_all):
            if not drop[i]:
                uv_cat[j, c, 0], uv_cat[j, c, 1] = uvs[j, i, 0], uvs[j, i, 1]
                c += 1
        if n_new:
            _uv_batch(ci, cf, ck, cpw, j, new_s, _use_uv_all, w)
        for axis in range(2):
            g = G[j, axis, :gl[j, axis]]
            for i in range(n_new):
                v, hit = _snap1(_use_uv_all[i, axis], g, ptol[j])
                uv_cat[j, n_kept + i, axis] = v
                if hit:
                    iso_cat[n_kept + i] = True
    s_out = np.empty(n_out)
    iso_out = np.empty(n_out, dtype=np.bool_)
    uv_out = np.empty((L, n_out, 2))
    for i in range(n_out):
        o = order[i]
        s_out[i] = s_cat[o]
        iso_out[i] = iso_cat[o]
        for j in range(L):
            uv_out[j, i, 0], uv_out[j, i, 1] = uv_cat[j, o, 0], uv_cat[j, o, 1]
    return s_out, uv_out, iso_out


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _reduce_chunk(ci, cf, ck, cpw, cku, ckv, cpw4, G, gl, ptol, s, uvs, iso, tolerance, max_edge, m9, w):
    """The polygon reduction of `discretize_chunk`: `_reduce` keeping the grid-line crossings (on a shared
    edge only those the polygon does not run along, on a single use its iso points), then on a shared
    edge `_even_spacing` (one compiled function: the criteria linked into it once)."""
    k_all = s.shape[0]
    L = uvs.shape[0]
    if L >= 2:
        must = _crossing_points(G, gl, uvs, k_all)
    else:
        must = iso.copy()
    must[0] = True
    must[k_all - 1] = True
    s, uvs, iso = _reduce(ci, cf, ck, cpw, cku, ckv, cpw4, G, gl, s, uvs, must, iso, tolerance, max_edge, m9)
    if L >= 2:
        s, uvs, iso = _even_spacing(ci, cf, ck, cpw, cku, ckv, cpw4, G, gl, ptol, s, uvs, iso, tolerance, max_edge,
                                    m9, w)
    return s, uvs, iso


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _merge_close(G, gl, ptol, s, uvs, iso):
    """`discretize_chunk`'s merge of points that (nearly) coincide in some use (the inner point of the
    pair dropped, preferably no iso point; the kept one takes over its grid coordinates)."""
    L, k_all = uvs.shape[0], uvs.shape[1]
    gap = np.empty(k_all - 1)
    for i in range(k_all - 1):
        gap[i] = np.inf
    for j in range(L):
        den = 100.0 * ptol[j]
        for i in range(k_all - 1):
            d0 = uvs[j, i + 1, 0] - uvs[j, i, 0]
            d1 = uvs[j, i + 1, 1] - uvs[j, i, 1]
            g = np.sqrt(d0 * d0 + d1 * d1) / den
            if g < gap[i] or np.isnan(g):
                gap[i] = g
    drop = np.zeros(k_all, dtype=np.bool_)
    any_drop = False
    for k in range(k_all - 1):
        if not gap[k] <= 1.0:
            continue
        c = -1
        for cc in (k, k + 1):
            if 0 < cc < k_all - 1 and not drop[cc]:
                # min over (iso[c], c)
                if c < 0 or (iso[cc] < iso[c]):
                    c = cc
        if c < 0:
            continue
        other = k + 1 if c == k else k
        drop[c] = True
        any_drop = True
        for j in range(L):
            for axis in range(2):
                if _on_grid(uvs[j, c, axis], G, gl, j, axis) and not _on_grid(uvs[j, other, axis], G, gl, j, axis):
                    uvs[j, other, axis] = uvs[j, c, axis]
        iso[other] = iso[other] or iso[c]
    if not any_drop:
        return s, uvs, iso
    keep = np.empty(k_all, dtype=np.bool_)
    for i in range(k_all):
        keep[i] = not drop[i]
    return _select(s, uvs, iso, keep)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _scratch(ci):
    """One work array for `_curve_uv` and `_surface_xyz` of any use in ci (their layout, per use: left,
    right (max degree + 1 each), the curve's basis, the surface's two bases, tmp (pu + 1, dimw); the
    point in the last 3)."""
    mcp, mpu, mpv, mdw = 0, 0, 0, 0
    for j in range(ci.shape[0]):
        mcp = max(mcp, ci[j, 0])
        mpu = max(mpu, ci[j, 2])
        mpv = max(mpv, ci[j, 3])
        mdw = max(mdw, ci[j, 17])
    nl = max(mcp, mpu, mpv) + 1
    return np.empty(2 * nl + (mcp + 1) + (mpu + 1) + (mpv + 1) + (mpu + 1) * mdw + 3)


@njit(cache=True, nogil=True, inline="always")
def _curve_uv(ci, cf, ck, cpw, j, s, w):
    """(u, v) of use j at the chunk parameter s: `ChunkUse.uv` of one value (`_curve_point` written out as
    in `_chunk_criteria`: the same operations in the same order), w a `_scratch`. Only inside the
    loops of `_probe_extent` / `_even_spacing` (inline: the arrays are the caller's)."""
    cp, crat = ci[j, 0], ci[j, 1] != 0
    okc, ocw, ncw, cdimw = ci[j, 5], ci[j, 7], ci[j, 8], ci[j, 9]
    nl = max(cp, ci[j, 2], ci[j, 3]) + 1
    ol, orr, onc = 0, nl, 2 * nl
    lo, hi = cf[j, 0], cf[j, 1]
    t0, t1 = ck[okc + cp], ck[okc + ci[j, 6] - cp - 1]
    cdim = cdimw - 1 if crat else cdimw
    tt = lo + s * (hi - lo)
    tt = min(max(tt, t0), t1)
    if tt >= ck[okc + ncw]:
        sc = ncw - 1
        while sc > cp and ck[okc + sc] >= ck[okc + ncw]:
            sc -= 1
    else:
        sc = cp
        hi_ = ncw
        while hi_ - sc > 1:
            mid_ = (sc + hi_) // 2
            if tt < ck[okc + mid_]:
                hi_ = mid_
            else:
                sc = mid_
    w[onc] = 1.0
    for j_ in range(1, cp + 1):
        w[ol + j_] = tt - ck[okc + sc + 1 - j_]
        w[orr + j_] = ck[okc + sc + j_] - tt
        saved = 0.0
        for r_ in range(j_):
            temp = w[onc + r_] / (w[orr + r_ + 1] + w[ol + j_ - r_])
            w[onc + r_] = saved + w[orr + r_ + 1] * temp
            saved = w[ol + j_ - r_] * temp
        w[onc + j_] = saved
    wc = 1.0
    if crat:
        wc = 0.0
        for r in range(cp + 1):
            wc += w[onc + r] * cpw[ocw + (sc - cp + r) * cdimw + cdim]
    uv0 = 0.0
    uv1 = 0.0
    for dd in range(cdim):
        acc = 0.0
        for r in range(cp + 1):
            acc += w[onc + r] * cpw[ocw + (sc - cp + r) * cdimw + dd]
        if dd == 0:
            uv0 = acc / wc if crat else acc
        else:
            uv1 = acc / wc if crat else acc
    return min(max(uv0, cf[j, 2]), cf[j, 3]), min(max(uv1, cf[j, 4]), cf[j, 5])


@njit(cache=True, nogil=True, inline="always")
def _surface_xyz(ci, cku, ckv, cpw4, j, uu, vv, w):
    """S(clip(u, v)) of use j's surface into w[-3:]: `_surface_point01` (nd = 0) written out as in
    `_chunk_criteria` (the same operations in the same order), w a `_scratch`. Only inside the loops of
    `_probe_extent` / `_shared_points` (inline: the arrays are the caller's)."""
    pu, pv, srat = ci[j, 2], ci[j, 3], ci[j, 4] != 0
    oku, okv, opw = ci[j, 10], ci[j, 12], ci[j, 14]
    nu_c, nv_c, dimw = ci[j, 15], ci[j, 16], ci[j, 17]
    dim = dimw - 1 if srat else dimw
    nl = max(ci[j, 0], pu, pv) + 1
    ol, orr = 0, nl
    onu = 2 * nl + ci[j, 0] + 1
    onv = onu + pu + 1
    otm = onv + pv + 1
    ores = w.shape[0] - 3
    su0, su1 = cku[oku + pu], cku[oku + ci[j, 11] - pu - 1]
    sv0, sv1 = ckv[okv + pv], ckv[okv + ci[j, 13] - pv - 1]
    uu = min(max(uu, su0), su1)
    vv = min(max(vv, sv0), sv1)
    if uu >= cku[oku + nu_c]:
        su = nu_c - 1
        while su > pu and cku[oku + su] >= cku[oku + nu_c]:
            su -= 1
    else:
        su = pu
        hi_ = nu_c
        while hi_ - su > 1:
            mid_ = (su + hi_) // 2
            if uu < cku[oku + mid_]:
                hi_ = mid_
            else:
                su = mid_
    if vv >= ckv[okv + nv_c]:
        sv = nv_c - 1
        while sv > pv and ckv[okv + sv] >= ckv[okv + nv_c]:
            sv -= 1
    else:
        sv = pv
        hi_ = nv_c
        while hi_ - sv > 1:
            mid_ = (sv + hi_) // 2
            if vv < ckv[okv + mid_]:
                hi_ = mid_
            else:
                sv = mid_
    w[onu] = 1.0
    for j_ in range(1, pu + 1):
        w[ol + j_] = uu - cku[oku + su + 1 - j_]
        w[orr + j_] = cku[oku + su + j_] - uu
        saved = 0.0
        for r_ in range(j_):
            temp = w[onu + r_] / (w[orr + r_ + 1] + w[ol + j_ - r_])
            w[onu + r_] = saved + w[orr + r_ + 1] * temp
            saved = w[ol + j_ - r_] * temp
        w[onu + j_] = saved
    w[onv] = 1.0
    for j_ in range(1, pv + 1):
        w[ol + j_] = vv - ckv[okv + sv + 1 - j_]
        w[orr + j_] = ckv[okv + sv + j_] - vv
        saved = 0.0
        for r_ in range(j_):
            temp = w[onv + r_] / (w[orr + r_ + 1] + w[ol + j_ - r_])
            w[onv + r_] = saved + w[orr + r_ + 1] * temp
            saved = w[ol + j_ - r_] * temp
        w[onv + j_] = saved
    for r in range(pu + 1):
        for dd in range(dimw):
            w[otm + r * dimw + dd] = 0.0
        for s_ in range(pv + 1):
            bb = w[onv + s_]
            if bb != 0.0:
                row = su - pu + r
                col = sv - pv + s_
                for dd in range(dimw):
                    w[otm + r * dimw + dd] += bb * cpw4[opw + (row * nv_c + col) * dimw + dd]
    w0 = 1.0
    if srat:
        w0 = 0.0
        for r in range(pu + 1):
            w0 += w[onu + r] * w[otm + r * dimw + dim]
    for dd in range(dim):
        acc = 0.0
        for r in range(pu + 1):
            acc += w[onu + r] * w[otm + r * dimw + dd]
        w[ores + dd] = acc / w0 if srat else acc


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _probe_extent(ci, cf, ck, cpw, cku, ckv, cpw4, j, s33, thr, extent, w):
    """The 33-point probe of use j (`discretize_chunks_kernel`): the 3D extent from its first point,
    updated from `extent`, stopping at the first point that puts it above thr (or NaN). One call per
    use, the points written out (`_curve_uv`, `_surface_xyz`)."""
    ores = w.shape[0] - 3
    x0, y0, z0 = 0.0, 0.0, 0.0
    for i in range(s33.shape[0]):
        u, v = _curve_uv(ci, cf, ck, cpw, j, s33[i], w)
        _surface_xyz(ci, cku, ckv, cpw4, j, u, v, w)
        if i == 0:
            x0, y0, z0 = w[ores], w[ores + 1], w[ores + 2]
        d0, d1, d2 = w[ores] - x0, w[ores + 1] - y0, w[ores + 2] - z0
        e = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
        if e > extent or np.isnan(e):
            extent = e
        if not extent <= thr:
            break
    return extent


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _shared_points(ci, cku, ckv, cpw4, j, uvs, o_pts, o_uv, w):
    """Use j's part of the shared points of a chunk of k = uvs.shape[1] points: (u, v) into o_uv[j k + i],
    S(clip(u, v)) set (j = 0) or added into o_pts[i, 1:4]. One call per use, the points written out
    (`_surface_xyz`)."""
    ores = w.shape[0] - 3
    k = uvs.shape[1]
    for i in range(k):
        uu, vv = uvs[j, i, 0], uvs[j, i, 1]
        o_uv[j * k + i, 0] = uu
        o_uv[j * k + i, 1] = vv
        _surface_xyz(ci, cku, ckv, cpw4, j, uu, vv, w)
        for q in range(3):
            if j == 0:
                o_pts[i, 1 + q] = w[ores + q]
            else:
                o_pts[i, 1 + q] += w[ores + q]


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _uv_batch(ci, cf, ck, cpw, j, s, out, w):
    """uv of use j at the chunk parameters s into out (n, 2) (as `ChunkUse.uv`: p(t(s)) clipped into the
    grid box) point by point with `_curve_uv` (no allocation, call or array view per point), w a
    `_scratch`."""
    for i in range(s.shape[0]):
        u, v = _curve_uv(ci, cf, ck, cpw, j, s[i], w)
        out[i, 0] = u
        out[i, 1] = v


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _refine_crossing_w(ci, cf, ck, cpw, j, axis, ptol, s, value, lo, hi, w):
    """`trims._refine_crossing` (Illinois regula falsi, all crossings in lockstep until all converge),
    the points by `_uv_batch`."""
    n = s.shape[0]
    buf = np.empty((n, 2))
    _uv_batch(ci, cf, ck, cpw, j, lo, buf, w)
    flo = np.empty(n)
    fhi = np.empty(n)
    for i in range(n):
        flo[i] = buf[i, axis] - value[i]
    _uv_batch(ci, cf, ck, cpw, j, hi, buf, w)
    for i in range(n):
        fhi[i] = buf[i, axis] - value[i]
    side = np.zeros(n, dtype=np.int8)
    lo = lo.copy()
    hi = hi.copy()
    s = s.copy()
    fs = np.empty(n)
    for _ in range(40):
        for i in range(n):
            den = fhi[i] - flo[i]
            if abs(den) > 0:
                si = lo[i] - flo[i] * (hi[i] - lo[i]) / (den if den != 0 else 1.0)
            else:
                si = 0.5 * (lo[i] + hi[i])
            a, b = min(lo[i], hi[i]), max(lo[i], hi[i])
            s[i] = min(max(si, a), b)
        _uv_batch(ci, cf, ck, cpw, j, s, buf, w)
        conv = True
        for i in range(n):
            fs[i] = buf[i, axis] - value[i]
            if not abs(fs[i]) <= 1e-3 * ptol:
                conv = False
        if conv:
            break
        for i in range(n):
            left = _sgn(fs[i]) == _sgn(flo[i])
            if left:
                lo[i], flo[i] = s[i], fs[i]
            else:
                hi[i], fhi[i] = s[i], fs[i]
            if left and side[i] == 1:
                fhi[i] = 0.5 * fhi[i]
            if (not left) and side[i] == -1:
                flo[i] = 0.5 * flo[i]
            side[i] = 1 if left else -1
    return s


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _chunk_iso(ci, cf, ck, cpw, G, gl, ptol, s, w):
    """`trims.discretize_chunk` from the sampled s to the iso flags: every use's grid-line crossings
    inserted (four rounds), near-duplicates dropped, each use's (u, v) snapped onto its grid lines and
    the crossings set exactly onto theirs. G (L, 2, g) the uses' grids (us, vs) padded, gl their
    lengths, ptol (L,) the uses' parameter tolerances, w a `_scratch` of ci (the p-curve points by
    `_uv_batch`). Returns (s_all, uvs (L, k, 2), iso (k,))."""
    n_uses = G.shape[0]
    cap = 16
    f_sc = np.empty(cap)
    f_val = np.empty(cap)
    f_ui = np.empty(cap, dtype=np.int64)
    f_ax = np.empty(cap, dtype=np.int64)
    nf = 0
    s_all = s
    for _ in range(4):
        ex = np.empty(0)
        n_ex = 0
        k_all = s_all.shape[0]
        for ui in range(n_uses):
            uv = np.empty((k_all, 2))
            _uv_batch(ci, cf, ck, cpw, ui, s_all, uv, w)
            for q in range(nf):
                if f_ui[q] == ui:
                    uv[_ss_left(s_all, f_sc[q]), f_ax[q]] = f_val[q]
            for axis in range(2):
                grid = _grid(G, gl, ui, axis)
                coord = np.empty(k_all)
                for i in range(k_all):
                    coord[i] = _snap1(uv[i, axis], grid, ptol[ui])[0]
                # iso_crossings
                cnt_total = 0
                for i in range(k_all - 1):
                    a, b = coord[i], coord[i + 1]
                    first = _ss_right(grid, min(a, b))
                    last = _ss_left(grid, max(a, b))
                    if last > first:
                        cnt_total += last - first
                if cnt_total == 0:
                    continue
                sc = np.empty(cnt_total)
                val = np.empty(cnt_total)
                c = 0
                for i in range(k_all - 1):
                    a, b = coord[i], coord[i + 1]
                    first = _ss_right(grid, min(a, b))
                    last = _ss_left(grid, max(a, b))
                    for g in range(first, last):
                        vv = grid[g]
                        f = (vv - a) / (b - a)
                        sc[c] = s_all[i] + f * (s_all[i + 1] - s_all[i])
                        val[c] = vv
                        c += 1
                lo = np.empty(cnt_total)
                hi = np.empty(cnt_total)
                for q in range(cnt_total):
                    k = _ss_right(s_all, sc[q]) - 1
                    k = min(max(k, 0), k_all - 2)
                    lo[q], hi[q] = s_all[k], s_all[k + 1]
                sc = _refine_crossing_w(ci, cf, ck, cpw, ui, axis, ptol[ui], sc, val, lo, hi, w)
                for q in range(cnt_total):
                    k = _ss_left(s_all, sc[q])
                    k = min(max(k, 0), k_all - 1)
                    if abs(s_all[k] - sc[q]) > 1e-13:
                        if n_ex == ex.shape[0]:
                            ex2 = np.empty(2 * n_ex + 8)
                            for e in range(n_ex):
                                ex2[e] = ex[e]
                            ex = ex2
                        ex[n_ex] = sc[q]
                        n_ex += 1
                        if nf == cap:
                            cap *= 2
                            a1, a2 = np.empty(cap), np.empty(cap)
                            a3, a4 = np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64)
                            for e in range(nf):
                                a1[e], a2[e], a3[e], a4[e] = f_sc[e], f_val[e], f_ui[e], f_ax[e]
                            f_sc, f_val, f_ui, f_ax = a1, a2, a3, a4
                        f_sc[nf], f_val[nf], f_ui[nf], f_ax[nf] = sc[q], val[q], ui, axis
                        nf += 1
        if n_ex == 0:
            break
        merged = np.empty(k_all + n_ex)
        for e in range(k_all):
            merged[e] = s_all[e]
        for e in range(n_ex):
            merged[k_all + e] = ex[e]
        s_all = _unique(merged)
    # drop near-duplicate parameters
    k_all = s_all.shape[0]
    keep = np.ones(k_all, dtype=np.bool_)
    for i in range(1, k_all):
        keep[i] = s_all[i] - s_all[i - 1] > 1e-13
    s_all = _take(s_all, _nonzero(keep))
    k_all = s_all.shape[0]
    uvs = np.empty((n_uses, k_all, 2))
    iso = np.zeros(k_all, dtype=np.bool_)
    for ui in range(n_uses):
        _uv_batch(ci, cf, ck, cpw, ui, s_all, uvs[ui], w)
        for axis in range(2):
            grid = _grid(G, gl, ui, axis)
            for i in range(k_all):
                v, hit = _snap1(uvs[ui, i, axis], grid, ptol[ui])
                uvs[ui, i, axis] = v
                if hit:
                    iso[i] = True
    # the crossings lie exactly on their iso-line (whatever the solver's last digit)
    for q in range(nf):
        sc = f_sc[q]
        k = _ss_left(s_all, sc)
        k = min(max(k, 0), k_all - 1)
        if k > 0 and abs(s_all[k - 1] - sc) < abs(s_all[k] - sc):
            k -= 1
        uvs[f_ui[q], k, f_ax[q]] = f_val[q]
        iso[k] = True
    iso[0] = True
    iso[k_all - 1] = True
    return s_all, uvs, iso


@njit(cache=True, nogil=True)
def chunk_iso_kernel(ci, cf, ck, cpw, G, gl, ptol, s):
    """`_chunk_iso` of one chunk from Python (`trims._insert_iso_values`, the numpy path): the iso step
    the chunk kernel runs, with its own work array."""
    return _chunk_iso(ci, cf, ck, cpw, G, gl, ptol, s, _scratch(ci))


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _grow(a, n):
    """a (rows, cols) with room for at least n rows (copied by a loop)."""
    if a.shape[0] >= n:
        return a
    out = np.empty((max(n, 2 * a.shape[0]), a.shape[1]))
    for i in range(a.shape[0]):
        for q in range(a.shape[1]):
            out[i, q] = a[i, q]
    return out


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _straight_scale(ci, cf, ck, cpw, cku, ckv, cpw4, j):
    """M >= 0 when use j's points P(s) = S(clip(p(t(s)))) are affine in s (a straight segment run at
    constant speed) up to rounding, whose size M scales (the surface's largest |control point| over its
    smallest weight, times 1 + |knot end| / knot span per direction); else -1. Exact tests on the arrays:
    a linear p-curve (non-rational, two control points) inside the grid box and the surface's knot range
    (so the clipping changes nothing but rounding), and either an iso-line (the two points share u, or v)
    on a surface of degree 1 with two control rows in the other direction whose weights are equal across
    the two rows (S(u0, v) = A (1 - t) + B t, t affine in v: a plane's iso-line, a cylinder's ruling), or
    any line on a 2 x 2 patch of degree (1, 1) with equal weights and zero twist (an affine map)."""
    if ci[j, 1] != 0:
        return -1.0
    kc, cw, ku, kv, pw = _use_arrays(ci, ck, cpw, cku, ckv, cpw4, j)
    pu, pv, srat = ci[j, 2], ci[j, 3], ci[j, 4] != 0
    nu, nv, dimw = pw.shape
    dim = dimw - 1 if srat else dimw
    if cw.shape[0] != 2 or cw.shape[1] != 2:
        return -1.0
    ku0, ku1 = ku[pu], ku[ku.shape[0] - pu - 1]
    kv0, kv1 = kv[pv], kv[kv.shape[0] - pv - 1]
    if not (ku1 > ku0 and kv1 > kv0):
        return -1.0
    lo_u, hi_u = max(cf[j, 2], ku0), min(cf[j, 3], ku1)
    lo_v, hi_v = max(cf[j, 4], kv0), min(cf[j, 5], kv1)
    for q in range(2):
        if not (lo_u <= cw[q, 0] <= hi_u and lo_v <= cw[q, 1] <= hi_v):
            return -1.0
    big = 0.0
    wmin = np.inf
    for a in range(nu):
        for b in range(nv):
            w = pw[a, b, dimw - 1] if srat else 1.0
            if not w > 0.0:
                return -1.0
            wmin = min(wmin, w)
            for d in range(dimw):
                big = max(big, abs(pw[a, b, d]))
    scale = big / wmin * (1.0 + max(abs(ku0), abs(ku1)) / (ku1 - ku0) + max(abs(kv0), abs(kv1)) / (kv1 - kv0))
    if not scale < np.inf:
        return -1.0
    if cw[0, 0] == cw[1, 0]:            # u constant: degree 1 in v, two rows, equal weights across them
        if pv == 1 and nv == 2:
            same = True
            if srat:
                for a in range(nu):
                    same = same and pw[a, 0, dimw - 1] == pw[a, 1, dimw - 1]
            if same:
                return scale
    if cw[0, 1] == cw[1, 1]:            # v constant
        if pu == 1 and nu == 2:
            same = True
            if srat:
                for b in range(nv):
                    same = same and pw[0, b, dimw - 1] == pw[1, b, dimw - 1]
            if same:
                return scale
    # any line on an affine patch
    if pu != 1 or pv != 1 or nu != 2 or nv != 2:
        return -1.0
    if srat:
        w0 = pw[0, 0, dimw - 1]
        if pw[1, 0, dimw - 1] != w0 or pw[0, 1, dimw - 1] != w0 or pw[1, 1, dimw - 1] != w0:
            return -1.0
    for d in range(dim):
        if pw[0, 0, d] - pw[1, 0, d] - pw[0, 1, d] + pw[1, 1, d] != 0.0:
            return -1.0
    return scale


@njit(cache=True, nogil=True)
def discretize_chunks_kernel(kind, iso_i, iso_f, lines_c, lines_raw, dil, rgeo, d_ku, d_kv, d_pw,
                             ci, cf, ck, cpw, cku, ckv, cpw4, gi, gf, ptol_all, c_off, forced,
                             s9, s33, s_in, s_off, tolerance, shared_chord, max_edge, max_values, flags):
    """`trims.discretize_chunk` (strategy "equidistributed") for chunks c = 0 .. C-1, chunk c made of the
    uses c_off[c] .. c_off[c + 1] - 1 (rows of ci, cf, gi, ptol_all); forced[c] = 1 / 0: degenerate or
    not, -1: decided from the 3D extent of 33 probe points.
    The first ten arguments are the unused kind-0 members of the family tuple (`kind` = 1); flags =
    (reduce, 5, 9, mode, straight): run-time constants. Mode 0: the placement's start values (pts[:, 0]),
    status 2: a straight chunk whose placement is [0, 1] (see `_straight_scale` and
    `trims.discretize_chunks`; only with `straight`). Mode 1: from the placed values s_in (s_off per
    chunk). Mode 2: both, the placement (`_line_kernels.equidistributed_kernel`) in between; what
    `trims.discretize_chunks` runs. Returns (info (C, 3): points k_c, degenerate, status (0 done,
    1 more than max_values intervals needed: the caller runs the numpy path, which refuses); pts
    (sum k_c, 5): s, xyz (the mean of the uses' S(uv), before the degenerate averaging), iso (0 / 1);
    uv (sum L_c k_c, 2), use-major per chunk)."""
    do_reduce = flags[0] != 0
    m9 = flags[2]
    mode = flags[3]
    n_chunks = c_off.shape[0] - 1
    info = np.zeros((n_chunks, 3), dtype=np.int64)       # points, degenerate, status
    o_pts = np.empty((64, 5))                            # s, xyz, iso
    o_uv = np.empty((128, 2))
    s0 = np.empty(1)
    s1_ = np.empty(1)
    ns = 0
    nuv = 0
    w = _scratch(ci)
    for c in range(n_chunks):
        u0, u1 = c_off[c], c_off[c + 1]
        L = u1 - u0
        cic = np.empty((L, ci.shape[1]), dtype=np.int64)
        cfc = np.empty((L, cf.shape[1]))
        ptol = np.empty(L)
        g = 0
        for j in range(L):
            for q in range(ci.shape[1]):
                cic[j, q] = ci[u0 + j, q]
            for q in range(cf.shape[1]):
                cfc[j, q] = cf[u0 + j, q]
            ptol[j] = ptol_all[u0 + j]
            g = max(g, gi[u0 + j, 1], gi[u0 + j, 3])
        G = np.zeros((L, 2, g))
        gl = np.empty((L, 2), dtype=np.int64)
        for j in range(L):
            for axis in range(2):
                o, n = gi[u0 + j, 2 * axis], gi[u0 + j, 2 * axis + 1]
                gl[j, axis] = n
                for q in range(n):
                    G[j, axis, q] = gf[o + q]
        chord_tol = tolerance if L < 2 else shared_chord * tolerance
        if mode != 1:
            # the start values: the first use's p-curve knots inside its range, mapped onto [0, 1], and s9
            cp = cic[0, 0]
            kc = ck[cic[0, 5]:cic[0, 5] + cic[0, 6]]
            lo, hi = cfc[0, 0], cfc[0, 1]
            nk = 0
            for q in range(kc.shape[0]):
                if kc[q] > lo and kc[q] < hi:
                    nk += 1
            kin = np.empty(nk)
            nk = 0
            for q in range(kc.shape[0]):
                if kc[q] > lo and kc[q] < hi:
                    kin[nk] = kc[q]
                    nk += 1
            kin = _unique(kin)
            init = np.empty(s9.shape[0] + kin.shape[0])
            for q in range(s9.shape[0]):
                init[q] = s9[q]
            for q in range(kin.shape[0]):
                init[s9.shape[0] + q] = (kin[q] - lo) / (hi - lo)
            init = _unique(init)
            # the 3D extent of the 33 probe points (per use, from its first point): only whether it is
            # <= 1e-3 x tolerance is read, so a forced chunk skips the probe, and the probe stops at the
            # first point that puts the extent above it (or NaN: the extent is then NaN, no degenerate);
            # point by point (`_curve_uv`, `_surface_xyz`: the numbers of `ChunkUse.uv` and `_surface_point01`)
            thr = 1e-3 * tolerance
            extent = 0.0
            n_use = L if forced[c] < 0 else 0
            for j in range(n_use):
                extent = _probe_extent(cic, cfc, ck, cpw, cku, ckv, cpw4, j, s33, thr, extent, w)
                if not extent <= thr:
                    break
            if forced[c] >= 0:
                degenerate = forced[c] == 1
            else:
                degenerate = extent <= 1e-3 * tolerance
            # adaptive_values' start: x0 = unique(clip(r_[0, init, 1], 0, 1))
            xin = np.empty(init.shape[0] + 2)
            xin[0] = 0.0
            for q in range(init.shape[0]):
                xin[q + 1] = min(max(init[q], 0.0), 1.0)
            xin[init.shape[0] + 1] = 1.0
            xin = _unique(xin)
            k = xin.shape[0]
            info[c, 0] = k
            info[c, 1] = degenerate
            # a straight chunk: the placement gives [0, 1] when [0, 1] passes its check (status 2: the
            # caller skips the placement); see `trims.discretize_chunks`
            if not degenerate and L <= 4 and flags[4] != 0:
                scale = 0.0
                for j in range(L):
                    sj = _straight_scale(cic, cfc, ck, cpw, cku, ckv, cpw4, j)
                    if sj < 0.0:
                        scale = -1.0
                        break
                    scale = max(scale, sj)
                noise = 1e-13 * scale
                if scale >= 0.0 and noise <= 1e-3 * chord_tol:
                    s0[0], s1_[0] = 0.0, 1.0
                    ok, ln, _ = _crit(cic, cfc, ck, cpw, cku, ckv, cpw4, s0, s1_, m9, max_edge, chord_tol, m9 > 0)
                    ell = ln[0] * (1.0 + 1e-9)
                    if ok and ell / max_edge + (k - 1) * (np.sqrt(noise / chord_tol) + noise / max_edge) <= 1.05:
                        info[c, 2] = 2
            if mode == 0:
                o_pts = _grow(o_pts, ns + k)
                for i in range(k):
                    o_pts[ns + i, 0] = xin[i]
                ns += k
                continue
            # mode 2: the placement here (`domain.adaptive_values`' compiled path)
            if degenerate or info[c, 2] == 2:
                s = np.empty(2)
                s[0], s[1] = 0.0, 1.0
                info[c, 2] = 0
            else:
                s, needed = equidistributed_kernel(kind, iso_i, iso_f, lines_c, lines_raw, dil, rgeo, d_ku, d_kv, d_pw,
                                                   cic, cfc, ck, cpw, cku, ckv, cpw4, xin, 0.0, 1.0, chord_tol, max_edge,
                                                   max_values)
                if needed >= 0:         # more than max_values intervals: the caller runs the numpy path
                    info[c, 2] = 1
                    s = np.empty(2)
                    s[0], s[1] = 0.0, 1.0
        else:
            # mode 1: from the placed values s (`equidistributed_kernel`, called by the caller per chunk)
            degenerate = forced[c] == 1
            s = np.empty(s_off[c + 1] - s_off[c])
            for i in range(s.shape[0]):
                s[i] = s_in[s_off[c] + i]
        s_all, uvs, iso = _chunk_iso(cic, cfc, ck, cpw, G, gl, ptol, s, w)
        if s_all.shape[0] > 2:
            s_all, uvs, iso = _merge_close(G, gl, ptol, s_all, uvs, iso)
        if do_reduce and not degenerate and s_all.shape[0] > 2:
            s_all, uvs, iso = _reduce_chunk(cic, cfc, ck, cpw, cku, ckv, cpw4, G, gl, ptol, s_all, uvs, iso, chord_tol,
                                            max_edge, m9, w)
        k = s_all.shape[0]
        info[c, 0] = k
        info[c, 1] = degenerate
        o_pts = _grow(o_pts, ns + k)
        o_uv = _grow(o_uv, nuv + L * k)
        for i in range(k):
            o_pts[ns + i, 0] = s_all[i]
            o_pts[ns + i, 4] = 1.0 if iso[i] else 0.0
        # the shared points: np.mean over the uses of S(uv) (a sequential sum, then / L)
        for j in range(L):
            _shared_points(cic, cku, ckv, cpw4, j, uvs, o_pts[ns:ns + k], o_uv[nuv:nuv + L * k], w)
        for i in range(k):
            for q in range(3):
                o_pts[ns + i, 1 + q] = o_pts[ns + i, 1 + q] / L
        ns += k
        nuv += L * k
    return info, o_pts[:ns], o_uv[:nuv]


@njit(cache=True, nogil=True)
def pcurve_ends_kernel(rows, ck, cpw, t, out):
    """out[i, e] = C_i(clip(t[i, e], knots[p], knots[-p - 1])) for e = 0, 1: `repair._ends` of the 2D
    curves in `model.trim._pcurve_rows`' layout (rows: degree, rational, knots offset and count in ck,
    control points offset in cpw, rows, columns), with the same point code (`_curve_point`)."""
    for i in range(rows.shape[0]):
        p, rat = rows[i, 0], rows[i, 1] != 0
        kc = ck[rows[i, 2]:rows[i, 2] + rows[i, 3]]
        cw = cpw[rows[i, 4]:rows[i, 4] + rows[i, 5] * rows[i, 6]].reshape((rows[i, 5], rows[i, 6]))
        ndu = np.empty((p + 1, p + 1))
        a = np.empty((2, p + 1))
        left = np.empty(p + 1)
        right = np.empty(p + 1)
        ders = np.empty((1, p + 1))
        lo, hi = kc[p], kc[kc.shape[0] - p - 1]
        for e in range(2):
            _curve_point(p, kc, cw, rat, min(max(t[i, e], lo), hi), ndu, a, left, right, ders, out[i, e])
