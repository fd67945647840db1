"""Compiled 1-D adaptive sampling (numba, nogil): `domain._equidistributed` and the bisection rounds of
`domain.adaptive_values` in one call per curve family, with the family's `interval_criteria` computed
inside (a face's iso-lines, or a chunk's uses: a p-curve on its surface each).

Every number is computed with the same operations in the same order as the numpy path (the criteria
as `iso_line_criteria_kernel` / `pcurve_surface_kernel` + `chord_criteria_kernel` compute them; the
placement as `np.linspace`, `np.interp`, `np.cumsum` do), so the values are the numpy path's bit for
bit. An interval's criteria depend on its two ends only, so they are computed once, for the new
intervals of each round (the numpy path recomputed the checked placement's).

A family is a tuple F (see `face.IsoLines.family`, `trims._ChunkLines.family`), passed to the kernels
as separate arguments (`*F`: numba compiles functions with a tuple of arrays several times slower):

    (kind, iso_i, iso_f, lines_c, lines_raw, dil, rgeo, ku, kv, pw,   # kind 0: iso-lines of one surface
     ci, cf, ck, cpw, cku, ckv, cpw4)                                 # kind 1: chunk uses

kind 0: iso_i = (axis, has_raster, pu, pv, rational), iso_f = (x0, x1) (the moving parameter's range) or
(x0, x1, bound) for straight lines (bound: of the rounding noise of their sampled chord deviation),
lines_c / lines_raw the lines clipped into the domain / as given, dil the inside raster of
`face._inside_raster` and rgeo = (u0, v0, du, dv) its origin and steps, ku, kv, pw the surface; cf (a
kind-1 member) the family's own record of its placement's start (`equidistributed_kernel`).

kind 1 per use j: ci[j] = (cp, crat, pu, pv, srat, o_ck, n_ck, o_cw, rows_cw, cols_cw, o_ku, n_ku, o_kv,
n_kv, o_pw, nu, nv, dimw) (degrees, flags, offsets and shapes in the flat read-only arrays ck, cpw, cku,
ckv, cpw4 of all uses), cf[j] = (lo, hi, u0, u1, v0, v1) (the p-curve range and the face's grid box).
Flat read-only C arrays: the curve and surface helpers of `_nurbs_kernels` are then called with the
types `pcurve_surface_kernel` calls them with (no second compiled version).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..geom._nurbs_kernels import (_chord_worst, _moving_basis, _point_scratch, _surface_distance1,
                                   _surface_point01)
from ..geom.nurbs import read_only

#: the other kind's members of a family tuple (one compiled signature for both kinds)
DUMMY_1D = read_only(np.zeros(1))
DUMMY_3D = read_only(np.zeros((1, 1, 3)))
DUMMY_BOOL = np.zeros((1, 1), dtype=np.bool_)
DUMMY_CI = np.zeros((1, 18), dtype=np.int64)
DUMMY_CF = np.zeros((1, 6))


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _linspace01(m):
    """np.linspace(0.0, 1.0, m)."""
    t = np.empty(m)
    step = 1.0 / (m - 1)
    for k in range(m):
        t[k] = k * step
    t[m - 1] = 1.0
    return t


# numba's np.searchsorted / np.unique / np.argsort / boolean indexing cost seconds of compile time per
# use; these plain loops give the same results on sorted, NaN-free input. Slice assignment (a[:n] = b[:n])
# too: its shape-mismatch error path compiles numba's str/repr machinery (~1.2 s CPU cold), so copies are loops


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _ss_left(a, v):
    """np.searchsorted(a, v) (side="left")."""
    lo, hi = 0, a.shape[0]
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < v:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _ss_right(a, v):
    """np.searchsorted(a, v, side="right")."""
    lo, hi = 0, a.shape[0]
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] <= v:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _stable_order(x):
    """np.argsort(x, kind="stable") (insertion sort: the inputs are nearly sorted)."""
    n = x.shape[0]
    order = np.arange(n)
    for i in range(1, n):
        o = order[i]
        v = x[o]
        j = i - 1
        while j >= 0 and x[order[j]] > v:
            order[j + 1] = order[j]
            j -= 1
        order[j + 1] = o
    return order


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _unique(x):
    """np.unique(x)."""
    n = x.shape[0]
    if n == 0:
        return x.copy()
    order = _stable_order(x)
    out = np.empty(n)
    k = 0
    for i in range(n):
        v = x[order[i]]
        if k == 0 or v != out[k - 1]:
            out[k] = v
            k += 1
    return out[:k].copy()


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _nonzero(mask):
    """np.flatnonzero(mask)."""
    n = 0
    for i in range(mask.shape[0]):
        n += mask[i]
    out = np.empty(n, dtype=np.int64)
    k = 0
    for i in range(mask.shape[0]):
        if mask[i]:
            out[k] = i
            k += 1
    return out


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _take(x, idx):
    out = np.empty(idx.shape[0], dtype=x.dtype)
    for i in range(idx.shape[0]):
        out[i] = x[idx[i]]
    return out


#: `_chord_worst` inlined into the criteria loop (the same body; a call per line and interval cost ~1/3 of it)
_chord_worst_i = njit(cache=True, nogil=True, inline="always")(getattr(_chord_worst, "py_func", _chord_worst))


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _raster_in(dil, rgeo, u, v):
    nr = dil.shape[0]
    i = int(np.rint((u - rgeo[0]) / rgeo[2]))
    j = int(np.rint((v - rgeo[1]) / rgeo[3]))
    i = min(max(i, 0), nr - 1)
    j = min(max(j, 0), nr - 1)
    return dil[i, j]


@njit(cache=True, nogil=True, inline="always")
def _raster_ix(rgeo, nr, axis, x):
    """The raster index of x along axis 0 (u) or 1 (v), as `_raster_in` computes it."""
    i = int(np.rint((x - rgeo[axis]) / rgeo[2 + axis]))
    return min(max(i, 0), nr - 1)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _iso_point(axis, rational, pu, pv, pw, dimw, lspan, lbasis, mspan, mbasis, tmp, pts, l, k, net, tk, stamp, cur):
    """pts[l, k] = the point of line l at the moving parameter's sample k (spans and bases given).
    With `net` (axis 0), pw[l] is line l's net (`line_net_kernel`): the v contraction done already.
    Axis 1: the v contraction of sample k is the same for the lines of one u span: kept in tk[span, k]
    (valid while stamp[span, k] == cur, the caller's count of the moving samples' bases)."""
    if axis == 0:
        su = mspan[0, k]
        sv = lspan[0, l]
    else:
        su = lspan[0, l]
        sv = mspan[0, k]
    if net:     # the sums below straight from the line's net (the same products and sums)
        base = su - pu
        w0 = 1.0
        for dd_ in range(dimw):
            acc = 0.0
            for r in range(pu + 1):
                acc += mbasis[0, k, r] * pw[l, base + r, dd_]
            if dd_ < 3:
                pts[l, k, dd_] = acc
            else:
                w0 = acc
        if rational:
            for dd_ in range(dimw - 1):
                pts[l, k, dd_] = pts[l, k, dd_] / w0
        return
    if axis == 1:   # the v contraction of (span, sample) once, kept in tk; the sums from it
        if stamp[su, k] != cur:
            for r in range(pu + 1):
                for dd_ in range(dimw):
                    tk[su, k, r, dd_] = 0.0
                for s_ in range(pv + 1):
                    bb = mbasis[0, k, s_]
                    if bb != 0.0:
                        row = su - pu + r
                        col = sv - pv + s_
                        for dd_ in range(dimw):
                            tk[su, k, r, dd_] += bb * pw[row, col, dd_]
            stamp[su, k] = cur
        w0 = 1.0
        for dd_ in range(dimw):
            acc = 0.0
            for r in range(pu + 1):
                acc += lbasis[0, l, r] * tk[su, k, r, dd_]
            if dd_ < 3:
                pts[l, k, dd_] = acc
            else:
                w0 = acc
        if rational:
            for dd_ in range(dimw - 1):
                pts[l, k, dd_] = pts[l, k, dd_] / w0
        return
    else:
        for r in range(pu + 1):
            for dd_ in range(dimw):
                tmp[r, dd_] = 0.0
            for s_ in range(pv + 1):
                bb = lbasis[0, l, s_] if axis == 0 else mbasis[0, k, s_]
                if bb != 0.0:
                    row = su - pu + r
                    col = sv - pv + s_
                    for dd_ in range(dimw):
                        tmp[r, dd_] += bb * pw[row, col, dd_]
    w0 = 1.0
    for dd_ in range(dimw):
        acc = 0.0
        for r in range(pu + 1):
            bu = mbasis[0, k, r] if axis == 0 else lbasis[0, l, r]
            acc += bu * tmp[r, dd_]
        if dd_ < 3:
            pts[l, k, dd_] = acc
        else:
            w0 = acc
    if rational:
        for dd_ in range(dimw - 1):
            pts[l, k, dd_] = pts[l, k, dd_] / w0


@njit(cache=True, nogil=True, inline="always")
def _moving_point_basis(pm, km, nm, xs, k, left, right, mspan, mbasis):
    """mspan[0, k] and mbasis[0, k] of the moving parameter xs[0, k]: `_nurbs_kernels._span` and
    `_ders_basis` (nd = 0: A2.2, ndu[:, p]) written out (the same operations in the same order), the
    basis built in place in mbasis[0, k] (no call with array arguments per sample)."""
    x = xs[0, k]
    if x >= km[nm]:
        sk = nm - 1
        while sk > pm and km[sk] >= km[nm]:
            sk -= 1
    else:
        sk = pm
        hi_ = nm
        while hi_ - sk > 1:
            mid_ = (sk + hi_) // 2
            if x < km[mid_]:
                hi_ = mid_
            else:
                sk = mid_
    mspan[0, k] = sk
    mbasis[0, k, 0] = 1.0
    for j_ in range(1, pm + 1):
        left[j_] = x - km[sk + 1 - j_]
        right[j_] = km[sk + j_] - x
        saved = 0.0
        for r_ in range(j_):
            temp = mbasis[0, k, r_] / (right[r_ + 1] + left[j_ - r_])
            mbasis[0, k, r_] = saved + right[r_ + 1] * temp
            saved = left[j_ - r_] * temp
        mbasis[0, k, j_] = saved


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _iso_criteria(iso_i, iso_f, lines_c, lines_raw, dil, rgeo, ku, kv, pw, a, b, m, length, dev, max_len, max_dev,
                  stop):
    """`iso_line_criteria_kernel` over the intervals [a_i, b_i] (weights from the raster), interval by
    interval: a point equal to the previous interval's last one (same parameter, same line) is taken
    from it; with `stop`, returns False at the first interval over max_len or max_dev.

    Straight lines (iso_f[2] = thr >= 0, see `equidistributed_kernel`): an interval whose chords are
    at least thr long (and finite) gets deviation 0 without its interior samples being evaluated: the
    sampled deviation it stands for is rounding noise below the bound that `equidistributed_kernel`
    checked makes no decision differ (shorter intervals are sampled as usual)."""
    axis, has_raster, pu, pv, rational = iso_i[0], iso_i[1] != 0, iso_i[2], iso_i[3], iso_i[4] != 0
    xr0, xr1 = iso_f[0], iso_f[1]
    straight = iso_f.shape[0] > 2 and iso_f[2] >= 0.0
    thr = iso_f[2] if straight else 0.0
    # net: pw holds the lines' nets (`line_net_kernel`, axis 0), (L, nu, dimw)
    net = iso_i.shape[0] > 5 and iso_i[5] != 0
    nu_ctrl, nv_ctrl, dimw = ku.shape[0] - pu - 1, kv.shape[0] - pv - 1, pw.shape[2]
    xyz_w = rational and dimw == 4          # the usual nets: the sums written out per coordinate
    xyz = not rational and dimw == 3
    if axis == 0:
        pf, kf, nf, pm, km, nm = pv, kv, nv_ctrl, pu, ku, nu_ctrl
    else:
        pf, kf, nf, pm, km, nm = pu, ku, nu_ctrl, pv, kv, nv_ctrl
    n = a.shape[0]
    n_lines = lines_c.shape[0]
    lspan = np.empty((1, n_lines), dtype=np.int64)
    lbasis = np.empty((1, n_lines, pf + 1))
    _moving_basis(pf, kf, nf, lines_c.reshape(1, n_lines), lspan, lbasis)
    t = _linspace01(m)
    xs = np.empty((1, m))
    mspan = np.empty((1, m), dtype=np.int64)
    mbasis = np.empty((1, m, pm + 1))
    pts = np.empty((n_lines, m, 3))
    tmp = np.empty((pu + 1, dimw))
    left = np.empty(pm + 1)
    right = np.empty(pm + 1)
    nr = dil.shape[0]
    lix = np.empty(n_lines, dtype=np.int64)         # the raster index of each line (its fixed parameter)
    if has_raster:
        for l in range(n_lines):
            lix[l] = _raster_ix(rgeo, nr, 1 - axis, lines_raw[l])
    prev_ok = np.zeros(n_lines, dtype=np.bool_)     # pts[l, m - 1] holds the point at prev_x on line l
    k0l = np.zeros(n_lines, dtype=np.int64)         # per line: its first sample to compute (1: taken)
    abl = np.empty((n_lines, 3))                    # per line: its chord, the chord's squared length
    ddl = np.empty(n_lines)                         # (1 if 0) and its largest deviation
    worst_l = np.empty(n_lines)
    prev_x = np.nan
    w = np.empty(n_lines, dtype=np.bool_)
    nt = nu_ctrl if axis == 1 and not net else 1
    tk = np.empty((nt, m, pu + 1, dimw))            # axis 1: v contractions per (u span, sample)
    stamp = np.full((nt, m), -1, dtype=np.int64)
    cur = 0
    for i in range(n):
        cur += 1
        d = b[i] - a[i]
        for k in range(m):
            xs[0, k] = min(max(a[i] + d * t[k], xr0), xr1)
        any_w = False
        if has_raster:      # `_raster_in` of (a, line), (b, line), (mid, line): the moving index once
            xm = 0.5 * (a[i] + b[i])
            ia, ib = _raster_ix(rgeo, nr, axis, a[i]), _raster_ix(rgeo, nr, axis, b[i])
            im = _raster_ix(rgeo, nr, axis, xm)
            for l in range(n_lines):
                jl = lix[l]
                if axis == 0:
                    w[l] = dil[ia, jl] or dil[ib, jl] or dil[im, jl]
                else:
                    w[l] = dil[jl, ia] or dil[jl, ib] or dil[jl, im]
                any_w = any_w or w[l]
        else:
            for l in range(n_lines):
                w[l] = True
            any_w = n_lines > 0
        lmax = 0.0
        dmax = 0.0
        if any_w:
            for k in range(m):
                if straight and 0 < k < m - 1:
                    continue
                _moving_point_basis(pm, km, nm, xs, k, left, right, mspan, mbasis)
        same = xs[0, 0] == prev_x
        for l in range(n_lines):
            k0l[l] = 0
            if w[l] and same and prev_ok[l]:
                for q in range(3):
                    pts[l, 0, q] = pts[l, m - 1, q]
                k0l[l] = 1
        if net:     # `_iso_point`'s net sums, in place (the same products and sums), sample by sample
            for k in range(m):
                if straight and 0 < k < m - 1:
                    continue
                base = mspan[0, k] - pu
                for l in range(n_lines):
                    if not w[l] or k < k0l[l]:
                        continue
                    if xyz_w:       # the four sums at once (each the same terms in the same order)
                        c0 = c1 = c2 = c3 = 0.0
                        for r in range(pu + 1):
                            bb = mbasis[0, k, r]
                            c0 += bb * pw[l, base + r, 0]
                            c1 += bb * pw[l, base + r, 1]
                            c2 += bb * pw[l, base + r, 2]
                            c3 += bb * pw[l, base + r, 3]
                        pts[l, k, 0], pts[l, k, 1], pts[l, k, 2] = c0 / c3, c1 / c3, c2 / c3
                        continue
                    if xyz:
                        c0 = c1 = c2 = 0.0
                        for r in range(pu + 1):
                            bb = mbasis[0, k, r]
                            c0 += bb * pw[l, base + r, 0]
                            c1 += bb * pw[l, base + r, 1]
                            c2 += bb * pw[l, base + r, 2]
                        pts[l, k, 0], pts[l, k, 1], pts[l, k, 2] = c0, c1, c2
                        continue
                    w0 = 1.0
                    for dd_ in range(dimw):
                        acc = 0.0
                        for r in range(pu + 1):
                            acc += mbasis[0, k, r] * pw[l, base + r, dd_]
                        if dd_ < 3:
                            pts[l, k, dd_] = acc
                        else:
                            w0 = acc
                    if rational:
                        for dd_ in range(dimw - 1):
                            pts[l, k, dd_] = pts[l, k, dd_] / w0
        else:
            for l in range(n_lines):
                if not w[l]:
                    continue
                k0 = k0l[l]
                if axis == 1:     # `_iso_point`'s axis-1 sums, in place (the same products and sums)
                    su = lspan[0, l]
                    for k in range(k0, m):
                        if straight and 0 < k < m - 1:
                            continue
                        if stamp[su, k] != cur:
                            sv = mspan[0, k]
                            for r in range(pu + 1):
                                row = su - pu + r
                                if xyz_w or xyz:    # the sums at once (the same terms in the same order)
                                    c0 = c1 = c2 = c3 = 0.0
                                    for s_ in range(pv + 1):
                                        bb = mbasis[0, k, s_]
                                        if bb != 0.0:
                                            col = sv - pv + s_
                                            c0 += bb * pw[row, col, 0]
                                            c1 += bb * pw[row, col, 1]
                                            c2 += bb * pw[row, col, 2]
                                            if xyz_w:
                                                c3 += bb * pw[row, col, 3]
                                    tk[su, k, r, 0], tk[su, k, r, 1], tk[su, k, r, 2] = c0, c1, c2
                                    if xyz_w:
                                        tk[su, k, r, 3] = c3
                                    continue
                                for dd_ in range(dimw):
                                    tk[su, k, r, dd_] = 0.0
                                for s_ in range(pv + 1):
                                    bb = mbasis[0, k, s_]
                                    if bb != 0.0:
                                        col = sv - pv + s_
                                        for dd_ in range(dimw):
                                            tk[su, k, r, dd_] += bb * pw[row, col, dd_]
                            stamp[su, k] = cur
                        if xyz_w or xyz:    # the sums at once (each the same terms in the same order)
                            c0 = c1 = c2 = c3 = 0.0
                            for r in range(pu + 1):
                                bb = lbasis[0, l, r]
                                c0 += bb * tk[su, k, r, 0]
                                c1 += bb * tk[su, k, r, 1]
                                c2 += bb * tk[su, k, r, 2]
                                if xyz_w:
                                    c3 += bb * tk[su, k, r, 3]
                            if xyz_w:
                                c0, c1, c2 = c0 / c3, c1 / c3, c2 / c3
                            pts[l, k, 0], pts[l, k, 1], pts[l, k, 2] = c0, c1, c2
                            continue
                        w0 = 1.0
                        for dd_ in range(dimw):
                            acc = 0.0
                            for r in range(pu + 1):
                                acc += lbasis[0, l, r] * tk[su, k, r, dd_]
                            if dd_ < 3:
                                pts[l, k, dd_] = acc
                            else:
                                w0 = acc
                        if rational:
                            for dd_ in range(dimw - 1):
                                pts[l, k, dd_] = pts[l, k, dd_] / w0
                else:
                    for k in range(k0, m):
                        if straight and 0 < k < m - 1:
                            continue
                        _iso_point(axis, rational, pu, pv, pw, dimw, lspan, lbasis, mspan, mbasis, tmp, pts, l, k, net,
                                   tk, stamp, cur)
        # the chords, then the deviations (`_chord_worst`'s arithmetic per line) sample by sample across
        # the lines. The maxima are taken of the squares, one square root at the end: sqrt is correctly
        # rounded and monotone, so sqrt(max s) = max sqrt(s) bit for bit, and a NaN is skipped (or kept
        # as a line's first sample) the same way as the square roots' comparisons skip (keep) it
        lmax2 = 0.0
        for l in range(n_lines):
            if not w[l]:
                continue
            a0, a1, a2 = pts[l, 0, 0], pts[l, 0, 1], pts[l, 0, 2]
            ab0, ab1, ab2 = pts[l, m - 1, 0] - a0, pts[l, m - 1, 1] - a1, pts[l, m - 1, 2] - a2
            den = (ab0 * ab0 + ab2 * ab2) + ab1 * ab1
            if den > lmax2:
                lmax2 = den
            abl[l, 0], abl[l, 1], abl[l, 2] = ab0, ab1, ab2
            ddl[l] = den if den > 0 else 1.0
            worst_l[l] = 0.0
        lmax = np.sqrt(lmax2)
        if not straight:    # line by line: its chord in registers (each line's samples in the same order)
            dmax2 = 0.0
            for l in range(n_lines):
                if not w[l]:
                    continue
                a0, a1, a2 = pts[l, 0, 0], pts[l, 0, 1], pts[l, 0, 2]
                ab0, ab1, ab2 = abl[l, 0], abl[l, 1], abl[l, 2]
                dd = ddl[l]
                worst = 0.0
                for k in range(1, m - 1):
                    q0, q1, q2 = pts[l, k, 0] - a0, pts[l, k, 1] - a1, pts[l, k, 2] - a2
                    tq = ((q0 * ab0 + q2 * ab2) + q1 * ab1) / dd
                    if tq < 0.0:
                        tq = 0.0
                    elif tq > 1.0:
                        tq = 1.0
                    r0, r1, r2 = q0 - tq * ab0, q1 - tq * ab1, q2 - tq * ab2
                    d2 = (r0 * r0 + r1 * r1) + r2 * r2
                    if d2 > worst or k == 1:
                        worst = d2
                if worst > dmax2:
                    dmax2 = worst
            dmax = np.sqrt(dmax2)
        if straight and any_w and not (lmax >= thr and lmax < np.inf):
            # a short (or non-finite) interval: its interior samples after all
            for k in range(1, m - 1):
                _moving_point_basis(pm, km, nm, xs, k, left, right, mspan, mbasis)
            for l in range(n_lines):
                if not w[l]:
                    continue
                for k in range(1, m - 1):
                    _iso_point(axis, rational, pu, pv, pw, dimw, lspan, lbasis, mspan, mbasis, tmp, pts, l, k, net, tk,
                           stamp, cur)
                ab0, ab1, ab2 = (pts[l, m - 1, 0] - pts[l, 0, 0], pts[l, m - 1, 1] - pts[l, 0, 1],
                                 pts[l, m - 1, 2] - pts[l, 0, 2])
                worst = _chord_worst(pts[l], m, (ab0 * ab0 + ab2 * ab2) + ab1 * ab1)
                if worst > dmax:
                    dmax = worst
        for l in range(n_lines):
            prev_ok[l] = w[l]
        prev_x = xs[0, m - 1]
        length[i] = lmax
        dev[i] = dmax
        if stop and not (lmax <= max_len and dmax <= max_dev):
            return False
    return True


@njit(cache=True, nogil=True, inline="always")
def _use_arrays(ci, ck, cpw, cku, ckv, cpw4, j):
    """Use j's p-curve knots, control points, surface knots u, v and control net (views of the flat arrays)."""
    kc = ck[ci[j, 5]:ci[j, 5] + ci[j, 6]]
    cw = cpw[ci[j, 7]:ci[j, 7] + ci[j, 8] * ci[j, 9]].reshape((ci[j, 8], ci[j, 9]))
    ku = cku[ci[j, 10]:ci[j, 10] + ci[j, 11]]
    kv = ckv[ci[j, 12]:ci[j, 12] + ci[j, 13]]
    o = ci[j, 14]
    pw = cpw4[o:o + ci[j, 15] * ci[j, 16] * ci[j, 17]].reshape((ci[j, 15], ci[j, 16], ci[j, 17]))
    return kc, cw, ku, kv, pw


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _chunk_criteria(ci, cf, ck, cpw, cku, ckv, cpw4, a, b, m, length, dev, max_len, max_dev, stop, pin, pout):
    """`_ChunkLines.criteria` (`pcurve_surface_kernel` then `chord_criteria_kernel`) over the intervals
    [a_i, b_i]: a point at the previous interval's last parameter is taken from it; with `stop`,
    returns False at the first interval over max_len or max_dev. The uses are taken in turn, and an
    interval over max_len or max_dev after some of them skips the rest: its length and dev are then
    those of the uses taken (over the limit all the same; the maxima only grow), and exact otherwise
    (np.inf limits: always exact).

    The points as `_curve_point` and `_surface_point01` (nd = 0) compute them (the same operations in
    the same order), their span searches (`_nurbs_kernels._span`) and bases (A2.2, `_ders_basis` with
    nd = 0) written out here: no compiled call per point, and no IR-inlined helper either (each array
    argument of one costs an atomic reference count pair per call). The work arrays are parts of one
    scratch array; the chord maxima are taken of the squares, one square root each.

    pout (a.shape[0] * m * n_uses * 3 long, else empty): the intervals' points (xyz), written there (all
    uses: only with np.inf limits). pin (same layout, one row per pair of intervals, else empty): the
    intervals come in halves (a[2q], b[2q]), (a[2q + 1], b[2q + 1]) of a parent [a[2q], b[2q + 1]] whose
    points are row q (`equidistributed_kernel`'s bisection rounds): a point k = 2k' of a half is the
    parent's point k' (first half) or (m - 1) / 2 + k' (second) when its parameter has the same bits
    as the parent's (the same s, the same code: the same point); else it is evaluated."""
    n_uses = ci.shape[0]
    mcp, mpu, mpv, mdw = 0, np.int64(0), np.int64(0), np.int64(0)
    for j in range(n_uses):
        mcp = max(mcp, ci[j, 0])
        mpu = max(mpu, ci[j, 2])
        mpv = max(mpv, ci[j, 3])
        mdw = max(mdw, ci[j, 17])
    nl = max(mcp, mpu, mpv) + 1
    ol = 0                          # left
    orr = ol + nl                   # right
    onc = orr + nl                  # the curve's basis
    onu = onc + mcp + 1             # the surface's bases
    onv = onu + mpu + 1
    otm = onv + mpv + 1             # tmp (pu + 1, dimw)
    opt = otm + (mpu + 1) * mdw     # pts (m, n_uses, 3)
    npt = m * n_uses * 3
    store = pout.shape[0] >= a.shape[0] * npt
    par = a.shape[0] % 2 == 0 and pin.shape[0] >= (a.shape[0] // 2) * npt
    w = np.empty(opt + (0 if store else npt))
    pts = pout if store else w
    half = (m - 1) // 2
    step = 1.0 / (m - 1)            # `_linspace01`: t_k = k * step, t_(m-1) = 1
    prev_s = np.nan
    prev_done = 0                   # the uses whose points the previous interval evaluated
    prev_base = 0 if store else opt
    for i in range(a.shape[0]):
        base = i * npt if store else opt
        d = b[i] - a[i]
        reuse = a[i] + d * 0.0 == prev_s
        lmax2 = 0.0
        dmax2 = 0.0
        done = n_uses
        h = i % 2
        pa = a[i - h] if par else 0.0
        pd = b[i - h + 1] - pa if par else 0.0
        for j in range(n_uses):
            k0 = 0
            if reuse and j < prev_done:
                for q in range(3):
                    pts[base + j * 3 + q] = pts[prev_base + ((m - 1) * n_uses + j) * 3 + q]
                k0 = 1
            cp, crat, pu, pv, srat = ci[j, 0], ci[j, 1] != 0, ci[j, 2], ci[j, 3], ci[j, 4] != 0
            # `_use_arrays`' views, indexed in the flat arrays (a view costs a reference count pair)
            okc, ocw, ncw, cdimw = ci[j, 5], ci[j, 7], ci[j, 8], ci[j, 9]
            oku, okv, opw = ci[j, 10], ci[j, 12], ci[j, 14]
            nu_c, nv_c, dimw = ci[j, 15], ci[j, 16], ci[j, 17]
            lo, hi = cf[j, 0], cf[j, 1]
            t0, t1 = ck[okc + cp], ck[okc + ci[j, 6] - cp - 1]
            su0, su1 = cku[oku + pu], cku[oku + ci[j, 11] - pu - 1]
            sv0, sv1 = ckv[okv + pv], ckv[okv + ci[j, 13] - pv - 1]
            cdim = cdimw - 1 if crat else cdimw
            dim = dimw - 1 if srat else dimw
            for k in range(k0, m):
                tk = 1.0 if k == m - 1 else k * step
                s = a[i] + d * tk
                if par and k % 2 == 0:
                    kp = h * half + k // 2
                    sp = pa + pd * (1.0 if kp == m - 1 else kp * step)
                    if _same_bits(s, sp):
                        o = base + (k * n_uses + j) * 3
                        op = (i // 2) * npt + (kp * n_uses + j) * 3
                        pts[o], pts[o + 1], pts[o + 2] = pin[op], pin[op + 1], pin[op + 2]
                        continue
                tt = lo + s * (hi - lo)
                tt = min(max(tt, t0), t1)
                # _curve_point
                # the span (`_nurbs_kernels._span`)
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
                # the basis functions at the span (A2.2; `_ders_basis`' ndu[:, p] with nd = 0)
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
                uu = min(max(uv0, cf[j, 2]), cf[j, 3])
                vv = min(max(uv1, cf[j, 4]), cf[j, 5])
                uu = min(max(uu, su0), su1)
                vv = min(max(vv, sv0), sv1)
                # _surface_point01, nd = 0
                # the span (`_nurbs_kernels._span`)
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
                # the span (`_nurbs_kernels._span`)
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
                # the basis functions at the span (A2.2; `_ders_basis`' ndu[:, p] with nd = 0)
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
                # the basis functions at the span (A2.2; `_ders_basis`' ndu[:, p] with nd = 0)
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
                        w[otm + r * mdw + dd] = 0.0
                    for s_ in range(pv + 1):
                        bb = w[onv + s_]
                        if bb != 0.0:
                            row = su - pu + r
                            col = sv - pv + s_
                            for dd in range(dimw):
                                w[otm + r * mdw + dd] += bb * cpw4[opw + ((row) * nv_c + col) * dimw + dd]
                w0 = 1.0
                if srat:
                    w0 = 0.0
                    for r in range(pu + 1):
                        w0 += w[onu + r] * w[otm + r * mdw + dim]
                o = base + (k * n_uses + j) * 3
                for dd in range(dim):
                    acc = 0.0
                    for r in range(pu + 1):
                        acc += w[onu + r] * w[otm + r * mdw + dd]
                    pts[o + dd] = acc / w0 if srat else acc
            # as chord_criteria_kernel, the maxima taken of the squares with one square root each: sqrt is
            # correctly rounded and monotone, so sqrt(max x) = max sqrt(x) bit for bit (0 = sqrt(0) the
            # start), and a NaN fails the comparison either way; use by use, in the order of the uses
            o0 = base + j * 3
            o1 = base + ((m - 1) * n_uses + j) * 3
            a0, a1, a2 = pts[o0], pts[o0 + 1], pts[o0 + 2]
            ab0, ab1, ab2 = pts[o1] - a0, pts[o1 + 1] - a1, pts[o1 + 2] - a2
            den = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
            if den > lmax2:
                lmax2 = den
            dd = den if den > 0 else 1.0
            for k in range(1, m - 1):
                ok_ = base + (k * n_uses + j) * 3
                q0, q1, q2 = pts[ok_] - a0, pts[ok_ + 1] - a1, pts[ok_ + 2] - a2
                tq = (q0 * ab0 + q1 * ab1 + q2 * ab2) / dd
                if tq < 0.0:
                    tq = 0.0
                elif tq > 1.0:
                    tq = 1.0
                r0, r1, r2 = q0 - tq * ab0, q1 - tq * ab1, q2 - tq * ab2
                d2 = r0 * r0 + r1 * r1 + r2 * r2
                if d2 > dmax2:
                    dmax2 = d2
            # over a limit already (the maxima only grow, NaNs never enter them): the other uses cannot
            # bring the interval back within both, so they are skipped
            if j < n_uses - 1 and not (np.sqrt(lmax2) <= max_len and np.sqrt(dmax2) <= max_dev):
                done = j + 1
                break
        prev_s = a[i] + d * 1.0
        prev_done = done
        prev_base = base
        lmax = np.sqrt(lmax2)
        dmax = np.sqrt(dmax2)
        length[i] = lmax
        dev[i] = dmax
        if stop and not (lmax <= max_len and dmax <= max_dev):
            return False
    return True


@njit(cache=True, nogil=True, inline="always")
def _rt():
    """(5, 9, False, True) as run-time values: numba compiles a callee once per literal argument, so
    constants passed down would multiply the compiled versions of the criteria (and the cold start)."""
    c = np.array([5, 9, 0, 1])
    return c[0], c[1], c[2] != 0, c[3] != 0


@njit(cache=True, nogil=True, inline="always")
def _criteria(kind, iso_i, iso_f, lines_c, lines_raw, dil, rgeo, ku, kv, pw,
              ci, cf, ck, cpw, cku, ckv, cpw4, a, b, m, length, dev, max_len, max_dev, stop, pin, pout):
    if kind == 0:
        return _iso_criteria(iso_i, iso_f, lines_c, lines_raw, dil, rgeo, ku, kv, pw, a, b, m, length, dev, max_len,
                             max_dev, stop)
    return _chunk_criteria(ci, cf, ck, cpw, cku, ckv, cpw4, a, b, m, length, dev, max_len, max_dev, stop, pin, pout)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _place(cum, x, a, b, n):
    """np.unique(v) of v = np.interp(np.linspace(0, cum[-1], n + 1), cum, x), v[0] = a, v[-1] = b."""
    total = cum[cum.shape[0] - 1]
    step = total / n
    v = np.empty(n + 1)
    nxp = cum.shape[0]
    j = 0
    for i in range(n + 1):
        key = i * step + 0.0
        if i == n:
            key = total
        if key > cum[nxp - 1]:
            v[i] = x[nxp - 1]
            continue
        if key < cum[0]:
            v[i] = x[0]
            continue
        while j + 1 < nxp and cum[j + 1] <= key:    # the largest j with cum[j] <= key (np.interp's)
            j += 1
        if j == nxp - 1 or cum[j] == key:
            v[i] = x[j]
        else:
            slope = (x[j + 1] - x[j]) / (cum[j + 1] - cum[j])
            r = slope * (key - cum[j]) + x[j]
            if np.isnan(r):
                r = slope * (key - cum[j + 1]) + x[j + 1]
                if np.isnan(r) and x[j] == x[j + 1]:
                    r = x[j]
            v[i] = r
    v[0] = a
    v[n] = b
    return _unique(v)


@njit(cache=True, nogil=True, inline="always")
def _same_bits(p, q):
    """p and q are the same float bit for bit (== with the zeros' signs; NaN: never)."""
    return p == q and (p != 0.0 or np.signbit(p) == np.signbit(q))


@njit(cache=True, nogil=True, inline="always")
def _halves(x, bad, nbad, P, npt):
    """The two halves (sa, sb) of every bad interval of x, and the bad intervals' rows of their points P
    (npt each; none with npt = 0)."""
    n = x.shape[0] - 1
    sa = np.empty(2 * nbad)
    sb = np.empty(2 * nbad)
    pin = np.empty(nbad * npt)
    k = 0
    for i in range(n):
        if bad[i]:
            mid = 0.5 * (x[i] + x[i + 1])
            sa[k], sb[k] = x[i], mid
            sa[k + 1], sb[k + 1] = mid, x[i + 1]
            o = (k >> 1) * npt
            for q in range(npt):
                pin[o + q] = P[i * npt + q]
            k += 2
    return sa, sb, pin


@njit(cache=True, nogil=True, inline="always")
def _merge(x, length, dev, bad, nbad, sb, sl, sd, P, po, npt):
    """x with the midpoints of the bad intervals inserted, and the criteria of the new intervals
    (sl, sd of the halves; those of the kept intervals copied), and their points (po of the halves, P
    of the kept intervals; npt each, none with npt = 0)."""
    n = x.shape[0] - 1
    nx = np.empty(n + 1 + nbad)
    nl = np.empty(n + nbad)
    nd = np.empty(n + nbad)
    nP = np.empty((n + nbad) * npt)
    k = 0
    q = 0
    for i in range(n):
        nx[k] = x[i]
        if bad[i]:
            nx[k + 1] = sb[q]
            nl[k], nd[k] = sl[q], sd[q]
            nl[k + 1], nd[k + 1] = sl[q + 1], sd[q + 1]
            for r in range(2 * npt):
                nP[k * npt + r] = po[q * npt + r]
            q += 2
            k += 2
        else:
            nl[k], nd[k] = length[i], dev[i]
            for r in range(npt):
                nP[k * npt + r] = P[i * npt + r]
            k += 1
    nx[k] = x[n]
    return nx, nl, nd, nP


@njit(cache=True, nogil=True)
def equidistributed_kernel(kind, iso_i, iso_f, lines_c, lines_raw, dil, rgeo, ku, kv, pw,
                           ci, cf, ck, cpw, cku, ckv, cpw4, x0, a, b, tolerance, max_edge, max_values):
    """`domain._equidistributed` then `adaptive_values`' bisection rounds, for the family (*F) from the
    fine sampling's start x0 (np.unique(np.clip(np.r_[a, init, b], a, b))).

    Returns (values, needed): needed < 0 if the values meet both criteria (or the rounds ran out, as
    the numpy path), else the count of intervals that exceeds max_values (the caller refuses).

    One loop around ONE call of the criteria (a request: intervals, m, outputs, limits, stop; then a
    state says what to do with the answer): numba re-optimises and re-emits a called function's body in
    every caller, and IR-inlines an inline="always" one at every call site, so the big criteria bodies
    are inlined here once and compiled only once. States: 0 the fine sampling's criteria, 1 a
    fine bisection round's, 2 the check of n0 - 1 placed values, 3 the check of nn placed values,
    4 the placed values' criteria, 5 a bisection round's (adaptive_values').
    A chunk family (kind 1) keeps the points of every interval of x in states 0, 1, 4, 5 (P; no limits
    there, so all uses are evaluated), and a bisection round's halves take the points they share with
    their interval from it (`_chunk_criteria`'s pin: the same parameter bits, the same point)."""
    m5, m9, no, yes = _rt()
    inf = np.inf
    if kind == 0 and iso_f.shape[0] > 2:
        # straight iso-lines (`face.IsoLines.family`: iso_f[2] bounds the rounding noise of their sampled
        # deviation): an interval at least thr long may skip its interior samples, its deviation
        # then counts 0. Exact: noise <= bound <= tolerance / 1000 passes every deviation check the
        # same, and in the density max(len / max_edge, sqrt(dev / tolerance)) the length term wins
        thr = -1.0
        bound = iso_f[2]
        if bound >= 0.0 and bound <= 1e-3 * tolerance:
            thr = max_edge * np.sqrt(bound / tolerance) * (1.0 + 1e-9)
        f2 = np.empty(3)
        f2[0], f2[1], f2[2] = iso_f[0], iso_f[1], thr
        iso_f = f2
    x = x0
    n = x.shape[0] - 1
    length = np.empty(n)
    dev = np.empty(n)
    ra, rb, rm, rl, rd, rml, rmd, rst = x[:-1], x[1:], m5, length, dev, inf, inf, no
    state = 0
    e0 = np.empty(0)
    L3 = ci.shape[0] * 3 if kind != 0 else 0
    npt = m5 * L3
    P = e0
    rpi = e0
    rpo = np.empty(n * npt)
    rounds = 0
    bad = np.empty(0, dtype=np.bool_)
    nbad = 0
    sb = np.empty(0)
    cum = np.empty(0)
    n0 = np.int64(0)
    nn = np.int64(0)
    v = np.empty(2)
    # kind 0, curved lines: cf is the family's record of its fine sampling's start (`face.IsoLines.family`;
    # the two placements of a face start from the same values): rows 1..n the start's intervals
    # (x_i, x_i+1, length, deviation), cf[0, 0] = n (0: none). Those criteria depend on the family and
    # the two ends only (all lines, no limits; not on the tolerance: the straight skip is off), so a
    # start with the same ends bit for bit takes them
    rec = kind == 0 and cf.shape[0] > n and cf.shape[1] >= 4 and not (iso_f.shape[0] > 2 and iso_f[2] >= 0.0)
    while True:
        hit = state == 0 and rec and cf[0, 0] == n
        if hit:
            for i in range(n):
                if not (_same_bits(cf[i + 1, 0], x[i]) and _same_bits(cf[i + 1, 1], x[i + 1])):
                    hit = False
                    break
        if hit:
            for i in range(n):
                length[i] = cf[i + 1, 2]
                dev[i] = cf[i + 1, 3]
            ok = True
        else:
            ok = _criteria(kind, iso_i, iso_f, lines_c, lines_raw, dil, rgeo, ku, kv, pw,
                           ci, cf, ck, cpw, cku, ckv, cpw4, ra, rb, rm, rl, rd, rml, rmd, rst, rpi, rpo)
            if state == 0 and rec:
                for i in range(n):
                    cf[i + 1, 0], cf[i + 1, 1] = x[i], x[i + 1]
                    cf[i + 1, 2], cf[i + 1, 3] = length[i], dev[i]
                cf[0, 0] = n
        if state == 0 or state == 4:
            P = rpo
        if state == 1 or state == 5:
            x, length, dev, P = _merge(x, length, dev, bad, nbad, sb, rl, rd, P, rpo, npt)
            if state == 5 and x.shape[0] - 1 > max_values:
                return x, float(x.shape[0] - 1)
        phase2 = False
        if state == 0 or state == 1:
            more = False
            if rounds < 8:
                n = x.shape[0] - 1
                bad = np.empty(n, dtype=np.bool_)
                nbad = 0
                for i in range(n):
                    bad[i] = (length[i] > 0.25 * max_edge) or (dev[i] > 0.0625 * tolerance)
                    nbad += bad[i]
                more = not (nbad == 0 or x.shape[0] > 20000)
            if more:
                rounds += 1
                sa, sb, rpi = _halves(x, bad, nbad, P, npt)
                rpo = np.empty(2 * nbad * npt)
                ra, rb, rm, rl, rd, rml, rmd, rst = sa, sb, m5, np.empty(2 * nbad), np.empty(2 * nbad), inf, inf, no
                state = 1
                continue
            n = x.shape[0] - 1
            cum = np.empty(n + 1)
            cum[0] = 0.0
            for i in range(n):
                p = length[i] / max_edge
                q = np.sqrt(dev[i] / tolerance)
                nd = p if p >= q else q
                if np.isnan(p) or np.isnan(q):
                    nd = np.nan
                cum[i + 1] = cum[i] + nd
            total = cum[n]
            v = np.empty(2)
            v[0], v[1] = a, b
            if total > 0:
                if not total <= max_values:
                    return v, total
                n0 = max(1, int(np.ceil(total - 1e-9)))
                if n0 > 1 and total - (n0 - 1) < 0.1:
                    v = _place(cum, x, a, b, n0 - 1)
                    state = 2
                else:
                    nn = n0
                    v = _place(cum, x, a, b, nn)     # nn <= 1.5 * n0 + 2 holds for nn = n0 >= 1
                    state = 3
                ra, rb, rm, rl, rd, rml, rmd, rst = (v[:-1], v[1:], m9, np.empty(v.shape[0] - 1),
                                                     np.empty(v.shape[0] - 1), max_edge, tolerance, yes)
                rpi, rpo = e0, e0
                continue
            phase2 = True
        elif state == 2 or state == 3:
            if ok:
                return v, -1.0
            if state == 3:
                nn += max(1, int(0.04 * nn))
            else:
                nn = n0
            if nn <= 1.5 * n0 + 2:
                v = _place(cum, x, a, b, nn)
                ra, rb, rm, rl, rd, rml, rmd, rst = (v[:-1], v[1:], m9, np.empty(v.shape[0] - 1),
                                                     np.empty(v.shape[0] - 1), max_edge, tolerance, yes)
                rpi, rpo = e0, e0
                state = 3
                continue
            v = _place(cum, x, a, b, n0)
            phase2 = True
        if phase2:
            # every interval against both criteria; bisect where one fails (adaptive_values' rounds)
            x = v
            n = x.shape[0] - 1
            length = np.empty(n)
            dev = np.empty(n)
            ra, rb, rm, rl, rd, rml, rmd, rst = x[:-1], x[1:], m9, length, dev, inf, inf, no
            npt = m9 * L3
            rpi, rpo = e0, np.empty(n * npt)
            state = 4
            rounds = 0
            continue
        # state 4 or 5
        if state == 4:
            length, dev = rl, rd
        if rounds < 12:
            n = x.shape[0] - 1
            bad = np.empty(n, dtype=np.bool_)
            nbad = 0
            for i in range(n):
                bad[i] = (length[i] > max_edge) or (dev[i] > tolerance)
                nbad += bad[i]
            if nbad != 0:
                rounds += 1
                sa, sb, rpi = _halves(x, bad, nbad, P, npt)
                rpo = np.empty(2 * nbad * npt)
                ra, rb, rm, rl, rd, rml, rmd, rst = sa, sb, m9, np.empty(2 * nbad), np.empty(2 * nbad), inf, inf, no
                state = 5
                continue
        return x, -1.0


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _snap1(v, grid, tol):
    """`trims._snap` of one value: (snapped, hit)."""
    n = grid.shape[0]
    j = _ss_left(grid, v)
    j = min(max(j, 1), n - 1)
    lo, hi = grid[j - 1], grid[j]
    near = lo if abs(v - lo) <= abs(v - hi) else hi
    if abs(v - near) <= tol:
        return near, True
    return v, False


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _sgn(x):
    if x > 0:
        return 1.0
    if x < 0:
        return -1.0
    if x == 0:
        return 0.0
    return np.nan


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _grid(G, gl, j, axis):
    return G[j, axis, :gl[j, axis]]


@njit(cache=True, nogil=True)
def inside_grid_kernel(xs, ys, a, b, dil, ero):
    """Which points (xs[i], ys[j]) of a tensor grid lie inside the closed polygons with edges a[e] -> b[e]
    (even-odd rule), dilated (dil: the point or one of its four neighbours inside) and eroded (ero: the
    point and its four neighbours inside), by rows: the crossings of row y are computed once, with the
    crossing test and abscissa of `predicates._points_in_polygons_kernel`, so the same decisions as
    `points_in_polygons` (which counts the same crossings, edge by edge)."""
    ins = _inside_rows(xs, ys, a, b)
    nx, ny = ins.shape
    for i in range(nx):     # (a missing neighbour at the border: the point itself; | and & of bools: no branches)
        im, ip = max(i - 1, 0), min(i + 1, nx - 1)
        for j in range(ny):
            v, v0, v1 = ins[i, j], ins[im, j], ins[ip, j]
            w0, w1 = ins[i, max(j - 1, 0)], ins[i, min(j + 1, ny - 1)]
            dil[i, j] = v | v0 | v1 | w0 | w1
            ero[i, j] = v & v0 & v1 & w0 & w1


@njit(cache=True, nogil=True)
def _inside_rows(xs, ys, a, b):
    """ins[i, j]: (xs[i], ys[j]) inside the polygons (even-odd), row by row. An edge crosses row y when
    (ay > y) != (by > y), i.e. lo <= y < hi for lo, hi = its ends' min and max (one end NaN: lo = -inf
    and hi the other; both: never): with ys increasing (no NaN) the rows an edge crosses are the range
    [searchsorted(ys, lo), searchsorted(ys, hi)), so each row's crossings are gathered from the edges'
    ranges (counting sort) instead of testing every edge on every row. Each crossing's abscissa is the
    same number, and a row's decisions do not depend on the order of its crossings (sorted, or counted)."""
    nx, ny, m = xs.shape[0], ys.shape[0], a.shape[0]
    ins = np.zeros((nx, ny), dtype=np.bool_)
    if m == 0 or ny == 0:
        return ins
    sweep = not np.isnan(ys[0])
    for j in range(1, ny):
        if not ys[j] >= ys[j - 1]:
            sweep = False
            break
    xinc = nx == 0 or not np.isnan(xs[0])
    for i in range(1, nx):
        if not xs[i] >= xs[i - 1]:
            xinc = False
            break
    xc = np.empty(m)
    if sweep:
        j0 = np.empty(m, dtype=np.int64)
        j1 = np.empty(m, dtype=np.int64)
        cnt = np.zeros(ny + 1, dtype=np.int64)
        for e in range(m):
            ay, by = a[e, 1], b[e, 1]
            if np.isnan(ay):
                lo, hi = -np.inf, by
            elif np.isnan(by):
                lo, hi = -np.inf, ay
            else:
                lo, hi = min(ay, by), max(ay, by)
            if np.isnan(hi):
                j0[e], j1[e] = 0, 0
                continue
            r0, r1 = _ss_left(ys, lo), _ss_left(ys, hi)
            j0[e], j1[e] = r0, r1
            if r1 > r0:
                cnt[r0] += 1
                cnt[r1] -= 1
        off = np.empty(ny + 1, dtype=np.int64)     # row j's edges: slots off[j]:off[j + 1]
        off[0] = 0
        run = 0
        for j in range(ny):
            run += cnt[j]
            off[j + 1] = off[j] + run
        fill = off[:ny].copy()
        eid = np.empty(max(off[ny], 1), dtype=np.int64)
        for e in range(m):
            for j in range(j0[e], j1[e]):
                eid[fill[j]] = e
                fill[j] += 1
    for j in range(ny):
        y = ys[j]
        k = 0
        finite = True
        if sweep:
            for s in range(off[j], off[j + 1]):
                e = eid[s]
                ay, by = a[e, 1], b[e, 1]
                c = a[e, 0] + (y - ay) * (b[e, 0] - a[e, 0]) / (by - ay)
                xc[k] = c
                k += 1
                finite = finite and not np.isnan(c)
        else:
            for e in range(m):
                ay, by = a[e, 1], b[e, 1]
                if (ay > y) != (by > y):
                    c = a[e, 0] + (y - ay) * (b[e, 0] - a[e, 0]) / (by - ay)
                    xc[k] = c
                    k += 1
                    finite = finite and not np.isnan(c)
        if k == 0:
            continue
        if finite:
            for q in range(1, k):       # insertion sort (a few crossings per row)
                v = xc[q]
                r = q - 1
                while r >= 0 and xc[r] > v:
                    xc[r + 1] = xc[r]
                    r -= 1
                xc[r + 1] = v
            if xinc:    # xs increasing: the count of crossings <= x by a walk (searchsorted's, side right)
                p = 0
                for i in range(nx):
                    x = xs[i]
                    while p < k and xc[p] <= x:
                        p += 1
                    ins[i, j] = (k - p) % 2 == 1
            else:
                srt = xc[:k]
                for i in range(nx):
                    x = xs[i]
                    if not np.isnan(x):
                        # crossings with x < xc: those after the last xc <= x
                        ins[i, j] = (k - _ss_right(srt, x)) % 2 == 1
        else:
            for i in range(nx):
                x = xs[i]
                c = 0
                for q in range(k):
                    if x < xc[q]:
                        c += 1
                ins[i, j] = c % 2 == 1
    return ins


@njit(cache=True, nogil=True)
def cell_surface_kernel(op, pu, pv, ku, kv, pw, rational, us, vs, ia, ib, flags, bary, uv, p, screen, out_f, out_b,
                        out_b2, out_d):
    """The surface work of `face._CellCache` and `face.refine_cells` in one compiled function (one copy of
    the surface kernels compiled: the cold start), every surface point and distance as
    `_surface_distance1` (`surface_distance`, `NurbsSurface.evaluate`) computes it:

    op 0, cells (ki, kj) = (ia, ib) of the grid us x vs: uv (n, 5, 2) the four corners (u0 v0, u1 v0,
    u1 v1, u0 v1) and the centre, p (n, 5, 3) their points (each grid node evaluated once), out_d (n, 2)
    the two diagonals' midpoints' distances (one step from the centre), as the numpy code computed them.

    op 1, the deviation of the split cells rows = ia (uv, p: the cache's): the largest `surface_distance`
    (2 Gauss-Newton steps) of their two triangles' sample points into out_f (np.max: NaN if one is NaN).
    Cell rows[c] is split along (0, 2) if flags[c] (triangles 0 1 2, 0 2 3), else along (1, 3) (triangles
    0 1 3, 1 2 3); the sample points as np.einsum("bk,nskd->nsbd", bary, ...) computes them. With
    screen > 0, a sample within `screen` of the surface point at its interpolated parameters takes no
    steps: that start distance bounds its value (`surface_distance` keeps the smallest distance met,
    the start one included). A cell over the screen gets its exact value (the samples left at their
    bounds are below the screen, so below the largest); a cell within it the largest of its bounds and
    values (out_b[c] True): an upper bound of its deviation within the screen, enough where only "at
    most screen" counts.

    op 2, `face._side_bulge` of the cells (bi, bj) = (ia, ib): whether each gets a u mid-line (out_b:
    su >= 0.5 sv) and a v one (out_b2: sv >= 0.5 su), as refine_cells decides it."""
    u_lo, u_hi = ku[pu], ku[ku.shape[0] - pu - 1]
    v_lo, v_hi = kv[pv], kv[kv.shape[0] - pv - 1]
    ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl = _point_scratch(pu, pv, pw.shape[2])
    res = np.empty((3, 3))
    two = np.full(1, 2, dtype=np.int64)[0]      # run-time values (no compiled version per literal)
    one = two - 1
    zero = two - two
    nb = bary.shape[0]
    n = ia.shape[0]
    if op == 0:
        # the grid's nodes are corners of up to four cells: each evaluated once (the same point each time),
        # all in one `_points0` call (as `_surface_distance1` with steps = 0 computes them)
        gid = np.full((us.shape[0], vs.shape[0]), -1, dtype=np.int64)
        q = np.empty((4 * n, 2))
        m = 0
        for c in range(n):
            u0, u1, v0, v1 = us[ia[c]], us[ia[c] + 1], vs[ib[c]], vs[ib[c] + 1]
            uv[c, 0, 0], uv[c, 0, 1] = u0, v0
            uv[c, 1, 0], uv[c, 1, 1] = u1, v0
            uv[c, 2, 0], uv[c, 2, 1] = u1, v1
            uv[c, 3, 0], uv[c, 3, 1] = u0, v1
            uv[c, 4, 0], uv[c, 4, 1] = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
            for k in range(4):
                gi = ia[c] + (1 if k == 1 or k == 2 else 0)
                gj = ib[c] + (1 if k >= 2 else 0)
                if gid[gi, gj] < 0:
                    gid[gi, gj] = m
                    q[m, 0], q[m, 1] = uv[c, k, 0], uv[c, k, 1]
                    m += 1
        node = np.empty((m, 3))
        _points0(pu, pv, ku, kv, pw, rational, q[:m], node)
        for c in range(n):
            for k in range(4):
                g = gid[ia[c] + (1 if k == 1 or k == 2 else 0), ib[c] + (1 if k >= 2 else 0)]
                for q_ in range(3):
                    p[c, k, q_] = node[g, q_]
        # the centre once with its derivatives: its point (the position `_surface_point01` computes
        # with nd = 1 is nd = 0's, the same operations) and the first step of both diagonals' distances,
        # `_surface_distance1` (one step) from there with the same operations: the start evaluation each
        # of the two calls made (and the centre's own) done once; the steps' ends in one `_points0` call
        st = np.empty((2 * n, 2))
        sxd = np.empty((2 * n, 4))
        for c in range(n):
            uc0, vc0 = uv[c, 4, 0], uv[c, 4, 1]
            _surface_point01(pu, pv, ku, kv, pw, rational, min(max(uc0, u_lo), u_hi), min(max(vc0, v_lo), v_hi),
                             one, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, res)
            c0, c1, c2 = res[0, 0], res[0, 1], res[0, 2]
            p[c, 4, 0], p[c, 4, 1], p[c, 4, 2] = c0, c1, c2
            su0, su1, su2 = res[1, 0], res[1, 1], res[1, 2]
            sv0, sv1, sv2 = res[2, 0], res[2, 1], res[2, 2]
            ga = su0 * su0 + su1 * su1 + su2 * su2
            gb = su0 * sv0 + su1 * sv1 + su2 * sv2
            gc = sv0 * sv0 + sv1 * sv1 + sv2 * sv2
            det = ga * gc - gb * gb
            solve = np.isfinite(det) and det > 1e-12 * max(ga * gc, 1e-300)
            for h in range(2):
                i0, i1 = (0, 2) if h == 0 else (1, 3)
                x0 = 0.5 * (p[c, i0, 0] + p[c, i1, 0])
                x1 = 0.5 * (p[c, i0, 1] + p[c, i1, 1])
                x2 = 0.5 * (p[c, i0, 2] + p[c, i1, 2])
                r0, r1, r2 = x0 - c0, x1 - c1, x2 - c2
                bd = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
                ru = su0 * r0 + su1 * r1 + su2 * r2
                rv = sv0 * r0 + sv1 * r1 + sv2 * r2
                if solve:
                    un = min(max(uc0 + (gc * ru - gb * rv) / det, u_lo), u_hi)
                    vn = min(max(vc0 + (ga * rv - gb * ru) / det, v_lo), v_hi)
                else:
                    un = min(max(uc0, u_lo), u_hi)
                    vn = min(max(vc0, v_lo), v_hi)
                st[2 * c + h, 0], st[2 * c + h, 1] = un, vn
                sxd[2 * c + h, 0], sxd[2 * c + h, 1], sxd[2 * c + h, 2], sxd[2 * c + h, 3] = x0, x1, x2, bd
        ends = np.empty((2 * n, 3))
        _points0(pu, pv, ku, kv, pw, rational, st, ends)
        for c in range(n):
            for h in range(2):
                e = 2 * c + h
                r0, r1, r2 = sxd[e, 0] - ends[e, 0], sxd[e, 1] - ends[e, 1], sxd[e, 2] - ends[e, 2]
                dist = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
                bd = sxd[e, 3]
                out_d[c, h] = dist if dist < bd else bd
        return
    if op == 2:
        q8 = np.empty((8, 2))
        pc = np.empty((4, 3))
        dd = np.empty(4)
        for c in range(n):
            u0, u1, v0, v1 = us[ia[c]], us[ia[c] + 1], vs[ib[c]], vs[ib[c] + 1]
            um, vm = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
            q8[0, 0], q8[0, 1] = u0, v0
            q8[1, 0], q8[1, 1] = u1, v0
            q8[2, 0], q8[2, 1] = u1, v1
            q8[3, 0], q8[3, 1] = u0, v1
            q8[4, 0], q8[4, 1] = um, v0
            q8[5, 0], q8[5, 1] = um, v1
            q8[6, 0], q8[6, 1] = u0, vm
            q8[7, 0], q8[7, 1] = u1, vm
            for k in range(4):
                _surface_distance1(pu, pv, ku, kv, pw, rational, q8[k, 0], q8[k, 1], 0.0, 0.0, 0.0, zero,
                                   u_lo, u_hi, v_lo, v_hi, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp,
                                   skl, res)
                for q in range(3):
                    pc[k, q] = res[0, q]
            for h in range(4):
                # side midpoints (0, 1), (3, 2), (0, 3), (1, 2) from (um v0, um v1, u0 vm, u1 vm)
                i0, i1 = (0, 1) if h == 0 else ((3, 2) if h == 1 else ((0, 3) if h == 2 else (1, 2)))
                dd[h] = _surface_distance1(pu, pv, ku, kv, pw, rational, q8[4 + h, 0], q8[4 + h, 1],
                                           0.5 * (pc[i0, 0] + pc[i1, 0]), 0.5 * (pc[i0, 1] + pc[i1, 1]),
                                           0.5 * (pc[i0, 2] + pc[i1, 2]), one, u_lo, u_hi, v_lo, v_hi, ndu_u, ndu_v,
                                           a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, res)
            su_ = _nanmax2(dd[0], dd[1])
            sv_ = _nanmax2(dd[2], dd[3])
            out_b[c] = su_ >= 0.5 * sv_
            out_b2[c] = sv_ >= 0.5 * su_
        return
    ns = 2 * nb
    # the two triangles share the split diagonal: its midpoint's sample in the second triangle (kd) is
    # the first's (ko) where their parameters and points have the same bits (the same sample: the same
    # distance, which the maxima below already hold): per split, the bary rows of the midpoints of the
    # triangles' edges (t0, t2) and (t0, t1) (main split, corners 0 2), (t1, t2) and (t0, t2) (the other)
    e01 = e02 = e12 = -1
    for b in range(nb):
        if bary[b, 0] == 0.5 and bary[b, 1] == 0.5 and bary[b, 2] == 0.0:
            e01 = b
        elif bary[b, 0] == 0.5 and bary[b, 1] == 0.0 and bary[b, 2] == 0.5:
            e02 = b
        elif bary[b, 0] == 0.0 and bary[b, 1] == 0.5 and bary[b, 2] == 0.5:
            e12 = b
    # the other edge midpoints are the midpoints of the cell's sides, samples of the neighbour cell too:
    # each (parameters and point, bit for bit) evaluated once per call, its surface point's row and its
    # distance kept in a hash table (keys: the parameters' bits; the point's bits compared too); hs bit 1:
    # hq[t] the row of its surface point in pq, bit 2: hv[t] the distance, 4: in use
    side = np.zeros(ns, dtype=np.bool_)
    cap = 16
    while cap < 8 * n:
        cap *= 2
    hk = np.empty((cap, 2), dtype=np.int64)
    hx = np.empty((cap, 3))
    hv = np.empty(cap)
    hq = np.empty(cap, dtype=np.int64)
    hs = np.zeros(cap, dtype=np.int64)
    # pass 1: every cell's samples (rows c * ns + k of su, sx), their hash slots (st_: -1 none, -2 the
    # skipped second diagonal midpoint) and, with screen > 0, the row in pq of the surface point at
    # their parameters (sq: -1 the centre's, p[r, 4]); the points to evaluate in one `_points0` call
    su = np.empty((n * ns, 2))
    sx = np.empty((n * ns, 3))
    sub = su.view(np.int64)
    st_ = np.empty(n * ns, dtype=np.int64)
    sq = np.empty(n * ns if screen > 0 else 0, dtype=np.int64)
    pq = np.empty((n * ns if screen > 0 else 0, 2))
    m = 0
    for c in range(n):
        r = ia[c]
        o = c * ns
        ko, kd = (e02, e01) if flags[c] else (e12, e02)
        if ko >= 0 and kd >= 0:
            kd += nb
        else:
            ko = kd = -1
        for k in range(ns):
            side[k] = False
        for s in range(2):
            for b in (e01, e12, e02):
                if b >= 0 and s * nb + b != ko and s * nb + b != kd:
                    side[s * nb + b] = True
        for s in range(2):
            if flags[c]:
                t0, t1, t2 = (0, 1, 2) if s == 0 else (0, 2, 3)
            else:
                t0, t1, t2 = (0, 1, 3) if s == 0 else (1, 2, 3)
            for b in range(nb):
                k = o + s * nb + b
                for q in range(2):
                    su[k, q] = (bary[b, 0] * uv[r, t0, q] + bary[b, 1] * uv[r, t1, q]) + bary[b, 2] * uv[r, t2, q]
                for q in range(3):
                    sx[k, q] = (bary[b, 0] * p[r, t0, q] + bary[b, 1] * p[r, t1, q]) + bary[b, 2] * p[r, t2, q]
        skip = kd >= 0
        if skip:
            for q in range(2):
                skip = skip and _same_bits(su[o + kd, q], su[o + ko, q])
            for q in range(3):
                skip = skip and _same_bits(sx[o + kd, q], sx[o + ko, q])
        for k_ in range(ns):
            k = o + k_
            if skip and k_ == kd:
                st_[k] = -2
                continue
            t = -1
            if side[k_]:
                ub, vb = sub[k, 0], sub[k, 1]
                t = _pair_hash(ub, vb) & (cap - 1)
                while hs[t] != 0:
                    if (hk[t, 0] == ub and hk[t, 1] == vb and _same_bits(hx[t, 0], sx[k, 0])
                            and _same_bits(hx[t, 1], sx[k, 1]) and _same_bits(hx[t, 2], sx[k, 2])):
                        break
                    t = (t + 1) & (cap - 1)
                if hs[t] == 0:
                    hk[t, 0], hk[t, 1] = ub, vb
                    hx[t, 0], hx[t, 1], hx[t, 2] = sx[k, 0], sx[k, 1], sx[k, 2]
                    hs[t] = 4
            st_[k] = t
            if screen > 0:
                if t >= 0 and hs[t] & 1:
                    sq[k] = hq[t]
                elif (k_ == ko or k_ == kd) and _same_bits(su[k, 0], uv[r, 4, 0]) and _same_bits(su[k, 1], uv[r, 4, 1]):
                    # the diagonal's midpoint at the centre's parameters (bit for bit): the surface point
                    # there is the centre's, p[r, 4] (op 0 evaluated it at the same clipped parameters;
                    # the position nd = 1 computes is nd = 0's)
                    sq[k] = -1
                else:
                    pq[m, 0], pq[m, 1] = su[k, 0], su[k, 1]
                    sq[k] = m
                    if t >= 0:
                        hq[t] = m
                        hs[t] |= 1
                    m += 1
    # the start points (`_surface_distance1` with steps = 0: `_points0` computes them with the same operations)
    px = np.empty((m, 3))
    if m > 0:
        _points0(pu, pv, ku, kv, pw, rational, pq[:m], px)
    # the distances (`_surface_distance1` with steps = 2) written out below: scratch, both knot vectors in
    # one array (no array variable per sample)
    pm = pu if pu >= pv else pv
    wn = np.empty((pm + 1, pm + 1))
    wl = np.empty(pm + 1)
    wr = np.empty(pm + 1)
    dimw = pw.shape[2]
    kk = np.empty(ku.shape[0] + kv.shape[0])
    kk[:ku.shape[0]] = ku
    kk[ku.shape[0]:] = kv
    b2 = np.empty((2, 2, pm + 1))
    sp2 = np.empty(2, dtype=np.int64)
    tw2 = np.empty((2, pu + 1, dimw))
    sk3 = np.empty((3, dimw))
    rs3 = np.empty((3, 3))
    for c in range(n):
        r = ia[c]
        o = c * ns
        bnd = 0.0
        ex = 0.0
        for k_ in range(ns):
            k = o + k_
            t = st_[k]
            if t == -2:
                continue
            if screen > 0:
                # the start distance as `_surface_distance1` (steps = 0) computes it
                j = sq[k]
                if j < 0:
                    r0, r1, r2 = sx[k, 0] - p[r, 4, 0], sx[k, 1] - p[r, 4, 1], sx[k, 2] - p[r, 4, 2]
                else:
                    r0, r1, r2 = sx[k, 0] - px[j, 0], sx[k, 1] - px[j, 1], sx[k, 2] - px[j, 2]
                d0 = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
                if d0 <= screen:
                    if d0 > bnd:
                        bnd = d0
                    continue
            if t >= 0 and hs[t] & 2:
                dk = hv[t]
            else:
                # `_surface_distance1` with steps = 2 written out (the same operations in the same order:
                # `_span`, `_ders_basis` with nd = 1 / 0, `_surface_point01`'s sums, the Gauss-Newton steps)
                x0_, x1_, x2_ = sx[k, 0], sx[k, 1], sx[k, 2]
                gu_, gv_ = su[k, 0], su[k, 1]
                dk = np.inf
                for it in range(3):
                    nd = 1 if it < 2 else 0
                    for ax in range(2):
                        t_ = min(max(gu_, u_lo), u_hi) if ax == 0 else min(max(gv_, v_lo), v_hi)
                        o_ = 0 if ax == 0 else ku.shape[0]
                        pp = pu if ax == 0 else pv
                        nc = (ku.shape[0] if ax == 0 else kv.shape[0]) - pp - 1
                        if t_ >= kk[o_ + nc]:
                            spn = nc - 1
                            while spn > pp and kk[o_ + spn] >= kk[o_ + nc]:
                                spn -= 1
                        else:
                            lo, hi = pp, nc
                            while hi - lo > 1:
                                mid = (lo + hi) // 2
                                if t_ < kk[o_ + mid]:
                                    hi = mid
                                else:
                                    lo = mid
                            spn = lo
                        wn[0, 0] = 1.0
                        for j in range(1, pp + 1):
                            wl[j] = t_ - kk[o_ + spn + 1 - j]
                            wr[j] = kk[o_ + spn + j] - t_
                            saved = 0.0
                            for rr in range(j):
                                wn[j, rr] = wr[rr + 1] + wl[j - rr]
                                temp = wn[rr, j - 1] / wn[j, rr]
                                wn[rr, j] = saved + wr[rr + 1] * temp
                                saved = wl[j - rr] * temp
                            wn[j, j] = saved
                        for j in range(pp + 1):
                            b2[ax, 0, j] = wn[j, pp]
                        if nd == 1:
                            for rr in range(pp + 1):
                                if pp == 0:
                                    b2[ax, 1, rr] = 0.0
                                    continue
                                d_ = 0.0
                                if rr >= 1:
                                    d_ = (1.0 / wn[pp, rr - 1]) * wn[rr - 1, pp - 1]
                                if rr <= pp - 1:
                                    d_ += ((-1.0) / wn[pp, rr]) * wn[rr, pp - 1]
                                b2[ax, 1, rr] = d_ * pp
                        sp2[ax] = spn
                    spu, spv = sp2[0], sp2[1]
                    for l_ in range(nd + 1):
                        for rr in range(pu + 1):
                            for dd_ in range(dimw):
                                tw2[l_, rr, dd_] = 0.0
                            for ss in range(pv + 1):
                                bb_ = b2[1, l_, ss]
                                if bb_ != 0.0:
                                    row = spu - pu + rr
                                    col = spv - pv + ss
                                    for dd_ in range(dimw):
                                        tw2[l_, rr, dd_] += bb_ * pw[row, col, dd_]
                    for dd_ in range(dimw):
                        acc = 0.0
                        for rr in range(pu + 1):
                            acc += b2[0, 0, rr] * tw2[0, rr, dd_]
                        sk3[0, dd_] = acc
                    if nd == 1:
                        for dd_ in range(dimw):
                            acc = 0.0
                            for rr in range(pu + 1):
                                acc += b2[0, 0, rr] * tw2[1, rr, dd_]
                            sk3[2, dd_] = acc
                            acc = 0.0
                            for rr in range(pu + 1):
                                acc += b2[0, 1, rr] * tw2[0, rr, dd_]
                            sk3[1, dd_] = acc
                    if rational:
                        w0 = sk3[0, dimw - 1]
                        for dd_ in range(3):
                            rs3[0, dd_] = sk3[0, dd_] / w0
                        if nd == 1:
                            for dd_ in range(3):
                                val = sk3[2, dd_]
                                val -= 1.0 * sk3[2, dimw - 1] * rs3[0, dd_]
                                rs3[2, dd_] = val / w0
                                val = sk3[1, dd_]
                                val -= 1.0 * sk3[1, dimw - 1] * rs3[0, dd_]
                                val -= 1.0 * 0.0
                                rs3[1, dd_] = val / w0
                    else:
                        for dd_ in range(3):
                            rs3[0, dd_] = sk3[0, dd_]
                            if nd == 1:
                                rs3[2, dd_] = sk3[2, dd_]
                                rs3[1, dd_] = sk3[1, dd_]
                    r0, r1, r2 = x0_ - rs3[0, 0], x1_ - rs3[0, 1], x2_ - rs3[0, 2]
                    dist = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
                    if it == 0 or dist < dk:
                        dk = dist
                    if it == 2:
                        break
                    g0, g1, g2 = rs3[1, 0], rs3[1, 1], rs3[1, 2]
                    h0, h1, h2 = rs3[2, 0], rs3[2, 1], rs3[2, 2]
                    a_ = g0 * g0 + g1 * g1 + g2 * g2
                    bq = g0 * h0 + g1 * h1 + g2 * h2
                    c_ = h0 * h0 + h1 * h1 + h2 * h2
                    ru = g0 * r0 + g1 * r1 + g2 * r2
                    rv = h0 * r0 + h1 * r1 + h2 * r2
                    det = a_ * c_ - bq * bq
                    if np.isfinite(det) and det > 1e-12 * max(a_ * c_, 1e-300):
                        gu_ = min(max(gu_ + (c_ * ru - bq * rv) / det, u_lo), u_hi)
                        gv_ = min(max(gv_ + (a_ * rv - bq * ru) / det, v_lo), v_hi)
                    else:
                        gu_ = min(max(gu_, u_lo), u_hi)
                        gv_ = min(max(gv_, v_lo), v_hi)
                if t >= 0:
                    hv[t] = dk
                    hs[t] |= 2
            if np.isnan(dk) or np.isnan(ex):
                ex = np.nan
            elif k_ == 0 or dk > ex:
                ex = dk
        if screen > 0 and not (np.isnan(ex) or ex > screen):
            out_f[c] = bnd if bnd >= ex else ex
            out_b[c] = True
        else:
            out_f[c] = ex
            out_b[c] = False


@njit(cache=True, nogil=True, inline="always")
def _nanmax2(a, b):
    """np.maximum(a, b) (NaN if either is NaN)."""
    if np.isnan(a) or np.isnan(b):
        return np.nan
    return a if a >= b else b


@njit(cache=True, nogil=True)
def cell_check_kernel(d, p, devs, bounds, rows, tolerance, exact, main, dev, diag, diag_max, side_u, side_v):
    """`face._CellCache.deviation` after the cells are known, per cell c of row rows[c]: the split
    (`_split_from_fits` of its midpoint distances d[row] with the face's preference, `_prefer_main`:
    the sums over the cells in order, as numpy sums a column), its deviation from devs[row] (or,
    unless `exact`, a bound within the tolerance from bounds[row]; NaN: not yet computed) and the
    lengths of `face._cell_lengths` (the same operations in the same order)."""
    t0 = 0.0
    t1 = 0.0
    for c in range(rows.shape[0]):
        t0 += d[rows[c], 0]
        t1 += d[rows[c], 1]
    pref = t0 <= t1
    for c in range(rows.shape[0]):
        r = rows[c]
        d_main, d_anti = d[r, 0], d[r, 1]
        if pref:
            d_pref, d_other = d_main, d_anti
        else:
            d_pref, d_other = d_anti, d_main
        switch = (((d_pref > 0.5 * tolerance) and (d_other < 0.8 * d_pref))
                  or ((d_pref > 0.9 * tolerance) and (d_other < 0.98 * d_pref)))
        m = (not pref) if switch else pref
        main[c] = m
        col = 0 if m else 1
        v = devs[r, col]
        if not exact and np.isnan(v) and bounds[r, col] <= tolerance:
            v = bounds[r, col]
        dev[c] = v
        # _cell_lengths: corners (0, 2), (1, 3) the diagonals, (0, 1), (3, 2) the u sides, (0, 3), (1, 2) the v sides
        n0 = _corner_dist(p, r, 0, 2)
        n1 = _corner_dist(p, r, 1, 3)
        diag[c] = n0 if m else n1
        diag_max[c] = _nanmax2(n0, n1)
        side_u[c] = _nanmax2(_corner_dist(p, r, 0, 1), _corner_dist(p, r, 3, 2))
        side_v[c] = _nanmax2(_corner_dist(p, r, 0, 3), _corner_dist(p, r, 1, 2))


@njit(cache=True, nogil=True)
def cache_cells_kernel(table, iu, iv, pu, pv, ku, kv, pw, rational, us, vs, bary, uv, p, d, n0):
    """`face._CellCache._cells` after the interval ids: the rows table[iu[a], iv[b]] of the grid's cells
    (a, b raveled, meshgrid(..., indexing="ij")); the new ones (-1) get rows n0, n0 + 1, ... in that order,
    their points and midpoint distances (`cell_surface_kernel` op 0) and their table entries. Returns
    (rows, n): n the rows in use after, or -(the count of new cells) with nothing done when the buffers
    (uv, p, d) hold fewer than n0 + that count rows."""
    nu_, nv_ = iu.shape[0], iv.shape[0]
    rows = np.empty(nu_ * nv_, dtype=np.int64)
    cnt = 0
    for a in range(nu_):
        for b in range(nv_):
            r = table[iu[a], iv[b]]
            rows[a * nv_ + b] = r
            if r < 0:
                cnt += 1
    if cnt == 0:
        return rows, n0
    if n0 + cnt > uv.shape[0]:
        return rows, -cnt
    ki = np.empty(cnt, dtype=np.int64)
    kj = np.empty(cnt, dtype=np.int64)
    q = 0
    for idx in range(nu_ * nv_):
        if rows[idx] < 0:
            ki[q] = idx // nv_
            kj[q] = idx % nv_
            q += 1
    op = np.zeros(1, dtype=np.int64)[0]    # op 0 as a run-time value (no compiled version per literal)
    cell_surface_kernel(op, pu, pv, ku, kv, pw, rational, us, vs, ki, kj, np.empty(0, dtype=np.bool_), bary,
                        uv[n0:n0 + cnt], p[n0:n0 + cnt], 0.0, np.empty(0), np.empty(0, dtype=np.bool_),
                        np.empty(0, dtype=np.bool_), d[n0:n0 + cnt])
    q = 0
    for idx in range(nu_ * nv_):
        if rows[idx] < 0:
            rows[idx] = n0 + q
            table[iu[ki[q]], iv[kj[q]]] = n0 + q
            q += 1
    return rows, n0 + cnt


#: IR-inlined twins of the cell kernels, inlined once each (`cache_cells_kernel` into `grid_cells_kernel`,
#: `grid_cells_kernel` and `cell_deviation_kernel` into `refine_cells_kernel`): a compiled call links the
#: callee's library, `cell_surface_kernel`'s body with it, into the caller's, where LLVM optimizes and emits
#: it again (the cold compile paid that body once per caller: 5 times)
_cache_cells_i = njit(cache=True, nogil=True, inline="always")(cache_cells_kernel.py_func)


@njit(cache=True, nogil=True)
def cell_deviation_kernel(pu, pv, ku, kv, pw, rational, d, p, uv, devs, bounds, rows, tolerance, exact, bary, main,
                          dev, diag, diag_max, side_u, side_v, lin):
    """`face._CellCache.deviation` in one call: `cell_check_kernel`, then the deviation of the cells it
    left NaN (`cell_surface_kernel` op 1, screened unless `exact`), kept in the cache's devs (exact
    values) or bounds (values within the screen) and put into dev.

    lin = (e, noise), e >= 0 for a bilinear patch (`face._CellCache._bilinear`): a cell of extents du, dv
    whose bound e du dv + noise of its samples' start distances is within the screen gets that bound
    (a bound within the screen, as the screened kernel would give) without its samples evaluated."""
    cell_check_kernel(d, p, devs, bounds, rows, tolerance, exact, main, dev, diag, diag_max, side_u, side_v)
    screened = not exact and tolerance > 0
    if screened and lin[0] >= 0.0:
        for c in range(rows.shape[0]):
            if np.isnan(dev[c]):
                rc = rows[c]
                bb = lin[0] * ((uv[rc, 2, 0] - uv[rc, 0, 0]) * (uv[rc, 2, 1] - uv[rc, 0, 1])) + lin[1]
                if bb <= tolerance:
                    bounds[rc, 0 if main[c] else 1] = bb
                    dev[c] = bb
    k = 0
    for c in range(rows.shape[0]):
        if np.isnan(dev[c]):
            k += 1
    if k == 0:
        return
    r = np.empty(k, dtype=np.int64)
    m = np.empty(k, dtype=np.bool_)
    at = np.empty(k, dtype=np.int64)
    k = 0
    for c in range(rows.shape[0]):
        if np.isnan(dev[c]):
            r[k], m[k], at[k] = rows[c], main[c], c
            k += 1
    got = np.empty(k)
    bounded = np.empty(k, dtype=np.bool_)
    no_f = np.empty(0)
    op = np.ones(1, dtype=np.int64)[0]     # op 1 as a run-time value (no compiled version per literal)
    cell_surface_kernel(op, pu, pv, ku, kv, pw, rational, no_f, no_f, r, np.empty(0, dtype=np.int64), m, bary, uv, p,
                        0.0 if exact else tolerance, got, bounded, np.empty(0, dtype=np.bool_), np.empty((0, 2)))
    for q in range(k):
        col = 0 if m[q] else 1
        if bounded[q]:
            bounds[r[q], col] = got[q]
        else:
            devs[r[q], col] = got[q]
        dev[at[q]] = got[q]


_cell_deviation_i = njit(cache=True, nogil=True, inline="always")(cell_deviation_kernel.py_func)


@njit(cache=True, nogil=True, inline="always")
def _corner_dist(p, r, i, j):
    """np.sqrt(np.add.reduce(q * q)) of q = p[r, j] - p[r, i] (the sum left to right)."""
    q0 = p[r, j, 0] - p[r, i, 0]
    q1 = p[r, j, 1] - p[r, i, 1]
    q2 = p[r, j, 2] - p[r, i, 2]
    return np.sqrt((q0 * q0 + q1 * q1) + q2 * q2)


@njit(cache=True, nogil=True)
def line_net_kernel(pv, kv, lines, pw, out):
    """out[l, i] = sum_s N_s(lines[l]) pw[i, span - pv + s] (zero basis values skipped): the control points of
    the iso-line v = lines[l], the v contraction `_iso_point` does per point for axis 0, with the same
    operations in the same order (so its points are the same numbers)."""
    n_lines = lines.shape[0]
    nv_ctrl = kv.shape[0] - pv - 1
    lspan = np.empty((1, n_lines), dtype=np.int64)
    lbasis = np.empty((1, n_lines, pv + 1))
    _moving_basis(pv, kv, nv_ctrl, lines.reshape(1, n_lines), lspan, lbasis)
    for l in range(n_lines):
        sv = lspan[0, l]
        for i in range(pw.shape[0]):
            for dd_ in range(pw.shape[2]):
                out[l, i, dd_] = 0.0
            for s_ in range(pv + 1):
                bb = lbasis[0, l, s_]
                if bb != 0.0:
                    for dd_ in range(pw.shape[2]):
                        out[l, i, dd_] += bb * pw[i, sv - pv + s_, dd_]


@njit(cache=True, nogil=True)
def refine_round_kernel(op, dev, diag, diag_max, side_u, side_v, near, interior, has_polys, tolerance, max_edge,
                        aspect, min_across, local_fix, long, bi, bj, cu, cv, split_u, split_v):
    """One round of `face.refine_cells` after the cells' numbers (dev, diag, diag_max, side_u, side_v, grids
    (nu, nv)) and the trim band (near, interior) are known, with the same decisions, in two calls:

    op 0: dev and diag masked by the band in place (as refine_cells masks them), the cells to halve
    across their long side into `long`; returns (go, bi, bj): go False when nothing is to split, the
    bad cells (over the tolerance) in row-major order.
    op 1, with the bad cells' side bulges cu, cv (`cell_surface_kernel` op 2): split_u[i] / split_v[j],
    the columns / rows that get a mid-line; returns (go, -, -)."""
    nu, nv = dev.shape
    if op == 0:
        n_bad = 0
        any_long = False
        for i in range(nu):
            for j in range(nv):
                if has_polys:
                    if not near[i, j]:
                        dev[i, j] = 0.0
                        diag[i, j] = 0.0
                    elif not interior[i, j]:
                        diag[i, j] = diag_max[i, j]
                b = dev[i, j] > tolerance
                n_bad += b
                lg = (diag[i, j] > max_edge) and not b
                if aspect > 0 and not b and not lg:
                    a, c = side_u[i, j], side_v[i, j]
                    thin = False
                    if not (np.isnan(a) or np.isnan(c)):
                        mx = a if a >= c else c
                        mn = c if a >= c else a
                        if mn > 0:
                            r = mx / mn
                            thin = np.isfinite(r) and r > aspect
                    across = nu if a < c else nv
                    thin = thin and across >= min_across
                    if has_polys:
                        thin = thin and near[i, j]
                    lg = thin
                long[i, j] = lg
                any_long = any_long or lg
        obi = np.empty(n_bad, dtype=np.int64)
        obj = np.empty(n_bad, dtype=np.int64)
        k = 0
        for i in range(nu):
            for j in range(nv):
                if dev[i, j] > tolerance:
                    obi[k], obj[k] = i, j
                    k += 1
        return n_bad > 0 or any_long, obi, obj
    any_long = False
    for i in range(nu):
        for j in range(nv):
            any_long = any_long or long[i, j]
    for i in range(nu):
        split_u[i] = False
    for j in range(nv):
        split_v[j] = False
    n_bad = bi.shape[0]
    if n_bad:
        n_col = np.zeros(nu, dtype=np.int64)
        n_row = np.zeros(nv, dtype=np.int64)
        for i in range(nu):
            for j in range(nv):
                if near[i, j] or not has_polys:
                    n_col[i] += 1
                    n_row[j] += 1
        col_bad = np.zeros(nu, dtype=np.int64)
        row_bad = np.zeros(nv, dtype=np.int64)
        for k in range(n_bad):
            if cu[k]:
                col_bad[bi[k]] += 1
            if cv[k]:
                row_bad[bj[k]] += 1
        n_split = 0
        for k in range(n_bad):
            few = dev[bi[k], bj[k]] <= local_fix * tolerance
            lim_c = 0.25 * n_col[bi[k]]
            lim_r = 0.25 * n_row[bj[k]]
            if cu[k] and (not few or col_bad[bi[k]] >= (lim_c if lim_c > 2 else 2)):
                split_u[bi[k]] = True
                n_split += 1
            if cv[k] and (not few or row_bad[bj[k]] >= (lim_r if lim_r > 2 else 2)):
                split_v[bj[k]] = True
                n_split += 1
        if n_split == 0 and not any_long:
            return False, bi, bj
    for i in range(nu):
        for j in range(nv):
            if long[i, j]:
                if side_u[i, j] >= side_v[i, j]:
                    split_u[i] = True
                elif side_u[i, j] < side_v[i, j]:
                    split_v[j] = True
    return True, bi, bj


@njit(cache=True, nogil=True)
def inside_grids_kernel(lo, hi, a, b, rows, dil):
    """`face._inside_raster` of many faces: face f's raster dil[f] over the grid box lo[f], hi[f] (n x n
    points as `face._linspace` places them) of the polygon edges a[e] -> b[e], e in rows[f, 0]:rows[f, 1]
    (`inside_grid_kernel`, dilated: its dil alone)."""
    n = dil.shape[1]
    gu = np.empty(n)
    gv = np.empty(n)
    for f in range(lo.shape[0]):
        for axis in range(2):
            g = gu if axis == 0 else gv
            x0, x1 = lo[f, axis], hi[f, axis]
            step = (x1 - x0) / (n - 1)
            for k in range(n):
                if step == 0.0:     # as np.linspace for a zero (subnormal) step
                    g[k] = (k / (n - 1)) * (x1 - x0) + x0
                else:
                    g[k] = k * step + x0
            g[n - 1] = x1
        ins = _inside_rows(gu, gv, a[rows[f, 0]:rows[f, 1]], b[rows[f, 0]:rows[f, 1]])
        d = dil[f]
        for i in range(n):      # (| of bools: no branches)
            im, ip = max(i - 1, 0), min(i + 1, n - 1)
            for j in range(n):
                d[i, j] = ins[i, j] | ins[im, j] | ins[ip, j] | ins[i, max(j - 1, 0)] | ins[i, min(j + 1, n - 1)]


# the interval ids of `face._CellCache`: open addressing (linear probing) over (x0, x1) pairs, the table at
# most half full; keys (cap, 2) the pairs, ent (cap, 2) (id, hash), id -1 an empty slot
_H1 = 0x5851F42D4C957F2D
_H2 = 0x27D4EB2F165667C5


@njit(cache=True, nogil=True, inline="always")
def _pair_hash(ba, bb):
    """A hash (int64) of two floats' bit patterns."""
    h = ba * _H1 + bb * _H2
    return h ^ (h >> 29)


@njit(cache=True, nogil=True)
def _interval_ids(keys, ent, cnt, x, out):
    """out[k] = the id of the interval (x[k], x[k + 1]) (==, as a dict of float pairs: -0.0 is 0.0), new
    intervals get ids cnt, cnt + 1, ... in order. Returns (keys, ent, cnt) after (the table grown when
    needed: new arrays)."""
    m = x.shape[0] - 1
    cap = ent.shape[0]
    if 2 * (cnt + m) > cap:
        ncap = cap if cap >= 64 else 64
        while 2 * (cnt + m) > ncap:
            ncap *= 2
        nk = np.empty((ncap, 2))
        ne = np.full((ncap, 2), -1, dtype=np.int64)
        for s in range(cap):
            if ent[s, 0] >= 0:
                t = ent[s, 1] & (ncap - 1)
                while ne[t, 0] >= 0:
                    t = (t + 1) & (ncap - 1)
                nk[t, 0], nk[t, 1] = keys[s, 0], keys[s, 1]
                ne[t, 0], ne[t, 1] = ent[s, 0], ent[s, 1]
        keys, ent, cap = nk, ne, ncap
    xb = x.view(np.int64)
    for k in range(m):
        a, b = x[k], x[k + 1]
        h = _pair_hash(xb[k] if a != 0.0 else 0, xb[k + 1] if b != 0.0 else 0)
        t = h & (cap - 1)
        while True:
            if ent[t, 0] < 0:
                keys[t, 0], keys[t, 1] = a, b
                ent[t, 0], ent[t, 1] = cnt, h
                out[k] = cnt
                cnt += 1
                break
            if keys[t, 0] == a and keys[t, 1] == b:
                out[k] = ent[t, 0]
                break
            t = (t + 1) & (cap - 1)
    return keys, ent, cnt


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _grow_rows(uv, p, d, devs, bounds, n, cap):
    """The cell buffers with cap rows, the first n copied (devs, bounds NaN after them)."""
    nuv = np.empty((cap, 5, 2))
    np_ = np.empty((cap, 5, 3))
    nd = np.empty((cap, 2))
    ndev = np.full((cap, 2), np.nan)
    nb = np.full((cap, 2), np.nan)
    for r in range(n):
        for k in range(5):
            nuv[r, k, 0], nuv[r, k, 1] = uv[r, k, 0], uv[r, k, 1]
            np_[r, k, 0], np_[r, k, 1], np_[r, k, 2] = p[r, k, 0], p[r, k, 1], p[r, k, 2]
        for h in range(2):
            nd[r, h], ndev[r, h], nb[r, h] = d[r, h], devs[r, h], bounds[r, h]
    return nuv, np_, nd, ndev, nb


@njit(cache=True, nogil=True)
def grid_cells_kernel(hk_u, he_u, hk_v, he_v, nid, table, pu, pv, ku, kv, pw, rational, us, vs, bary, uv, p, d,
                      devs, bounds, n0):
    """`face._CellCache._cells` in one call: the grid's interval ids (`_interval_ids`, nid = the counts per
    direction, updated), the (u id, v id) -> row table grown to them, then `cache_cells_kernel` (the
    buffers uv, p, d, devs, bounds grown first when the new cells do not fit: capacity max(needed, 2 x,
    64) rows, devs and bounds NaN). Returns (hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, rows, n):
    the cache's arrays after (new ones where grown), the grid's rows, the rows in use."""
    iu = np.empty(us.shape[0] - 1, dtype=np.int64)
    iv = np.empty(vs.shape[0] - 1, dtype=np.int64)
    hk_u, he_u, cu = _interval_ids(hk_u, he_u, nid[0], us, iu)
    hk_v, he_v, cv = _interval_ids(hk_v, he_v, nid[1], vs, iv)
    nid[0], nid[1] = cu, cv
    tu, tv = table.shape
    if tu < cu or tv < cv:
        nt = np.full((cu if cu > 2 * tu else 2 * tu, cv if cv > 2 * tv else 2 * tv), -1, dtype=np.int64)
        for i in range(tu):
            for j in range(tv):
                nt[i, j] = table[i, j]
        table = nt
    new = 0
    for a in range(iu.shape[0]):        # (the count cache_cells_kernel finds: the buffers grown first)
        for b in range(iv.shape[0]):
            if table[iu[a], iv[b]] < 0:
                new += 1
    if n0 + new > uv.shape[0]:
        uv, p, d, devs, bounds = _grow_rows(uv, p, d, devs, bounds, n0, max(n0 + new, 2 * uv.shape[0], 64))
    rows, n = _cache_cells_i(table, iu, iv, pu, pv, ku, kv, pw, rational, us, vs, bary, uv, p, d, n0)
    return hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, rows, n


_grid_cells_i = njit(cache=True, nogil=True, inline="always")(grid_cells_kernel.py_func)


@njit(cache=True, nogil=True)
def _with_mids(x, split):
    """unique_values(np.concatenate((x, (0.5 * (x[:-1] + x[1:]))[split]))) of an increasing x, or an empty
    array when a midpoint is not within its interval (overflow, NaN: the caller falls back)."""
    m = x.shape[0]
    out = np.empty(m + split.shape[0])
    k = 0
    for i in range(m):
        if k == 0 or x[i] != out[k - 1]:
            out[k] = x[i]
            k += 1
        if i < m - 1 and split[i]:
            c = 0.5 * (x[i] + x[i + 1])
            if not (x[i] <= c and c <= x[i + 1]):
                return np.empty(0)
            if c != out[k - 1]:
                out[k] = c
                k += 1
    return out[:k].copy()


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _max0(a):
    """float(a.max(initial=0.0)) (NaN if one is NaN)."""
    mx = 0.0
    for v in a.ravel():
        if np.isnan(v):
            return np.nan
        if v > mx:
            mx = v
    return mx


@njit(cache=True, nogil=True)
def refine_cells_kernel(hk_u, he_u, hk_v, he_v, nid, table, pu, pv, ku, kv, pw, rational, bary, lin, uv, p, d, devs,
                        bounds, n0, us, vs, pa, pb, has_polys, tolerance, max_edge, aspect, min_across, local_fix,
                        max_cells, max_rounds):
    """`face.refine_cells` in one call, every round as `face._refine_cells_rounds` does it (the same kernels
    in the same order on the same numbers): the cells (`grid_cells_kernel`), their numbers
    (`cell_deviation_kernel`, screened), the trim band of the cell centres in the polygon edges pa -> pb
    (`inside_grid_kernel`), the decisions (`refine_round_kernel` op 0, `cell_surface_kernel` op 2,
    op 1) and the mid-lines (`_with_mids`).

    Returns (hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, n, us, vs, status, rounds, dev0, diag0,
    rows): the cache's arrays after; the grid; status 0: the grid is the last one checked, rows its
    cells' rows; 1: max_rounds rounds refined it (not checked since); 2: the grid has more than max_cells
    cells; 3: a grid not increasing, or a midpoint outside its interval (the caller runs the rounds itself);
    rounds: the rounds that added lines; dev0, diag0: the first grid's largest (masked) deviation and
    diagonal, as `np.max(..., initial=0.0)` (`_worst_cell_ratio`)."""
    two = np.full(1, 2, dtype=np.int64)[0]      # run-time values (no compiled version per literal)
    one = two - 1
    zero = two - two
    no = one < zero
    n = n0
    dev0 = 0.0
    diag0 = 0.0
    rows = np.empty(0, dtype=np.int64)
    no_b = np.empty(0, dtype=np.bool_)
    no_f = np.empty(0)
    no_uv = np.empty((0, 5, 2))
    no_p = np.empty((0, 5, 3))
    no_d = np.empty((0, 2))
    status = 1
    rounds = max_rounds
    for x in (us, vs):      # an increasing grid (unique_values keeps it as it is)
        for i in range(x.shape[0] - 1):
            if not x[i] < x[i + 1]:
                status = 3
    for round_ in range(max_rounds if status == 1 else 0):
        hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, rows, n = _grid_cells_i(
            hk_u, he_u, hk_v, he_v, nid, table, pu, pv, ku, kv, pw, rational, us, vs, bary, uv, p, d, devs, bounds, n)
        nu, nv = us.shape[0] - 1, vs.shape[0] - 1
        k = nu * nv
        main = np.empty(k, dtype=np.bool_)
        dev = np.empty((nu, nv))
        diag = np.empty((nu, nv))
        diag_max = np.empty((nu, nv))
        side_u = np.empty((nu, nv))
        side_v = np.empty((nu, nv))
        _cell_deviation_i(pu, pv, ku, kv, pw, rational, d, p, uv, devs, bounds, rows, tolerance, no, bary, main,
                          dev.reshape(k), diag.reshape(k), diag_max.reshape(k), side_u.reshape(k),
                          side_v.reshape(k), lin)
        near = np.zeros((nu, nv), dtype=np.bool_)
        interior = np.zeros((nu, nv), dtype=np.bool_)
        if has_polys:
            ci = np.empty(nu)
            cj = np.empty(nv)
            for i in range(nu):
                ci[i] = 0.5 * (us[i] + us[i + 1])
            for j in range(nv):
                cj[j] = 0.5 * (vs[j] + vs[j + 1])
            inside_grid_kernel(ci, cj, pa, pb, near, interior)
        split_u = np.empty(nu, dtype=np.bool_)
        split_v = np.empty(nv, dtype=np.bool_)
        long = np.empty((nu, nv), dtype=np.bool_)
        go, bi, bj = refine_round_kernel(zero, dev, diag, diag_max, side_u, side_v, near, interior, has_polys,
                                         tolerance, max_edge, aspect, min_across, local_fix, long, rows, rows, no_b,
                                         no_b, split_u, split_v)
        if round_ == 0:
            dev0 = _max0(dev)
            diag0 = _max0(diag)
        if go:
            cu = np.empty(bi.shape[0], dtype=np.bool_)
            cv = np.empty(bi.shape[0], dtype=np.bool_)
            if bi.shape[0]:
                cell_surface_kernel(two, pu, pv, ku, kv, pw, rational, us, vs, bi, bj, no_b, bary, no_uv, no_p, 0.0,
                                    no_f, cu, cv, no_d)
            go = refine_round_kernel(one, dev, diag, diag_max, side_u, side_v, near, interior, has_polys, tolerance,
                                     max_edge, aspect, min_across, local_fix, long, bi, bj, cu, cv, split_u,
                                     split_v)[0]
        if not go:
            status, rounds = 0, round_
            break
        nus = _with_mids(us, split_u)
        nvs = _with_mids(vs, split_v)
        if nus.shape[0] == 0 or nvs.shape[0] == 0:
            status, rounds = 3, round_
            break
        us, vs = nus, nvs
        if (us.shape[0] - 1) * (vs.shape[0] - 1) > max_cells:
            status, rounds = 2, round_ + 1
            break
    return hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, n, us, vs, status, rounds, dev0, diag0, rows


@njit(cache=True, nogil=True)
def _points0(pu, pv, ku, kv, pw, rational, q, out):
    """out[i] = the surface point at q[i] (clipped to the domain) as `_surface_distance1` with steps = 0
    computes it (`_span`, `_ders_basis` with nd = 0 and `_surface_point01`'s sums written out: the same
    operations in the same order), each parameter value's span and basis taken from a direct-mapped store
    where the same value (bit for bit) was met before in this call (a grid's nodes share their u and v
    values)."""
    u_lo, u_hi = ku[pu], ku[ku.shape[0] - pu - 1]
    v_lo, v_hi = kv[pv], kv[kv.shape[0] - pv - 1]
    nbs = 256
    pm = pu if pu >= pv else pv
    bss = np.full((2, nbs), -1, dtype=np.int64)
    bsx = np.empty((2, nbs))
    bsb = np.empty((2, nbs, pm + 1))
    wn = np.empty((pm + 1, pm + 1))
    wl = np.empty(pm + 1)
    wr = np.empty(pm + 1)
    dimw = pw.shape[2]
    tw = np.empty((pu + 1, dimw))
    sk = np.empty(dimw)
    qb = q.view(np.int64)
    s_u = s_v = 0
    kk = np.empty(ku.shape[0] + kv.shape[0])      # both knot vectors (no array variable per value)
    kk[:ku.shape[0]] = ku
    kk[ku.shape[0]:] = kv
    for i in range(q.shape[0]):
        for ax in range(2):
            x_ = q[i, ax]
            o_ = 0 if ax == 0 else ku.shape[0]
            pp = pu if ax == 0 else pv
            slot = _pair_hash(qb[i, ax], ax) & (nbs - 1)
            if not (bss[ax, slot] >= 0 and _same_bits(bsx[ax, slot], x_)):
                t_ = min(max(x_, u_lo), u_hi) if ax == 0 else min(max(x_, v_lo), v_hi)
                nc = (ku.shape[0] if ax == 0 else kv.shape[0]) - pp - 1
                if t_ >= kk[o_ + nc]:
                    spn = nc - 1
                    while spn > pp and kk[o_ + spn] >= kk[o_ + nc]:
                        spn -= 1
                else:
                    lo, hi = pp, nc
                    while hi - lo > 1:
                        mid = (lo + hi) // 2
                        if t_ < kk[o_ + mid]:
                            hi = mid
                        else:
                            lo = mid
                    spn = lo
                wn[0, 0] = 1.0
                for j in range(1, pp + 1):
                    wl[j] = t_ - kk[o_ + spn + 1 - j]
                    wr[j] = kk[o_ + spn + j] - t_
                    saved = 0.0
                    for rr in range(j):
                        wn[j, rr] = wr[rr + 1] + wl[j - rr]
                        temp = wn[rr, j - 1] / wn[j, rr]
                        wn[rr, j] = saved + wr[rr + 1] * temp
                        saved = wl[j - rr] * temp
                    wn[j, j] = saved
                for j in range(pp + 1):
                    bsb[ax, slot, j] = wn[j, pp]
                bss[ax, slot] = spn
                bsx[ax, slot] = x_
            if ax == 0:
                s_u = slot
            else:
                s_v = slot
        spu, spv = bss[0, s_u], bss[1, s_v]
        for rr in range(pu + 1):
            for dd_ in range(dimw):
                tw[rr, dd_] = 0.0
            for ss in range(pv + 1):
                bb_ = bsb[1, s_v, ss]
                if bb_ != 0.0:
                    row = spu - pu + rr
                    col = spv - pv + ss
                    for dd_ in range(dimw):
                        tw[rr, dd_] += bb_ * pw[row, col, dd_]
        for dd_ in range(dimw):
            acc = 0.0
            for rr in range(pu + 1):
                acc += bsb[0, s_u, rr] * tw[rr, dd_]
            sk[dd_] = acc
        if rational:
            w0 = sk[dimw - 1]
            out[i, 0], out[i, 1], out[i, 2] = sk[0] / w0, sk[1] / w0, sk[2] / w0
        else:
            out[i, 0], out[i, 1], out[i, 2] = sk[0], sk[1], sk[2]
