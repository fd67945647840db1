"""Compiled per-point kernels for tensor-product NURBS evaluation (numba).

The numpy path in `nurbs.py` is batched but moves (n, p+1, q+1, dim) arrays
through memory several times; evaluating with derivatives in one pass per
point is 3-6x faster. Same algorithms: A2.1, A2.3, A3.6, A4.4 of The NURBS Book.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

# before any kernel loads: this module is imported by the kernel modules that call its helpers; the others
# call `_numba_load.install` themselves (geom.nurbs imports this module only on first use)
_install_lazy_bitcode()


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _span(degree, knots, n_ctrl, t):
    if t >= knots[n_ctrl]:
        last = n_ctrl - 1
        while last > degree and knots[last] >= knots[n_ctrl]:
            last -= 1
        return last
    lo, hi = degree, n_ctrl
    while hi - lo > 1:  # knots[lo] <= t < knots[hi]
        mid = (lo + hi) // 2
        if t < knots[mid]:
            hi = mid
        else:
            lo = mid
    return lo


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _ders_basis(span, t, p, knots, nd, ndu, a, left, right, ders):
    ndu[0, 0] = 1.0
    for j in range(1, p + 1):
        left[j] = t - knots[span + 1 - j]
        right[j] = knots[span + j] - t
        saved = 0.0
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    for j in range(p + 1):
        ders[0, j] = ndu[j, p]
    for k in range(1, nd + 1):
        for j in range(p + 1):
            ders[k, j] = 0.0
    top = min(nd, p)
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[0, 0] = 1.0
        for k in range(1, top + 1):
            d = 0.0
            rk, pk = r - k, p - k
            if r >= k:
                a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                d = a[s2, 0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d += a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d += a[s2, k] * ndu[r, pk]
            ders[k, r] = d
            s1, s2 = s2, s1
    factor = p
    for k in range(1, top + 1):
        for j in range(p + 1):
            ders[k, j] *= factor
        factor *= p - k


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _surface_scratch(pu, pv, nd, dimw):
    """Work arrays of `_surface_point` (allocated once per kernel call, not per point)."""
    binom = np.zeros((nd + 1, nd + 1))
    for i in range(nd + 1):
        binom[i, 0] = 1.0
        for j in range(1, i + 1):
            binom[i, j] = binom[i - 1, j - 1] + (binom[i - 1, j] if j < i else 0.0)
    return (np.empty((pu + 1, pu + 1)), np.empty((pv + 1, pv + 1)), np.empty((2, pu + 1)), np.empty((2, pv + 1)),
            np.empty(pu + 1), np.empty(pu + 1), np.empty(pv + 1), np.empty(pv + 1),
            np.empty((nd + 1, pu + 1)), np.empty((nd + 1, pv + 1)), np.empty((nd + 1, pu + 1, dimw)),
            np.empty((nd + 1, nd + 1, dimw)), binom)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _surface_point(pu, pv, ku, kv, pw, rational, u, v, nd, scratch, out, i):
    """out[k, l, i, :] = d^(k+l) S / du^k dv^l at (u, v) (A3.6, A4.4)."""
    ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, binom = scratch
    nu_ctrl, nv_ctrl, dimw = pw.shape
    dim = dimw - 1 if rational else dimw
    su = _span(pu, ku, nu_ctrl, u)
    sv = _span(pv, kv, nv_ctrl, v)
    _ders_basis(su, u, pu, ku, nd, ndu_u, a_u, l_u, r_u, bu)
    _ders_basis(sv, v, pv, kv, nd, ndu_v, a_v, l_v, r_v, bv)
    # contract v: tmp[l, r] = sum_s bv[l, s] P[su - pu + r, sv - pv + s]
    for l in range(nd + 1):
        for r in range(pu + 1):
            for d in range(dimw):
                tmp[l, r, d] = 0.0
            for s in range(pv + 1):
                b = bv[l, s]
                if b != 0.0:
                    row = su - pu + r
                    col = sv - pv + s
                    for d in range(dimw):
                        tmp[l, r, d] += b * pw[row, col, d]
    for k in range(nd + 1):
        for l in range(nd + 1 - k):
            for d in range(dimw):
                acc = 0.0
                for r in range(pu + 1):
                    acc += bu[k, r] * tmp[l, r, d]
                skl[k, l, d] = acc
    if not rational:
        for k in range(nd + 1):
            for l in range(nd + 1 - k):
                for d in range(dim):
                    out[k, l, i, d] = skl[k, l, d]
        return
    w0 = skl[0, 0, dim]
    for k in range(nd + 1):
        for l in range(nd + 1 - k):
            for d in range(dim):
                val = skl[k, l, d]
                for j in range(1, l + 1):
                    val -= binom[l, j] * skl[0, j, dim] * out[k, l - j, i, d]
                for q in range(1, k + 1):
                    val -= binom[k, q] * skl[q, 0, dim] * out[k - q, l, i, d]
                    v2 = 0.0
                    for j in range(1, l + 1):
                        v2 += binom[l, j] * skl[q, j, dim] * out[k - q, l - j, i, d]
                    val -= binom[k, q] * v2
                out[k, l, i, d] = val / w0


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _point_scratch(pu, pv, dimw):
    """Work arrays of `_surface_point01`."""
    return (np.empty((pu + 1, pu + 1)), np.empty((pv + 1, pv + 1)), np.empty((2, pu + 1)), np.empty((2, pv + 1)),
            np.empty(pu + 1), np.empty(pu + 1), np.empty(pv + 1), np.empty(pv + 1),
            np.empty((2, pu + 1)), np.empty((2, pv + 1)), np.empty((2, pu + 1, dimw)), np.empty((3, dimw)))


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _surface_point01(pu, pv, ku, kv, pw, rational, u, v, nd, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv,
                     tmp, skl, res):
    """`_surface_point` for nd = 0 or 1, the same operations in the same order (so the same numbers):
    res[0] = S, res[1] = S_u, res[2] = S_v (the last two with nd = 1)."""
    nu_ctrl, nv_ctrl, dimw = pw.shape
    dim = dimw - 1 if rational else dimw
    su = _span(pu, ku, nu_ctrl, u)
    sv = _span(pv, kv, nv_ctrl, v)
    _ders_basis(su, u, pu, ku, nd, ndu_u, a_u, l_u, r_u, bu)
    _ders_basis(sv, v, pv, kv, nd, ndu_v, a_v, l_v, r_v, bv)
    for l in range(nd + 1):
        for r in range(pu + 1):
            for d in range(dimw):
                tmp[l, r, d] = 0.0
            for s in range(pv + 1):
                b = bv[l, s]
                if b != 0.0:
                    row = su - pu + r
                    col = sv - pv + s
                    for d in range(dimw):
                        tmp[l, r, d] += b * pw[row, col, d]
    # skl rows: 0 = (0, 0), 1 = (1, 0), 2 = (0, 1)
    for d in range(dimw):
        acc = 0.0
        for r in range(pu + 1):
            acc += bu[0, r] * tmp[0, r, d]
        skl[0, d] = acc
    if nd >= 1:
        for d in range(dimw):
            acc = 0.0
            for r in range(pu + 1):
                acc += bu[0, r] * tmp[1, r, d]
            skl[2, d] = acc
            acc = 0.0
            for r in range(pu + 1):
                acc += bu[1, r] * tmp[0, r, d]
            skl[1, d] = acc
    if not rational:
        for d in range(dim):
            res[0, d] = skl[0, d]
            if nd >= 1:
                res[2, d] = skl[2, d]
                res[1, d] = skl[1, d]
        return
    w0 = skl[0, dim]
    for d in range(dim):
        res[0, d] = skl[0, d] / w0
    if nd >= 1:
        for d in range(dim):
            val = skl[2, d]
            val -= 1.0 * skl[2, dim] * res[0, d]
            res[2, d] = val / w0
            val = skl[1, d]
            val -= 1.0 * skl[1, dim] * res[0, d]
            val -= 1.0 * 0.0
            res[1, d] = val / w0


@njit(cache=True, nogil=True)
def surface_derivatives_kernel(pu, pv, ku, kv, pw, rational, u, v, nd, out):
    """out[k, l, i, :] = d^(k+l) S / du^k dv^l at (u[i], v[i]); pw homogeneous if rational."""
    if nd <= 1:
        ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl = _point_scratch(pu, pv, pw.shape[2])
        res = np.empty((3, 3))
        for i in range(u.shape[0]):
            _surface_point01(pu, pv, ku, kv, pw, rational, u[i], v[i], nd, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v,
                             r_v, bu, bv, tmp, skl, res)
            for d in range(3):
                out[0, 0, i, d] = res[0, d]
                if nd == 1:
                    out[1, 0, i, d] = res[1, d]
                    out[0, 1, i, d] = res[2, d]
        return
    scratch = _surface_scratch(pu, pv, nd, pw.shape[2])
    for i in range(u.shape[0]):
        _surface_point(pu, pv, ku, kv, pw, rational, u[i], v[i], nd, scratch, out, i)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _surface_distance1(pu, pv, ku, kv, pw, rational, u, v, x0, x1, x2, steps, u0, u1, v0, v1,
                       ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, res):
    """|S(u, v) - x| and `steps` Gauss-Newton steps of the foot point (clipped to [u0, u1] x [v0, v1]), the
    smallest distance met: `surface_distance_kernel` of one point (scratch from `_point_scratch`, res (3, 3))."""
    b = np.inf
    for it in range(steps + 1):
        uc = min(max(u, u0), u1)
        vc = min(max(v, v0), v1)
        _surface_point01(pu, pv, ku, kv, pw, rational, uc, vc, 1 if it < steps else 0, ndu_u, ndu_v, a_u, a_v,
                         l_u, r_u, l_v, r_v, bu, bv, tmp, skl, res)
        p0, p1, p2 = res[0, 0], res[0, 1], res[0, 2]
        r0, r1, r2 = x0 - p0, x1 - p1, x2 - p2
        dist = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        if it == 0 or dist < b:
            b = dist
        if it == steps:
            break
        su0, su1, su2 = res[1, 0], res[1, 1], res[1, 2]
        sv0, sv1, sv2 = res[2, 0], res[2, 1], res[2, 2]
        a = su0 * su0 + su1 * su1 + su2 * su2
        bb = su0 * sv0 + su1 * sv1 + su2 * sv2
        c = sv0 * sv0 + sv1 * sv1 + sv2 * sv2
        ru = su0 * r0 + su1 * r1 + su2 * r2
        rv = sv0 * r0 + sv1 * r1 + sv2 * r2
        det = a * c - bb * bb
        if np.isfinite(det) and det > 1e-12 * max(a * c, 1e-300):
            u = min(max(u + (c * ru - bb * rv) / det, u0), u1)
            v = min(max(v + (a * rv - bb * ru) / det, v0), v1)
        else:
            u = min(max(u, u0), u1)
            v = min(max(v, v0), v1)
    return b


@njit(cache=True, nogil=True)
def surface_distance_kernel(pu, pv, ku, kv, pw, rational, uv, x, steps, best):
    """`trimsurf.tessellate.face.surface_distance` per point: |S(uv) - x| and `steps` Gauss-Newton
    steps of the foot point (clipped to the domain), the smallest distance met."""
    u0, u1 = ku[pu], ku[ku.shape[0] - pu - 1]
    v0, v1 = kv[pv], kv[kv.shape[0] - pv - 1]
    ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl = _point_scratch(pu, pv, pw.shape[2])
    res = np.empty((3, 3))
    for i in range(uv.shape[0]):
        best[i] = _surface_distance1(pu, pv, ku, kv, pw, rational, uv[i, 0], uv[i, 1], x[i, 0], x[i, 1], x[i, 2],
                                     steps, u0, u1, v0, v1, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv,
                                     tmp, skl, res)


@njit(cache=True, nogil=True)
def basis_functions_kernel(p, knots, spans, t, nd, out):
    """out[k, i, r] = k-th derivative of N_{spans[i]-p+r, p} at t[i] (A2.3 per point)."""
    ndu = np.empty((p + 1, p + 1))
    a = np.empty((2, p + 1))
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    ders = np.empty((nd + 1, p + 1))
    for i in range(t.shape[0]):
        _ders_basis(spans[i], t[i], p, knots, nd, ndu, a, left, right, ders)
        for k in range(nd + 1):
            for r in range(p + 1):
                out[k, i, r] = ders[k, r]


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _moving_basis(p, knots, n_ctrl, t, spans, basis):
    """spans[i, k], basis[i, k, :] of the parameters t[i, k] (A2.1, A2.3 without derivatives)."""
    ndu = np.empty((p + 1, p + 1))
    a = np.empty((2, p + 1))
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    ders = np.empty((1, p + 1))
    for i in range(t.shape[0]):
        for k in range(t.shape[1]):
            s = _span(p, knots, n_ctrl, t[i, k])
            _ders_basis(s, t[i, k], p, knots, np.int64(0), ndu, a, left, right, ders)
            spans[i, k] = s
            for r in range(p + 1):
                basis[i, k, r] = ders[0, r]


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _chord_worst(pts, m, den):
    """Largest distance of the interior samples pts[1:m-1] from the chord pts[0] -> pts[m - 1] (den: the
    chord's squared length), clamped to the chord, summed in numpy's order (the numpy path bit for bit)."""
    a0, a1, a2 = pts[0, 0], pts[0, 1], pts[0, 2]
    ab0, ab1, ab2 = pts[m - 1, 0] - a0, pts[m - 1, 1] - a1, pts[m - 1, 2] - a2
    dd = den if den > 0 else 1.0
    worst = 0.0
    for k in range(1, m - 1):
        q0, q1, q2 = pts[k, 0] - a0, pts[k, 1] - a1, pts[k, 2] - a2
        t = ((q0 * ab0 + q2 * ab2) + q1 * ab1) / dd
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        r0, r1, r2 = q0 - t * ab0, q1 - t * ab1, q2 - t * ab2
        dist = np.sqrt((r0 * r0 + r1 * r1) + r2 * r2)
        if dist > worst or k == 1:
            worst = dist
    return worst


@njit(cache=True, nogil=True)
def iso_line_criteria_kernel(pu, pv, ku, kv, pw, rational, axis, lines, xs, weights, length, deviation):
    """Chord length and chord deviation of intervals on iso-lines of a surface (`interval_criteria`).

    Line l is v = lines[l] (axis 0: the points move in u) or u = lines[l] (axis 1). Interval i is
    sampled at the parameters xs[i, :] (its two ends first and last); only the pairs (i, l) with
    weights[i, l] count (the others are not evaluated). length[i] = the largest chord |S(b) - S(a)|,
    deviation[i] = the largest distance of a sample from its chord (foot clipped to the chord). The
    points are computed exactly as `surface_derivatives_kernel` computes them (same operations in the
    same order), so the result equals the batched numpy path bit for bit.
    """
    nu_ctrl, nv_ctrl, dimw = pw.shape
    dim = dimw - 1 if rational else dimw
    n, m = xs.shape
    n_lines = lines.shape[0]
    # the fixed parameter's basis, once per line
    if axis == 0:
        pf, kf, nf, pm, km, nm = pv, kv, nv_ctrl, pu, ku, nu_ctrl
    else:
        pf, kf, nf, pm, km, nm = pu, ku, nu_ctrl, pv, kv, nv_ctrl
    lspan = np.empty((1, n_lines), dtype=np.int64)
    lbasis = np.empty((1, n_lines, pf + 1))
    _moving_basis(pf, kf, nf, lines.reshape(1, n_lines), lspan, lbasis)
    mspan = np.empty((n, m), dtype=np.int64)
    mbasis = np.empty((n, m, pm + 1))
    _moving_basis(pm, km, nm, xs, mspan, mbasis)
    tmp = np.empty((pu + 1, dimw))
    pts = np.empty((m, 3))
    for i in range(n):
        lmax = 0.0
        dmax = 0.0
        for l in range(n_lines):
            if not weights[i, l]:
                continue
            for k in range(m):
                if axis == 0:
                    su = mspan[i, k]
                    sv = lspan[0, l]
                else:
                    su = lspan[0, l]
                    sv = mspan[i, k]
                for r in range(pu + 1):
                    for d in range(dimw):
                        tmp[r, d] = 0.0
                    for s in range(pv + 1):
                        b = lbasis[0, l, s] if axis == 0 else mbasis[i, k, s]
                        if b != 0.0:
                            row = su - pu + r
                            col = sv - pv + s
                            for d in range(dimw):
                                tmp[r, d] += b * pw[row, col, d]
                for d in range(dimw):
                    acc = 0.0
                    for r in range(pu + 1):
                        bu = mbasis[i, k, r] if axis == 0 else lbasis[0, l, r]
                        acc += bu * tmp[r, d]
                    if d < 3:
                        pts[k, d] = acc
                    else:
                        w0 = acc
                if rational:
                    for d in range(dim):
                        pts[k, d] = pts[k, d] / w0
            a0, a1, a2 = pts[0, 0], pts[0, 1], pts[0, 2]
            ab0, ab1, ab2 = pts[m - 1, 0] - a0, pts[m - 1, 1] - a1, pts[m - 1, 2] - a2
            # sums in numpy's order (einsum pairs lanes 0 and 2; reduce runs left to right), so that
            # the result is the numpy path's bit for bit
            den = (ab0 * ab0 + ab2 * ab2) + ab1 * ab1
            ln = np.sqrt(den)
            if ln > lmax:
                lmax = ln
            worst = _chord_worst(pts, m, den)
            if worst > dmax:
                dmax = worst
        length[i] = lmax
        deviation[i] = dmax


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _curve_point(p, knots, pw, rational, t, ndu, a, left, right, ders, out_row):
    n_ctrl, dimw = pw.shape
    s = _span(p, knots, n_ctrl, t)
    _ders_basis(s, t, p, knots, np.int64(0), ndu, a, left, right, ders)
    dim = dimw - 1 if rational else dimw
    w = 1.0
    if rational:
        w = 0.0
        for r in range(p + 1):
            w += ders[0, r] * pw[s - p + r, dim]
    for d in range(dim):
        acc = 0.0
        for r in range(p + 1):
            acc += ders[0, r] * pw[s - p + r, d]
        out_row[d] = acc / w if rational else acc


@njit(cache=True, nogil=True)
def curve_points_kernel(p, knots, pw, rational, t, out):
    """out[i] = C(t[i]) (A2.1, A2.2, A4.1 per point); pw homogeneous if rational, t clamped."""
    ndu = np.empty((p + 1, p + 1))
    a = np.empty((2, p + 1))
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    ders = np.empty((1, p + 1))
    for i in range(t.shape[0]):
        _curve_point(p, knots, pw, rational, t[i], ndu, a, left, right, ders, out[i])


@njit(cache=True, nogil=True)
def pcurve_surface_kernel(cp, ck, cpw, crat, lo, hi, box, pu, pv, ku, kv, pw, srat, s, with_xyz, out_uv, out_xyz):
    """Points of a p-curve on its surface: t = lo + s (hi - lo), uv = p(t) clipped into
    box = (u0, u1, v0, v1), xyz = S(uv) (with_xyz); out_uv (n, 2), out_xyz (n, 3)."""
    ndu = np.empty((cp + 1, cp + 1))
    a = np.empty((2, cp + 1))
    left = np.empty(cp + 1)
    right = np.empty(cp + 1)
    ders = np.empty((1, cp + 1))
    t0, t1 = ck[cp], ck[ck.shape[0] - cp - 1]
    su0, su1 = ku[pu], ku[ku.shape[0] - pu - 1]
    sv0, sv1 = kv[pv], kv[kv.shape[0] - pv - 1]
    uv = np.empty(2)
    res = np.empty((3, 3))
    ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl = _point_scratch(pu, pv, pw.shape[2])
    for i in range(s.shape[0]):
        t = lo + s[i] * (hi - lo)
        t = min(max(t, t0), t1)
        _curve_point(cp, ck, cpw, crat, t, ndu, a, left, right, ders, uv)
        uu = min(max(uv[0], box[0]), box[1])
        vv = min(max(uv[1], box[2]), box[3])
        out_uv[i, 0] = uu
        out_uv[i, 1] = vv
        if not with_xyz:
            continue
        _surface_point01(pu, pv, ku, kv, pw, srat, min(max(uu, su0), su1), min(max(vv, sv0), sv1), np.int64(0), ndu_u, ndu_v,
                         a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, res)
        for d in range(3):
            out_xyz[i, d] = res[0, d]


@njit(cache=True, nogil=True)
def chord_criteria_kernel(p, weights, length, deviation):
    """`interval_criteria` from sampled points p (n, m, L, 3): the two ends of interval i are
    p[i, 0] and p[i, m - 1]; only lines l with weights[i, l] count."""
    n, m, n_lines, _ = p.shape
    for i in range(n):
        lmax = 0.0
        dmax = 0.0
        for l in range(n_lines):
            if not weights[i, l]:
                continue
            a0, a1, a2 = p[i, 0, l, 0], p[i, 0, l, 1], p[i, 0, l, 2]
            ab0, ab1, ab2 = p[i, m - 1, l, 0] - a0, p[i, m - 1, l, 1] - a1, p[i, m - 1, l, 2] - a2
            den = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
            ln = np.sqrt(den)
            if ln > lmax:
                lmax = ln
            dd = den if den > 0 else 1.0
            for k in range(1, m - 1):
                q0, q1, q2 = p[i, k, l, 0] - a0, p[i, k, l, 1] - a1, p[i, k, l, 2] - a2
                t = (q0 * ab0 + q1 * ab1 + q2 * ab2) / dd
                if t < 0.0:
                    t = 0.0
                elif t > 1.0:
                    t = 1.0
                r0, r1, r2 = q0 - t * ab0, q1 - t * ab1, q2 - t * ab2
                dist = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
                if dist > dmax:
                    dmax = dist
        length[i] = lmax
        deviation[i] = dmax


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _d2_work(pu, pv, dimw):
    """Work arrays of `_eval_d2`, allocated once per kernel call."""
    return (np.empty((pu + 1, pu + 1)), np.empty((pv + 1, pv + 1)), np.empty((2, pu + 1)), np.empty((2, pv + 1)),
            np.empty(pu + 1), np.empty(pu + 1), np.empty(pv + 1), np.empty(pv + 1), np.empty((3, pu + 1)),
            np.empty((3, pv + 1)), np.empty((3, pu + 1, dimw)), np.empty((3, 3, dimw)), np.empty((3, 3, 3)))


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _eval_d2(pu, pv, ku, kv, pw, rational, u, v, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, o,
             S, D1, D2):
    """S (3,), D1 (2, 3), D2 (2, 2, 3) at (u, v) clamped to the domain: `_surface_point` with nd = 2, the
    same operations in the same order (so the same numbers as `nurbs.surface_derivatives`), in one
    function (2-3x faster than through the general one)."""
    u = min(max(u, ku[pu]), ku[ku.shape[0] - pu - 1])
    v = min(max(v, kv[pv]), kv[kv.shape[0] - pv - 1])
    nu_ctrl, nv_ctrl, dimw = pw.shape
    dim = dimw - 1 if rational else dimw
    su = _span(pu, ku, nu_ctrl, u)
    sv = _span(pv, kv, nv_ctrl, v)
    nd = np.int64(2)  # not the literal 2: that would compile `_ders_basis` once more (cold cache)
    _ders_basis(su, u, pu, ku, nd, ndu_u, a_u, l_u, r_u, bu)
    _ders_basis(sv, v, pv, kv, nd, ndu_v, a_v, l_v, r_v, bv)
    for l in range(3):
        for r in range(pu + 1):
            for d in range(dimw):
                tmp[l, r, d] = 0.0
            for s in range(pv + 1):
                b = bv[l, s]
                if b != 0.0:
                    for d in range(dimw):
                        tmp[l, r, d] += b * pw[su - pu + r, sv - pv + s, d]
    for k in range(3):
        for l in range(3 - k):
            for d in range(dimw):
                acc = 0.0
                for r in range(pu + 1):
                    acc += bu[k, r] * tmp[l, r, d]
                skl[k, l, d] = acc
    if rational:
        w0 = skl[0, 0, dim]
        for k in range(3):
            for l in range(3 - k):
                for d in range(dim):
                    val = skl[k, l, d]
                    for j in range(1, l + 1):
                        bl = 2.0 if (l == 2 and j == 1) else 1.0       # binom(l, j)
                        val -= bl * skl[0, j, dim] * o[k, l - j, d]
                    for q in range(1, k + 1):
                        bk = 2.0 if (k == 2 and q == 1) else 1.0
                        val -= bk * skl[q, 0, dim] * o[k - q, l, d]
                        v2 = 0.0
                        for j in range(1, l + 1):
                            bl = 2.0 if (l == 2 and j == 1) else 1.0
                            v2 += bl * skl[q, j, dim] * o[k - q, l - j, d]
                        val -= bk * v2
                    o[k, l, d] = val / w0
    else:
        for k in range(3):
            for l in range(3 - k):
                for d in range(dim):
                    o[k, l, d] = skl[k, l, d]
    for d in range(3):
        S[d] = o[0, 0, d]
        D1[0, d] = o[1, 0, d]
        D1[1, d] = o[0, 1, d]
        D2[0, 0, d] = o[2, 0, d]
        D2[0, 1, d] = o[1, 1, d]
        D2[1, 0, d] = o[1, 1, d]
        D2[1, 1, d] = o[0, 2, d]


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _box(brk, x):
    """(lower, upper, index) of the crease-free interval of `brk` holding x (`projection._boxes`)."""
    nb = brk.shape[0]
    idx = -1
    for j in range(nb):
        if brk[j] <= x:
            idx = j
        else:
            break
    idx = min(max(idx, 0), nb - 2)
    upper = brk[idx + 1]
    if idx + 1 < nb - 1:
        upper = np.nextafter(upper, -np.inf)
    return brk[idx], upper, idx


@njit(cache=True, nogil=True)
def project_newton_kernel(pu, pv, ku, kv, pw, rational, pts, x, S0, D10, D20, lo, hi, brk_u, brk_v, tol, max_iter,
                          crossed0, crossed_up0, barrier, floor, max_halvings, obj_slack, noise,
                          foot, conv, onb, eval_start):
    """`projection._newton` for surfaces (d = 2), point by point: the same box-constrained Newton
    iteration (crease crossing, crease minima, saddle-free step, backtracking, Gauss-Newton after a
    failed line search, final polish). x (m, 2) is updated in place; foot, conv, onb are written.
    The start state is S0, D10, D20 (m, ...) or, with ``eval_start``, `_eval_d2` at x (S0, D10, D20 then
    unused). ``max_iter < 0`` with ``eval_start``: no iteration, S0, D10, D20 (and foot) receive the state at
    x (the seed samples' evaluation, without a kernel of its own to compile). Returns the largest number
    of iterations any point ran."""
    ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl, o = _d2_work(pu, pv, pw.shape[2])
    S = np.empty(3)
    D1 = np.empty((2, 3))
    D2 = np.empty((2, 2, 3))
    nS = np.empty(3)
    nD1 = np.empty((2, 3))
    nD2 = np.empty((2, 2, 3))
    r = np.empty(3)
    g = np.empty(2)
    E = np.empty((2, 2))
    H = np.empty((2, 2))
    blo = np.empty(2)
    bhi = np.empty(2)
    bup = np.empty(2)
    okk = np.empty(2, dtype=np.bool_)
    down = np.empty(2, dtype=np.bool_)
    up = np.empty(2, dtype=np.bool_)
    edge = np.empty(2, dtype=np.bool_)
    crease = np.empty(2, dtype=np.bool_)
    cross = np.empty(2, dtype=np.bool_)
    fixed = np.empty(2, dtype=np.bool_)
    step = np.empty(2)
    trial = np.empty(2)
    crossed = np.empty(2)
    crossed_up = np.empty(2, dtype=np.bool_)
    crossed_x = np.empty(2)
    tiny_f = np.finfo(np.float64).tiny
    it_max = 0
    for i in range(pts.shape[0]):
        # the state at x is evaluated at the loop's top (the start, after a crease crossing): one call site
        # of `_eval_d2` for both (each site is compiled into this kernel again)
        at_x = eval_start
        if not eval_start:
            for d in range(3):
                S[d] = S0[i, d]
                for a in range(2):
                    D1[a, d] = D10[i, a, d]
                    for b in range(2):
                        D2[a, b, d] = D20[i, a, b, d]
        for a in range(2):
            crossed[a] = crossed0[i, a]
            crossed_up[a] = crossed_up0[i, a]
        allnan = np.isnan(crossed[0]) and np.isnan(crossed[1])
        for a in range(2):
            crossed_x[a] = x[i, a] if (barrier and not allnan) else np.nan
        gn = False
        conv[i] = False
        onb[i] = False
        finished = False
        it = 0
        while True:
            if at_x:
                _eval_d2(pu, pv, ku, kv, pw, rational, x[i, 0], x[i, 1], ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v,
                         r_v, bu, bv, tmp, skl, o, S, D1, D2)
                at_x = False
            if it >= max_iter:
                break
            it += 1
            for d in range(3):
                r[d] = S[d] - pts[i, d]
            for a in range(2):
                g[a] = D1[a, 0] * r[0] + D1[a, 1] * r[1] + D1[a, 2] * r[2]
                for b in range(2):
                    E[a, b] = D1[a, 0] * D1[b, 0] + D1[a, 1] * D1[b, 1] + D1[a, 2] * D1[b, 2]
            for a in range(2):
                sp = np.sqrt(E[a, a])
                okk[a] = (abs(g[a]) / sp if sp > 0 else 0.0) <= tol
                brk = brk_u if a == 0 else brk_v
                bl, bh, bi = _box(brk, x[i, a])
                blo[a] = bl
                bhi[a] = bh
                bup[a] = brk[bi + 1]
                down[a] = (x[i, a] <= bl) and (g[a] > 0) and not okk[a]
                up[a] = (x[i, a] >= bh) and (g[a] < 0) and not okk[a]
                edge[a] = (down[a] and bl <= lo[a]) or (up[a] and bh >= hi[a])
            still = x[i, 0] == crossed_x[0] and x[i, 1] == crossed_x[1]
            anycross = False
            for a in range(2):
                crease[a] = still and ((down[a] and not edge[a] and crossed_up[a] and crossed[a] == blo[a])
                                       or (up[a] and not edge[a] and not crossed_up[a] and crossed[a] == bup[a]))
                cross[a] = (down[a] or up[a]) and not edge[a] and not crease[a]
                anycross = anycross or cross[a]
            if anycross:
                for a in range(2):
                    if cross[a]:
                        if up[a]:
                            x[i, a] = bup[a]
                            crossed[a] = bup[a]
                            crossed_up[a] = True
                        else:
                            x[i, a] = np.nextafter(blo[a], -np.inf)
                            crossed[a] = blo[a]
                            crossed_up[a] = False
                crossed_x[0] = x[i, 0]
                crossed_x[1] = x[i, 1]
                gn = False
                at_x = True
                continue
            done = True
            for a in range(2):
                fixed[a] = edge[a] or crease[a]
                done = done and (fixed[a] or okk[a])
            for a in range(2):
                for b in range(2):
                    H[a, b] = E[a, b] + (D2[a, b, 0] * r[0] + D2[a, b, 1] * r[1] + D2[a, b, 2] * r[2])
            # `projection._step_matrix`
            use = not gn
            tiny = 1e-30 * (E[0, 0] + E[1, 1]) + tiny_f
            sc0 = np.sqrt(max(E[0, 0], tiny))
            sc1 = np.sqrt(max(E[1, 1], tiny))
            M = H if use else E
            ma = M[0, 0] / (sc0 * sc0)
            mb = M[0, 1] / (sc0 * sc1)
            mc = M[1, 1] / (sc1 * sc1)
            gs0 = 0.0 if fixed[0] else g[0] / sc0
            gs1 = 0.0 if fixed[1] else g[1] / sc1
            if fixed[0]:
                ma = 1.0
                mb = 0.0
            if fixed[1]:
                mc = 1.0
                mb = 0.0
            lam = 0.5 * (ma + mc) - np.sqrt(0.25 * (ma - mc) ** 2 + mb * mb)
            shift = max(-2.0 * lam, floor) if lam < floor else 0.0
            ma += shift
            mc += shift
            det = ma * mc - mb * mb
            step[0] = (-mc * gs0 + mb * gs1) / det / sc0
            step[1] = (mb * gs0 - ma * gs1) / det / sc1
            plain = use and shift == 0
            if done:
                for d in range(3):
                    foot[i, d] = S[d]
                if plain:
                    n0 = min(max(x[i, 0] + step[0], blo[0]), bhi[0])
                    n1 = min(max(x[i, 1] + step[1], blo[1]), bhi[1])
                    mv0 = (n0 - x[i, 0]) * D1[0, 0] + (n1 - x[i, 1]) * D1[1, 0]
                    mv1 = (n0 - x[i, 0]) * D1[0, 1] + (n1 - x[i, 1]) * D1[1, 1]
                    mv2 = (n0 - x[i, 0]) * D1[0, 2] + (n1 - x[i, 1]) * D1[1, 2]
                    if np.sqrt(mv0 * mv0 + mv1 * mv1 + mv2 * mv2) <= 10.0 * tol:
                        x[i, 0] = n0
                        x[i, 1] = n1
                        foot[i, 0] = S[0] + mv0
                        foot[i, 1] = S[1] + mv1
                        foot[i, 2] = S[2] + mv2
                conv[i] = True
                onb[i] = edge[0] or edge[1]
                finished = True
                break
            obj = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
            limit = obj * (1.0 + obj_slack) + 2.0 * np.sqrt(obj) * noise + noise * noise
            bad = True
            halvings = 0
            while True:
                for a in range(2):
                    trial[a] = min(max(x[i, a] + step[a], blo[a]), bhi[a])
                _eval_d2(pu, pv, ku, kv, pw, rational, trial[0], trial[1], ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v,
                         r_v, bu, bv, tmp, skl, o, nS, nD1, nD2)
                q0 = nS[0] - pts[i, 0]
                q1 = nS[1] - pts[i, 1]
                q2 = nS[2] - pts[i, 2]
                bad = q0 * q0 + q1 * q1 + q2 * q2 > limit
                if not bad or halvings >= max_halvings:
                    break
                halvings += 1
                step[0] *= 0.5
                step[1] *= 0.5
            stuck = bad and gn
            gn = bad
            if not bad:
                x[i, 0] = trial[0]
                x[i, 1] = trial[1]
                for d in range(3):
                    S[d] = nS[d]
                    for a in range(2):
                        D1[a, d] = nD1[a, d]
                        for b in range(2):
                            D2[a, b, d] = nD2[a, b, d]
            if stuck:
                for d in range(3):
                    foot[i, d] = S[d]
                finished = True
                break
        if not finished:
            for d in range(3):
                foot[i, d] = S[d]
        if max_iter < 0:
            for d in range(3):
                S0[i, d] = S[d]
                for a in range(2):
                    D10[i, a, d] = D1[a, d]
                    for b in range(2):
                        D20[i, a, b, d] = D2[a, b, d]
        it_max = max(it_max, it)
    return it_max
